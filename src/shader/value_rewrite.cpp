// Helpers for rules that replace a fragment value (see value_rewrite.hpp).
#include "shader/value_rewrite.hpp"

#include <algorithm>
#include <functional>
#include <map>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include "shader/rules_internal.hpp"

namespace duolod::shader {

using ir::Id;
using ir::Instruction;
using ir::Module;

int entryFunctionIndex(const Module& module, spv::ExecutionModel model) {
  const ir::Function* function = module.entryFunction(model);
  if (!function) return -1;
  return static_cast<int>(function - module.functions.data());
}

Id glslStd450Import(Module& module) {
  for (const Instruction& import : module.ext_inst_imports)
    if (import.literalString(0) == "GLSL.std.450") return import.result_id;
  Id id = module.allocateId();
  module.ext_inst_imports.push_back(ir::makeInstruction(module, spv::OpExtInstImport, ir::kNoId, id,
                                                        ir::encodeString("GLSL.std.450")));
  return id;
}

void addToEntryInterface(Module& module, spv::ExecutionModel model, Id variable) {
  for (Instruction& entry : module.entry_points) {
    if (entry.operands.empty() || entry.operands[0] != static_cast<uint32_t>(model)) continue;
    entry.operands.push_back(variable);
    entry.is_id.push_back(true);
  }
}

std::optional<ir::InstructionPosition> insertionPointFor(const Module& module, Id value) {
  std::optional<ir::InstructionPosition> position = module.findPosition(value);
  if (!position) return std::nullopt;
  const std::vector<Instruction>& list =
      module.functions[position->function].blocks[position->block].instructions;
  if (list[position->index].opcode == spv::OpPhi) {
    // SPIR-V requires the phis first in their block.
    while (position->index < static_cast<int>(list.size()) &&
           list[position->index].opcode == spv::OpPhi)
      ++position->index;
  }
  return position;
}

core::Result<Id> replaceValueByLoad(Module& module, Id value, Id variable) {
  std::optional<ir::InstructionPosition> defined_at = module.findPosition(value);
  std::optional<ir::InstructionPosition> position = insertionPointFor(module, value);
  if (!defined_at || !position)
    return core::Error{"value %" + std::to_string(value) + " is not in a function body"};
  Id type = module.functions[defined_at->function]
                .blocks[defined_at->block]
                .instructions[defined_at->index]
                .type_id;
  Id load = module.allocateId();
  module.insertBefore(*position,
                      {ir::makeInstruction(module, spv::OpLoad, type, load, {variable})});
  module.replaceAllUses(value, load);
  removeDeadCode(module);
  return load;
}

namespace {

bool isAtomic(spv::Op op) {
  return (op >= spv::OpAtomicLoad && op <= spv::OpAtomicXor) || op == spv::OpAtomicFlagTestAndSet ||
         op == spv::OpAtomicFlagClear;
}

// Opcodes whose removal, once their result is unused, cannot change what the shader does.
bool removableWhenUnused(const Module& module, const Instruction& instruction) {
  switch (instruction.opcode) {
    case spv::OpFunctionCall:
    case spv::OpVariable:
    case spv::OpFunctionParameter:
    case spv::OpLabel:
    case spv::OpImageTexelPointer:
      return false;
    case spv::OpExtInst: {
      // Only GLSL.std.450 is known to be free of side effects.
      for (const Instruction& import : module.ext_inst_imports)
        if (import.result_id == instruction.operands[0])
          return import.literalString(0) == "GLSL.std.450";
      return false;
    }
    default:
      return !isAtomic(instruction.opcode);
  }
}

// The variable (or parameter) a pointer is based on, through access chains.
const Instruction* pointerBase(const ir::DefUse& uses, Id pointer) {
  const Instruction* def = uses.def(pointer);
  while (def && (def->opcode == spv::OpAccessChain || def->opcode == spv::OpInBoundsAccessChain ||
                 def->opcode == spv::OpPtrAccessChain || def->opcode == spv::OpCopyObject))
    def = uses.def(def->operands[0]);
  return def;
}

bool isLocalPointer(const Instruction* base) {
  if (!base) return false;
  if (base->opcode == spv::OpFunctionParameter) return true;
  return base->opcode == spv::OpVariable && base->operands[0] == spv::StorageClassFunction;
}

// True when calling `function` can only write memory reachable from its own pointer arguments
// and locals, and has no other effect (discard, atomics, image writes, unknown extended sets).
bool functionIsPure(const Module& module, const ir::DefUse& uses, Id function_id,
                    std::map<Id, bool>& memo) {
  if (auto found = memo.find(function_id); found != memo.end()) return found->second;
  memo[function_id] = false;  // recursion is illegal in SPIR-V shaders; be conservative
  const ir::Function* function = module.findFunction(function_id);
  if (!function) return false;
  for (const ir::Block& block : function->blocks)
    for (const Instruction& instruction : block.instructions) {
      switch (instruction.opcode) {
        case spv::OpKill:
        case spv::OpTerminateInvocation:
        case spv::OpDemoteToHelperInvocation:
        case spv::OpImageWrite:
        case spv::OpEmitVertex:
        case spv::OpEndPrimitive:
        case spv::OpControlBarrier:
        case spv::OpMemoryBarrier:
          return false;
        case spv::OpStore:
        case spv::OpCopyMemory:
          if (!isLocalPointer(pointerBase(uses, instruction.operands[0]))) return false;
          break;
        case spv::OpFunctionCall:
          if (!functionIsPure(module, uses, instruction.operands[0], memo)) return false;
          break;
        case spv::OpExtInst:
          if (!removableWhenUnused(module, instruction)) return false;
          break;
        default:
          if (isAtomic(instruction.opcode)) return false;
      }
    }
  memo[function_id] = true;
  return true;
}

bool isDebugOrAnnotation(spv::Op op) {
  return op == spv::OpName || op == spv::OpMemberName || op == spv::OpDecorate ||
         op == spv::OpMemberDecorate || op == spv::OpDecorateId || op == spv::OpLine;
}

// The distinct ids an instruction uses (its result type and id operands), as DefUse lists them:
// one use per (instruction, id).
std::vector<Id> distinctUses(const Instruction& instruction) {
  std::vector<Id> ids;
  if (instruction.type_id) ids.push_back(instruction.type_id);
  for (size_t i = 0; i < instruction.operands.size(); ++i)
    if (instruction.is_id[i]) ids.push_back(instruction.operands[i]);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

bool isStoreInto(const Instruction& instruction, Id variable) {
  return instruction.opcode == spv::OpStore && instruction.operands[0] == variable;
}

// Dead-code removal as a worklist over use counts (each removal updates the counts of what the
// removed instruction used and queues their definitions), so a chain of N values that dies from
// its end costs O(N), not the O(N²) of sweeping until nothing changes (a 400-statement shader
// took 0.5 s a rule application that way). The rules are monotone (removing an instruction
// never makes another one needed), so the result is the same fixpoint whatever the order.
class DeadCodeRemover {
 public:
  explicit DeadCodeRemover(const Module& module) : module_(module), uses_(module) {
    for (const Instruction& entry : module.entry_points) entry_functions_.insert(entry.operands[1]);
  }

  // Finds everything removable: `dead` holds result ids (functions and their contents
  // included), `store_targets` the Function variables whose stores go with them.
  void run(std::set<Id>& dead, std::set<Id>& store_targets) {
    for (const ir::Function& function : module_.functions)
      for (const ir::Block& block : function.blocks)
        for (const Instruction& instruction : block.instructions) {
          if (isDebugOrAnnotation(instruction.opcode)) continue;  // names do not keep values
          for (Id id : distinctUses(instruction)) {
            ++live_uses_[id];
            const Instruction* def = uses_.def(id);
            if (!(def && def->opcode == spv::OpVariable && isStoreInto(instruction, id)))
              ++live_non_store_uses_[id];
          }
        }
    for (const ir::Function& function : module_.functions) {
      // Uses from parameters and the definition (types) matter for no removable id.
      pending_functions_.push_back(function.id());
      for (const ir::Block& block : function.blocks)
        for (const Instruction& instruction : block.instructions) pending_.push_back(&instruction);
    }
    while (!pending_.empty() || !pending_functions_.empty()) {
      if (!pending_functions_.empty()) {
        Id function = pending_functions_.back();
        pending_functions_.pop_back();
        considerFunction(function);
        continue;
      }
      const Instruction* instruction = pending_.back();
      pending_.pop_back();
      consider(*instruction);
    }
    dead = std::move(dead_ids_);
    store_targets = std::move(store_targets_);
  }

 private:
  bool isDead(const Instruction& instruction) const { return dead_.count(&instruction) > 0; }

  void considerFunction(Id function_id) {
    if (dead_functions_.count(function_id) || entry_functions_.count(function_id)) return;
    if (live_uses_[function_id] != 0) return;
    const ir::Function* function = module_.findFunction(function_id);
    if (!function) return;
    // The whole function goes, and with it the names of everything defined inside.
    dead_functions_.insert(function_id);
    dead_ids_.insert(function_id);
    for (const Instruction& parameter : function->parameters) dead_ids_.insert(parameter.result_id);
    for (const ir::Block& block : function->blocks) {
      dead_ids_.insert(block.id());
      for (const Instruction& instruction : block.instructions) {
        if (instruction.hasResult()) dead_ids_.insert(instruction.result_id);
        if (!isDead(instruction)) kill(instruction);
      }
    }
  }

  void consider(const Instruction& instruction) {
    if (isDead(instruction) || !instruction.hasResult()) return;
    const ir::InstructionRef* ref = uses_.defRef(instruction.result_id);
    if (ref && ref->function >= 0 &&
        dead_functions_.count(module_.functions[static_cast<size_t>(ref->function)].id()))
      return;
    if (instruction.opcode == spv::OpVariable) {
      if (live_non_store_uses_[instruction.result_id] != 0) return;
      dead_ids_.insert(instruction.result_id);
      store_targets_.insert(instruction.result_id);
      kill(instruction);
      for (const ir::InstructionRef& user : uses_.users(instruction.result_id))
        if (isStoreInto(*user.instruction, instruction.result_id) && !isDead(*user.instruction))
          kill(*user.instruction);
      return;
    }
    if (live_uses_[instruction.result_id] != 0) return;
    if (instruction.opcode == spv::OpFunctionCall) {
      if (!functionIsPure(module_, uses_, instruction.operands[0], pure_functions_)) return;
      // The callee may write through its pointer arguments: only drop the call when nobody
      // reads those variables (parameter temporaries, which are then dropped too).
      for (size_t i = 1; i < instruction.operands.size(); ++i) {
        const Instruction* argument = uses_.def(instruction.operands[i]);
        if (!argument || !argument->type_id || !ir::pointerStorageClass(uses_, argument->type_id))
          continue;
        if (argument->opcode != spv::OpVariable) return;
        for (const ir::InstructionRef& user : uses_.users(argument->result_id)) {
          const Instruction& reader = *user.instruction;
          if (isDebugOrAnnotation(reader.opcode) || isDead(reader)) continue;
          if (reader.opcode != spv::OpStore && reader.opcode != spv::OpFunctionCall) return;
        }
      }
    } else if (!removableWhenUnused(module_, instruction)) {
      return;
    }
    dead_ids_.insert(instruction.result_id);
    kill(instruction);
  }

  // Marks `instruction` removed and takes its uses off what it used, queueing those for another
  // look (and, for a variable, the calls it is passed to: their arguments may now be unread).
  void kill(const Instruction& instruction) {
    dead_.insert(&instruction);
    if (isDebugOrAnnotation(instruction.opcode)) return;  // its uses were never counted
    for (Id id : distinctUses(instruction)) {
      --live_uses_[id];
      const Instruction* def = uses_.def(id);
      bool variable = def && def->opcode == spv::OpVariable;
      if (!(variable && isStoreInto(instruction, id))) --live_non_store_uses_[id];
      if (!def) continue;
      if (def->opcode == spv::OpFunction) {
        pending_functions_.push_back(id);
        continue;
      }
      // Only function-body instructions are removed (never types, constants, globals).
      const ir::InstructionRef* ref = uses_.defRef(id);
      if (ref->block < 0 || ref->index < 0) continue;
      pending_.push_back(def);
      if (variable)
        for (const ir::InstructionRef& user : uses_.users(id))
          if (user.instruction->opcode == spv::OpFunctionCall) pending_.push_back(user.instruction);
    }
  }

  const Module& module_;
  ir::DefUse uses_;
  std::set<Id> entry_functions_;
  std::unordered_map<Id, int64_t> live_uses_;            // by live instructions in function bodies
  std::unordered_map<Id, int64_t> live_non_store_uses_;  // the same, less stores into the id
  std::unordered_set<const Instruction*> dead_;
  std::set<Id> dead_functions_;
  std::set<Id> dead_ids_;
  std::set<Id> store_targets_;
  std::map<Id, bool> pure_functions_;
  std::vector<const Instruction*> pending_;
  std::vector<Id> pending_functions_;
};

}  // namespace

size_t removeDeadCode(Module& module) {
  std::set<Id> dead;
  std::set<Id> store_targets;
  DeadCodeRemover(module).run(dead, store_targets);
  if (dead.empty()) return 0;
  size_t before = 0, after = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks) before += block.instructions.size();
  module.removeInstructionsIf([&](const Instruction& instruction) {
    return instruction.opcode == spv::OpStore && store_targets.count(instruction.operands[0]);
  });
  module.removeInstructions(dead);
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks) after += block.instructions.size();
  return before - after;
}

