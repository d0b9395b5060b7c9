// Cost-model benchmark (issue 4 item 4; Liang et al. §5.2): over variants of the three reference
// shaders on their assets, how well do predicted costs rank the measured llvmpipe wall time?
//   - He et al. 2015: static `scalar ops + 100 × texture ops` over both stages;
//   - static instruction count (every op once, unweighted);
//   - ours with static counts (calibrated weights × static op counts × V, F): no profile;
//   - ours (calibrated weights × dynamic per-block counts × V, F + per draw), with the weights
//     stored in src/shader/cost_model.cpp, and calibrated afresh on held-out splits
//     (leave-one-shader-out, and even/odd variants).
// Spearman rank correlation against the measured time for each, in one table.
//
// Variants are textual edits of the GLSL (fewer octaves, terms and textures removed, no tone map),
// compiled with glslang and cleaned up by SPIRV-Tools' performance passes (the form the search
// compiles and times). Times: Renderer::measureDrawTimes (wall clock around glFinish, median of
// interleaved repeats minus a clear-only pass; never GL_TIME_ELAPSED, DESIGN.md "Measuring cost").

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "duolod/io.hpp"
#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/cost_model.hpp"
#include "shader/instrument.hpp"
#include "shader/rules.hpp"
#include "support/options.hpp"

using namespace duolod;
namespace ir = duolod::shader::ir;

