// duolod shader: the GLSL/HLSL front end (glslang → SPIR-V for OpenGL), validation, the clean-up
// of evaluation copies (SPIRV-Tools passes) and cross-compilation to GLSL 450, GLSL ES 300 and HLSL
// (SPIRV-Cross). The SPIR-V IR (src/shader/ir.hpp), rules, cost model and searches build on this.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"

namespace duolod::shader {

enum class Stage { kVertex, kTessControl, kTessEvaluation, kGeometry, kFragment };
enum class Language { kGlsl, kHlsl };

struct CompileOptions {
  Language language = Language::kGlsl;
  std::string entry_point = "main";
  std::vector<std::string> include_dirs;  // for #include "..."
  std::vector<std::pair<std::string, std::string>> defines;
  // Let glslang assign locations to stage inputs/outputs and loose uniforms, and bindings to
  // samplers and blocks, that the source leaves unqualified (WebGL-style shaders). The assignment
  // follows declaration order, so stages must declare varyings alike. HLSL's stage inputs and
  // outputs are always assigned so; its resources are bound by register(), and without this
  // option a live resource without one (or a global outside a cbuffer) is an error naming it.
  bool auto_map_locations = false;
  // HLSL vertex stage: each vertex input's location by its semantic, as Direct3D binds vertex
  // streams by semantic. Keys are canonical semantics: upper case with the index ("POSITION0",
  // "TEXCOORD1"). An input whose semantic is not listed is an error naming it and the ones that
  // are; a listed semantic wins over [[vk::location(N)]]. Empty: [[vk::location(N)]], else
  // declaration order. render::hlslVertexInputLocations gives duolod's interface.
  std::map<std::string, uint32_t> vertex_input_locations;
};

// Compiles one stage to SPIR-V for OpenGL 4.5 (ARB_gl_spirv), with debug names kept and no
// optimisation, so later passes and emitters see the program as written. Errors carry the file
// name and line from glslang's log.
core::Result<std::vector<uint32_t>> compileToSpirv(const std::string& source, Stage stage,
                                                   const std::string& file_name,
                                                   const CompileOptions& options = {});

// Validates a module with SPIRV-Tools for SPV_ENV_OPENGL_4_5; the error names what is wrong.
core::Status validateSpirv(const std::vector<uint32_t>& words, const std::string& what);

// ---- cross-compilation (SPIRV-Cross) ----

enum class Target {
  kGlsl450,    // #version 450 core, explicit locations and bindings kept
  kGlslEs300,  // #version 300 es, highp defaults (ES 3.0 has no binding qualifiers)
  kHlsl50,     // HLSL shader model 5.0, entry point "main"
};
const char* targetName(Target target);

// Emits source for `target` from a SPIR-V module (use the unoptimised module: names are kept, so
// the output reads like the input). `what` names the module in errors. An HLSL vertex stage's
// input at a location listed in `hlsl_vertex_semantics` gets that semantic (e.g. 0 → "POSITION0",
// so that an engine binds its streams by name, as Direct3D does); an unlisted one is
// TEXCOORD<location>, SPIRV-Cross's default.
core::Result<std::string> crossCompile(
    const std::vector<uint32_t>& words, Target target, const std::string& what,
    const std::map<uint32_t, std::string>& hlsl_vertex_semantics = {});
// HLSL source as GLSL 450, so that an HLSL shader goes wherever duolod takes GLSL (the renderer,
// the rules, `duolod shader` and `generate`): compiled by glslang's HLSL front end (entry point
// `options.entry_point`; stage inputs and outputs get locations in declaration order), legalized
// by SPIRV-Tools (every function inlined into the entry point), then emitted by SPIRV-Cross. Each
// texture sampled with a SamplerState becomes one sampler2D named and bound as the texture
// (`Texture2D uBaseColorTexture : register(t0)` → `sampler2D uBaseColorTexture` at binding 0);
// cbuffers keep their register's binding (b0 → 0); vertex inputs take their locations by semantic
// from CompileOptions::vertex_input_locations, else their [[vk::location(N)]]. A resource without
// a register() is an error. One stage alone cannot match varyings by semantic:
// use hlslPairToGlsl for a vertex + pixel pair.
core::Result<std::string> hlslToGlsl(const std::string& source, Stage stage,
                                     const std::string& file_name,
                                     const CompileOptions& options = {});

// An HLSL vertex + pixel shader pair as GLSL 450, each stage as hlslToGlsl, with the varyings
// matched by semantic as Direct3D matches them (case-insensitive, TEXCOORD = TEXCOORD0): each
// fragment input takes the location of the vertex output with its semantic, whatever order the
// two stages declare them in, and may read a subset of them. A fragment input that no vertex
// output writes is an error naming it and its semantic.
struct GlslPair {
  std::string vertex, fragment;
};
core::Result<GlslPair> hlslPairToGlsl(const std::string& vertex_source,
                                      const std::string& vertex_file,
                                      const std::string& fragment_source,
                                      const std::string& fragment_file,
                                      const CompileOptions& vertex_options = {},
                                      const CompileOptions& fragment_options = {});

// A SPIR-V module's `stage` entry point as GLSL 450 (SPIRV-Cross), so that compiled shaders go
// wherever duolod takes GLSL (the CLI's --vert/--frag take .spv files). The module must validate
// for OpenGL 4.5 or Vulkan 1.0-1.3 and hold an entry point of `stage`; errors name `file_name`
// and what is wrong (not a SPIR-V file, invalid, the stages it holds instead). HLSL-born modules
// are legalized first (as hlslToGlsl does); separate textures and samplers become one sampler2D
// named and bound as the texture; a push-constant block becomes a uniform block at the first
// binding from 32 up that no block takes. `entry_point` names the entry point to take; empty:
// the module's first one of `stage`.
core::Result<std::string> spirvToGlsl(const std::vector<uint32_t>& words, Stage stage,
                                      const std::string& file_name,
                                      const std::string& entry_point = "");

// SPIR-V modules (file name, words) used together as one OpenGL program, each valid: an error
// naming both when two resources of one kind (uniform blocks, storage blocks, textures, images)
// in different descriptor sets take one binding, which OpenGL, having no sets, would make one
// binding point. spirvToGlsl checks each module on its own; this checks a vertex module against
// its fragment module.
core::Status checkBindingsAcrossSets(
    const std::vector<std::pair<std::string, std::vector<uint32_t>>>& modules);

// Checks a vertex + fragment pair against what duolod feeds it (shaders/INTERFACE.md, moved by
// `bindings`). An error for what cannot render right: a fragment input that no vertex output at
// its location writes, or one of another type (SPIR-V stages link by location unchecked); two
// sampler types on one texture unit (OpenGL refuses the draw). Warnings, naming file and
// variable, for what reads zeros: a vertex input no stream feeds, a texture at a unit nothing is
// bound to or not 2D, a uniform block other than Frame and Material, a storage block, a loose
// uniform. Compile errors are returned as they are.
core::Result<std::vector<std::string>> checkShaderInterface(const render::GlslSource& source,
                                                            const render::Bindings& bindings = {});

// Re-compiles emitted source with glslang as a check: GLSL 450 to SPIR-V (validated), GLSL ES 300
// with the ES profile, HLSL with the HLSL front end (entry "main"). The error names `what`.
core::Status checkCrossCompiled(const std::string& source, Target target, Stage stage,
                                const std::string& what);

// ---- evaluation copy ----

enum class OptimizationLevel {
  kCleanup,      // dead code, dead constants, constant folding, CFG clean-up
  kPerformance,  // SPIRV-Tools' performance recipe (inlining, SSA, folding, dead code...)
};
// Runs SPIRV-Tools' public passes on a copy meant for rendering and timing (never for the
// readable output), then validates the result. Errors name `what`.
core::Result<std::vector<uint32_t>> optimizeForEvaluation(
    const std::vector<uint32_t>& words, const std::string& what,
    OptimizationLevel level = OptimizationLevel::kPerformance);
// While one of these lives (on any thread), optimizeForEvaluation remembers its successful
// results by input (a search optimises the same stages again and again; up to 64 MB); when the
// last one ends the memory is released. lod::generateLod and shader::runShaderLod hold one.
class OptimizationMemoScope {
 public:
  OptimizationMemoScope();
  ~OptimizationMemoScope();
  OptimizationMemoScope(const OptimizationMemoScope&) = delete;
  OptimizationMemoScope& operator=(const OptimizationMemoScope&) = delete;
};

}  // namespace duolod::shader
