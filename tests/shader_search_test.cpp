// GP (NSGA-II) and greedy searches over the real rules on a small hand-written shader, with a
// deterministic stand-in scorer (cost: instructions left in the fragment stage; error: rules
// applied), so fronts, determinism, caching and invalid genomes can be checked exactly without a
// GPU. The scorer the CLI uses (evaluator + cost model) is exercised by tests/cli_shader_test.cpp.
#include <gtest/gtest.h>

#include <set>

#include "duolod/shader.hpp"
#include "shader/search.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

constexpr const char* kVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec3 vPosition;
void main() { vPosition = inPosition; gl_Position = vec4(inPosition, 1.0); }
)";

// A few independent operations whose removal saves different amounts.
constexpr const char* kFragment = R"(#version 450 core
layout(location = 0) in vec3 vPosition;
layout(location = 0) out vec4 outColor;
void main() {
  float wave = sin(vPosition.x * 7.0) * cos(vPosition.y * 5.0);
  float ramp = vPosition.z * 0.5 + 0.25;
  vec3 tint = vec3(0.2, 0.4, 0.6) * (ramp + wave);
  outColor = vec4(tint + 0.1 * vPosition, 1.0);
}
)";

// kVertex with `fragment_source`, parsed.
ShaderProgram programWith(const char* fragment_source, const char* fragment_name) {
  auto vertex = compileToSpirv(kVertex, Stage::kVertex, "small.vert");
  auto fragment = compileToSpirv(fragment_source, Stage::kFragment, fragment_name);
  EXPECT_TRUE(vertex && fragment);
  auto program = parseProgram(*vertex, *fragment);
  EXPECT_TRUE(program) << program.error().message;
  return *program;
}

ShaderProgram smallProgram() { return programWith(kFragment, "small.frag"); }

double instructionCount(const ir::Module& module) {
  double count = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks) count += static_cast<double>(block.instructions.size());
  return count;
}

RuleContext operationRemovalOnly() {
  RuleContext context;
  context.enabled = {true, false, false, false, false, false};
  return context;
}

VariantScorer countingScorer(int* scored = nullptr) {
  VariantScorer scorer;
  scorer.predicted_cost = [scored](const ShaderProgram& program) -> core::Result<double> {
    if (scored) ++*scored;
    return instructionCount(program.fragment);
  };
  scorer.predicted_error = [](const ShaderProgram& program) -> core::Result<double> {
    return 0.1 * static_cast<double>(program.history.size());
  };
  scorer.rendered_error = [](const ShaderProgram& program) -> core::Result<double> {
    return 0.1 * static_cast<double>(program.history.size()) + 0.01;
  };
  return scorer;
}

GeneticSearchOptions smallGp(uint64_t seed) {
  GeneticSearchOptions options;
  options.population_size = 10;
  options.generations = 6;
  options.seed = seed;
  return options;
}

TEST(ShaderSearchTest, GeneticFrontIsNondominatedSortedAndStartsFromTheOriginal) {
  SearchCache cache(smallProgram(), operationRemovalOnly(), countingScorer());
  auto result = searchGenetic(cache, smallGp(7));
  ASSERT_TRUE(result) << result.error().message;
  const auto& front = result->variants;
  ASSERT_GE(front.size(), 3u);
  for (size_t i = 0; i < front.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(front[i].predicted_cost, front[i - 1].predicted_cost);  // by increasing cost...
      EXPECT_LT(front[i].predicted_error, front[i - 1].predicted_error);  // ...so falling error
    }
    EXPECT_EQ(front[i].program->history.size(), front[i].sites.size());
  }
  // The original (no rule, error 0) is the most expensive point of the front.
  EXPECT_TRUE(front.back().sites.empty());
  EXPECT_EQ(front.back().predicted_error, 0.0);
  EXPECT_EQ(describeSites(front.back().sites), "original");
  EXPECT_TRUE(test::contains(describeSites(front.front().sites), "operation removal"));
  // Every front program is valid SPIR-V.
  for (const SearchVariant& variant : front) {
    auto words = emitProgram(*variant.program, false);
    EXPECT_TRUE(words) << describeSites(variant.sites) << ": " << words.error().message;
  }
  // Counters: many genomes, fewer distinct programs (the score cache answered the rest).
  const SearchCounters& counters = result->counters;
  EXPECT_GT(counters.genomes_evaluated, counters.variants_predicted);
  EXPECT_GT(counters.score_cache_hits, 0);
  EXPECT_LE(counters.variants_predicted, counters.variants_generated + 1);  // + the original
  EXPECT_EQ(counters.variants_rendered, 0);

  ASSERT_TRUE(renderFront(cache, result->variants));
  // The rendered error is the front program's own (the stand-in scorer reads the history, which
  // the program hash leaves out, so a predicted score may come from another genome giving the
  // same program).
  for (const SearchVariant& variant : result->variants)
    EXPECT_DOUBLE_EQ(*variant.rendered_error,
                     0.1 * static_cast<double>(variant.program->history.size()) + 0.01);
  EXPECT_EQ(cache.counters().variants_rendered, static_cast<int>(result->variants.size()));
}

