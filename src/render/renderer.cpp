// Batched offscreen rendering of the view × light domain. Every sample gets its own tile of one
// atlas framebuffer (its own viewport and scissor), all per-sample uniforms live in one buffer
// bound by range, and the atlas is read back once: on llvmpipe a readback per view would cost more
// than the drawing. References (f̄, eq. 1) are drawn k× larger and box-filtered on the GPU.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <glslang/SPIRV/spirv.hpp>
#include <optional>
#include <string_view>
#include <thread>

#include "duolod/render.hpp"
#include "render/batch_memory.hpp"
#include "render/renderer_internal.hpp"

namespace duolod::render {
namespace {
using core::Error;


constexpr const char* kDownsampleVertex = R"(#version 450 core
void main() {
  // One triangle covering the viewport.
  vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
)";
// Box filter of eq. (1)'s supersampling: destination pixel p averages the k×k source block at k·p.
constexpr const char* kDownsampleFragment = R"(#version 450 core
layout(binding = 0) uniform sampler2D uSource;
layout(location = 0) uniform int uFactor;
layout(location = 0) out vec4 outColor;
void main() {
  ivec2 base = ivec2(gl_FragCoord.xy) * uFactor;
  vec4 sum = vec4(0.0);
  for (int y = 0; y < uFactor; ++y)
    for (int x = 0; x < uFactor; ++x) sum += texelFetch(uSource, base + ivec2(x, y), 0);
  outColor = sum / float(uFactor * uFactor);
}
)";

}  // namespace

namespace internal {

GLuint addBuffer(GpuAsset& gpu, const void* data, size_t bytes) {
  GLuint buffer;
  glCreateBuffers(1, &buffer);
  glNamedBufferStorage(buffer, static_cast<GLsizeiptr>(bytes), data, 0);
  gpu.buffers.push_back(buffer);
  return buffer;
}

void uploadVertexStreams(const core::Mesh& mesh, GpuAsset& gpu) {
  glCreateVertexArrays(1, &gpu.vao);
  auto stream = [&](int slot, const auto& values) {
    if (values.empty()) return;
    GLuint buffer = addBuffer(gpu, values.data(), values.size() * sizeof(values[0]));
    glVertexArrayVertexBuffer(gpu.vao, slot, buffer, 0, sizeof(values[0]));
    gpu.has[slot] = true;
  };
  stream(0, mesh.positions);
  stream(1, mesh.normals);
  stream(2, mesh.tangents);
  stream(3, mesh.uv0);
  stream(4, mesh.uv1);
  stream(5, mesh.colors);
}

void destroyFramebuffer(Framebuffer& f) {
  if (f.fbo) glDeleteFramebuffers(1, &f.fbo);
  if (f.texture) {
    if (f.color) glDeleteTextures(1, &f.color);
  } else if (f.color) {
    glDeleteRenderbuffers(1, &f.color);
  }
  if (f.depth) glDeleteRenderbuffers(1, &f.depth);
  f = {};
}

core::Status ensureFramebuffer(Framebuffer& f, int width, int height, int samples, GLenum format,
                               bool with_depth, bool as_texture) {
  if (f.fbo && f.width == width && f.height == height && f.samples == samples &&
      f.format == format && f.texture == as_texture && (f.depth != 0) == with_depth)
    return core::okStatus();
  destroyFramebuffer(f);
  f.width = width, f.height = height, f.samples = samples, f.format = format,
  f.texture = as_texture;
  glCreateFramebuffers(1, &f.fbo);
  if (as_texture) {
    glCreateTextures(GL_TEXTURE_2D, 1, &f.color);
    glTextureStorage2D(f.color, 1, format, width, height);
    glTextureParameteri(f.color, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(f.color, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glNamedFramebufferTexture(f.fbo, GL_COLOR_ATTACHMENT0, f.color, 0);
  } else {
    glCreateRenderbuffers(1, &f.color);
    if (samples > 0)
      glNamedRenderbufferStorageMultisample(f.color, samples, format, width, height);
    else
      glNamedRenderbufferStorage(f.color, format, width, height);
    glNamedFramebufferRenderbuffer(f.fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, f.color);
  }
  if (with_depth) {
    glCreateRenderbuffers(1, &f.depth);
    if (samples > 0)
      glNamedRenderbufferStorageMultisample(f.depth, samples, GL_DEPTH_COMPONENT24, width, height);
    else
      glNamedRenderbufferStorage(f.depth, GL_DEPTH_COMPONENT24, width, height);
    glNamedFramebufferRenderbuffer(f.fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, f.depth);
  }
  GLenum status = glCheckNamedFramebufferStatus(f.fbo, GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    destroyFramebuffer(f);
    return Error{"cannot create a " + std::to_string(width) + "x" + std::to_string(height) +
                 " framebuffer (status 0x" + std::to_string(status) + ")"};
  }
  return core::okStatus();
}

std::string shaderLog(GLuint shader) {
  GLint length = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
  std::string log(std::max(length, 1), '\0');
  glGetShaderInfoLog(shader, length, nullptr, log.data());
  while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
  return log;
}

static std::string programLog(GLuint program) {
  GLint length = 0;
  glGetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
  std::string log(std::max(length, 1), '\0');
  glGetProgramInfoLog(program, length, nullptr, log.data());
  while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
  return log;
}

core::Result<GLuint> linkProgram(GLuint vertex, GLuint fragment, const std::string& what) {
  GLuint program = glCreateProgram();
  glAttachShader(program, vertex);
  glAttachShader(program, fragment);
  glLinkProgram(program);
  glDeleteShader(vertex);
  glDeleteShader(fragment);
  GLint linked = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &linked);
  if (!linked) {
    std::string log = programLog(program);
    glDeleteProgram(program);
    // The usual cause with a user's pair: an HLSL stage beside a GLSL one. HLSL's cbuffer
    // matrices arrive row_major (as HLSL lays them out), a GLSL block's column_major, so the two
    // cannot share a block holding matrices.
    const bool blocks_differ = log.find("mismatching definitions") != std::string::npos ||
                               (log.find("uniform block") != std::string::npos &&
                                log.find("do not match") != std::string::npos);
    return Error{what + ": program failed to link:\n" + log +
                 (blocks_differ ? "\n(each uniform block must be declared alike in both stages, "
                                  "matrix layout included: an HLSL stage's cbuffer matrices are "
                                  "row_major, so a block holding matrices cannot be shared by an "
                                  "HLSL stage and a GLSL one; give both stages in one language)"
                                : "")};
  }
  return program;
}

void beginDrawing(const Framebuffer& target) {
  glBindFramebuffer(GL_FRAMEBUFFER, target.fbo);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  glDisable(GL_SCISSOR_TEST);
  glViewport(0, 0, target.width, target.height);
  glClearColor(0, 0, 0, 0);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_SCISSOR_TEST);
  if (target.samples > 0) glEnable(GL_MULTISAMPLE);
}

namespace {
constexpr GLenum kWorkQueryTargets[WorkQueries::kCount] = {
    GL_VERTEX_SHADER_INVOCATIONS_ARB, GL_FRAGMENT_SHADER_INVOCATIONS_ARB,
    GL_PRIMITIVES_SUBMITTED_ARB, GL_CLIPPING_INPUT_PRIMITIVES_ARB,
    GL_CLIPPING_OUTPUT_PRIMITIVES_ARB};
}  // namespace

void WorkQueries::create() {
  available = epoxy_gl_version() >= 46 ||
              epoxy_has_gl_extension("GL_ARB_pipeline_statistics_query");
  if (available) glGenQueries(kCount, ids);
}
void WorkQueries::destroy() {
  if (available) glDeleteQueries(kCount, ids);
  available = false;
}
void WorkQueries::begin() {
  for (int q = 0; q < kCount; ++q) glBeginQuery(kWorkQueryTargets[q], ids[q]);
}
void WorkQueries::end() {
  for (int q = 0; q < kCount; ++q) glEndQuery(kWorkQueryTargets[q]);
}
void WorkQueries::addResults(WorkCounts& counts) {
  uint64_t* fields[kCount] = {&counts.vertex_invocations, &counts.fragment_invocations,
                              &counts.primitives_submitted, &counts.clipping_input_primitives,
                              &counts.clipping_output_primitives};
  for (int q = 0; q < kCount; ++q) {
    GLuint64 value = 0;
    glGetQueryObjectui64v(ids[q], GL_QUERY_RESULT, &value);
    *fields[q] += value;
  }
}

}  // namespace internal

