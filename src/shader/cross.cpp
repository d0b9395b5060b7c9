// SPIR-V → GLSL 450 / GLSL ES 300 / HLSL 5.0 through SPIRV-Cross's C++ API (Debian
// libspirv-cross-c-shared-dev static libraries), with explicit options, and the re-compile check of
// what it emits through glslang.
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>

#include <cctype>
#include <exception>
#include <map>
#include <optional>
#include <set>
#include <spirv-tools/libspirv.hpp>
#include <spirv-tools/optimizer.hpp>
#include <spirv_glsl.hpp>
#include <spirv_hlsl.hpp>

#include "duolod/shader.hpp"

namespace duolod::shader {
namespace {
using core::Error;

EShLanguage glslangStage(Stage stage) {
  switch (stage) {
    case Stage::kVertex: return EShLangVertex;
    case Stage::kTessControl: return EShLangTessControl;
    case Stage::kTessEvaluation: return EShLangTessEvaluation;
    case Stage::kGeometry: return EShLangGeometry;
    case Stage::kFragment: return EShLangFragment;
  }
  return EShLangVertex;
}

void setGlslOptions(spirv_cross::CompilerGLSL& compiler, Target target) {
  spirv_cross::CompilerGLSL::Options options;
  options.vulkan_semantics = false;
  options.separate_shader_objects = false;
  options.emit_line_directives = false;
  options.force_zero_initialized_variables = false;
  if (target == Target::kGlslEs300) {
    options.es = true;
    options.version = 300;
    // highp everywhere: the ES output must compute what the desktop one does.
    options.fragment.default_float_precision = spirv_cross::CompilerGLSL::Options::Highp;
    options.fragment.default_int_precision = spirv_cross::CompilerGLSL::Options::Highp;
  } else {
    options.es = false;
    options.version = 450;
    options.enable_420pack_extension = true;
  }
  compiler.set_common_options(options);
}

// HLSL as glslang emits it is not yet legal for OpenGL: a texture or sampler passed to a function
// is copied into a function-local variable (SPIRV-Cross then declared such a copy a uniform of its
// own, with no binding: sampled from unit 0), and the entry point is a function called from
// main(). SPIRV-Tools' legalization passes (the ones DXC and glslang's optimizer run for HLSL:
// exhaustive inlining, then forwarding loads and stores through locals) make each sample read the
// resource itself, and leave one function, so the rules see the whole shader as they see GLSL's.
core::Result<std::vector<uint32_t>> legalize(const std::vector<uint32_t>& words,
                                             spv_target_env environment,
                                             const std::string& file_name) {
  spvtools::Optimizer optimizer(environment);
  std::string messages;
  optimizer.SetMessageConsumer(
      [&](spv_message_level_t severity, const char*, const spv_position_t&, const char* message) {
        if (severity <= SPV_MSG_ERROR) messages += std::string(message) + "\n";
      });
  optimizer.RegisterLegalizationPasses();
  std::vector<uint32_t> legal;
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);  // validated before and after, with our messages
  if (!optimizer.Run(words.data(), words.size(), &legal, options))
    return Error{file_name + ": SPIRV-Tools could not legalize the HLSL's SPIR-V: " + messages};
  spvtools::SpirvTools tools(environment);
  std::string problems;
  tools.SetMessageConsumer(
      [&](spv_message_level_t, const char*, const spv_position_t& position, const char* message) {
        problems += "word " + std::to_string(position.index) + ": " + message + "\n";
      });
  if (!tools.Validate(legal)) return Error{file_name + " (legalized): invalid SPIR-V: " + problems};
  return legal;
}

core::Result<std::vector<uint32_t>> legalizeHlsl(const std::vector<uint32_t>& words,
                                                 const std::string& file_name) {
  return legalize(words, SPV_ENV_OPENGL_4_5, file_name);
}

// The language of a module's OpSource, if it has one.
std::optional<spv::SourceLanguage> sourceLanguage(const std::vector<uint32_t>& words) {
  for (size_t at = 5; at < words.size();) {
    const uint32_t count = words[at] >> 16, opcode = words[at] & 0xffff;
    if (count == 0 || at + count > words.size()) break;
    if (opcode == spv::OpSource && count >= 2)
      return static_cast<spv::SourceLanguage>(words[at + 1]);
    if (opcode == spv::OpFunction) break;  // debug instructions come before any function
    at += count;
  }
  return std::nullopt;
}

}  // namespace

