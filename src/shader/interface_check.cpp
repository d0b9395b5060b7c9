// A user's shader pair against what duolod feeds it (shaders/INTERFACE.md, moved by a bindings
// file): what cannot render right is an error, what reads zeros a warning (see shader.hpp).
#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "duolod/shader.hpp"
#include "shader/ir.hpp"

namespace duolod::shader {

namespace {

using ir::Id;

struct ParsedStage {
  ir::Module module;
  std::string file;
};

core::Result<ParsedStage> parseStage(const std::string& source, Stage stage,
                                     const std::string& file) {
  auto words = compileToSpirv(source, stage, file);
  if (!words) return words.error();
  auto module = ir::parseModule(*words);
  if (!module) return core::Error{file + ": " + module.error().message};
  return ParsedStage{std::move(*module), file};
}

// "vec3", "float", "mat4", "ivec2"... for messages; "" for what is neither (arrays, structs).
std::string glslTypeName(const ir::DefUse& uses, Id type) {
  ir::TypeInfo info = ir::typeInfo(uses, type);
  const ir::Instruction* scalar = uses.def(info.scalar_type);
  if (!scalar || info.components == 0) return "";
  std::string prefix;
  std::string scalar_name;
  switch (scalar->opcode) {
    case spv::OpTypeFloat:
      scalar_name = info.width == 64 ? "double" : "float";
      prefix = info.width == 64 ? "d" : "";
      break;
    case spv::OpTypeInt:
      scalar_name = scalar->operands[1] ? "int" : "uint";
      prefix = scalar->operands[1] ? "i" : "u";
      break;
    case spv::OpTypeBool:
      scalar_name = "bool";
      prefix = "b";
      break;
    default:
      return "";
  }
  if (info.opcode == spv::OpTypeMatrix) {
    uint32_t rows = info.components / std::max(info.columns, 1u);
    return prefix + "mat" + std::to_string(info.columns) +
           (rows == info.columns ? "" : "x" + std::to_string(rows));
  }
  if (info.opcode == spv::OpTypeVector) return prefix + "vec" + std::to_string(info.components);
  return scalar_name;
}

// What a sampler variable samples, as OpenGL tells sampler types apart: the image's dimension,
// depth, arrayed, multisampled flags and sampled type. Empty when it is not an image type.
std::string samplerSignature(const ir::DefUse& uses, Id type) {
  const ir::Instruction* def = uses.def(type);
  while (def && (def->opcode == spv::OpTypeArray || def->opcode == spv::OpTypeRuntimeArray))
    def = uses.def(def->operands[0]);
  if (def && def->opcode == spv::OpTypeSampledImage) def = uses.def(def->operands[0]);
  if (!def || def->opcode != spv::OpTypeImage || def->operands.size() < 6) return "";
  static const char* const kDimensions[] = {"1D",   "2D",     "3D",         "Cube",
                                            "Rect", "Buffer", "SubpassData"};
  uint32_t dim = def->operands[1];
  std::string text = dim < 7 ? kDimensions[dim] : "dim" + std::to_string(dim);
  if (def->operands[2] == 1) text += "Shadow";
  if (def->operands[3]) text += "Array";
  if (def->operands[4]) text += "MS";
  std::string sampled = glslTypeName(uses, def->operands[0]);
  return (sampled == "int" ? "isampler" : sampled == "uint" ? "usampler" : "sampler") + text;
}

bool isStorageBlock(const ir::DefUse& uses, const ir::UniformBlock& block) {
  const ir::Instruction* variable = uses.def(block.variable);
  return (variable && variable->operands[0] == spv::StorageClassStorageBuffer) ||
         uses.hasDecoration(block.block_type, spv::DecorationBufferBlock);
}

// Whether a global variable is read or written anywhere in a function (names, decorations and
// the entry point's interface list do not count): OpenGL ignores what no code touches.
bool isUsed(const ir::DefUse& uses, Id variable) {
  for (const ir::InstructionRef& user : uses.users(variable))
    if (user.function >= 0) return true;
  return false;
}

// Array elements of a type (1 for a non-array), and the element type.
uint32_t arrayLength(const ir::DefUse& uses, Id& type) {
  uint32_t count = 1;
  const ir::Instruction* def = uses.def(type);
  for (int depth = 0; def && def->opcode == spv::OpTypeArray && depth < 8; ++depth) {
    count *= static_cast<uint32_t>(
        std::max<int64_t>(1, ir::constantIntValue(uses, def->operands[1]).value_or(1)));
    type = def->operands[0];
    def = uses.def(type);
  }
  return count;
}

// Locations a varying of `type` takes (GLSL 4.50 §4.4.1: a matrix one per column, a 64-bit
// three- or four-component vector two, arrays their element's times their length).
uint32_t locationsSpanned(const ir::DefUse& uses, Id type) {
  const uint32_t count = arrayLength(uses, type);
  ir::TypeInfo info = ir::typeInfo(uses, type);
  uint32_t per_element = 1;
  if (info.opcode == spv::OpTypeMatrix) per_element = std::max(info.columns, 1u);
  if (info.width == 64 && info.opcode == spv::OpTypeVector && info.components > 2) per_element = 2;
  if (const ir::Instruction* def = uses.def(type); def && def->opcode == spv::OpTypeStruct) {
    per_element = 0;
    for (Id member : def->operands) per_element += locationsSpanned(uses, member);
  }
  return count * per_element;
}

struct Varying {
  const ir::InterfaceVariable* variable = nullptr;
  bool starts_here = false;  // the location is its first (else inside an array or matrix)
};

std::string blockName(const ir::UniformBlock& block) {
  return block.name.empty() ? block.instance_name : block.name;
}

}  // namespace

core::Result<std::vector<std::string>> checkShaderInterface(const render::GlslSource& source,
                                                            const render::Bindings& bindings) {
  auto vertex = parseStage(source.vertex, Stage::kVertex, source.vertex_name);
  if (!vertex) return vertex.error();
  auto fragment = parseStage(source.fragment, Stage::kFragment, source.fragment_name);
  if (!fragment) return fragment.error();
  std::vector<std::string> warnings;
  const ir::DefUse vertex_uses(vertex->module), fragment_uses(fragment->module);

  // Vertex inputs: each location a stream is bound to, else the generic attribute (0, 0, 0, 1).
  std::set<uint32_t> fed;
  for (int location : {bindings.position, bindings.normal, bindings.tangent, bindings.uv0,
                       bindings.uv1, bindings.color})
    if (location >= 0) fed.insert(static_cast<uint32_t>(location));
  for (const ir::InterfaceVariable& input : ir::interfaceVariables(vertex->module, vertex_uses))
    if (input.storage == spv::StorageClassInput && !input.builtin && input.location &&
        !fed.count(*input.location))
      warnings.push_back(vertex->file + ": vertex input '" + input.name + "' at location " +
                         std::to_string(*input.location) +
                         " is fed no mesh stream (shaders/INTERFACE.md, --bindings): it reads "
                         "(0, 0, 0, 1)");

  // Varyings: SPIR-V stages link by location without a check; a fragment input that no vertex
  // output writes is undefined, one of another type reads the wrong bits. Keyed by (location,
  // component); an input the code never reads is no read.
  std::map<std::pair<uint32_t, uint32_t>, Varying> outputs;
  const std::vector<ir::InterfaceVariable> vertex_interface =
      ir::interfaceVariables(vertex->module, vertex_uses);
  for (const ir::InterfaceVariable& output : vertex_interface) {
    if (output.storage != spv::StorageClassOutput || output.builtin || !output.location) continue;
    const uint32_t component =
        vertex_uses.decoration(output.variable, spv::DecorationComponent).value_or(0);
    const uint32_t span = locationsSpanned(vertex_uses, output.value_type);
    for (uint32_t k = 0; k < std::max(span, 1u); ++k)
      outputs[{*output.location + k, component}] = Varying{&output, k == 0};
  }
  for (const ir::InterfaceVariable& input :
       ir::interfaceVariables(fragment->module, fragment_uses)) {
    if (input.storage != spv::StorageClassInput || input.builtin || !input.location ||
        !isUsed(fragment_uses, input.variable))
      continue;
    const uint32_t component =
        fragment_uses.decoration(input.variable, spv::DecorationComponent).value_or(0);
    auto found = outputs.find({*input.location, component});
    const std::string where =
        fragment->file + ": fragment input '" + input.name + "' at location " +
        std::to_string(*input.location) +
        (component ? " component " + std::to_string(component) : std::string());
    if (found == outputs.end())
      return core::Error{where + ": " + vertex->file +
                         " writes no output there (the stages are linked by location)"};
    if (!found->second.starts_here) continue;  // part of an array or matrix: not compared
    const std::string input_type = glslTypeName(fragment_uses, input.value_type);
    const std::string output_type = glslTypeName(vertex_uses, found->second.variable->value_type);
    if (!input_type.empty() && !output_type.empty() && input_type != output_type)
      return core::Error{where + " is a " + input_type + ", but " + vertex->file +
                         "'s output there, '" + found->second.variable->name + "', is a " +
                         output_type};
  }

  // The colour: duolod reads the fragment stage's output at location 0, and counts the object's
  // pixels by its alpha. Without it (or with a vec3, alpha undefined) every pixel is undefined:
  // garbage errors that changed from run to run, or 0 coverage and every error 0.
  const std::vector<ir::InterfaceVariable> fragment_interface =
      ir::interfaceVariables(fragment->module, fragment_uses);
  const ir::InterfaceVariable* colour = nullptr;
  for (const ir::InterfaceVariable& output : fragment_interface)
    if (output.storage == spv::StorageClassOutput && !output.builtin && output.location &&
        *output.location == 0 && isUsed(fragment_uses, output.variable))
      colour = &output;
  const std::string colour_rule =
      " (shaders/INTERFACE.md: `layout(location = 0) out vec4 outColor`; duolod counts the "
      "object's pixels by its alpha, 1 where the object is)";
  if (!colour)
    return core::Error{fragment->file + ": writes no colour output at location 0" + colour_rule};
  // (An array's element 0 is what location 0 gets.)
  Id colour_type = colour->value_type;
  arrayLength(fragment_uses, colour_type);
  const ir::TypeInfo colour_info = ir::typeInfo(fragment_uses, colour_type);
  const ir::Instruction* colour_scalar = fragment_uses.def(colour_info.scalar_type);
  if (colour_info.components != 4 || !colour_scalar || colour_scalar->opcode != spv::OpTypeFloat) {
    const std::string type = glslTypeName(fragment_uses, colour_type);
    return core::Error{fragment->file + ": its colour output '" + colour->name +
                       "' at location 0 is " + (type.empty() ? "not a vec4" : "a " + type) +
                       (colour_info.components != 4 ? ", which leaves alpha undefined"
                                                    : ", which a colour attachment cannot take") +
                       colour_rule};
  }

  // Textures: a unit duolod binds nothing to samples (0, 0, 0, 1); two sampler types on one unit
  // make OpenGL refuse every draw (GL_INVALID_OPERATION).
  std::set<uint32_t> bound;
  for (int binding : {bindings.base_color, bindings.metallic_roughness, bindings.normal_map,
                      bindings.occlusion, bindings.emissive})
    if (binding >= 0) bound.insert(static_cast<uint32_t>(binding));
  std::map<uint32_t, std::pair<std::string, std::string>> unit_types;  // type, "file: name"
  for (const ParsedStage* stage : {&*vertex, &*fragment}) {
    const ir::DefUse& uses = stage == &*vertex ? vertex_uses : fragment_uses;
    for (const ir::Sampler& sampler : ir::samplers(stage->module, uses)) {
      // OpenGL checks only the samplers the program uses (an unused one is no active uniform).
      if (!sampler.binding || !isUsed(uses, sampler.variable)) continue;
      Id element = sampler.type;
      const uint32_t count = arrayLength(uses, element);  // an array takes consecutive units
      const std::string signature = samplerSignature(uses, sampler.type);
      for (uint32_t k = 0; k < count; ++k) {
        const uint32_t unit = *sampler.binding + k;
        const std::string who = stage->file + ": '" + sampler.name +
                                (count > 1 ? "[" + std::to_string(k) + "]" : std::string()) + "'";
        auto [known, added] = unit_types.emplace(unit, std::pair{signature, who});
        if (!added && !signature.empty() && !known->second.first.empty() &&
            known->second.first != signature)
          return core::Error{who + " (a " + signature + ") and " + known->second.second + " (a " +
                             known->second.first + ") share texture unit " + std::to_string(unit) +
                             ": OpenGL draws nothing with two sampler types on one unit"};
        if (!added) continue;
        if (!bound.count(unit))
          warnings.push_back(who + " at binding " + std::to_string(unit) +
                             " is bound to no texture (shaders/INTERFACE.md, --bindings): it "
                             "samples (0, 0, 0, 1)");
        else if (!signature.empty() && signature != "sampler2D")
          warnings.push_back(who + " at binding " + std::to_string(unit) + " is a " + signature +
                             "; duolod binds 2D textures only: it samples (0, 0, 0, 1)");
      }
    }
  }

  // Blocks and loose uniforms duolod does not fill read zeros.
  std::set<std::pair<std::string, std::string>> reported;  // a block both stages declare, once
  for (const ParsedStage* stage : {&*vertex, &*fragment}) {
    const ir::DefUse& uses = stage == &*vertex ? vertex_uses : fragment_uses;
    for (const ir::UniformBlock& block : ir::uniformBlocks(stage->module, uses)) {
      const int binding = block.binding ? static_cast<int>(*block.binding) : -1;
      if (isStorageBlock(uses, block) || !isUsed(uses, block.variable) ||
          binding == bindings.frame_block || binding == bindings.material_block)
        continue;
      if (!reported.insert({blockName(block), std::to_string(binding)}).second) continue;
      warnings.push_back(
          stage->file + ": uniform block '" + blockName(block) + "'" +
          (binding >= 0 ? " at binding " + std::to_string(binding) : " without a binding") +
          " is neither Frame nor Material (shaders/INTERFACE.md, --bindings): it reads zeros");
    }
    for (const ir::StorageBlock& block : ir::storageBlocks(stage->module, uses)) {
      const int binding = block.binding ? static_cast<int>(*block.binding) : -1;
      if (!isUsed(uses, block.variable) ||
          !reported.insert({block.name, std::to_string(binding)}).second)
        continue;
      warnings.push_back(
          stage->file + ": storage block '" + block.name + "'" +
          (binding >= 0 ? " at binding " + std::to_string(binding) : " without a binding") +
          " gets no buffer (duolod binds none): it reads zeros and its writes are lost");
    }
    for (const ir::LooseUniform& uniform : ir::looseUniforms(stage->module, uses))
      if (isUsed(uses, uniform.variable))
        warnings.push_back(
            stage->file + ": uniform '" + uniform.name + "'" +
            (uniform.location ? " at location " + std::to_string(*uniform.location)
                              : std::string()) +
            " is set by nothing (duolod sets blocks, not loose uniforms): it reads 0");
  }
  return warnings;
}

}  // namespace duolod::shader