using namespace internal;


Renderer::Renderer() : state_(std::make_unique<State>()) {}
Renderer::~Renderer() = default;

core::Result<std::unique_ptr<Renderer>> Renderer::create(const ContextOptions& options) {
  auto context = options.textures ? GlContext::createSharing(options.textures->impl_->display,
                                                             options.textures->impl_->context)
                                  : GlContext::create(options);
  if (!context) return context.error();
  std::unique_ptr<Renderer> renderer(new Renderer());
  State& s = *renderer->state_;
  s.context = std::move(context.value());
  s.context_alive = true;
  s.shared_textures = options.textures;
  if (options.drawing_threads < 0 || options.drawing_threads > 2)
    return core::Error{"render: drawing_threads must be 0 (automatic), 1 or 2, got " +
                       std::to_string(options.drawing_threads)};
  s.drawing_threads = options.drawing_threads;
  s.bindings = options.bindings;
  if (s.drawing_threads == 0) {
    // On llvmpipe the thread that draws shades vertices, clips and bins triangles while the
    // rasterizer threads wait, and the reverse: a second drawing context keeps both cores busy
    // (region_renderer.cpp). A GPU gains nothing from it.
    const GLubyte* name = glGetString(GL_RENDERER);
    const bool cpu_rasterizer =
        name && std::string(reinterpret_cast<const char*>(name)).find("llvmpipe") != std::string::npos;
    s.drawing_threads = cpu_rasterizer && std::thread::hardware_concurrency() >= 2 ? 2 : 1;
  }
  glGetIntegerv(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &s.ubo_alignment);
  GLint max_texture = 0, max_renderbuffer = 0, max_viewport[2] = {0, 0};
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_renderbuffer);
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, max_viewport);
  s.max_size = std::min({max_texture, max_renderbuffer, max_viewport[0], max_viewport[1], kMaxTileSize});
  s.white_texture = s.makeSolidTexture(kMissingTextureTexel);
  s.flat_normal_texture = s.makeSolidTexture(kMissingNormalTexel);
  glCreateBuffers(1, &s.frame_ubo);
  glCreateVertexArrays(1, &s.empty_vao);
  s.work_queries.create();
  auto downsample =
      renderer->compileProgram(GlslSource{kDownsampleVertex, kDownsampleFragment, "downsample.vert",
                                          "downsample.frag"});
  if (!downsample) return downsample.error();
  s.downsample_program = s.programs[*downsample];
  s.programs[*downsample] = 0;  // owned separately, never released by id
  return renderer;
}

std::string Renderer::deviceDescription() const {
  if (auto bound = state_->context.makeCurrent(); !bound)
    return "? (" + bound.error().message + ")";
  return state_->context.description();
}
bool Renderer::canCountWork() const { return state_->work_queries.available; }

core::Status Renderer::setProgramUniforms(ProgramId program, std::span<const UniformValue> values) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound;
  State& s = *state_;
  if (program < 0 || program >= static_cast<int>(s.programs.size()) || !s.programs[program])
    return Error{"setProgramUniforms: unknown program id " + std::to_string(program)};
  const GLuint id = s.programs[program];
  const auto declared = s.declared_uniforms.find(id);
  if (auto set = setUniforms(id, values,
                             declared == s.declared_uniforms.end()
                                 ? std::span<const int>()
                                 : std::span<const int>(declared->second));
      !set)
    return set;
  // A region program's values go to the helper's copy too, when it next draws with it.
  if (auto region = s.region_programs.find(id); region != s.region_programs.end()) {
    std::vector<UniformValue>& kept = region->second.uniforms;
    for (const UniformValue& v : values) {
      auto same = std::find_if(kept.begin(), kept.end(),
                               [&](const UniformValue& k) { return k.location == v.location; });
      if (same != kept.end())
        *same = v;
      else
        kept.push_back(v);
    }
    ++region->second.version;
  }
  return core::okStatus();
}