const char* targetName(Target target) {
  switch (target) {
    case Target::kGlsl450: return "GLSL 450";
    case Target::kGlslEs300: return "GLSL ES 300";
    case Target::kHlsl50: return "HLSL 5.0";
  }
  return "?";
}

core::Result<std::string> crossCompile(
    const std::vector<uint32_t>& words, Target target, const std::string& what,
    const std::map<uint32_t, std::string>& hlsl_vertex_semantics) {
  // SPIRV-Cross trusts its input (a corrupt module crashed its parser): validated first.
  if (auto valid = validateSpirv(words, what); !valid) return valid.error();
  // SPIRV-Cross reports unsupported constructs by throwing CompilerError.
  try {
    if (target == Target::kHlsl50) {
      spirv_cross::CompilerHLSL compiler(words);
      spirv_cross::CompilerHLSL::Options hlsl;
      hlsl.shader_model = 50;
      // HLSL has no gl_PointSize; writes of 1.0 (the only size D3D draws) are dropped rather than
      // failing the whole shader (the glTF Sample Viewer's vertex shader writes it).
      hlsl.point_size_compat = true;
      hlsl.use_entry_point_name = false;  // "main", which checkCrossCompiled expects
      compiler.set_hlsl_options(hlsl);
      if (!hlsl_vertex_semantics.empty() &&
          compiler.get_execution_model() == spv::ExecutionModelVertex) {
        // An input at a location without a stream would get SPIRV-Cross's TEXCOORD<location>,
        // which may be a semantic given to a stream (TEXCOORD1 at location 1): each gets the
        // first TEXCOORD<k> no other input has.
        std::map<uint32_t, std::string> semantics = hlsl_vertex_semantics;
        std::set<std::string> used;
        for (const auto& [location, semantic] : semantics) used.insert(semantic);
        uint32_t next = 0;
        for (const spirv_cross::Resource& input : compiler.get_shader_resources().stage_inputs) {
          const uint32_t location = compiler.get_decoration(input.id, spv::DecorationLocation);
          if (semantics.count(location)) continue;
          while (used.count("TEXCOORD" + std::to_string(next))) ++next;
          semantics[location] = "TEXCOORD" + std::to_string(next);
          used.insert(semantics[location]);
        }
        for (const auto& [location, semantic] : semantics)
          compiler.add_vertex_attribute_remap({location, semantic});
      }
      spirv_cross::CompilerGLSL::Options common;
      common.vertex.flip_vert_y = false;
      common.vertex.fixup_clipspace = false;  // keep OpenGL's clip space; the reader's engine maps it
      compiler.set_common_options(common);
      return compiler.compile();
    }
    spirv_cross::CompilerGLSL compiler(words);
    setGlslOptions(compiler, target);
    return compiler.compile();
  } catch (const std::exception& error) {
    return Error{what + ": SPIRV-Cross (" + targetName(target) + "): " + error.what()};
  }
}

