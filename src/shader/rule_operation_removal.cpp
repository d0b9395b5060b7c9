// Operation removal, op(a, b) → a | b (Sitthi-Amorn et al. 2011, "Genetic programming for shader
// simplification"; Liang et al. §4.1): an arithmetic operation or a GLSL.std.450 call with two or
// more value operands is replaced by one of its operands, when that operand has the result's type
// (or is a scalar of the result's component type, then splatted: `v * s → s` gives vec(s)).
// dot(a, b) cannot become a (float from vec3), so such a pair is never offered.
//
// Two kinds of value are never touched, because changing them breaks more than the image quality:
//   - what decides whether a loop ends (a conditional branch inside a loop, with its backward
//     slice): `i + 1 → i` would make the loop run forever;
//   - in the vertex stage, what is written to gl_PerVertex / Position: moving the geometry is the
//     mesh simplifier's business, not the shader's.
// After the replacement the operation and whatever only it used are deleted, so the readable
// module shrinks too.
#include <glslang/SPIRV/GLSL.std.450.h>

#include <algorithm>
#include <map>
#include <set>
#include <unordered_set>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {
namespace {

bool isRemovableArithmetic(spv::Op opcode) {
  switch (opcode) {
    case spv::OpFAdd: case spv::OpFSub: case spv::OpFMul: case spv::OpFDiv: case spv::OpFMod:
    case spv::OpFRem: case spv::OpIAdd: case spv::OpISub: case spv::OpIMul: case spv::OpSDiv:
    case spv::OpUDiv: case spv::OpSMod: case spv::OpUMod: case spv::OpSRem:
    case spv::OpVectorTimesScalar: case spv::OpMatrixTimesScalar: case spv::OpVectorTimesMatrix:
    case spv::OpMatrixTimesVector: case spv::OpMatrixTimesMatrix: case spv::OpDot:
    case spv::OpOuterProduct: case spv::OpBitwiseAnd: case spv::OpBitwiseOr:
    case spv::OpBitwiseXor: case spv::OpShiftLeftLogical: case spv::OpShiftRightLogical:
    case spv::OpShiftRightArithmetic: case spv::OpSelect: case spv::OpExtInst:
      return true;
    default:
      return false;
  }
}

// The value operands of an operation: its id operands, without OpExtInst's instruction-set id.
std::vector<ir::Id> valueOperands(const ir::Instruction& instruction) {
  std::vector<ir::Id> ids = instruction.idOperands();
  if (instruction.opcode == spv::OpExtInst && !ids.empty()) ids.erase(ids.begin());
  return ids;
}

// How an operand can stand in for the result.
enum class Substitute { kNone, kSame, kSplat };

Substitute substituteFor(const ir::DefUse& uses, const ir::Instruction& operation,
                         ir::Id operand) {
  const ir::Instruction* definition = uses.def(operand);
  if (!definition || definition->type_id == ir::kNoId) return Substitute::kNone;
  ir::Id operand_type = definition->type_id;
  if (operand_type == operation.type_id) return Substitute::kSame;
  ir::TypeInfo result = ir::typeInfo(uses, operation.type_id);
  ir::TypeInfo source = ir::typeInfo(uses, operand_type);
  if (result.opcode == spv::OpTypeVector && source.components == 1 &&
      source.opcode != spv::OpTypeVector && operand_type == result.scalar_type)
    return Substitute::kSplat;
  return Substitute::kNone;
}

// The conditions of `function`'s conditional branches and switches inside loops.
void collectLoopConditions(const ir::Function& function, std::vector<ir::Id>& conditions) {
  ir::Cfg cfg = ir::buildCfg(function);
  std::vector<bool> in_loop(cfg.blocks.size(), false);
  for (size_t header = 0; header < cfg.blocks.size(); ++header) {
    const ir::Instruction* merge = function.blocks[header].mergeInstruction();
    if (!merge || merge->opcode != spv::OpLoopMerge) continue;
    std::vector<bool> blocks = loopConstructBlocks(cfg, static_cast<int>(header));
    for (size_t block = 0; block < blocks.size(); ++block)
      if (blocks[block]) in_loop[block] = true;
  }
  for (size_t block = 0; block < cfg.blocks.size(); ++block) {
    if (!in_loop[block]) continue;
    const ir::Instruction& terminator = function.blocks[block].terminator();
    if (terminator.opcode == spv::OpBranchConditional || terminator.opcode == spv::OpSwitch)
      conditions.push_back(terminator.operands[0]);
  }
}

// Ids that must not change: the backward slices of the loop conditions (collectLoopConditions),
// and everything in the functions those slices call. One slice of all conditions together: a
// slice per condition re-walked what the conditions share (64 loops reading one uniform block).
void protectLoopConditions(const ir::Module& module, const ir::DefUse& uses,
                           std::unordered_set<ir::Id>& protect) {
  std::vector<ir::Id> conditions;
  for (const ir::Function& function : module.functions) collectLoopConditions(function, conditions);
  if (conditions.empty()) return;
  std::vector<ir::Id> callees;
  for (ir::Id id : ir::backwardSlice(module, uses, conditions).instructions) {
    protect.insert(id);
    const ir::Instruction* definition = uses.def(id);
    if (definition && definition->opcode == spv::OpFunctionCall)
      callees.push_back(definition->operands[0]);
  }
  std::set<ir::Id> visited;
  while (!callees.empty()) {
    ir::Id callee_id = callees.back();
    callees.pop_back();
    const ir::Function* callee = module.findFunction(callee_id);
    if (!visited.insert(callee_id).second || !callee) continue;
    for (const ir::Block& block : callee->blocks)
      for (const ir::Instruction& instruction : block.instructions) {
        if (instruction.hasResult()) protect.insert(instruction.result_id);
        if (instruction.opcode == spv::OpFunctionCall) callees.push_back(instruction.operands[0]);
      }
  }
}

std::unordered_set<ir::Id> protectedValues(const ir::Module& module, const ir::DefUse& uses,
                                           Stage stage) {
  std::unordered_set<ir::Id> protect;
  protectLoopConditions(module, uses, protect);
  if (stage == Stage::kVertex) {
    std::unordered_set<ir::Id> position = vertexPositionSources(module, uses);
    protect.insert(position.begin(), position.end());
  }
  return protect;
}

bool isGlslStd450(const ir::DefUse& uses, const ir::Instruction& instruction) {
  if (instruction.opcode != spv::OpExtInst) return true;
  const ir::Instruction* import = uses.def(instruction.operands[0]);
  return import && import->opcode == spv::OpExtInstImport &&
         import->literalString(0) == "GLSL.std.450";
}

// For one operation: the kept-operand choices (index among valueOperands) that are type-correct,
// one per distinct operand id.
std::vector<uint32_t> keptOperandChoices(const ir::DefUse& uses,
                                         const ir::Instruction& instruction) {
  std::vector<uint32_t> choices;
  if (!isRemovableArithmetic(instruction.opcode) || !instruction.hasResult() ||
      !isGlslStd450(uses, instruction))
    return choices;
  std::vector<ir::Id> operands = valueOperands(instruction);
  if (operands.size() < 2) return choices;
  std::set<ir::Id> offered;
  for (size_t index = 0; index < operands.size(); ++index)
    if (substituteFor(uses, instruction, operands[index]) != Substitute::kNone &&
        offered.insert(operands[index]).second)
      choices.push_back(static_cast<uint32_t>(index));
  return choices;
}

}  // namespace