namespace {
bool hasActiveUniformAt(GLuint program, int location) {
  GLint count = 0;
  glGetProgramInterfaceiv(program, GL_UNIFORM, GL_ACTIVE_RESOURCES, &count);
  const GLenum property = GL_LOCATION;
  for (GLint i = 0; i < count; ++i) {
    GLint found = -1;
    glGetProgramResourceiv(program, GL_UNIFORM, GLuint(i), 1, &property, 1, nullptr, &found);
    if (found == location) return true;
  }
  return false;
}

// The Location of every UniformConstant variable of a SPIR-V module (loose uniforms; samplers
// have bindings, not locations).
void collectUniformLocations(const std::vector<uint32_t>& words, std::vector<int>& locations) {
  std::map<uint32_t, int> located;
  std::vector<uint32_t> uniforms;
  for (size_t i = 5; i < words.size();) {
    const uint32_t count = words[i] >> 16, opcode = words[i] & 0xffffu;
    if (count == 0 || i + count > words.size()) return;
    if (opcode == spv::OpDecorate && count >= 4 && words[i + 2] == spv::DecorationLocation)
      located[words[i + 1]] = static_cast<int>(words[i + 3]);
    if (opcode == spv::OpVariable && count >= 4 && words[i + 3] == spv::StorageClassUniformConstant)
      uniforms.push_back(words[i + 2]);
    i += count;
  }
  for (uint32_t id : uniforms)
    if (auto found = located.find(id); found != located.end()) locations.push_back(found->second);
}
}  // namespace

core::Status internal::setUniforms(GLuint id, std::span<const UniformValue> values,
                                   std::span<const int> declared) {
  while (glGetError() != GL_NO_ERROR) {
  }
  for (const UniformValue& v : values) {
    if (v.location < 0 || v.components < 1 || v.components > 4)
      return Error{"setProgramUniforms: uniform at location " + std::to_string(v.location) +
                   " with " + std::to_string(v.components) +
                   " components (needs a location >= 0 and 1..4 components)"};
    const float* x = v.value.data();
    switch (v.components) {
      case 1: glProgramUniform1fv(id, v.location, 1, x); break;
      case 2: glProgramUniform2fv(id, v.location, 1, x); break;
      case 3: glProgramUniform3fv(id, v.location, 1, x); break;
      default: glProgramUniform4fv(id, v.location, 1, x); break;
    }
    if (GLenum error = glGetError(); error != GL_NO_ERROR) {
      // A uniform the driver optimized away (its value can change nothing, e.g. moved to a
      // parameter in a branch that never writes the output) has no active location: nothing to
      // set. An active one of another type is the caller's mistake.
      if (std::find(declared.begin(), declared.end(), v.location) != declared.end() &&
          !hasActiveUniformAt(id, v.location))
        continue;
      return Error{"setProgramUniforms: the program has no " + std::to_string(v.components) +
                   "-float uniform at location " + std::to_string(v.location) + " (GL error " +
                   std::to_string(error) + ")"};
    }
  }
  return core::okStatus();
}

core::Status Renderer::setParameterBlock(int binding, std::span<const uint8_t> bytes) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound;
  State& s = *state_;
  if (bytes.empty()) {
    s.parameter_binding = -1;
    return core::okStatus();
  }
  GLint max_bindings = 0;
  glGetIntegerv(GL_MAX_UNIFORM_BUFFER_BINDINGS, &max_bindings);
  if (binding < 0 || binding >= max_bindings || binding == s.bindings.frame_block ||
      binding == s.bindings.material_block)
    return Error{"setParameterBlock: binding " + std::to_string(binding) +
                 " is out of range or taken by the frame/material block"};
  // A new buffer each time: a draw still queued may read the old one (the driver keeps it alive).
  if (s.parameter_ubo) glDeleteBuffers(1, &s.parameter_ubo);
  glCreateBuffers(1, &s.parameter_ubo);
  glNamedBufferStorage(s.parameter_ubo, static_cast<GLsizeiptr>(bytes.size()), bytes.data(), 0);
  s.parameter_binding = binding;
  return core::okStatus();
}

void Renderer::setBindings(const Bindings& bindings) { state_->bindings = bindings; }
void Renderer::setAmbient(core::Vec3 ambient_color) { state_->ambient = ambient_color; }
void Renderer::setLightColor(core::Vec3 light_color) { state_->light_color = light_color; }

