// Analyses on duolod's SPIR-V IR: type and constant queries, the interface (inputs/outputs,
// uniform blocks, loose uniforms, samplers), per-function CFG with a structured order, and the
// program-dependence backward slice used to decide per-pixel → per-vertex moves (Wang et al. 2014,
// "Automatic shader simplification using surface signal approximation").
#include <algorithm>
#include <cstring>
#include <map>

#include "shader/ir.hpp"

namespace duolod::shader::ir {

// ---------------------------------------------------------------------------------------------
// Types and constants.

namespace {
// Nesting limit for type and constant walks: a valid module's types are acyclic and shallow; a
// malformed one (ids referring to themselves) must not recurse forever.
constexpr int kMaxNesting = 64;

TypeInfo typeInfoAt(const DefUse& uses, Id type_id, int depth) {
  TypeInfo info;
  const Instruction* type = uses.def(type_id);
  if (!type || depth > kMaxNesting) return info;
  info.opcode = type->opcode;
  switch (type->opcode) {
    case spv::OpTypeBool:
      info.scalar_type = type_id;
      info.components = 1;
      break;
    case spv::OpTypeFloat:
    case spv::OpTypeInt:
      info.scalar_type = type_id;
      info.components = 1;
      info.width = type->operands[0];
      break;
    case spv::OpTypeVector: {
      TypeInfo component = typeInfoAt(uses, type->operands[0], depth + 1);
      info.scalar_type = component.scalar_type;
      info.width = component.width;
      info.components = type->operands[1];
      break;
    }
    case spv::OpTypeMatrix: {
      TypeInfo column = typeInfoAt(uses, type->operands[0], depth + 1);
      info.scalar_type = column.scalar_type;
      info.width = column.width;
      info.columns = type->operands[1];
      info.components = column.components * info.columns;
      break;
    }
    default: break;
  }
  return info;
}
}  // namespace

TypeInfo typeInfo(const DefUse& uses, Id type_id) { return typeInfoAt(uses, type_id, 0); }

namespace {
spv::Op scalarOpcode(const DefUse& uses, Id type_id) {
  const Instruction* scalar = uses.def(typeInfo(uses, type_id).scalar_type);
  return scalar ? scalar->opcode : spv::OpNop;
}
}  // namespace

bool isFloatType(const DefUse& uses, Id type_id) {
  const Instruction* type = uses.def(type_id);
  return type && type->opcode == spv::OpTypeFloat;
}
bool isFloatVectorType(const DefUse& uses, Id type_id) {
  const Instruction* type = uses.def(type_id);
  return type && type->opcode == spv::OpTypeVector && scalarOpcode(uses, type_id) == spv::OpTypeFloat;
}
bool isFloatScalarOrVector(const DefUse& uses, Id type_id) {
  return isFloatType(uses, type_id) || isFloatVectorType(uses, type_id);
}
bool isMatrixType(const DefUse& uses, Id type_id) {
  const Instruction* type = uses.def(type_id);
  return type && type->opcode == spv::OpTypeMatrix;
}
bool isBoolType(const DefUse& uses, Id type_id) {
  const Instruction* type = uses.def(type_id);
  return type && type->opcode == spv::OpTypeBool;
}
uint32_t componentCount(const DefUse& uses, Id type_id) { return typeInfo(uses, type_id).components; }
Id scalarType(const DefUse& uses, Id type_id) { return typeInfo(uses, type_id).scalar_type; }

std::optional<spv::StorageClass> pointerStorageClass(const DefUse& uses, Id pointer_type) {
  const Instruction* type = uses.def(pointer_type);
  if (!type || type->opcode != spv::OpTypePointer) return std::nullopt;
  return static_cast<spv::StorageClass>(type->operands[0]);
}
Id pointeeType(const DefUse& uses, Id pointer_type) {
  const Instruction* type = uses.def(pointer_type);
  if (!type || type->opcode != spv::OpTypePointer) return kNoId;
  return type->operands[1];
}
bool isSampledImageType(const DefUse& uses, Id type_id) {
  const Instruction* type = uses.def(type_id);
  return type && type->opcode == spv::OpTypeSampledImage;
}

namespace {
bool isOpaqueType(const DefUse& uses, Id type_id, int depth = 0) {
  const Instruction* type = uses.def(type_id);
  if (!type || depth > kMaxNesting) return false;
  switch (type->opcode) {
    case spv::OpTypeImage:
    case spv::OpTypeSampler:
    case spv::OpTypeSampledImage: return true;
    case spv::OpTypeArray:
    case spv::OpTypeRuntimeArray: return isOpaqueType(uses, type->operands[0], depth + 1);
    default: return false;
  }
}
}  // namespace

bool isConstant(const DefUse& uses, Id id) {
  const Instruction* value = uses.def(id);
  if (!value) return false;
  switch (value->opcode) {
    case spv::OpConstant:
    case spv::OpConstantTrue:
    case spv::OpConstantFalse:
    case spv::OpConstantComposite:
    case spv::OpConstantNull:
    case spv::OpSpecConstant:
    case spv::OpSpecConstantTrue:
    case spv::OpSpecConstantFalse:
    case spv::OpSpecConstantComposite:
    case spv::OpSpecConstantOp: return true;
    default: return false;
  }
}

std::optional<float> constantFloatValue(const DefUse& uses, Id id) {
  std::vector<float> values = constantAsFloats(uses, id);
  if (values.size() != 1) return std::nullopt;
  return values[0];
}

std::optional<int64_t> constantIntValue(const DefUse& uses, Id id) {
  const Instruction* value = uses.def(id);
  if (!value || value->opcode != spv::OpConstant) return std::nullopt;
  const Instruction* type = uses.def(value->type_id);
  if (!type || type->opcode != spv::OpTypeInt || type->operands[0] != 32) return std::nullopt;
  if (type->operands[1]) return static_cast<int64_t>(static_cast<int32_t>(value->operands[0]));
  return static_cast<int64_t>(value->operands[0]);
}

namespace {
std::vector<float> constantAsFloatsAt(const DefUse& uses, Id id, int depth) {
  const Instruction* value = uses.def(id);
  if (!value || depth > kMaxNesting) return {};
  switch (value->opcode) {
    case spv::OpConstantTrue: return {1.0f};
    case spv::OpConstantFalse: return {0.0f};
    case spv::OpConstant: {
      const Instruction* type = uses.def(value->type_id);
      if (!type || type->operands[0] != 32 || value->operands.size() != 1) return {};
      if (type->opcode == spv::OpTypeFloat) {
        float result;
        std::memcpy(&result, &value->operands[0], sizeof result);
        return {result};
      }
      if (type->opcode == spv::OpTypeInt)
        return {type->operands[1] ? static_cast<float>(static_cast<int32_t>(value->operands[0]))
                                  : static_cast<float>(value->operands[0])};
      return {};
    }
    case spv::OpConstantNull: {
      uint32_t count = componentCount(uses, value->type_id);
      return std::vector<float>(count, 0.0f);
    }
    case spv::OpConstantComposite: {
      std::vector<float> result;
      for (uint32_t component : value->operands) {
        std::vector<float> part = constantAsFloatsAt(uses, component, depth + 1);
        if (part.empty()) return {};
        result.insert(result.end(), part.begin(), part.end());
      }
      return result;
    }
    default: return {};
  }
}
}  // namespace

std::vector<float> constantAsFloats(const DefUse& uses, Id id) { return constantAsFloatsAt(uses, id, 0); }

// ---------------------------------------------------------------------------------------------
// Interface, uniforms, samplers.

namespace {
template <class Visit>
void forEachGlobalVariable(const Module& module, Visit visit) {
  for (const Instruction& instruction : module.types_values)
    if (instruction.opcode == spv::OpVariable) visit(instruction);
}
}  // namespace

std::vector<InterfaceVariable> interfaceVariables(const Module& module, const DefUse& uses) {
  std::vector<InterfaceVariable> result;
  forEachGlobalVariable(module, [&](const Instruction& variable) {
    auto storage = static_cast<spv::StorageClass>(variable.operands[0]);
    if (storage != spv::StorageClassInput && storage != spv::StorageClassOutput) return;
    InterfaceVariable entry;
    entry.variable = variable.result_id;
    entry.value_type = pointeeType(uses, variable.type_id);
    entry.storage = storage;
    entry.name = module.name(variable.result_id);
    entry.location = uses.decoration(variable.result_id, spv::DecorationLocation);
    if (auto builtin = uses.decoration(variable.result_id, spv::DecorationBuiltIn))
      entry.builtin = static_cast<spv::BuiltIn>(*builtin);
    if (!entry.builtin) {
      // gl_PerVertex-style blocks carry BuiltIn on members; report the first member's.
      Id value_type = entry.value_type;
      if (const Instruction* array = uses.def(value_type); array && array->opcode == spv::OpTypeArray)
        value_type = array->operands[0];
      if (auto builtin = uses.memberDecoration(value_type, 0, spv::DecorationBuiltIn))
        entry.builtin = static_cast<spv::BuiltIn>(*builtin);
    }
    entry.flat = uses.hasDecoration(variable.result_id, spv::DecorationFlat);
    result.push_back(std::move(entry));
  });
  return result;
}

std::vector<UniformBlock> uniformBlocks(const Module& module, const DefUse& uses) {
  std::vector<UniformBlock> result;
  forEachGlobalVariable(module, [&](const Instruction& variable) {
    auto storage = static_cast<spv::StorageClass>(variable.operands[0]);
    if (storage != spv::StorageClassUniform && storage != spv::StorageClassPushConstant &&
        storage != spv::StorageClassStorageBuffer)
      return;
    Id block_type = pointeeType(uses, variable.type_id);
    const Instruction* type = uses.def(block_type);
    if (!type || type->opcode != spv::OpTypeStruct) return;
    UniformBlock block;
    block.variable = variable.result_id;
    block.block_type = block_type;
    block.name = module.name(block_type);
    block.instance_name = module.name(variable.result_id);
    block.binding = uses.decoration(variable.result_id, spv::DecorationBinding);
    for (uint32_t member = 0; member < type->operands.size(); ++member)
      block.members.push_back({member, module.memberName(block_type, member), type->operands[member],
                               uses.memberDecoration(block_type, member, spv::DecorationOffset)});
    result.push_back(std::move(block));
  });
  return result;
}

std::vector<StorageBlock> storageBlocks(const Module& module, const DefUse& uses) {
  std::vector<StorageBlock> result;
  forEachGlobalVariable(module, [&](const Instruction& variable) {
    auto storage = static_cast<spv::StorageClass>(variable.operands[0]);
    if (storage != spv::StorageClassUniform && storage != spv::StorageClassStorageBuffer) return;
    Id type = pointeeType(uses, variable.type_id);
    uint32_t count = 1;
    const Instruction* def = uses.def(type);
    for (int depth = 0; def && def->opcode == spv::OpTypeArray && depth < kMaxNesting; ++depth) {
      count *= static_cast<uint32_t>(
          std::max<int64_t>(1, constantIntValue(uses, def->operands[1]).value_or(1)));
      type = def->operands[0];
      def = uses.def(type);
    }
    if (def && def->opcode == spv::OpTypeRuntimeArray) {
      type = def->operands[0];
      def = uses.def(type);
    }
    if (!def || def->opcode != spv::OpTypeStruct) return;
    if (storage == spv::StorageClassUniform &&
        !uses.hasDecoration(type, spv::DecorationBufferBlock))
      return;  // a uniform block
    std::string name = module.name(type);
    result.push_back({variable.result_id, name.empty() ? module.name(variable.result_id) : name,
                      uses.decoration(variable.result_id, spv::DecorationBinding), count});
  });
  return result;
}

std::vector<LooseUniform> looseUniforms(const Module& module, const DefUse& uses) {
  std::vector<LooseUniform> result;
  forEachGlobalVariable(module, [&](const Instruction& variable) {
    if (variable.operands[0] != spv::StorageClassUniformConstant) return;
    Id value_type = pointeeType(uses, variable.type_id);
    if (isOpaqueType(uses, value_type)) return;
    result.push_back({variable.result_id, value_type, module.name(variable.result_id),
                      uses.decoration(variable.result_id, spv::DecorationLocation)});
  });
  return result;
}

std::vector<Sampler> samplers(const Module& module, const DefUse& uses) {
  std::vector<Sampler> result;
  forEachGlobalVariable(module, [&](const Instruction& variable) {
    if (variable.operands[0] != spv::StorageClassUniformConstant) return;
    Id value_type = pointeeType(uses, variable.type_id);
    if (!isOpaqueType(uses, value_type)) return;
    result.push_back({variable.result_id, value_type, module.name(variable.result_id),
                      uses.decoration(variable.result_id, spv::DecorationBinding)});
  });
  return result;
}

// ---------------------------------------------------------------------------------------------
// CFG.

namespace {
std::vector<Id> branchTargets(const Instruction& terminator) {
  switch (terminator.opcode) {
    case spv::OpBranch: return {terminator.operands[0]};
    case spv::OpBranchConditional: return {terminator.operands[1], terminator.operands[2]};
    case spv::OpSwitch: {
      std::vector<Id> targets;
      for (size_t i = 1; i < terminator.operands.size(); ++i)
        if (terminator.is_id[i]) targets.push_back(terminator.operands[i]);
      return targets;
    }
    default: return {};
  }
}
}  // namespace

Cfg buildCfg(const Function& function) {
  Cfg cfg;
  size_t count = function.blocks.size();
  for (size_t b = 0; b < count; ++b) {
    cfg.blocks.push_back(function.blocks[b].id());
    cfg.index_of[function.blocks[b].id()] = static_cast<int>(b);
  }
  cfg.successors.assign(count, {});
  cfg.predecessors.assign(count, {});
  cfg.merge_block.assign(count, -1);
  cfg.continue_block.assign(count, -1);
  auto indexOf = [&](Id id) {
    auto found = cfg.index_of.find(id);
    return found == cfg.index_of.end() ? -1 : found->second;
  };
  for (size_t b = 0; b < count; ++b) {
    const Block& block = function.blocks[b];
    if (block.instructions.empty()) continue;
    for (Id target : branchTargets(block.terminator())) {
      int t = indexOf(target);
      if (t < 0) continue;
      std::vector<int>& successors = cfg.successors[b];
      if (std::find(successors.begin(), successors.end(), t) != successors.end()) continue;
      successors.push_back(t);
      cfg.predecessors[static_cast<size_t>(t)].push_back(static_cast<int>(b));
    }
    if (const Instruction* merge = block.mergeInstruction()) {
      cfg.merge_block[b] = indexOf(merge->operands[0]);
      if (merge->opcode == spv::OpLoopMerge) cfg.continue_block[b] = indexOf(merge->operands[1]);
    }
  }
  // Iterative DFS over structured successors: merge first, then continue, then branch targets, so
  // the merge block finishes first and comes last in reverse post-order.
  std::vector<bool> visited(count, false);
  std::vector<int> post_order;
  auto structuredSuccessors = [&](int b) {
    std::vector<int> list;
    if (cfg.merge_block[static_cast<size_t>(b)] >= 0) list.push_back(cfg.merge_block[static_cast<size_t>(b)]);
    if (cfg.continue_block[static_cast<size_t>(b)] >= 0)
      list.push_back(cfg.continue_block[static_cast<size_t>(b)]);
    for (int s : cfg.successors[static_cast<size_t>(b)]) list.push_back(s);
    return list;
  };
  if (count > 0) {
    struct Frame {
      int block;
      std::vector<int> next;
      size_t cursor = 0;
    };
    std::vector<Frame> stack;
    visited[0] = true;
    stack.push_back({0, structuredSuccessors(0)});
    while (!stack.empty()) {
      Frame& frame = stack.back();
      if (frame.cursor < frame.next.size()) {
        int next = frame.next[frame.cursor++];
        if (!visited[static_cast<size_t>(next)]) {
          visited[static_cast<size_t>(next)] = true;
          stack.push_back({next, structuredSuccessors(next)});
        }
        continue;
      }
      post_order.push_back(frame.block);
      stack.pop_back();
    }
  }
  cfg.structured_order.assign(post_order.rbegin(), post_order.rend());
  for (size_t b = 0; b < count; ++b)
    if (!visited[b]) cfg.structured_order.push_back(static_cast<int>(b));  // unreachable, last
  return cfg;
}

// ---------------------------------------------------------------------------------------------
// Program dependence.

namespace {

bool isDerivativeOrImplicitLod(spv::Op op) {
  switch (op) {
    case spv::OpDPdx:
    case spv::OpDPdy:
    case spv::OpFwidth:
    case spv::OpDPdxFine:
    case spv::OpDPdyFine:
    case spv::OpFwidthFine:
    case spv::OpDPdxCoarse:
    case spv::OpDPdyCoarse:
    case spv::OpFwidthCoarse:
    case spv::OpImageSampleImplicitLod:
    case spv::OpImageSampleDrefImplicitLod:
    case spv::OpImageSampleProjImplicitLod:
    case spv::OpImageSampleProjDrefImplicitLod:
    case spv::OpImageQueryLod: return true;
    default: return false;
  }
}

bool hasSideEffects(spv::Op op) {
  switch (op) {
    case spv::OpKill:
    case spv::OpTerminateInvocation:
    case spv::OpImageWrite:
    case spv::OpEmitVertex:
    case spv::OpEndPrimitive:
    case spv::OpControlBarrier:
    case spv::OpMemoryBarrier: return true;
    default: return op >= spv::OpAtomicLoad && op <= spv::OpAtomicXor;
  }
}

bool isPointerStep(spv::Op op) {
  return op == spv::OpAccessChain || op == spv::OpInBoundsAccessChain || op == spv::OpPtrAccessChain ||
         op == spv::OpInBoundsPtrAccessChain || op == spv::OpCopyObject;
}

// Blocks each conditional branch may decide about: S is (conservatively) control dependent on
// the conditional block C when S is reachable from C and does not post-dominate C.
class ControlDependence {
 public:
  explicit ControlDependence(const Function& function) : cfg_(buildCfg(function)) {
    size_t count = cfg_.blocks.size();
    // Post-dominator sets by iteration to a fixed point (functions are small).
    std::vector<std::vector<bool>> postdom(count, std::vector<bool>(count, true));
    for (size_t b = 0; b < count; ++b)
      if (cfg_.successors[b].empty()) {
        postdom[b].assign(count, false);
        postdom[b][b] = true;
      }
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t i = count; i-- > 0;) {
        if (cfg_.successors[i].empty()) continue;
        std::vector<bool> meet(count, true);
        for (int s : cfg_.successors[i])
          for (size_t k = 0; k < count; ++k) meet[k] = meet[k] && postdom[static_cast<size_t>(s)][k];
        meet[i] = true;
        if (meet != postdom[i]) {
          postdom[i] = std::move(meet);
          changed = true;
        }
      }
    }
    controllers_.assign(count, {});
    for (size_t c = 0; c < count; ++c) {
      const Block& block = function.blocks[c];
      if (block.instructions.empty()) continue;
      const Instruction& terminator = block.terminator();
      if (terminator.opcode != spv::OpBranchConditional && terminator.opcode != spv::OpSwitch) continue;
      std::vector<bool> reached(count, false);
      std::vector<int> stack(cfg_.successors[c].begin(), cfg_.successors[c].end());
      while (!stack.empty()) {
        int s = stack.back();
        stack.pop_back();
        if (reached[static_cast<size_t>(s)]) continue;
        reached[static_cast<size_t>(s)] = true;
        for (int next : cfg_.successors[static_cast<size_t>(s)]) stack.push_back(next);
      }
      for (size_t s = 0; s < count; ++s)
        if (reached[s] && !postdom[c][s]) controllers_[s].push_back(terminator.operands[0]);
    }
  }
  // Condition / selector ids deciding whether block `label` runs.
  const std::vector<Id>& conditionsFor(Id label) const {
    static const std::vector<Id> none;
    auto found = cfg_.index_of.find(label);
    return found == cfg_.index_of.end() ? none : controllers_[static_cast<size_t>(found->second)];
  }