namespace {

struct Edit {
  std::string from, to;
};
struct VariantSpec {
  std::string name;
  std::vector<Edit> edits;
};
struct ShaderCase {
  std::string shader;      // shaders/NAME.vert + .frag
  std::string asset_path;  // under the shared assets
  std::vector<VariantSpec> variants;
};

// ---- the variants ----

Edit octaves(const std::string& knob, int from, int to) {
  return {"const int " + knob + " = " + std::to_string(from) + ";",
          "const int " + knob + " = " + std::to_string(to) + ";"};
}
const Edit kNoToneMap{"outColor = vec4(linearToSrgb(toneMapFilmic(radiance)), 1.0);",
                      "outColor = vec4(radiance, 1.0);"};
const Edit kSqrtEncode{"outColor = vec4(linearToSrgb(toneMapFilmic(radiance)), 1.0);",
                       "outColor = vec4(sqrt(toneMapFilmic(radiance)), 1.0);"};

std::vector<VariantSpec> noisePhongVariants() {
  const Edit no_veins_core{"float vein = pow(veinProfile, VEIN_SHARPNESS);", "float vein = 0.0;"};
  const Edit no_vein_halo{"float veinHalo = pow(veinProfile, VEIN_HALO_SHARPNESS);",
                          "float veinHalo = 0.0;"};
  const Edit no_bump{"vec3 heightGradient = BUMP_HEIGHT * turbulence.yzw;",
                     "vec3 heightGradient = vec3(0.0);"};
  const Edit no_specular{
      "float specular = pow(max(dot(reflected, viewDir), 0.0), SHININESS) * step(0.0, nDotL);",
      "float specular = 0.0;"};
  const Edit no_noise{"vec4 turbulence = fbm(q);", "vec4 turbulence = vec4(0.0);"};
  std::vector<VariantSpec> variants{{"original", {}}};
  for (int n : {1, 2, 3, 5, 6, 8})
    variants.push_back({"octaves " + std::to_string(n), {octaves("OCTAVES", 4, n)}});
  variants.push_back({"no veins", {no_veins_core, no_vein_halo}});
  variants.push_back({"no bump", {no_bump}});
  variants.push_back({"no specular", {no_specular}});
  variants.push_back({"no tone map", {kNoToneMap}});
  variants.push_back({"octaves 2, no veins", {octaves("OCTAVES", 4, 2), no_veins_core, no_vein_halo}});
  variants.push_back({"octaves 1, no specular, no tone map",
                      {octaves("OCTAVES", 4, 1), no_specular, kNoToneMap}});
  variants.push_back({"no veins, bump, specular", {no_veins_core, no_vein_halo, no_bump, no_specular}});
  variants.push_back({"no noise", {no_noise}});
  variants.push_back({"no noise, no tone map", {no_noise, kNoToneMap}});
  variants.push_back({"octaves 3, sqrt encode", {octaves("OCTAVES", 4, 3), kSqrtEncode}});
  return variants;
}

std::vector<VariantSpec> pbrVariants() {
  const Edit no_emissive{
      "vec3 emissive = srgbToLinear(texture(uEmissiveTexture, uv).rgb) * uEmissiveFactor.rgb;",
      "vec3 emissive = uEmissiveFactor.rgb;"};
  const Edit no_occlusion{"float occlusionSample = texture(uOcclusionTexture, uv).r;",
                          "float occlusionSample = 1.0;"};
  const Edit no_normal_map{"vec3 tangentNormal = texture(uNormalTexture, uv).xyz * 2.0 - 1.0;",
                           "vec3 tangentNormal = vec3(0.0, 0.0, 1.0);"};
  const Edit no_metallic_roughness{
      "vec4 metallicRoughness = texture(uMetallicRoughnessTexture, uv);",
      "vec4 metallicRoughness = vec4(1.0);"};
  const Edit no_base_texture{"vec4 baseColorSample = texture(uBaseColorTexture, uv);",
                             "vec4 baseColorSample = vec4(0.8);"};
  const Edit no_srgb_decode{"vec3 baseColor = srgbToLinear(baseColorSample.rgb)",
                            "vec3 baseColor = baseColorSample.rgb"};
  const Edit no_ambient_specular{
      "vec3 ambientSpecular = uAmbientColor.rgb * ambientSpecularBrdf(f0, perceptualRoughness, "
      "nDotV);",
      "vec3 ambientSpecular = vec3(0.0);"};
  const Edit no_specular{"vec3 specularBrdf = fresnel * (ndf * visibility);",
                         "vec3 specularBrdf = vec3(0.0);"};
  std::vector<VariantSpec> variants{
      {"original", {}},
      {"no emissive texture", {no_emissive}},
      {"no occlusion texture", {no_occlusion}},
      {"no normal map", {no_normal_map}},
      {"no metallic-roughness texture", {no_metallic_roughness}},
      {"no base colour texture", {no_base_texture}},
      {"no sRGB decode", {no_srgb_decode}},
      {"no ambient specular", {no_ambient_specular}},
      {"no direct specular", {no_specular}},
      {"no tone map", {kNoToneMap}},
      {"sqrt encode", {kSqrtEncode}},
      {"no emissive, occlusion", {no_emissive, no_occlusion}},
      {"no emissive, occlusion, normal map", {no_emissive, no_occlusion, no_normal_map}},
      {"only base colour texture",
       {no_emissive, no_occlusion, no_normal_map, no_metallic_roughness}},
      {"no textures",
       {no_emissive, no_occlusion, no_normal_map, no_metallic_roughness, no_base_texture}},
      {"no textures, no specular",
       {no_emissive, no_occlusion, no_normal_map, no_metallic_roughness, no_base_texture,
        no_specular, no_ambient_specular}},
      {"no textures, no specular, no tone map",
       {no_emissive, no_occlusion, no_normal_map, no_metallic_roughness, no_base_texture,
        no_specular, no_ambient_specular, kNoToneMap}},
  };
  return variants;
}

std::vector<VariantSpec> blendVariants() {
  const Edit no_layer1{
      "vec4 layer1Sample = texture(uMetallicRoughnessTexture, uv * LAYER1_SCALE + LAYER1_OFFSET);",
      "vec4 layer1Sample = vec4(0.5);"};
  const Edit no_layer2{
      "vec3 layer2 = texture(uOcclusionTexture,\n"
      "                        placeLayer(uv, LAYER2_ANGLE, LAYER2_SCALE, LAYER2_OFFSET)).rgb;",
      "vec3 layer2 = vec3(0.5);"};
  const Edit no_detail_normal{
      "texture(uNormalTexture, uv * DETAIL_NORMAL_SCALE + vec2(0.21, 0.63)).xyz * 2.0 - 1.0;",
      "vec3(0.0, 0.0, 1.0);"};
  const Edit no_specular{"float specular = (shininess + 8.0) / 8.0 * pow(nDotH, shininess);",
                         "float specular = 0.0;"};
  const Edit no_noise{"vec2 noise = noiseFbm(uv * NOISE_SCALE);", "vec2 noise = vec2(0.5);"};
  std::vector<VariantSpec> variants{{"original", {}}};
  for (int n : {1, 2, 4, 6})
    variants.push_back({"noise octaves " + std::to_string(n), {octaves("NOISE_OCTAVES", 3, n)}});
  variants.push_back({"no layer 1", {no_layer1}});
  variants.push_back({"no layer 2", {no_layer2}});
  variants.push_back({"no detail normal", {no_detail_normal}});
  variants.push_back({"no specular", {no_specular}});
  variants.push_back({"no tone map", {kNoToneMap}});
  variants.push_back({"no noise", {no_noise}});
  variants.push_back({"noise octaves 1, no layers 1-2", {octaves("NOISE_OCTAVES", 3, 1), no_layer1, no_layer2}});
  variants.push_back({"no noise, no detail normal, no specular", {no_noise, no_detail_normal, no_specular}});
  variants.push_back({"no layers 1-2, no detail normal, no tone map",
                      {no_layer1, no_layer2, no_detail_normal, kNoToneMap}});
  variants.push_back({"noise octaves 6, sqrt encode", {octaves("NOISE_OCTAVES", 3, 6), kSqrtEncode}});
  return variants;
}

// ---- compiling ----

core::Result<std::string> readText(const std::string& path) {
  std::ifstream in(path);
  if (!in) return core::Error{path + ": cannot open"};
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

core::Result<std::string> applyEdits(std::string source, const VariantSpec& variant) {
  for (const Edit& edit : variant.edits) {
    size_t at = source.find(edit.from);
    if (at == std::string::npos)
      return core::Error{"variant '" + variant.name + "': text not found: " + edit.from};
    source.replace(at, edit.from.size(), edit.to);
  }
  return source;
}

// glslang, then SPIRV-Tools' performance passes (inlining, dead code, folding): what is compiled
// and timed. Glslang's unoptimised output keeps dead code that the driver removes anyway, which
// would make every static count meaningless.
core::Result<ir::Module> compileStage(const std::string& source, shader::Stage stage,
                                      const std::string& name) {
  auto words = shader::compileToSpirv(source, stage, name);
  if (!words.ok()) return words.error();
  auto optimized = shader::optimizeForEvaluation(*words, name);
  if (!optimized.ok()) return optimized.error();
  auto module = ir::parseModule(*optimized);
  if (!module.ok()) return core::Error{name + ": " + module.error().message};
  return std::move(*module);
}

// Both stages of `shader` with fragment value `value` (a source name) computed per vertex by the
// rule, in the evaluated form (SPIRV-Tools' performance passes, like the search's variants).
core::Result<std::pair<ir::Module, ir::Module>> perVertexVariant(const std::string& vertex_source,
                                                                 const std::string& fragment_source,
                                                                 const std::string& shader,
                                                                 const std::string& value) {
  auto vertex = shader::compileToSpirv(vertex_source, shader::Stage::kVertex, shader + ".vert");
  if (!vertex.ok()) return vertex.error();
  auto fragment = shader::compileToSpirv(fragment_source, shader::Stage::kFragment, shader + ".frag");
  if (!fragment.ok()) return fragment.error();
  auto program = shader::parseProgram(*vertex, *fragment);
  if (!program.ok()) return program.error();
  shader::RuleContext context;
  context.enabled = {false, false, true, false, false, false};
  const std::string wanted = "per-vertex: " + value + " computed";
  for (const shader::RuleSite& site : shader::enumerateSites(*program, context)) {
    if (site.description.rfind(wanted, 0) != 0) continue;
    auto applied = shader::applyRule(*program, site, context);
    if (!applied.ok()) return applied.error();
    auto words = shader::emitProgram(*applied, /*optimize=*/true);
    if (!words.ok()) return words.error();
    auto vertex_module = ir::parseModule(words->vertex);
    if (!vertex_module.ok()) return vertex_module.error();
    auto fragment_module = ir::parseModule(words->fragment);
    if (!fragment_module.ok()) return fragment_module.error();
    return std::make_pair(std::move(*vertex_module), std::move(*fragment_module));
  }
  return core::Error{"no per-vertex site for " + value};
}

// ---- one measured point ----

struct Point {
  std::string shader, variant;
  int resolution = 0;
  shader::CostFeatures features;         // dynamic (profiled)
  shader::CostFeatures static_features;  // every block once
  double he = 0;
  double static_instructions = 0;  // every op once, unweighted
  double measured = 0;             // seconds per draw
  double spread = 0;
};

double sum(const shader::OpClassCounts& counts) {
  double total = 0;
  for (double c : counts) total += c;
  return total;
}

std::vector<double> predictAll(const std::vector<Point>& points, const shader::CostWeights& weights,
                               bool dynamic) {
  std::vector<double> predicted;
  for (const Point& p : points)
    predicted.push_back(shader::predictCost(dynamic ? p.features : p.static_features, weights));
  return predicted;
}

// Predictions for every point from weights calibrated without it: `fold(point)` names the point's
// fold; each fold is predicted by weights fitted on the others.
template <class Fold>
core::Result<std::vector<double>> heldOut(const std::vector<Point>& points, Fold fold, bool dynamic) {
  std::map<int, std::vector<size_t>> folds;
  for (size_t i = 0; i < points.size(); ++i) folds[fold(i)].push_back(i);
  std::vector<double> predicted(points.size(), 0);
  for (const auto& [key, members] : folds) {
    std::vector<shader::CostFeatures> features;
    std::vector<double> seconds;
    for (size_t i = 0; i < points.size(); ++i) {
      if (fold(i) == key || !(points[i].measured > 0)) continue;
      features.push_back(dynamic ? points[i].features : points[i].static_features);
      seconds.push_back(points[i].measured);
    }
    auto weights = shader::calibrateCostWeights(features, seconds, "held out");
    if (!weights.ok()) return weights.error();
    for (size_t i : members)
      predicted[i] = shader::predictCost(dynamic ? points[i].features : points[i].static_features,
                                         *weights);
  }
  return predicted;
}

struct Row {
  std::string name;
  std::vector<double> predicted;
};

void printCorrelations(const std::vector<Point>& points, const std::vector<Row>& rows,
                       const std::vector<std::string>& shaders) {
  std::printf("\n| predictor | Spearman, all %zu | ", points.size());
  for (const std::string& s : shaders) std::printf("%s | ", s.c_str());
  std::printf("\n|---|---:|");
  for (size_t i = 0; i < shaders.size(); ++i) std::printf("---:|");
  std::printf("\n");
  std::vector<double> measured;
  for (const Point& p : points) measured.push_back(p.measured);
  for (const Row& row : rows) {
    std::printf("| %s | %.3f | ", row.name.c_str(), core::spearmanCorrelation(row.predicted, measured));
    for (const std::string& s : shaders) {
      std::vector<double> a, b;
      for (size_t i = 0; i < points.size(); ++i)
        if (points[i].shader == s) a.push_back(row.predicted[i]), b.push_back(points[i].measured);
      std::printf("%.3f | ", core::spearmanCorrelation(a, b));
    }
    std::printf("\n");
  }
}

void printWeights(const shader::CostWeights& weights) {
  auto names = shader::costModelParameterNames();
  auto vector = shader::weightVector(weights);
  std::printf("\nweights calibrated on all points (seconds; paste into cost_model.cpp):\n  {");
  for (size_t i = 0; i < vector.size(); ++i)
    std::printf("%s%.6e /* %s */", i ? ", " : "", vector[i], names[i].c_str());
  std::printf("}\n");
}

int fail(const std::string& message) {
  std::fprintf(stderr, "bench_shader_cost: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{"duolod shader cost model: predicted cost vs measured llvmpipe time"};
  std::vector<int> resolutions = {128, 64};
  int repeats = 7;
  double min_repeat_seconds = 0.04;
  int views = 20;
  std::string only;
  app.add("--resolutions", resolutions, "footprints s_d in pixels (one configuration each)");
  app.add("--repeats", repeats, "timed repeats per program (median)");
  app.add("--min-repeat-seconds", min_repeat_seconds);
  app.add("--views", views, "views of the dodecahedron domain (centre light each)");
  app.add("--only", only, "run one shader (pbr, noise_phong, blend)");
  std::vector<std::string> per_vertex_values;
  app.add("--per-vertex", per_vertex_values,
          "also time variants with these fragment values (by source name) moved per vertex "
          "by the per-vertex rule, one each, in every shader that has them");
  std::vector<double> try_scales = {1.0};
  app.add("--vertex-op-scales", try_scales,
          "also rank with the stored weights at these "
          "vertex-op scales");
  std::string noise_asset;
  app.add("--noise-phong-asset", noise_asset,
          "mesh for the noise_phong variants (default: Spot), e.g. the Dragon of the GP bench");
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;

  const std::string assets = DUOLOD_ASSET_DIR;
  std::vector<ShaderCase> cases{
      {"pbr", assets + "/gltf/WaterBottle/WaterBottle.gltf", pbrVariants()},
      {"noise_phong", noise_asset.empty() ? assets + "/obj/spot/spot.obj" : noise_asset,
       noisePhongVariants()},
      {"blend", assets + "/gltf/Avocado/Avocado.gltf", blendVariants()},
  };

  auto renderer = render::Renderer::create();
  if (!renderer.ok()) return fail(renderer.error().message);
  render::Renderer& r = **renderer;
  std::printf("device: %s\n", r.deviceDescription().c_str());

  std::vector<Point> points;
  std::vector<std::string> shader_names;
  for (const ShaderCase& shader_case : cases) {
    if (!only.empty() && only != shader_case.shader) continue;
    shader_names.push_back(shader_case.shader);
    auto asset = io::loadAsset(shader_case.asset_path);
    if (!asset.ok()) return fail(asset.error().message);
    auto asset_id = r.uploadAsset(*asset);
    if (!asset_id.ok()) return fail(asset_id.error().message);
    core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
    std::vector<render::Sample> samples;
    for (const render::Sample& s : render::domainSamples(sphere, 3 * sphere.radius))
      if (s.light_index == 0 && s.view_index < views) samples.push_back(s);

    std::string prefix = render::shaderDirectory() + "/" + shader_case.shader;
    auto vertex_source = readText(prefix + ".vert");
    auto fragment_source = readText(prefix + ".frag");
    if (!vertex_source.ok()) return fail(vertex_source.error().message);
    if (!fragment_source.ok()) return fail(fragment_source.error().message);
    auto vertex = compileStage(*vertex_source, shader::Stage::kVertex, shader_case.shader + ".vert");
    if (!vertex.ok()) return fail(vertex.error().message);

    struct Compiled {
      std::string name;
      ir::Module vertex;
      ir::Module fragment;
      render::Renderer::ProgramId program;
    };
    std::vector<Compiled> compiled;
    for (const VariantSpec& spec : shader_case.variants) {
      auto source = applyEdits(*fragment_source, spec);
      if (!source.ok()) return fail(source.error().message);
      auto fragment = compileStage(*source, shader::Stage::kFragment,
                                   shader_case.shader + ".frag [" + spec.name + "]");
      if (!fragment.ok()) return fail(fragment.error().message);
      auto program = r.compileProgram(
          render::SpirvBinary{ir::emitModule(*vertex), ir::emitModule(*fragment)});
      if (!program.ok()) return fail(spec.name + ": " + program.error().message);
      compiled.push_back({spec.name, *vertex, std::move(*fragment), *program});
    }
    // With --per-vertex: the per-vertex rule (Wang et al. 2014) applied to one named value each,
    // on the SPIR-V: variants whose vertex stage does the work, which the textual edits never
    // have (llvmpipe shades vertices on one thread, fragments on all cores).
    for (const std::string& value : per_vertex_values) {
      auto variant = perVertexVariant(*vertex_source, *fragment_source, shader_case.shader, value);
      if (!variant.ok()) {
        std::fprintf(stderr, "%s: per-vertex %s: %s (skipped)\n", shader_case.shader.c_str(),
                     value.c_str(), variant.error().message.c_str());
        continue;
      }
      auto program = r.compileProgram(
          render::SpirvBinary{ir::emitModule(variant->first), ir::emitModule(variant->second)});
      if (!program.ok()) return fail("per-vertex " + value + ": " + program.error().message);
      compiled.push_back(
          {"per-vertex " + value, std::move(variant->first), std::move(variant->second), *program});
    }
    std::vector<render::Renderer::ProgramId> programs;
    for (const Compiled& c : compiled) programs.push_back(c.program);

    for (int resolution : resolutions) {
      std::fprintf(stderr, "%s at %d px: profiling %zu variants...\n", shader_case.shader.c_str(),
                   resolution, compiled.size());
      std::vector<Point> shader_points;
      for (const Compiled& c : compiled) {
        // The configuration's invocations, from the program itself (uninstrumented).
        render::RenderStats stats;
        auto image = r.render(*asset_id, c.program, samples,
                              {.resolution = resolution, .count_work = true}, &stats);
        if (!image.ok()) return fail(image.error().message);
        double draws = static_cast<double>(samples.size());
        double v = stats.work.vertex_invocations / draws;
        double f = stats.work.fragment_invocations / draws;
        auto profile = shader::profileBlockCounts(r, *asset_id, c.vertex, c.fragment, samples,
                                                  resolution);
        if (!profile.ok()) return fail(c.name + ": " + profile.error().message);
        Point point;
        point.shader = shader_case.shader;
        point.variant = c.name;
        point.resolution = resolution;
        point.features = shader::profiledCostFeatures(c.vertex, c.fragment, *profile, v, f);
        point.static_features = shader::staticCostFeatures(c.vertex, c.fragment, v, f);
        point.he = shader::heStaticCost(c.vertex, c.fragment);
        point.static_instructions =
            sum(shader::staticOpCounts(c.vertex)) + sum(shader::staticOpCounts(c.fragment));
        shader_points.push_back(point);
      }
      std::fprintf(stderr, "%s at %d px: timing...\n", shader_case.shader.c_str(), resolution);
      auto times = r.measureDrawTimes(
          *asset_id, programs, samples,
          {.resolution = resolution, .repeats = repeats, .min_repeat_seconds = min_repeat_seconds});
      if (!times.ok()) return fail(times.error().message);
      for (size_t i = 0; i < shader_points.size(); ++i) {
        shader_points[i].measured = (*times)[i].seconds / samples.size();
        shader_points[i].spread = (*times)[i].spread;
      }
      points.insert(points.end(), shader_points.begin(), shader_points.end());
    }
    for (const Compiled& c : compiled) r.releaseProgram(c.program);
    r.releaseAsset(*asset_id);
  }

  // A point timed at 0 (a draw cheaper than the clear's noise) has no rank information worth
  // calibrating on; keep it in the correlations, but out of the fits.
  std::vector<shader::CostFeatures> all_features;
  std::vector<double> all_seconds;
  for (const Point& p : points)
    if (p.measured > 0) all_features.push_back(p.features), all_seconds.push_back(p.measured);
  auto fitted = shader::calibrateCostWeights(all_features, all_seconds, "this run");
  if (!fitted.ok()) return fail(fitted.error().message);

  const shader::CostWeights& stored = shader::calibratedCostWeights();
  std::vector<Row> rows;
  {
    Row he{"He et al. 2015: static scalar ops + 100 x texture ops", {}};
    Row count{"static instruction count (unweighted)", {}};
    for (const Point& p : points) he.predicted.push_back(p.he), count.predicted.push_back(p.static_instructions);
    rows.push_back(he);
    rows.push_back(count);
  }
  rows.push_back({"ours, static counts x V,F (stored weights)", predictAll(points, stored, false)});
  std::vector<double> ours_stored = predictAll(points, stored, true);
  rows.push_back({"ours: dynamic counts x V,F (stored weights " + stored.version + ")", ours_stored});
  auto shader_fold = [&](size_t i) {
    return static_cast<int>(std::find(shader_names.begin(), shader_names.end(), points[i].shader) -
                            shader_names.begin());
  };
  auto half_fold = [&](size_t i) { return static_cast<int>(i % 2); };
  if (shader_names.size() > 1) {
    auto loso = heldOut(points, shader_fold, true);
    if (!loso.ok()) return fail(loso.error().message);
    rows.push_back({"ours, held out: weights fitted on the other shaders", *loso});
  }
  auto half = heldOut(points, half_fold, true);
  if (!half.ok()) return fail(half.error().message);
  rows.push_back({"ours, held out: even/odd halves", *half});
  auto half_static = heldOut(points, half_fold, false);
  if (!half_static.ok()) return fail(half_static.error().message);
  rows.push_back({"ours, static counts, held out: even/odd halves", *half_static});
  rows.push_back({"ours, in-sample fit of this run", predictAll(points, *fitted, true)});

  std::printf("\n| shader | variant | s_d | V/draw | F/draw | He | static ops | ours (stored) us | "
              "measured us | spread |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    std::printf("| %s | %s | %d | %.0f | %.0f | %.0f | %.0f | %.1f | %.1f | %.2f |\n",
                p.shader.c_str(), p.variant.c_str(), p.resolution, p.features.vertex_invocations,
                p.features.fragment_invocations, p.he, p.static_instructions,
                ours_stored[i] * 1e6, p.measured * 1e6, p.spread);
  }
  {
    // The vertex stage's per-op multiplier on top of the stored weights (cost_model.hpp).
    std::vector<shader::CostFeatures> features;
    std::vector<double> seconds;
    for (const Point& p : points) features.push_back(p.features), seconds.push_back(p.measured);
    shader::CostWeights scaled = stored;
    scaled.vertex_op_scale = shader::fitVertexOpScale(features, seconds, stored);
    char name[160];
    std::snprintf(name, sizeof name, "ours, stored weights with the vertex-op scale fitted here (%.2f)",
                  scaled.vertex_op_scale);
    rows.push_back({name, predictAll(points, scaled, true)});
    for (double given : try_scales) {
      shader::CostWeights other = stored;
      other.vertex_op_scale = given;
      std::snprintf(name, sizeof name, "ours, stored weights, vertex-op scale %.2f", given);
      rows.push_back({name, predictAll(points, other, true)});
    }
  }
  printCorrelations(points, rows, shader_names);
  {
    // The stored weights' absolute scale on this machine: the ranks above do not depend on it,
    // but the milliseconds `generate` and `shader` print and export do.
    const shader::CostScaleFit scale = shader::fitCostScale(all_features, all_seconds, stored);
    std::printf("\nstored weights' absolute scale here: measured / predicted = %.4g (common factor "
                "over %zu configurations); after it, predicted / measured spans %.2f-%.2f\n",
                scale.factor, scale.points, scale.smallest_ratio, scale.largest_ratio);
  }
  printWeights(*fitted);
  return 0;
}
