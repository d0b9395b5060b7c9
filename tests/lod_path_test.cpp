// Dijkstra on hand-made graphs, the smoothest path of Algorithm 3 (§6.1) against enumeration and
// against the per-level cheapest choice, and merging inefficient levels (§6.2, W = 4%).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "duolod/lod.hpp"

namespace duolod {
namespace {
using lod::EvaluatedPair;

TEST(LodDijkstra, HandMadeGraph) {
  // 0 →(4) 1 →(1) 3, 0 →(1) 2 →(1) 1, 2 →(5) 3: the short way is 0-2-1-3 with length 3.
  lod::WeightedGraph graph;
  for (int i = 0; i < 5; ++i) graph.addNode();
  graph.addEdge(0, 1, 4);
  graph.addEdge(0, 2, 1);
  graph.addEdge(2, 1, 1);
  graph.addEdge(1, 3, 1);
  graph.addEdge(2, 3, 5);
  lod::ShortestPath path = lod::dijkstra(graph, 0, 3);
  EXPECT_EQ(path.nodes, (std::vector<int>{0, 2, 1, 3}));
  EXPECT_DOUBLE_EQ(path.length, 3.0);
  // Node 4 has no incoming edge.
  EXPECT_TRUE(lod::dijkstra(graph, 0, 4).nodes.empty());
  // Source = target.
  EXPECT_EQ(lod::dijkstra(graph, 2, 2).nodes, (std::vector<int>{2}));
  EXPECT_DOUBLE_EQ(lod::dijkstra(graph, 2, 2).length, 0.0);
}

TEST(LodDijkstra, ZeroWeightsAndACycle) {
  lod::WeightedGraph graph;
  for (int i = 0; i < 4; ++i) graph.addNode();
  graph.addEdge(0, 1, 0);
  graph.addEdge(1, 0, 0);
  graph.addEdge(1, 2, 2);
  graph.addEdge(0, 3, 1);
  graph.addEdge(3, 2, 0.5);
  lod::ShortestPath path = lod::dijkstra(graph, 0, 2);
  EXPECT_EQ(path.nodes, (std::vector<int>{0, 3, 2}));
  EXPECT_DOUBLE_EQ(path.length, 1.5);
}

std::vector<EvaluatedPair> pairsWithCosts(std::vector<double> costs) {
  std::vector<EvaluatedPair> pairs;
  for (size_t i = 0; i < costs.size(); ++i)
    pairs.push_back(
        {.mesh = static_cast<int>(i), .shader = 0, .cost = costs[i], .within_bound = true});
  return pairs;
}

TEST(LodSmoothestPath, HandMadeThreeLevels) {
  // Level 0: {a}, level 1: {b0, b1}, level 2: {c0, c1}. Weights chosen so the greedy step from a
  // (to b0, weight 1) leads to an expensive last transition (10), while a→b1→c1 totals 2 + 1 = 3.
  std::vector<std::vector<EvaluatedPair>> levels = {pairsWithCosts({5}), pairsWithCosts({3, 4}),
                                                    pairsWithCosts({1, 2})};
  double weight[3][2][2] = {};  // [level][from][to]
  weight[0][0][0] = 1;
  weight[0][0][1] = 2;
  weight[1][0][0] = 10;
  weight[1][0][1] = 10;
  weight[1][1][0] = 7;
  weight[1][1][1] = 1;
  int calls = 0;
  lod::TransitionEvaluator evaluate = [&](int level, const EvaluatedPair& from,
                                          const EvaluatedPair& to) -> core::Result<double> {
    ++calls;
    return weight[level][from.mesh][to.mesh];
  };
  auto path = lod::smoothestPath(levels, evaluate);
  ASSERT_TRUE(path.ok()) << path.error().message;
  EXPECT_EQ(path->choice, (std::vector<int>{0, 1, 1}));
  EXPECT_DOUBLE_EQ(path->total_transition, 3.0);
  EXPECT_EQ(path->transition, (std::vector<double>{2.0, 1.0}));
  EXPECT_EQ(calls, 1 * 2 + 2 * 2);  // every pair of adjacent levels once
  EXPECT_EQ(path->evaluations, 6);
  EXPECT_EQ(path->edges.size(), 6u);
}

TEST(LodSmoothestPath, SingleLevelAndErrors) {
  std::vector<std::vector<EvaluatedPair>> one = {pairsWithCosts({3, 1, 2})};
  lod::TransitionEvaluator never = [](int, const EvaluatedPair&,
                                      const EvaluatedPair&) -> core::Result<double> {
    return core::Error{"not called"};
  };
  auto path = lod::smoothestPath(one, never);
  ASSERT_TRUE(path.ok());
  EXPECT_EQ(path->choice.size(), 1u);
  EXPECT_DOUBLE_EQ(path->total_transition, 0.0);

  std::vector<std::vector<EvaluatedPair>> with_empty = {pairsWithCosts({1}), {}};
  auto empty = lod::smoothestPath(with_empty, never);
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.error().message.find("level 1"), std::string::npos);