 private:
  Cfg cfg_;
  std::vector<std::vector<Id>> controllers_;
};

class Slicer {
 public:
  Slicer(const Module& module, const DefUse& uses) : module_(module), uses_(uses) {}

  ValueSources run(std::span<const Id> values) {
    for (Id value : values) push(value);
    while (!work_.empty()) {
      Id id = work_.back();
      work_.pop_back();
      visit(id);
    }
    return std::move(sources_);
  }

  // One node of the slice graph on its own: what visit() pushes for `id` (its dependences) and
  // the flags it sets itself. A node's visit depends on the node alone (callees are summarized
  // again for each node: their flags are the same each time), so run(value) is the closure of
  // these steps and its flags their OR.
  //
  // In this mode a variable read through loads is a node of its own, whose dependences are the
  // stores into it: each load depends on the variable alone. Otherwise every load would list
  // every store, and a local updated in N places and read in N places would cost N² edges (N
  // sequential if/else blocks updating one colour).
  // Such a node's id is the variable's plus the module's bound, apart from the variable's own
  // value (its pointer).
  ValueSources step(Id id, std::vector<Id>& dependences) {
    variables_are_nodes_ = module_.bound < (1u << 31);
    sources_ = ValueSources{};
    seen_.clear();
    callees_.clear();
    followed_.clear();
    work_.clear();
    visit(id);
    dependences.assign(work_.begin(), work_.end());
    work_.clear();
    return std::move(sources_);
  }

