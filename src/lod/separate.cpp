// The separate optimization's decisions (Liang et al. §5 Algorithm 1, §6.1 Algorithm 3, §6.2).
#include "lod/separate.hpp"

#include <string>

namespace duolod::lod {
namespace {

core::Status checkProblem(const SeparateProblem& problem) {
  const size_t levels = static_cast<size_t>(problem.level_count);
  if (problem.level_count < 1) return core::Error{"separate optimization: no levels"};
  if (problem.error_bounds.size() != levels || problem.mesh_counts.size() != levels)
    return core::Error{"separate optimization: one error bound and one mesh count per level needed"};
  for (int count : problem.mesh_counts)
    if (count < 1) return core::Error{"separate optimization: a level has no mesh candidate"};
  if (problem.shader_count < 1) return core::Error{"separate optimization: no shader candidate"};
  if (!problem.evaluate || !problem.transition || !problem.cost_at)
    return core::Error{"separate optimization: an evaluator is missing"};
  return core::okStatus();
}

}  // namespace

core::Result<SeparateSolution> optimizeSeparate(const SeparateProblem& problem,
                                                const SeparateOptions& options) {
  if (auto valid = checkProblem(problem); !valid) return valid.error();
  SeparateSolution solution;
  // Algorithm 1, lines 5–10.
  for (int level = 0; level < problem.level_count; ++level) {
    if (auto searched = searchLevel(problem, options, level, solution); !searched)
      return searched.error();
    if (options.on_level_pairs) options.on_level_pairs(level, solution.level_pairs.back());
    if (options.on_level) options.on_level(level, solution.evaluations);
  }
  if (auto finished = smoothAndMerge(problem, options, solution); !finished)
    return finished.error();
  return solution;
}

core::Status searchLevel(const SeparateProblem& problem, const SeparateOptions& options, int level,
                         SeparateSolution& solution) {
  if (auto valid = checkProblem(problem); !valid) return valid.error();
  if (level < 0 || level >= problem.level_count)
    return core::Error{"separate optimization: no level " + std::to_string(level)};
  // A bound of 0 (d_near, eq. 4) admits no pair (eq. 3 is strict; errors are never negative),
  // so the search is skipped: at d_near it would render every shader at the largest footprint
  // for nothing. The original is kept, flagged, as when a search finds nothing.
  if (problem.error_bounds[level] <= 0) {
    auto original = problem.evaluate(level, 0, 0);
    if (!original) return original.error();
    ++solution.evaluations;
    const bool within = original->error < problem.error_bounds[level];  // eq. (3): never
    solution.shader_orders.emplace_back(1, 0);
    solution.searches.emplace_back();
    solution.level_pairs.push_back({EvaluatedPair{.mesh = 0,
                                                  .shader = 0,
                                                  .shader_rank = 0,
                                                  .error = original->error,
                                                  .cost = original->cost,
                                                  .within_bound = within}});
    solution.fallback_to_original.push_back(!within);
    return core::okStatus();
  }
  // Line 6, SortByError: every shader on the original mesh at d_i.
  std::vector<double> errors(problem.shader_count);
  for (int shader = 0; shader < problem.shader_count; ++shader) {
    auto evaluation = problem.evaluate(level, 0, shader);
    if (!evaluation)
      return core::Error{"SortByError at level " + std::to_string(level) + ": " +
                         evaluation.error().message};
    errors[shader] = evaluation->error;
    ++solution.evaluations;
  }
  solution.shader_orders.push_back(sortByError(errors));

  // Line 8, SearchPairs (Algorithm 2) or the 2D brute force.
  PairSearchOptions search_options;
  search_options.error_bound = problem.error_bounds[level];
  search_options.time_tolerance = options.time_tolerance;
  search_options.bisect_meshes = options.bisect_meshes;
  if (size_t(level) < problem.mesh_sizes.size()) {
    search_options.mesh_sizes = problem.mesh_sizes[level];
    search_options.bisection_stop = options.bisection_stop;
  }
  if (options.on_discarded)
    search_options.on_discarded = [&](int mesh, int shader) {
      options.on_discarded(level, mesh, shader);
    };
  PairEvaluator evaluate = [&](int mesh, int shader) {
    return problem.evaluate(level, mesh, shader);
  };
  auto search = options.brute_force
                    ? searchPairsBruteForce(problem.mesh_counts[level],
                                            solution.shader_orders.back(), evaluate, search_options)
                    : searchPairs(problem.mesh_counts[level], solution.shader_orders.back(),
                                  evaluate, search_options);
  if (!search) return core::Error{"level " + std::to_string(level) + ": " + search.error().message};
  solution.evaluations += search->evaluations;

  // No pair within the bound (at d_near the bound is 0, and the original's own aliasing against
  // the supersampled reference counts): the level keeps the original pair, flagged, because
  // no LOD can be better than drawing the original.
  std::vector<EvaluatedPair> pairs = search->optimal;
  bool fallback = pairs.empty();
  if (fallback) {
    auto original = problem.evaluate(level, 0, 0);
    if (!original) return original.error();
    pairs.push_back(EvaluatedPair{.mesh = 0,
                                  .shader = 0,
                                  .shader_rank = 0,
                                  .error = original->error,
                                  .cost = original->cost,
                                  .within_bound = false});
  }
  solution.searches.push_back(std::move(*search));
  solution.level_pairs.push_back(std::move(pairs));
  solution.fallback_to_original.push_back(fallback);
  return core::okStatus();
}

core::Status smoothAndMerge(const SeparateProblem& problem, const SeparateOptions& options,
                            SeparateSolution& solution) {
  const int level_count = problem.level_count;
  if (static_cast<int>(solution.level_pairs.size()) != level_count)
    return core::Error{"smoothest path: one pair set per level needed"};
  solution.chosen.clear();
  // §6.1, Algorithm 3; without smoothing each level takes its cheapest pair (the baseline the
  // smoothest path is compared with).
  if (options.smooth) {
    auto path = smoothestPath(solution.level_pairs, problem.transition);
    if (!path) return path.error();
    solution.path = std::move(*path);
  } else {
    solution.path.choice.assign(level_count, 0);
    for (int level = 0; level + 1 < level_count; ++level) {
      auto error = problem.transition(level, solution.level_pairs[level][0],
                                      solution.level_pairs[level + 1][0]);
      if (!error) return error.error();
      solution.path.transition.push_back(*error);
      solution.path.total_transition += *error;
    }
  }
  for (int level = 0; level < level_count; ++level)
    solution.chosen.push_back(solution.level_pairs[level][solution.path.choice[level]]);

  // §6.2: merge levels whose pair hardly beats the previous kept level's pair at their distance.
  auto merged = mergeInefficientLevels(
      level_count,
      [&](int pair_level, int distance_level) {
        return problem.cost_at(pair_level, solution.chosen[pair_level], distance_level);
      },
      [&](int distance_level) {
        return problem.cost_at(distance_level, EvaluatedPair{}, distance_level);
      },
      options.merge_min_gain);
  if (!merged) return merged.error();
  solution.merge = std::move(*merged);
  return core::okStatus();
}

}  // namespace duolod::lod