  std::vector<std::vector<EvaluatedPair>> two = {pairsWithCosts({1}), pairsWithCosts({1})};
  auto failed = lod::smoothestPath(two, never);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.error().message.find("not called"), std::string::npos);
  lod::TransitionEvaluator negative =
      [](int, const EvaluatedPair&, const EvaluatedPair&) -> core::Result<double> { return -1.0; };
  EXPECT_FALSE(lod::smoothestPath(two, negative).ok());
  // An infinite or NaN transition error is refused too (infinity crashed the path's read-back).
  for (double bad : {std::numeric_limits<double>::infinity(), std::nan("")}) {
    lod::TransitionEvaluator odd = [bad](int, const EvaluatedPair&,
                                         const EvaluatedPair&) -> core::Result<double> {
      return bad;
    };
    auto refused = lod::smoothestPath(two, odd);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_NE(refused.error().message.find("finite"), std::string::npos) << refused.error().message;
  }
}

TEST(LodDijkstra, OutOfRangeEndsAndInfiniteWeights) {
  lod::WeightedGraph graph;
  for (int i = 0; i < 3; ++i) graph.addNode();
  graph.addEdge(0, 1, std::numeric_limits<double>::infinity());
  graph.addEdge(1, 2, 1);
  EXPECT_TRUE(lod::dijkstra(graph, 0, 2).nodes.empty());  // the infinite edge is no edge
  EXPECT_TRUE(lod::dijkstra(graph, 0, 7).nodes.empty());
  EXPECT_TRUE(lod::dijkstra(graph, -1, 2).nodes.empty());
  EXPECT_EQ(lod::dijkstra(graph, 1, 2).nodes, (std::vector<int>{1, 2}));
}

// The property: the smoothest path never has a larger total transition error than taking
// each level's cheapest pair; and it equals the minimum over all paths (exhaustive enumeration).
TEST(LodSmoothestPath, NeverWorseThanCheapestPerLevelAndOptimalOverAllPaths) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    const int level_count = 2 + trial % 5;
    std::vector<std::vector<EvaluatedPair>> levels(level_count);
    for (auto& level : levels) {
      const int pair_count = 1 + static_cast<int>(unit(random) * 4);
      for (int p = 0; p < pair_count; ++p)
        level.push_back({.mesh = p, .shader = p, .cost = unit(random), .within_bound = true});
    }
    // A fixed random weight per edge, looked up by (level, from, to).
    std::vector<std::vector<std::vector<double>>> weight(level_count);
    for (int l = 0; l + 1 < level_count; ++l) {
      weight[l].assign(levels[l].size(), std::vector<double>(levels[l + 1].size()));
      for (auto& row : weight[l])
        for (double& w : row) w = unit(random) * 10;
    }
    lod::TransitionEvaluator evaluate = [&](int level, const EvaluatedPair& from,
                                            const EvaluatedPair& to) -> core::Result<double> {
      return weight[level][from.mesh][to.mesh];
    };
    auto path = lod::smoothestPath(levels, evaluate);
    ASSERT_TRUE(path.ok());
    auto total = [&](const std::vector<int>& choice) {
      double sum = 0;
      for (int l = 0; l + 1 < level_count; ++l) sum += weight[l][choice[l]][choice[l + 1]];
      return sum;
    };
    EXPECT_NEAR(path->total_transition, total(path->choice), 1e-9);
    std::vector<int> cheapest;
    for (const auto& level : levels) {
      int best = 0;
      for (size_t p = 1; p < level.size(); ++p)
        if (level[p].cost < level[best].cost) best = static_cast<int>(p);
      cheapest.push_back(best);
    }
    EXPECT_LE(path->total_transition, total(cheapest) + 1e-12) << "trial " << trial;
    // Exhaustive minimum.
    double minimum = INFINITY;
    std::vector<int> choice(level_count, 0);
    std::function<void(int)> enumerate = [&](int l) {
      if (l == level_count) {
        minimum = std::min(minimum, total(choice));
        return;
      }
      for (size_t p = 0; p < levels[l].size(); ++p) {
        choice[l] = static_cast<int>(p);
        enumerate(l + 1);
      }
    };
    enumerate(0);
    EXPECT_NEAR(path->total_transition, minimum, 1e-9) << "trial " << trial;
  }
}

