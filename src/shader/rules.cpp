// The rules API (rules.hpp): parsing and emitting a two-stage program, and the dispatch from a
// RuleKind to its find/apply pair (rules_internal.hpp). The rules themselves live in rule_*.cpp,
// one file per rule family (Liang et al. §4.1).
#include "shader/rules.hpp"

#include <algorithm>
#include <optional>
#include <unordered_map>

#include "shader/rules_internal.hpp"

namespace duolod::shader {
namespace {

using core::Error;

// The emitted words of one stage, validated. With `optimize`, SPIRV-Tools' performance recipe
// (optimizeForEvaluation: inlining, dead code, folding) runs on the copy that is compiled and timed:
// a rule leaves dead code and foldable constants behind, and the driver should not be credited or
// blamed for them (§5.2's cost is the cost of what really runs).
core::Result<std::vector<uint32_t>> emitStage(const ir::Module& module, bool optimize,
                                              const std::string& what) {
  std::vector<uint32_t> words = ir::emitModule(module);
  if (optimize) return optimizeForEvaluation(words, what);  // validates before and after
  if (auto valid = validateSpirv(words, what); !valid.ok()) return valid.error();
  return words;
}

// Module order of every result id and block label, for enumerateSites' ordering.
std::unordered_map<ir::Id, size_t> moduleOrder(const ir::Module& module) {
  std::unordered_map<ir::Id, size_t> order;
  size_t next = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks) {
      order.emplace(block.id(), next++);
      for (const ir::Instruction& instruction : block.instructions)
        if (instruction.hasResult()) order.emplace(instruction.result_id, next++);
    }
  return order;
}

}  // namespace

std::string_view ruleName(RuleKind kind) {
  switch (kind) {
    case RuleKind::kOperationRemoval: return "operation removal";
    case RuleKind::kMoveToParameter: return "moving to parameter";
    case RuleKind::kPerVertex: return "per-vertex";
    case RuleKind::kTextureAverage: return "texture average";
    case RuleKind::kTextureMip: return "texture mip";
    case RuleKind::kLoopTruncation: return "loop truncation";
  }
  return "unknown rule";
}

const ir::Module& stageModule(const ShaderProgram& program, Stage stage) {
  return stage == Stage::kVertex ? program.vertex : program.fragment;
}
ir::Module& stageModule(ShaderProgram& program, Stage stage) {
  return stage == Stage::kVertex ? program.vertex : program.fragment;
}

std::string stageName(Stage stage) {
  switch (stage) {
    case Stage::kVertex: return "vertex";
    case Stage::kTessControl: return "tessellation control";
    case Stage::kTessEvaluation: return "tessellation evaluation";
    case Stage::kGeometry: return "geometry";
    case Stage::kFragment: return "fragment";
  }
  return "unknown stage";
}

core::Error siteError(const RuleSite& site, const std::string& reason) {
  return Error{std::string(ruleName(site.kind)) + " at " + stageName(site.stage) + " %" +
               std::to_string(site.target) + ": " + reason};
}

std::string valueName(const ir::Module& module, ir::Id id) {
  std::string name = module.name(id);
  return name.empty() ? "%" + std::to_string(id) : name;
}

std::string describeOperand(const ir::Module& module, const ir::DefUse& uses, ir::Id id) {
  if (std::string name = module.name(id); !name.empty()) return name;
  const ir::Instruction* definition = uses.def(id);
  if (!definition) return valueName(module, id);
  if (std::optional<float> value = ir::constantFloatValue(uses, id)) {
    std::string text = std::to_string(*value);
    text.erase(text.find_last_not_of('0') + 1);
    if (!text.empty() && text.back() == '.') text += '0';
    return text;
  }
  if (definition->opcode == spv::OpLoad) {
    const ir::Instruction* pointer = uses.def(definition->operands[0]);
    if (pointer && pointer->opcode == spv::OpVariable) return valueName(module, pointer->result_id);
    // A uniform-block member: block.member with a constant member index.
    if (pointer && pointer->opcode == spv::OpAccessChain && pointer->operands.size() == 2) {
      const ir::Instruction* block = uses.def(pointer->operands[0]);
      std::optional<int64_t> member = ir::constantIntValue(uses, pointer->operands[1]);
      if (block && member) {
        ir::Id struct_type = ir::pointeeType(uses, block->type_id);
        std::string name = module.memberName(struct_type, static_cast<uint32_t>(*member));
        if (!name.empty()) return name;
      }
    }
  }
  return valueName(module, id);
}

std::string functionName(const ir::Module& module, size_t function_index) {
  std::string name = module.name(module.functions[function_index].id());
  return name.substr(0, name.find('('));
}

