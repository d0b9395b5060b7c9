// duolod render: a headless OpenGL 4.5 core context (EGL; Mesa llvmpipe by default), programs from
// GLSL or SPIR-V, uploaded assets, and batched rendering of the paper's view × light domain (§7)
// into an atlas read back once. Supersampled references (f̄, eq. 1) are box-filtered on the GPU.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::render {

// ---------------------------------------------------------------------------------------------
// The domain (§7): cameras on the vertices of a dodecahedron around the object, 5 point lights per
// camera at the ends (and centre) of a cross on the plane through the camera orthogonal to the
// view direction.

enum class ViewSet {
  kDodecahedron,  // 20 views: the paper's training domain
  kIcosahedron,   // 12 views: a held-out domain sharing no direction with the dodecahedron
};

struct DomainOptions {
  ViewSet views = ViewSet::kDodecahedron;
  // Cross arm length as a fraction of the camera distance: lights sit up to atan(0.5) ≈ 27° off
  // the view axis, so every light reaches what the camera sees.
  float light_cross_arm = 0.5f;
  bool light_cross_center = true;  // 5 lights (centre + 4 ends) rather than 4
  float light_rotation_deg = 0;    // rotates the cross about the view axis (held-out lights)
};

// The display the LOD is made for: vertical field of view and screen height in pixels fix how many
// pixels an object covers at a distance.
struct Display {
  float fov_y_deg = 45.0f;
  int height_px = 1080;
};

// One camera × light configuration.
struct Sample {
  int view_index = 0;
  int light_index = 0;
  core::Vec3 eye;    // world space
  core::Vec3 light;  // world space
  core::Mat4 view;
  core::Mat4 projection;
};

std::vector<core::Vec3> viewDirections(ViewSet views);

// Pixels across the object's bounding sphere when seen from `distance` on `display`: the side of
// the square footprint images are rendered at. At least 1. Distances inside the sphere are clamped
// to just outside it.
int footprintPixels(const core::Sphere& bounds, float distance, const Display& display);

