// Code transformation per-pixel → per-vertex (Wang, Yang, Yuan, Chen, Bala, Bao, "Automatic shader
// simplification using surface signal approximation", TOG 2014; Liang et al. §4.1 rule 2): a
// fragment value that depends only on interpolated inputs, uniforms and constants is computed in
// the vertex stage instead and reaches the fragment stage through a new varying, so the rasterizer
// interpolates f(x) instead of the fragment stage evaluating f(interpolate(x)) — Gouraud instead
// of Phong for a lighting term.
//
// The value's computation is copied into the vertex module:
//   - a fragment Input at location L reads, in the vertex stage, the Output at location L (loaded
//     at the end of the vertex entry point, after the vertex stage has written it);
//   - uniform blocks map by binding (same layout required; the block is declared in the vertex
//     module when missing), loose uniforms by location;
//   - a local variable with exactly one store becomes a fresh local with the same store; called
//     functions are copied whole;
//   - types and constants are re-created (de-duplicated) in the vertex module.
// Anything else (phis, locals written more than once, builtins, textures) makes the site
// unavailable. The copy runs at the end of the vertex entry point and stores a new Output at the
// lowest varying location both stages leave free (from RuleContext::first_varying_location, 0:
// GL 4.5 guarantees locations 0-14 only); the fragment stage reads the
// matching Input instead of computing the value, and what becomes dead is removed.
#include <map>
#include <set>
#include <unordered_map>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {

namespace {

using ir::Id;
using ir::Instruction;
using ir::Module;

bool isTypeOpcode(spv::Op op) {
  return op >= spv::OpTypeVoid && op <= spv::OpTypeForwardPointer;
}

// The vertex module's interface before the rule changes it.
struct VertexInterface {
  struct Output {
    Id variable = ir::kNoId;
    Id value_type = ir::kNoId;
  };
  struct BlockVariable {
    Id variable = ir::kNoId;
    std::vector<Id> member_types;
    std::vector<std::optional<uint32_t>> member_offsets;
  };
  std::map<uint32_t, Output> outputs;                          // by location (no builtins)
  std::map<uint32_t, BlockVariable> blocks;                    // Uniform blocks by binding
  std::map<uint32_t, VertexInterface::Output> loose_uniforms;  // by location
  std::map<std::string, uint32_t> loose_uniform_names;

  explicit VertexInterface(const Module& vertex) {
    ir::DefUse uses(vertex);
    for (const ir::InterfaceVariable& variable : ir::interfaceVariables(vertex, uses))
      if (variable.storage == spv::StorageClassOutput && variable.location && !variable.builtin &&
          !uses.hasDecoration(variable.variable, spv::DecorationComponent))
        outputs[*variable.location] = {variable.variable, variable.value_type};
    for (const ir::UniformBlock& block : ir::uniformBlocks(vertex, uses)) {
      if (!block.binding) continue;
      BlockVariable entry{block.variable, {}, {}};
      for (const ir::UniformMember& member : block.members) {
        entry.member_types.push_back(member.type);
        entry.member_offsets.push_back(member.offset);
      }
      blocks[*block.binding] = std::move(entry);
    }
    for (const ir::LooseUniform& uniform : ir::looseUniforms(vertex, uses)) {
      if (uniform.location)
        loose_uniforms[*uniform.location] = {uniform.variable, uniform.value_type};
      loose_uniform_names[uniform.name] = uniform.location.value_or(~0u);
    }
  }
};

// Copies fragment values, with everything they are computed from, into the vertex module.
class VertexTranslator {
 public:
  VertexTranslator(const Module& fragment, Module& vertex)
      : fragment_(fragment),
        uses_(fragment),
        vertex_(vertex),
        interface_(vertex),
        entry_(entryFunctionIndex(fragment, spv::ExecutionModelFragment)) {
    for (const Instruction& instruction : fragment.names)
      if (instruction.opcode == spv::OpName)
        names_[instruction.operands[0]] = instruction.literalString(1);
  }

