// Variant evaluation (eq. 6 against the supersampled original, caches, prediction) on scenes whose
// answers follow from the shaders by hand, and Spearman's rank correlation on hand cases.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "duolod/mesh.hpp"
#include "duolod/shader.hpp"
#include "mesh_test_meshes.hpp"
#include "shader/compile_ahead.hpp"
#include "shader/evaluate.hpp"
#include "shader/instrument.hpp"
#include "shader/ir.hpp"
#include "shader/scoring.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

// ---- Spearman (core) ----

TEST(Spearman, TiedValuesShareTheirMeanRank) {
  std::vector<double> values = {10, 20, 20, 30, 20};
  EXPECT_EQ(core::fractionalRanks(values), (std::vector<double>{1, 3, 3, 5, 3}));
}

TEST(Spearman, HandCases) {
  std::vector<double> x = {1, 2, 3, 4, 5};
  std::vector<double> squares = {1, 4, 9, 16, 25};
  std::vector<double> reversed = {5, 4, 3, 2, 1};
  EXPECT_DOUBLE_EQ(core::spearmanCorrelation(x, squares), 1.0);  // monotone, not linear
  EXPECT_DOUBLE_EQ(core::spearmanCorrelation(x, reversed), -1.0);
  // One swap of neighbours among 5: 1 − 6·Σd²/(n(n²−1)) = 1 − 6·2/120 = 0.9 (no ties).
  std::vector<double> swapped = {2, 1, 3, 4, 5};
  EXPECT_NEAR(core::spearmanCorrelation(x, swapped), 0.9, 1e-12);
  // With ties: ranks a = (1, 2.5, 2.5, 4), b = (1, 2, 3, 4); centred a = (−1.5, 0, 0, 1.5),
  // b = (−1.5, −0.5, 0.5, 1.5): cov 4.5, var_a 4.5, var_b 5 → 4.5 / sqrt(22.5).
  std::vector<double> a = {1, 2, 2, 3}, b = {1, 2, 3, 4};
  EXPECT_NEAR(core::spearmanCorrelation(a, b), 4.5 / std::sqrt(22.5), 1e-12);
  std::vector<double> constant = {7, 7, 7, 7};
  EXPECT_EQ(core::spearmanCorrelation(constant, b), 0.0);
  EXPECT_EQ(core::spearmanCorrelation(std::vector<double>{1}, std::vector<double>{2}), 0.0);
  EXPECT_EQ(core::spearmanCorrelation(x, b), 0.0);  // sizes differ
}

TEST(Median, OddEvenEmpty) {
  EXPECT_EQ(core::median({3, 1, 2}), 2);
  EXPECT_EQ(core::median({4, 1, 3, 2}), 2.5);
  EXPECT_EQ(core::median({}), 0);
}

// ---- The evaluator ----

using test::kFrameBlock;
// The colour of the constant shader, moved to a plain uniform (location 0) or to a parameter
// block (binding 2): what "moving to parameter" produces.
constexpr const char* kUniformFragment = R"(#version 450 core
layout(location = 0) uniform vec4 uTint;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(uTint.rgb, 1.0); }
)";
constexpr const char* kBlockFragment = R"(#version 450 core
layout(std140, binding = 2) uniform Parameters { vec4 uTint; };
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(uTint.rgb, 1.0); }
)";

core::Result<render::SpirvBinary> spirvPair(const std::string& vertex, const std::string& fragment,
                                            const std::string& name) {
  auto v = shader::compileToSpirv(vertex, shader::Stage::kVertex, name + ".vert");
  if (!v) return v.error();
  auto f = shader::compileToSpirv(fragment, shader::Stage::kFragment, name + ".frag");
  if (!f) return f.error();
  return render::SpirvBinary{*v, *f};
}

class EvaluatorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    renderer_ = test::createRenderer(failure_);
    if (!renderer_) return;
    asset_.source_path = "icosphere";
    asset_.mesh = test::icosphere(2);
    core::computeNormals(asset_.mesh);
    core::Material material;
    material.base_color_factor = {0.2f, 0.4f, 0.6f, 1};
    asset_.materials = {material};
    auto id = renderer_->uploadAsset(asset_);
    ASSERT_TRUE(id) << id.error().message;
    asset_id_ = *id;
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  void SetUp() override { ASSERT_NE(renderer_, nullptr) << "no OpenGL 4.5 context: " << failure_; }

  static shader::Variant shaderVariant(const std::string& name) {
    auto source = render::loadShaderPair(test::sourcePath("shaders/" + name));
    EXPECT_TRUE(source) << source.error().message;
    auto spirv = spirvPair(source->vertex, source->fragment, name);
    EXPECT_TRUE(spirv) << spirv.error().message;
    return shader::Variant{*spirv, {}, {}};
  }
  static shader::Variant fragmentVariant(const char* fragment) {
    auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
    EXPECT_TRUE(source) << source.error().message;
    auto spirv = spirvPair(source->vertex, fragment, "variant");
    EXPECT_TRUE(spirv) << spirv.error().message;
    return shader::Variant{*spirv, {}, {}};
  }
  static core::Result<std::unique_ptr<shader::VariantEvaluator>> constantEvaluator(
      std::shared_ptr<shader::EvaluationCache> cache, const shader::Variant& original) {
    return shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, smallConfig());
  }
  // About 50 pixels across the sphere on a 240-pixel display.
  static shader::EvaluationConfig smallConfig(float distance = 12.0f) {
    shader::EvaluationConfig config;
    config.distance = distance;
    config.display = {.fov_y_deg = 45, .height_px = 240};
    return config;
  }

  static inline render::Renderer* renderer_ = nullptr;
  static inline core::Asset asset_;
  static inline render::Renderer::AssetId asset_id_ = -1;
  static inline std::string failure_;
};

TEST_F(EvaluatorTest, KeysSeparateWordsFromValues) {
  shader::Variant a{{{0x07230203u, 1, 2}, {3, 4}}, {}, {}};
  shader::Variant b = a;
  b.uniforms.push_back({.location = 0, .components = 1, .value = {0.5f}});
  EXPECT_EQ(shader::programKey(a), shader::programKey(b));
  EXPECT_NE(shader::variantKey(a), shader::variantKey(b));
  shader::Variant c = a;
  c.parameter_block = {1, 2, 3, 4};
  EXPECT_NE(shader::variantKey(a), shader::variantKey(c));
  // The same words split differently between the stages are a different program.
  shader::Variant moved{{{0x07230203u, 1}, {2, 3, 4}}, {}, {}};
  EXPECT_NE(shader::programKey(a), shader::programKey(moved));
}

