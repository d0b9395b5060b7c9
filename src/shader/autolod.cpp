// Olano's single LOD shader on the SPIR-V IR (see autolod.hpp).
#include "shader/autolod.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>

#include "duolod/shader.hpp"

namespace duolod::shader {
namespace {

using ir::Id;
using ir::Instruction;
using ir::Module;

constexpr const char* kLevelSuffix = "_lod";

// ---------------------------------------------------------------------------------------------
// Structural descriptions, comparable across modules.

// A type (or constant) spelled out recursively: equal strings mean the same type in any module.
std::string typeSignature(const ir::DefUse& uses, Id id) {
  const Instruction* definition = uses.def(id);
  if (definition == nullptr) return "?";
  std::string text = std::to_string(static_cast<int>(definition->opcode));
  if (definition->type_id != ir::kNoId) text += ":" + typeSignature(uses, definition->type_id);
  for (size_t i = 0; i < definition->operands.size(); ++i)
    text += definition->is_id[i] ? "(" + typeSignature(uses, definition->operands[i]) + ")"
                                 : "," + std::to_string(definition->operands[i]);
  return text;
}

// How many locations a varying of `type` takes (vectors and scalars 1, matrices a column each,
// arrays their length times the element's).
uint32_t locationSlots(const ir::DefUse& uses, Id type) {
  const Instruction* definition = uses.def(type);
  if (definition == nullptr) return 1;
  if (definition->opcode == spv::OpTypeMatrix) return definition->operands[1];
  if (definition->opcode == spv::OpTypeArray) {
    auto length = ir::constantIntValue(uses, definition->operands[1]);
    return static_cast<uint32_t>(std::max<int64_t>(1, length.value_or(1))) *
           locationSlots(uses, definition->operands[0]);
  }
  return 1;
}

spv::StorageClass storageOf(const Instruction& variable) {
  return static_cast<spv::StorageClass>(variable.operands[0]);
}

template <class Visit>
void forEachGlobalVariable(const Module& module, Visit visit) {
  for (const Instruction& instruction : module.types_values)
    if (instruction.opcode == spv::OpVariable) visit(instruction);
}

// A varying: an Output of the vertex stage or an Input of the fragment stage, at a Location.
bool isVarying(const Module& module, const ir::DefUse& uses, const Instruction& variable) {
  spv::StorageClass storage = storageOf(variable);
  bool vertex = module.entryFunction(spv::ExecutionModelVertex) != nullptr;
  bool varying_side = vertex ? storage == spv::StorageClassOutput : storage == spv::StorageClassInput;
  return varying_side && uses.decoration(variable.result_id, spv::DecorationLocation) &&
         !uses.decoration(variable.result_id, spv::DecorationBuiltIn);
}

bool isLooseUniform(const ir::DefUse& uses, const Instruction& variable) {
  return storageOf(variable) == spv::StorageClassUniformConstant &&
         !uses.decoration(variable.result_id, spv::DecorationBinding) &&
         uses.decoration(variable.result_id, spv::DecorationLocation);
}

// ---------------------------------------------------------------------------------------------
// The location plan: which varyings and parameters of each level move, and where.

struct LevelMoves {
  std::map<uint32_t, uint32_t> varyings;    // old location -> new
  std::map<uint32_t, uint32_t> parameters;  // old location -> new
};

// Slots in use, with what occupies them (a key that decides sharing).
class LocationTable {
 public:
  // The location `wanted` when it is free or holds the same `key`; nothing when it clashes.
  std::optional<uint32_t> share(uint32_t wanted, uint32_t slots, const std::string& key) {
    auto existing = keys_.find(wanted);
    if (existing != keys_.end()) return existing->second == key ? std::optional(wanted) : std::nullopt;
    for (uint32_t slot = wanted; slot < wanted + slots; ++slot)
      if (occupied_.count(slot)) return std::nullopt;
    take(wanted, slots, key);
    return wanted;
  }
  // The lowest free run of `slots` locations at or above `first`.
  uint32_t place(uint32_t first, uint32_t slots, const std::string& key) {
    uint32_t location = first;
    for (;;) {
      bool free = true;
      for (uint32_t slot = location; slot < location + slots && free; ++slot)
        free = !occupied_.count(slot);
      if (free) break;
      ++location;
    }
    take(location, slots, key);
    return location;
  }
  void reserve(uint32_t location) { occupied_.insert(location); }