  // The vertex id computing the same as fragment id `id`, or kNoId (see failure()).
  Id translate(Id id) {
    if (!failure_.empty()) return ir::kNoId;
    if (auto found = map_.find(id); found != map_.end()) return found->second;
    if (!in_progress_.insert(id).second) return fail(id, "depends on itself");
    Id result = translateNew(id);
    in_progress_.erase(id);
    if (result != ir::kNoId) map_[id] = result;
    return result;
  }

  const std::string& failure() const { return failure_; }
  // Forgets a failed translation so the next translate() starts clean. What was translated stays
  // mapped: a dry run over many values shares their common dependencies.
  void clearFailure() {
    failure_.clear();
    in_progress_.clear();
  }
  // New Function variables for the start of the vertex entry block.
  std::vector<Instruction> variables;
  // The computation, in order, for the end of the vertex entry point.
  std::vector<Instruction> body;

 private:
  Id fail(Id id, const std::string& reason) {
    if (failure_.empty()) failure_ = "%" + std::to_string(id) + " " + reason;
    return ir::kNoId;
  }

  void copyName(Id from, Id to) {
    if (auto found = names_.find(from); found != names_.end()) vertex_.setName(to, found->second);
  }

  Id translateNew(Id id) {
    const ir::InstructionRef* ref = uses_.defRef(id);
    if (!ref) return fail(id, "has no definition");
    const Instruction& instruction = *ref->instruction;
    spv::Op op = instruction.opcode;
    if (op == spv::OpExtInstImport) {
      if (instruction.literalString(0) != "GLSL.std.450")
        return fail(id, "is an unknown extended set");
      return glslStd450Import(vertex_);
    }
    if (op == spv::OpFunction) return copyFunction(id);
    if (ref->function < 0) {
      if (isTypeOpcode(op)) return translateType(instruction);
      if (op == spv::OpVariable) return mapGlobal(instruction);
      return translateConstant(instruction);
    }
    if (ref->function != entry_) return fail(id, "is inside a function the value does not call");
    return translateEntryInstruction(instruction);
  }

  Id translateType(const Instruction& type) {
    const std::vector<uint32_t>& in = type.operands;
    switch (type.opcode) {
      case spv::OpTypeVoid:
        return vertex_.typeVoid();
      case spv::OpTypeBool:
        return vertex_.typeBool();
      case spv::OpTypeInt:
        return vertex_.typeInt(in[0], in[1] != 0);
      case spv::OpTypeFloat:
        return vertex_.typeFloat(in[0]);
      case spv::OpTypeVector: {
        Id component = translate(in[0]);
        return component ? vertex_.typeVector(component, in[1]) : ir::kNoId;
      }
      case spv::OpTypeMatrix: {
        Id column = translate(in[0]);
        return column ? vertex_.addTypeOrConstant(spv::OpTypeMatrix, ir::kNoId, {column, in[1]})
                      : ir::kNoId;
      }
      case spv::OpTypeArray: {
        Id element = translate(in[0]), length = translate(in[1]);
        if (!element || !length) return ir::kNoId;
        if (!uses_.hasDecoration(type.result_id, spv::DecorationArrayStride))
          return vertex_.addTypeOrConstant(spv::OpTypeArray, ir::kNoId, {element, length});
        // A laid-out array (inside a uniform block) must not be merged with a plain one.
        Id array = vertex_.allocateId();
        vertex_.types_values.push_back(
            ir::makeInstruction(vertex_, spv::OpTypeArray, ir::kNoId, array, {element, length}));
        copyAnnotations(type.result_id, array);
        return array;
      }
      case spv::OpTypeStruct: {
        if (uses_.hasDecoration(type.result_id, spv::DecorationBlock) ||
            uses_.hasDecoration(type.result_id, spv::DecorationBufferBlock))
          return fail(type.result_id, "is a block type used outside its variable");
        return copyStruct(type);
      }
      case spv::OpTypePointer: {
        Id pointee = translate(in[1]);
        return pointee ? vertex_.typePointer(static_cast<spv::StorageClass>(in[0]), pointee)
                       : ir::kNoId;
      }
      case spv::OpTypeFunction: {
        std::vector<uint32_t> operands;
        for (uint32_t part : in) {
          Id translated = translate(part);
          if (!translated) return ir::kNoId;
          operands.push_back(translated);
        }
        return vertex_.addTypeOrConstant(spv::OpTypeFunction, ir::kNoId, operands);
      }
      default:
        return fail(type.result_id, "is a type the vertex stage cannot share (image, sampler...)");
    }
  }