// Cameras at `distance` from the sphere centre, each framing exactly the bounding sphere (the
// image is the footprint's crop of the display), with its lights. View-major order:
// sample = view * lights_per_view + light.
std::vector<Sample> domainSamples(const core::Sphere& bounds, float distance,
                                  const DomainOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Rendered images: `count` tiles of width × height, each contiguous, rows top first, RGBA.

template <class T>
struct TiledImages {
  int width = 0, height = 0, count = 0;
  std::vector<T> pixels;  // count * height * width * 4
  const T* tile(int i) const { return pixels.data() + size_t(i) * width * height * 4; }
  T* tile(int i) { return pixels.data() + size_t(i) * width * height * 4; }
};
using ImageBatch8 = TiledImages<uint8_t>;  // what the display shows
using ImageBatchF = TiledImages<float>;    // supersampled references, in [0,1]

core::ImageRGBA8 tileImage(const ImageBatch8& batch, int index);
core::ImageRGBA8 tileImage(const ImageBatchF& batch, int index);
// All tiles in a grid (`columns` per row), with a 1-pixel gap.
core::ImageRGBA8 contactSheet(const ImageBatch8& batch, int columns);

// ---------------------------------------------------------------------------------------------
// Shader inputs. The default is shaders/INTERFACE.md; a bindings file can move things around.

struct Bindings {
  // Vertex attribute location per stream; -1 = the shader does not read it.
  int position = 0, normal = 1, tangent = 2, uv0 = 3, uv1 = 4, color = 5;
  int frame_block = 0, material_block = 1;  // std140 uniform block bindings
  // Texture unit per material texture; -1 = not bound.
  int base_color = 0, metallic_roughness = 1, normal_map = 2, occlusion = 3, emissive = 4;
};
// Parses a bindings JSON file ({"attributes": {"position": 0, ...}, "blocks": {"frame": 0,
// "material": 1}, "textures": {"baseColor": 0, ...}}); unknown keys are errors naming the key.
core::Result<Bindings> parseBindings(const std::string& json_text, const std::string& file_name);

struct GlslSource {
  std::string vertex, fragment;
  std::string vertex_name = "vertex", fragment_name = "fragment";  // for messages
};
struct SpirvBinary {
  std::vector<uint32_t> vertex, fragment;
};

// Loads NAME.vert and NAME.frag from duolod's shaders/ folder (or a path prefix).
core::Result<GlslSource> loadShaderPair(const std::string& name_or_prefix);
std::string shaderDirectory();

// ---------------------------------------------------------------------------------------------

struct ContextOptions {
  // -1: Mesa's surfaceless platform (llvmpipe on a machine without a GPU). N >= 0: the Nth EGL
  // device from EGL_EXT_device_enumeration (a real GPU where one exists).
  int device = -1;
};

struct RenderOptions {
  int resolution = 128;   // tile side in pixels (the footprint)
  int supersample = 1;    // k: render at k×resolution and box-filter k×k (the reference f̄)
  int msaa_samples = 0;   // 0 = off
};

struct RenderStats {
  double seconds = 0;  // wall clock including glFinish and readback
  int draws = 0;
  int chunks = 0;  // atlas passes needed
};

class Renderer {
 public:
  static core::Result<std::unique_ptr<Renderer>> create(const ContextOptions& options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  std::string deviceDescription() const;  // GL_RENDERER, GL_VERSION

  // Handles to GPU objects owned by the Renderer.
  using AssetId = int;
  using ProgramId = int;

  core::Result<AssetId> uploadAsset(const core::Asset& asset);
  // Another mesh with the materials and textures of an uploaded asset (textures are shared, not
  // copied): for the many meshes of one asset an optimizer renders.
  core::Result<AssetId> uploadMesh(AssetId materials_from, const core::Mesh& mesh);
  void releaseAsset(AssetId asset);
  core::Result<ProgramId> compileProgram(const GlslSource& source);
  core::Result<ProgramId> compileProgram(const SpirvBinary& binary);
  void releaseProgram(ProgramId program);

  void setBindings(const Bindings& bindings);
  void setAmbient(core::Vec3 ambient_color);
  void setLightColor(core::Vec3 light_color);

  // Renders every sample into its own tile and reads all of them back in one go (per atlas chunk).
  core::Result<ImageBatch8> render(AssetId asset, ProgramId program,
                                   std::span<const Sample> samples, const RenderOptions& options,
                                   RenderStats* stats = nullptr);
  // The same, box-filtered from options.supersample× into float tiles: f̄ of eq. (1).
  core::Result<ImageBatchF> renderReference(AssetId asset, ProgramId program,
                                            std::span<const Sample> samples,
                                            const RenderOptions& options,
                                            RenderStats* stats = nullptr);

  // ---- Local re-rendering, for image-driven simplification (§4.2, Lindstrom & Turk 2000) ----
  // A collapse changes only a few pixels of each view. Each tile is a small screen region of one
  // view; the soup holds the triangles to draw there (the region's neighbourhood with the change
  // applied). All tiles of a view are drawn for each of its lights in one draw per material.

  // The program for renderRegions(): the user's vertex stage wrapped so that each vertex is moved
  // into its tile of the atlas and clipped to it (GLSL source only).
  core::Result<ProgramId> compileRegionProgram(const GlslSource& source);

  struct RegionTile {
    int view_index = 0;  // which view's camera (samples are view-major)
    int x0 = 0, y0 = 0;  // top-left pixel of the region in the view's image (rows top first)
    // The region's size; drawing is clipped to it, so no fragment outside it is shaded. 0 = the
    // whole tile.
    int width = 0, height = 0;
  };
  struct RegionSoup {
    core::Mesh triangles;  // non-indexed: 3 consecutive vertices per triangle; attribute streams
    std::vector<uint32_t> triangle_tile;      // tile index of each triangle
    std::vector<uint32_t> triangle_material;  // material index of each triangle
    std::vector<RegionTile> tiles;
  };
  // Output tile for (tile t, light l) is t * lights_per_view + l, each tile_size² pixels. `samples`
  // are the full view-major domain (view v's lights at v*lights_per_view ...). The footprint
  // `view_resolution` must be the one the samples were framed for.
  core::Result<ImageBatch8> renderRegions(AssetId asset, ProgramId region_program,
                                          const RegionSoup& soup, std::span<const Sample> samples,
                                          int lights_per_view, int view_resolution, int tile_size,
                                          RenderStats* stats = nullptr);

  struct State;  // implementation detail (renderer.cpp)

 private:
  Renderer();
  std::unique_ptr<State> state_;
};

}  // namespace duolod::render