 private:
  void take(uint32_t location, uint32_t slots, const std::string& key) {
    keys_[location] = key;
    for (uint32_t slot = location; slot < location + slots; ++slot) occupied_.insert(slot);
  }
  std::map<uint32_t, std::string> keys_;
  std::set<uint32_t> occupied_;
};

struct VaryingEntry {
  uint32_t location, slots;
  std::string key;
};

// The varyings of one level, from both stages (the fragment's view wins: it is what is read).
std::vector<VaryingEntry> levelVaryings(const ShaderProgram& level) {
  std::map<uint32_t, VaryingEntry> by_location;
  for (const Module* module : {&level.vertex, &level.fragment}) {
    ir::DefUse uses(*module);
    forEachGlobalVariable(*module, [&](const Instruction& variable) {
      if (!isVarying(*module, uses, variable)) return;
      uint32_t location = *uses.decoration(variable.result_id, spv::DecorationLocation);
      Id type = ir::pointeeType(uses, variable.type_id);
      std::string key = typeSignature(uses, type);
      for (spv::Decoration interpolation :
           {spv::DecorationFlat, spv::DecorationNoPerspective, spv::DecorationCentroid,
            spv::DecorationSample})
        if (uses.hasDecoration(variable.result_id, interpolation))
          key += "/" + std::to_string(static_cast<int>(interpolation));
      by_location[location] = {location, locationSlots(uses, type), key};
    });
  }
  std::vector<VaryingEntry> entries;
  for (auto& [location, entry] : by_location) entries.push_back(entry);
  return entries;
}

std::string parameterKey(const ParameterValue& parameter) {
  std::string key = std::to_string(parameter.components);
  for (int i = 0; i < parameter.components; ++i) key += "," + std::to_string(parameter.value[i]);
  return key;
}

}  // namespace

core::Status checkRoomForAutoLod(const ShaderProgram& original, const std::string& vertex_name,
                                 const std::string& fragment_name, const AutoLodOptions& options) {
  for (const auto& [module, file] :
       {std::pair{&original.vertex, &vertex_name}, std::pair{&original.fragment, &fragment_name}}) {
    ir::DefUse uses(*module);
    for (const ir::LooseUniform& uniform : ir::looseUniforms(*module, uses))
      if (uniform.name == options.uniform_name || uniform.location == options.autolod_location)
        return core::Error{*file + ": uniform '" + uniform.name + "' at location " +
                           std::to_string(uniform.location.value_or(0)) +
                           ": the single LOD shader's level switch needs the name '" +
                           options.uniform_name + "' and location " +
                           std::to_string(options.autolod_location) +
                           " (shaders/INTERFACE.md, reserved): rename or move it"};
  }
  return core::okStatus();
}

namespace {

core::Result<std::vector<LevelMoves>> planLocations(std::span<const ShaderProgram> levels,
                                                    const AutoLodOptions& options) {
  std::vector<LevelMoves> moves(levels.size());
  LocationTable varyings, parameters;
  parameters.reserve(options.autolod_location);
  for (size_t k = 0; k < levels.size(); ++k) {
    // Loose uniforms that are not parameters keep their place (shared by location).
    for (const Module* module : {&levels[k].vertex, &levels[k].fragment}) {
      ir::DefUse uses(*module);
      for (const ir::LooseUniform& uniform : ir::looseUniforms(*module, uses)) {
        if (uniform.name == options.uniform_name || uniform.location == options.autolod_location)
          return core::Error{"autoLOD: level " + std::to_string(k) + " already has a uniform '" +
                             uniform.name + "' at location " +
                             std::to_string(uniform.location.value_or(0)) +
                             ", which the LOD shader's '" + options.uniform_name + "' needs"};
        bool is_parameter = std::any_of(
            levels[k].parameters.begin(), levels[k].parameters.end(),
            [&](const ParameterValue& parameter) { return parameter.location == uniform.location; });
        if (!is_parameter && uniform.location)
          parameters.share(*uniform.location, 1, "uniform " + uniform.name);
      }
    }
    // First every varying/parameter that can stay, then the clashing ones move to free places.
    std::vector<VaryingEntry> clashing_varyings;
    for (const VaryingEntry& entry : levelVaryings(levels[k]))
      if (!varyings.share(entry.location, entry.slots, entry.key)) clashing_varyings.push_back(entry);
    for (const VaryingEntry& entry : clashing_varyings)
      moves[k].varyings[entry.location] = varyings.place(entry.location, entry.slots, entry.key);
    std::vector<const ParameterValue*> clashing_parameters;
    for (const ParameterValue& parameter : levels[k].parameters)
      if (!parameters.share(parameter.location, 1, parameterKey(parameter)))
        clashing_parameters.push_back(&parameter);
    for (const ParameterValue* parameter : clashing_parameters)
      moves[k].parameters[parameter->location] =
          parameters.place(parameter->location, 1, parameterKey(*parameter));
  }
  return moves;
}

// Rewrites the Location decorations of the moved varyings and parameters of one stage.
void applyMoves(Module& module, const LevelMoves& moves) {
  ir::DefUse uses(module);
  std::map<Id, const std::map<uint32_t, uint32_t>*> table_of;
  forEachGlobalVariable(module, [&](const Instruction& variable) {
    if (isVarying(module, uses, variable)) table_of[variable.result_id] = &moves.varyings;
    else if (isLooseUniform(uses, variable)) table_of[variable.result_id] = &moves.parameters;
  });
  for (Instruction& annotation : module.annotations) {
    if (annotation.opcode != spv::OpDecorate || annotation.operands.size() < 3 ||
        annotation.operands[1] != spv::DecorationLocation)
      continue;
    auto table = table_of.find(annotation.operands[0]);
    if (table == table_of.end()) continue;
    auto moved = table->second->find(annotation.operands[2]);
    if (moved != table->second->end()) annotation.operands[2] = moved->second;
  }
}

// ---------------------------------------------------------------------------------------------
// Importing one module's functions into another.

// Decorations and member decorations of `id`, without the target, as text.
std::string decorationSignature(const Module& module, Id id) {
  std::vector<std::string> parts;
  for (const Instruction& annotation : module.annotations) {
    if ((annotation.opcode != spv::OpDecorate && annotation.opcode != spv::OpMemberDecorate) ||
        annotation.operands.empty() || annotation.operands[0] != id)
      continue;
    std::string part = std::to_string(static_cast<int>(annotation.opcode));
    for (size_t i = 1; i < annotation.operands.size(); ++i)
      part += "," + std::to_string(annotation.operands[i]);
    parts.push_back(part);
  }
  std::sort(parts.begin(), parts.end());
  std::string text;
  for (const std::string& part : parts) text += part + ";";
  return text;
}

std::string instructionKey(const Instruction& instruction) {
  std::string key = std::to_string(static_cast<int>(instruction.opcode)) + ":" +
                    std::to_string(instruction.type_id);
  for (uint32_t operand : instruction.operands) key += "," + std::to_string(operand);
  return key;
}

// A global variable's identity across levels: BuiltIn or Location for the interface, Binding for
// resources, Location for loose uniforms. Nothing: each level keeps its own (Private, ...).
std::optional<std::string> variableKey(const ir::DefUse& uses, const Instruction& variable) {
  spv::StorageClass storage = storageOf(variable);
  std::string prefix = std::to_string(static_cast<int>(storage)) + ":";
  Id id = variable.result_id;
  if (storage == spv::StorageClassInput || storage == spv::StorageClassOutput) {
    if (auto builtin = uses.decoration(id, spv::DecorationBuiltIn))
      return prefix + "builtin" + std::to_string(*builtin);
    Id value_type = ir::pointeeType(uses, variable.type_id);
    if (const Instruction* array = uses.def(value_type); array && array->opcode == spv::OpTypeArray)
      value_type = array->operands[0];
    if (auto builtin = uses.memberDecoration(value_type, 0, spv::DecorationBuiltIn))
      return prefix + "block-builtin" + std::to_string(*builtin);
    if (auto location = uses.decoration(id, spv::DecorationLocation))
      return prefix + "location" + std::to_string(*location);
    return std::nullopt;
  }
  if (storage == spv::StorageClassPushConstant) return prefix;
  if (auto binding = uses.decoration(id, spv::DecorationBinding))
    return prefix + "set" + std::to_string(uses.decoration(id, spv::DecorationDescriptorSet).value_or(0)) +
           "binding" + std::to_string(*binding);
  if (auto location = uses.decoration(id, spv::DecorationLocation))
    return prefix + "location" + std::to_string(*location);
  return std::nullopt;
}

// "fbm(vf3;" -> "fbm_lod2(vf3;": imported functions and globals keep readable, distinct names.
std::string levelName(const std::string& name, int level) {
  if (name.empty()) return name;
  std::string suffix = kLevelSuffix + std::to_string(level);
  size_t paren = name.find('(');
  return paren == std::string::npos ? name + suffix : name.substr(0, paren) + suffix + name.substr(paren);
}

// The merged module under construction, with indices over what it already holds.
class StageMerger {
 public:
  explicit StageMerger(Module base) : module_(std::move(base)) {
    ir::DefUse uses(module_);
    for (const Instruction& instruction : module_.types_values) {
      if (!instruction.hasResult()) continue;
      if (instruction.opcode == spv::OpVariable) {
        if (auto key = variableKey(uses, instruction)) variables_[*key] = instruction.result_id;
      } else {
        types_[instruction.opcode == spv::OpUndef ? instructionKey(instruction)
                                                  : instructionKey(instruction) + "|" +
                                                        decorationSignature(module_, instruction.result_id)] =
            instruction.result_id;
      }
    }
  }