namespace {

const char* executionModelName(spv::ExecutionModel model) {
  switch (model) {
    case spv::ExecutionModelVertex:
      return "vertex";
    case spv::ExecutionModelTessellationControl:
      return "tessellation control";
    case spv::ExecutionModelTessellationEvaluation:
      return "tessellation evaluation";
    case spv::ExecutionModelGeometry:
      return "geometry";
    case spv::ExecutionModelFragment:
      return "fragment";
    case spv::ExecutionModelGLCompute:
      return "compute";
    default:
      return "other";
  }
}

spv::ExecutionModel executionModelOf(Stage stage) {
  switch (stage) {
    case Stage::kVertex:
      return spv::ExecutionModelVertex;
    case Stage::kTessControl:
      return spv::ExecutionModelTessellationControl;
    case Stage::kTessEvaluation:
      return spv::ExecutionModelTessellationEvaluation;
    case Stage::kGeometry:
      return spv::ExecutionModelGeometry;
    case Stage::kFragment:
      return spv::ExecutionModelFragment;
  }
  return spv::ExecutionModelVertex;
}

// OpenGL has no descriptor sets: the GLSL keeps each resource's binding and drops its set, so
// two resources of one kind in different sets at one binding (Vulkan's usual set 0 per frame, set
// 1 per material, both from binding 0) would share a binding point and one would read the
// other's data, silently. Refused with both named, not guessed apart. One resource seen by both
// stages (one set and binding) is one resource.
struct BoundResource {
  uint32_t set;
  std::string name, file;
};
using BindingsOfKind = std::map<std::string, std::map<uint32_t, BoundResource>>;

core::Status addBindings(const spirv_cross::Compiler& compiler,
                         const spirv_cross::ShaderResources& resources,
                         const std::string& file_name, BindingsOfKind& seen) {
  struct Kind {
    const char* name;
    std::vector<const spirv_cross::SmallVector<spirv_cross::Resource>*> lists;
  };
  for (const Kind& kind :
       {Kind{"uniform blocks", {&resources.uniform_buffers}},
        Kind{"storage blocks", {&resources.storage_buffers}},
        Kind{"textures", {&resources.sampled_images, &resources.separate_images}},
        Kind{"images", {&resources.storage_images}}}) {
    std::map<uint32_t, BoundResource>& first_at = seen[kind.name];
    for (const auto* list : kind.lists)
      for (const spirv_cross::Resource& resource : *list) {
        if (!compiler.has_decoration(resource.id, spv::DecorationBinding)) continue;
        const uint32_t binding = compiler.get_decoration(resource.id, spv::DecorationBinding);
        const uint32_t set = compiler.get_decoration(resource.id, spv::DecorationDescriptorSet);
        auto [found, added] =
            first_at.emplace(binding, BoundResource{set, resource.name, file_name});
        if (added || found->second.set == set) continue;
        const BoundResource& first = found->second;
        return Error{first.file + ": " + kind.name + " '" + first.name + "' (set " +
                     std::to_string(first.set) + ") and " +
                     (first.file == file_name ? std::string() : file_name + "'s ") + "'" +
                     resource.name + "' (set " + std::to_string(set) + ") both take binding " +
                     std::to_string(binding) +
                     "; OpenGL has no descriptor sets, so one would read the other's data: "
                     "compile the shaders with bindings that differ across their sets"};
      }
  }
  return core::okStatus();
}

}  // namespace