  // A fresh struct (never merged: its decorations are its own), with its decorations and names.
  Id copyStruct(const Instruction& type) {
    std::vector<uint32_t> members;
    for (uint32_t member : type.operands) {
      Id translated = translate(member);
      if (!translated) return ir::kNoId;
      members.push_back(translated);
    }
    Id copy = vertex_.allocateId();
    vertex_.types_values.push_back(
        ir::makeInstruction(vertex_, spv::OpTypeStruct, ir::kNoId, copy, members));
    copyAnnotations(type.result_id, copy);
    return copy;
  }

  // Decorations and names of fragment `from` re-targeted at vertex `to`.
  void copyAnnotations(Id from, Id to) {
    for (const Instruction& annotation : fragment_.annotations)
      if ((annotation.opcode == spv::OpDecorate || annotation.opcode == spv::OpMemberDecorate) &&
          annotation.operands[0] == from) {
        Instruction copy = annotation;
        copy.operands[0] = to;
        vertex_.annotations.push_back(std::move(copy));
      }
    for (const Instruction& name : fragment_.names)
      if ((name.opcode == spv::OpName || name.opcode == spv::OpMemberName) &&
          name.operands[0] == from) {
        Instruction copy = name;
        copy.operands[0] = to;
        vertex_.names.push_back(std::move(copy));
      }
  }

  Id translateConstant(const Instruction& constant) {
    switch (constant.opcode) {
      case spv::OpConstant:
      case spv::OpConstantTrue:
      case spv::OpConstantFalse:
      case spv::OpConstantNull:
      case spv::OpConstantComposite:
      case spv::OpUndef:
        break;
      default:
        return fail(constant.result_id, "is a specialization constant or unknown value");
    }
    Id type = translate(constant.type_id);
    if (!type) return ir::kNoId;
    std::vector<uint32_t> operands = constant.operands;
    for (size_t i = 0; i < operands.size(); ++i)
      if (constant.is_id[i] && !(operands[i] = translate(operands[i]))) return ir::kNoId;
    return vertex_.addTypeOrConstant(constant.opcode, type, operands);
  }