  Module& module() { return module_; }

  // Imports every function of `source`; returns the id its entry function has in the merged module.
  core::Result<Id> import(const Module& source, spv::ExecutionModel model, int level) {
    ir::DefUse uses(source);
    std::unordered_map<Id, Id> map;
    std::set<Id> fresh;  // source ids given new instructions (their names/decorations are copied)
    auto mapped = [&](Id id) -> core::Result<Id> {
      auto found = map.find(id);
      if (found == map.end())
        return core::Error{"autoLOD: level " + std::to_string(level) + ": id %" +
                           std::to_string(id) + " is used before it is defined"};
      return found->second;
    };
    auto remap = [&](const Instruction& instruction) -> core::Result<Instruction> {
      Instruction copy = instruction;
      if (copy.type_id != ir::kNoId) {
        auto type = mapped(copy.type_id);
        if (!type) return type.error();
        copy.type_id = *type;
      }
      if (copy.result_id != ir::kNoId) copy.result_id = map.at(copy.result_id);
      for (size_t i = 0; i < copy.operands.size(); ++i) {
        if (!copy.is_id[i]) continue;
        auto operand = mapped(copy.operands[i]);
        if (!operand) return operand.error();
        copy.operands[i] = *operand;
      }
      return copy;
    };

    for (const Instruction& capability : source.capabilities) addUnique(module_.capabilities, capability);
    for (const Instruction& extension : source.extensions) addUnique(module_.extensions, extension);
    for (const Instruction& import : source.ext_inst_imports) {
      Id target = ir::kNoId;
      for (const Instruction& existing : module_.ext_inst_imports)
        if (existing.literalString(0) == import.literalString(0)) target = existing.result_id;
      if (target == ir::kNoId) {
        target = module_.allocateId();
        Instruction copy = import;
        copy.result_id = target;
        module_.ext_inst_imports.push_back(copy);
      }
      map[import.result_id] = target;
    }
    for (const Instruction& annotation : source.annotations)
      if (annotation.opcode == spv::OpDecorationGroup || annotation.opcode == spv::OpGroupDecorate ||
          annotation.opcode == spv::OpGroupMemberDecorate)
        return core::Error{"autoLOD: level " + std::to_string(level) +
                           " uses decoration groups, which the LOD shader builder does not support"};

    // Types, constants and global variables, in order (each refers only to earlier ones).
    for (const Instruction& instruction : source.types_values) {
      if (!instruction.hasResult()) continue;  // OpLine / OpNoLine
      Id source_id = instruction.result_id;
      if (instruction.opcode == spv::OpVariable) {
        auto key = variableKey(uses, instruction);
        auto shared = key ? variables_.find(*key) : variables_.end();
        if (shared != variables_.end()) {
          map[source_id] = shared->second;
          auto copy = remap(instruction);
          if (!copy) return copy.error();
          const Instruction* existing = findGlobal(shared->second);
          if (existing == nullptr || existing->type_id != copy->type_id)
            return core::Error{"autoLOD: level " + std::to_string(level) + "'s '" +
                               source.name(source_id) + "' has another type than level 0's '" +
                               module_.name(shared->second) + "' at the same binding or location"};
          continue;
        }
        Id target = module_.allocateId();
        map[source_id] = target;
        fresh.insert(source_id);
        auto copy = remap(instruction);
        if (!copy) return copy.error();
        module_.types_values.push_back(*copy);
        if (key) variables_[*key] = target;
        continue;
      }
      // A type or constant: shared when structurally equal with the same decorations.
      Id provisional = module_.bound;  // the id it gets when it is new
      map[source_id] = provisional;
      auto copy = remap(instruction);
      if (!copy) return copy.error();
      std::string key = instructionKey(*copy);
      if (instruction.opcode != spv::OpUndef)
        key += "|" + decorationSignature(source, source_id);  // literals only (Offset, Block...)
      auto existing = types_.find(key);
      if (existing != types_.end()) {
        map[source_id] = existing->second;
        continue;
      }
      module_.allocateId();
      fresh.insert(source_id);
      module_.types_values.push_back(*copy);
      types_[key] = provisional;
    }

    // Functions: ids first (bodies refer forward to blocks and functions), then the copies.
    Id entry = ir::kNoId;
    for (const ir::Function& function : source.functions) {
      auto allocate = [&](Id id) {
        map[id] = module_.allocateId();
        fresh.insert(id);
      };
      allocate(function.id());
      for (const Instruction& parameter : function.parameters) allocate(parameter.result_id);
      for (const ir::Block& block : function.blocks) {
        allocate(block.id());
        for (const Instruction& instruction : block.instructions)
          if (instruction.hasResult()) allocate(instruction.result_id);
      }
    }
    const ir::Function* source_entry = source.entryFunction(model);
    for (const ir::Function& function : source.functions) {
      ir::Function copy;
      auto definition = remap(function.definition);
      if (!definition) return definition.error();
      copy.definition = *definition;
      for (const Instruction& parameter : function.parameters) {
        auto mapped_parameter = remap(parameter);
        if (!mapped_parameter) return mapped_parameter.error();
        copy.parameters.push_back(*mapped_parameter);
      }
      for (const ir::Block& block : function.blocks) {
        ir::Block mapped_block;
        mapped_block.label = block.label;
        mapped_block.label.result_id = map.at(block.id());
        for (const Instruction& instruction : block.instructions) {
          // Debug line info names the source's OpStrings, which are not imported.
          if (instruction.opcode == spv::OpLine || instruction.opcode == spv::OpNoLine) continue;
          auto mapped_instruction = remap(instruction);
          if (!mapped_instruction) return mapped_instruction.error();
          mapped_block.instructions.push_back(*mapped_instruction);
        }
        copy.blocks.push_back(std::move(mapped_block));
      }
      copy.end = function.end;
      if (&function == source_entry) entry = copy.id();
      module_.functions.push_back(std::move(copy));
    }
    if (entry == ir::kNoId)
      return core::Error{"autoLOD: level " + std::to_string(level) + " has no entry point for its stage"};

    // Names and decorations of what was copied; functions and private globals get the level's
    // suffix so the cross-compiled source has distinct, readable names.
    std::set<Id> functions_and_globals;
    for (const ir::Function& function : source.functions) functions_and_globals.insert(function.id());
    for (const Instruction& instruction : source.types_values)
      if (instruction.opcode == spv::OpVariable || instruction.opcode == spv::OpTypeStruct)
        functions_and_globals.insert(instruction.result_id);
    for (const Instruction& name : source.names) {
      Id target = name.operands[0];
      if (!fresh.count(target)) continue;
      Instruction copy = name;
      copy.operands[0] = map.at(target);
      if (name.opcode == spv::OpName && functions_and_globals.count(target)) {
        std::vector<uint32_t> operands = {copy.operands[0]};
        std::vector<uint32_t> text = ir::encodeString(levelName(name.literalString(1), level));
        operands.insert(operands.end(), text.begin(), text.end());
        copy = ir::makeInstruction(module_, spv::OpName, ir::kNoId, ir::kNoId, std::move(operands));
      }
      module_.names.push_back(copy);
    }
    if (source_entry != nullptr)
      module_.setName(entry, levelName(source.name(source_entry->id()), level));
    for (const Instruction& annotation : source.annotations) {
      if (annotation.operands.empty() || !fresh.count(annotation.operands[0])) continue;
      auto copy = remap(annotation);
      if (!copy) return copy.error();
      module_.annotations.push_back(*copy);
    }
    for (const Instruction& mode : source.execution_modes) {
      if (source_entry == nullptr || mode.operands.empty() || mode.operands[0] != source_entry->id())
        continue;
      std::vector<uint32_t> tail(mode.operands.begin() + 1, mode.operands.end());
      execution_modes_.insert(tail);
    }
    return entry;
  }