 private:
  void push(Id id) {
    if (id != kNoId && seen_.insert(id).second) work_.push_back(id);
  }

  const Function* functionAt(int index) const {
    return index < 0 ? nullptr : &module_.functions[static_cast<size_t>(index)];
  }

  const ControlDependence& controlFor(int function_index) {
    auto found = control_.find(function_index);
    if (found != control_.end()) return found->second;
    return control_.emplace(function_index, ControlDependence(*functionAt(function_index))).first->second;
  }

  // Adds the conditions deciding whether the instruction at `ref` runs.
  void pushControl(const InstructionRef& ref) {
    if (ref.function < 0 || ref.block < 0) return;
    Id label = module_.functions[static_cast<size_t>(ref.function)].blocks[static_cast<size_t>(ref.block)].id();
    for (Id condition : controlFor(ref.function).conditionsFor(label)) push(condition);
  }

  void classifyGlobal(const Instruction& variable) {
    sources_.global_reads.insert(variable.result_id);
    auto storage = static_cast<spv::StorageClass>(variable.operands[0]);
    Id value_type = pointeeType(uses_, variable.type_id);
    switch (storage) {
      case spv::StorageClassInput: sources_.reads_input = true; break;
      case spv::StorageClassUniform:
      case spv::StorageClassPushConstant: sources_.reads_uniform = true; break;
      case spv::StorageClassUniformConstant:
        if (isOpaqueType(uses_, value_type)) {
          sources_.reads_texture = true;
        } else {
          sources_.reads_uniform = true;
        }
        break;
      case spv::StorageClassPrivate:
        readVariable(variable);
        break;
      default: sources_.reads_other = true;
    }
  }