// ---- merging (§6.2) ----

TEST(LodMerge, DropsLevelsThatGainLessThanW) {
  // cost[pair_level][distance_level]; the original costs 100 everywhere.
  // Level 1 gains (100 − 90)/100 = 10%: kept. Level 2: level 1's pair at d_2 costs 89, so it gains
  // (89 − 88)/100 = 1% < 4%: dropped.
  // Level 3 is then compared with level 1's pair at d_3 (85): (85 − 70)/100 = 15%: kept.
  std::vector<std::vector<double>> cost = {
      {100, 100, 100, 100},
      {0, 90, 89, 85},
      {0, 0, 88, 84},
      {0, 0, 0, 70},
  };
  lod::LevelCostEvaluator pair_cost = [&](int pair_level,
                                          int distance_level) -> core::Result<double> {
    return cost[pair_level][distance_level];
  };
  lod::OriginalCostEvaluator original = [](int) -> core::Result<double> { return 100.0; };
  auto merged = lod::mergeInefficientLevels(4, pair_cost, original);
  ASSERT_TRUE(merged.ok()) << merged.error().message;
  EXPECT_EQ(merged->kept_levels, (std::vector<int>{0, 1, 3}));
  ASSERT_EQ(merged->decisions.size(), 3u);
  EXPECT_NEAR(merged->decisions[1].gain, 0.01, 1e-12);
  EXPECT_TRUE(merged->decisions[1].dropped);
  EXPECT_EQ(merged->decisions[2].previous, 1);
  EXPECT_NEAR(merged->decisions[2].gain, 0.15, 1e-12);
  EXPECT_FALSE(merged->decisions[2].dropped);

  // W = 0 keeps every level that is not slower; W = 1 drops them all.
  EXPECT_EQ(lod::mergeInefficientLevels(4, pair_cost, original, 0.0)->kept_levels,
            (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(lod::mergeInefficientLevels(4, pair_cost, original, 1.0)->kept_levels,
            (std::vector<int>{0}));
}

TEST(LodMerge, ErrorsAreReported) {
  lod::LevelCostEvaluator failing = [](int, int) -> core::Result<double> {
    return core::Error{"timer broke"};
  };
  lod::OriginalCostEvaluator zero = [](int) -> core::Result<double> { return 0.0; };
  auto merged = lod::mergeInefficientLevels(3, failing, zero);
  ASSERT_FALSE(merged.ok());
  EXPECT_NE(merged.error().message.find("timer broke"), std::string::npos);
  lod::LevelCostEvaluator fine = [](int, int) -> core::Result<double> { return 1.0; };
  EXPECT_FALSE(lod::mergeInefficientLevels(3, fine, zero).ok());
  EXPECT_EQ(lod::mergeInefficientLevels(1, fine, zero)->kept_levels, (std::vector<int>{0}));
}

}  // namespace
}  // namespace duolod