namespace {

// Vertex streams, index buffer, submeshes and material blocks of `mesh`; textures are separate.
core::Status uploadGeometry(const core::Mesh& source, const std::vector<core::Material>& materials,
                            GLint ubo_alignment, GpuAsset& gpu) {
  if (auto valid = core::validateMesh(source); !valid) return valid;
  if (source.triangleCount() == 0) return Error{"no triangles to render"};
  // (uploadMesh's new mesh against the asset's materials; uploadAsset checked its own already.)
  if (auto valid = core::validateSubmeshMaterials(source, materials.size()); !valid) return valid;
  gpu.bounds = core::computeBoundingSphere(source);
  core::Mesh mesh = source;
  // llvmpipe shades a vertex again whenever its index is not among the recently shaded ones: the
  // Dragon as loaded costs 3.8 vertex shader runs per vertex per draw, 1.3 in this order.
  core::optimizeVertexReuse(mesh);
  gpu.materials = materials;
  uploadVertexStreams(mesh, gpu);
  GLuint index_buffer = addBuffer(gpu, mesh.indices.data(), mesh.indices.size() * 4);
  glVertexArrayElementBuffer(gpu.vao, index_buffer);
  for (const core::Submesh& sub : mesh.submeshes)
    if (sub.index_count > 0)
      gpu.submeshes.push_back({static_cast<GLsizei>(sub.index_count), sub.first_index, sub.material});

  // One material block per material, at aligned offsets of one buffer.
  gpu.material_stride = roundUp(sizeof(MaterialBlock), ubo_alignment);
  std::vector<uint8_t> material_bytes(std::max<size_t>(1, materials.size()) *
                                      gpu.material_stride);
  for (size_t m = 0; m < materials.size(); ++m) {
    const core::Material& mat = materials[m];
    MaterialBlock block{};
    float* f = block.base_color_factor;
    f[0] = mat.base_color_factor.x, f[1] = mat.base_color_factor.y, f[2] = mat.base_color_factor.z,
    f[3] = mat.base_color_factor.w;
    block.emissive_factor[0] = mat.emissive_factor.x;
    block.emissive_factor[1] = mat.emissive_factor.y;
    block.emissive_factor[2] = mat.emissive_factor.z;
    block.material_params[0] = mat.metallic_factor;
    block.material_params[1] = mat.roughness_factor;
    block.material_params[2] = mat.normal_scale;
    block.material_params[3] = mat.occlusion_strength;
    block.texture_flags[0] = mat.base_color_texture >= 0;
    block.texture_flags[1] = mat.metallic_roughness_texture >= 0;
    block.texture_flags[2] = mat.normal_texture >= 0;
    block.texture_flags[3] = mat.occlusion_texture >= 0;
    block.texture_flags2[0] = mat.emissive_texture >= 0;
    std::memcpy(material_bytes.data() + m * gpu.material_stride, &block, sizeof block);
  }
  glCreateBuffers(1, &gpu.material_ubo);
  glNamedBufferStorage(gpu.material_ubo, static_cast<GLsizeiptr>(material_bytes.size()),
                       material_bytes.data(), 0);
  return core::okStatus();
}

// The asset's textures into `set` (the current context), with their mipmaps and signatures.
core::Status uploadTextures(const core::Asset& asset, internal::TextureSet& set) {
  for (const core::Texture& texture : asset.textures) {
    if (texture.image.pixels.empty() && texture.encoded)  // io::LoadOptions::decode_textures
      return Error{asset.source_path + ": texture " + texture.name +
                   " was loaded without decoding it (LoadOptions::decode_textures = false): "
                   "load the asset with decoded textures to draw it"};
    GLuint id = 0;
    if (!texture.image.pixels.empty()) {
      const core::ImageRGBA8& image = texture.image;
      int levels = 1 + static_cast<int>(std::floor(std::log2(std::max(image.width, image.height))));
      glCreateTextures(GL_TEXTURE_2D, 1, &id);
      glTextureStorage2D(id, levels, texture.srgb ? GL_SRGB8_ALPHA8 : GL_RGBA8, image.width,
                         image.height);
      glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      glTextureSubImage2D(id, 0, 0, 0, image.width, image.height, GL_RGBA, GL_UNSIGNED_BYTE,
                          image.pixels.data());
      glGenerateTextureMipmap(id);
      glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
      glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_REPEAT);
      glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_REPEAT);
      set.bytes += image.pixels.size() * 4 / 3;  // the mipmaps add a third
    }
    set.ids.push_back(id);
    set.signatures.push_back({texture.image.width, texture.image.height, texture.srgb,
                              core::fingerprintImage(texture.image)});
  }
  return core::okStatus();
}

}  // namespace

SharedTextures::SharedTextures() : impl_(std::make_unique<Impl>()) {}
SharedTextures::~SharedTextures() = default;

bool SharedTextures::matches(const core::Asset& asset) const {
  const auto& signatures = impl_->set->signatures;
  if (asset.textures.size() != signatures.size()) return false;
  for (size_t i = 0; i < asset.textures.size(); ++i) {
    const core::ImageRGBA8& image = asset.textures[i].image;
    const internal::TextureSet::Signature& signature = signatures[i];
    if (image.width != signature.width || image.height != signature.height ||
        asset.textures[i].srgb != signature.srgb ||
        core::fingerprintImage(image) != signature.fingerprint)
      return false;
  }
  return true;
}

size_t Renderer::uploadedTextureBytes() const {
  return state_->uploaded_texture_bytes;
}

size_t SharedTextures::textureBytes() const {
  return impl_->set->bytes;
}

core::Result<std::shared_ptr<const SharedTextures>> Renderer::shareTextures(AssetId asset) const {
  const State& s = *state_;
  if (asset < 0 || asset >= static_cast<int>(s.assets.size()) || !s.assets[asset])
    return Error{"shareTextures: unknown asset id " + std::to_string(asset)};
  std::shared_ptr<SharedTextures> shared(new SharedTextures());
  shared->impl_->display = s.context.display();
  shared->impl_->context = s.context.handle();
  shared->impl_->set = s.assets[asset]->textures;
  return std::shared_ptr<const SharedTextures>(std::move(shared));
}

core::Result<Renderer::AssetId> Renderer::uploadAsset(const core::Asset& asset) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  if (auto consistent = core::validateAssetReferences(asset); !consistent)
    return Error{asset.source_path + ": " + consistent.error().message};
  GpuAsset gpu;
  if (auto uploaded = uploadGeometry(asset.mesh, asset.materials, state_->ubo_alignment, gpu);
      !uploaded) {
    State::release(gpu);
    return Error{asset.source_path + ": " + uploaded.error().message};
  }
  const SharedTextures* shared = state_->shared_textures.get();
  if (shared && shared->matches(asset)) {
    gpu.textures = shared->impl_->set;  // the objects of the context this one shares
  } else if (auto uploaded = uploadTextures(asset, *gpu.textures); !uploaded) {
    State::release(gpu);
    return uploaded.error();
  } else {
    state_->uploaded_texture_bytes += gpu.textures->bytes;
  }
  GLenum error = glGetError();
  if (error != GL_NO_ERROR) {
    State::release(gpu);
    return Error{asset.source_path + ": uploading to the GPU failed (GL error " +
                 std::to_string(error) + ")"};
  }
  state_->assets.push_back(std::move(gpu));
  return static_cast<AssetId>(state_->assets.size() - 1);
}

core::Result<Renderer::AssetId> Renderer::uploadMesh(AssetId materials_from,
                                                     const core::Mesh& mesh) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  if (materials_from < 0 || materials_from >= static_cast<int>(state_->assets.size()) ||
      !state_->assets[materials_from])
    return Error{"uploadMesh: unknown asset id " + std::to_string(materials_from)};
  const GpuAsset& source = *state_->assets[materials_from];
  GpuAsset gpu;
  if (auto uploaded = uploadGeometry(mesh, source.materials, state_->ubo_alignment, gpu);
      !uploaded) {
    State::release(gpu);
    return Error{"uploadMesh: " + uploaded.error().message};
  }
  gpu.textures = source.textures;
  // The same object, simplified: it keeps the original's bounding sphere (uObjectInfo), so
  // object-space procedural shading (noise_phong scales its noise by the radius) does not shift
  // from level to level.
  gpu.bounds = source.bounds;
  state_->assets.push_back(std::move(gpu));
  return static_cast<AssetId>(state_->assets.size() - 1);
}

