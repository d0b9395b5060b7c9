// duolod render: a headless OpenGL 4.5 core context (EGL; Mesa llvmpipe by default), programs from
// GLSL or SPIR-V, uploaded assets, and batched rendering of the paper's view × light domain (§7)
// into an atlas read back once. Supersampled references (f̄, eq. 1) are box-filtered on the GPU.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
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
  // For objects that stand upright (+Y up) and are seen by a viewer walking among them, as props
  // on the ground are: 20 views in four rings at −10°, 5°, 20° and 35° of elevation, 5 azimuths
  // each (the rings staggered by 18°). The sphere's views include the top and the underside
  // (4 of 20 within 21° of a pole), which such objects never show.
  kUpright,
  // 12 held-out views of the same band, sharing no direction with kUpright: four rings at −2.5°,
  // 12.5°, 27.5° and 42.5°, 3 azimuths each.
  kUprightHeldOut,
};
// The held-out counterpart of a training view set (kDodecahedron → kIcosahedron, kUpright →
// kUprightHeldOut); a held-out set is its own.
ViewSet heldOutViews(ViewSet training);

struct DomainOptions {
  ViewSet views = ViewSet::kDodecahedron;
  // Each sample's object pose in the world (Sample::placement): turned about a varying axis,
  // scaled by 0.5–2, and moved 0.75–1.25 × this many camera distances from the origin. false
  // keeps every sample's object at the origin as it is (the identity).
  bool place_objects = true;
  float placement_distance = 1.5f;
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

// The largest coordinate (asset, camera, light or placement, in asset units) a render accepts:
// the shaders square distances in 32-bit floats, which overflow above ~1.8e19. Larger requests
// fail with a message instead of an empty image.
constexpr float kLargestRenderableCoordinate = 4e18f;
// The smallest bounding-sphere radius a render accepts: the same squares vanish below ~1e-19 (a
// sphere 1e-20 across still rendered right with pbr, one 3e-21 across came out wrong, 1e-30
// blank). Smaller assets fail with a message instead.
constexpr float kSmallestRenderableRadius = 1e-18f;

// One camera × light configuration.
struct Sample {
  int view_index = 0;
  int light_index = 0;
  core::Vec3 eye;    // relative to the object (its coordinates with the object at the origin)
  core::Vec3 light;  // likewise
  core::Mat4 view;   // likewise
  core::Mat4 projection;
  // The object's pose in the world for this sample (object -> world: a rotation, a uniform scale
  // and a translation). The shaders get it as the model matrix, with the eye, light and view
  // moved along, so the image is the same as with the identity (up to float rounding), but a
  // simplified shader that only holds for an object at the origin as modelled errs: e.g.
  // normalize(light − position) reduced to normalize(light), or the normal matrix dropped from
  // the normal's transform. Engines draw objects anywhere, turned and scaled. Everything on the
  // CPU side (eye, light, view above) stays relative to the object as modelled.
  core::Mat4 placement = core::Mat4::identity();
};

std::vector<core::Vec3> viewDirections(ViewSet views);

// The largest tile side (footprint × supersampling) a render takes: OpenGL 4.5's guaranteed
// minimum texture and viewport size, so that the same request works on every device.
inline constexpr int kMaxTileSize = 16384;

// Pixels across the object's bounding sphere when seen from `distance` on `display`: the side of
// the square footprint images are rendered at. At least 1, at most kMaxTileSize. Distances inside
// the sphere are clamped to just outside it.
int footprintPixels(const core::Sphere& bounds, float distance, const Display& display);
// The same before rounding up: the bounding sphere's projected diameter in (fractional) pixels.
// What screen coverage is computed from (lod::screenCoverage), so that coverage and distance
// give the same switch.
double projectedDiameterPixels(const core::Sphere& bounds, float distance, const Display& display);
// The camera distance at which the bounding sphere's projected diameter is `pixels` on `display`
// (the inverse of projectedDiameterPixels): what a `--pixels N` flag means.
float distanceForDiameterPixels(const core::Sphere& bounds, int pixels, const Display& display);
// The nearest distance (to float precision, by bisection) at which footprintPixels is at most
// `pixels`: where `generate --near-pixels` / `--far-pixels` put d_near and d_far, and `error`'s
// defaults, so that both bound the same distances.
float distanceForFootprint(const core::Sphere& bounds, int pixels, const Display& display);

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
// The RGBA8 texel bound in place of a texture the material lacks (INTERFACE.md): white, and for
// the normal map a flat tangent-space normal. Shader rules read the same values as those
// textures' average colour, so a sample of a missing texture folds to the constant it returns.
inline constexpr std::array<uint8_t, 4> kMissingTextureTexel = {255, 255, 255, 255};
inline constexpr std::array<uint8_t, 4> kMissingNormalTexel = {128, 128, 255, 255};

// Parses a bindings JSON file ({"attributes": {"position": 0, ...}, "blocks": {"frame": 0,
// "material": 1}, "textures": {"baseColor": 0, ...}}); unknown keys are errors naming the key.
core::Result<Bindings> parseBindings(const std::string& json_text, const std::string& file_name);
// The locations of an HLSL vertex shader's inputs by semantic (shader::CompileOptions::
// vertex_input_locations) for these bindings: POSITION0, NORMAL0, TANGENT0, TEXCOORD0 (uv0),
// TEXCOORD1 (uv1) and COLOR0, each where its stream is bound; streams bound nowhere are left out.
std::map<std::string, uint32_t> hlslVertexInputLocations(const Bindings& bindings = {});

struct GlslSource {
  std::string vertex, fragment;
  std::string vertex_name = "vertex", fragment_name = "fragment";  // for messages
};
struct SpirvBinary {
  std::vector<uint32_t> vertex, fragment;
};

// Loads NAME.vert and NAME.frag: a bare NAME from duolod's shaders/ folder (shaderDirectory),
// else from the working folder; a path prefix ("dir/name", "./name") as it is.
core::Result<GlslSource> loadShaderPair(const std::string& name_or_prefix);
// duolod's shaders/ folder: the environment variable DUOLOD_SHADER_DIR when set, else the source
// share/duolod/shaders beside the running program's bin/ folder when it exists (an installed
// program, whatever --prefix it was installed with), else the source tree the library was built
// from while it exists, else the configured install prefix's share/duolod/shaders.
std::string shaderDirectory();

// ---------------------------------------------------------------------------------------------

class SharedTextures;

struct ContextOptions {
  // -1: Mesa's surfaceless platform (llvmpipe on a machine without a GPU). N >= 0: the Nth EGL
  // device from EGL_EXT_device_enumeration (a real GPU where one exists).
  int device = -1;
  // Contexts that draw renderRegions() (image-driven simplification): 2 splits each call's views
  // between this context and a second one on a thread of its own, which shares its objects; 1
  // draws in this context only. 0 chooses: 2 on a CPU rasterizer (llvmpipe) with two or more
  // hardware threads, else 1. The images are the same either way.
  int drawing_threads = 0;
  // The shader interface's locations and bindings (setBindings) from the start, so that every
  // context a task makes (its own, and those of its worker threads) feeds the shader alike.
  Bindings bindings = {};
  // Another renderer's textures (SharedTextures): this context shares that renderer's objects
  // (on its device, not `device`), and its uploadAsset() of an asset with the same textures draws
  // those instead of uploading its own.
  std::shared_ptr<const SharedTextures> textures = nullptr;
};

// An uploaded asset's textures, drawn by renderers on other threads (generate's and `duolod
// shader`'s compile-ahead workers) without copies of their own: on llvmpipe a texture is system
// memory (a 2048² one with its mipmaps is 21 MB) and each worker's context held a copy of every
// texture. Made by Renderer::shareTextures; a renderer created with ContextOptions::textures shares
// the objects of the renderer that made it. Drawing shared textures is slower on llvmpipe (Mesa
// 22.3: 1.1-1.5x the time of a render, bench_throughput --shared-textures), so they are for
// renderers that draw little. The textures stay while any renderer or handle holds them and the
// making renderer's context or another that shares them exists.
class SharedTextures {
 public:
  ~SharedTextures();
  SharedTextures(const SharedTextures&) = delete;
  SharedTextures& operator=(const SharedTextures&) = delete;