  // A global the value reads: the vertex variable holding the same thing.
  Id mapGlobal(const Instruction& variable) {
    Id id = variable.result_id;
    auto storage = static_cast<spv::StorageClass>(variable.operands[0]);
    Id pointee = ir::pointeeType(uses_, variable.type_id);
    if (storage == spv::StorageClassInput) {
      std::optional<uint32_t> location = uses_.decoration(id, spv::DecorationLocation);
      if (!location || uses_.hasDecoration(id, spv::DecorationBuiltIn) ||
          uses_.hasDecoration(id, spv::DecorationComponent))
        return fail(id, "is a builtin or component input the vertex stage does not write");
      auto output = interface_.outputs.find(*location);
      if (output == interface_.outputs.end())
        return fail(id, "reads location " + std::to_string(*location) +
                            ", which the vertex stage does not write");
      if (translate(pointee) != output->second.value_type)
        return fail(id, "has another type than the vertex output at its location");
      return output->second.variable;
    }
    if (storage == spv::StorageClassUniform) {
      std::optional<uint32_t> binding = uses_.decoration(id, spv::DecorationBinding);
      const Instruction* block = uses_.def(pointee);
      if (!binding || !block || block->opcode != spv::OpTypeStruct ||
          !uses_.hasDecoration(pointee, spv::DecorationBlock))
        return fail(id, "is a uniform without a binding or block");
      auto existing = interface_.blocks.find(*binding);
      if (existing == interface_.blocks.end()) return declareBlock(variable, *block);
      const VertexInterface::BlockVariable& vertex_block = existing->second;
      if (vertex_block.member_types.size() != block->operands.size())
        return fail(id, "has another layout than the vertex block at its binding");
      for (uint32_t member = 0; member < block->operands.size(); ++member) {
        if (translate(block->operands[member]) != vertex_block.member_types[member] ||
            uses_.memberDecoration(pointee, member, spv::DecorationOffset) !=
                vertex_block.member_offsets[member])
          return fail(id, "has another layout than the vertex block at its binding");
      }
      return vertex_block.variable;
    }
    if (storage == spv::StorageClassUniformConstant) {
      std::optional<uint32_t> location = uses_.decoration(id, spv::DecorationLocation);
      Id type = location ? translate(pointee) : ir::kNoId;
      if (!type) return fail(id, "is an opaque uniform or has no location");
      if (auto existing = interface_.loose_uniforms.find(*location);
          existing != interface_.loose_uniforms.end()) {
        if (existing->second.value_type != type)
          return fail(id, "has another type than the vertex uniform at its location");
        return existing->second.variable;
      }
      std::string name = fragment_.name(id);
      if (name.empty()) name = "uParameter" + std::to_string(*location);
      if (interface_.loose_uniform_names.count(name))
        return fail(id, "shares its name with a vertex uniform at another location");
      return vertex_.addLooseUniform(type, name, *location);
    }
    return fail(id, "reads memory the vertex stage does not have (private, output, storage)");
  }

  // The vertex module lacks this uniform block: declare it with the same layout and binding.
  Id declareBlock(const Instruction& variable, const Instruction& block) {
    Id block_type = copyStruct(block);
    if (!block_type) return ir::kNoId;
    map_[block.result_id] = block_type;
    Id pointer = vertex_.typePointer(spv::StorageClassUniform, block_type);
    Id copy = vertex_.allocateId();
    vertex_.types_values.push_back(
        ir::makeInstruction(vertex_, spv::OpVariable, pointer, copy,
                            {static_cast<uint32_t>(spv::StorageClassUniform)}));
    copyAnnotations(variable.result_id, copy);
    return copy;
  }

  Id translateEntryInstruction(const Instruction& instruction) {
    Id id = instruction.result_id;
    switch (instruction.opcode) {
      case spv::OpVariable:
        return translateLocalVariable(instruction);
      case spv::OpPhi:
        return fail(id, "is a phi (control flow)");
      case spv::OpLabel:
      case spv::OpFunctionParameter:
        return fail(id, "is not a value");
      case spv::OpDPdx:
      case spv::OpDPdy:
      case spv::OpFwidth:
      case spv::OpDPdxFine:
      case spv::OpDPdyFine:
      case spv::OpFwidthFine:
      case spv::OpDPdxCoarse:
      case spv::OpDPdyCoarse:
      case spv::OpFwidthCoarse:
        return fail(id, "is a screen-space derivative");
      default:
        break;
    }
    Id type = instruction.type_id ? translate(instruction.type_id) : ir::kNoId;
    std::vector<uint32_t> operands = instruction.operands;
    for (size_t i = 0; i < operands.size(); ++i)
      if (instruction.is_id[i] && !(operands[i] = translate(operands[i]))) return ir::kNoId;
    if (!failure_.empty()) return ir::kNoId;
    Id copy = vertex_.allocateId();
    body.push_back(ir::makeInstruction(vertex_, instruction.opcode, type, copy, operands));
    copyName(id, copy);
    return copy;
  }