void Renderer::releaseAsset(AssetId asset) {
  if (!state_->context.makeCurrent()) return;
  if (asset >= 0 && asset < static_cast<int>(state_->assets.size()) && state_->assets[asset]) {
    State::release(*state_->assets[asset]);
    state_->assets[asset].reset();
  }
}

core::Result<Renderer::ProgramId> Renderer::compileProgram(const GlslSource& source) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  auto program = buildProgram(source);
  if (!program) return program.error();
  state_->programs.push_back(*program);
  state_->program_names[*program] = source.vertex_name + " + " + source.fragment_name;
  return static_cast<ProgramId>(state_->programs.size() - 1);
}

namespace {
// Whether GLSL source names gl_Position outside comments: a vertex stage that never does draws
// nothing, with no error from the GL (a fragment shader given as the vertex stage compiles as one
// when it uses no fragment-only built-in).
bool namesGlPosition(std::string_view text) {
  constexpr std::string_view kName = "gl_Position";
  auto identifier = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  for (size_t i = 0; i < text.size();) {
    if (text.compare(i, 2, "//") == 0) {
      i = text.find('\n', i);
      if (i == std::string_view::npos) return false;
    } else if (text.compare(i, 2, "/*") == 0) {
      i = text.find("*/", i + 2);
      if (i == std::string_view::npos) return false;
      i += 2;
    } else if (text.compare(i, kName.size(), kName) == 0 && (i == 0 || !identifier(text[i - 1])) &&
               (i + kName.size() == text.size() || !identifier(text[i + kName.size()]))) {
      return true;
    } else {
      ++i;
    }
  }
  return false;
}
}  // namespace

core::Result<GLuint> internal::buildProgram(const GlslSource& source) {
  if (!namesGlPosition(source.vertex))
    return Error{source.vertex_name +
                 ": the vertex stage never writes gl_Position, so nothing would be drawn (is it "
                 "the fragment stage?)"};
  auto compile = [](GLenum stage, const std::string& text,
                    const std::string& name) -> core::Result<GLuint> {
    GLuint shader = glCreateShader(stage);
    const char* pointer = text.c_str();
    glShaderSource(shader, 1, &pointer, nullptr);
    glCompileShader(shader);
    GLint compiled = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &compiled);
    if (!compiled) {
      std::string log = shaderLog(shader);
      glDeleteShader(shader);
      return Error{name + ": failed to compile:\n" + log};
    }
    return shader;
  };
  auto vertex = compile(GL_VERTEX_SHADER, source.vertex, source.vertex_name);
  if (!vertex) return vertex.error();
  auto fragment = compile(GL_FRAGMENT_SHADER, source.fragment, source.fragment_name);
  if (!fragment) {
    glDeleteShader(*vertex);
    return fragment.error();
  }
  return linkProgram(*vertex, *fragment, source.vertex_name + " + " + source.fragment_name);
}

core::Result<Renderer::ProgramId> Renderer::compileProgram(const SpirvBinary& binary) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  auto specialize = [](GLenum stage, const std::vector<uint32_t>& words,
                       const char* name) -> core::Result<GLuint> {
    if (words.size() < 5 || words[0] != 0x07230203u)
      return Error{std::string(name) + " SPIR-V: not a SPIR-V module (bad magic number)"};
    GLuint shader = glCreateShader(stage);
    glShaderBinary(1, &shader, GL_SHADER_BINARY_FORMAT_SPIR_V_ARB, words.data(),
                   static_cast<GLsizei>(words.size() * 4));
    glSpecializeShaderARB(shader, "main", 0, nullptr, nullptr);
    GLint compiled = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &compiled);
    if (!compiled) {
      std::string log = shaderLog(shader);
      glDeleteShader(shader);
      return Error{std::string(name) + " SPIR-V: specialization failed:\n" + log};
    }
    return shader;
  };
  auto vertex = specialize(GL_VERTEX_SHADER, binary.vertex, "vertex");
  if (!vertex) return vertex.error();
  auto fragment = specialize(GL_FRAGMENT_SHADER, binary.fragment, "fragment");
  if (!fragment) {
    glDeleteShader(*vertex);
    return fragment.error();
  }
  auto program = linkProgram(*vertex, *fragment, "SPIR-V program");
  if (!program) return program.error();
  std::vector<int>& declared = state_->declared_uniforms[*program];
  declared.clear();  // (a recycled GL name)
  collectUniformLocations(binary.vertex, declared);
  collectUniformLocations(binary.fragment, declared);
  state_->programs.push_back(*program);
  return static_cast<ProgramId>(state_->programs.size() - 1);
}

void Renderer::releaseProgram(ProgramId program) {
  State& s = *state_;
  if (!s.context.makeCurrent()) return;
  if (program >= 0 && program < static_cast<int>(s.programs.size()) && s.programs[program]) {
    // A region program's copy in the helper's context goes with it, deleted there.
    const GLuint id = s.programs[program];
    s.declared_uniforms.erase(id);
    s.forgetProgram(id);
    if (s.region_programs.erase(id) > 0 && s.region_helper) {
      s.region_helper->run([id](internal::RegionHelper::Context& helper) {
        if (auto copy = helper.programs.find(id); copy != helper.programs.end()) {
          glDeleteProgram(copy->second.program);
          helper.programs.erase(copy);
        }
      });
      s.region_helper->wait();
    }
    glDeleteProgram(id);
    s.programs[program] = 0;
  }
}

