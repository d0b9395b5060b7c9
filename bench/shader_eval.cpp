// Shader-variant evaluation throughput (issue 4, "Evaluation throughput"): distinct variants
// evaluated per second (compiled + rendered over the 20 × 5 domain against the 4×4-supersampled
// reference of the original, eq. 6) and predicted per second (5 views × 1 light), the cost of
// re-evaluating a cached variant, how well the predicted error ranks the rendered one (Spearman),
// and each variant's measured draw time and fragment work at the footprint.
// Variants for now: textual GLSL edits of noise_phong (octaves, bump, veins, shininess), the
// constant shader, pbr, and colours moved to a uniform; the SPIR-V rules will replace them.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "duolod/io.hpp"
#include "duolod/shader.hpp"
#include "shader/evaluate.hpp"
#include "support/options.hpp"

using namespace duolod;

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

constexpr size_t kNoiseEdits = 10;  // the first variants: noise_phong and its textual edits

struct NamedVariant {
  std::string name;
  shader::Variant variant;
};

// noise_phong with some of its constants replaced ("const int OCTAVES = 4;" → "... = 2;").
core::Result<render::SpirvBinary> compilePair(const render::GlslSource& source,
                                              const std::vector<std::pair<std::string, std::string>>&
                                                  edits) {
  std::string fragment = source.fragment;
  for (const auto& [from, to] : edits) {
    size_t at = fragment.find(from);
    if (at == std::string::npos) return core::Error{"edit target not found: " + from};
    fragment.replace(at, from.size(), to);
  }
  auto vertex = shader::compileToSpirv(source.vertex, shader::Stage::kVertex, source.vertex_name);
  if (!vertex) return vertex.error();
  auto compiled = shader::compileToSpirv(fragment, shader::Stage::kFragment, source.fragment_name);
  if (!compiled) return compiled.error();
  return render::SpirvBinary{*vertex, *compiled};
}

constexpr const char* kTintFragment = R"(#version 450 core
layout(location = 0) uniform vec4 uTint;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(uTint.rgb, 1.0); }
)";

core::Result<std::vector<NamedVariant>> buildVariants() {
  auto noise = render::loadShaderPair("noise_phong");
  auto constant = render::loadShaderPair("constant");
  auto pbr = render::loadShaderPair("pbr");
  if (!noise || !constant || !pbr) return core::Error{"cannot load the reference shaders"};
  using Edits = std::vector<std::pair<std::string, std::string>>;
  const std::string octaves = "const int OCTAVES = 4;", bump = "const float BUMP_HEIGHT = 0.012;";
  const std::string veins = "const float VEIN_SHARPNESS = 10.0;";
  const std::string shininess = "const float SHININESS = 48.0;";
  std::vector<std::pair<std::string, Edits>> noise_edits = {
      {"noise_phong (original)", {}},
      {"octaves 3", {{octaves, "const int OCTAVES = 3;"}}},
      {"octaves 2", {{octaves, "const int OCTAVES = 2;"}}},
      {"octaves 1", {{octaves, "const int OCTAVES = 1;"}}},
      {"no bump", {{bump, "const float BUMP_HEIGHT = 0.0;"}}},
      {"octaves 2, no bump", {{octaves, "const int OCTAVES = 2;"}, {bump, "const float BUMP_HEIGHT = 0.0;"}}},
      {"octaves 1, no bump", {{octaves, "const int OCTAVES = 1;"}, {bump, "const float BUMP_HEIGHT = 0.0;"}}},
      {"soft veins", {{veins, "const float VEIN_SHARPNESS = 3.0;"}}},
      {"shininess 12", {{shininess, "const float SHININESS = 12.0;"}}},
      {"octaves 3, shininess 12", {{octaves, "const int OCTAVES = 3;"}, {shininess, "const float SHININESS = 12.0;"}}},
  };
  std::vector<NamedVariant> variants;
  static_assert(kNoiseEdits > 0);
  if (noise_edits.size() != kNoiseEdits) return core::Error{"kNoiseEdits is out of date"};
  for (const auto& [name, edits] : noise_edits) {
    auto spirv = compilePair(*noise, edits);
    if (!spirv) return core::Error{name + ": " + spirv.error().message};
    variants.push_back({name, {*spirv, {}, {}}});
  }
  auto constant_spirv = compilePair(*constant, {});
  auto pbr_spirv = compilePair(*pbr, {});
  render::GlslSource tint = *constant;
  tint.fragment = kTintFragment;
  auto tint_spirv = compilePair(tint, {});
  if (!constant_spirv || !pbr_spirv || !tint_spirv) return core::Error{"cannot compile variants"};
  variants.push_back({"pbr", {*pbr_spirv, {}, {}}});
  variants.push_back({"constant (material colour)", {*constant_spirv, {}, {}}});
  // Stone colours of noise_phong moved to a uniform (same program, different values).
  variants.push_back({"uniform: light stone", {*tint_spirv, {{0, 4, {0.66f, 0.61f, 0.53f, 1}}}, {}}});
  variants.push_back({"uniform: stone cloud", {*tint_spirv, {{0, 4, {0.30f, 0.27f, 0.24f, 1}}}, {}}});
  variants.push_back({"uniform: mid stone", {*tint_spirv, {{0, 4, {0.45f, 0.42f, 0.37f, 1}}}, {}}});
  return variants;
}

