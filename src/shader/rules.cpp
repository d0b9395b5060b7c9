// The rules API (rules.hpp): parsing and emitting a two-stage program, and the dispatch from a
// RuleKind to its find/apply pair (rules_internal.hpp). The rules themselves live in rule_*.cpp,
// one file per rule family (Liang et al. §4.1).
#include "shader/rules.hpp"

#include <algorithm>
#include <cctype>
#include <optional>
#include <unordered_map>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

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

std::string identifierFrom(const std::string& text) {
  std::string result;
  for (char c : text) {
    const bool letter_or_digit = std::isalnum(static_cast<unsigned char>(c)) != 0;
    if (letter_or_digit)
      result += c;
    else if (!result.empty() && result.back() != '_')
      result += '_';
  }
  while (!result.empty() && result.back() == '_') result.pop_back();
  return result.empty() ? "value" : result;
}

std::string valueTargetUnsuitability(const ir::Module& fragment, const ir::DefUse& uses,
                                     ir::Id value) {
  const ir::InstructionRef* ref = uses.defRef(value);
  int entry = entryFunctionIndex(fragment, spv::ExecutionModelFragment);
  if (!ref || ref->function != entry || ref->block < 0)
    return "not a value of the fragment entry point";
  const ir::Instruction& definition = *ref->instruction;
  if (!definition.type_id || !ir::isFloatScalarOrVector(uses, definition.type_id) ||
      ir::typeInfo(uses, definition.type_id).width != 32)
    return "not a 32-bit float scalar or vector";
  if (definition.opcode == spv::OpLoad || definition.opcode == spv::OpPhi)
    return "a plain load or a phi";
  return "";
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
