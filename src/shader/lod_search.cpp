// Shader LOD for one (mesh, distance) configuration, end to end (see lod_search.hpp).
#include "shader/lod_search.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/clock.hpp"
#include "duolod/io.hpp"
#include "duolod/shader.hpp"
#include "shader/scoring.hpp"
#include "shader/shader_files.hpp"

namespace duolod::shader {
namespace {

namespace fs = std::filesystem;

using core::internal::secondsSince;

}  // namespace

core::Result<ShaderLodReport> runShaderLod(const core::Asset& asset, const render::GlslSource& source,
                                           const ShaderLodOptions& options) {
  const OptimizationMemoScope memo;  // released when the search ends
  auto start = std::chrono::steady_clock::now();
  if (!(options.distance > 0)) return core::Error{"shader LOD: the distance must be positive"};
  auto vertex_words = compileToSpirv(source.vertex, Stage::kVertex, source.vertex_name);
  if (!vertex_words) return vertex_words.error();
  auto fragment_words = compileToSpirv(source.fragment, Stage::kFragment, source.fragment_name);
  if (!fragment_words) return fragment_words.error();
  auto original = parseProgram(*vertex_words, *fragment_words);
  if (!original) return original.error();
  if (auto room = checkRoomForAutoLod(*original, source.vertex_name, source.fragment_name); !room)
    return room.error();

  render::ContextOptions gl_context{.device = options.device, .bindings = options.bindings};
  auto renderer = render::Renderer::create(gl_context);
  if (!renderer) return renderer.error();
  render::Renderer& gl = **renderer;
  auto asset_id = gl.uploadAsset(asset);
  if (!asset_id) return asset_id.error();

  ShaderLodReport report;
  report.device = gl.deviceDescription();
  EvaluationConfig config = options.evaluation;
  config.distance = options.distance;
  config.display = options.display;
  auto cache = std::make_shared<EvaluationCache>(gl);
  // The scorer: our cost model (instrumented block counts x calibrated weights x invocation
  // counts) and the evaluator's predicted / rendered eq. (6) per-pixel error (shader/scoring.hpp).
  auto scoring = ConfigurationScorer::create(gl, cache, *asset_id, asset.mesh, *original, config);
  if (!scoring) return scoring.error();
  ConfigurationScorer& scorer = **scoring;
  if (options.compile_ahead) {
    // The workers draw this context's textures (a few profile samples a variant) instead of each
    // uploading a copy.
    if (auto shared = gl.shareTextures(*asset_id); shared) gl_context.textures = std::move(*shared);
    scorer.enableCompileAhead(asset, gl_context);
  }
  report.footprint_px = scorer.footprint();
  report.domain_samples = scorer.evaluator().sampleCount();
  std::vector<render::Sample> domain = render::domainSamples(
      core::computeBoundingSphere(asset.mesh), options.distance, config.domain);

  RuleContext context;
  context.texture_averages = textureAverages(asset, options.bindings);
  if (options.move_to_parameter) context.average_value = scorer.averageValue(options.average_resolution);
  SearchCache search_cache(*original, context, scorer.scorer());
  auto search_start = std::chrono::steady_clock::now();
  auto searched = options.method == SearchMethod::kGenetic
                      ? searchGenetic(search_cache, options.genetic)
                      : searchGreedy(search_cache, options.greedy);
  if (!searched) return searched.error();
  report.search_seconds = secondsSince(search_start);
  report.compiled_ahead = scorer.compileAheadCounts().first;

  // Levels: by decreasing predicted cost, as the LOD shader orders them, and always from the
  // original: it can be off the front (a variant that removes aliasing detail may be closer to the
  // supersampled reference than the original itself), but it is the level of the nearest
  // distances and the measured times' baseline.
  std::vector<SearchVariant> variants = searched->variants;
  bool has_original = std::any_of(variants.begin(), variants.end(),
                                  [](const SearchVariant& v) { return v.sites.empty(); });
  if (!has_original) {
    auto score = search_cache.score(search_cache.original());
    if (!score) return core::Error{"shader LOD: the original: " + score.error().message};
    variants.push_back({{}, search_cache.sharedOriginal(), score->cost, score->error, {}});
  }
  std::stable_sort(variants.begin(), variants.end(), [](const auto& a, const auto& b) {
    if (a.sites.empty() != b.sites.empty()) return a.sites.empty();
    return a.predicted_cost > b.predicted_cost;
  });
  // A level must be cheaper than the original: on Spot at 64 px a variant at 1.5x the original's
  // cost was on the front for its error below the aliased original's.
  const double original_cost = variants.front().predicted_cost;
  const auto costlier = std::remove_if(variants.begin() + 1, variants.end(), [&](const auto& v) {
    return !(v.predicted_cost < original_cost);
  });
  report.dropped_costlier = static_cast<int>(variants.end() - costlier);
  variants.erase(costlier, variants.end());
  auto rerender_start = std::chrono::steady_clock::now();
  if (auto rendered = renderFront(search_cache, variants); !rendered) return rendered.error();
  report.rerender_seconds = secondsSince(rerender_start);
  for (SearchVariant& variant : variants) report.variants.push_back({std::move(variant), 0, 0});

  if (options.measure_time) {
    auto timing_start = std::chrono::steady_clock::now();
    std::vector<render::Renderer::ProgramId> programs;
    for (const ShaderLodVariant& variant : report.variants) {
      auto evaluated = evaluationVariant(*variant.search.program);
      if (!evaluated) return evaluated.error();
      auto program = cache->program(*evaluated);
      if (!program) return program.error();
      if (auto set = gl.setProgramUniforms(*program, evaluated->uniforms); !set) return set.error();
      programs.push_back(*program);
    }
    render::TimingOptions timing = options.timing;
    timing.resolution = report.footprint_px;
    auto times = gl.measureDrawTimes(*asset_id, programs, domain, timing);
    if (!times) return times.error();
    // The original is the level with no site (the first, unless a variant equals it in cost).
    double original_seconds = 0;
    for (size_t i = 0; i < report.variants.size(); ++i)
      if (report.variants[i].search.sites.empty()) original_seconds = (*times)[i].seconds;
    for (size_t i = 0; i < report.variants.size(); ++i) {
      report.variants[i].measured_seconds = (*times)[i].seconds;
      report.variants[i].time_ratio = original_seconds > 0 ? (*times)[i].seconds / original_seconds : 0;
    }
    report.timing_seconds = secondsSince(timing_start);
  }

  std::vector<ShaderProgram> levels;
  std::vector<float> thresholds;
  for (const ShaderLodVariant& variant : report.variants) {
    levels.push_back(*variant.search.program);
    thresholds.push_back(static_cast<float>(thresholds.size()));
  }
  auto autolod = buildAutoLodShader(levels, thresholds);
  if (!autolod) return autolod.error();
  report.autolod = std::move(*autolod);
  report.bindings = options.bindings;

  report.search = search_cache.counters();
  report.compile = cache->counters();
  report.evaluation = scorer.evaluator().counters();
  report.cost_profiles = scorer.costProfiles();
  report.average_renders = scorer.averageRenders();
  report.total_seconds = secondsSince(start);
  return report;
}

// ---------------------------------------------------------------------------------------------
// Output files.

namespace {

// NAME.{vert,frag}.* of the readable (unoptimised) module.
core::Status writeProgramFiles(const ShaderProgram& program, const fs::path& directory,
                               const std::string& name, const render::Bindings& bindings) {
  auto words = emitProgram(program, /*optimize=*/false);
  if (!words) return core::Error{name + ": " + words.error().message};
  auto files = writeShaderFiles(words->vertex, words->fragment, directory, name, bindings);
  if (!files) return files.error();
  return core::okStatus();
}

nlohmann::json positiveOrNull(double value) {
  return value > 0 ? nlohmann::json(value) : nlohmann::json(nullptr);
}

nlohmann::json parametersJson(const std::vector<ParameterValue>& parameters) {
  nlohmann::json list = nlohmann::json::array();
  for (const ParameterValue& parameter : parameters)
    list.push_back({{"name", parameter.name},
                    {"location", parameter.location},
                    {"value", std::vector<float>(parameter.value.begin(),
                                                 parameter.value.begin() + parameter.components)}});
  return list;
}

}  // namespace

std::string levelFileName(size_t level) {
  char name[32];
  std::snprintf(name, sizeof name, "level%02zu", level);
  return name;
}

core::Status writeShaderLod(const ShaderLodReport& report, const std::string& directory, bool force) {
  std::error_code ec;
  if (fs::exists(directory, ec) && !fs::is_directory(directory, ec))
    return core::Error{directory + ": exists and is not a directory"};
  if (fs::exists(directory, ec) && !force) {
    auto holds = io::folderHoldsFiles(directory);
    if (!holds) return holds.error();
    if (*holds)
      return core::Error{directory +
                         ": already exists and is not empty, and writing into a folder that "
                         "holds files was not asked for"};
  }
  // All or nothing: written beside the folder, then moved in (a failure leaves it as it was).
  io::OutputFolder folder;
  if (auto begun = folder.begin(directory); !begun) return begun;
  const fs::path out(folder.stagingPath());

  nlohmann::json levels = nlohmann::json::array();
  for (size_t k = 0; k < report.variants.size(); ++k) {
    const ShaderLodVariant& variant = report.variants[k];
    std::string name = levelFileName(k);
    if (auto ok = writeProgramFiles(*variant.search.program, out, name, report.bindings); !ok)
      return ok;
    nlohmann::json rules = nlohmann::json::array();
    for (const RuleSite& site : variant.search.sites)
      rules.push_back({{"rule", std::string(ruleName(site.kind))}, {"description", site.description}});
    levels.push_back({{"files", name},
                      {"rules", rules},
                      {"predicted_cost", variant.search.predicted_cost},
                      {"predicted_error", variant.search.predicted_error},
                      {"rendered_error", variant.search.rendered_error
                                             ? nlohmann::json(*variant.search.rendered_error)
                                             : nlohmann::json(nullptr)},
                      // null, not 0, when not measured (--no-timing): 0 would read as free
                      {"measured_seconds", positiveOrNull(variant.measured_seconds)},
                      {"time_ratio", positiveOrNull(variant.time_ratio)},
                      {"parameters", parametersJson(variant.search.program->parameters)}});
  }
  if (auto ok = writeProgramFiles(report.autolod.program, out, "autolod", report.bindings); !ok)
    return ok;

  const SearchCounters& s = report.search;
  nlohmann::json summary = {{"device", report.device},
                            {"footprint_px", report.footprint_px},
                            {"domain_samples", report.domain_samples},
                            {"levels", levels},
                            {"autolod",
                             {{"files", "autolod"},
                              {"uniform", "autoLOD"},
                              {"location", report.autolod.autolod_location},
                              {"thresholds", report.autolod.thresholds},
                              {"distinct_vertex_stages", report.autolod.distinct_vertex_stages},
                              {"parameters", parametersJson(report.autolod.program.parameters)}}},
                            {"counters",
                             {{"variants_generated", s.variants_generated},
                              {"rule_failures", s.rule_failures},
                              {"variants_predicted", s.variants_predicted},
                              {"score_failures", s.score_failures},
                              {"score_cache_hits", s.score_cache_hits},
                              {"variants_rendered", s.variants_rendered},
                              {"genomes_evaluated", s.genomes_evaluated},
                              {"programs_compiled", report.compile.programs_compiled},
                              {"compile_failures", report.compile.compile_failures},
                              {"cost_profiles", report.cost_profiles},
                              {"average_renders", report.average_renders},
                              {"dropped_costlier_than_original", report.dropped_costlier}}},
                            // What depends on thread timing, not on the input and seed: how many
                            // programs the compile-ahead worker had ready when they were scored.
                            {"timing_dependent", {{"compiled_ahead", report.compiled_ahead}}},
                            {"seconds",
                             {{"search", report.search_seconds},
                              {"rerender", report.rerender_seconds},
                              {"timing", report.timing_seconds},
                              {"total", report.total_seconds}}}};
  if (auto ok = io::writeFileAtomic(
          (out / "summary.json").string(),
          summary.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
      !ok)
    return ok;
  return folder.commit();
}

}  // namespace duolod::shader
