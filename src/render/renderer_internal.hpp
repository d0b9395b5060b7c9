// Internals shared by the renderer's passes (renderer.cpp: whole-view batches and references;
// region_renderer.cpp: local re-rendering). Not part of the public API.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "duolod/render.hpp"
#include "render/gl_context.hpp"
#include "render/slow_requests.hpp"

namespace duolod::render {
namespace internal {

// std140 layouts of shaders/INTERFACE.md.
struct FrameBlock {
  float model[16];
  float view[16];
  float projection[16];
  float normal_matrix[16];
  float camera_position[4];
  float light_position[4];
  float light_color[4];
  float ambient_color[4];
  float object_info[4];
};
struct MaterialBlock {
  float base_color_factor[4];
  float emissive_factor[4];
  float material_params[4];
  float texture_flags[4];
  float texture_flags2[4];
};

// Deletes its textures with the last asset that uses them, when that happens in the context that
// made them. Elsewhere (a renderer sharing them, SharedTextures, released last on another thread)
// the names could be another context's objects: left to the share group, which frees its
// objects when its last context goes.
struct TextureSet {
  std::vector<GLuint> ids;
  EGLContext owner = eglGetCurrentContext();
  // What each texture was made from, so that a renderer sharing them (SharedTextures) uses them
  // only for the same images.
  struct Signature {
    int width = 0, height = 0;
    bool srgb = false;
    uint64_t fingerprint = 0;  // core::fingerprintImage
  };
  std::vector<Signature> signatures;
  size_t bytes = 0;  // the texels with their mipmaps
  TextureSet() = default;
  TextureSet(const TextureSet&) = delete;
  TextureSet& operator=(const TextureSet&) = delete;
  ~TextureSet() {
    if (!ids.empty() && owner != EGL_NO_CONTEXT && eglGetCurrentContext() == owner)
      glDeleteTextures(static_cast<GLsizei>(ids.size()), ids.data());
  }
};

struct GpuSubmesh {
  GLsizei index_count = 0;
  size_t first_index = 0;
  uint32_t material = 0;
};

struct GpuAsset {
  GLuint vao = 0;
  std::vector<GLuint> buffers;
  GLuint material_ubo = 0;
  GLsizeiptr material_stride = 0;
  // One per asset texture; shared by meshes uploaded with uploadMesh() from this asset.
  std::shared_ptr<TextureSet> textures = std::make_shared<TextureSet>();
  std::vector<core::Material> materials;
  std::vector<GpuSubmesh> submeshes;
  core::Sphere bounds;
  bool has[6] = {};  // position, normal, tangent, uv0, uv1, color
};

struct Framebuffer {
  GLuint fbo = 0, color = 0, depth = 0;
  int width = 0, height = 0, samples = 0;
  GLenum format = 0;
  bool texture = false;
};

// What renderRegions() draws with in one GL context: a layered target (2D array colour + depth,
// view-sized) and the draws' Frame blocks. Framebuffers are not shared between contexts, and the
// Frame blocks are written per call, so each drawing context has its own.
struct RegionTarget {
  GLuint fbo = 0, color = 0, depth = 0;
  int width = 0, height = 0, layers = 0;
  GLuint frame_ubo = 0;
  GLsizeiptr frame_ubo_size = 0;
  void destroy();  // with its context current
};

// renderRegions()'s second drawing thread: a GL context of its own that shares the Renderer's
// objects (programs, buffers, textures), made current on a thread that runs one job at a time.
// llvmpipe shades vertices, clips and bins triangles on the thread that draws, and rasterizes
// when the scene is read back, so with one context one stage waits for the other; with two, one
// context's drawing runs beside the other's rasterizing (region_renderer.cpp).
//
// Each context draws with programs of its own. A program object is shared by the contexts that
// share objects, but on llvmpipe (Mesa 22.3) that is not safe for two contexts that draw with it:
// a uniform set in one context never reaches the other (the "changed" flags are per context),
// deleting it from one context frees the other's compiled variants through the wrong context
// (generate crashed at its second mesh level), and both contexts compile variants of it at once
// into one list. So the helper compiles its own copy of each region program from its source
// (State::region_programs) and gives it the uniform values set on the original.
class RegionHelper {
 public:
  // What the thread keeps in its context: its region target and its copies of region programs.
  struct Context {
    struct Copy {
      GLuint program = 0;
      uint32_t version = 0;  // RegionProgram::version of the uniforms it was given
    };
    RegionTarget target;
    std::map<GLuint, Copy> programs;  // by the first context's program
  };