  // A local variable with exactly one store (a GLSL local initialised once, or a call's parameter
  // temporary) becomes a vertex local with the same store.
  Id translateLocalVariable(const Instruction& variable) {
    Id id = variable.result_id;
    int stores = 0;
    Id stored = ir::kNoId;
    if (variable.operands.size() > 1) {  // an initializer
      ++stores;
      stored = variable.operands[1];
    }
    bool loaded = false, passed_to_call = false;
    std::vector<Id> pointers = {id};
    for (size_t p = 0; p < pointers.size(); ++p) {
      Id pointer = pointers[p];
      for (const ir::InstructionRef& user : uses_.users(pointer)) {
        const Instruction& use = *user.instruction;
        switch (use.opcode) {
          case spv::OpName:
          case spv::OpDecorate:
            break;
          case spv::OpStore:
            if (use.operands[0] != pointer || pointer != id) return fail(id, "is written in part");
            ++stores;
            stored = use.operands[1];
            break;
          case spv::OpLoad:
            loaded = true;
            break;
          case spv::OpAccessChain:
          case spv::OpInBoundsAccessChain:
            pointers.push_back(use.result_id);
            break;
          case spv::OpFunctionCall:
            if (pointer != id) return fail(id, "is passed in part to a function");
            passed_to_call = true;
            break;
          default:
            return fail(id, "is used in a way the rule does not follow");
        }
      }
    }
    if (stores != 1) return fail(id, "is written " + std::to_string(stores) + " times");
    if (passed_to_call && loaded) return fail(id, "may be written by a function it is passed to");
    Id type = translate(variable.type_id);
    if (!type) return ir::kNoId;
    Id copy = vertex_.allocateId();
    variables.push_back(ir::makeInstruction(vertex_, spv::OpVariable, type, copy,
                                            {static_cast<uint32_t>(spv::StorageClassFunction)}));
    copyName(id, copy);
    Id value = translate(stored);
    if (!value) return ir::kNoId;
    body.push_back(ir::makeInstruction(vertex_, spv::OpStore, ir::kNoId, ir::kNoId, {copy, value}));
    return copy;
  }

  // A function the value calls, copied whole (with what it calls).
  Id copyFunction(Id function_id) {
    const ir::Function* function = fragment_.findFunction(function_id);
    if (!function) return fail(function_id, "is not a function");
    if (entry_ >= 0 && fragment_.functions[entry_].id() == function_id)
      return fail(function_id, "is the fragment entry point");
    Id copy_id = vertex_.allocateId();
    map_[function_id] = copy_id;
    // Every id defined inside gets its vertex id first: branches and phis refer forward.
    for (const Instruction& parameter : function->parameters)
      map_[parameter.result_id] = vertex_.allocateId();
    for (const ir::Block& block : function->blocks) {
      map_[block.id()] = vertex_.allocateId();
      for (const Instruction& instruction : block.instructions)
        if (instruction.hasResult()) map_[instruction.result_id] = vertex_.allocateId();
    }
    auto copyInstruction = [&](const Instruction& instruction) -> std::optional<Instruction> {
      Id type = instruction.type_id ? translate(instruction.type_id) : ir::kNoId;
      std::vector<uint32_t> operands = instruction.operands;
      for (size_t i = 0; i < operands.size(); ++i)
        if (instruction.is_id[i] && !(operands[i] = translate(operands[i]))) return std::nullopt;
      if (!failure_.empty()) return std::nullopt;
      Id result = instruction.hasResult() ? map_.at(instruction.result_id) : ir::kNoId;
      copyName(instruction.result_id, result);
      return ir::makeInstruction(vertex_, instruction.opcode, type, result, operands);
    };
    ir::Function copy;
    Id return_type = translate(function->definition.type_id);
    Id function_type = translate(function->definition.operands[1]);
    if (!return_type || !function_type) return ir::kNoId;
    copy.definition = ir::makeInstruction(vertex_, spv::OpFunction, return_type, copy_id,
                                          {function->definition.operands[0], function_type});
    copyName(function_id, copy_id);
    for (const Instruction& parameter : function->parameters) {
      auto copied = copyInstruction(parameter);
      if (!copied) return ir::kNoId;
      copy.parameters.push_back(std::move(*copied));
    }
    for (const ir::Block& block : function->blocks) {
      ir::Block copied_block;
      copied_block.label =
          ir::makeInstruction(vertex_, spv::OpLabel, ir::kNoId, map_.at(block.id()), {});
      for (const Instruction& instruction : block.instructions) {
        if (instruction.opcode == spv::OpLine || instruction.opcode == spv::OpNoLine) continue;
        auto copied = copyInstruction(instruction);
        if (!copied) return ir::kNoId;
        copied_block.instructions.push_back(std::move(*copied));
      }
      copy.blocks.push_back(std::move(copied_block));
    }
    copy.end = ir::makeInstruction(vertex_, spv::OpFunctionEnd, ir::kNoId, ir::kNoId, {});
    vertex_.functions.push_back(std::move(copy));
    return copy_id;
  }