TEST_F(EvaluatorTest, ConstantColoursByHandAndTheCachesAtWork) {
  auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
  shader::Variant original = shaderVariant("constant");
  auto evaluator = constantEvaluator(cache, original);
  ASSERT_TRUE(evaluator) << evaluator.error().message;
  shader::VariantEvaluator& e = **evaluator;
  EXPECT_EQ(e.sampleCount(), 100);           // 20 views × 5 lights
  EXPECT_EQ(e.predictedSampleCount(), 5);    // 5 views × 1 light
  EXPECT_GT(e.footprint(), 20);
  EXPECT_EQ(e.predictedResolution(), e.footprint());  // the default: predict at the footprint

  // The original against its own supersampled reference: only the silhouette's aliasing.
  auto own = e.renderedError(original);
  ASSERT_TRUE(own) << own.error().message;
  EXPECT_GT(own->epsilon, 0);
  EXPECT_LT(own->per_pixel, 0.02);

  // The colour moved to a uniform holding the same value: the same image, the same error.
  shader::Variant same_uniform = fragmentVariant(kUniformFragment);
  same_uniform.uniforms = {{.location = 0, .components = 4, .value = {0.2f, 0.4f, 0.6f, 1}}};
  auto same = e.renderedError(same_uniform);
  ASSERT_TRUE(same) << same.error().message;
  EXPECT_DOUBLE_EQ(same->epsilon, own->epsilon);

  // Blue off by 0.3: every pixel the variant covers adds 0.3² = 0.09 to the error inside the
  // silhouette, and (0.9 − 0.6α)² − (0.6 − 0.6α)² = 0.09 + 0.36(1 − α) on it, where the reference
  // has coverage α. Per covered pixel that is 0.09 plus a silhouette term below 0.36 × the
  // fraction of edge pixels.
  shader::Variant bluer = same_uniform;
  bluer.uniforms[0].value = {0.2f, 0.4f, 0.9f, 1};
  auto off = e.renderedError(bluer);
  ASSERT_TRUE(off) << off.error().message;
  double added_per_pixel = (off->epsilon - own->epsilon) / off->coverage_px;
  EXPECT_GT(added_per_pixel, 0.088);  // 8-bit rounding: 0.6 → 153/255, 0.9 → 230/255
  EXPECT_LT(added_per_pixel, 0.09 + 0.36 * 0.15);
  // The predicted error (5 samples at this footprint) estimates the rendered one.
  auto off_predicted = e.predictedError(bluer);
  ASSERT_TRUE(off_predicted) << off_predicted.error().message;
  EXPECT_NEAR(off_predicted->per_pixel, off->per_pixel, 0.1 * off->per_pixel);
  EXPECT_NEAR(off_predicted->coverage_px, off->coverage_px, 0.1 * off->coverage_px);

  // The same colour through a parameter block.
  shader::Variant block = fragmentVariant(kBlockFragment);
  float tint[4] = {0.2f, 0.4f, 0.6f, 1};
  block.parameter_block.assign(reinterpret_cast<uint8_t*>(tint),
                               reinterpret_cast<uint8_t*>(tint) + sizeof tint);
  auto through_block = e.renderedError(block);
  ASSERT_TRUE(through_block) << through_block.error().message;
  EXPECT_DOUBLE_EQ(through_block->epsilon, own->epsilon);

  // Compiled: original, uniform shader (two variants, one program), block shader.
  EXPECT_EQ(cache->counters().programs_compiled, 3);
  EXPECT_EQ(e.counters().rendered, 4);
  EXPECT_EQ(e.counters().predicted, 1);
  EXPECT_EQ(e.counters().sample_renders, 4 * 100 + 5);

  // The device's work was counted with the render: the same mesh and footprint give the same
  // counts for both colours (no discard), and at least the covered pixels are shaded.
  ASSERT_TRUE(renderer_->canCountWork());
  auto own_work = e.work(original), bluer_work = e.work(bluer);
  ASSERT_TRUE(own_work && bluer_work);
  EXPECT_EQ(own_work->fragment_invocations, bluer_work->fragment_invocations);
  EXPECT_GE(double(own_work->fragment_invocations), 100 * own->coverage_px);
  EXPECT_EQ(own_work->primitives_submitted, 100 * asset_.mesh.triangleCount());
  EXPECT_FALSE(e.work(shaderVariant("noise_phong")));  // never rendered here

  // Re-evaluation is answered from the error cache: no compile, no render, the same value.
  int hits = cache->counters().error_hits;
  auto again = e.renderedError(bluer);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->epsilon, off->epsilon);
  EXPECT_EQ(cache->counters().error_hits, hits + 1);
  EXPECT_EQ(e.counters().rendered, 4);
  EXPECT_EQ(cache->counters().programs_compiled, 3);

  // A second configuration sharing the cache reuses the programs but renders its own images.
  auto far_evaluator =
      shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, smallConfig(24));
  ASSERT_TRUE(far_evaluator) << far_evaluator.error().message;
  auto far = (*far_evaluator)->renderedError(bluer);
  ASSERT_TRUE(far);
  EXPECT_LT((*far_evaluator)->footprint(), e.footprint());
  EXPECT_EQ((*far_evaluator)->counters().rendered, 1);
  EXPECT_EQ(cache->counters().programs_compiled, 3);
  EXPECT_GT(far->per_pixel, 0.088);
  EXPECT_LT(far->per_pixel, 0.09 + 0.36 * 0.3);  // half the footprint: more edge pixels
}

