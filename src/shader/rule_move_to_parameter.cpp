// "Moving to parameter" (He, Foley, Tatarchuk, Fatahalian, "A system for rapid, automatic shader
// level-of-detail", TOG 2015; Liang et al. §4.1 rule 3; Pellacini 2005's average substitution): a
// fragment value n is replaced by average(n), its mean over the covered pixels of the training
// domain, which the CPU sets as a uniform. The average comes from RuleContext::average_value (an
// instrumented render, value_average.cpp); the rule only rewrites the program.
//
// Sites: fragment-entry float scalar/vector values that compute something (their backward slice
// holds at least one arithmetic/call/sample instruction: replacing a plain load saves nothing), are
// outside loops (one value per pixel), and whose slice has no side effects.
#include <set>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {

namespace {

using ir::Id;

// The blocks of the fragment entry point inside loops (blocksInLoops), or none.
std::set<Id> entryLoopBlocks(const ir::Module& fragment) {
  int entry = entryFunctionIndex(fragment, spv::ExecutionModelFragment);
  return entry < 0 ? std::set<Id>{} : blocksInLoops(fragment.functions[static_cast<size_t>(entry)]);
}

// Why `value` cannot be moved to a parameter, or "" when it can. `in_loops`: entryLoopBlocks();
// `slices`: computingSliceSummaries() of the same module.
std::string unsuitability(const ir::Module& fragment, const ir::DefUse& uses,
                          const std::set<Id>& in_loops, ir::SliceSummaries& slices, Id value) {
  if (std::string why = valueTargetUnsuitability(fragment, uses, value); !why.empty()) return why;
  const ir::InstructionRef* ref = uses.defRef(value);
  const ir::Function& function = fragment.functions[static_cast<size_t>(ref->function)];
  if (in_loops.count(function.blocks[ref->block].id())) return "inside a loop";
  ir::SliceFlags slice = slices.of(value);
  if (slice.has_side_effects) return "its computation has side effects";
  if (!slice.reaches_marked) return "computes nothing";
  return "";
}

}  // namespace

std::vector<RuleSite> findMoveToParameterSites(const ShaderProgram& program,
                                               const RuleContext& context) {
  std::vector<RuleSite> sites;
  if (!context.average_value) return sites;  // nothing could compute the averages
  const ir::Module& fragment = program.fragment;
  ir::DefUse uses(fragment);
  const std::set<Id> in_loops = entryLoopBlocks(fragment);
  ir::SliceSummaries slices = computingSliceSummaries(fragment, uses);
  for (Id value : candidateValues(fragment, uses, spv::ExecutionModelFragment)) {
    if (!unsuitability(fragment, uses, in_loops, slices, value).empty()) continue;
    RuleSite site;
    site.kind = RuleKind::kMoveToParameter;
    site.stage = Stage::kFragment;
    site.target = value;
    site.description = "fragment: " + describeComputedValue(fragment, uses, value) +
                       " → its average over the domain";
    sites.push_back(std::move(site));
  }
  return sites;
}

core::Result<ShaderProgram> applyMoveToParameter(const ShaderProgram& program, const RuleSite& site,
                                                 const RuleContext& context) {
  if (site.kind != RuleKind::kMoveToParameter || site.stage != Stage::kFragment)
    return siteError(site, "not a fragment moving-to-parameter site");
  if (!context.average_value) return siteError(site, "no average_value in the rule context");
  Id type_id = ir::kNoId;
  std::string name;
  {
    ir::DefUse uses(program.fragment);
    ir::SliceSummaries slices = computingSliceSummaries(program.fragment, uses);
    if (std::string why = unsuitability(program.fragment, uses, entryLoopBlocks(program.fragment),
                                        slices, site.target);
        !why.empty())
      return siteError(site, why);
    type_id = uses.def(site.target)->type_id;
    name = describeComputedValue(program.fragment, uses, site.target);
  }
  core::Result<std::vector<float>> average =
      context.average_value(program, Stage::kFragment, site.target);
  if (!average) return siteError(site, "averaging failed: " + average.error().message);
  ir::DefUse uses(program.fragment);
  size_t components = ir::componentCount(uses, type_id);
  if (average->size() != components || components > 4)
    return siteError(site, "the average has " + std::to_string(average->size()) +
                               " components, the value " + std::to_string(components));

  std::vector<uint32_t> taken;
  for (const ParameterValue& parameter : program.parameters) taken.push_back(parameter.location);
  uint32_t location = freeUniformLocation({&program.vertex, &program.fragment},
                                          context.first_parameter_location, taken);
  ParameterValue parameter;
  parameter.name = "uAverage_" + identifierFrom(name) + "_" + std::to_string(location);
  parameter.location = location;
  parameter.components = static_cast<int>(components);
  for (size_t i = 0; i < components; ++i) parameter.value[i] = (*average)[i];

  ShaderProgram result = program;
  Id uniform = result.fragment.addLooseUniform(type_id, parameter.name, location);
  if (auto replaced = replaceValueByLoad(result.fragment, site.target, uniform); !replaced)
    return siteError(site, replaced.error().message);
  result.parameters.push_back(std::move(parameter));
  return result;
}

}  // namespace duolod::shader