TEST(ShaderSearchTest, GeneticSearchIsDeterministicAndTheCacheMakesARerunFree) {
  int scored = 0;
  SearchCache cache(smallProgram(), operationRemovalOnly(), countingScorer(&scored));
  auto first = searchGenetic(cache, smallGp(3));
  ASSERT_TRUE(first) << first.error().message;
  int scored_once = scored;
  auto rerun = searchGenetic(cache, smallGp(3));
  ASSERT_TRUE(rerun);
  EXPECT_EQ(scored, scored_once);  // same genomes: every score came from the cache

  SearchCache fresh(smallProgram(), operationRemovalOnly(), countingScorer());
  auto again = searchGenetic(fresh, smallGp(3));
  ASSERT_TRUE(again);
  ASSERT_EQ(again->variants.size(), first->variants.size());
  for (size_t i = 0; i < first->variants.size(); ++i) {
    EXPECT_EQ(again->variants[i].sites, first->variants[i].sites);
    EXPECT_EQ(again->variants[i].predicted_cost, first->variants[i].predicted_cost);
  }
}

TEST(ShaderSearchTest, VariantsTheScorerRejectsNeverReachTheFront) {
  VariantScorer scorer = countingScorer();
  auto cost = scorer.predicted_cost;
  // Rejected by a property of the program itself (scores are cached by program, and different
  // site lists can give the same program once dead code is removed).
  auto rejected = [](const ShaderProgram& program) {
    return static_cast<int>(instructionCount(program.fragment)) % 3 == 0;
  };
  scorer.predicted_cost = [cost, rejected](const ShaderProgram& program) -> core::Result<double> {
    if (rejected(program)) return core::Error{"pretend this variant failed to compile"};
    return cost(program);
  };
  SearchCache cache(smallProgram(), operationRemovalOnly(), scorer);
  auto result = searchGenetic(cache, smallGp(11));
  ASSERT_TRUE(result) << result.error().message;
  EXPECT_GT(result->counters.score_failures, 0);
  for (const SearchVariant& variant : result->variants) EXPECT_FALSE(rejected(*variant.program));
}

TEST(ShaderSearchTest, GreedyTakesTheBestErrorPerCostStepByStep) {
  SearchCache cache(smallProgram(), operationRemovalOnly(), countingScorer());
  GreedySearchOptions options;
  options.max_steps = 2;
  auto result = searchGreedy(cache, options);
  ASSERT_TRUE(result) << result.error().message;
  ASSERT_EQ(result->variants.size(), 3u);  // the original + 2 steps
  EXPECT_TRUE(result->variants[0].sites.empty());
  for (size_t step = 1; step < result->variants.size(); ++step) {
    const SearchVariant& variant = result->variants[step];
    EXPECT_EQ(variant.sites.size(), step);
    EXPECT_LT(variant.predicted_cost, result->variants[step - 1].predicted_cost);
    // With every step costing the same error (0.1), the best ratio is the largest saving: no
    // single-site candidate from the previous program saves more.
    auto previous = cache.materialise(result->variants[step - 1].sites);
    ASSERT_TRUE(previous);
    for (const RuleSite& site : enumerateSites(**previous, cache.context())) {
      std::vector<RuleSite> other = result->variants[step - 1].sites;
      other.push_back(site);
      auto program = cache.materialise(other);
      if (!program) continue;
      EXPECT_GE((*program)->fragment.functions.empty() ? 0 : instructionCount((*program)->fragment),
                variant.predicted_cost);
    }
  }
}