TEST_F(EvaluatorTest, PredictedDomainIsAnEvenSubsetAtTheChosenResolution) {
  auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
  shader::Variant original = shaderVariant("constant");
  shader::EvaluationConfig config = smallConfig();
  config.predicted_views = 4;
  config.predicted_lights = 2;
  config.predicted_resolution_scale = 0.5f;
  config.predicted_min_resolution = 8;
  auto evaluator = shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, config);
  ASSERT_TRUE(evaluator) << evaluator.error().message;
  EXPECT_EQ((*evaluator)->predictedSampleCount(), 8);
  EXPECT_EQ((*evaluator)->predictedResolution(), ((*evaluator)->footprint() + 1) / 2);
  config.predicted_min_resolution = 1000;  // the floor never exceeds the footprint
  auto floored = shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, config);
  ASSERT_TRUE(floored) << floored.error().message;
  EXPECT_EQ((*floored)->predictedResolution(), (*floored)->footprint());
  // Both programs came from the cache after the first compile.
  EXPECT_EQ(cache->counters().programs_compiled, 1);
}

TEST_F(EvaluatorTest, BrokenVariantsFailOnceWithAMessage) {
  auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
  shader::Variant original = shaderVariant("constant");
  auto evaluator = constantEvaluator(cache, original);
  ASSERT_TRUE(evaluator) << evaluator.error().message;
  shader::Variant broken = original;
  broken.spirv.fragment = {0xdeadbeefu, 1, 2, 3, 4, 5};
  auto error = (*evaluator)->renderedError(broken);
  ASSERT_FALSE(error);
  EXPECT_TRUE(test::contains(error.error().message, "magic")) << error.error().message;
  EXPECT_FALSE((*evaluator)->predictedError(broken));
  EXPECT_EQ(cache->counters().compile_failures, 1);  // tried once, then remembered
  // A uniform the program does not have is an error too, not a silent no-op.
  shader::Variant stray = original;
  stray.uniforms = {{.location = 9, .components = 2}};
  auto stray_error = (*evaluator)->renderedError(stray);
  ASSERT_FALSE(stray_error);
  EXPECT_TRUE(test::contains(stray_error.error().message, "location 9"))
      << stray_error.error().message;
  // Bad configurations.
  EXPECT_FALSE(
      shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, smallConfig(0)));
  EXPECT_FALSE(shader::VariantEvaluator::create(nullptr, asset_id_, asset_.mesh, original, {}));
}

// A one-sided square facing away from the first view: the one predicting view sees nothing, so
// the errors are predicted from the whole domain (which sees its front from the opposite view),
// not refused as "alpha 0" (a flat glTF of many primitives failed `duolod shader` so).
TEST_F(EvaluatorTest, PredictingViewsThatMissTheObjectGiveWayToTheWholeDomain) {
  const core::Vec3 first_eye = render::domainSamples(core::Sphere{{0, 0, 0}, 1}, 12.0f).front().eye;
  const core::Vec3 n = core::normalize(first_eye) * -1.0f;
  const core::Vec3 u = core::normalize(
      core::cross(n, std::abs(n.x) < 0.9f ? core::Vec3{1, 0, 0} : core::Vec3{0, 1, 0}));
  const core::Vec3 w = core::cross(n, u);  // (u, w, n) right-handed: the square faces n
  core::Asset square;
  square.source_path = "square";
  square.mesh.positions = {u * -1.0f - w, u - w, u + w, w - u};
  square.mesh.normals.assign(4, n);
  square.mesh.indices = {0, 1, 2, 0, 2, 3};
  square.mesh.submeshes = {{0, 6, 0}};
  square.materials = {core::Material{}};
  auto id = renderer_->uploadAsset(square);
  ASSERT_TRUE(id) << id.error().message;
  auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
  shader::EvaluationConfig config = smallConfig();
  config.predicted_views = 1;
  auto evaluator =
      shader::VariantEvaluator::create(cache, *id, square.mesh, shaderVariant("constant"), config);
  ASSERT_TRUE(evaluator) << evaluator.error().message;
  EXPECT_EQ((*evaluator)->predictedSampleCount(), 100) << "20 views x 5 lights";
  renderer_->releaseAsset(*id);
}