std::vector<RuleSite> findOperationRemovalSites(const ShaderProgram& program, const RuleContext&) {
  std::vector<RuleSite> sites;
  for (Stage stage : {Stage::kVertex, Stage::kFragment}) {
    const ir::Module& module = stageModule(program, stage);
    ir::DefUse uses(module);
    std::unordered_set<ir::Id> protect = protectedValues(module, uses, stage);
    for (size_t f = 0; f < module.functions.size(); ++f)
      for (const ir::Block& block : module.functions[f].blocks)
        for (const ir::Instruction& instruction : block.instructions) {
          if (protect.count(instruction.result_id)) continue;
          std::vector<ir::Id> operands = valueOperands(instruction);
          std::string call = operationName(instruction) + "(";
          for (size_t i = 0; i < operands.size(); ++i)
            call += (i ? ", " : "") + describeOperand(module, uses, operands[i]);
          call += ")";
          for (uint32_t choice : keptOperandChoices(uses, instruction)) {
            RuleSite site{.kind = RuleKind::kOperationRemoval,
                          .stage = stage,
                          .target = instruction.result_id,
                          .choice = choice,
                          .description = {}};
            site.description = stageName(stage) + " " + functionName(module, f) + ": " + call +
                               " → " + describeOperand(module, uses, operands[choice]);
            sites.push_back(std::move(site));
          }
        }
  }
  return sites;
}

core::Result<ShaderProgram> applyOperationRemoval(const ShaderProgram& program,
                                                  const RuleSite& site, const RuleContext&) {
  const ir::Module& original = stageModule(program, site.stage);
  ir::DefUse uses(original);
  std::optional<ir::InstructionPosition> position = original.findPosition(site.target);
  if (!position) return siteError(site, "the operation is no longer in the module");
  const ir::Instruction& operation = original.functions[static_cast<size_t>(position->function)]
                                         .blocks[static_cast<size_t>(position->block)]
                                         .instructions[static_cast<size_t>(position->index)];
  std::vector<uint32_t> choices = keptOperandChoices(uses, operation);
  if (std::find(choices.begin(), choices.end(), site.choice) == choices.end())
    return siteError(site, "operand " + std::to_string(site.choice) +
                               " cannot replace the result (type or operation changed)");
  if (protectedValues(original, uses, site.stage).count(site.target))
    return siteError(site, "the value decides a loop's exit or the vertex position");
  ir::Id kept = valueOperands(operation)[site.choice];
  Substitute substitute = substituteFor(uses, operation, kept);
  ir::Id result_type = operation.type_id;
  uint32_t components = ir::componentCount(uses, result_type);

  ShaderProgram rewritten = program;
  ir::Module& module = stageModule(rewritten, site.stage);
  ir::Id replacement = kept;
  if (substitute == Substitute::kSplat) {
    replacement = module.allocateId();
    std::vector<uint32_t> constituents(components, kept);
    module.insertBefore(*position, {ir::makeInstruction(module, spv::OpCompositeConstruct,
                                                        result_type, replacement,
                                                        std::move(constituents))});
  }
  module.replaceAllUses(site.target, replacement);
  module.removeInstructions({site.target});
  removeDeadCode(module);
  return rewritten;
}

}  // namespace duolod::shader
