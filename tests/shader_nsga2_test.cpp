// NSGA-II (Deb et al. 2002) on hand-checkable point sets, determinism for a seed, and convergence
// on ZDT1 (Zitzler, Deb, Thiele 2000) with few genes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "shader/nsga2.hpp"

namespace duolod::shader {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Nsga2, DominanceIsStrictInOneObjective) {
  EXPECT_TRUE(dominates({1, 1}, {2, 2}));
  EXPECT_TRUE(dominates({1, 2}, {2, 2}));
  EXPECT_FALSE(dominates({2, 2}, {2, 2}));  // equal points do not dominate each other
  EXPECT_FALSE(dominates({1, 3}, {2, 2}));  // a trade-off
  EXPECT_FALSE(dominates({2, 2}, {1, 2}));
}

// (cost, error) points drawn on paper: three on the first front, a duplicate of one of them, two
// on the second, then one each.
const std::vector<Objectives> kPoints = {{1, 5}, {2, 3}, {3, 1}, {2, 4},
                                         {3, 3}, {4, 4}, {5, 5}, {2, 3}};

TEST(Nsga2, FrontsOfAKnownPointSet) {
  std::vector<std::vector<int>> fronts = nondominatedFronts(kPoints);
  ASSERT_EQ(fronts.size(), 4u);
  EXPECT_EQ(fronts[0], (std::vector<int>{0, 1, 2, 7}));  // (2,3) twice: neither dominates
  EXPECT_EQ(fronts[1], (std::vector<int>{3, 4}));        // (2,4) and (3,3): beaten by (2,3)
  EXPECT_EQ(fronts[2], (std::vector<int>{5}));           // (4,4): beaten by (3,3)
  EXPECT_EQ(fronts[3], (std::vector<int>{6}));
  EXPECT_TRUE(nondominatedFronts({}).empty());
}

TEST(Nsga2, CrowdingDistancesByHand) {
  // Front (0,4) (1,2) (3,1) (4,0): cost range 4, error range 4.
  std::vector<Objectives> points = {{3, 1}, {0, 4}, {4, 0}, {1, 2}};
  std::vector<int> front = {0, 1, 2, 3};
  std::vector<double> distance = crowdingDistances(points, front);
  EXPECT_DOUBLE_EQ(distance[0], (4.0 - 1.0) / 4 + (2.0 - 0.0) / 4);  // (3,1): 1.25
  EXPECT_EQ(distance[1], kInf);
  EXPECT_EQ(distance[2], kInf);
  EXPECT_DOUBLE_EQ(distance[3], (3.0 - 0.0) / 4 + (4.0 - 1.0) / 4);  // (1,2): 1.5
  // Two members are both extremes.
  std::vector<int> pair = {0, 1};
  EXPECT_EQ(crowdingDistances(points, pair), (std::vector<double>{kInf, kInf}));
}

TEST(Nsga2, SurvivalFillsByFrontThenCrowding) {
  // Front 1 = {0,1,2,7} (4 points), front 2 = {3,4}: 5 places take front 1 and one of front 2.
  Survival survival = selectSurvivors(kPoints, 5);
  ASSERT_EQ(survival.survivors.size(), 5u);
  EXPECT_EQ(survival.rank[0], 0);
  EXPECT_EQ(survival.rank[4], 1);
  EXPECT_EQ(survival.rank[6], 3);
  // Front 1's extremes (0 and 2) are infinitely crowded and come first. The two copies of (2,3)
  // each have one copy and one extreme as neighbours: cost gap 1 of range 2, error gap 2 of range
  // 4, so 1/2 + 1/2 = 1 both, and index order decides: 1 before 7.
  EXPECT_DOUBLE_EQ(survival.crowding[1], 1.0);
  EXPECT_DOUBLE_EQ(survival.crowding[7], 1.0);
  EXPECT_EQ(survival.survivors[0], 0);
  EXPECT_EQ(survival.survivors[1], 2);
  EXPECT_EQ(survival.survivors[2], 1);
  EXPECT_EQ(survival.survivors[3], 7);
  // Both members of front 2 are extremes (infinite distance): the lower index wins.
  EXPECT_EQ(survival.survivors[4], 3);
}

