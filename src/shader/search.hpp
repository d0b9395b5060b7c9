// Searches over shader simplification rules (Liang et al. §5.2; issue 4 item 6), private to
// src/shader:
//
//  * Genetic programming with NSGA-II selection (Sitthi-Amorn, Modly, Weimer, Lawrence 2011,
//    "Genetic Programming for Shader Simplification"; Deb et al. 2002). A genome is the ordered list
//    of RuleSites applied to the original program. Mutation appends sites drawn from
//    enumerateSites() of the genome's program, removes one, or replaces one by a site of the
//    program before it; crossover joins a prefix of one parent to a suffix of the other. A genome
//    whose sites no longer apply (a rule removed what a later site names) is invalid and dropped.
//    The two objectives are the predicted cost and the predicted error; the result is the Pareto
//    frontier of (cost, error) for the (mesh, distance) configuration the scorer stands for.
//
//  * He et al. 2015's greedy simplification: from the original, repeatedly apply the single rule
//    with the smallest predicted error increase per unit of predicted cost saved, recording the
//    sequence (each step is a level).
//
// Both materialise genomes through a prefix cache (a genome extending a known one costs one
// applyRule) and score each distinct program once (by a hash of its SPIR-V and parameters); the
// scorer's own caches (compiled programs, errors by module hash: shader/evaluate.hpp) are shared by
// both searches and by the final re-evaluation. Everything is seeded and deterministic for a
// deterministic scorer.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "duolod/core.hpp"
#include "shader/rules.hpp"

namespace duolod::shader {

// What the searches optimise, for one (mesh, distance) configuration. Errors from a callback make
// the variant invalid (dropped), they do not stop the search.
struct VariantScorer {
  std::function<core::Result<double>(const ShaderProgram&)> predicted_cost;
  std::function<core::Result<double>(const ShaderProgram&)> predicted_error;
  // For the final front only: eq. (6) over the whole domain (optional).
  std::function<core::Result<double>(const ShaderProgram&)> rendered_error;
  // Optional: the programs about to be scored, in order (the GP announces each generation's
  // new offspring), e.g. to compile them ahead on another thread. Must not change any score.
  std::function<void(std::span<const std::shared_ptr<const ShaderProgram>>)> prepare;
};

// A hash of the program's emitted words and CPU-set parameters: identifies a variant.
uint64_t programHash(const ShaderProgram& program);

struct SearchVariant {
  std::vector<RuleSite> sites;  // applied to the original, in order
  std::shared_ptr<const ShaderProgram> program;
  double predicted_cost = 0;
  double predicted_error = 0;
  std::optional<double> rendered_error;  // filled by the final re-evaluation
};

struct SearchCounters {
  int variants_generated = 0;  // distinct programs materialised (applyRule successes)
  int rule_failures = 0;       // applyRule calls that failed (the genome was dropped)
  int variants_predicted = 0;  // distinct programs scored with the predicted cost and error
  int score_failures = 0;      // distinct programs the scorer rejected (e.g. failed to compile)
  int score_cache_hits = 0;    // genomes whose program was already scored
  int variants_rendered = 0;   // rendered errors computed (final re-evaluation)
  int genomes_evaluated = 0;   // NSGA-II evaluations (GP only)
  double seconds = 0;
};

struct SearchResult {
  // GP: the valid first front, by increasing predicted cost (the original included when it is
  // on it). Greedy: the original, then one variant per step.
  std::vector<SearchVariant> variants;
  SearchCounters counters;
};

struct GeneticSearchOptions {
  int population_size = 24;
  int generations = 20;
  double crossover_probability = 0.5;
  uint64_t seed = 1;
  // Mutation: append sites (1 + a geometric number, mean about 1 + append_extra_mean) with
  // probability append_probability, else remove one or replace one, equally likely.
  double append_probability = 0.6;
  double append_extra_mean = 1.0;
  int max_genome_length = 200;
  // How a mutation draws a new site: false = uniformly over all sites; true = a rule kind
  // uniformly among the kinds with sites, then a site of that kind. Operation removal offers ~80%
  // of noise_phong's ~570 sites, so uniform draws almost never try the 3 loop truncations or the
  // per-vertex moves that save the most (bench/RESULTS.md, issue 4 search).
  bool balance_rule_kinds = true;
  // Errors above this (predicted) make a variant invalid: the search spends no time beyond the
  // useful range (the paper's e_max bounds the levels anyway). Infinity keeps everything.
  // A finite cap cuts the cheap end of the front (nearly constant variants err most): keep it
  // infinite when the front must span from the original to nearly constant, and cap the levels
  // by e_max afterwards.
  double max_error = 1e30;
  // Seed the initial population with a few aggressive genomes (aggressiveSeedGenomes: the colour
  // output and each function result moved to a parameter, every loop cut to its fewest
  // iterations, every texture replaced by its average) instead of random one-site mutants of the
  // original: mutations one site at a time would need many generations to walk from the original
  // to the cheap end (bench/RESULTS.md, issue 4 search). At most half the population; the
  // population size, hence the number of evaluations, is unchanged.
  bool seed_aggressive_genomes = true;
  // Mutation: with this probability an append adds a burst of sites instead (up to
  // append_burst_max, uniform), so one child can jump far down in cost.
  double append_burst_probability = 0.1;
  int append_burst_max = 16;
  // Called after each generation with the generation (1-based) and the counters so far.
  std::function<void(int, const SearchCounters&)> on_generation;
};

struct GreedySearchOptions {
  int max_steps = 64;
  // Candidates scored per step: all sites when <= 0, else this many drawn evenly over the sites
  // in enumerateSites() order (deterministic), keeping each step's cost bounded on big shaders.
  int max_candidates_per_step = 0;
  double max_error = 1e30;  // stop when every candidate's predicted error is above this
  std::function<void(int, const SearchCounters&)> on_step;
};

// The caches both searches share (materialised genomes and scores). One per (original, context,
// scorer configuration).
class SearchCache {
 public:
  SearchCache(ShaderProgram original, RuleContext context, VariantScorer scorer);
  ~SearchCache();