namespace internal {

AtlasLayout planAtlas(int count, int tile, int max_size, int samples) {
  // ~8M pixels a chunk: 32 MB of colour and as much depth at 1 sample (a 4x4 supersampled
  // reference of 256 px takes 13 chunks of 8 tiles). The framebuffers behind a chunk stay
  // allocated for the renderer's life, as large as its largest chunk, and llvmpipe works through
  // a small atlas faster: against 48M pixels, measured on llvmpipe (2 cores), the 100-sample 4x4
  // reference at 256 px took 0.80-0.96x the time (5 alternations) and `duolod error` at 1024 px
  // 38 s instead of 45-47 s, with peak memory 1.39 -> 0.79 GB (bench_throughput) and 3.5 -> 2.7 GB
  // (bench/RESULTS.md, session 47). Plain renders of up to 256 px at 100 samples still fit one
  // chunk.
  const size_t kBudgetPixels = size_t(8) << 20;
  size_t per_pixel_factor = std::max(1, samples);
  int max_columns = std::max(1, max_size / tile);
  size_t budget_tiles = std::max<size_t>(1, kBudgetPixels / per_pixel_factor / (size_t(tile) * tile));
  int per_chunk = static_cast<int>(std::min<size_t>({size_t(count), budget_tiles,
                                                     size_t(max_columns) * max_columns}));
  AtlasLayout layout;
  layout.columns = std::min(per_chunk, std::max(1, static_cast<int>(std::ceil(std::sqrt(per_chunk)))));
  layout.columns = std::min(layout.columns, max_columns);
  layout.rows = (per_chunk + layout.columns - 1) / layout.columns;
  layout.per_chunk = per_chunk;
  return layout;
}

}  // namespace internal

namespace internal {

// The batch memory check (batch_memory.hpp), kept in this file rather than one of its own so
// that the unity build's batches of eight files stay as they are.
namespace {

// A file's first number ("max", a missing file or one that does not start with a number: -1).
double readBytes(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "r");
  if (!file) return -1;
  double value = -1;
  if (std::fscanf(file, "%lf", &value) != 1) value = -1;
  std::fclose(file);
  return value;
}
// The values of `keys` in a "key value" file (memory.stat; /proc/meminfo with "key: value kB"),
// in one reading; -1 for a key that is not there.
template <size_t N>
std::array<double, N> readKeyed(const std::string& path, const std::array<const char*, N>& keys) {
  std::array<double, N> values;
  values.fill(-1);
  std::FILE* file = std::fopen(path.c_str(), "r");
  if (!file) return values;
  char line[256];
  while (std::fgets(line, sizeof line, file))
    for (size_t i = 0; i < N; ++i) {
      const size_t length = std::strlen(keys[i]);
      if (std::strncmp(line, keys[i], length) == 0 &&
          (line[length] == ' ' || line[length] == ':'))
        std::sscanf(line + length + 1, "%lf", &values[i]);
    }
  std::fclose(file);
  return values;
}

// The tightest memory limit of the process's control group and its ancestors, and what the group
// uses that the kernel cannot reclaim (its usage less its inactive file pages), in bytes; limit
// 0 when there is none. cgroup v2 ("0::/path" in /proc/self/cgroup) or v1 (the line naming the
// memory controller). Inside a container the group's path may not exist under the mount (the
// container sees its own group as the root): the mount's root files stand for it then.
void readGroupLimit(const std::string& root, double& limit, double& in_use) {
  limit = 0, in_use = 0;
  std::FILE* file = std::fopen((root + "/proc/self/cgroup").c_str(), "r");
  if (!file) return;
  std::string v2_path, v1_path;
  bool v2 = false, v1 = false;
  char line[1024];
  while (std::fgets(line, sizeof line, file)) {
    std::string text(line);
    if (!text.empty() && text.back() == '\n') text.pop_back();
    const size_t first = text.find(':'), second = text.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = text.substr(first + 1, second - first - 1);
    const std::string path = text.substr(second + 1);
    if (text.compare(0, first, "0") == 0 && controllers.empty()) v2 = true, v2_path = path;
    for (size_t at = 0; at <= controllers.size();) {
      const size_t end = std::min(controllers.find(',', at), controllers.size());
      if (controllers.compare(at, end - at, "memory") == 0) v1 = true, v1_path = path;
      at = end + 1;
    }
  }
  std::fclose(file);
  if (!v1 && !v2) return;
  // v1 when the memory controller is on a v1 hierarchy (a hybrid system lists both).
  const std::string mount = root + (v1 ? "/sys/fs/cgroup/memory" : "/sys/fs/cgroup");
  const char* limit_file = v1 ? "/memory.limit_in_bytes" : "/memory.max";
  const char* usage_file = v1 ? "/memory.usage_in_bytes" : "/memory.current";
  const char* inactive_key = v1 ? "total_inactive_file" : "inactive_file";
  std::string group = v1 ? v1_path : v2_path;
  if (group.empty() || group[0] != '/') group = "/" + group;
  while (group.size() > 1 && group.back() == '/') group.pop_back();
  if (readBytes(mount + (group == "/" ? "" : group) + usage_file) < 0) group = "/";
  const std::string own = mount + (group == "/" ? "" : group);
  // The group and its ancestors up to the mount's root: the tightest limit holds. (v1 reports
  // "no limit" as a number near 2^63.)
  for (std::string at = group;;) {
    const double value = readBytes(mount + (at == "/" ? "" : at) + limit_file);
    if (value > 0 && value < 1e18 && (limit == 0 || value < limit)) limit = value;
    if (at == "/") break;
    const size_t slash = at.find_last_of('/');
    at = slash == 0 ? "/" : at.substr(0, slash);
  }
  const double usage = readBytes(own + usage_file);
  const double inactive = readKeyed<1>(own + "/memory.stat", {inactive_key})[0];
  if (usage > 0) in_use = std::max(0.0, usage - std::max(0.0, inactive));
}

double batchBytes(size_t count, int tile, size_t bytes_per_pixel) {
  return double(count) * double(tile) * double(tile) * double(bytes_per_pixel);
}

}  // namespace

MachineMemory readMachineMemory(const std::string& root, double physical) {
  MachineMemory memory;
  memory.total = physical > 0 ? physical : 0;
  // "MemAvailable:   12345678 kB" (Linux 3.14 on); without it the available figure is unknown.
  const auto [available_kb, swap_free_kb] =
      readKeyed<2>(root + "/proc/meminfo", {"MemAvailable", "SwapFree"});
  if (available_kb >= 0) memory.available = (available_kb + std::max(0.0, swap_free_kb)) * 1024.0;
  double limit = 0, in_use = 0;
  readGroupLimit(root, limit, in_use);
  if (limit > 0) {
    if (memory.total == 0 || limit < memory.total) memory.total = limit, memory.group_limit = true;
    const double left = std::max(limit - in_use, 1.0);  // 0 would read as unknown
    if (memory.available == 0 || left < memory.available) memory.available = left;
  }
  return memory;
}

