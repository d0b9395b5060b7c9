// Levels and bounds (eq. 3/4), SortByError and SearchPairs (Algorithm 2, §5.3) against the 2D brute
// force, on hand-made error/cost tables whose feasible region and optimum are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "duolod/lod.hpp"

namespace duolod {
namespace {
using lod::EvaluatedPair;
using lod::PairEvaluation;

// ---- levels ----

TEST(LodLevels, LinearLevelsSpanNearToFarWithTheBoundOfEquation4) {
  lod::LevelOptions options;
  options.bound = {.d_near = 2, .d_far = 20, .q = 0.5f, .e_max = 0.1f};
  options.level_count = 10;
  core::Sphere sphere{{0, 0, 0}, 1.0f};
  auto levels = lod::distanceLevels(sphere, options);
  ASSERT_TRUE(levels.ok()) << levels.error().message;
  ASSERT_EQ(levels->size(), 10u);
  EXPECT_DOUBLE_EQ(levels->front().distance, 2.0);
  EXPECT_DOUBLE_EQ(levels->back().distance, 20.0);
  EXPECT_DOUBLE_EQ((*levels)[1].distance, 4.0);     // steps of (20 − 2)/9
  EXPECT_EQ(levels->front().per_pixel_bound, 0.0);  // the original's level: no error allowed
  EXPECT_NEAR(levels->back().per_pixel_bound, 0.1, 1e-7);
  // eq. (4) at level 3: ((8 − 2)/18)^0.5 · 0.1.
  EXPECT_NEAR((*levels)[3].per_pixel_bound, std::sqrt(6.0 / 18.0) * 0.1, 1e-7);
  for (size_t i = 1; i < levels->size(); ++i) {
    EXPECT_LE((*levels)[i].footprint_px, (*levels)[i - 1].footprint_px);  // farther is smaller
    EXPECT_LE((*levels)[i].screen_coverage, (*levels)[i - 1].screen_coverage);
    EXPECT_GT((*levels)[i].per_pixel_bound, (*levels)[i - 1].per_pixel_bound);
  }
  // eq. (3): the bound scales with the covered pixels.
  EXPECT_DOUBLE_EQ(lod::errorBound((*levels)[3], 200.0), (*levels)[3].per_pixel_bound * 200.0);
  EXPECT_NEAR((*levels)[3].disc_coverage_px,
              3.14159265 / 4 * (*levels)[3].footprint_px * (*levels)[3].footprint_px, 1e-3);
}

TEST(LodLevels, GeometricSpacingAndTableOne) {
  lod::LevelOptions options;
  options.bound = {.d_near = 1, .d_far = 16, .q = 0.5f, .e_max = 0.1f};
  options.level_count = 5;
  options.spacing = lod::LevelSpacing::kGeometric;
  auto levels = lod::distanceLevels({{0, 0, 0}, 0.5f}, options);
  ASSERT_TRUE(levels.ok());
  EXPECT_NEAR((*levels)[1].distance, 2.0, 1e-9);
  EXPECT_NEAR((*levels)[2].distance, 4.0, 1e-9);
  auto dragon = lod::tableOneBound("Dragon");
  ASSERT_TRUE(dragon.has_value());
  EXPECT_FLOAT_EQ(dragon->e_max, 0.14f);
  EXPECT_FLOAT_EQ(dragon->q, 0.5f);
  EXPECT_FLOAT_EQ(lod::tableOneBound("rocket")->q, 0.6f);
  EXPECT_FALSE(lod::tableOneBound("teapot").has_value());
  EXPECT_EQ(lod::tableOneBounds().size(), 5u);
}

TEST(LodLevels, BadOptionsAreErrors) {
  lod::LevelOptions options;
  options.level_count = 0;
  EXPECT_FALSE(lod::distanceLevels({{0, 0, 0}, 1}, options).ok());
  options.level_count = 3;
  options.bound.d_far = options.bound.d_near;
  auto bad = lod::distanceLevels({{0, 0, 0}, 1}, options);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("d_near"), std::string::npos);
  options.bound = {.d_near = 1, .d_far = 4, .q = 2.0f, .e_max = 0.1f};
  EXPECT_FALSE(lod::distanceLevels({{0, 0, 0}, 1}, options).ok());
}

// generateLod names an out-of-range option before any GL work (the shader is never read).
TEST(LodGenerate, OutOfRangeOptionsAreNamedFirst) {
  core::Asset asset;
  asset.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  asset.mesh.indices = {0, 1, 2};
  struct Case {
    float max_edge_pixels;
    int population;
    const char* message;
  };
  for (const Case& c : {Case{0.0f, 16, "max_edge_pixels"}, Case{NAN, 16, "max_edge_pixels"},
                        Case{-2.0f, 16, "max_edge_pixels"}, Case{1.0f, 1, "population"}}) {
    lod::GenerateOptions options;
    options.max_edge_pixels = c.max_edge_pixels;
    options.population = c.population;
    auto result = lod::generateLod(asset, render::GlslSource{}, options);
    ASSERT_FALSE(result.ok()) << c.message;
    EXPECT_NE(result.error().message.find(c.message), std::string::npos) << result.error().message;
  }
}

// ---- SortByError ----

TEST(LodSearch, SortByErrorIsStableAndIncreasing) {
  std::vector<double> errors = {0.5, 0.1, 0.3, 0.1, 0.0};
  EXPECT_EQ(lod::sortByError(errors), (std::vector<int>{4, 1, 3, 2, 0}));
}

// ---- SearchPairs ----

// A synthetic K × L table: error grows with the mesh index (coarser) and with the shader rank
// (simpler); cost falls with both. `calls` counts evaluations.
struct Table {
  std::vector<std::vector<double>> error, cost;  // [mesh][shader]
  int calls = 0;
  lod::PairEvaluator evaluator() {
    return [this](int mesh, int shader) -> core::Result<PairEvaluation> {
      ++calls;
      return PairEvaluation{error[mesh][shader], cost[mesh][shader]};
    };
  }
};

Table separableTable(int mesh_count, int shader_count) {
  Table table;
  table.error.assign(mesh_count, std::vector<double>(shader_count));
  table.cost = table.error;
  for (int m = 0; m < mesh_count; ++m)
    for (int s = 0; s < shader_count; ++s) {
      table.error[m][s] = m * 1.0 + s * 2.0;         // monotone in both
      table.cost[m][s] = 100.0 - 3.0 * m - 5.0 * s;  // simpler is cheaper
    }
  return table;
}

std::vector<int> identityOrder(int count) {
  std::vector<int> order(count);
  for (int i = 0; i < count; ++i) order[i] = i;
  return order;
}

TEST(LodSearch, WalksTheBoundaryOfAHandMadeTable) {
  // 4 meshes × 3 shaders, error = m + 2s, bound 4 (strict): feasible pairs are
  // s=0: m ≤ 3; s=1: m ≤ 1; s=2: none. Costs 100 − 3m − 5s: boundary (3,0)=91, (1,1)=92.
  Table table = separableTable(4, 3);
  auto order = identityOrder(3);
  auto result =
      lod::searchPairs(4, order, table.evaluator(), {.error_bound = 4.0, .time_tolerance = 0.0});
  ASSERT_TRUE(result.ok()) << result.error().message;
  // Path: (3,0) ok → (3,1)=5 no → (2,1)=4 no → (1,1)=3 ok → (1,2)=5 no → (0,2)=4 no → stop.
  std::vector<std::pair<int, int>> path;
  for (const EvaluatedPair& p : result->visited) path.push_back({p.mesh, p.shader});
  EXPECT_EQ(path,
            (std::vector<std::pair<int, int>>{{3, 0}, {3, 1}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}));
  EXPECT_EQ(result->evaluations, 6);
  EXPECT_EQ(table.calls, 6);
  ASSERT_EQ(result->optimal.size(), 1u);
  EXPECT_EQ(result->optimal[0].mesh, 3);
  EXPECT_EQ(result->optimal[0].shader, 0);
  EXPECT_DOUBLE_EQ(result->optimal[0].cost, 91.0);

  // With T = 2%, (1,1) at 92 is within (92 − 91)/91 = 1.1% of the best and joins the set.
  auto tolerant =
      lod::searchPairs(4, order, table.evaluator(), {.error_bound = 4.0, .time_tolerance = 0.02});
  ASSERT_TRUE(tolerant.ok());
  ASSERT_EQ(tolerant->optimal.size(), 2u);
  EXPECT_EQ(tolerant->optimal[1].mesh, 1);
  EXPECT_EQ(tolerant->optimal[1].shader, 1);

  // The brute force finds the same optimum with all 12 evaluations.
  auto brute = lod::searchPairsBruteForce(4, order, table.evaluator(),
                                          {.error_bound = 4.0, .time_tolerance = 0.0});
  ASSERT_TRUE(brute.ok());
  EXPECT_EQ(brute->evaluations, 12);
  ASSERT_EQ(brute->optimal.size(), 1u);
  EXPECT_EQ(brute->optimal[0].mesh, 3);
  EXPECT_EQ(brute->optimal[0].shader, 0);
}

TEST(LodSearch, VisitsShadersInSortByErrorOrder) {
  // Shader candidates given out of order: shader 2 is the most accurate, then 0, then 1.
  std::vector<double> error_on_m0 = {1.0, 2.0, 0.0};
  auto order = lod::sortByError(error_on_m0);
  ASSERT_EQ(order, (std::vector<int>{2, 0, 1}));
  std::vector<int> seen;
  lod::PairEvaluator evaluate = [&](int mesh, int shader) -> core::Result<PairEvaluation> {
    seen.push_back(shader);
    return PairEvaluation{mesh + error_on_m0[shader], 10.0 - mesh};
  };
  auto result = lod::searchPairs(2, order, evaluate, {.error_bound = 10.0});
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(seen, (std::vector<int>{2, 0, 1}));  // everything fits: one mesh, each shader in turn
  EXPECT_EQ(result->visited[1].shader_rank, 1);
}

TEST(LodSearch, NothingWithinTheBoundGivesAnEmptySet) {
  Table table = separableTable(3, 2);
  auto result = lod::searchPairs(3, identityOrder(2), table.evaluator(), {.error_bound = 0.0});
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result->optimal.empty());
  EXPECT_EQ(result->evaluations, 3);  // walked down every mesh with S_0, never moved right
}

