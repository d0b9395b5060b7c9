// Block-count instrumentation of a SPIR-V module (shader/instrument.hpp). The render side lives in
// block_profile.cpp.
#include "shader/instrument.hpp"

#include <algorithm>
#include <set>
#include <string>
#include <utility>

namespace duolod::shader {

using core::Error;

namespace {

void addDecoration(ir::Module& module, ir::Id target, spv::Decoration decoration,
                   std::vector<uint32_t> literals = {}) {
  std::vector<uint32_t> operands{target, static_cast<uint32_t>(decoration)};
  operands.insert(operands.end(), literals.begin(), literals.end());
  module.annotations.push_back(
      ir::makeInstruction(module, spv::OpDecorate, ir::kNoId, ir::kNoId, std::move(operands)));
}

// Where the counter increment goes: after the OpPhis (which must lead a block) and, in a function's
// entry block, after the OpVariables (which must lead the entry block) and any debug lines between.
size_t firstInsertionIndex(const ir::Block& block, bool entry_block) {
  size_t index = 0;
  while (index < block.instructions.size()) {
    spv::Op opcode = block.instructions[index].opcode;
    bool leading = opcode == spv::OpPhi || opcode == spv::OpLine || opcode == spv::OpNoLine ||
                   (entry_block && opcode == spv::OpVariable);
    if (!leading) break;
    ++index;
  }
  return index;
}

}  // namespace

std::pair<uint32_t, uint32_t> counterBindings(const ir::Module& vertex,
                                              const ir::Module& fragment) {
  std::set<uint32_t> taken = {14, 15};
  for (const ir::Module* module : {&vertex, &fragment}) {
    ir::DefUse uses(*module);
    for (const ir::StorageBlock& block : ir::storageBlocks(*module, uses))
      if (block.binding)
        for (uint32_t i = 0; i < block.count; ++i) taken.insert(*block.binding + i);
  }
  uint32_t first = kVertexCounterBinding;
  while (taken.count(first)) ++first;
  uint32_t second = first + 1;
  while (taken.count(second)) ++second;
  return {first, second};
}

core::Result<InstrumentedModule> instrumentBlockCounts(const ir::Module& original,
                                                       uint32_t binding) {
  if (original.functions.empty()) return Error{"instrumentation: the module has no functions"};
  InstrumentedModule result{.module = original, .binding = binding};
  ir::Module& module = result.module;

  // buffer DuolodBlockCounts { uint count[]; } counters;  (SPIR-V 1.0 for OpenGL: Uniform storage
  // with BufferBlock, as glslang emits SSBOs for GL 4.5). The array and struct are fresh types, so
  // their decorations cannot clash with a structurally equal type of the shader.
  ir::Id uint_type = module.typeInt(32, false);
  ir::Id array_type = module.allocateId();
  module.types_values.push_back(
      ir::makeInstruction(module, spv::OpTypeRuntimeArray, ir::kNoId, array_type, {uint_type}));
  ir::Id block_type = module.allocateId();
  module.types_values.push_back(
      ir::makeInstruction(module, spv::OpTypeStruct, ir::kNoId, block_type, {array_type}));
  ir::Id block_pointer = module.typePointer(spv::StorageClassUniform, block_type);
  ir::Id counters = module.allocateId();
  module.types_values.push_back(ir::makeInstruction(module, spv::OpVariable, block_pointer,
                                                    counters, {spv::StorageClassUniform}));
  ir::Id element_pointer = module.typePointer(spv::StorageClassUniform, uint_type);
  addDecoration(module, array_type, spv::DecorationArrayStride, {4});
  module.annotations.push_back(ir::makeInstruction(
      module, spv::OpMemberDecorate, ir::kNoId, ir::kNoId,
      {block_type, 0, static_cast<uint32_t>(spv::DecorationOffset), 0}));
  addDecoration(module, block_type, spv::DecorationBufferBlock);
  addDecoration(module, counters, spv::DecorationBinding, {binding});
  module.setName(block_type, "DuolodBlockCounts");
  module.setName(counters, "duolodBlockCounts");

  ir::Id member_zero = module.constantInt(0);
  ir::Id scope_device = module.constantUint(spv::ScopeDevice);
  ir::Id semantics_relaxed = module.constantUint(spv::MemorySemanticsMaskNone);
  ir::Id one = module.constantUint(1);

  int counter = 0;
  for (ir::Function& function : module.functions) {
    for (size_t b = 0; b < function.blocks.size(); ++b) {
      ir::Block& block = function.blocks[b];
      ir::Id index = module.constantUint(static_cast<uint32_t>(counter++));
      ir::Id pointer = module.allocateId();
      ir::Id previous = module.allocateId();
      std::vector<ir::Instruction> increment{
          ir::makeInstruction(module, spv::OpAccessChain, element_pointer, pointer,
                              {counters, member_zero, index}),
          ir::makeInstruction(module, spv::OpAtomicIAdd, uint_type, previous,
                              {pointer, scope_device, semantics_relaxed, one}),
      };
      size_t at = firstInsertionIndex(block, b == 0);
      block.instructions.insert(block.instructions.begin() + static_cast<std::ptrdiff_t>(at),
                                increment.begin(), increment.end());
    }
  }
  result.counter_count = counter;
  return result;
}

CostFeatures profiledCostFeatures(const ir::Module& vertex, const ir::Module& fragment,
                                  const BlockProfile& profile, double vertex_invocations_per_draw,
                                  double fragment_invocations_per_draw) {
  return {.vertex_ops = dynamicOpCounts(vertex, profile.vertex_executions),
          .fragment_ops = dynamicOpCounts(fragment, profile.fragment_executions),
          .vertex_invocations = vertex_invocations_per_draw,
          .fragment_invocations = fragment_invocations_per_draw};
}

}  // namespace duolod::shader