core::Result<std::string> spirvToGlsl(const std::vector<uint32_t>& words, Stage stage,
                                      const std::string& file_name,
                                      const std::string& entry_point) {
  constexpr uint32_t kMagic = 0x07230203;
  if (words.size() < 5 || words[0] != kMagic)
    return Error{
        file_name + ": not a SPIR-V module (" +
        (words.empty() ? std::string("empty") : "it does not start with the magic number") + ")"};
  // SPIRV-Cross trusts its input: validated first, for OpenGL or for Vulkan (an engine's
  // shaders are often compiled for Vulkan; SPIRV-Cross's GLSL drops what OpenGL lacks).
  std::optional<spv_target_env> environment;
  std::string vulkan_messages;
  core::Status valid = validateSpirv(words, file_name);
  if (valid) {
    environment = SPV_ENV_OPENGL_4_5;
  } else {
    for (spv_target_env vulkan :
         {SPV_ENV_VULKAN_1_0, SPV_ENV_VULKAN_1_1, SPV_ENV_VULKAN_1_2, SPV_ENV_VULKAN_1_3}) {
      spvtools::SpirvTools tools(vulkan);
      vulkan_messages.clear();
      tools.SetMessageConsumer([&](spv_message_level_t, const char*, const spv_position_t&,
                                   const char* message) { vulkan_messages += message; });
      if (tools.Validate(words)) {
        environment = vulkan;
        break;
      }
    }
    if (!environment)
      return Error{valid.error().message + " (and for Vulkan 1.3: " + vulkan_messages + ")"};
  }
  std::vector<uint32_t> module = words;
  if (sourceLanguage(words) == spv::SourceLanguageHLSL) {
    // As the HLSL input path does (legalizeHlsl): textures and samplers passed to functions
    // become reads of the resources themselves, which SPIRV-Cross's GLSL needs.
    auto legal = legalize(words, *environment, file_name);
    if (!legal) return legal.error();
    module = std::move(*legal);
  }
  try {
    spirv_cross::CompilerGLSL compiler(module);
    const spv::ExecutionModel wanted = executionModelOf(stage);
    std::string held;
    for (const spirv_cross::EntryPoint& entry : compiler.get_entry_points_and_stages()) {
      if (entry.execution_model == wanted && (entry_point.empty() || entry.name == entry_point)) {
        compiler.set_entry_point(entry.name, entry.execution_model);
        setGlslOptions(compiler, Target::kGlsl450);
        spirv_cross::CompilerGLSL::Options options = compiler.get_common_options();
        options.emit_push_constant_as_uniform_buffer = true;  // GLSL has no push constants
        compiler.set_common_options(options);
        // ...and OpenGL needs the block a binding: the first one from 32 up that no uniform block
        // takes, past every binding a bindings file can give Frame or Material (0-31), so that
        // it reads zeros (the interface check says so) instead of another block's data.
        const spirv_cross::ShaderResources resources = compiler.get_shader_resources();
        BindingsOfKind seen;
        if (auto distinct = addBindings(compiler, resources, file_name, seen); !distinct)
          return distinct.error();
        std::set<uint32_t> taken;
        for (const spirv_cross::Resource& block : resources.uniform_buffers)
          taken.insert(compiler.get_decoration(block.id, spv::DecorationBinding));
        uint32_t free_binding = 32;
        for (const spirv_cross::Resource& block : resources.push_constant_buffers) {
          while (taken.count(free_binding)) ++free_binding;
          compiler.set_decoration(block.id, spv::DecorationBinding, free_binding);
          taken.insert(free_binding);
        }
        // Vulkan's separate textures and samplers: one sampler2D per pair, named and bound as
        // the texture (as the HLSL path binds Texture2D + SamplerState).
        compiler.build_combined_image_samplers();
        for (const spirv_cross::CombinedImageSampler& combined :
             compiler.get_combined_image_samplers()) {
          compiler.set_name(combined.combined_id, compiler.get_name(combined.image_id));
          compiler.set_decoration(
              combined.combined_id, spv::DecorationBinding,
              compiler.get_decoration(combined.image_id, spv::DecorationBinding));
        }
        return compiler.compile();
      }
      held += std::string(held.empty() ? "" : ", ") + executionModelName(entry.execution_model) +
              " '" + entry.name + "'";
    }
    return Error{file_name + ": holds no " + executionModelName(wanted) + " entry point" +
                 (entry_point.empty() ? std::string() : " '" + entry_point + "'") + " (it holds " +
                 (held.empty() ? std::string("none") : held) + ")"};
  } catch (const std::exception& error) {
    return Error{file_name + ": SPIRV-Cross (GLSL 450): " + error.what()};
  }
}

core::Status checkBindingsAcrossSets(
    const std::vector<std::pair<std::string, std::vector<uint32_t>>>& modules) {
  BindingsOfKind seen;
  for (const auto& [file_name, words] : modules) {
    try {
      spirv_cross::Compiler compiler(words);
      if (auto distinct = addBindings(compiler, compiler.get_shader_resources(), file_name, seen);
          !distinct)
        return distinct;
    } catch (const std::exception& error) {
      return Error{file_name + ": SPIRV-Cross: " + error.what()};
    }
  }
  return core::okStatus();
}

namespace {

using SemanticLocations = std::map<std::string, uint32_t>;
core::Result<std::string> hlslStageToGlsl(const std::string& source, Stage stage,
                                          const std::string& file_name,
                                          const CompileOptions& options,
                                          const SemanticLocations* input_locations,
                                          SemanticLocations* output_locations);

// A varying's semantic as Direct3D compares them: case-insensitive, and a missing index is 0
// ("texcoord" is "TEXCOORD0").
std::string canonicalSemantic(std::string semantic) {
  for (char& c : semantic) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (!semantic.empty() && !std::isdigit(static_cast<unsigned char>(semantic.back())))
    semantic += '0';
  return semantic;
}

// The semantic, name and location of each stage input or output that is not a built-in.
struct Varying {
  spirv_cross::VariableID id;
  std::string semantic, name;
  uint32_t location = 0;
};
std::vector<Varying> varyingsOf(const spirv_cross::CompilerGLSL& compiler,
                                const spirv_cross::SmallVector<spirv_cross::Resource>& list) {
  std::vector<Varying> varyings;
  for (const spirv_cross::Resource& resource : list) {
    const std::string semantic =
        compiler.get_decoration_string(resource.id, spv::DecorationHlslSemanticGOOGLE);
    if (semantic.empty()) continue;
    varyings.push_back({resource.id, canonicalSemantic(semantic), compiler.get_name(resource.id),
                        compiler.get_decoration(resource.id, spv::DecorationLocation)});
  }
  return varyings;
}

}  // namespace