TEST(LodSearch, EvaluatorErrorsPropagateAndBadInputIsRejected) {
  lod::PairEvaluator failing = [](int, int) -> core::Result<PairEvaluation> {
    return core::Error{"render failed"};
  };
  auto result = lod::searchPairs(3, identityOrder(2), failing, {.error_bound = 1});
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.error().message.find("render failed"), std::string::npos);
  EXPECT_FALSE(lod::searchPairs(0, identityOrder(2), failing, {}).ok());
  EXPECT_FALSE(lod::searchPairs(2, {}, failing, {}).ok());
}

// Where monotonicity fails the walk can miss what the brute force finds: this is why the paper
// reports both (and why the brute force exists here). Mesh 1 is an outlier: worse than mesh 2.
TEST(LodSearch, NonMonotoneTableShowsTheWalksAssumption) {
  Table table;
  table.error = {{0.0, 3.0}, {9.0, 9.0}, {1.0, 9.0}, {9.0, 9.0}};  // [mesh][shader]
  table.cost = {{10.0, 8.0}, {9.0, 7.0}, {6.0, 5.0}, {5.0, 4.0}};
  auto order = identityOrder(2);
  lod::PairSearchOptions options{.error_bound = 2.0, .time_tolerance = 0.0};
  auto walk = lod::searchPairs(4, order, table.evaluator(), options);
  auto brute = lod::searchPairsBruteForce(4, order, table.evaluator(), options);
  ASSERT_TRUE(walk.ok() && brute.ok());
  // Walk: (3,0) over → (2,0) within → (2,1) over → (1,1) over → (0,1) over: optimum (2,0) at 6.
  ASSERT_EQ(walk->optimal.size(), 1u);
  EXPECT_EQ(walk->optimal[0].mesh, 2);
  EXPECT_EQ(walk->evaluations, 5);
  ASSERT_EQ(brute->optimal.size(), 1u);
  EXPECT_EQ(brute->optimal[0].mesh, 2);  // here both agree: the outlier is never the optimum
  // Make (0,1) feasible and the cheapest: the walk still reaches it, stepping down past the
  // outlier (1,1).
  table.error[0][1] = 1.5;
  table.cost[0][1] = 1.0;
  walk = lod::searchPairs(4, order, table.evaluator(), options);
  brute = lod::searchPairsBruteForce(4, order, table.evaluator(), options);
  ASSERT_TRUE(walk.ok() && brute.ok());
  EXPECT_EQ(brute->optimal[0].mesh, 0);
  EXPECT_EQ(brute->optimal[0].shader, 1);
  EXPECT_EQ(walk->optimal[0].mesh, 0);
  // But an infeasible coarse mesh before a feasible one with a later shader is never revisited:
  // with (3,1) feasible and cheapest, the walk has already left mesh 3 at shader 0.
  table.error[3][1] = 0.5;
  table.cost[3][1] = 0.5;
  walk = lod::searchPairs(4, order, table.evaluator(), options);
  brute = lod::searchPairsBruteForce(4, order, table.evaluator(), options);
  ASSERT_TRUE(walk.ok() && brute.ok());
  EXPECT_EQ(brute->optimal[0].mesh, 3);
  EXPECT_EQ(brute->optimal[0].shader, 1);
  EXPECT_NE(walk->optimal[0].mesh, 3) << "the walk cannot find a pair its assumption rules out";
}