bool isPureOpcode(spv::Op opcode) {
  switch (opcode) {
    // Memory reads and address arithmetic: no side effects (an unused load can go).
    case spv::OpLoad: case spv::OpAccessChain: case spv::OpInBoundsAccessChain:
    // Composites and conversions.
    case spv::OpVectorShuffle: case spv::OpCompositeConstruct: case spv::OpCompositeExtract:
    case spv::OpCompositeInsert: case spv::OpCopyObject: case spv::OpTranspose:
    case spv::OpConvertFToU: case spv::OpConvertFToS: case spv::OpConvertSToF:
    case spv::OpConvertUToF: case spv::OpUConvert: case spv::OpSConvert: case spv::OpFConvert:
    case spv::OpBitcast: case spv::OpVectorExtractDynamic: case spv::OpVectorInsertDynamic:
    // Arithmetic.
    case spv::OpSNegate: case spv::OpFNegate: case spv::OpIAdd: case spv::OpFAdd:
    case spv::OpISub: case spv::OpFSub: case spv::OpIMul: case spv::OpFMul: case spv::OpUDiv:
    case spv::OpSDiv: case spv::OpFDiv: case spv::OpUMod: case spv::OpSRem: case spv::OpSMod:
    case spv::OpFRem: case spv::OpFMod: case spv::OpVectorTimesScalar:
    case spv::OpMatrixTimesScalar: case spv::OpVectorTimesMatrix: case spv::OpMatrixTimesVector:
    case spv::OpMatrixTimesMatrix: case spv::OpOuterProduct: case spv::OpDot:
    // Bits, logic and comparisons.
    case spv::OpShiftRightLogical: case spv::OpShiftRightArithmetic:
    case spv::OpShiftLeftLogical: case spv::OpBitwiseOr: case spv::OpBitwiseXor:
    case spv::OpBitwiseAnd: case spv::OpNot: case spv::OpAny: case spv::OpAll:
    case spv::OpIsNan: case spv::OpIsInf: case spv::OpLogicalEqual: case spv::OpLogicalNotEqual:
    case spv::OpLogicalOr: case spv::OpLogicalAnd: case spv::OpLogicalNot: case spv::OpSelect:
    case spv::OpIEqual: case spv::OpINotEqual: case spv::OpUGreaterThan:
    case spv::OpSGreaterThan: case spv::OpUGreaterThanEqual: case spv::OpSGreaterThanEqual:
    case spv::OpULessThan: case spv::OpSLessThan: case spv::OpULessThanEqual:
    case spv::OpSLessThanEqual: case spv::OpFOrdEqual: case spv::OpFUnordEqual:
    case spv::OpFOrdNotEqual: case spv::OpFUnordNotEqual: case spv::OpFOrdLessThan:
    case spv::OpFUnordLessThan: case spv::OpFOrdGreaterThan: case spv::OpFUnordGreaterThan:
    case spv::OpFOrdLessThanEqual: case spv::OpFUnordLessThanEqual:
    case spv::OpFOrdGreaterThanEqual: case spv::OpFUnordGreaterThanEqual:
    // Derivatives and image sampling (reads only).
    case spv::OpDPdx: case spv::OpDPdy: case spv::OpFwidth: case spv::OpDPdxFine:
    case spv::OpDPdyFine: case spv::OpFwidthFine: case spv::OpDPdxCoarse: case spv::OpDPdyCoarse:
    case spv::OpFwidthCoarse: case spv::OpSampledImage: case spv::OpImage:
    case spv::OpImageSampleImplicitLod: case spv::OpImageSampleExplicitLod:
    case spv::OpImageSampleDrefImplicitLod: case spv::OpImageSampleDrefExplicitLod:
    case spv::OpImageSampleProjImplicitLod: case spv::OpImageSampleProjExplicitLod:
    case spv::OpImageFetch: case spv::OpImageGather: case spv::OpImageQuerySizeLod:
    case spv::OpImageQueryLod: case spv::OpImageQueryLevels:
    // GLSL.std.450 is the only extended set glslang emits for GLSL; none of it writes memory.
    case spv::OpExtInst:
    case spv::OpPhi:
      return true;
    default:
      return false;
  }
}