std::string defaultMesh() {
  const char* dir = std::getenv("DUOLOD_DATA_DIR");
  return std::string(dir ? dir : "/tmp/duolod-data") + "/cgal/data/meshes/ChineseDragon-10kv.off";
}

}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{
      "duolod shader-variant evaluation throughput, prediction quality and draw cost"};
  std::string mesh_path = defaultMesh();
  int pixels = 128, repeats = 5;
  app.add("--mesh", mesh_path, "mesh (scripts/fetch-bench-data.sh fetches the default)");
  app.add("--pixels", pixels, "footprint s_d in pixels");
  app.add("--repeats", repeats, "draw-time repeats (median); 0 = no draw timing");
  shader::EvaluationConfig config;
  app.add("--predicted-views", config.predicted_views);
  app.add("--predicted-lights", config.predicted_lights);
  app.add("--predicted-scale", config.predicted_resolution_scale,
          "predicted resolution / footprint");
  app.add("--predicted-min", config.predicted_min_resolution, "predicted resolution floor (px)");
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;
  if (!std::filesystem::exists(mesh_path))
    return std::fprintf(stderr, "%s not found: run scripts/fetch-bench-data.sh\n",
                        mesh_path.c_str()), 1;
  auto asset = io::loadAsset(mesh_path);
  if (!asset) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 1;
  auto created = render::Renderer::create();
  if (!created) return std::fprintf(stderr, "%s\n", created.error().message.c_str()), 1;
  render::Renderer& renderer = **created;
  auto asset_id = renderer.uploadAsset(*asset);
  if (!asset_id) return std::fprintf(stderr, "%s\n", asset_id.error().message.c_str()), 1;
  auto variants = buildVariants();
  if (!variants) return std::fprintf(stderr, "%s\n", variants.error().message.c_str()), 1;

  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  float screen_half = std::tan(config.display.fov_y_deg * 3.14159265f / 360.0f);
  config.distance =
      sphere.radius / std::sin(std::atan(pixels / float(config.display.height_px) * screen_half));
  const shader::Variant& original = variants->front().variant;

  // Cold: a fresh cache, every variant compiled and rendered over the whole domain.
  auto cache = std::make_shared<shader::EvaluationCache>(renderer);
  auto evaluator = shader::VariantEvaluator::create(cache, *asset_id, asset->mesh, original, config);
  if (!evaluator) return std::fprintf(stderr, "%s\n", evaluator.error().message.c_str()), 1;
  shader::VariantEvaluator& e = **evaluator;
  size_t n = variants->size();
  std::vector<metric::ImageError> rendered(n), predicted(n);
  std::vector<double> compile_seconds(n), render_seconds(n), predict_seconds(n);
  auto start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < n; ++i) {
    double compiled_before = cache->counters().compile_seconds;
    auto begin = std::chrono::steady_clock::now();
    auto error = e.renderedError((*variants)[i].variant);
    if (!error) return std::fprintf(stderr, "%s\n", error.error().message.c_str()), 1;
    rendered[i] = *error;
    compile_seconds[i] = cache->counters().compile_seconds - compiled_before;
    render_seconds[i] = secondsSince(begin) - compile_seconds[i];
  }
  double cold_rendered_seconds = secondsSince(start);
  start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < n; ++i) {
    auto begin = std::chrono::steady_clock::now();
    auto error = e.predictedError((*variants)[i].variant);
    if (!error) return std::fprintf(stderr, "%s\n", error.error().message.c_str()), 1;
    predicted[i] = *error;
    predict_seconds[i] = secondsSince(begin);
  }
  double warm_predicted_seconds = secondsSince(start);
  start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < n; ++i) {
    if (!e.renderedError((*variants)[i].variant) || !e.predictedError((*variants)[i].variant))
      return 1;
  }
  double reevaluation_seconds = secondsSince(start) / double(2 * n);
  const int distinct_programs = cache->counters().programs_compiled;

  // Cold predicted: a second cache, so the predicted path pays its compiles too.
  auto predicted_cache = std::make_shared<shader::EvaluationCache>(renderer);
  auto predictor =
      shader::VariantEvaluator::create(predicted_cache, *asset_id, asset->mesh, original, config);
  if (!predictor) return std::fprintf(stderr, "%s\n", predictor.error().message.c_str()), 1;
  start = std::chrono::steady_clock::now();
  for (const NamedVariant& v : *variants)
    if (!(*predictor)->predictedError(v.variant)) return 1;
  double cold_predicted_seconds = secondsSince(start);

  // Draw cost at the footprint over the domain, all variants in one interleaved measurement,
  // and the fragment work of one render.
  std::vector<render::Renderer::ProgramId> programs;
  std::vector<render::WorkCounts> work(n);
  auto samples = render::domainSamples(sphere, config.distance);
  for (size_t i = 0; i < n; ++i) {
    const shader::Variant& v = (*variants)[i].variant;
    auto program = cache->program(v);
    if (!program || !renderer.setProgramUniforms(*program, v.uniforms)) return 1;
    programs.push_back(*program);
    render::RenderStats stats;
    if (!renderer.render(*asset_id, *program, samples,
                         {.resolution = e.footprint(), .count_work = true}, &stats))
      return 1;
    work[i] = stats.work;
  }
  std::vector<render::DrawTime> times(n);
  if (repeats > 0) {
    auto measured = renderer.measureDrawTimes(*asset_id, programs, samples,
                                              {.resolution = e.footprint(), .repeats = repeats});
    if (!measured) return std::fprintf(stderr, "%s\n", measured.error().message.c_str()), 1;
    times = *measured;
  }

  std::printf("mesh %s (%zu triangles), s_d %d px (distance %.3f), reference %dx%d; %d samples "
              "rendered, %d predicted (%d px); device %s; %u hardware threads\n\n",
              mesh_path.c_str(), asset->mesh.triangleCount(), e.footprint(), config.distance,
              config.supersample, config.supersample, e.sampleCount(), e.predictedSampleCount(),
              e.predictedResolution(), renderer.deviceDescription().c_str(),
              std::thread::hardware_concurrency());
  std::printf("| variant | compile s | render s | predict s | rendered eps (per px) | predicted eps "
              "(per px) | draw ms / domain | vs original | fragments |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  std::vector<double> rendered_eps, predicted_eps;
  for (size_t i = 0; i < n; ++i) {
    rendered_eps.push_back(rendered[i].epsilon);
    predicted_eps.push_back(predicted[i].epsilon);
    std::printf("| %s | %.3f | %.3f | %.3f | %.2f (%.4f) | %.2f (%.4f) | %.2f | %.2fx | %llu |\n",
                (*variants)[i].name.c_str(), compile_seconds[i], render_seconds[i],
                predict_seconds[i], rendered[i].epsilon, rendered[i].per_pixel,
                predicted[i].epsilon, predicted[i].per_pixel, times[i].seconds * 1e3,
                times[0].seconds > 0 ? times[i].seconds / times[0].seconds : 0,
                static_cast<unsigned long long>(work[i].fragment_invocations));
  }
  std::printf("\ncompile s = glSpecializeShader + link only: llvmpipe JIT-compiles at the first "
              "draw, which lands in render s\n");
  std::printf("references (whole + predicted domain, 4x4): %.2f s\n",
              e.counters().reference_seconds);
  std::printf("distinct variants %zu, programs compiled %d (uniform variants share one), "
              "compile total %.2f s\n", n, distinct_programs, cache->counters().compile_seconds);
  std::printf("rendered, cold (compile + %d samples + eq. 6): %.2f variants/s (%.3f s each)\n",
              e.sampleCount(), n / cold_rendered_seconds, cold_rendered_seconds / n);
  std::printf("predicted, cold (compile + %d samples): %.2f variants/s; warm (program cached): "
              "%.2f variants/s\n", e.predictedSampleCount(), n / cold_predicted_seconds,
              n / warm_predicted_seconds);
  std::printf("re-evaluation of a cached variant: %.2f us (error cache hits %d)\n",
              reevaluation_seconds * 1e6, cache->counters().error_hits);
  std::printf("Spearman(predicted, rendered) over %zu variants: %.3f; over the %zu noise_phong "
              "edits alone: %.3f\n", n, core::spearmanCorrelation(predicted_eps, rendered_eps),
              kNoiseEdits, core::spearmanCorrelation(std::span(predicted_eps).first(kNoiseEdits),
                                                     std::span(rendered_eps).first(kNoiseEdits)));
  std::printf("draw time: median of %d interleaved repeats, %d passes each for the original, "
              "clear-only baseline %.3f ms subtracted\n",
              repeats, times[0].passes_per_repeat, times[0].clear_seconds * 1e3);
  return 0;
}