  void readVariable(const Instruction& variable) {
    if (variables_are_nodes_) {
      push(variable.result_id + module_.bound);
    } else {
      followStores(variable);
    }
  }

  // A variable read through loads: the value is whatever was stored into it (any store, any
  // place: flow-insensitive), under the conditions deciding that store, or passed to a call that
  // may write it.
  void followStores(const Instruction& variable) {
    // Within one walk a second follow pushes only what the first did: a variable loaded in N
    // places would cost N times its stores.
    if (!followed_.insert(variable.result_id).second) return;
    if (variable.operands.size() >= 2) push(variable.operands[1]);  // initializer
    std::vector<Id> pointers = {variable.result_id};
    std::set<Id> visited_pointers;
    while (!pointers.empty()) {
      Id pointer = pointers.back();
      pointers.pop_back();
      if (!visited_pointers.insert(pointer).second) continue;
      for (const InstructionRef& user : uses_.users(pointer)) {
        const Instruction& instruction = *user.instruction;
        if (isPointerStep(instruction.opcode) && instruction.operands[0] == pointer) {
          pointers.push_back(instruction.result_id);
        } else if (instruction.opcode == spv::OpStore && instruction.operands[0] == pointer) {
          push(instruction.operands[1]);
          pushControl(user);
        } else if (instruction.opcode == spv::OpCopyMemory && instruction.operands[0] == pointer) {
          push(instruction.operands[1]);
          pushControl(user);
        } else if (instruction.opcode == spv::OpFunctionCall) {
          push(instruction.result_id);
          pushControl(user);
        }
      }
    }
  }