MachineMemory machineMemory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page_size = sysconf(_SC_PAGESIZE);
  return readMachineMemory("", pages > 0 && page_size > 0 ? double(pages) * double(page_size) : 0);
}

core::Status checkBatchMemory(size_t count, int tile, size_t bytes_per_pixel, const char* as,
                              const MachineMemory& memory) {
  const double needed = batchBytes(count, tile, bytes_per_pixel);
  char text[320];
  if (memory.total > 0 && needed > memory.total) {
    std::snprintf(text, sizeof text,
                  "render: %zu images of %d x %d pixels take %.1f GB %s, more than %s %.1f GB of "
                  "memory: render fewer pixels or samples",
                  count, tile, tile, needed / 1e9, as,
                  memory.group_limit ? "the process's control group's limit of" : "this machine's",
                  memory.total / 1e9);
    return core::Error{text};
  }
  if (memory.available > 0 && needed > memory.available) {
    std::snprintf(text, sizeof text,
                  "render: %zu images of %d x %d pixels take %.1f GB %s, more than the %.1f GB "
                  "of memory available now (of %s %.1f GB): render fewer pixels or samples, or "
                  "free memory",
                  count, tile, tile, needed / 1e9, as, memory.available / 1e9,
                  memory.group_limit ? "the control group's" : "this machine's",
                  memory.total / 1e9);
    return core::Error{text};
  }
  return core::okStatus();
}

core::Status checkBatchMemory(size_t count, int tile, size_t bytes_per_pixel, const char* as) {
  // Reading the figures takes ~0.1 ms (a few /proc and /sys files), and the pair search and the
  // shader searches render thousands of small batches: one below kSmallBatchBytes is let through.
  if (batchBytes(count, tile, bytes_per_pixel) <= kSmallBatchBytes) return core::okStatus();
  return checkBatchMemory(count, tile, bytes_per_pixel, as, machineMemory());
}

core::Status checkRequest(const Renderer::State& s, Renderer::AssetId asset,
                          Renderer::ProgramId program, std::span<const Sample> samples,
                          const RenderOptions& options) {
  if (asset < 0 || asset >= static_cast<int>(s.assets.size()) || !s.assets[asset])
    return Error{"render: unknown asset id " + std::to_string(asset)};
  if (program < 0 || program >= static_cast<int>(s.programs.size()) || !s.programs[program])
    return Error{"render: unknown program id " + std::to_string(program)};
  if (samples.empty()) return Error{"render: no samples to render"};
  if (options.resolution < 1 || options.supersample < 1 || options.supersample > 16)
    return Error{"render: resolution must be >= 1 and supersampling 1..16"};
  if (options.count_work && !s.work_queries.available)
    return Error{"render: counting work needs ARB_pipeline_statistics_query, which " +
                 s.context.description() + " lacks"};
  if (options.resolution * options.supersample > s.max_size)
    return Error{"render: a " + std::to_string(options.resolution * options.supersample) +
                 "-pixel tile exceeds the device's " + std::to_string(s.max_size) + " limit"};
  // The shaders measure distances in 32-bit floats (normalize, length and dot of eye − position,
  // light − position), whose squares overflow above ~1.8e19: beyond that every shader's lighting
  // and llvmpipe's clipping go to inf or NaN and the image comes out empty (an asset 1e20 units
  // across did, with the constant shader too). A clear refusal instead, with room to spare.
  auto largest = [](core::Vec3 p) {
    return std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  };
  // The first of `what` that reaches too far (NaN counts), or none.
  auto refusal = [&](const std::string& what, core::Vec3 p) -> std::optional<Error> {
    const float reach = largest(p);
    if (reach <= kLargestRenderableCoordinate) return std::nullopt;
    char figures[64];
    std::snprintf(figures, sizeof figures, "%.3g units from the origin; renders stop at %.3g",
                  double(reach), double(kLargestRenderableCoordinate));
    return Error{"render: " + what + " reaches " + figures + " (the GPU's 32-bit shading " +
                 "squares distances, which overflow above ~1.8e19): scale the asset down " +
                 "(e.g. to metres)"};
  };
  const core::Sphere& bounds = s.assets[asset]->bounds;
  const float r = bounds.radius;
  const core::Vec3 sphere_reach{std::fabs(bounds.center.x) + r, std::fabs(bounds.center.y) + r,
                                std::fabs(bounds.center.z) + r};
  if (auto refused = refusal("the asset's bounding sphere", sphere_reach)) return *refused;
  if (!(r >= kSmallestRenderableRadius)) {
    char figures[96];
    std::snprintf(figures, sizeof figures, "has radius %.3g; renders need at least %.3g", double(r),
                  double(kSmallestRenderableRadius));
    return Error{std::string("render: the asset's bounding sphere ") + figures +
                 " (the GPU's 32-bit shading squares distances, which vanish below ~1e-19): "
                 "scale the asset up"};
  }
  for (size_t i = 0; i < samples.size(); ++i) {
    const Sample& sample = samples[i];
    const std::string name = "sample " + std::to_string(i) + "'s ";
    const core::Vec3 offset{sample.placement.at(0, 3), sample.placement.at(1, 3),
                            sample.placement.at(2, 3)};
    for (const auto& [part, p] : {std::pair{"camera", sample.eye}, std::pair{"light", sample.light},
                                  std::pair{"placement", offset}})
      if (auto refused = refusal(name + part, p)) return *refused;
  }
  return core::okStatus();
}

}  // namespace internal

namespace {

// drawChunk(), inside the work queries when counting.
int drawCounted(Renderer::State& s, ChunkDrawer& drawer, bool count_work, int first, int count,
                int tile, const AtlasLayout& layout, GLsizeiptr stride, WorkCounts& work) {
  if (count_work) s.work_queries.begin();
  int draws = drawer.drawChunk(first, count, tile, layout, stride);
  if (count_work) {
    s.work_queries.end();
    s.work_queries.addResults(work);
  }
  return draws;
}

}  // namespace

