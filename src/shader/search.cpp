// GP (NSGA-II) and greedy searches over shader simplification rules (see search.hpp).
#include "shader/search.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "core/clock.hpp"
#include "shader/nsga2.hpp"

namespace duolod::shader {
namespace {

using Genome = std::vector<RuleSite>;

// A genome's identity: every site's (kind, stage, target, choice).
std::vector<uint32_t> genomeKey(const Genome& genome, size_t length) {
  std::vector<uint32_t> key;
  key.reserve(length * 4);
  for (size_t i = 0; i < length; ++i) {
    const RuleSite& site = genome[i];
    key.insert(key.end(), {static_cast<uint32_t>(site.kind), static_cast<uint32_t>(site.stage),
                           site.target, site.choice});
  }
  return key;
}

struct KeyHash {
  size_t operator()(const std::vector<uint32_t>& key) const {
    return static_cast<size_t>(core::hashBytes(key.data(), key.size() * sizeof(uint32_t)));
  }
};

using core::internal::secondsSince;

// Materialised genomes are whole programs (both modules): past this many the prefix cache starts
// afresh, bounding memory on long searches (a re-materialisation costs a few applyRule calls).
constexpr size_t kMaxCachedPrograms = 3000;

}  // namespace

uint64_t programHash(const ShaderProgram& program) {
  std::vector<uint32_t> vertex = ir::emitModule(program.vertex);
  std::vector<uint32_t> fragment = ir::emitModule(program.fragment);
  uint64_t hash = core::hashBytes(vertex.data(), vertex.size() * sizeof(uint32_t));
  hash = core::hashBytes(fragment.data(), fragment.size() * sizeof(uint32_t), hash ^ vertex.size());
  for (const ParameterValue& parameter : program.parameters) {
    hash = core::hashBytes(&parameter.location, sizeof parameter.location, hash);
    hash = core::hashBytes(&parameter.components, sizeof parameter.components, hash);
    hash = core::hashBytes(parameter.value.data(), sizeof(float) * parameter.value.size(), hash);
  }
  return hash;
}

struct SearchCache::State {
  std::shared_ptr<const ShaderProgram> original;
  RuleContext context;
  VariantScorer scorer;
  std::unordered_map<std::vector<uint32_t>, core::Result<std::shared_ptr<const ShaderProgram>>, KeyHash>
      programs;
  std::unordered_map<uint64_t, core::Result<Score>> scores;
  std::unordered_map<uint64_t, core::Result<double>> rendered;
  std::unordered_map<uint64_t, bool> generated;  // program hashes materialised so far
  std::unordered_map<uint64_t, std::vector<RuleSite>> sites;  // enumerateSites by program hash
  SearchCounters counters;
};

SearchCache::SearchCache(ShaderProgram original, RuleContext context, VariantScorer scorer)
    : state_(std::make_unique<State>()) {
  state_->original = std::make_shared<const ShaderProgram>(std::move(original));
  state_->context = std::move(context);
  state_->scorer = std::move(scorer);
}
SearchCache::~SearchCache() = default;

const ShaderProgram& SearchCache::original() const { return *state_->original; }
std::shared_ptr<const ShaderProgram> SearchCache::sharedOriginal() const { return state_->original; }
const RuleContext& SearchCache::context() const { return state_->context; }
SearchCounters& SearchCache::counters() { return state_->counters; }

const std::vector<RuleSite>& SearchCache::sitesOf(const ShaderProgram& program) {
  State& s = *state_;
  if (s.sites.size() > kMaxCachedPrograms) s.sites.clear();  // bounded like the programs
  uint64_t hash = programHash(program);
  auto found = s.sites.find(hash);
  if (found == s.sites.end()) found = s.sites.emplace(hash, enumerateSites(program, s.context)).first;
  return found->second;
}

void SearchCache::prepare(std::span<const Genome> genomes) {
  State& s = *state_;
  if (!s.scorer.prepare) return;
  std::vector<std::shared_ptr<const ShaderProgram>> programs;
  std::unordered_set<uint64_t> announced;
  for (const Genome& genome : genomes) {
    auto program = materialise(genome);
    if (!program) continue;
    uint64_t hash = programHash(**program);
    if (!s.scores.contains(hash) && announced.insert(hash).second) programs.push_back(*program);
  }
  if (!programs.empty()) s.scorer.prepare(programs);
}

core::Result<std::shared_ptr<const ShaderProgram>> SearchCache::materialise(const Genome& sites) {
  State& s = *state_;
  // The longest known prefix, then one applyRule per further site, caching each prefix.
  size_t known = sites.size();
  std::shared_ptr<const ShaderProgram> program;
  for (;; --known) {
    if (known == 0) {
      program = s.original;
      break;
    }
    auto found = s.programs.find(genomeKey(sites, known));
    if (found != s.programs.end()) {
      if (!found->second) return found->second.error();
      program = *found->second;
      break;
    }
  }
  if (s.programs.size() > kMaxCachedPrograms) s.programs.clear();
  for (size_t length = known + 1; length <= sites.size(); ++length) {
    auto applied = applyRule(*program, sites[length - 1], s.context);
    std::vector<uint32_t> key = genomeKey(sites, length);
    if (!applied) {
      ++s.counters.rule_failures;
      s.programs.emplace(std::move(key), applied.error());
      return applied.error();
    }
    program = std::make_shared<const ShaderProgram>(std::move(*applied));
    if (s.generated.emplace(programHash(*program), true).second) ++s.counters.variants_generated;
    s.programs.emplace(std::move(key), program);
  }
  return program;
}

core::Result<SearchCache::Score> SearchCache::score(const ShaderProgram& program) {
  State& s = *state_;
  uint64_t hash = programHash(program);
  auto found = s.scores.find(hash);
  if (found != s.scores.end()) {
    ++s.counters.score_cache_hits;
    return found->second;
  }
  core::Result<Score> result = [&]() -> core::Result<Score> {
    auto cost = s.scorer.predicted_cost(program);
    if (!cost) return cost.error();
    auto error = s.scorer.predicted_error(program);
    if (!error) return error.error();
    return Score{*cost, *error};
  }();
  if (result) ++s.counters.variants_predicted;
  else ++s.counters.score_failures;
  s.scores.emplace(hash, result);
  return result;
}

core::Result<double> SearchCache::renderedError(const ShaderProgram& program) {
  State& s = *state_;
  if (!s.scorer.rendered_error) return core::Error{"search: the scorer has no rendered error"};
  uint64_t hash = programHash(program);
  auto found = s.rendered.find(hash);
  if (found != s.rendered.end()) return found->second;
  core::Result<double> result = s.scorer.rendered_error(program);
  if (result) ++s.counters.variants_rendered;
  s.rendered.emplace(hash, result);
  return result;
}

std::string describeSites(const Genome& sites) {
  if (sites.empty()) return "original";
  std::string text;
  for (const RuleSite& site : sites) {
    if (!text.empty()) text += "; ";
    text += std::string(ruleName(site.kind));
    if (!site.description.empty()) text += ": " + site.description;
  }
  return text;
}

// ---------------------------------------------------------------------------------------------
// Genetic programming.

namespace {

// Whether fragment value `value` is stored straight into an Output variable (the colour).
bool storedToOutput(const ir::DefUse& uses, ir::Id value) {
  for (const ir::InstructionRef& user : uses.users(value)) {
    const ir::Instruction& instruction = *user.instruction;
    if (instruction.opcode != spv::OpStore || instruction.operands.size() < 2 ||
        instruction.operands[1] != value)
      continue;
    const ir::Instruction* pointer = uses.def(instruction.operands[0]);
    if (pointer && pointer->opcode == spv::OpVariable &&
        ir::pointerStorageClass(uses, pointer->type_id) == spv::StorageClassOutput)
      return true;
  }
  return false;
}

}  // namespace

std::vector<Genome> aggressiveSeedGenomes(const ShaderProgram& program,
                                          const std::vector<RuleSite>& sites, size_t max_count) {
  ir::DefUse uses(program.fragment);
  Genome output, loops, textures;
  std::vector<std::pair<size_t, const RuleSite*>> results;  // (backward-slice size, site)
  std::map<ir::Id, const RuleSite*> shortest_loop;
  for (const RuleSite& site : sites) {
    if (site.kind == RuleKind::kMoveToParameter && site.stage == Stage::kFragment) {
      const ir::Instruction* definition = uses.def(site.target);
      if (output.empty() && storedToOutput(uses, site.target))
        output.push_back(site);
      else if (definition && definition->opcode == spv::OpFunctionCall)
        results.push_back(
            {ir::backwardSlice(program.fragment, uses, site.target).instructions.size(), &site});
    } else if (site.kind == RuleKind::kLoopTruncation) {
      const RuleSite*& kept = shortest_loop[site.target];
      if (!kept || site.choice < kept->choice) kept = &site;
    } else if (site.kind == RuleKind::kTextureAverage &&
               std::none_of(textures.begin(), textures.end(),
                            [&](const RuleSite& t) { return t.target == site.target; })) {
      textures.push_back(site);
    }
  }
  for (const RuleSite& site : sites)  // enumerateSites order: the genome is deterministic
    if (site.kind == RuleKind::kLoopTruncation && shortest_loop[site.target] == &site)
      loops.push_back(site);
  std::stable_sort(results.begin(), results.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  // The structurally different seeds first, so a small population still gets each kind.
  std::vector<Genome> seeds;
  for (Genome* genome : {&output, &loops, &textures})
    if (!genome->empty()) seeds.push_back(std::move(*genome));
  for (const auto& [size, site] : results) seeds.push_back({*site});
  if (seeds.size() > max_count) seeds.resize(max_count);
  return seeds;
}

core::Result<SearchResult> searchGenetic(SearchCache& cache, const GeneticSearchOptions& options) {
  auto start = std::chrono::steady_clock::now();
  if (options.population_size < 2) return core::Error{"GP search: the population needs at least 2"};
  if (options.generations < 0) return core::Error{"GP search: negative generation count"};

  // Every distinct valid program scored, with the shortest genome that made it: the archive the
  // final front is taken from (NSGA-II's last population alone can hold fewer front points than
  // the search has seen).
  struct ArchiveEntry {
    Genome genome;
    std::shared_ptr<const ShaderProgram> program;
    SearchCache::Score score;
  };
  std::map<uint64_t, ArchiveEntry> archive;

  auto sitesOf = [&](const Genome& genome, size_t length) -> std::vector<RuleSite> {
    auto program = cache.materialise(Genome(genome.begin(), genome.begin() + length));
    if (!program) return {};
    return cache.sitesOf(**program);
  };

  // One site of `sites` (not empty), by options.balance_rule_kinds.
  auto drawSite = [&](const std::vector<RuleSite>& sites, SearchRandom& random) -> const RuleSite& {
    if (!options.balance_rule_kinds) return sites[random.index(sites.size())];
    std::array<std::vector<size_t>, kRuleKindCount> by_kind;
    for (size_t i = 0; i < sites.size(); ++i) by_kind[static_cast<size_t>(sites[i].kind)].push_back(i);
    std::vector<const std::vector<size_t>*> present;
    for (const std::vector<size_t>& kind : by_kind)
      if (!kind.empty()) present.push_back(&kind);
    const std::vector<size_t>& kind = *present[random.index(present.size())];
    return sites[kind[random.index(kind.size())]];
  };

  Nsga2Problem<Genome> problem;
  problem.mutate = [&](const Genome& parent, SearchRandom& random) {
    Genome child = parent;
    double draw = random.uniform();
    double remove_below = options.append_probability + (1 - options.append_probability) / 2;
    if (child.empty() || draw < options.append_probability) {
      int count = 1;
      if (options.append_burst_max > 1 && random.chance(options.append_burst_probability)) {
        count = 2 + static_cast<int>(random.index(static_cast<size_t>(options.append_burst_max - 1)));
      } else {
        double extra = options.append_extra_mean / (1 + options.append_extra_mean);
        while (count < 8 && random.chance(extra)) ++count;
      }
      for (int i = 0; i < count && static_cast<int>(child.size()) < options.max_genome_length; ++i) {
        std::vector<RuleSite> sites = sitesOf(child, child.size());
        if (sites.empty()) break;
        child.push_back(drawSite(sites, random));
      }
    } else if (draw < remove_below) {
      child.erase(child.begin() + static_cast<long>(random.index(child.size())));
    } else {
      size_t position = random.index(child.size());
      std::vector<RuleSite> sites = sitesOf(child, position);
      if (!sites.empty()) child[position] = drawSite(sites, random);
    }
    return child;
  };
  problem.crossover = [](const Genome& first, const Genome& second, SearchRandom& random) {
    size_t cut_first = random.index(first.size() + 1), cut_second = random.index(second.size() + 1);
    Genome child(first.begin(), first.begin() + static_cast<long>(cut_first));
    child.insert(child.end(), second.begin() + static_cast<long>(cut_second), second.end());
    return child;
  };
  problem.evaluate = [&](const Genome& genome) -> std::optional<Objectives> {
    ++cache.counters().genomes_evaluated;
    auto program = cache.materialise(genome);
    if (!program) return std::nullopt;
    auto score = cache.score(**program);
    if (!score || !(score->error <= options.max_error)) return std::nullopt;
    uint64_t hash = programHash(**program);
    auto known = archive.find(hash);
    if (known == archive.end() || genome.size() < known->second.genome.size())
      archive[hash] = {genome, *program, *score};
    return Objectives{score->cost, score->error};
  };
  problem.prepare = [&](std::span<const Genome> genomes) { cache.prepare(genomes); };
  int generation_seen = 0;
  problem.on_generation = [&](int generation, std::span<const Objectives>) {
    generation_seen = generation;
    if (options.on_generation) options.on_generation(generation, cache.counters());
  };

  Nsga2Options nsga;
  nsga.population_size = options.population_size;
  nsga.generations = options.generations;
  nsga.crossover_probability = options.crossover_probability;
  nsga.seed = options.seed;
  std::vector<Genome> initial{Genome{}};
  if (options.seed_aggressive_genomes) {
    std::vector<Genome> seeds =
        aggressiveSeedGenomes(cache.original(), cache.sitesOf(cache.original()),
                              static_cast<size_t>(options.population_size / 2));
    initial.insert(initial.end(), seeds.begin(), seeds.end());
  }
  runNsga2<Genome>(std::move(initial), problem, nsga);
  (void)generation_seen;
  if (archive.empty()) return core::Error{"GP search: no valid variant (not even the original)"};

  // The archive's first front, by increasing cost (ties: lower error first).
  std::vector<const ArchiveEntry*> entries;
  std::vector<Objectives> points;
  for (const auto& [hash, entry] : archive) {
    entries.push_back(&entry);
    points.push_back({entry.score.cost, entry.score.error});
  }
  std::vector<std::vector<int>> fronts = nondominatedFronts(points);
  SearchResult result;
  for (int index : fronts.front()) {
    const ArchiveEntry& entry = *entries[index];
    result.variants.push_back({entry.genome, entry.program, entry.score.cost, entry.score.error, {}});
  }
  // By increasing cost; of programs with equal objectives the shortest genome stays (ties: the
  // archive's hash order, which is deterministic).
  std::stable_sort(result.variants.begin(), result.variants.end(), [](const auto& a, const auto& b) {
    if (a.predicted_cost != b.predicted_cost) return a.predicted_cost < b.predicted_cost;
    if (a.predicted_error != b.predicted_error) return a.predicted_error < b.predicted_error;
    return a.sites.size() < b.sites.size();
  });
  result.variants.erase(
      std::unique(result.variants.begin(), result.variants.end(),
                  [](const SearchVariant& a, const SearchVariant& b) {
                    return a.predicted_cost == b.predicted_cost && a.predicted_error == b.predicted_error;
                  }),
      result.variants.end());
  cache.counters().seconds += secondsSince(start);
  result.counters = cache.counters();
  return result;
}

// ---------------------------------------------------------------------------------------------
// He et al.'s greedy search.

core::Result<SearchResult> searchGreedy(SearchCache& cache, const GreedySearchOptions& options) {
  auto start = std::chrono::steady_clock::now();
  SearchResult result;
  Genome current;
  auto original_score = cache.score(cache.original());
  if (!original_score) return core::Error{"greedy search: the original: " + original_score.error().message};
  SearchCache::Score current_score = *original_score;
  result.variants.push_back({{},
                             cache.sharedOriginal(),
                             current_score.cost, current_score.error, {}});
  for (int step = 1; step <= options.max_steps; ++step) {
    auto program = cache.materialise(current);
    if (!program) return program.error();
    std::vector<RuleSite> sites = cache.sitesOf(**program);
    if (options.max_candidates_per_step > 0 &&
        sites.size() > static_cast<size_t>(options.max_candidates_per_step)) {
      std::vector<RuleSite> sampled;
      for (size_t i = 0; i < static_cast<size_t>(options.max_candidates_per_step); ++i)
        sampled.push_back(sites[i * sites.size() / options.max_candidates_per_step]);
      sites = std::move(sampled);
    }
    // The step's candidates are all known now: announce them (VariantScorer::prepare), so that
    // compile-ahead workers compile them on the other cores while this thread scores them in
    // order (each a compile of ~0.2 s on llvmpipe, most of a step's time).
    std::vector<Genome> candidates(sites.size(), current);
    for (size_t i = 0; i < sites.size(); ++i) candidates[i].push_back(sites[i]);
    cache.prepare(candidates);
    // The smallest error increase per cost saved; ties: the larger saving, then site order.
    std::optional<size_t> best;
    double best_ratio = std::numeric_limits<double>::infinity(), best_saving = 0;
    std::shared_ptr<const ShaderProgram> best_program;
    SearchCache::Score best_score;
    for (size_t i = 0; i < sites.size(); ++i) {
      auto candidate_program = cache.materialise(candidates[i]);
      if (!candidate_program) continue;
      auto score = cache.score(**candidate_program);
      if (!score || !(score->error <= options.max_error)) continue;
      double saving = current_score.cost - score->cost;
      if (!(saving > 0)) continue;
      double ratio = std::max(0.0, score->error - current_score.error) / saving;
      if (ratio < best_ratio || (ratio == best_ratio && saving > best_saving)) {
        best = i, best_ratio = ratio, best_saving = saving;
        best_program = *candidate_program;
        best_score = *score;
      }
    }
    if (!best) break;
    current.push_back(sites[*best]);
    current_score = best_score;
    result.variants.push_back({current, best_program, best_score.cost, best_score.error, {}});
    if (options.on_step) options.on_step(step, cache.counters());
  }
  cache.counters().seconds += secondsSince(start);
  result.counters = cache.counters();
  return result;
}

core::Status renderFront(SearchCache& cache, std::vector<SearchVariant>& variants) {
  for (SearchVariant& variant : variants) {
    auto error = cache.renderedError(*variant.program);
    if (!error) return core::Error{"rendering variant '" + describeSites(variant.sites) + "': " +
                                   error.error().message};
    variant.rendered_error = *error;
  }
  return core::okStatus();
}

}  // namespace duolod::shader