TEST(Nsga2, RandomNumbersAreSeededAndInRange) {
  SearchRandom a(7), b(7), c(8);
  for (int i = 0; i < 100; ++i) {
    uint64_t x = a.next();
    EXPECT_EQ(x, b.next());
    EXPECT_NE(x, c.next());
  }
  SearchRandom r(1);
  int heads = 0;
  for (int i = 0; i < 10000; ++i) {
    double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    ASSERT_LT(r.index(3), 3u);
    heads += r.chance(0.5);
  }
  EXPECT_NEAR(heads, 5000, 300);  // ~6 standard deviations
}

// ZDT1 with `genes` variables in [0,1]: f1 = x1, g = 1 + 9·mean(x2..xn), f2 = g·(1 − sqrt(f1/g)).
// The Pareto front is g = 1 (x2..xn = 0): f2 = 1 − sqrt(f1).
using Genes = std::vector<double>;
double zdt1G(const Genes& x) {
  double sum = 0;
  for (size_t i = 1; i < x.size(); ++i) sum += x[i];
  return 1 + 9 * sum / double(x.size() - 1);
}
Nsga2Problem<Genes> zdt1Problem() {
  Nsga2Problem<Genes> problem;
  problem.evaluate = [](const Genes& x) -> std::optional<Objectives> {
    double g = zdt1G(x);
    return Objectives{x[0], g * (1 - std::sqrt(x[0] / g))};
  };
  problem.mutate = [](const Genes& x, SearchRandom& random) {
    Genes y = x;
    for (double& gene : y)
      if (random.chance(1.0 / double(y.size())))
        gene = std::clamp(gene + 0.1 * random.normal(), 0.0, 1.0);
    return y;
  };
  problem.crossover = [](const Genes& a, const Genes& b, SearchRandom& random) {
    Genes y = a;
    for (size_t i = 0; i < y.size(); ++i)
      if (random.chance(0.5)) y[i] = b[i];
    return y;
  };
  return problem;
}
std::vector<Genes> randomGenes(int count, int genes, uint64_t seed) {
  SearchRandom random(seed);
  std::vector<Genes> result(count, Genes(genes));
  for (Genes& x : result)
    for (double& gene : x) gene = random.uniform();
  return result;
}

TEST(Nsga2, SameSeedSameSearch) {
  Nsga2Options options{.population_size = 16, .generations = 10, .seed = 42};
  auto first = runNsga2(randomGenes(16, 4, 3), zdt1Problem(), options);
  auto second = runNsga2(randomGenes(16, 4, 3), zdt1Problem(), options);
  ASSERT_EQ(first.population.size(), second.population.size());
  for (size_t i = 0; i < first.population.size(); ++i)
    EXPECT_EQ(first.population[i].genome, second.population[i].genome);
  EXPECT_EQ(first.evaluations, 16 + 10 * 16);
  options.seed = 43;
  auto other = runNsga2(randomGenes(16, 4, 3), zdt1Problem(), options);
  bool differs = false;
  for (size_t i = 0; i < first.population.size(); ++i)
    differs |= first.population[i].genome != other.population[i].genome;
  EXPECT_TRUE(differs);
}