core::Result<std::string> hlslToGlsl(const std::string& source, Stage stage,
                                     const std::string& file_name, const CompileOptions& options) {
  return hlslStageToGlsl(source, stage, file_name, options, nullptr, nullptr);
}

core::Result<GlslPair> hlslPairToGlsl(const std::string& vertex_source,
                                      const std::string& vertex_file,
                                      const std::string& fragment_source,
                                      const std::string& fragment_file,
                                      const CompileOptions& vertex_options,
                                      const CompileOptions& fragment_options) {
  SemanticLocations written;
  auto vertex = hlslStageToGlsl(vertex_source, Stage::kVertex, vertex_file, vertex_options,
                                     nullptr, &written);
  if (!vertex) return vertex.error();
  auto fragment = hlslStageToGlsl(fragment_source, Stage::kFragment, fragment_file,
                                       fragment_options, &written, nullptr);
  if (!fragment) return fragment.error();
  return GlslPair{*vertex, *fragment};
}

namespace {
// One stage of hlslToGlsl / hlslPairToGlsl: the fragment stage's inputs take the locations of
// `input_locations` (by semantic) when given; the vertex stage's outputs are reported in
// `output_locations` when given.
core::Result<std::string> hlslStageToGlsl(const std::string& source, Stage stage,
                                          const std::string& file_name,
                                          const CompileOptions& options,
                                          const SemanticLocations* input_locations,
                                          SemanticLocations* output_locations) {
  CompileOptions hlsl = options;
  hlsl.language = Language::kHlsl;
  auto words = compileToSpirv(source, stage, file_name, hlsl);
  if (!words) return words.error();
  if (auto valid = validateSpirv(*words, file_name); !valid) return valid.error();
  auto legal = legalizeHlsl(*words, file_name);
  if (!legal) return legal.error();
  try {
    spirv_cross::CompilerGLSL compiler(*legal);
    setGlslOptions(compiler, Target::kGlsl450);
    // OpenGL has no separate samplers: each (texture, sampler) pair the shader samples with
    // becomes one sampler2D, named and bound as the texture (register(tN) → binding N), which is
    // how duolod's interface binds textures.
    // Texture.Load reads without a sampler: GLSL's texelFetch still needs a sampler2D, so such
    // reads are paired with a dummy sampler (not a second SamplerState of the texture).
    const spirv_cross::VariableID dummy_sampler =
        compiler.build_dummy_sampler_for_combined_images();
    compiler.build_combined_image_samplers();
    std::set<spirv_cross::VariableID> textures;
    for (const spirv_cross::CombinedImageSampler& pair : compiler.get_combined_image_samplers())
      if (pair.sampler_id != dummy_sampler && !textures.insert(pair.image_id).second)
        return Error{file_name + ": texture '" + compiler.get_name(pair.image_id) +
                     "' is sampled with more than one SamplerState; OpenGL binds one sampler "
                     "state per texture unit, so use one SamplerState per texture"};
    for (const spirv_cross::CombinedImageSampler& pair : compiler.get_combined_image_samplers()) {
      compiler.set_name(pair.combined_id, compiler.get_name(pair.image_id));
      if (compiler.has_decoration(pair.image_id, spv::DecorationBinding))
        compiler.set_decoration(pair.combined_id, spv::DecorationBinding,
                                compiler.get_decoration(pair.image_id, spv::DecorationBinding));
    }
    // Names for what glslang leaves unnamed or names after HLSL's plumbing, so that the GLSL,
    // and the rules' descriptions of it, read as a GLSL author would write them: a cbuffer
    // `Frame` is read through `frame` (not `_27`), the entry point's result is `outColor` or
    // `out_<member>` (not `_entryPointOutput_<member>`).
    const spirv_cross::ShaderResources resources = compiler.get_shader_resources();
    for (const spirv_cross::Resource& block : resources.uniform_buffers) {
      if (!compiler.get_name(block.id).empty()) continue;
      std::string name = compiler.get_name(block.base_type_id);
      if (name.empty()) continue;
      name[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(name[0])));
      if (name != compiler.get_name(block.base_type_id)) compiler.set_name(block.id, name);
    }
    // Vertex inputs by semantic, when asked: Direct3D binds vertex streams by semantic, so an
    // HLSL author declares them in any order and without [[vk::location]].
    if (stage == Stage::kVertex && !options.vertex_input_locations.empty()) {
      std::map<std::string, std::string> taken;  // semantic -> input
      for (const Varying& input : varyingsOf(compiler, resources.stage_inputs)) {
        const auto location = options.vertex_input_locations.find(input.semantic);
        if (location == options.vertex_input_locations.end()) {
          std::string list;
          for (const auto& [semantic, unused] : options.vertex_input_locations)
            list += (list.empty() ? "" : ", ") + semantic;
          return Error{file_name + ": vertex input '" + input.name + "' (" + input.semantic +
                       ") is not a stream the mesh provides (it provides " + list + ")"};
        }
        if (auto [other, inserted] = taken.emplace(input.semantic, input.name); !inserted)
          return Error{file_name + ": vertex inputs '" + other->second + "' and '" + input.name +
                       "' have the same semantic " + input.semantic};
        compiler.set_decoration(input.id, spv::DecorationLocation, location->second);
      }
    }
    // Varyings by semantic: the vertex stage's outputs keep the locations glslang gave them
    // (declaration order) and are reported; the fragment stage's inputs take the location of the
    // output with the same semantic, whatever order either stage declares them in, and one that
    // no output writes is an error naming both sides.
    if (output_locations)
      for (const Varying& varying : varyingsOf(compiler, resources.stage_outputs))
        (*output_locations)[varying.semantic] = varying.location;
    if (input_locations)
      for (const Varying& varying : varyingsOf(compiler, resources.stage_inputs)) {
        const auto written = input_locations->find(varying.semantic);
        if (written == input_locations->end()) {
          std::string list;
          for (const auto& [semantic, location] : *input_locations)
            if (semantic.rfind("SV_", 0) != 0) list += (list.empty() ? "" : ", ") + semantic;
          return Error{file_name + ": input '" + varying.name + "' (" + varying.semantic +
                       ") is not written by the vertex stage (its outputs: " +
                       (list.empty() ? std::string("none") : list) + ")"};
        }
        compiler.set_decoration(varying.id, spv::DecorationLocation, written->second);
      }
    const std::string plumbing = "@entryPointOutput";
    for (const spirv_cross::Resource& output : resources.stage_outputs) {
      const std::string name = compiler.get_name(output.id);
      if (name.rfind(plumbing, 0) != 0) continue;
      const std::string member = name.substr(plumbing.size());  // "" or ".worldPosition"
      compiler.set_name(output.id, member.empty()
                                       ? (stage == Stage::kFragment ? "outColor" : "outValue")
                                       : "out_" + member.substr(1));
    }
    return compiler.compile();
  } catch (const std::exception& error) {
    return Error{file_name + ": SPIRV-Cross (GLSL 450 from HLSL): " + error.what()};
  }
}

}  // namespace