// On random monotone tables (error increasing, cost decreasing along both axes) the walk finds the
// brute force's optimum, evaluating at most K + L pairs where the brute force evaluates K·L.
TEST(LodSearch, MatchesBruteForceOnRandomMonotoneTablesInLinearEvaluations) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> step(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int mesh_count = 5 + trial % 40, shader_count = 3 + trial % 17;
    Table table;
    table.error.assign(mesh_count, std::vector<double>(shader_count));
    table.cost = table.error;
    // Cumulative sums of positive steps are monotone; cost is a separable sum so that the
    // optimum is unique with probability 1.
    std::vector<double> mesh_error(mesh_count), shader_error(shader_count), mesh_cost(mesh_count),
        shader_cost(shader_count);
    for (int m = 1; m < mesh_count; ++m) {
      mesh_error[m] = mesh_error[m - 1] + step(random);
      mesh_cost[m] = mesh_cost[m - 1] + step(random);
    }
    for (int s = 1; s < shader_count; ++s) {
      shader_error[s] = shader_error[s - 1] + step(random);
      shader_cost[s] = shader_cost[s - 1] + step(random);
    }
    for (int m = 0; m < mesh_count; ++m)
      for (int s = 0; s < shader_count; ++s) {
        table.error[m][s] = mesh_error[m] + shader_error[s] + 0.3 * mesh_error[m] * shader_error[s];
        table.cost[m][s] = 1000.0 - mesh_cost[m] - shader_cost[s];
      }
    const double bound = 0.5 * (mesh_error.back() + shader_error.back()) * step(random);
    auto order = identityOrder(shader_count);
    lod::PairSearchOptions options{.error_bound = bound, .time_tolerance = 0.0};
    auto walk = lod::searchPairs(mesh_count, order, table.evaluator(), options);
    auto brute = lod::searchPairsBruteForce(mesh_count, order, table.evaluator(), options);
    ASSERT_TRUE(walk.ok() && brute.ok());
    EXPECT_LE(walk->evaluations, mesh_count + shader_count) << "trial " << trial;
    EXPECT_EQ(brute->evaluations, mesh_count * shader_count);
    ASSERT_EQ(walk->optimal.empty(), brute->optimal.empty()) << "trial " << trial;
    if (!walk->optimal.empty()) {
      EXPECT_EQ(walk->optimal[0].mesh, brute->optimal[0].mesh) << "trial " << trial;
      EXPECT_EQ(walk->optimal[0].shader, brute->optimal[0].shader) << "trial " << trial;
    }
  }
}

