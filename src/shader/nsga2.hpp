// NSGA-II for two minimised objectives (cost, error), genome-agnostic: Deb, Pratap, Agarwal,
// Meyarivan, "A Fast and Elitist Multiobjective Genetic Algorithm: NSGA-II", IEEE TEC 6(2), 2002.
// Used as in Sitthi-Amorn et al. 2011 ("Genetic Programming for Shader Simplification") and Liang
// et al. §5.2 to find Pareto frontiers of shader variants. Seeded and deterministic: the same
// seed, genomes and callbacks give the same search on every platform (own generator, no
// std::*_distribution, whose output is implementation-defined).
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace duolod::shader {

struct Objectives {
  double cost = 0;
  double error = 0;
};
// Pareto dominance for minimisation: no worse in both objectives and better in at least one.
bool dominates(const Objectives& a, const Objectives& b);

// Fast non-dominated sort (Deb et al. 2002, §III-A): fronts F1, F2, ... as indices into `points`,
// each front in increasing index order. Equal points share a front.
std::vector<std::vector<int>> nondominatedFronts(std::span<const Objectives> points);

// Crowding distance (§III-B) of each member of `front` (indices into `points`), in the front's
// order: per objective, the gap between the two neighbours normalised by the front's range;
// the extreme points of either objective get +infinity.
std::vector<double> crowdingDistances(std::span<const Objectives> points,
                                      std::span<const int> front);

// Elitist (μ+λ) survival (§III-C): fills `count` places front by front, the last front by
// decreasing crowding distance (ties: lower index first). Also the rank (0 = first front) and
// crowding distance of every point, as the crowded-comparison tournament needs them.
struct Survival {
  std::vector<int> survivors;  // indices into the points, best first
  std::vector<int> rank;       // per point
  std::vector<double> crowding;  // per point
};
Survival selectSurvivors(std::span<const Objectives> points, int count);

// splitmix64 (Steele, Lea, Flood 2014): small, fast, and the same on every platform.
class SearchRandom {
 public:
  explicit SearchRandom(uint64_t seed) : state_(seed) {}
  uint64_t next();
  double uniform();                    // [0, 1)
  size_t index(size_t count);          // [0, count); count > 0
  bool chance(double probability);
  double normal();                     // standard normal (Box–Muller)

 private:
  uint64_t state_;
};

struct Nsga2Options {
  int population_size = 24;
  int generations = 20;
  double crossover_probability = 0.9;  // else the child is a copy of the first parent, mutated
  uint64_t seed = 1;
};

template <class Genome>
struct Nsga2Problem {
  std::function<Genome(const Genome&, SearchRandom&)> mutate;
  // Optional: empty means offspring come from mutation alone.
  std::function<Genome(const Genome&, const Genome&, SearchRandom&)> crossover;
  // std::nullopt marks an invalid genome (e.g. a shader that fails to compile): it ranks behind
  // every valid one and never appears in the returned front.
  std::function<std::optional<Objectives>(const Genome&)> evaluate;
  // Optional: told each batch of genomes before they are evaluated one by one, in that order
  // (the initial population, then each generation's offspring). Must not change any result.
  std::function<void(std::span<const Genome>)> prepare;
  // Optional: called after each generation's survival with the generation (1-based) and the
  // population, for progress and logging.
  std::function<void(int, std::span<const Objectives>)> on_generation;
};

template <class Genome>
struct Individual {
  Genome genome;
  Objectives objectives;
  bool valid = true;
  int rank = 0;
  double crowding = 0;
};

template <class Genome>
struct Nsga2Result {
  std::vector<Individual<Genome>> population;  // the final population, best first
  std::vector<Individual<Genome>> front;       // its valid first front, by increasing cost
  int evaluations = 0;                         // calls of evaluate()
};

namespace nsga2_detail {
inline Objectives invalidObjectives() {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  return {kInf, kInf};
}
// Crowded-comparison binary tournament (§III-C): lower rank wins, then larger crowding distance,
// then a fair coin.
int tournament(std::span<const int> rank, std::span<const double> crowding, SearchRandom& random);
}  // namespace nsga2_detail

// Runs NSGA-II from `initial` genomes (at least one). A smaller initial set is filled up to the
// population size with mutants of its members; a larger one is cut down by survival.
template <class Genome>
Nsga2Result<Genome> runNsga2(std::vector<Genome> initial, const Nsga2Problem<Genome>& problem,
                             const Nsga2Options& options) {
  SearchRandom random(options.seed);
  Nsga2Result<Genome> result;
  const int size = options.population_size;
  std::vector<Individual<Genome>> population;
  auto evaluated = [&](Genome genome) {
    Individual<Genome> individual{std::move(genome), {}, true, 0, 0};
    ++result.evaluations;
    if (auto objectives = problem.evaluate(individual.genome))
      individual.objectives = *objectives;
    else
      individual.valid = false, individual.objectives = nsga2_detail::invalidObjectives();
    return individual;
  };
  auto objectivesOf = [](const std::vector<Individual<Genome>>& individuals) {
    std::vector<Objectives> points;
    for (const auto& individual : individuals) points.push_back(individual.objectives);
    return points;
  };
  // Keeps the `size` best of `pool` (best first), with their rank and crowding distance.
  auto survive = [&](std::vector<Individual<Genome>> pool) {
    std::vector<Objectives> points = objectivesOf(pool);
    Survival survival = selectSurvivors(points, size);
    std::vector<Individual<Genome>> next;
    for (int index : survival.survivors) {
      pool[index].rank = survival.rank[index];
      pool[index].crowding = survival.crowding[index];
      next.push_back(std::move(pool[index]));
    }
    return next;
  };

  // Each batch is made whole before any of it is evaluated (evaluation draws no random numbers,
  // so the order of draws is as if made one by one), then announced, then evaluated in order.
  auto evaluateBatch = [&](std::vector<Genome> batch, std::vector<Individual<Genome>>& into) {
    if (problem.prepare) problem.prepare(batch);
    for (Genome& genome : batch) into.push_back(evaluated(std::move(genome)));
  };
  const size_t initial_count = initial.size();
  std::vector<Genome> first_batch = initial;
  for (size_t i = 0; first_batch.size() < size_t(size) && initial_count > 0; ++i)
    first_batch.push_back(problem.mutate(initial[i % initial_count], random));
  evaluateBatch(std::move(first_batch), population);
  population = survive(std::move(population));

  for (int generation = 1; generation <= options.generations && !population.empty();
       ++generation) {
    std::vector<int> rank;
    std::vector<double> crowding;
    for (const auto& individual : population) {
      rank.push_back(individual.rank);
      crowding.push_back(individual.crowding);
    }
    std::vector<Individual<Genome>> pool = population;
    std::vector<Genome> offspring_batch;
    for (int child = 0; child < size; ++child) {
      const Genome& first = population[nsga2_detail::tournament(rank, crowding, random)].genome;
      const Genome& second = population[nsga2_detail::tournament(rank, crowding, random)].genome;
      Genome offspring = problem.crossover && random.chance(options.crossover_probability)
                             ? problem.crossover(first, second, random)
                             : first;
      offspring_batch.push_back(problem.mutate(offspring, random));
    }
    evaluateBatch(std::move(offspring_batch), pool);
    population = survive(std::move(pool));
    if (problem.on_generation) problem.on_generation(generation, objectivesOf(population));
  }

  for (const auto& individual : population)
    if (individual.rank == 0 && individual.valid) result.front.push_back(individual);
  std::stable_sort(result.front.begin(), result.front.end(), [](const auto& a, const auto& b) {
    return a.objectives.cost < b.objectives.cost ||
           (a.objectives.cost == b.objectives.cost && a.objectives.error < b.objectives.error);
  });
  result.population = std::move(population);
  return result;
}

}  // namespace duolod::shader