// The procedural shader against two simplifications: fewer noise octaves (a textual edit), and
// its lightest stone colour as a constant. Rendered and predicted errors rank them alike.
TEST_F(EvaluatorTest, NoiseShaderSimplificationsRankAlikeRenderedAndPredicted) {
  auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
  shader::Variant original = shaderVariant("noise_phong");
  auto evaluator =
      shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, smallConfig());
  ASSERT_TRUE(evaluator) << evaluator.error().message;
  auto source = render::loadShaderPair(test::sourcePath("shaders/noise_phong"));
  ASSERT_TRUE(source);
  std::string fragment = source->fragment;
  size_t at = fragment.find("const int OCTAVES = 4;");
  ASSERT_NE(at, std::string::npos);
  fragment.replace(at, 22, "const int OCTAVES = 1;");
  auto one_octave = spirvPair(source->vertex, fragment, "noise_phong_1");
  ASSERT_TRUE(one_octave) << one_octave.error().message;
  shader::Variant flat = fragmentVariant(kUniformFragment);
  flat.uniforms = {{.location = 0, .components = 4, .value = {0.66f, 0.61f, 0.53f, 1}}};

  std::vector<shader::Variant> variants = {original, {*one_octave, {}, {}}, flat};
  std::vector<double> rendered, predicted;
  for (const shader::Variant& variant : variants) {
    auto r = (*evaluator)->renderedError(variant);
    auto p = (*evaluator)->predictedError(variant);
    ASSERT_TRUE(r && p);
    rendered.push_back(r->epsilon);
    predicted.push_back(p->epsilon);
  }
  EXPECT_LT(rendered[0], rendered[1]);
  EXPECT_LT(rendered[1], rendered[2]);
  EXPECT_DOUBLE_EQ(core::spearmanCorrelation(rendered, predicted), 1.0);
}

// The searches price a variant's predicted error from the cost model's instrumented render
// (one compile instead of two): the counters must change no colour, and the variant's CPU-set
// uniforms must be applied to the instrumented copy too.
TEST_F(EvaluatorTest, InstrumentedRenderGivesThePredictedErrorOfThePlainRender) {
  shader::Variant original = shaderVariant("noise_phong");
  shader::Variant flat = fragmentVariant(kUniformFragment);
  flat.uniforms = {{.location = 0, .components = 4, .value = {0.66f, 0.61f, 0.53f, 1}}};
  for (const shader::Variant& variant : {original, flat}) {
    // Separate caches: the second evaluator must not find the first one's error.
    auto plain_cache = std::make_shared<shader::EvaluationCache>(*renderer_);
    auto shared_cache = std::make_shared<shader::EvaluationCache>(*renderer_);
    auto plain = shader::VariantEvaluator::create(plain_cache, asset_id_, asset_.mesh, original,
                                                  smallConfig());
    auto shared = shader::VariantEvaluator::create(shared_cache, asset_id_, asset_.mesh, original,
                                                   smallConfig());
    ASSERT_TRUE(plain && shared);
    ASSERT_EQ((*shared)->predictedResolution(), (*shared)->footprint());
    auto expected = (*plain)->predictedError(variant);
    ASSERT_TRUE(expected) << expected.error().message;

    auto vertex = shader::ir::parseModule(variant.spirv.vertex);
    auto fragment = shader::ir::parseModule(variant.spirv.fragment);
    ASSERT_TRUE(vertex && fragment);
    render::ImageBatch8 images;
    auto profile = shader::profileBlockCounts(*renderer_, asset_id_, *vertex, *fragment,
                                              (*shared)->predictedSamples(),
                                              (*shared)->predictedResolution(), variant.uniforms,
                                              &images);
    ASSERT_TRUE(profile) << profile.error().message;
    auto from_images = (*shared)->predictedErrorFromImages(variant, images);
    ASSERT_TRUE(from_images) << from_images.error().message;
    EXPECT_GT(expected->epsilon, 0.0);
    EXPECT_NEAR(from_images->epsilon, expected->epsilon, 1e-6 * expected->epsilon);
    EXPECT_EQ(from_images->coverage_px, expected->coverage_px);
    // Served from the cache now: no second render.
    auto again = (*shared)->predictedError(variant);
    ASSERT_TRUE(again);
    EXPECT_EQ(again->epsilon, from_images->epsilon);
    EXPECT_EQ((*shared)->counters().predicted, 1);
  }
  // Images of the wrong shape are refused.
  auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
  auto evaluator =
      shader::VariantEvaluator::create(cache, asset_id_, asset_.mesh, original, smallConfig());
  ASSERT_TRUE(evaluator);
  render::ImageBatch8 wrong;
  wrong.width = wrong.height = 3;
  wrong.count = 1;
  wrong.pixels.assign(36, 0);
  EXPECT_FALSE((*evaluator)->predictedErrorFromImages(original, wrong).ok());
}