  // Starts the thread and creates its context; fails when the thread or context cannot be made.
  static core::Result<std::unique_ptr<RegionHelper>> start(const GlContext& share);
  ~RegionHelper();  // after the job under way; its objects are deleted in its context
  RegionHelper(const RegionHelper&) = delete;
  RegionHelper& operator=(const RegionHelper&) = delete;

  // Runs `job` on the thread, with its context current; wait() returns when it is done and
  // rethrows what the job threw. One job at a time.
  void run(std::function<void(Context&)> job);
  void wait();

 private:
  RegionHelper() = default;
  void loop(const GlContext* share, std::promise<core::Status>* started);

  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::function<void(Context&)> job_;
  std::exception_ptr thrown_;
  bool busy_ = false, stopping_ = false;
};

// A program made by compileRegionProgram(): its source, wrapped, and the uniform values set on it
// (setProgramUniforms), for the helper's copy.
struct RegionProgram {
  GlslSource source;
  std::vector<UniformValue> uniforms;  // one per location, the last value set
  uint32_t version = 0;                // counts the setProgramUniforms calls
};

// A program from GLSL source, compiled and linked in the current context.
core::Result<GLuint> buildProgram(const GlslSource& source);
// glProgramUniform of each value; fails on a location or size the program lacks. A location in
// `declared` (the program's SPIR-V declares a uniform there) that the driver optimized away is
// skipped: its value can change nothing.
core::Status setUniforms(GLuint program, std::span<const UniformValue> values,
                         std::span<const int> declared = {});

// Creates `gpu.vao` and one buffer per present attribute stream of `mesh`, bound to VAO binding
// point = stream slot (position 0, normal 1, tangent 2, uv0 3, uv1 4, colour 5); the attribute
// locations come from the bindings at draw time, so one upload serves any bindings.
void uploadVertexStreams(const core::Mesh& mesh, GpuAsset& gpu);
// Appends a buffer holding `bytes` to gpu.buffers and returns it.
GLuint addBuffer(GpuAsset& gpu, const void* data, size_t bytes);

void destroyFramebuffer(Framebuffer& f);
// (Re)creates `f` only when its shape changes: allocation is costly on llvmpipe at atlas sizes.
core::Status ensureFramebuffer(Framebuffer& f, int width, int height, int samples, GLenum format,
                               bool with_depth, bool as_texture);
std::string shaderLog(GLuint shader);
core::Result<GLuint> linkProgram(GLuint vertex, GLuint fragment, const std::string& what);
// Clears `target` and sets the state every pass draws with (depth test, back-face culling).
void beginDrawing(const Framebuffer& target);
// How many tiles of `tile` pixels fit one atlas pass: bounded by the GL limits and by a memory
// budget (colour + depth at 4 bytes each, times MSAA samples).
struct AtlasLayout {
  int columns = 1, rows = 1, per_chunk = 1;
};
AtlasLayout planAtlas(int count, int tile, int max_size, int samples);

// Copies chunk tiles (bottom-up GL rows, atlas layout) into the batch (top-down, contiguous tiles).
template <class T>
void scatterTiles(const std::vector<T>& atlas, int atlas_width, const AtlasLayout& layout,
                  int tile, int first, int count, TiledImages<T>& batch) {
  for (int i = 0; i < count; ++i) {
    int x0 = (i % layout.columns) * tile, y0 = (i / layout.columns) * tile;
    T* out = batch.tile(first + i);
    for (int row = 0; row < tile; ++row) {
      const T* source = atlas.data() + (size_t(y0 + tile - 1 - row) * atlas_width + x0) * 4;
      std::copy_n(source, size_t(tile) * 4, out + size_t(row) * tile * 4);
    }
  }
}

// The five ARB_pipeline_statistics_query counters of WorkCounts, begun and ended around the
// object's draws only (not the box filter or clears), summed over atlas chunks.
struct WorkQueries {
  static constexpr int kCount = 5;
  GLuint ids[kCount] = {};
  bool available = false;  // the device has the extension (or GL 4.6)
  void create();
  void destroy();
  void begin();
  void end();
  void addResults(WorkCounts& counts);  // waits for the results
};

inline void copyMatrix(float* out, const core::Mat4& m) { std::memcpy(out, m.m.data(), 64); }
inline int roundUp(int value, int multiple) { return (value + multiple - 1) / multiple * multiple; }

}  // namespace internal

// SharedTextures' state: the textures and the context that made them (a renderer's, which
// renderers made with them share).
struct SharedTextures::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  std::shared_ptr<internal::TextureSet> set;
};