  // A pointer operand: walk access chains to the base variable, following index ids.
  void visitPointer(Id pointer) {
    const Instruction* def = uses_.def(pointer);
    for (int steps = 0; def && isPointerStep(def->opcode); ++steps) {
      if (steps > kMaxNesting) {  // a malformed module's chain that loops
        sources_.reads_other = true;
        return;
      }
      for (size_t i = 1; i < def->operands.size(); ++i)
        if (def->is_id[i]) push(def->operands[i]);
      def = uses_.def(def->operands[0]);
    }
    if (!def) {
      sources_.reads_other = true;
      return;
    }
    if (def->opcode == spv::OpVariable) {
      auto storage = static_cast<spv::StorageClass>(def->operands[0]);
      if (storage == spv::StorageClassFunction) {
        readVariable(*def);
      } else {
        classifyGlobal(*def);
      }
      return;
    }
    if (def->opcode == spv::OpFunctionParameter) {
      // A pointer parameter inside a callee: the caller's variable (unknown here).
      sources_.reads_other = true;
      return;
    }
    sources_.reads_other = true;
  }

  // Everything a called function (and what it calls) reads and does, conservatively.
  void summarizeCallee(Id function_id) {
    if (!callees_.insert(function_id).second) return;
    const Function* callee = module_.findFunction(function_id);
    if (!callee) {
      sources_.reads_other = true;
      return;
    }
    for (const Block& block : callee->blocks)
      for (const Instruction& instruction : block.instructions) {
        if (isDerivativeOrImplicitLod(instruction.opcode)) sources_.uses_derivatives = true;
        if (hasSideEffects(instruction.opcode)) sources_.has_side_effects = true;
        if (instruction.opcode == spv::OpFunctionCall) summarizeCallee(instruction.operands[0]);
        for (size_t i = 0; i < instruction.operands.size(); ++i) {
          if (!instruction.is_id[i]) continue;
          const Instruction* operand = uses_.def(instruction.operands[i]);
          if (!operand || operand->opcode != spv::OpVariable) continue;
          if (operand->operands[0] != spv::StorageClassFunction) classifyGlobal(*operand);
        }
      }
  }