// The compile-ahead workers make the scorer's cost profiles too (generate's searches): with the
// scorer drawing a simplified mesh uploaded over the asset, each program's predicted cost and
// error are the same bit for bit with the workers' profiles as with the scorer's own, and the
// workers' profiles are the ones used.
TEST_F(EvaluatorTest, ProfilesMadeAheadScoreAsTheScorersOwn) {
  auto source = render::loadShaderPair(test::sourcePath("shaders/noise_phong"));
  ASSERT_TRUE(source) << source.error().message;
  auto vertex = shader::compileToSpirv(source->vertex, shader::Stage::kVertex, "v");
  auto fragment = shader::compileToSpirv(source->fragment, shader::Stage::kFragment, "f");
  ASSERT_TRUE(vertex && fragment);
  auto original = shader::parseProgram(*vertex, *fragment);
  ASSERT_TRUE(original) << original.error().message;
  // The original and a few variants, each one more operation removed.
  std::vector<std::shared_ptr<const shader::ShaderProgram>> programs = {
      std::make_shared<const shader::ShaderProgram>(*original)};
  shader::RuleContext context;
  context.enabled = {true, false, false, false, false, false};
  const std::vector<shader::RuleSite> sites = shader::enumerateSites(*original, context);
  ASSERT_GE(sites.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    auto variant = shader::applyRule(*programs.back(), sites[sites.size() - 1 - k], context);
    if (variant) programs.push_back(std::make_shared<const shader::ShaderProgram>(*variant));
  }
  ASSERT_GE(programs.size(), 3u);

  mesh::SimplifyOptions half;
  half.target_triangles = asset_.mesh.triangleCount() / 2;
  half.record = false;
  const core::Mesh drawn = mesh::simplifyQuadric(asset_.mesh, half).mesh;
  auto drawn_id = renderer_->uploadMesh(asset_id_, drawn);
  ASSERT_TRUE(drawn_id) << drawn_id.error().message;
  auto scores = [&](bool ahead, int* profiled) {
    std::vector<double> values;
    auto cache = std::make_shared<shader::EvaluationCache>(*renderer_);
    auto scoring = shader::ConfigurationScorer::create(*renderer_, cache, *drawn_id, drawn,
                                                       *original, smallConfig());
    EXPECT_TRUE(scoring) << scoring.error().message;
    if (!scoring) return values;
    if (ahead) (*scoring)->enableCompileAhead(asset_, drawn, {});
    shader::VariantScorer scorer = (*scoring)->scorer();
    scorer.prepare(programs);
    for (const auto& program : programs) {
      if (ahead)  // let the workers finish it, so that its profile is theirs
        for (int i = 0;
             i < 6000 && (*scoring)->compileAheadCounts().first < int(&program - &programs[0]) + 1;
             ++i)
          std::this_thread::sleep_for(std::chrono::milliseconds(10));
      auto cost = scorer.predicted_cost(*program);
      auto error = scorer.predicted_error(*program);
      EXPECT_TRUE(cost && error);
      values.push_back(cost ? *cost : -1);
      values.push_back(error ? *error : -1);
    }
    *profiled = (*scoring)->costProfilesAhead();
    return values;
  };
  int profiled_inline = 0, profiled_ahead = 0;
  const std::vector<double> inline_scores = scores(false, &profiled_inline);
  const std::vector<double> ahead_scores = scores(true, &profiled_ahead);
  EXPECT_EQ(profiled_inline, 0);
  EXPECT_EQ(profiled_ahead, int(programs.size()));
  ASSERT_EQ(inline_scores.size(), ahead_scores.size());
  for (size_t i = 0; i < inline_scores.size(); ++i)
    EXPECT_EQ(inline_scores[i], ahead_scores[i])
        << (i % 2 ? "error" : "cost") << " of program " << i / 2;
  renderer_->releaseAsset(*drawn_id);
}

}  // namespace
}  // namespace duolod