  // Whether `asset`'s textures are these: the same count and, each, size, colour space and
  // pixels (core::fingerprintImage).
  bool matches(const core::Asset& asset) const;
  size_t textureBytes() const;  // the texels' bytes with their mipmaps

  struct Impl;

 private:
  SharedTextures();
  std::unique_ptr<Impl> impl_;
  friend class Renderer;
};

struct RenderOptions {
  int resolution = 128;   // tile side in pixels (the footprint)
  int supersample = 1;    // k: render at k×resolution and box-filter k×k (the reference f̄)
  int msaa_samples = 0;   // 0 = off
  // Count the work of the object's draws into RenderStats::work (ARB_pipeline_statistics_query).
  // Fails with an error on a device without the extension.
  bool count_work = false;
};

// Work the device did for the object's draws, from ARB_pipeline_statistics_query (core in GL 4.6).
// Unlike time it is deterministic for a device and input, so tests and the cost model (§5.2: the
// paper's extension of He et al. with vertex and pixel counts) use it. For renderReference() the
// counts are those of the k×-sized render; the box filter's own pass is not counted.
// On Mesa llvmpipe (measured, tests/render_counters_test.cpp): each distinct indexed vertex of a draw
// is shaded once (a quad of 6 indices counts 4), and fragments are shaded in whole 4×4-pixel blocks:
// a triangle adds 16 for every block it touches, so edges and shared diagonals count extra.
struct WorkCounts {
  uint64_t vertex_invocations = 0;          // GL_VERTEX_SHADER_INVOCATIONS
  uint64_t fragment_invocations = 0;        // GL_FRAGMENT_SHADER_INVOCATIONS
  uint64_t primitives_submitted = 0;        // GL_PRIMITIVES_SUBMITTED
  uint64_t clipping_input_primitives = 0;   // GL_CLIPPING_INPUT_PRIMITIVES (after culling stages)
  uint64_t clipping_output_primitives = 0;  // GL_CLIPPING_OUTPUT_PRIMITIVES
  WorkCounts& operator+=(const WorkCounts& other) {
    vertex_invocations += other.vertex_invocations;
    fragment_invocations += other.fragment_invocations;
    primitives_submitted += other.primitives_submitted;
    clipping_input_primitives += other.clipping_input_primitives;
    clipping_output_primitives += other.clipping_output_primitives;
    return *this;
  }
};

struct RenderStats {
  double seconds = 0;  // wall clock including glFinish and readback
  int draws = 0;
  int chunks = 0;  // atlas passes needed
  WorkCounts work;  // filled when RenderOptions::count_work is set
};

// A plain uniform of a program, set by the CPU: how "moving to parameter" (He et al. 2015) hands a
// value averaged over the domain to a simplified shader. Programs from SPIR-V have no names to look
// up (ARB_gl_spirv), so the uniform is addressed by its explicit `layout(location = N)`.
struct UniformValue {
  int location = -1;
  int components = 1;  // float, vec2, vec3 or vec4
  std::array<float, 4> value{};
};

// Draw-cost timing on the wall clock (DESIGN.md, "Measuring cost": llvmpipe's GL_TIME_ELAPSED is
// wrong, so it is never used). Protocol: the samples are drawn at the footprint into one atlas
// (one tile per sample, no readback), a "pass" being a clear plus one draw of the object per
// sample. Each program is warmed up (llvmpipe compiles shader variants at the first draw), then
// the number of passes per repeat is calibrated so that a repeat lasts at least
// `min_repeat_seconds`; the repeats alternate between the programs and a clear-only baseline
// (A B C base A B C base ...) so slow drift hits all of them alike; each repeat ends in glFinish.
struct TimingOptions {
  int resolution = 128;              // tile side: the footprint s_d the samples were framed for
  int repeats = 7;                   // timed repeats per program; the median is reported
  double min_repeat_seconds = 0.03;  // calibrates passes per repeat (timer noise ≪ a repeat)
  int max_passes_per_repeat = 1000;
};
struct DrawTime {
  // Median over repeats of one pass's time minus the clear-only baseline's median (>= 0): the
  // object's draw cost over all samples. Divide by the sample count for one view.
  double seconds = 0;
  double pass_seconds = 0;   // median raw time of one pass (clear + draws, up to glFinish)
  double clear_seconds = 0;  // median time of a clear-only pass
  double spread = 0;         // (max − min) / median of the per-pass times over the repeats
  int passes_per_repeat = 0;
  int repeats = 0;
};

// ---------------------------------------------------------------------------------------------
// Scenes: many placed instances of uploaded assets seen by one camera (the walk-through benchmark,
// Liang et al. §7.2.2). Ids are Renderer::AssetId / ProgramId.

struct SceneCamera {
  core::Mat4 view, projection;
  core::Vec3 eye;    // world space
  core::Vec3 light;  // world-space point light (INTERFACE.md: no falloff)
  int width = 1280, height = 720;
  core::Vec3 clear_color{0, 0, 0};  // cleared with alpha 0
};
// Instances of one asset drawn with one program, in order: a batch binds the program, vertex
// arrays and materials once, then each instance only moves the Frame block's range (uModel).
struct InstanceBatch {
  int asset = -1;
  int program = -1;
  std::vector<core::Mat4> models;  // object -> world, one per instance
};
struct SceneOptions {
  bool read_back = false;   // fill SceneFrame::image
  bool count_work = false;  // fill SceneFrame::work (ARB_pipeline_statistics_query)
  // Also fill SceneFrame::batch_work (needs count_work). Waits for the counters after every
  // batch, so frames counted this way are not for timing.
  bool count_work_per_batch = false;
};
struct SceneFrame {
  double seconds = 0;  // wall clock from the clear to glFinish (excludes the readback)
  int draws = 0;
  WorkCounts work;
  std::vector<WorkCounts> batch_work;  // per batch, with SceneOptions::count_work_per_batch
  core::ImageRGBA8 image;  // width x height when read back, top row first
};

class Renderer {
 public:
  static core::Result<std::unique_ptr<Renderer>> create(const ContextOptions& options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  std::string deviceDescription() const;  // GL_RENDERER, GL_VERSION
  // Whether RenderOptions::count_work is available (ARB_pipeline_statistics_query or GL 4.6).
  bool canCountWork() const;

  // Handles to GPU objects owned by the Renderer.
  using AssetId = int;
  using ProgramId = int;

  core::Result<AssetId> uploadAsset(const core::Asset& asset);
  // Another mesh with the materials and textures of an uploaded asset (textures are shared, not
  // copied): for the many meshes of one asset an optimizer renders. It keeps that asset's
  // bounding sphere (the shaders' uObjectInfo): a simplification is the same object.
  core::Result<AssetId> uploadMesh(AssetId materials_from, const core::Mesh& mesh);
  // A handle to an uploaded asset's textures for renderers on other threads (SharedTextures).
  core::Result<std::shared_ptr<const SharedTextures>> shareTextures(AssetId asset) const;
  // The texture bytes (with mipmaps) uploadAsset() has copied into this context so far: shared
  // textures (ContextOptions::textures) add nothing.
  size_t uploadedTextureBytes() const;
  void releaseAsset(AssetId asset);
  core::Result<ProgramId> compileProgram(const GlslSource& source);
  core::Result<ProgramId> compileProgram(const SpirvBinary& binary);
  void releaseProgram(ProgramId program);

  // Sets plain uniforms of a program (program state: it persists across renders until set again).
  core::Status setProgramUniforms(ProgramId program, std::span<const UniformValue> values);
  // An extra std140 uniform block (e.g. the parameters a simplified shader reads), bound at
  // `binding` for every later draw; the frame and material blocks keep their bindings. Empty bytes
  // unbind it.
  core::Status setParameterBlock(int binding, std::span<const uint8_t> bytes);

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

  // Wall-clock draw cost of each program over the samples (TimingOptions describes the protocol).
  // Times are only comparable within one call: compare programs as ratios of one measurement.
  core::Result<std::vector<DrawTime>> measureDrawTimes(AssetId asset,
                                                       std::span<const ProgramId> programs,
                                                       std::span<const Sample> samples,
                                                       const TimingOptions& options = {});
  core::Result<DrawTime> measureDrawTime(AssetId asset, ProgramId program,
                                         std::span<const Sample> samples,
                                         const TimingOptions& options = {});

  // Draws the batches into a camera.width x camera.height target (depth-tested, back faces
  // culled) and waits for the frame with glFinish.
  core::Result<SceneFrame> renderScene(std::span<const InstanceBatch> batches,
                                       const SceneCamera& camera, const SceneOptions& options = {});

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

// ---------------------------------------------------------------------------------------------
// Requests that keep the device busy for long. On llvmpipe the first draw with a program includes
// LLVM's compile of it, and for some shaders that takes minutes: with a fragment stage of
// sequential loops whose trip counts are not constants, a one-image render run took 0.9 s with 8
// such loops, 1.8 s with 12, 8 s with 14 and 77 s with 16 (LLVM's scalar evolution;
// bench/RESULTS.md, session 38). A process
// that says why it waits is better than one that looks hung, so a sink set here is told about
// every renderer request still running `first_after_seconds` after it began, and again each time
// its time doubles. The sink runs on a monitor thread of its own.
struct SlowRequest {
  std::string what;         // e.g. "rendering 100 images of 64 px with constant.vert + loops.frag"
  double seconds = 0;       // since the request began
  bool first_draw = false;  // the request holds the program's first draw of its kind (a compile)
  int report = 0;           // 0 for the first report of this request, then 1, 2, ...
};
// An empty sink (the default) turns the reports off. first_after_seconds must be > 0. Once this
// returns, the sink it replaced is not running and will not run again; a sink must not call it.
void setSlowRequestSink(double first_after_seconds, std::function<void(const SlowRequest&)> sink);

}  // namespace duolod::render
