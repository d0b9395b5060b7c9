// The separate optimization's decision core (Liang et al. §5, Algorithm 1, then §6): for every
// distance level, SortByError of the shader candidates on M_0 and SearchPairs (Algorithm 2) over
// that level's mesh candidates; then the smoothest path through the levels' pair sets (Algorithm 3)
// and the merging of inefficient levels (§6.2). Private to src/lod.
//
// Everything that renders or times is a callback, so the decisions are tested on hand-made tables
// (tests/lod_separate_test.cpp) and driven by real renders in generate.cpp.
#pragma once

#include <functional>
#include <vector>

#include "duolod/lod.hpp"

namespace duolod::lod {

struct SeparateProblem {
  int level_count = 0;
  std::vector<double> error_bounds;  // per level: e_a(d_i)·s_{d_i} (eq. 3)
  std::vector<int> mesh_counts;      // per level: K_i candidates, index 0 = the original M_0
  // Optional, per level: each candidate's size in triangles (PairSearchOptions::mesh_sizes).
  std::vector<std::vector<double>> mesh_sizes;
  int shader_count = 0;              // shared by all levels, index 0 = the original S_0
  // ε_a and cost of (mesh j of level i's set, shader k) at d_i.
  std::function<core::Result<PairEvaluation>(int level, int mesh, int shader)> evaluate;
  // ε_t of eq. (5): the pair `from` (of level `level`'s sets) and `to` (of level + 1), at d_{level+1}.
  TransitionEvaluator transition;
  // Cost of level `pair_level`'s chosen pair drawn at distance level `distance_level` (§6.2).
  std::function<core::Result<double>(int pair_level, const EvaluatedPair& pair,
                                     int distance_level)>
      cost_at;
};

struct SeparateOptions {
  double time_tolerance = 0.05;   // T of Algorithm 2
  double merge_min_gain = 0.04;   // W of §6.2
  bool brute_force = false;       // the 2D search over all K·L pairs instead of Algorithm 2
  bool bisect_meshes = true;      // PairSearchOptions::bisect_meshes
  double bisection_stop = 0;      // PairSearchOptions::bisection_stop (needs mesh_sizes)
  bool smooth = true;             // Algorithm 3; off: each level takes its cheapest pair
  // Called as each level's search finishes (level, evaluations so far).
  std::function<void(int, int)> on_level;
  // Called with each level's pair set as it is chosen, before on_level. The smoothest path
  // (Algorithm 3) compares the renders of these pairs only: a caller that keeps renders for it can
  // drop the level's others.
  std::function<void(int level, const std::vector<EvaluatedPair>& pairs)> on_level_pairs;
  // Called for each pair a level's search visited as soon as it cannot be in the level's pair set
  // (PairSearchOptions::on_discarded): its render can go before the level ends.
  std::function<void(int level, int mesh, int shader)> on_discarded;
};

struct SeparateSolution {
  std::vector<std::vector<int>> shader_orders;  // per level, SortByError on M_0
  std::vector<PairSearchResult> searches;       // per level
  // The pair sets the path chose from: the search's optimal pairs, or the original pair (0, 0)
  // when no pair is within the bound (then `fallback_to_original` is set for that level).
  std::vector<std::vector<EvaluatedPair>> level_pairs;
  std::vector<bool> fallback_to_original;
  SmoothPath path;
  std::vector<EvaluatedPair> chosen;  // per level, the pair on the path
  MergeResult merge;                  // kept_levels index into chosen
  int evaluations = 0;                // pair evaluations (SortByError + SearchPairs)
};

core::Result<SeparateSolution> optimizeSeparate(const SeparateProblem& problem,
                                                const SeparateOptions& options);

// One level of the first half (Algorithm 1, lines 5-10: SortByError, then SearchPairs), appended
// to `solution` (shader_orders, searches, level_pairs, fallback_to_original, evaluations), without
// the hooks. optimizeSeparate runs it for each level in turn; a caller may run it alone to learn
// which pairs a level of another problem would choose.
core::Status searchLevel(const SeparateProblem& problem, const SeparateOptions& options, int level,
                         SeparateSolution& solution);

// The second half, for optimizers that make the levels' pair sets another way (the interleaved
// one, §4.3): given solution.level_pairs and fallback_to_original, picks the smoothest path
// (or the cheapest pairs) and merges inefficient levels.
core::Status smoothAndMerge(const SeparateProblem& problem, const SeparateOptions& options,
                            SeparateSolution& solution);

}  // namespace duolod::lod