  const Module& fragment_;
  ir::DefUse uses_;
  Module& vertex_;
  VertexInterface interface_;
  int entry_;
  std::unordered_map<Id, Id> map_;
  std::set<Id> in_progress_;
  std::unordered_map<Id, std::string> names_;
  std::string failure_;
};

// The index of the vertex entry point's only returning block, or -1.
int returnBlockIndex(const Module& vertex) {
  int entry = entryFunctionIndex(vertex, spv::ExecutionModelVertex);
  if (entry < 0) return -1;
  int found = -1;
  const std::vector<ir::Block>& blocks = vertex.functions[entry].blocks;
  for (size_t b = 0; b < blocks.size(); ++b)
    if (!blocks[b].instructions.empty() && blocks[b].terminator().opcode == spv::OpReturn) {
      if (found >= 0) return -1;
      found = static_cast<int>(b);
    }
  return found;
}

// Why fragment `value` is not a per-vertex candidate by its dependences, or "". `slices`:
// computingSliceSummaries() of `fragment`.
std::string unsuitability(const Module& fragment, const ir::DefUse& uses,
                          ir::SliceSummaries& slices, Id value) {
  if (std::string why = valueTargetUnsuitability(fragment, uses, value); !why.empty()) return why;
  ir::SliceFlags slice = slices.of(value);
  if (!slice.onlyInputsUniformsConstants())
    return "depends on textures, derivatives, side effects or other memory";
  if (!slice.reads_input) return "reads no interpolated input";
  if (!slice.reaches_marked) return "computes nothing";
  return "";
}

}  // namespace

std::vector<RuleSite> findPerVertexSites(const ShaderProgram& program, const RuleContext&) {
  std::vector<RuleSite> sites;
  if (returnBlockIndex(program.vertex) < 0) return sites;
  ir::DefUse uses(program.fragment);
  // A dry run: can everything a value needs be copied? One scratch copy and one translator for
  // all values (whether an id translates does not depend on what was translated before it; the
  // GP enumerates sites on every mutation, and a copy + translator per value was 17% of its time).
  Module scratch = program.vertex;
  VertexTranslator translator(program.fragment, scratch);
  ir::SliceSummaries slices = computingSliceSummaries(program.fragment, uses);
  for (Id value : candidateValues(program.fragment, uses, spv::ExecutionModelFragment)) {
    if (!unsuitability(program.fragment, uses, slices, value).empty()) continue;
    translator.clearFailure();
    if (!translator.translate(value)) continue;
    RuleSite site;
    site.kind = RuleKind::kPerVertex;
    site.stage = Stage::kFragment;
    site.target = value;
    site.description = "fragment: " + describeComputedValue(program.fragment, uses, value) +
                       " computed in the vertex stage and interpolated";
    sites.push_back(std::move(site));
  }
  return sites;
}