namespace {

// How many locations a value of `type` occupies (SPIR-V / GLSL location rules, 32-bit types).
uint32_t locationsSpanned(const ir::DefUse& uses, Id type) {
  const Instruction* def = uses.def(type);
  if (!def) return 1;
  switch (def->opcode) {
    case spv::OpTypeMatrix:
      return def->operands[1];
    case spv::OpTypeArray: {
      auto length = ir::constantIntValue(uses, def->operands[1]);
      return static_cast<uint32_t>(std::max<int64_t>(1, length.value_or(1))) *
             locationsSpanned(uses, def->operands[0]);
    }
    case spv::OpTypeStruct: {
      uint32_t total = 0;
      for (uint32_t member : def->operands) total += locationsSpanned(uses, member);
      return total;
    }
    default:
      return 1;
  }
}

}  // namespace

uint32_t freeVaryingLocation(const Module& vertex, const Module& fragment, uint32_t first) {
  std::set<uint32_t> taken;
  for (const auto& [module, storage] : {std::pair{&vertex, spv::StorageClassOutput},
                                        std::pair{&fragment, spv::StorageClassInput}}) {
    ir::DefUse uses(*module);
    for (const ir::InterfaceVariable& variable : ir::interfaceVariables(*module, uses)) {
      if (variable.storage != storage || !variable.location) continue;
      uint32_t span = locationsSpanned(uses, variable.value_type);
      for (uint32_t i = 0; i < span; ++i) taken.insert(*variable.location + i);
    }
  }
  uint32_t location = first;
  while (taken.count(location)) ++location;
  return location;
}