// PairSearchOptions::on_discarded names exactly the visited pairs that end outside `optimal`,
// each once it can no longer be in it: on the hand-made table (T = 0 and 2%) and random tables
// with a tolerance, for the walk (with and without bisection) and the brute force.
TEST(LodSearch, DiscardedPairsAreTheVisitedOnesOutsideTheSet) {
  using Pair = std::pair<int, int>;
  auto check = [](const lod::PairSearchResult& result, const std::vector<Pair>& discarded,
                  const std::string& what) {
    std::set<Pair> outside, told(discarded.begin(), discarded.end());
    for (const EvaluatedPair& p : result.visited) outside.insert({p.mesh, p.shader});
    for (const EvaluatedPair& p : result.optimal) outside.erase({p.mesh, p.shader});
    EXPECT_EQ(told, outside) << what;
    EXPECT_EQ(told.size(), discarded.size()) << what << ": a pair told twice";
  };
  Table hand = separableTable(4, 3);
  for (double tolerance : {0.0, 0.02}) {
    std::vector<Pair> discarded;
    lod::PairSearchOptions options{.error_bound = 4.0, .time_tolerance = tolerance};
    options.on_discarded = [&](int mesh, int shader) { discarded.push_back({mesh, shader}); };
    auto result = lod::searchPairs(4, identityOrder(3), hand.evaluator(), options);
    ASSERT_TRUE(result.ok());
    check(*result, discarded, "hand-made, T " + std::to_string(tolerance));
    // (1,1) costs 92 against the best 91: out at T = 0, kept at 2%.
    EXPECT_EQ(std::count(discarded.begin(), discarded.end(), Pair{1, 1}), tolerance == 0 ? 1 : 0);
  }
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 60; ++trial) {
    const int mesh_count = 4 + trial % 30, shader_count = 2 + trial % 9;
    Table table;
    table.error.assign(mesh_count, std::vector<double>(shader_count));
    table.cost = table.error;
    for (int m = 0; m < mesh_count; ++m)
      for (int s = 0; s < shader_count; ++s) {
        table.error[m][s] = m + s + unit(random);
        table.cost[m][s] = 100.0 - m - 0.5 * s + 3 * unit(random);  // not monotone: ties, jumps
      }
    for (int kind = 0; kind < 3; ++kind) {
      std::vector<Pair> discarded;
      lod::PairSearchOptions options{
          .error_bound = 0.6 * (mesh_count + shader_count) * unit(random),
          .time_tolerance = 0.03,
          .bisect_meshes = kind == 1};
      options.on_discarded = [&](int mesh, int shader) { discarded.push_back({mesh, shader}); };
      auto order = identityOrder(shader_count);
      auto result = kind == 2
                        ? lod::searchPairsBruteForce(mesh_count, order, table.evaluator(), options)
                        : lod::searchPairs(mesh_count, order, table.evaluator(), options);
      ASSERT_TRUE(result.ok());
      check(*result, discarded, "trial " + std::to_string(trial) + " kind " + std::to_string(kind));
    }
  }
}

}  // namespace
}  // namespace duolod