core::Status checkCrossCompiled(const std::string& source, Target target, Stage stage,
                                const std::string& what) {
  std::string name = what + " (" + targetName(target) + ")";
  if (target == Target::kGlsl450 || target == Target::kHlsl50) {
    CompileOptions options;
    options.language = target == Target::kHlsl50 ? Language::kHlsl : Language::kGlsl;
    // SPIRV-Cross writes no location for loose (non-block) uniforms, which OpenGL GLSL resolves by
    // name but glslang's SPIR-V path insists on: let glslang number them for the check.
    options.auto_map_locations = true;
    auto words = compileToSpirv(source, stage, name, options);
    if (!words.ok()) return words.error();
    return validateSpirv(*words, name);
  }
  // GLSL ES 300 has no SPIR-V path for OpenGL: parse and link with the ES profile.
  static_cast<void>(compileToSpirv("", stage, "init", {}));  // initialises glslang once
  EShLanguage language = glslangStage(stage);
  glslang::TShader shader(language);
  const char* text = source.c_str();
  const char* file = name.c_str();
  shader.setStringsWithLengthsAndNames(&text, nullptr, &file, 1);
  shader.setEnvInput(glslang::EShSourceGlsl, language, glslang::EShClientNone, 0);
  if (!shader.parse(GetDefaultResources(), 300, EEsProfile, false, false, EShMsgDefault))
    return Error{name + ": " + shader.getInfoLog()};
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(EShMsgDefault)) return Error{name + ": link: " + program.getInfoLog()};
  return core::okStatus();
}

}  // namespace duolod::shader
