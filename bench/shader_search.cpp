// Issue 4's GP "done means": on the procedural noise + Phong shader (the paper's Dragon shader,
// Sitthi-Amorn et al. 2011), the GP search (NSGA-II on predicted cost and error, §5.2) finds a
// Pareto frontier of at least 8 variants from the original to nearly constant, in which the
// cheapest variant within e_max = 0.1 (per-pixel error, eq. 4 at d_far) at a far distance is at
// least 2x cheaper than the original by MEASURED llvmpipe time. Prints the front (rules, predicted
// cost, measured time ratio, rendered error), the search time, and how many variants were
// generated, predicted, rendered and compiled.

#include <array>
#include <cmath>
#include <cstdio>

#include "duolod/io.hpp"
#include "duolod/render.hpp"
#include "shader/lod_search.hpp"
#include "support/options.hpp"

using namespace duolod;

namespace {

// What shader simplification can gain at each footprint: the measured draw time of the shader
// against the `constant` shader (the floor every variant's time approaches: the vertex and
// rasterisation work that no fragment rule removes), with the vertex and fragment invocations per
// view (pipeline statistics).
// "op 3, loop 1, per-vertex 1": how many sites of each rule a variant applies.
std::string ruleCounts(const std::vector<shader::RuleSite>& sites) {
  std::array<int, shader::kRuleKindCount> counts{};
  for (const shader::RuleSite& site : sites) ++counts[static_cast<size_t>(site.kind)];
  std::string text;
  for (int k = 0; k < shader::kRuleKindCount; ++k)
    if (counts[k] > 0)
      text += (text.empty() ? "" : ", ") + std::string(shader::ruleName(shader::RuleKind(k))) + " " +
              std::to_string(counts[k]);
  return text.empty() ? "original" : text;
}

int sweepFootprints(const core::Asset& asset, const render::GlslSource& source,
                    const std::vector<int>& footprints, int repeats) {
  auto renderer = render::Renderer::create();
  if (!renderer) return std::fprintf(stderr, "%s\n", renderer.error().message.c_str()), 1;
  render::Renderer& gl = **renderer;
  auto asset_id = gl.uploadAsset(asset);
  auto constant = render::loadShaderPair("constant");
  if (!asset_id || !constant) return std::fprintf(stderr, "cannot upload or load\n"), 1;
  auto shader = gl.compileProgram(source);
  auto floor_program = gl.compileProgram(*constant);
  if (!shader || !floor_program) return std::fprintf(stderr, "cannot compile\n"), 1;
  core::Sphere sphere = core::computeBoundingSphere(asset.mesh);
  std::printf("| footprint px | vertex inv./view | fragment inv./view | shader ms/view | constant ms/view | best ratio |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|\n");
  for (int footprint : footprints) {
    float distance = render::distanceForDiameterPixels(sphere, footprint, render::Display{});
    std::vector<render::Sample> samples = render::domainSamples(sphere, distance);
    render::RenderStats stats;
    render::RenderOptions options{.resolution = footprint, .count_work = true};
    if (auto image = gl.render(*asset_id, *shader, samples, options, &stats); !image)
      return std::fprintf(stderr, "%s\n", image.error().message.c_str()), 1;
    std::vector<render::Renderer::ProgramId> programs = {*shader, *floor_program};
    render::TimingOptions timing{.resolution = footprint, .repeats = repeats};
    auto times = gl.measureDrawTimes(*asset_id, programs, samples, timing);
    if (!times) return std::fprintf(stderr, "%s\n", times.error().message.c_str()), 1;
    double views = static_cast<double>(samples.size());
    std::printf("| %d | %.0f | %.0f | %.3f | %.3f | %.3f |\n", footprint,
                double(stats.work.vertex_invocations) / views,
                double(stats.work.fragment_invocations) / views, (*times)[0].seconds / views * 1e3,
                (*times)[1].seconds / views * 1e3, (*times)[1].seconds / (*times)[0].seconds);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{
      "duolod shader search benchmark: GP Pareto front of noise_phong at a far distance"};
  std::string asset_path = std::string(DUOLOD_ASSET_DIR) + "/obj/spot/spot.obj";
  std::string shader = "noise_phong";
  std::string method = "gp";
  int footprint_px = 64;
  int generations = 20, population = 24;
  uint64_t seed = 1;
  double e_max = 0.1;
  std::vector<int> sweep;
  int repeats = 7;
  app.add("--asset", asset_path);
  app.add("--shader", shader);
  app.add("--search", method, "gp or greedy");
  app.add("--footprint", footprint_px, "pixels across the object: the far distance");
  app.add("--generations", generations);
  app.add("--population", population);
  app.add("--seed", seed);
  app.add("--e-max", e_max, "per-pixel error bound at d_far (metric::BoundConfig)");
  app.add("--sweep", sweep,
          "instead of a search: time the shader against the constant shader at these "
          "footprints (what any variant can gain there)");
  app.add("--repeats", repeats, "timing repeats (median)");
  bool uniform_sites = false;
  app.flag("--uniform-sites", uniform_sites,
           "GP mutations draw sites uniformly (default: a rule kind first, then a site)");
  bool no_seeds = false, no_parameters = false;
  app.flag("--no-seeds", no_seeds,
           "GP starts from the original's one-site mutants only (no aggressive seed genomes)");
  app.flag("--no-move-to-parameter", no_parameters,
           "do not offer moving to parameter (no instrumented averaging renders)");
  double burst = 0.1;
  app.add("--burst", burst, "probability that an append mutation adds a burst of sites");
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;

  auto asset = io::loadAsset(asset_path);
  if (!asset) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 1;
  auto source = render::loadShaderPair(shader);
  if (!source) return std::fprintf(stderr, "%s\n", source.error().message.c_str()), 1;

  if (!sweep.empty()) return sweepFootprints(*asset, *source, sweep, repeats);

  shader::ShaderLodOptions options;
  options.distance = render::distanceForDiameterPixels(core::computeBoundingSphere(asset->mesh),
                                                       footprint_px, options.display);
  options.timing.repeats = repeats;
  options.method = method == "greedy" ? shader::SearchMethod::kGreedy : shader::SearchMethod::kGenetic;
  options.genetic.generations = generations;
  options.genetic.population_size = population;
  options.genetic.seed = seed;
  options.genetic.balance_rule_kinds = !uniform_sites;
  options.genetic.seed_aggressive_genomes = !no_seeds;
  options.genetic.append_burst_probability = burst;
  options.move_to_parameter = !no_parameters;
  options.genetic.on_generation = [](int generation, const shader::SearchCounters& counters) {
    std::fprintf(stderr, "generation %d: %d predicted, %d genomes\n", generation,
                 counters.variants_predicted, counters.genomes_evaluated);
  };
  auto report = shader::runShaderLod(*asset, *source, options);
  if (!report) return std::fprintf(stderr, "%s\n", report.error().message.c_str()), 1;

  std::printf("asset %s (%zu triangles), shader %s, %s search (population %d, %d generations, "
              "seed %llu)\n",
              asset_path.c_str(), asset->mesh.triangleCount(), shader.c_str(), method.c_str(),
              population, generations, static_cast<unsigned long long>(seed));
  std::printf("distance %.3g (footprint %d px, %d samples), device %s\n\n", options.distance,
              report->footprint_px, report->domain_samples, report->device.c_str());
  std::printf("| level | rules | predicted ms/view | predicted error/px | rendered error/px | measured time ratio |\n");
  std::printf("|---:|---|---:|---:|---:|---:|\n");
  int cheapest_within = -1;
  for (size_t k = 0; k < report->variants.size(); ++k) {
    const shader::ShaderLodVariant& v = report->variants[k];
    std::printf("| %zu | %s | %.4g | %.4g | %.4g | %.3f |\n", k, ruleCounts(v.search.sites).c_str(),
                v.search.predicted_cost * 1e3, v.search.predicted_error,
                v.search.rendered_error.value_or(-1), v.time_ratio);
    // Levels run by decreasing predicted cost; the cheapest within the bound by measured time.
    if (v.search.rendered_error.value_or(1e30) <= e_max &&
        (cheapest_within < 0 || v.time_ratio < report->variants[cheapest_within].time_ratio))
      cheapest_within = static_cast<int>(k);
  }
  const shader::SearchCounters& c = report->search;
  const shader::ShaderLodVariant& cheapest = report->variants.back();
  std::printf("\nfront: %zu variants (target >= 8): %s\n", report->variants.size(),
              report->variants.size() >= 8 ? "yes" : "NO");
  std::printf("cheapest level: %zu rules, predicted cost %.3g of the original's, time ratio %.3f, "
              "rendered error %.4g/px\n",
              cheapest.search.sites.size(),
              cheapest.search.predicted_cost / report->variants.front().search.predicted_cost,
              cheapest.time_ratio, cheapest.search.rendered_error.value_or(-1));
  if (cheapest_within >= 0) {
    const shader::ShaderLodVariant& v = report->variants[cheapest_within];
    std::printf("cheapest within e_max = %g: level %d, %zu rules, rendered error %.4g/px, measured "
                "time ratio %.3f = %.2fx faster (target >= 2x): %s\n",
                e_max, cheapest_within, v.search.sites.size(), v.search.rendered_error.value_or(-1),
                v.time_ratio, v.time_ratio > 0 ? 1 / v.time_ratio : 0.0,
                v.time_ratio > 0 && v.time_ratio <= 0.5 ? "yes" : "NO");
    std::printf("  its rules: %s\n", shader::describeSites(v.search.sites).c_str());
  }
  std::printf("variants: %d generated, %d predicted (%d cache hits, %d rejected), %d rendered, "
              "%d compiled, %d cost profiles, %d averaging renders, %d genomes\n",
              c.variants_generated, c.variants_predicted, c.score_cache_hits, c.score_failures,
              c.variants_rendered, report->compile.programs_compiled, report->cost_profiles,
              report->average_renders,
              c.genomes_evaluated);
  std::printf("seconds: search %.1f, re-render %.1f, timing %.1f, total %.1f\n", report->search_seconds,
              report->rerender_seconds, report->timing_seconds, report->total_seconds);
  std::printf("throughput: %.2f variants predicted/s, %.2f rendered/s\n",
              report->search_seconds > 0 ? c.variants_predicted / report->search_seconds : 0.0,
              report->rerender_seconds > 0 ? c.variants_rendered / report->rerender_seconds : 0.0);
  // The floor "nearly constant" is measured against: the constant shader at this footprint.
  std::printf("\nthe constant shader at this footprint (a separate timing):\n");
  return sweepFootprints(*asset, *source, {footprint_px}, repeats);
}