struct Renderer::State {
  GlContext context;
  std::shared_ptr<const SharedTextures> shared_textures;  // ContextOptions::textures
  size_t uploaded_texture_bytes = 0;
  std::vector<std::optional<internal::GpuAsset>> assets;
  std::vector<GLuint> programs;  // 0 = released
  // Per SPIR-V program: the loose uniform locations its modules declare (setUniforms).
  std::map<GLuint, std::vector<int>> declared_uniforms;
  Bindings bindings;
  core::Vec3 ambient{0.1f, 0.1f, 0.1f};
  core::Vec3 light_color{2.0f, 2.0f, 2.0f};
  GLuint white_texture = 0, flat_normal_texture = 0;
  GLuint frame_ubo = 0;
  GLsizeiptr frame_ubo_size = 0;
  GLint ubo_alignment = 256;
  GLint max_size = 4096;
  internal::Framebuffer atlas, resolved, reference_float;
  internal::RegionTarget region;  // renderRegions() in this context
  // renderRegions()'s second drawing thread and context (region_renderer.cpp), started at its
  // first use when `drawing_threads` is 2; a failure to start it is kept and not retried.
  int drawing_threads = 1;
  std::unique_ptr<internal::RegionHelper> region_helper;
  std::string region_helper_failure;
  std::map<GLuint, internal::RegionProgram> region_programs;  // by program
  GLuint downsample_program = 0;
  GLuint empty_vao = 0;
  internal::WorkQueries work_queries;
  GLuint parameter_ubo = 0;  // setParameterBlock(); bound with every draw's inputs
  int parameter_binding = -1;
  // For the slow-request reports (SlowRequestWatch): programs' names ("a.vert + b.frag"), and
  // the (program, kind of request) pairs drawn before: llvmpipe compiles a program for each kind
  // of target at its first draw there.
  std::map<GLuint, std::string> program_names;
  std::set<std::pair<GLuint, int>> drawn;

  ~State() {
    // First the helper's thread: its context shares these objects.
    region_helper.reset();
    // The objects are this context's: with another one current (a second Renderer), these
    // names would delete its objects. Not current here (another thread): they go with it (and a
    // TextureSet deletes its names only in the context that made them).
    if (context_alive && !context.makeCurrent()) return;
    if (context_alive) {
      for (auto& asset : assets)
        if (asset) release(*asset);
      for (GLuint p : programs)
        if (p) glDeleteProgram(p);
      destroyFramebuffer(atlas);
      destroyFramebuffer(resolved);
      destroyFramebuffer(reference_float);
      region.destroy();
      if (downsample_program) glDeleteProgram(downsample_program);
      GLuint textures[] = {white_texture, flat_normal_texture};
      glDeleteTextures(2, textures);
      if (frame_ubo) glDeleteBuffers(1, &frame_ubo);
      if (empty_vao) glDeleteVertexArrays(1, &empty_vao);
      work_queries.destroy();
      if (parameter_ubo) glDeleteBuffers(1, &parameter_ubo);
    }
  }

  // Kinds of request, for `drawn`.
  enum RequestKind { kRenderRequest, kReferenceRequest, kRegionRequest, kTimingRequest };
  // Whether a request of `kind` holds `program`'s first draw of that kind (and marks it drawn).
  bool firstDraw(GLuint program, RequestKind kind) { return drawn.insert({program, kind}).second; }
  const char* programName(GLuint program) const {
    auto it = program_names.find(program);
    return it == program_names.end() ? "a SPIR-V program" : it->second.c_str();
  }
  // A released program's name may come back for another program.
  void forgetProgram(GLuint program) {
    program_names.erase(program);
    for (auto it = drawn.lower_bound({program, 0}); it != drawn.end() && it->first == program;)
      it = drawn.erase(it);
  }