  const ShaderProgram& original() const;
  std::shared_ptr<const ShaderProgram> sharedOriginal() const;
  const RuleContext& context() const;
  // The program of `sites` applied to the original, or an error when a site does not apply.
  core::Result<std::shared_ptr<const ShaderProgram>> materialise(const std::vector<RuleSite>& sites);
  // enumerateSites(program, context()), kept by program: the GP draws sites on the same parents
  // and prefixes again and again.
  const std::vector<RuleSite>& sitesOf(const ShaderProgram& program);
  // Materialises the genomes and tells the scorer (VariantScorer::prepare) which of their
  // programs it will be asked to score, in order.
  void prepare(std::span<const std::vector<RuleSite>> genomes);
  struct Score {
    double cost = 0, error = 0;
  };
  core::Result<Score> score(const ShaderProgram& program);
  core::Result<double> renderedError(const ShaderProgram& program);
  SearchCounters& counters();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The aggressive seed genomes of GeneticSearchOptions::seed_aggressive_genomes for `program`
// (usually the original), from its sites: (1) the value stored to the fragment colour output
// moved to a parameter ("nearly constant"), (2) each fragment function result moved to a
// parameter (a programmer's big subexpressions: fbm(), a tone curve), by decreasing backward-slice
// size, (3) every loop with a constant trip count cut to its fewest iterations, (4) every texture
// sample replaced by the texture's average (Olano). Only genomes whose sites exist; at most
// `max_count`, in that order.
std::vector<std::vector<RuleSite>> aggressiveSeedGenomes(const ShaderProgram& program,
                                                         const std::vector<RuleSite>& sites,
                                                         size_t max_count);

core::Result<SearchResult> searchGenetic(SearchCache& cache, const GeneticSearchOptions& options);
core::Result<SearchResult> searchGreedy(SearchCache& cache, const GreedySearchOptions& options);

// Fills rendered_error of every variant with the scorer's rendered error (cached by program).
core::Status renderFront(SearchCache& cache, std::vector<SearchVariant>& variants);

// The sites of a variant in words: "operation removal: ...; texture average: ..." or "original".
std::string describeSites(const std::vector<RuleSite>& sites);

}  // namespace duolod::shader