uint32_t freeUniformLocation(const std::vector<const Module*>& modules, uint32_t first,
                             const std::vector<uint32_t>& taken_list) {
  std::set<uint32_t> taken(taken_list.begin(), taken_list.end());
  for (const Module* module : modules) {
    ir::DefUse uses(*module);
    for (const ir::LooseUniform& uniform : ir::looseUniforms(*module, uses))
      if (uniform.location) {
        uint32_t span = locationsSpanned(uses, uniform.value_type);
        for (uint32_t i = 0; i < span; ++i) taken.insert(*uniform.location + i);
      }
  }
  uint32_t location = first;
  while (taken.count(location)) ++location;
  return location;
}

std::vector<bool> loopConstructBlocks(const ir::Cfg& cfg, int header) {
  std::vector<bool> in_loop(cfg.blocks.size(), false);
  int merge_block = cfg.merge_block[static_cast<size_t>(header)];
  std::vector<int> stack = {header};
  while (!stack.empty()) {
    int block = stack.back();
    stack.pop_back();
    if (block == merge_block || in_loop[static_cast<size_t>(block)]) continue;
    in_loop[static_cast<size_t>(block)] = true;
    for (int next : cfg.successors[static_cast<size_t>(block)]) stack.push_back(next);
  }
  return in_loop;
}