  static void release(internal::GpuAsset& asset) {
    glDeleteVertexArrays(1, &asset.vao);
    glDeleteBuffers(static_cast<GLsizei>(asset.buffers.size()), asset.buffers.data());
    glDeleteBuffers(1, &asset.material_ubo);
    asset.textures.reset();
  }

  GLuint makeSolidTexture(const std::array<uint8_t, 4>& texel) {
    GLuint texture;
    glCreateTextures(GL_TEXTURE_2D, 1, &texture);
    glTextureStorage2D(texture, 1, GL_RGBA8, 1, 1);
    glTextureSubImage2D(texture, 0, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, texel.data());
    return texture;
  }

  bool context_alive = false;
};

namespace internal {

// The Frame block (INTERFACE.md) of one draw: the renderer's light colour and ambient, the object's
// bounding sphere in object space.
inline FrameBlock makeFrameBlock(const Renderer::State& s, const core::Mat4& model,
                                 const core::Mat4& normal_matrix, const core::Mat4& view,
                                 const core::Mat4& projection, core::Vec3 eye, core::Vec3 light,
                                 const core::Sphere& bounds) {
  FrameBlock block{};
  copyMatrix(block.model, model);
  copyMatrix(block.view, view);
  copyMatrix(block.projection, projection);
  copyMatrix(block.normal_matrix, normal_matrix);
  const float eye4[4] = {eye.x, eye.y, eye.z, 1};
  const float light4[4] = {light.x, light.y, light.z, 1};
  const float light_color[4] = {s.light_color.x, s.light_color.y, s.light_color.z, 0};
  const float ambient[4] = {s.ambient.x, s.ambient.y, s.ambient.z, 0};
  const float object[4] = {bounds.center.x, bounds.center.y, bounds.center.z, bounds.radius};
  std::memcpy(block.camera_position, eye4, 16);
  std::memcpy(block.light_position, light4, 16);
  std::memcpy(block.light_color, light_color, 16);
  std::memcpy(block.ambient_color, ambient, 16);
  std::memcpy(block.object_info, object, 16);
  return block;
}

// Copies `bytes` to the start of the buffer `ubo` of `size` bytes, growing it when needed.
inline void uploadFrameBytes(GLuint& ubo, GLsizeiptr& size, const std::vector<uint8_t>& bytes) {
  GLsizeiptr needed = static_cast<GLsizeiptr>(bytes.size());
  if (needed > size) {
    glDeleteBuffers(1, &ubo);
    glCreateBuffers(1, &ubo);
    glNamedBufferStorage(ubo, needed, nullptr, GL_DYNAMIC_STORAGE_BIT);
    size = needed;
  }
  glNamedBufferSubData(ubo, 0, needed, bytes.data());
}
inline void uploadFrameBytes(Renderer::State& s, const std::vector<uint8_t>& bytes) {
  uploadFrameBytes(s.frame_ubo, s.frame_ubo_size, bytes);
}

// The checks every whole-view render shares (ids, sample count, sizes, work counting available).
core::Status checkRequest(const Renderer::State& s, Renderer::AssetId asset,
                          Renderer::ProgramId program, std::span<const Sample> samples,
                          const RenderOptions& options);

// Shared by render() and renderReference(): draws samples [first, first+n) of a chunk into the
// atlas at `tile` pixels per sample.
struct ChunkDrawer {
  Renderer::State& s;
  const GpuAsset& asset;
  GLuint program;

  // Into s.frame_ubo, or the given buffer of `size` bytes (another context's).
  void uploadFrames(std::span<const Sample> samples, GLsizeiptr stride) {
    uploadFrames(samples, stride, s.frame_ubo, s.frame_ubo_size);
  }
  void uploadFrames(std::span<const Sample> samples, GLsizeiptr stride, GLuint& ubo,
                    GLsizeiptr& size) const {
    std::vector<uint8_t> bytes(samples.size() * stride);
    for (size_t i = 0; i < samples.size(); ++i) {
      const Sample& sample = samples[i];
      const core::Mat4& model = sample.placement;
      const core::Mat4 normal_matrix = core::transpose(core::inverse(model));
      const core::Mat4 view = sample.view * core::inverse(model);
      FrameBlock block = makeFrameBlock(s, model, normal_matrix, view, sample.projection,
                                        core::transformPoint(model, sample.eye),
                                        core::transformPoint(model, sample.light), asset.bounds);
      std::memcpy(bytes.data() + i * stride, &block, sizeof block);
    }
    uploadFrameBytes(ubo, size, bytes);
  }

