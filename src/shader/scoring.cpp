// Scoring shader variants for one configuration (shader/scoring.hpp).
#include "shader/scoring.hpp"

#include <algorithm>
#include <cmath>

#include "shader/compile_ahead.hpp"
#include "shader/cost_model.hpp"
#include "shader/instrument.hpp"

namespace duolod::shader {
namespace {

// A few evenly spaced views, centre light only: where the cost model's instrumented run looks
// (block counts per invocation hardly depend on the view; invocation counts are per draw).
std::vector<render::Sample> profileSamples(const std::vector<render::Sample>& domain, int views) {
  int view_count = 0, light_count = 0;
  for (const render::Sample& sample : domain) {
    view_count = std::max(view_count, sample.view_index + 1);
    light_count = std::max(light_count, sample.light_index + 1);
  }
  views = std::clamp(views, 1, std::max(1, view_count));
  std::vector<render::Sample> kept;
  for (int v = 0; v < views; ++v)
    kept.push_back(domain[size_t(v * view_count / views) * light_count]);
  return kept;
}

float srgbToLinear(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

}  // namespace

std::map<uint32_t, std::array<float, 4>> textureAverages(const core::Asset& asset,
                                                         const render::Bindings& bindings) {
  std::map<uint32_t, std::array<float, 4>> averages;
  const core::Material no_material;  // the renderer's fallback: no textures at all
  const core::Material& material = asset.materials.empty() ? no_material : asset.materials.front();
  const std::pair<int, int> textures[] = {
      {bindings.base_color, material.base_color_texture},
      {bindings.metallic_roughness, material.metallic_roughness_texture},
      {bindings.normal_map, material.normal_texture},
      {bindings.occlusion, material.occlusion_texture},
      {bindings.emissive, material.emissive_texture}};
  for (const auto& [binding, index] : textures) {
    if (binding < 0) continue;
    if (index < 0 || index >= static_cast<int>(asset.textures.size())) {
      // The renderer binds a solid texel here (renderer_internal.hpp's bindMaterial): a linear
      // RGBA8 texture, so its samples return exactly texel / 255.
      const std::array<uint8_t, 4>& texel = binding == bindings.normal_map
                                                ? render::kMissingNormalTexel
                                                : render::kMissingTextureTexel;
      std::array<float, 4> solid{};
      for (int c = 0; c < 4; ++c) solid[c] = texel[c] / 255.0f;
      averages[static_cast<uint32_t>(binding)] = solid;
      continue;
    }
    const core::Texture& texture = asset.textures[index];
    const size_t texels = size_t(texture.image.width) * texture.image.height;
    if (texels == 0) continue;
    std::array<double, 4> sum{};
    for (size_t t = 0; t < texels; ++t)
      for (int c = 0; c < 4; ++c) {
        float value = texture.image.pixels[t * 4 + c] / 255.0f;
        sum[c] += texture.srgb && c < 3 ? srgbToLinear(value) : value;
      }
    std::array<float, 4> average{};
    for (int c = 0; c < 4; ++c) average[c] = static_cast<float>(sum[c] / double(texels));
    averages[static_cast<uint32_t>(binding)] = average;
  }
  return averages;
}

core::Result<Variant> evaluationVariant(const ShaderProgram& program) {
  auto words = emitProgram(program, /*optimize=*/true);
  if (!words) return words.error();
  Variant variant;
  variant.spirv = {std::move(words->vertex), std::move(words->fragment)};
  for (const ParameterValue& parameter : program.parameters)
    variant.uniforms.push_back(
        {static_cast<int>(parameter.location), parameter.components, parameter.value});
  return variant;
}

core::Result<std::unique_ptr<ConfigurationScorer>> ConfigurationScorer::create(
    render::Renderer& renderer, std::shared_ptr<EvaluationCache> cache,
    render::Renderer::AssetId asset, const core::Mesh& mesh, const ShaderProgram& original,
    const EvaluationConfig& config) {
  auto original_variant = evaluationVariant(original);
  if (!original_variant) return original_variant.error();
  auto evaluator = VariantEvaluator::create(std::move(cache), asset, mesh, *original_variant, config);
  if (!evaluator) return evaluator.error();
  std::unique_ptr<ConfigurationScorer> scorer(new ConfigurationScorer());
  scorer->renderer_ = &renderer;
  scorer->asset_ = asset;
  scorer->evaluator_ = std::move(*evaluator);
  // The cost model's instrumented run looks where the predicted error looks when that is a
  // single light per view (block counts per invocation hardly depend on the view or the light):
  // then one render serves both. Otherwise a few views, centre light.
  if (config.predicted_lights == 1) {
    scorer->cost_samples_ = scorer->evaluator_->predictedSamples();
  } else {
    std::vector<render::Sample> domain =
        render::domainSamples(core::computeBoundingSphere(mesh), config.distance, config.domain);
    scorer->cost_samples_ = profileSamples(domain, config.predicted_views);
  }
  return scorer;
}

ConfigurationScorer::~ConfigurationScorer() = default;

void ConfigurationScorer::enableCompileAhead(core::Asset asset, render::ContextOptions context) {
  if (cost_samples_.empty()) return;
  compile_ahead_ = std::make_unique<CompileAhead>(std::move(asset), cost_samples_.front(),
                                                  evaluator_->footprint(), context);
}

void ConfigurationScorer::enableCompileAhead(core::Asset asset, const core::Mesh& drawn,
                                             render::ContextOptions context) {
  if (cost_samples_.empty()) return;
  // As the predicted cost's `shared` test, less the variant's parameter block (the workers
  // profile only variants without one).
  const bool keep_images = cost_samples_.size() == evaluator_->predictedSamples().size() &&
                           evaluator_->predictedResolution() == evaluator_->footprint();
  compile_ahead_ = std::make_unique<CompileAhead>(
      std::move(asset),
      CompileAhead::FullProfile{.drawn = drawn,
                                .samples = cost_samples_,
                                .resolution = evaluator_->footprint(),
                                .keep_images = keep_images},
      context);
}

std::pair<int, int> ConfigurationScorer::compileAheadCounts() const {
  if (!compile_ahead_) return {0, 0};
  CompileAhead::Counters counters = compile_ahead_->counters();
  return {counters.compiled, counters.taken};
}

const core::Result<Variant>& ConfigurationScorer::optimised(const ShaderProgram& program) {
  uint64_t hash = programHash(program);
  if (hash != memo_hash_ || !memo_) {
    memo_hash_ = hash;
    memo_profile_.reset();
    std::optional<core::Result<Variant>> ahead;
    if (compile_ahead_) ahead = compile_ahead_->take(hash);
    if (ahead) memo_profile_ = compile_ahead_->takeProfile(hash);
    memo_ = ahead ? std::move(*ahead) : evaluationVariant(program);
  }
  return memo_;
}

std::function<core::Result<std::vector<float>>(const ShaderProgram&, Stage, ir::Id)>
ConfigurationScorer::averageValue(int resolution) {
  if (!averager_)
    averager_ = std::make_unique<ValueAverager>(*renderer_, asset_, evaluator_->predictedSamples(),
                                                AverageOptions{.resolution = resolution});
  return averager_->function();
}

int ConfigurationScorer::averageRenders() const { return averager_ ? averager_->counters().renders : 0; }

VariantScorer ConfigurationScorer::scorer() {
  VariantScorer scorer;
  scorer.predicted_cost = [this](const ShaderProgram& program) -> core::Result<double> {
    // Predicted on the optimised modules: the code that is drawn and timed.
    const core::Result<Variant>& variant = optimised(program);
    if (!variant) return variant.error();
    auto vertex = ir::parseModule(variant->spirv.vertex);
    if (!vertex) return vertex.error();
    auto fragment = ir::parseModule(variant->spirv.fragment);
    if (!fragment) return fragment.error();
    // When the profile looks exactly where the predicted error does (same samples, the
    // footprint's resolution), its images are the variant's predicted-error render too: one
    // compile and render per variant instead of two.
    const bool shared = cost_samples_.size() == evaluator_->predictedSamples().size() &&
                        evaluator_->predictedResolution() == evaluator_->footprint() &&
                        variant->parameter_block.empty();
    render::ImageBatch8 images;
    core::Result<BlockProfile> profile = core::Error{"no profile"};
    if (memo_profile_ && (!shared || memo_profile_->images)) {
      // The workers' profile of this very program (CompileAhead::FullProfile).
      profile = std::move(memo_profile_->profile);
      if (shared) images = std::move(*memo_profile_->images);
      memo_profile_.reset();
      ++cost_profiles_ahead_;
    } else {
      profile = profileBlockCounts(*renderer_, asset_, *vertex, *fragment, cost_samples_,
                                   evaluator_->footprint(), variant->uniforms,
                                   shared ? &images : nullptr);
    }
    if (!profile) return profile.error();
    ++cost_profiles_;
    if (shared)
      if (auto error = evaluator_->predictedErrorFromImages(variant.value(), images); !error)
        return error.error();
    const double draws = static_cast<double>(cost_samples_.size());
    CostFeatures features;
    features.vertex_ops = dynamicOpCounts(*vertex, profile->vertex_executions);
    features.fragment_ops = dynamicOpCounts(*fragment, profile->fragment_executions);
    features.vertex_invocations = static_cast<double>(profile->vertex_invocations) / draws;
    features.fragment_invocations = static_cast<double>(profile->fragment_invocations) / draws;
    return predictCost(features, calibratedCostWeights());
  };
  auto errorOf = [this](const ShaderProgram& program, bool rendered) -> core::Result<double> {
    const core::Result<Variant>& variant = optimised(program);
    if (!variant) return variant.error();
    const Variant& value = variant.value();
    auto error = rendered ? evaluator_->renderedError(value) : evaluator_->predictedError(value);
    if (!error) return error.error();
    return error->per_pixel;
  };
  scorer.prepare = [this](std::span<const std::shared_ptr<const ShaderProgram>> programs) {
    if (compile_ahead_) compile_ahead_->enqueue(programs);
  };
  scorer.predicted_error = [errorOf](const ShaderProgram& program) { return errorOf(program, false); };
  scorer.rendered_error = [errorOf](const ShaderProgram& program) { return errorOf(program, true); };
  return scorer;
}

}  // namespace duolod::shader
