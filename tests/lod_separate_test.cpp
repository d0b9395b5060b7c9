// The separate optimization's decisions (Algorithm 1 → 2 → 3 → §6.2) on hand-made tables: errors
// and costs are additive in the mesh and shader simplification, so the right pairs can be worked
// out by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "lod/separate.hpp"

namespace duolod {
namespace {

// 5 mesh candidates (0 = original, 4 = coarsest) and 4 shaders (0 = original). Error of a pair:
// mesh_error[j] + shader_error[k], the same at every level; cost: mesh_cost[j] + shader_cost[k].
// Shader 2 errs less than shader 1, so SortByError must reorder them.
constexpr double kMeshError[5] = {0.0, 1.0, 2.0, 4.0, 8.0};
constexpr double kMeshCost[5] = {10, 8, 6, 4, 2};
constexpr double kShaderError[4] = {0.0, 3.0, 0.5, 6.0};
constexpr double kShaderCost[4] = {10, 4, 7, 1};

lod::SeparateProblem additiveProblem(std::vector<double> bounds, int* evaluations) {
  lod::SeparateProblem problem;
  problem.level_count = static_cast<int>(bounds.size());
  problem.error_bounds = bounds;
  problem.mesh_counts.assign(bounds.size(), 5);
  problem.shader_count = 4;
  problem.evaluate = [evaluations](int, int mesh, int shader) -> core::Result<lod::PairEvaluation> {
    ++*evaluations;
    return lod::PairEvaluation{.error = kMeshError[mesh] + kShaderError[shader],
                               .cost = kMeshCost[mesh] + kShaderCost[shader]};
  };
  problem.transition = [](int, const lod::EvaluatedPair& from,
                          const lod::EvaluatedPair& to) -> core::Result<double> {
    // Switching both mesh and shader is a bigger jump than switching one of them.
    return std::abs(kMeshError[from.mesh] - kMeshError[to.mesh]) +
           std::abs(kShaderError[from.shader] - kShaderError[to.shader]);
  };
  problem.cost_at = [](int, const lod::EvaluatedPair& pair, int) -> core::Result<double> {
    return kMeshCost[pair.mesh] + kShaderCost[pair.shader];
  };
  return problem;
}

TEST(LodSeparate, PicksTheCheapestPairWithinEachBound) {
  int evaluations = 0;
  // Level 0: bound 0 (d_near): nothing passes, the original is kept. Level 1: bound 2.5 (strict,
  // eq. 3): (mesh 2, shader 2) errs 2.5 and fails; (1, 2) errs 1.5 at cost 15, (2, 0) 2 at 16,
  // (0, 2) 0.5 at 17: the cheapest is (1, 2). Level 2: bound 9.5: (3, 1) errs 7 at cost 8, but
  // (2, 3) errs 8 at cost 7: the cheapest.
  lod::SeparateOptions options;
  options.time_tolerance = 0.0;  // keep only the cheapest: the path has no choice
  options.merge_min_gain = 0.0;  // keep every level that is cheaper at all
  auto solution = lod::optimizeSeparate(additiveProblem({0.0, 2.5, 9.5}, &evaluations), options);
  ASSERT_TRUE(solution.ok()) << solution.error().message;
  ASSERT_EQ(solution->chosen.size(), 3u);
  EXPECT_TRUE(solution->fallback_to_original[0]);
  EXPECT_FALSE(solution->fallback_to_original[1]);
  EXPECT_EQ(solution->chosen[0].mesh, 0);
  EXPECT_EQ(solution->chosen[0].shader, 0);
  EXPECT_EQ(solution->chosen[1].mesh, 1);
  EXPECT_EQ(solution->chosen[1].shader, 2);
  EXPECT_DOUBLE_EQ(solution->chosen[1].cost, 15);
  EXPECT_EQ(solution->chosen[2].mesh, 2);
  EXPECT_EQ(solution->chosen[2].shader, 3);
  EXPECT_DOUBLE_EQ(solution->chosen[2].cost, 7);
  // SortByError on M_0: shaders 0, 2, 1, 3.
  EXPECT_EQ(solution->shader_orders[1], (std::vector<int>{0, 2, 1, 3}));
  // Each level: 4 SortByError evaluations + at most K + L = 9 for the walk.
  EXPECT_LE(solution->evaluations, 3 * (4 + 9));
  EXPECT_EQ(solution->merge.kept_levels, (std::vector<int>{0, 1, 2}));
}

TEST(LodSeparate, OneDimensionalWalkFindsTheBruteForceOptimum) {
  for (double bound : {1.0, 2.5, 4.2, 6.6, 9.5, 20.0}) {
    int walk_evaluations = 0, brute_evaluations = 0;
    lod::SeparateOptions options;
    options.time_tolerance = 0.0;
    options.bisect_meshes = false;  // the paper's linear walk: at most K + L evaluations
    auto walk = lod::optimizeSeparate(additiveProblem({bound}, &walk_evaluations), options);
    options.brute_force = true;
    auto brute = lod::optimizeSeparate(additiveProblem({bound}, &brute_evaluations), options);
    ASSERT_TRUE(walk.ok() && brute.ok());
    EXPECT_DOUBLE_EQ(walk->chosen[0].cost, brute->chosen[0].cost) << "bound " << bound;
    EXPECT_EQ(brute->searches[0].evaluations, 5 * 4);
    EXPECT_LE(walk->searches[0].evaluations, 5 + 4);
  }
}

TEST(LodSeparate, BisectionFindsTheLinearWalksPairsWithFewerRenders) {
  // 200 mesh candidates whose error grows linearly, 6 shaders: the bisecting walk must choose what
  // the linear walk chooses, with O(L log K) instead of O(K + L) evaluations.
  lod::SeparateProblem problem;
  problem.level_count = 1;
  problem.mesh_counts = {200};
  problem.shader_count = 6;
  problem.evaluate = [](int, int mesh, int shader) -> core::Result<lod::PairEvaluation> {
    return lod::PairEvaluation{.error = 0.05 * mesh + 1.5 * shader,
                               .cost = 400.0 - mesh + 30.0 * (6 - shader)};
  };
  problem.transition = [](int, const lod::EvaluatedPair&, const lod::EvaluatedPair&)
      -> core::Result<double> { return 0.0; };
  problem.cost_at = [](int, const lod::EvaluatedPair& pair, int) -> core::Result<double> {
    return 400.0 - pair.mesh + 30.0 * (6 - pair.shader);
  };
  for (double bound : {0.5, 3.0, 7.7, 9.99}) {
    problem.error_bounds = {bound};
    lod::SeparateOptions options;
    options.bisect_meshes = false;
    auto linear = lod::optimizeSeparate(problem, options);
    options.bisect_meshes = true;
    auto bisected = lod::optimizeSeparate(problem, options);
    ASSERT_TRUE(linear.ok() && bisected.ok());
    EXPECT_EQ(bisected->chosen[0].mesh, linear->chosen[0].mesh) << "bound " << bound;
    EXPECT_EQ(bisected->chosen[0].shader, linear->chosen[0].shader) << "bound " << bound;
    EXPECT_LT(bisected->searches[0].evaluations, linear->searches[0].evaluations) << bound;
    EXPECT_LE(bisected->searches[0].evaluations, 6 * (2 + 8) + 1);  // L·(2 + log2 K)
  }
}

TEST(LodSeparate, BisectionStopsWhenTheBracketingMeshesAreAlmostTheSameSize) {
  // 101 meshes of 10000 − 10·j triangles, error 0.1·j, one shader, bound 5.05: the exact boundary
  // is mesh 50 (errs 5.0). The walk: mesh 100 fails, M_0 passes, then bisection of (0, 100).
  //   exact:    probes 50 (passes), 75, 62, 56, 53, 51 (fail): bracket (50, 51).
  //   1% stop:  50, 75, 62, 56; then (50, 56) differ by 60 ≤ 1% of 9500 triangles: stop, take 50.
  //   5% stop:  50, 75; then (50, 75) differ by 250 ≤ 5% of 9500: stop, take 50.
  lod::SeparateProblem problem;
  problem.level_count = 1;
  problem.mesh_counts = {101};
  problem.shader_count = 1;
  problem.error_bounds = {5.05};
  std::vector<double> sizes;
  for (int j = 0; j <= 100; ++j) sizes.push_back(10000.0 - 10.0 * j);
  problem.mesh_sizes = {sizes};
  problem.evaluate = [&](int, int mesh, int) -> core::Result<lod::PairEvaluation> {
    return lod::PairEvaluation{.error = 0.1 * mesh, .cost = sizes[mesh]};
  };
  problem.transition = [](int, const lod::EvaluatedPair&, const lod::EvaluatedPair&)
      -> core::Result<double> { return 0.0; };
  problem.cost_at = [&](int, const lod::EvaluatedPair& pair, int) -> core::Result<double> {
    return sizes[pair.mesh];
  };
  auto walk = [&](double stop) {
    lod::SeparateOptions options;
    options.bisection_stop = stop;
    auto solution = lod::optimizeSeparate(problem, options);
    EXPECT_TRUE(solution.ok());
    return std::pair{solution->chosen[0].mesh, solution->searches[0].evaluations};
  };
  // Evaluations: mesh 100, M_0, then the bisection's probes.
  EXPECT_EQ(walk(0.0), std::pair(50, 2 + 6));
  EXPECT_EQ(walk(0.01), std::pair(50, 2 + 4));
  EXPECT_EQ(walk(0.05), std::pair(50, 2 + 2));
}

TEST(LodSeparate, SmoothingNeverRaisesTheTotalTransitionError) {
  // With a tolerance, each level has several optimal pairs; the smoothest path's total ε_t is at
  // most that of taking each level's cheapest pair.
  for (double tolerance : {0.1, 0.3, 0.6}) {
    int evaluations = 0;
    lod::SeparateOptions options;
    options.time_tolerance = tolerance;
    auto smooth =
        lod::optimizeSeparate(additiveProblem({0.0, 2.5, 5.0, 9.5, 14.0}, &evaluations), options);
    options.smooth = false;
    auto cheapest =
        lod::optimizeSeparate(additiveProblem({0.0, 2.5, 5.0, 9.5, 14.0}, &evaluations), options);
    ASSERT_TRUE(smooth.ok() && cheapest.ok());
    EXPECT_LE(smooth->path.total_transition, cheapest->path.total_transition + 1e-12)
        << "tolerance " << tolerance;
    for (size_t level = 0; level < smooth->chosen.size(); ++level)
      EXPECT_TRUE(smooth->chosen[level].within_bound || smooth->fallback_to_original[level]);
  }
}

// The hook sees each level's pair set as it is chosen, in level order, before the smoothest path
// asks for any transition (generate drops the other renders then); one level searched alone
// chooses what the whole run chooses there.
TEST(LodSeparate, EachLevelsPairSetIsSeenBeforeAnyTransitionAndAloneIsTheSame) {
  int evaluations = 0;
  lod::SeparateProblem problem = additiveProblem({0.0, 2.5, 5.0, 9.5}, &evaluations);
  std::vector<int> seen_levels;
  std::vector<std::vector<lod::EvaluatedPair>> seen_pairs;
  bool transition_before_last_level = false;
  const lod::TransitionEvaluator transition = problem.transition;
  problem.transition = [&](int level, const lod::EvaluatedPair& from,
                           const lod::EvaluatedPair& to) {
    transition_before_last_level |= seen_levels.size() < 4;
    return transition(level, from, to);
  };
  lod::SeparateOptions options;
  options.time_tolerance = 0.3;  // several pairs per level
  options.on_level_pairs = [&](int level, const std::vector<lod::EvaluatedPair>& pairs) {
    seen_levels.push_back(level);
    seen_pairs.push_back(pairs);
  };
  auto solution = lod::optimizeSeparate(problem, options);
  ASSERT_TRUE(solution.ok()) << solution.error().message;
  EXPECT_EQ(seen_levels, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_FALSE(transition_before_last_level);
  size_t most_pairs = 0;
  for (int level = 0; level < 4; ++level) {
    const std::vector<lod::EvaluatedPair>& chosen = solution->level_pairs[level];
    ASSERT_EQ(seen_pairs[level].size(), chosen.size()) << "level " << level;
    most_pairs = std::max(most_pairs, chosen.size());
    lod::SeparateSolution alone;
    ASSERT_TRUE(lod::searchLevel(problem, options, level, alone).ok());
    ASSERT_EQ(alone.level_pairs.size(), 1u);
    ASSERT_EQ(alone.level_pairs[0].size(), chosen.size()) << "level " << level;
    for (size_t k = 0; k < chosen.size(); ++k) {
      for (const auto* pairs : {&seen_pairs[level], &alone.level_pairs[0]}) {
        EXPECT_EQ((*pairs)[k].mesh, chosen[k].mesh) << "level " << level;
        EXPECT_EQ((*pairs)[k].shader, chosen[k].shader) << "level " << level;
      }
    }
    EXPECT_EQ(alone.fallback_to_original[0], solution->fallback_to_original[level]);
  }
  EXPECT_GT(most_pairs, 1u);  // the tolerance did give the path a choice
  lod::SeparateSolution none;
  EXPECT_FALSE(lod::searchLevel(problem, options, 4, none).ok());
}

TEST(LodSeparate, MergesLevelsThatGainLessThanW) {
  // Bounds 9.5 and 9.6 give the same cheapest pair (cost 7): the second level gains nothing over
  // the first at its distance and is merged away with W = 4%.
  int evaluations = 0;
  lod::SeparateOptions options;
  options.time_tolerance = 0.0;
  auto solution = lod::optimizeSeparate(additiveProblem({0.0, 9.5, 9.6}, &evaluations), options);
  ASSERT_TRUE(solution.ok());
  EXPECT_EQ(solution->merge.kept_levels, (std::vector<int>{0, 1}));
  ASSERT_EQ(solution->merge.decisions.size(), 2u);
  EXPECT_TRUE(solution->merge.decisions[1].dropped);
  EXPECT_DOUBLE_EQ(solution->merge.decisions[1].gain, 0.0);
}

TEST(LodSeparate, BadProblemsAreErrors) {
  int evaluations = 0;
  lod::SeparateProblem problem = additiveProblem({0.0, 1.0}, &evaluations);
  problem.mesh_counts = {5};
  EXPECT_FALSE(lod::optimizeSeparate(problem, {}).ok());
  problem = additiveProblem({0.0}, &evaluations);
  problem.shader_count = 0;
  EXPECT_FALSE(lod::optimizeSeparate(problem, {}).ok());
  problem = additiveProblem({0.0}, &evaluations);
  problem.evaluate = [](int, int, int) -> core::Result<lod::PairEvaluation> {
    return core::Error{"render failed"};
  };
  auto failed = lod::optimizeSeparate(problem, {});
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.error().message.find("render failed"), std::string::npos);
}

}  // namespace
}  // namespace duolod