  void visit(Id id) {
    if (variables_are_nodes_ && id >= module_.bound) {  // a variable's stores (see step())
      if (const Instruction* variable = uses_.def(id - module_.bound)) followStores(*variable);
      return;
    }
    const InstructionRef* ref = uses_.defRef(id);
    if (!ref) return;
    const Instruction& instruction = *ref->instruction;
    if (ref->function < 0) {  // module scope: constants, types, global variables
      if (instruction.opcode == spv::OpVariable) classifyGlobal(instruction);
      return;
    }
    if (instruction.opcode == spv::OpLabel || instruction.opcode == spv::OpFunction) return;
    if (instruction.opcode == spv::OpFunctionParameter) {
      sources_.instructions.insert(id);
      sources_.reads_other = true;  // depends on the caller
      return;
    }
    sources_.instructions.insert(id);
    if (isDerivativeOrImplicitLod(instruction.opcode)) sources_.uses_derivatives = true;
    if (hasSideEffects(instruction.opcode)) sources_.has_side_effects = true;
    switch (instruction.opcode) {
      case spv::OpLoad: visitPointer(instruction.operands[0]); return;
      case spv::OpFunctionCall:
        summarizeCallee(instruction.operands[0]);
        for (size_t i = 1; i < instruction.operands.size(); ++i) {
          const Instruction* argument = uses_.def(instruction.operands[i]);
          if (argument && argument->type_id && pointerStorageClass(uses_, argument->type_id)) {
            visitPointer(instruction.operands[i]);
          } else {
            push(instruction.operands[i]);
          }
        }
        return;
      case spv::OpPhi:
        for (size_t i = 0; i + 1 < instruction.operands.size(); i += 2) push(instruction.operands[i]);
        pushControl(*ref);
        for (size_t i = 1; i < instruction.operands.size(); i += 2)
          for (Id condition : controlFor(ref->function).conditionsFor(instruction.operands[i]))
            push(condition);
        return;
      default:
        if (isPointerStep(instruction.opcode)) {
          visitPointer(id);
          return;
        }
        for (size_t i = 0; i < instruction.operands.size(); ++i)
          if (instruction.is_id[i]) push(instruction.operands[i]);
    }
  }