std::set<Id> blocksInLoops(const ir::Function& function) {
  std::set<Id> inside;
  ir::Cfg cfg = ir::buildCfg(function);
  for (size_t header = 0; header < function.blocks.size(); ++header) {
    const Instruction* merge = function.blocks[header].mergeInstruction();
    if (!merge || merge->opcode != spv::OpLoopMerge) continue;
    std::vector<bool> in_loop = loopConstructBlocks(cfg, static_cast<int>(header));
    for (size_t block = 0; block < in_loop.size(); ++block)
      if (in_loop[block]) inside.insert(cfg.blocks[block]);
  }
  return inside;
}

std::vector<Id> candidateValues(const Module& module, const ir::DefUse& uses,
                                spv::ExecutionModel model) {
  std::vector<Id> result;
  int entry = entryFunctionIndex(module, model);
  if (entry < 0) return result;
  for (const ir::Block& block : module.functions[entry].blocks)
    for (const Instruction& instruction : block.instructions) {
      if (!instruction.hasResult() || !instruction.type_id) continue;
      switch (instruction.opcode) {
        case spv::OpLoad:
        case spv::OpAccessChain:
        case spv::OpInBoundsAccessChain:
        case spv::OpVariable:
        case spv::OpPhi:
        case spv::OpCopyObject:
        case spv::OpUndef:
          continue;
        default:
          break;
      }
      if (!ir::isFloatScalarOrVector(uses, instruction.type_id)) continue;
      if (ir::typeInfo(uses, instruction.type_id).width != 32) continue;
      result.push_back(instruction.result_id);
    }
  return result;
}

