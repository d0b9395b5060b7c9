// Merging inefficient levels: Liang et al., "Automatic Mesh and Shader Level of Detail", §6.2. A
// level whose pair renders hardly faster than the previous kept level's pair at its distance only
// costs memory, so it is dropped.
#include "duolod/lod.hpp"

namespace duolod::lod {

core::Result<MergeResult> mergeInefficientLevels(int level_count, const LevelCostEvaluator& cost,
                                                 const OriginalCostEvaluator& original_cost,
                                                 double min_gain) {
  if (level_count < 1) return core::Error{"MergeInefficientLevels: no levels"};
  MergeResult result;
  result.kept_levels.push_back(0);
  auto fail = [](const char* what, int level, const core::Error& error) {
    return core::Error{std::string("MergeInefficientLevels: ") + what + " at level " +
                       std::to_string(level) + ": " + error.message};
  };
  for (int level = 1; level < level_count; ++level) {
    MergeDecision decision{.level = level, .previous = result.kept_levels.back()};
    auto previous_cost = cost(decision.previous, level);
    if (!previous_cost)
      return fail("cost of the previous level's pair", level, previous_cost.error());
    auto own_cost = cost(level, level);
    if (!own_cost) return fail("cost of the level's pair", level, own_cost.error());
    auto reference_cost = original_cost(level);
    if (!reference_cost) return fail("cost of the original", level, reference_cost.error());
    if (!(*reference_cost > 0))
      return core::Error{"MergeInefficientLevels: the original's cost at level " +
                         std::to_string(level) + " must be positive"};
    decision.previous_cost = *previous_cost;
    decision.cost = *own_cost;
    decision.original_cost = *reference_cost;
    // §6.2: (t_{i−1} − t_i)/t_0 < W means both levels perform about the same: keep the finer one.
    decision.gain = (decision.previous_cost - decision.cost) / decision.original_cost;
    decision.dropped = decision.gain < min_gain;
    if (!decision.dropped) result.kept_levels.push_back(level);
    result.decisions.push_back(decision);
  }
  return result;
}

}  // namespace duolod::lod