  const Module& module_;
  const DefUse& uses_;
  ValueSources sources_;
  std::set<Id> seen_, callees_, followed_;
  std::vector<Id> work_;
  std::map<int, ControlDependence> control_;
  bool variables_are_nodes_ = false;  // step() mode
};

}  // namespace

ValueSources backwardSlice(const Module& module, const DefUse& uses, Id value) {
  return Slicer(module, uses).run(std::span<const Id>(&value, 1));
}

ValueSources backwardSlice(const Module& module, const DefUse& uses, std::span<const Id> values) {
  return Slicer(module, uses).run(values);
}

namespace {

void merge(SliceFlags& into, const SliceFlags& from) {
  into.reads_input |= from.reads_input;
  into.reads_uniform |= from.reads_uniform;
  into.reads_texture |= from.reads_texture;
  into.reads_other |= from.reads_other;
  into.uses_derivatives |= from.uses_derivatives;
  into.has_side_effects |= from.has_side_effects;
  into.reaches_marked |= from.reaches_marked;
}

}  // namespace

struct SliceSummaries::Impl {
  struct Node {
    std::vector<Id> dependences;
    SliceFlags own;
    int index = -1, lowlink = -1;
    int component = -1;
    bool on_stack = false;
  };

  Impl(const Module& module, const DefUse& uses, std::function<bool(const Instruction&)> marked)
      : uses(uses), slicer(module, uses), marked(std::move(marked)) {}