  // The execution modes every level asked for (of its entry point), by operands after the entry.
  std::set<std::vector<uint32_t>>& executionModes() { return execution_modes_; }

 private:
  const Instruction* findGlobal(Id id) const {
    for (const Instruction& instruction : module_.types_values)
      if (instruction.result_id == id) return &instruction;
    return nullptr;
  }

  static void addUnique(std::vector<Instruction>& section, const Instruction& instruction) {
    if (std::find(section.begin(), section.end(), instruction) == section.end())
      section.push_back(instruction);
  }

  Module module_;
  std::map<std::string, Id> types_;      // instructionKey|decorations -> id
  std::map<std::string, Id> variables_;  // variableKey -> id
  std::set<std::vector<uint32_t>> execution_modes_;
};

Instruction rawInstruction(spv::Op opcode, Id type_id, Id result_id, std::vector<uint32_t> operands,
                           std::vector<bool> is_id) {
  return Instruction{opcode, type_id, result_id, std::move(operands), std::move(is_id)};
}

// The new entry function: level = #{k ≥ 1 : thresholds[k] ≤ autoLOD}, then a switch calling the
// level's entry function (levels sharing a stage share a case block).
void addSelectingMain(Module& module, std::span<const float> thresholds, std::span<const Id> level_entry,
                      Id autolod_variable) {
  Id void_type = module.typeVoid();
  Id function_type = module.addTypeOrConstant(spv::OpTypeFunction, ir::kNoId, {void_type});
  Id float_type = module.typeFloat();
  Id bool_type = module.typeBool();
  Id int_type = module.typeInt(32, true);
  Id zero = module.constantInt(0), one = module.constantInt(1);
  std::vector<Id> threshold_constants;
  for (float threshold : thresholds) threshold_constants.push_back(module.constantFloat(threshold));

  ir::Function main;
  main.definition = rawInstruction(spv::OpFunction, void_type, module.allocateId(),
                                   {spv::FunctionControlMaskNone, function_type}, {false, true});
  main.end = rawInstruction(spv::OpFunctionEnd, ir::kNoId, ir::kNoId, {}, {});
  auto label = [&](Id id) { return rawInstruction(spv::OpLabel, ir::kNoId, id, {}, {}); };

  ir::Block entry;
  entry.label = label(module.allocateId());
  Id value = module.allocateId();
  entry.instructions.push_back(
      rawInstruction(spv::OpLoad, float_type, value, {autolod_variable}, {true}));
  Id level = zero;
  for (size_t k = 1; k < thresholds.size(); ++k) {
    Id reached = module.allocateId(), step = module.allocateId(), sum = module.allocateId();
    entry.instructions.push_back(rawInstruction(spv::OpFOrdGreaterThanEqual, bool_type, reached,
                                                {value, threshold_constants[k]}, {true, true}));
    entry.instructions.push_back(
        rawInstruction(spv::OpSelect, int_type, step, {reached, one, zero}, {true, true, true}));
    entry.instructions.push_back(
        rawInstruction(spv::OpIAdd, int_type, sum, {level, step}, {true, true}));
    level = sum;
  }
  Id merge = module.allocateId();
  // One case block per distinct entry function; level 0's is the default.
  std::map<Id, Id> case_block_of_entry;
  std::vector<ir::Block> case_blocks;
  for (Id function : level_entry) {
    if (case_block_of_entry.count(function)) continue;
    ir::Block block;
    block.label = label(module.allocateId());
    block.instructions.push_back(rawInstruction(spv::OpFunctionCall, void_type, module.allocateId(),
                                                {function}, {true}));
    block.instructions.push_back(rawInstruction(spv::OpBranch, ir::kNoId, ir::kNoId, {merge}, {true}));
    case_block_of_entry[function] = block.id();
    case_blocks.push_back(std::move(block));
  }
  Id default_block = case_block_of_entry.at(level_entry[0]);
  std::vector<uint32_t> switch_operands = {level, default_block};
  std::vector<bool> switch_is_id = {true, true};
  for (size_t k = 1; k < level_entry.size(); ++k) {
    Id target = case_block_of_entry.at(level_entry[k]);
    if (target == default_block) continue;
    switch_operands.insert(switch_operands.end(), {static_cast<uint32_t>(k), target});
    switch_is_id.insert(switch_is_id.end(), {false, true});
  }
  entry.instructions.push_back(rawInstruction(spv::OpSelectionMerge, ir::kNoId, ir::kNoId,
                                              {merge, spv::SelectionControlMaskNone}, {true, false}));
  entry.instructions.push_back(rawInstruction(spv::OpSwitch, ir::kNoId, ir::kNoId,
                                              std::move(switch_operands), std::move(switch_is_id)));
  ir::Block merge_block;
  merge_block.label = label(merge);
  merge_block.instructions.push_back(rawInstruction(spv::OpReturn, ir::kNoId, ir::kNoId, {}, {}));

  main.blocks.push_back(std::move(entry));
  for (ir::Block& block : case_blocks) main.blocks.push_back(std::move(block));
  main.blocks.push_back(std::move(merge_block));
  module.functions.push_back(std::move(main));
}

// One stage of the LOD shader from the levels' (moved) modules of that stage.
core::Result<Module> mergeStage(std::span<const Module> distinct, std::span<const int> stage_of_level,
                                spv::ExecutionModel model, std::span<const float> thresholds,
                                const AutoLodOptions& options, const char* stage_name) {
  if (distinct.size() == 1 && model == spv::ExecutionModelVertex) return distinct[0];
  StageMerger merger(distinct[0]);
  Module& merged = merger.module();
  ir::Function* base_entry = merged.entryFunction(model);
  if (base_entry == nullptr)
    return core::Error{std::string("autoLOD: level 0 has no ") + stage_name + " entry point"};
  std::vector<Id> entry_of_stage = {base_entry->id()};
  std::string entry_name = merged.name(base_entry->id());
  merged.setName(base_entry->id(), levelName(entry_name.empty() ? "main" : entry_name, 0));
  for (const Instruction& mode : merged.execution_modes)
    merger.executionModes().insert(std::vector<uint32_t>(mode.operands.begin() + 1, mode.operands.end()));
  for (size_t stage = 1; stage < distinct.size(); ++stage) {
    int first_level = static_cast<int>(
        std::find(stage_of_level.begin(), stage_of_level.end(), static_cast<int>(stage)) -
        stage_of_level.begin());
    auto entry = merger.import(distinct[stage], model, first_level);
    if (!entry) return entry.error();
    entry_of_stage.push_back(*entry);
  }
  std::vector<Id> level_entry;
  for (int stage : stage_of_level) level_entry.push_back(entry_of_stage[stage]);

  Id autolod = merged.addLooseUniform(merged.typeFloat(), options.uniform_name, options.autolod_location);
  addSelectingMain(merged, thresholds, level_entry, autolod);
  Id main = merged.functions.back().id();
  merged.setName(main, entry_name.empty() ? "main" : entry_name);

  // The entry point now names the new main and every Input/Output variable of the module.
  Instruction& entry_point = merged.entry_points.at(0);
  std::vector<uint32_t> operands = {static_cast<uint32_t>(model), main};
  std::vector<uint32_t> name_words = ir::encodeString(entry_name.empty() ? "main" : entry_name);
  operands.insert(operands.end(), name_words.begin(), name_words.end());
  forEachGlobalVariable(merged, [&](const Instruction& variable) {
    spv::StorageClass storage = storageOf(variable);
    if (storage == spv::StorageClassInput || storage == spv::StorageClassOutput)
      operands.push_back(variable.result_id);
  });
  entry_point = ir::makeInstruction(merged, spv::OpEntryPoint, ir::kNoId, ir::kNoId, std::move(operands));
  merged.execution_modes.clear();
  for (const std::vector<uint32_t>& tail : merger.executionModes()) {
    std::vector<uint32_t> mode_operands = {main};
    mode_operands.insert(mode_operands.end(), tail.begin(), tail.end());
    merged.execution_modes.push_back(
        ir::makeInstruction(merged, spv::OpExecutionMode, ir::kNoId, ir::kNoId, std::move(mode_operands)));
  }
  if (auto valid = validateSpirv(ir::emitModule(merged), std::string("autoLOD ") + stage_name); !valid)
    return valid.error();
  return merged;
}

}  // namespace

int autoLodLevel(std::span<const float> thresholds, float autolod) {
  int level = 0;
  for (size_t k = 1; k < thresholds.size(); ++k) level += autolod >= thresholds[k] ? 1 : 0;
  return level;
}

core::Result<AutoLodShader> buildAutoLodShader(std::span<const ShaderProgram> levels,
                                               std::span<const float> thresholds,
                                               const AutoLodOptions& options) {
  if (levels.empty()) return core::Error{"autoLOD: no levels to combine"};
  if (thresholds.size() != levels.size())
    return core::Error{"autoLOD: " + std::to_string(levels.size()) + " levels but " +
                       std::to_string(thresholds.size()) + " thresholds"};
  for (size_t k = 0; k < thresholds.size(); ++k) {
    if (!std::isfinite(thresholds[k]))
      return core::Error{"autoLOD: threshold " + std::to_string(k) + " is not finite"};
    if (k > 0 && !(thresholds[k] > thresholds[k - 1]))
      return core::Error{"autoLOD: thresholds must increase strictly (threshold " +
                         std::to_string(k) + " = " + std::to_string(thresholds[k]) + " after " +
                         std::to_string(thresholds[k - 1]) + ")"};
  }
  auto moves = planLocations(levels, options);
  if (!moves) return moves.error();

  AutoLodShader result;
  result.thresholds.assign(thresholds.begin(), thresholds.end());
  result.autolod_location = options.autolod_location;
  std::vector<Module> vertex_stages, fragment_stages;
  std::vector<std::vector<uint32_t>> vertex_words, fragment_words;
  std::vector<int> vertex_of_level, fragment_of_level;
  std::set<uint32_t> parameter_locations;
  // Levels whose stage is word-identical after the moves share it.
  auto addStage = [](Module module, std::vector<Module>& stages,
                     std::vector<std::vector<uint32_t>>& words, std::vector<int>& stage_of_level) {
    std::vector<uint32_t> emitted = ir::emitModule(module);
    auto same = std::find(words.begin(), words.end(), emitted);
    if (same != words.end()) {
      stage_of_level.push_back(static_cast<int>(same - words.begin()));
      return;
    }
    stage_of_level.push_back(static_cast<int>(stages.size()));
    stages.push_back(std::move(module));
    words.push_back(std::move(emitted));
  };
  for (size_t k = 0; k < levels.size(); ++k) {
    const LevelMoves& level_moves = (*moves)[k];
    result.moved_varyings += static_cast<int>(level_moves.varyings.size());
    result.moved_parameters += static_cast<int>(level_moves.parameters.size());
    Module vertex = levels[k].vertex, fragment = levels[k].fragment;
    applyMoves(vertex, level_moves);
    applyMoves(fragment, level_moves);
    addStage(std::move(vertex), vertex_stages, vertex_words, vertex_of_level);
    addStage(std::move(fragment), fragment_stages, fragment_words, fragment_of_level);
    for (ParameterValue parameter : levels[k].parameters) {
      auto moved = level_moves.parameters.find(parameter.location);
      if (moved != level_moves.parameters.end()) parameter.location = moved->second;
      if (parameter_locations.insert(parameter.location).second)
        result.program.parameters.push_back(parameter);
    }
    std::string words_of_level;
    for (const std::string& step : levels[k].history)
      words_of_level += (words_of_level.empty() ? "" : "; ") + step;
    result.program.history.push_back("level " + std::to_string(k) + " (" + options.uniform_name +
                                     " >= " + std::to_string(thresholds[k]) + "): " +
                                     (words_of_level.empty() ? "original" : words_of_level));
  }
  auto vertex = mergeStage(vertex_stages, vertex_of_level, spv::ExecutionModelVertex, thresholds,
                           options, "vertex");
  if (!vertex) return vertex.error();
  auto fragment = mergeStage(fragment_stages, fragment_of_level, spv::ExecutionModelFragment,
                             thresholds, options, "fragment");
  if (!fragment) return fragment.error();
  result.program.vertex = std::move(*vertex);
  result.program.fragment = std::move(*fragment);
  // Each parameter under the name the merged stages give its uniform: imported globals took
  // their level's suffix ("uAverage_x_40_lod2"), and by-name lookups in the cross-compiled GLSL
  // ES and HLSL (which have no locations) must find what the summary and lod.json list.
  for (const Module* stage :
       {&result.program.vertex, &result.program.fragment}) {  // fragment last: its name wins
    ir::DefUse uses(*stage);
    for (const ir::LooseUniform& uniform : ir::looseUniforms(*stage, uses))
      for (ParameterValue& parameter : result.program.parameters)
        if (uniform.location && *uniform.location == parameter.location && !uniform.name.empty())
          parameter.name = uniform.name;
  }
  result.vertex_stage_of_level = vertex_of_level;
  result.distinct_vertex_stages = static_cast<int>(vertex_stages.size());
  return result;
}

namespace {

// Replaces every load of the loose uniform at each value's location by the value as a constant.
core::Status freezeModule(Module& module, std::span<const ParameterValue> values) {
  // Check and pair first, add the constants after: adding one may move the module's instructions,
  // which `uses` points into.
  std::vector<std::pair<Id, const ParameterValue*>> frozen;
  {
    ir::DefUse uses(module);
    for (const ir::LooseUniform& uniform : ir::looseUniforms(module, uses)) {
      if (!uniform.location) continue;
      for (const ParameterValue& value : values) {
        if (value.location != *uniform.location) continue;
        if (ir::componentCount(uses, uniform.value_type) !=
                static_cast<uint32_t>(value.components) ||
            !ir::isFloatScalarOrVector(uses, uniform.value_type))
          return core::Error{"freezing '" + uniform.name + "' at location " +
                             std::to_string(value.location) + ": it is not a float" +
                             (value.components > 1 ? "vec" + std::to_string(value.components) : "")};
        frozen.push_back({uniform.variable, &value});
      }
    }
  }
  std::map<Id, Id> constant_of_variable;
  for (const auto& [variable, value] : frozen)
    constant_of_variable[variable] = module.constantFloatVector(
        std::span<const float>(value->value.data(), static_cast<size_t>(value->components)));
  std::map<Id, Id> replacement;  // load result -> constant
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks)
      for (const Instruction& instruction : block.instructions)
        if (instruction.opcode == spv::OpLoad && constant_of_variable.count(instruction.operands[0]))
          replacement[instruction.result_id] = constant_of_variable[instruction.operands[0]];
  std::set<Id> loads;
  for (const auto& [load, constant] : replacement) {
    module.replaceAllUses(load, constant);
    loads.insert(load);
  }
  module.removeInstructions(loads);
  return core::okStatus();
}

}  // namespace

core::Result<ShaderProgram> freezeUniforms(const ShaderProgram& program,
                                           std::span<const ParameterValue> values) {
  ShaderProgram frozen = program;
  for (Module* module : {&frozen.vertex, &frozen.fragment})
    if (auto ok = freezeModule(*module, values); !ok) return ok.error();
  std::vector<ParameterValue> remaining;
  for (const ParameterValue& parameter : frozen.parameters) {
    bool is_frozen = std::any_of(values.begin(), values.end(), [&](const ParameterValue& value) {
      return value.location == parameter.location;
    });
    if (!is_frozen) remaining.push_back(parameter);
  }
  frozen.parameters = std::move(remaining);
  return frozen;
}

}  // namespace duolod::shader
