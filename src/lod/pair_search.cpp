// Searching optimal pairs of meshes and shaders: Liang et al., "Automatic Mesh and Shader Level of
// Detail", §5.3, Algorithm 1 (SortByError, line 6) and Algorithm 2 (SearchPairs), with the 2D
// brute force the paper compares against.
//
// With meshes ordered by increasing simplification and shaders by increasing error on M_0, the
// pairs within the bound form a staircase region; for each shader the cheapest feasible mesh is
// the coarsest one inside it, on the region's boundary. Walking that boundary visits at most
// K + L pairs instead of K·L.
#include <algorithm>
#include <numeric>

#include "duolod/lod.hpp"

namespace duolod::lod {
namespace {

// Algorithm 2's tolerance: a pair costing `cost` is kept beside the cheapest, `best`, when
// (t_n − t_0)/t_0 < T, written without the division so a zero cost cannot divide.
bool nearCheapest(double cost, double best, double time_tolerance) {
  return cost == best || cost - best < time_tolerance * best;
}

// Lines 15–23 of Algorithm 2: sort the feasible pairs by cost and keep those within T of the
// cheapest.
std::vector<EvaluatedPair> optimalPairs(const std::vector<EvaluatedPair>& visited,
                                        double time_tolerance) {
  std::vector<EvaluatedPair> feasible;
  for (const EvaluatedPair& pair : visited)
    if (pair.within_bound) feasible.push_back(pair);
  std::stable_sort(feasible.begin(), feasible.end(),
                   [](const EvaluatedPair& a, const EvaluatedPair& b) { return a.cost < b.cost; });
  if (feasible.empty()) return feasible;
  const double best = feasible.front().cost;
  std::vector<EvaluatedPair> optimal;
  for (const EvaluatedPair& pair : feasible)
    if (nearCheapest(pair.cost, best, time_tolerance)) optimal.push_back(pair);
  return optimal;
}

// PairSearchOptions::on_discarded: a visited pair is discarded once optimalPairs could no longer
// keep it. Out of the bound at once; a feasible one once its cost is not near the cheapest
// feasible cost so far (optimalPairs' test): the cheapest only falls, so it never comes near again.
class DiscardedPairs {
 public:
  explicit DiscardedPairs(const PairSearchOptions& options) : options_(options) {}
  void visited(const EvaluatedPair& pair) {
    if (!options_.on_discarded) return;
    if (!pair.within_bound) return options_.on_discarded(pair.mesh, pair.shader);
    if (kept_.empty() || pair.cost < best_) {
      best_ = pair.cost;
      std::erase_if(kept_, [&](const EvaluatedPair& old) {
        if (near(old.cost)) return false;
        options_.on_discarded(old.mesh, old.shader);
        return true;
      });
    }
    if (near(pair.cost))
      kept_.push_back(pair);
    else
      options_.on_discarded(pair.mesh, pair.shader);
  }

 private:
  bool near(double cost) const { return nearCheapest(cost, best_, options_.time_tolerance); }
  const PairSearchOptions& options_;
  std::vector<EvaluatedPair> kept_;  // feasible and near the cheapest so far
  double best_ = 0;
};

core::Status checkInputs(int mesh_count, std::span<const int> shader_order) {
  if (mesh_count < 1) return core::Error{"SearchPairs: no mesh candidates"};
  if (shader_order.empty()) return core::Error{"SearchPairs: no shader candidates"};
  return core::okStatus();
}

core::Result<EvaluatedPair> evaluatePair(const PairEvaluator& evaluate, int mesh, int shader_rank,
                                         std::span<const int> shader_order, double error_bound) {
  const int shader = shader_order[shader_rank];
  auto evaluation = evaluate(mesh, shader);
  if (!evaluation)
    return core::Error{"SearchPairs: evaluating mesh " + std::to_string(mesh) + " with shader " +
                       std::to_string(shader) + ": " + evaluation.error().message};
  return EvaluatedPair{.mesh = mesh,
                       .shader = shader,
                       .shader_rank = shader_rank,
                       .error = evaluation->error,
                       .cost = evaluation->cost,
                       .within_bound = evaluation->error < error_bound};  // eq. (3)
}

}  // namespace

std::vector<int> sortByError(std::span<const double> error_on_original_mesh) {
  std::vector<int> order(error_on_original_mesh.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return error_on_original_mesh[a] < error_on_original_mesh[b];
  });
  return order;
}

core::Result<PairSearchResult> searchPairs(int mesh_count, std::span<const int> shader_order,
                                           const PairEvaluator& evaluate,
                                           const PairSearchOptions& options) {
  if (auto valid = checkInputs(mesh_count, shader_order); !valid) return valid.error();
  PairSearchResult result;
  DiscardedPairs discarded(options);
  // Lines 1–14. The paper's loop bound `j < size(L) − 1` would never try the last shader; every
  // shader is tried here.
  int mesh = mesh_count - 1;
  int rank = 0;
  const int shader_count = static_cast<int>(shader_order.size());
  auto visit = [&](int at_mesh) -> core::Result<bool> {
    auto pair = evaluatePair(evaluate, at_mesh, rank, shader_order, options.error_bound);
    if (!pair) return pair.error();
    ++result.evaluations;
    result.visited.push_back(*pair);
    discarded.visited(*pair);
    return pair->within_bound;
  };
  while (mesh >= 0 && rank < shader_count) {
    auto within = visit(mesh);
    if (!within) return within.error();
    if (*within) {
      ++rank;  // the next shader errs more: its boundary mesh is this one or a finer one
    } else if (!options.bisect_meshes || mesh == 0) {
      --mesh;
    } else {
      // The coarsest feasible mesh in [0, mesh) for this shader: probe M_0 first (if even the
      // original mesh fails, nothing finer exists and the linear walk would end too), then
      // bisect, keeping `good` feasible and `bad` infeasible.
      auto finest = visit(0);
      if (!finest) return finest.error();
      if (!*finest) break;
      int good = 0, bad = mesh;
      const bool sized = options.mesh_sizes.size() == size_t(mesh_count);
      auto closeEnough = [&] {
        return sized && options.mesh_sizes[good] - options.mesh_sizes[bad] <=
                            options.bisection_stop * options.mesh_sizes[good];
      };
      while (bad - good > 1 && !closeEnough()) {
        int middle = (good + bad) / 2;
        auto ok = visit(middle);
        if (!ok) return ok.error();
        (*ok ? good : bad) = middle;
      }
      mesh = good;
      ++rank;  // (good, rank) was visited and is feasible
    }
  }
  result.optimal = optimalPairs(result.visited, options.time_tolerance);
  return result;
}

core::Result<PairSearchResult> searchPairsBruteForce(int mesh_count,
                                                     std::span<const int> shader_order,
                                                     const PairEvaluator& evaluate,
                                                     const PairSearchOptions& options) {
  if (auto valid = checkInputs(mesh_count, shader_order); !valid) return valid.error();
  PairSearchResult result;
  DiscardedPairs discarded(options);
  for (int mesh = mesh_count - 1; mesh >= 0; --mesh)
    for (int rank = 0; rank < static_cast<int>(shader_order.size()); ++rank) {
      auto pair = evaluatePair(evaluate, mesh, rank, shader_order, options.error_bound);
      if (!pair) return pair.error();
      ++result.evaluations;
      result.visited.push_back(*pair);
      discarded.visited(*pair);
    }
  result.optimal = optimalPairs(result.visited, options.time_tolerance);
  return result;
}

}  // namespace duolod::lod