core::Result<ShaderProgram> applyPerVertex(const ShaderProgram& program, const RuleSite& site,
                                           const RuleContext& context) {
  if (site.kind != RuleKind::kPerVertex || site.stage != Stage::kFragment)
    return siteError(site, "not a fragment per-vertex site");
  int return_block = returnBlockIndex(program.vertex);
  if (return_block < 0)
    return siteError(site, "the vertex entry point does not end in a single return");
  Id fragment_type = ir::kNoId;
  std::string name;
  {
    ir::DefUse uses(program.fragment);
    ir::SliceSummaries slices = computingSliceSummaries(program.fragment, uses);
    if (std::string why = unsuitability(program.fragment, uses, slices, site.target); !why.empty())
      return siteError(site, why);
    fragment_type = uses.def(site.target)->type_id;
    name = identifierFrom(describeComputedValue(program.fragment, uses, site.target));
  }

  ShaderProgram result = program;
  uint32_t location =
      freeVaryingLocation(program.vertex, program.fragment, context.first_varying_location);
  std::string varying_name = "vPerVertex_" + name + "_" + std::to_string(location);

  // Vertex stage: the copied computation, stored into a new output at the end of main.
  Module& vertex = result.vertex;
  VertexTranslator translator(program.fragment, vertex);
  Id computed = translator.translate(site.target);
  Id vertex_type = computed ? translator.translate(fragment_type) : ir::kNoId;
  if (!computed || !vertex_type) return siteError(site, translator.failure());
  Id output = vertex.allocateId();
  vertex.types_values.push_back(ir::makeInstruction(
      vertex, spv::OpVariable, vertex.typePointer(spv::StorageClassOutput, vertex_type), output,
      {static_cast<uint32_t>(spv::StorageClassOutput)}));
  vertex.annotations.push_back(
      ir::makeInstruction(vertex, spv::OpDecorate, ir::kNoId, ir::kNoId,
                          {output, static_cast<uint32_t>(spv::DecorationLocation), location}));
  vertex.setName(output, varying_name);
  addToEntryInterface(vertex, spv::ExecutionModelVertex, output);
  std::vector<Instruction> body = std::move(translator.body);
  body.push_back(
      ir::makeInstruction(vertex, spv::OpStore, ir::kNoId, ir::kNoId, {output, computed}));
  int vertex_entry = entryFunctionIndex(vertex, spv::ExecutionModelVertex);
  ir::Block& last = vertex.functions[vertex_entry].blocks[return_block];
  vertex.insertBefore({vertex_entry, return_block, static_cast<int>(last.instructions.size()) - 1},
                      std::move(body));
  vertex.insertBefore({vertex_entry, 0, 0}, std::move(translator.variables));

  // Fragment stage: the matching input replaces the value.
  Module& fragment = result.fragment;
  Id input = fragment.allocateId();
  fragment.types_values.push_back(ir::makeInstruction(
      fragment, spv::OpVariable, fragment.typePointer(spv::StorageClassInput, fragment_type), input,
      {static_cast<uint32_t>(spv::StorageClassInput)}));
  fragment.annotations.push_back(
      ir::makeInstruction(fragment, spv::OpDecorate, ir::kNoId, ir::kNoId,
                          {input, static_cast<uint32_t>(spv::DecorationLocation), location}));
  fragment.setName(input, varying_name);
  addToEntryInterface(fragment, spv::ExecutionModelFragment, input);
  if (auto replaced = replaceValueByLoad(fragment, site.target, input); !replaced)
    return siteError(site, replaced.error().message);
  return result;
}

}  // namespace duolod::shader