// A loop with a constant trip count and a function whose result is a big subexpression: what the
// aggressive seeds look for.
constexpr const char* kLoopFragment = R"(#version 450 core
layout(location = 0) in vec3 vPosition;
layout(location = 0) out vec4 outColor;
float waves(vec3 p) {
  float sum = 0.0;
  for (int i = 0; i < 4; ++i) sum += sin(p.x * float(i + 1)) * cos(p.y * float(i + 2));
  return sum;
}
void main() {
  float pattern = waves(vPosition * 3.0);
  vec3 tint = vec3(0.2, 0.4, 0.6) * (pattern * 0.5 + vPosition.z);
  outColor = vec4(tint + 0.1 * vPosition, 1.0);
}
)";

// Every rule but textures, with a stand-in averager (any value of the right size).
RuleContext allRulesWithAverages() {
  RuleContext context;
  context.average_value = [](const ShaderProgram& of, Stage, ir::Id value) {
    ir::DefUse uses(of.fragment);
    return core::Result<std::vector<float>>(
        std::vector<float>(ir::componentCount(uses, uses.def(value)->type_id), 0.5f));
  };
  return context;
}

ShaderProgram loopProgram() { return programWith(kLoopFragment, "loop.frag"); }

TEST(ShaderSearchTest, AggressiveSeedsAreTheOutputParameterTheShortestLoopsAndFunctionResults) {
  ShaderProgram program = loopProgram();
  RuleContext context = allRulesWithAverages();
  std::vector<RuleSite> sites = enumerateSites(program, context);
  std::vector<std::vector<RuleSite>> seeds = aggressiveSeedGenomes(program, sites, 10);
  ASSERT_EQ(seeds.size(), 3u);
  // The colour output moved to a parameter: the fragment stage is then nearly empty.
  ASSERT_EQ(seeds[0].size(), 1u);
  EXPECT_EQ(seeds[0][0].kind, RuleKind::kMoveToParameter);
  auto constant = applyRule(program, seeds[0][0], context);
  ASSERT_TRUE(constant) << constant.error().message;
  EXPECT_LT(instructionCount(constant->fragment), 12.0);
  EXPECT_EQ(constant->parameters.size(), 1u);
  EXPECT_EQ(constant->parameters[0].components, 4);
  // The loop cut to one iteration.
  ASSERT_EQ(seeds[1].size(), 1u);
  EXPECT_EQ(seeds[1][0].kind, RuleKind::kLoopTruncation);
  EXPECT_EQ(seeds[1][0].choice, 1u);
  // waves()'s result moved to a parameter.
  ASSERT_EQ(seeds[2].size(), 1u);
  EXPECT_EQ(seeds[2][0].kind, RuleKind::kMoveToParameter);
  EXPECT_TRUE(test::contains(seeds[2][0].description, "pattern")) << seeds[2][0].description;
  // The cut keeps the structurally different ones first.
  EXPECT_EQ(aggressiveSeedGenomes(program, sites, 2).size(), 2u);
  // Without an averager there is no parameter seed.
  RuleContext no_averages;
  std::vector<std::vector<RuleSite>> loops_only =
      aggressiveSeedGenomes(program, enumerateSites(program, no_averages), 10);
  ASSERT_EQ(loops_only.size(), 1u);
  EXPECT_EQ(loops_only[0][0].kind, RuleKind::kLoopTruncation);
}

TEST(ShaderSearchTest, SeededGeneticFrontReachesNearlyConstantInOneGeneration) {
  GeneticSearchOptions options = smallGp(5);
  options.generations = 1;
  options.population_size = 8;
  SearchCache cache(loopProgram(), allRulesWithAverages(), countingScorer());
  auto result = searchGenetic(cache, options);
  ASSERT_TRUE(result) << result.error().message;
  ASSERT_FALSE(result->variants.empty());
  // The cheapest point is the colour output as a parameter (one rule: also the least error of
  // anything that cheap under the counting scorer), and the original is on the front too.
  const SearchVariant& cheapest = result->variants.front();
  ASSERT_EQ(cheapest.sites.size(), 1u);
  EXPECT_EQ(cheapest.sites[0].kind, RuleKind::kMoveToParameter);
  EXPECT_LT(cheapest.predicted_cost, 12.0);
  EXPECT_TRUE(result->variants.back().sites.empty());
  // Seeds take places of the initial random mutants: no extra evaluations.
  options.seed_aggressive_genomes = false;
  SearchCache unseeded(loopProgram(), allRulesWithAverages(), countingScorer());
  auto plain = searchGenetic(unseeded, options);
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->counters.genomes_evaluated, result->counters.genomes_evaluated);
}

}  // namespace
}  // namespace duolod::shader