core::Result<ImageBatch8> Renderer::render(AssetId asset_id, ProgramId program_id,
                                           std::span<const Sample> samples,
                                           const RenderOptions& options, RenderStats* stats) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  State& s = *state_;
  if (auto ok = checkRequest(s, asset_id, program_id, samples, options); !ok) return ok.error();
  if (options.supersample != 1)
    return Error{"render: use renderReference() for supersampled images"};
  if (auto fits = checkBatchMemory(samples.size(), options.resolution, 4, "as 8-bit RGBA"); !fits)
    return fits.error();
  auto start = std::chrono::steady_clock::now();
  const GpuAsset& asset = *s.assets[asset_id];
  int tile = options.resolution;
  int count = static_cast<int>(samples.size());
  AtlasLayout layout = planAtlas(count, tile, s.max_size, options.msaa_samples);
  GLsizeiptr stride = roundUp(sizeof(FrameBlock), s.ubo_alignment);
  const GLuint program = s.programs[program_id];
  ChunkDrawer drawer{s, asset, program};
  drawer.uploadFrames(samples, stride);
  const internal::SlowRequestWatch watch(s.firstDraw(program, State::kRenderRequest),
                                         "rendering %d image%s of %d px with %s", count,
                                         pluralS(count), tile, s.programName(program));

  ImageBatch8 batch;
  batch.width = batch.height = tile;
  batch.count = count;
  batch.pixels.resize(size_t(count) * tile * tile * 4);
  int width = layout.columns * tile, height = layout.rows * tile;
  std::vector<uint8_t> atlas_pixels(size_t(width) * height * 4);
  RenderStats local;
  for (int first = 0; first < count; first += layout.per_chunk) {
    int n = std::min(layout.per_chunk, count - first);
    if (auto ok = ensureFramebuffer(s.atlas, width, height, options.msaa_samples, GL_RGBA8, true,
                                    false);
        !ok)
      return ok.error();
    beginDrawing(s.atlas);
    local.draws += drawCounted(s, drawer, options.count_work, first, n, tile, layout, stride,
                               local.work);
    GLuint read_fbo = s.atlas.fbo;
    if (options.msaa_samples > 0) {
      if (auto ok = ensureFramebuffer(s.resolved, width, height, 0, GL_RGBA8, false, false); !ok)
        return ok.error();
      glDisable(GL_SCISSOR_TEST);
      glBlitNamedFramebuffer(s.atlas.fbo, s.resolved.fbo, 0, 0, width, height, 0, 0, width,
                             height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
      read_fbo = s.resolved.fbo;
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, read_fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    int used_rows = (n + layout.columns - 1) / layout.columns;
    glReadPixels(0, 0, width, used_rows * tile, GL_RGBA, GL_UNSIGNED_BYTE, atlas_pixels.data());
    scatterTiles(atlas_pixels, width, layout, tile, first, n, batch);
    ++local.chunks;
  }
  glDisable(GL_SCISSOR_TEST);
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return Error{"render: OpenGL error " + std::to_string(error)};
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return batch;
}

core::Result<ImageBatchF> Renderer::renderReference(AssetId asset_id, ProgramId program_id,
                                                    std::span<const Sample> samples,
                                                    const RenderOptions& options,
                                                    RenderStats* stats) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  State& s = *state_;
  if (auto ok = checkRequest(s, asset_id, program_id, samples, options); !ok) return ok.error();
  if (auto fits =
          checkBatchMemory(samples.size(), options.resolution, 4 * sizeof(float), "as float RGBA");
      !fits)
    return fits.error();
  auto start = std::chrono::steady_clock::now();
  const GpuAsset& asset = *s.assets[asset_id];
  int k = options.supersample;
  int tile = options.resolution, big_tile = tile * k;
  int count = static_cast<int>(samples.size());
  AtlasLayout layout = planAtlas(count, big_tile, s.max_size, options.msaa_samples);
  GLsizeiptr stride = roundUp(sizeof(FrameBlock), s.ubo_alignment);
  const GLuint program = s.programs[program_id];
  ChunkDrawer drawer{s, asset, program};
  drawer.uploadFrames(samples, stride);
  const internal::SlowRequestWatch watch(
      s.firstDraw(program, State::kReferenceRequest),
      "rendering %d reference%s of %d px (%dx%d supersampled) with %s", count, pluralS(count), tile,
      k, k, s.programName(program));

  ImageBatchF batch;
  batch.width = batch.height = tile;
  batch.count = count;
  batch.pixels.resize(size_t(count) * tile * tile * 4);
  int big_width = layout.columns * big_tile, big_height = layout.rows * big_tile;
  int width = layout.columns * tile, height = layout.rows * tile;
  std::vector<float> atlas_pixels(size_t(width) * height * 4);
  RenderStats local;
  for (int first = 0; first < count; first += layout.per_chunk) {
    int n = std::min(layout.per_chunk, count - first);
    if (auto ok = ensureFramebuffer(s.atlas, big_width, big_height, options.msaa_samples, GL_RGBA8,
                                    true, false);
        !ok)
      return ok.error();
    beginDrawing(s.atlas);
    local.draws += drawCounted(s, drawer, options.count_work, first, n, big_tile, layout, stride,
                               local.work);
    glDisable(GL_SCISSOR_TEST);
    // The box filter reads a single-sample texture: resolve (or copy) the atlas into one.
    if (auto ok = ensureFramebuffer(s.resolved, big_width, big_height, 0, GL_RGBA8, false, true);
        !ok)
      return ok.error();
    glBlitNamedFramebuffer(s.atlas.fbo, s.resolved.fbo, 0, 0, big_width, big_height, 0, 0,
                           big_width, big_height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    if (auto ok = ensureFramebuffer(s.reference_float, width, height, 0, GL_RGBA32F, false, true);
        !ok)
      return ok.error();
    glBindFramebuffer(GL_FRAMEBUFFER, s.reference_float.fbo);
    glViewport(0, 0, width, height);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glUseProgram(s.downsample_program);
    glUniform1i(0, k);
    glBindTextureUnit(0, s.resolved.color);
    glBindVertexArray(s.empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    int used_rows = (n + layout.columns - 1) / layout.columns;
    glReadPixels(0, 0, width, used_rows * tile, GL_RGBA, GL_FLOAT, atlas_pixels.data());
    scatterTiles(atlas_pixels, width, layout, tile, first, n, batch);
    ++local.chunks;
  }
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return Error{"renderReference: OpenGL error " + std::to_string(error)};
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return batch;
}

}  // namespace duolod::render