// prepare() sees each batch whole before its first evaluation: the initial population, then one
// batch of offspring per generation, in exactly the order evaluate() is then called; and having
// it changes no result.
TEST(Nsga2, PrepareAnnouncesEveryBatchInEvaluationOrder) {
  Nsga2Options options{.population_size = 8, .generations = 3, .seed = 7};
  Nsga2Problem<Genes> problem = zdt1Problem();
  std::vector<Genes> announced, evaluated;
  std::vector<size_t> batch_sizes;
  problem.prepare = [&](std::span<const Genes> batch) {
    EXPECT_EQ(announced.size(), evaluated.size());  // the previous batch is fully evaluated
    announced.insert(announced.end(), batch.begin(), batch.end());
    batch_sizes.push_back(batch.size());
  };
  auto evaluate = problem.evaluate;
  problem.evaluate = [&](const Genes& x) {
    evaluated.push_back(x);
    return evaluate(x);
  };
  auto with = runNsga2(randomGenes(3, 4, 11), problem, options);
  EXPECT_EQ(batch_sizes, (std::vector<size_t>{8, 8, 8, 8}));  // 3 initial + 5 mutants, then 3 × 8
  EXPECT_EQ(announced, evaluated);
  auto without = runNsga2(randomGenes(3, 4, 11), zdt1Problem(), options);
  ASSERT_EQ(with.population.size(), without.population.size());
  for (size_t i = 0; i < with.population.size(); ++i)
    EXPECT_EQ(with.population[i].genome, without.population[i].genome);
}

TEST(Nsga2, ConvergesOnZdt1) {
  const int genes = 5;
  std::vector<Genes> initial = randomGenes(40, genes, 11);
  double initial_worst_g = 0;
  for (const Genes& x : initial) initial_worst_g = std::max(initial_worst_g, zdt1G(x));
  int generations_seen = 0;
  Nsga2Problem<Genes> problem = zdt1Problem();
  problem.on_generation = [&](int generation, std::span<const Objectives> population) {
    generations_seen = generation;
    EXPECT_EQ(population.size(), 40u);
  };
  auto result = runNsga2(initial, problem, {.population_size = 40, .generations = 150, .seed = 5});
  EXPECT_EQ(generations_seen, 150);
  ASSERT_GE(result.front.size(), 20u);
  double low = 1, high = 0;
  for (const auto& individual : result.front) {
    // Every front member lies within 5% of the true front (g = 1)...
    EXPECT_LT(zdt1G(individual.genome), 1.05) << "f1 " << individual.objectives.cost;
    low = std::min(low, individual.objectives.cost);
    high = std::max(high, individual.objectives.cost);
  }
  // ...and the front spans it (crowding keeps the extremes).
  EXPECT_LT(low, 0.05);
  EXPECT_GT(high, 0.9);
  EXPECT_GT(initial_worst_g, 3.0);  // the start was far from it
  // Sorted by cost, so errors decrease along a non-dominated front.
  for (size_t i = 1; i < result.front.size(); ++i)
    EXPECT_LE(result.front[i].objectives.error, result.front[i - 1].objectives.error);
}

TEST(Nsga2, InvalidGenomesNeverReachTheFront) {
  Nsga2Problem<Genes> problem = zdt1Problem();
  auto valid = problem.evaluate;
  int calls = 0;
  // Every genome with x1 > 0.5 "fails to compile".
  problem.evaluate = [&](const Genes& x) -> std::optional<Objectives> {
    ++calls;
    if (x[0] > 0.5) return std::nullopt;
    return valid(x);
  };
  auto result = runNsga2(randomGenes(12, 3, 9), problem, {.population_size = 12, .generations = 8});
  EXPECT_EQ(calls, result.evaluations);
  ASSERT_FALSE(result.front.empty());
  for (const auto& individual : result.front) {
    EXPECT_TRUE(individual.valid);
    EXPECT_LE(individual.genome[0], 0.5);
  }
}

TEST(Nsga2, FewInitialGenomesAreFilledWithMutants) {
  auto result = runNsga2(randomGenes(1, 3, 2), zdt1Problem(),
                         {.population_size = 10, .generations = 0});
  EXPECT_EQ(result.population.size(), 10u);
  EXPECT_EQ(result.evaluations, 10);
}

}  // namespace
}  // namespace duolod::shader