  int nodeFor(Id id) {
    auto [found, added] = node_of.emplace(id, static_cast<int>(nodes.size()));
    if (!added) return found->second;
    Node node;
    ValueSources own = slicer.step(id, node.dependences);
    node.own.reads_input = own.reads_input;
    node.own.reads_uniform = own.reads_uniform;
    node.own.reads_texture = own.reads_texture;
    node.own.reads_other = own.reads_other;
    node.own.uses_derivatives = own.uses_derivatives;
    node.own.has_side_effects = own.has_side_effects;
    if (own.instructions.count(id)) {
      const Instruction* def = uses.def(id);
      node.own.reaches_marked = def && this->marked(*def);
    }
    nodes.push_back(std::move(node));
    return found->second;
  }

  // Tarjan's strongly connected components from `root`, iteratively (a shader's dependence chain
  // can be thousands of values long); a component's flags are its members' and those of the
  // components it depends on, which Tarjan completes first.
  void complete(int root) {
    std::vector<std::pair<int, size_t>> calls;
    std::vector<int> stack;
    auto open = [&](int v) {
      nodes[v].index = nodes[v].lowlink = next_index++;
      nodes[v].on_stack = true;
      stack.push_back(v);
      calls.emplace_back(v, 0);
    };
    open(root);
    while (!calls.empty()) {
      int v = calls.back().first;
      size_t next = calls.back().second;
      if (next < nodes[v].dependences.size()) {
        calls.back().second = next + 1;
        int w = nodeFor(nodes[v].dependences[next]);
        if (nodes[w].component >= 0) continue;
        if (nodes[w].index < 0) {
          open(w);
        } else if (nodes[w].on_stack) {
          nodes[v].lowlink = std::min(nodes[v].lowlink, nodes[w].index);
        }
        continue;
      }
      calls.pop_back();
      if (!calls.empty()) {
        int parent = calls.back().first;
        nodes[parent].lowlink = std::min(nodes[parent].lowlink, nodes[v].lowlink);
      }
      if (nodes[v].lowlink != nodes[v].index) continue;
      int component = static_cast<int>(component_flags.size());
      size_t first = stack.size();
      do {
        --first;
      } while (stack[first] != v);
      SliceFlags flags;
      for (size_t k = first; k < stack.size(); ++k) {
        Node& member = nodes[stack[k]];
        member.on_stack = false;
        member.component = component;
        merge(flags, member.own);
      }
      for (size_t k = first; k < stack.size(); ++k)
        for (Id dependence : nodes[stack[k]].dependences) {
          int other = nodes[node_of.at(dependence)].component;
          if (other != component) merge(flags, component_flags[static_cast<size_t>(other)]);
        }
      component_flags.push_back(flags);
      stack.resize(first);
    }
  }

  const DefUse& uses;
  Slicer slicer;
  std::function<bool(const Instruction&)> marked;
  std::unordered_map<Id, int> node_of;
  std::vector<Node> nodes;
  std::vector<SliceFlags> component_flags;
  int next_index = 0;
};

SliceSummaries::SliceSummaries(const Module& module, const DefUse& uses,
                               std::function<bool(const Instruction&)> marked)
    : impl_(std::make_unique<Impl>(module, uses, std::move(marked))) {}

SliceSummaries::~SliceSummaries() = default;
SliceSummaries::SliceSummaries(SliceSummaries&&) noexcept = default;
SliceSummaries& SliceSummaries::operator=(SliceSummaries&&) noexcept = default;

SliceFlags SliceSummaries::of(Id value) {
  int node = impl_->nodeFor(value);
  if (impl_->nodes[static_cast<size_t>(node)].component < 0) impl_->complete(node);
  return impl_
      ->component_flags[static_cast<size_t>(impl_->nodes[static_cast<size_t>(node)].component)];
}

size_t SliceSummaries::dependenceCount() const {
  size_t count = 0;
  for (const Impl::Node& node : impl_->nodes) count += node.dependences.size();
  return count;
}

}  // namespace duolod::shader::ir