  void bindInputs() {
    const Bindings& b = s.bindings;
    glUseProgram(program);
    glBindVertexArray(asset.vao);
    if (s.parameter_binding >= 0)
      glBindBufferBase(GL_UNIFORM_BUFFER, s.parameter_binding, s.parameter_ubo);
    const int locations[6] = {b.position, b.normal, b.tangent, b.uv0, b.uv1, b.color};
    const int components[6] = {3, 3, 4, 2, 2, 4};
    const float defaults[6][4] = {{0, 0, 0, 1}, {0, 0, 1, 0}, {1, 0, 0, 1},
                                  {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 1, 1, 1}};
    for (int slot = 0; slot < 6; ++slot) {
      int location = locations[slot];
      if (location < 0) continue;
      if (asset.has[slot]) {
        glEnableVertexArrayAttrib(asset.vao, location);
        glVertexArrayAttribFormat(asset.vao, location, components[slot], GL_FLOAT, GL_FALSE, 0);
        glVertexArrayAttribBinding(asset.vao, location, slot);
      } else {
        glDisableVertexArrayAttrib(asset.vao, location);
        glVertexAttrib4fv(location, defaults[slot]);
      }
    }
  }

  void bindMaterial(uint32_t material_index) {
    const Bindings& b = s.bindings;
    if (b.material_block >= 0)  // -1: the shader reads no material block
      glBindBufferRange(GL_UNIFORM_BUFFER, b.material_block, asset.material_ubo,
                        asset.material_stride * material_index, sizeof(MaterialBlock));
    core::Material fallback;
    const core::Material& m =
        material_index < asset.materials.size() ? asset.materials[material_index] : fallback;
    // glTF's doubleSided: back faces drawn too (the shader reverses their normal by
    // gl_FrontFacing: shaders/INTERFACE.md). Set per material, since every draw path binds its
    // material here.
    if (m.double_sided) {
      glDisable(GL_CULL_FACE);
    } else {
      glEnable(GL_CULL_FACE);
      glCullFace(GL_BACK);
    }
    auto texture = [&](int index, GLuint missing) {
      const std::vector<GLuint>& ids = asset.textures->ids;
      return index >= 0 && index < static_cast<int>(ids.size()) && ids[index] ? ids[index]
                 : missing;
    };
    const std::pair<int, GLuint> units[] = {
        {b.base_color, texture(m.base_color_texture, s.white_texture)},
        {b.metallic_roughness, texture(m.metallic_roughness_texture, s.white_texture)},
        {b.normal_map, texture(m.normal_texture, s.flat_normal_texture)},
        {b.occlusion, texture(m.occlusion_texture, s.white_texture)},
        {b.emissive, texture(m.emissive_texture, s.white_texture)},
    };
    for (auto [unit, id] : units)
      if (unit >= 0) glBindTextureUnit(unit, id);
  }

  // Draws `count` samples starting at `first` into atlas tiles of `tile` pixels.
  int drawChunk(int first, int count, int tile, const AtlasLayout& layout, GLsizeiptr stride) {
    int draws = 0;
    bindInputs();
    for (int i = 0; i < count; ++i) {
      int x = (i % layout.columns) * tile, y = (i / layout.columns) * tile;
      glViewport(x, y, tile, tile);
      glScissor(x, y, tile, tile);
      if (s.bindings.frame_block >= 0)  // -1: the shader reads no frame block
        glBindBufferRange(GL_UNIFORM_BUFFER, s.bindings.frame_block, s.frame_ubo,
                          stride * (first + i), sizeof(FrameBlock));
      for (const GpuSubmesh& sub : asset.submeshes) {
        bindMaterial(sub.material);
        glDrawElements(GL_TRIANGLES, sub.index_count, GL_UNSIGNED_INT,
                       reinterpret_cast<const void*>(sub.first_index * 4));
        ++draws;
      }
    }
    return draws;
  }
};

}  // namespace internal
}  // namespace duolod::render