bool isComputingInstruction(const Instruction& instruction) {
  switch (instruction.opcode) {
    case spv::OpLoad:
    case spv::OpAccessChain:
    case spv::OpInBoundsAccessChain:
    case spv::OpVariable:
    case spv::OpCompositeExtract:
    case spv::OpCompositeConstruct:
    case spv::OpVectorShuffle:
    case spv::OpCopyObject:
      return false;
    default:
      return true;
  }
}

ir::SliceSummaries computingSliceSummaries(const Module& module, const ir::DefUse& uses) {
  return ir::SliceSummaries(module, uses, isComputingInstruction);
}

std::string describeComputedValue(const Module& module, const ir::DefUse& uses, Id value) {
  std::string own = module.name(value);
  if (!own.empty()) return own;
  // glslang's call-argument temporaries are all called "param": a GLSL variable says more.
  std::string temporary;
  for (const ir::InstructionRef& user : uses.users(value)) {
    const Instruction& instruction = *user.instruction;
    if (instruction.opcode != spv::OpStore || instruction.operands[1] != value) continue;
    std::string stored_into = module.name(instruction.operands[0]);
    if (stored_into.rfind("param", 0) == 0) {
      temporary = stored_into;
    } else if (!stored_into.empty()) {
      return stored_into;
    }
  }
  return temporary.empty() ? describeOperand(module, uses, value) : temporary;
}

}  // namespace duolod::shader