std::vector<bool> loopBlocks(const ir::Cfg& cfg, int header) {
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

size_t removeDeadPureInstructions(ir::Module& module) {
  size_t removed_total = 0;
  for (;;) {
    ir::DefUse uses(module);
    std::set<ir::Id> dead;
    for (const ir::Function& function : module.functions)
      for (const ir::Block& block : function.blocks)
        for (const ir::Instruction& instruction : block.instructions) {
          if (!instruction.hasResult() || !isPureOpcode(instruction.opcode)) continue;
          bool used = false;
          for (const ir::InstructionRef& user : uses.users(instruction.result_id))
            if (user.instruction->opcode != spv::OpName &&
                user.instruction->opcode != spv::OpDecorate &&
                user.instruction->opcode != spv::OpMemberDecorate)
              used = true;
          if (!used) dead.insert(instruction.result_id);
        }
    if (dead.empty()) return removed_total;
    removed_total += dead.size();
    module.removeInstructions(dead);
  }
}

core::Result<ShaderProgram> parseProgram(std::span<const uint32_t> vertex_words,
                                         std::span<const uint32_t> fragment_words) {
  ShaderProgram program;
  auto vertex = ir::parseModule(vertex_words);
  if (!vertex.ok()) return Error{"vertex stage: " + vertex.error().message};
  auto fragment = ir::parseModule(fragment_words);
  if (!fragment.ok()) return Error{"fragment stage: " + fragment.error().message};
  if (!vertex->entryFunction(spv::ExecutionModelVertex))
    return Error{"vertex stage: the module has no vertex entry point"};
  if (!fragment->entryFunction(spv::ExecutionModelFragment))
    return Error{"fragment stage: the module has no fragment entry point"};
  program.vertex = std::move(*vertex);
  program.fragment = std::move(*fragment);
  return program;
}

core::Result<ProgramWords> emitProgram(const ShaderProgram& program, bool optimize) {
  ProgramWords words;
  auto vertex = emitStage(program.vertex, optimize, "vertex stage");
  if (!vertex.ok()) return vertex.error();
  auto fragment = emitStage(program.fragment, optimize, "fragment stage");
  if (!fragment.ok()) return fragment.error();
  words.vertex = std::move(*vertex);
  words.fragment = std::move(*fragment);
  return words;
}

std::vector<RuleSite> enumerateSites(const ShaderProgram& program, const RuleContext& context) {
  using Finder = std::vector<RuleSite> (*)(const ShaderProgram&, const RuleContext&);
  // Indexed by RuleKind; nullptr: not implemented in this build.
  const std::array<Finder, kRuleKindCount> finders = {
      &findOperationRemovalSites, &findMoveToParameterSites, &findPerVertexSites,
      &findTextureAverageSites,   &findTextureMipSites,      &findLoopTruncationSites};
  std::vector<RuleSite> sites;
  for (int kind = 0; kind < kRuleKindCount; ++kind) {
    if (!context.enabled[static_cast<size_t>(kind)] || !finders[static_cast<size_t>(kind)])
      continue;
    std::vector<RuleSite> found = finders[static_cast<size_t>(kind)](program, context);
    sites.insert(sites.end(), found.begin(), found.end());
  }
  // Stage, then module order of the target, then rule and choice: independent of the order the
  // finders walk in.
  const std::unordered_map<ir::Id, size_t> vertex_order = moduleOrder(program.vertex);
  const std::unordered_map<ir::Id, size_t> fragment_order = moduleOrder(program.fragment);
  auto position = [&](const RuleSite& site) {
    const auto& order = site.stage == Stage::kVertex ? vertex_order : fragment_order;
    auto found = order.find(site.target);
    return found == order.end() ? static_cast<size_t>(-1) : found->second;
  };
  std::stable_sort(sites.begin(), sites.end(), [&](const RuleSite& a, const RuleSite& b) {
    auto key = [&](const RuleSite& site) {
      return std::make_tuple(static_cast<int>(site.stage), position(site),
                             static_cast<int>(site.kind), site.choice);
    };
    return key(a) < key(b);
  });
  return sites;
}

core::Result<ShaderProgram> applyRule(const ShaderProgram& program, const RuleSite& site,
                                      const RuleContext& context) {
  if (site.stage != Stage::kVertex && site.stage != Stage::kFragment)
    return siteError(site, "only the vertex and fragment stages are simplified");
  core::Result<ShaderProgram> result = siteError(site, "this rule is not implemented yet");
  switch (site.kind) {
    case RuleKind::kOperationRemoval: result = applyOperationRemoval(program, site, context); break;
    case RuleKind::kMoveToParameter: result = applyMoveToParameter(program, site, context); break;
    case RuleKind::kPerVertex: result = applyPerVertex(program, site, context); break;
    case RuleKind::kTextureAverage: result = applyTextureAverage(program, site, context); break;
    case RuleKind::kTextureMip: result = applyTextureMip(program, site, context); break;
    case RuleKind::kLoopTruncation: result = applyLoopTruncation(program, site, context); break;
  }
  if (!result.ok()) return result;
  result->history.push_back(site.description.empty() ? std::string(ruleName(site.kind))
                                                     : site.description);
  return result;
}

}  // namespace duolod::shader
