// Variant error evaluation with program and error caches (see evaluate.hpp). Errors follow Liang et
// al. eq. (6) through metric::imageError against the k×k-supersampled reference of eq. (1).
#include "shader/evaluate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <type_traits>

#include "core/clock.hpp"

namespace duolod::shader {
namespace {
using core::Error;

// Folds the bytes of plain values into an FNV-1a hash (core::hashBytes); sizes go in first so
// that adjacent sequences cannot alias.
template <class T>
uint64_t mixValue(uint64_t hash, const T& value) {
  static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>);
  return core::hashBytes(&value, sizeof value, hash);
}
template <class T>
uint64_t mixSequence(uint64_t hash, const std::vector<T>& values) {
  hash = mixValue(hash, values.size());
  return values.empty() ? hash : core::hashBytes(values.data(), values.size() * sizeof(T), hash);
}

uint64_t meshKey(const core::Mesh& mesh) {
  uint64_t hash = mixSequence(0xcbf29ce484222325ull, mesh.positions);
  hash = mixSequence(hash, mesh.normals);
  hash = mixSequence(hash, mesh.uv0);
  hash = mixSequence(hash, mesh.indices);
  for (const core::Submesh& sub : mesh.submeshes) {
    hash = mixValue(hash, sub.first_index);
    hash = mixValue(hash, sub.index_count);
    hash = mixValue(hash, sub.material);
  }
  return hash;
}

// Every view whose index is a multiple of views/kept_views (evenly spaced), and within it
// kept_lights evenly spaced lights (index 0, the centre light, first).
std::vector<render::Sample> reducedDomain(const std::vector<render::Sample>& samples,
                                          int kept_views, int kept_lights) {
  int views = 0, lights = 0;
  for (const render::Sample& s : samples) {
    views = std::max(views, s.view_index + 1);
    lights = std::max(lights, s.light_index + 1);
  }
  kept_views = std::clamp(kept_views, 1, views);
  kept_lights = std::clamp(kept_lights, 1, lights);
  std::vector<render::Sample> reduced;
  for (int v = 0; v < kept_views; ++v)
    for (int l = 0; l < kept_lights; ++l) {
      int view = v * views / kept_views, light = l * lights / kept_lights;
      reduced.push_back(samples[size_t(view) * lights + light]);  // view-major order
    }
  return reduced;
}

using core::internal::secondsSince;

}  // namespace

uint64_t programKey(const Variant& variant) {
  return mixSequence(mixSequence(0xcbf29ce484222325ull, variant.spirv.vertex),
                     variant.spirv.fragment);
}

uint64_t variantKey(const Variant& variant) {
  uint64_t hash = mixValue(programKey(variant), variant.uniforms.size());
  for (const render::UniformValue& uniform : variant.uniforms) {
    hash = mixValue(hash, uniform.location);
    hash = mixValue(hash, uniform.components);
    for (int c = 0; c < uniform.components && c < 4; ++c) hash = mixValue(hash, uniform.value[c]);
  }
  return mixSequence(hash, variant.parameter_block);
}

// ---------------------------------------------------------------------------------------------

EvaluationCache::EvaluationCache(render::Renderer& renderer) : renderer_(renderer) {}

EvaluationCache::~EvaluationCache() {
  for (auto& [key, program] : programs_)
    if (program) renderer_.releaseProgram(*program);
}

core::Result<render::Renderer::ProgramId> EvaluationCache::program(const Variant& variant) {
  uint64_t key = programKey(variant);
  if (auto found = programs_.find(key); found != programs_.end()) {
    ++counters_.program_hits;
    return found->second;
  }
  auto start = std::chrono::steady_clock::now();
  core::Result<render::Renderer::ProgramId> compiled = renderer_.compileProgram(variant.spirv);
  counters_.compile_seconds += secondsSince(start);
  if (compiled)
    ++counters_.programs_compiled;
  else
    ++counters_.compile_failures;
  programs_.emplace(key, compiled);
  return compiled;
}

std::optional<metric::ImageError> EvaluationCache::findError(uint64_t variant_key,
                                                             uint64_t configuration_key) {
  auto found = errors_.find({variant_key, configuration_key});
  if (found == errors_.end()) return std::nullopt;
  ++counters_.error_hits;
  return found->second;
}

void EvaluationCache::storeError(uint64_t variant_key, uint64_t configuration_key,
                                 const metric::ImageError& error) {
  errors_[{variant_key, configuration_key}] = error;
}

// ---------------------------------------------------------------------------------------------

core::Result<std::unique_ptr<VariantEvaluator>> VariantEvaluator::create(
    std::shared_ptr<EvaluationCache> cache, render::Renderer::AssetId asset,
    const core::Mesh& mesh, const Variant& original, const EvaluationConfig& config) {
  if (!cache) return Error{"VariantEvaluator: no evaluation cache"};
  if (!(config.distance > 0) || config.supersample < 1 || config.predicted_views < 1 ||
      config.predicted_lights < 1 || !(config.predicted_resolution_scale > 0))
    return Error{"VariantEvaluator: distance, supersampling and the predicted domain must be "
                 "positive"};
  if (mesh.positions.empty()) return Error{"VariantEvaluator: the mesh has no vertices"};
  std::unique_ptr<VariantEvaluator> evaluator(new VariantEvaluator());
  VariantEvaluator& e = *evaluator;
  e.cache_ = std::move(cache);
  e.asset_ = asset;
  e.config_ = config;
  core::Sphere bounds = core::computeBoundingSphere(mesh);
  e.footprint_ = render::footprintPixels(bounds, config.distance, config.display);
  e.predicted_resolution_ =
      std::min(e.footprint_,
               std::max(std::max(1, config.predicted_min_resolution),
                        static_cast<int>(std::lround(e.footprint_ *
                                                     config.predicted_resolution_scale))));
  e.samples_ = render::domainSamples(bounds, config.distance, config.domain);
  e.predicted_samples_ = reducedDomain(e.samples_, config.predicted_views, config.predicted_lights);

  // Everything that changes the images: mesh, materials, footprint, domain, reference k.
  uint64_t key = mixValue(meshKey(mesh), config.asset_key);
  key = mixValue(key, config.distance);
  key = mixValue(key, e.footprint_);
  key = mixValue(key, config.domain.views);
  key = mixValue(key, config.domain.light_cross_arm);
  key = mixValue(key, config.domain.light_cross_center);
  key = mixValue(key, config.domain.light_rotation_deg);
  key = mixValue(key, config.supersample);
  key = mixValue(key, config.parameter_binding);
  e.configuration_key_ = key;
  key = mixValue(key, e.predicted_resolution_);
  key = mixValue(key, config.predicted_views);
  key = mixValue(key, config.predicted_min_resolution);
  e.predicted_configuration_key_ = mixValue(key, config.predicted_lights);

  e.original_ = original;
  auto predicted = e.renderReference(e.predicted_samples_, e.predicted_resolution_);
  if (!predicted) return predicted.error();
  e.predicted_reference_ = std::move(predicted.value());
  if (!metric::checkReferenceCoverage(e.predicted_reference_) &&
      e.predicted_samples_.size() < e.samples_.size()) {
    // The few predicting views can all miss an object the domain sees (a one-sided plane seen
    // from behind or edge-on by each): an error predicted from them would be 0 for every
    // variant. Predict from the whole domain instead.
    e.predicted_samples_ = e.samples_;
    e.predicted_configuration_key_ = mixValue(e.predicted_configuration_key_, e.samples_.size());
    predicted = e.renderReference(e.predicted_samples_, e.predicted_resolution_);
    if (!predicted) return predicted.error();
    e.predicted_reference_ = std::move(predicted.value());
  }
  if (auto covered = metric::checkReferenceCoverage(e.predicted_reference_); !covered)
    return covered.error();
  return evaluator;
}

core::Result<render::ImageBatchF> VariantEvaluator::renderReference(
    std::span<const render::Sample> samples, int resolution) {
  auto program = cache_->program(original_);
  if (!program) return Error{"VariantEvaluator: the original shader: " + program.error().message};
  render::Renderer& renderer = cache_->renderer();
  if (auto ok = renderer.setProgramUniforms(*program, original_.uniforms); !ok) return ok.error();
  if (auto ok = renderer.setParameterBlock(config_.parameter_binding, original_.parameter_block);
      !ok)
    return ok.error();
  auto start = std::chrono::steady_clock::now();
  auto reference = renderer.renderReference(
      asset_, *program, samples, {.resolution = resolution, .supersample = config_.supersample});
  counters_.reference_seconds += secondsSince(start);
  return reference;
}

core::Result<metric::ImageError> VariantEvaluator::renderedError(const Variant& variant) {
  return evaluate(variant, false);
}

core::Result<metric::ImageError> VariantEvaluator::predictedError(const Variant& variant) {
  return evaluate(variant, true);
}

std::optional<render::WorkCounts> VariantEvaluator::work(const Variant& variant) const {
  auto found = work_.find(variantKey(variant));
  if (found == work_.end()) return std::nullopt;
  return found->second;
}

core::Result<metric::ImageError> VariantEvaluator::evaluate(const Variant& variant,
                                                            bool predicted) {
  uint64_t variant_key = variantKey(variant);
  uint64_t configuration_key = predicted ? predicted_configuration_key_ : configuration_key_;
  if (auto cached = cache_->findError(variant_key, configuration_key)) return *cached;

  // The whole domain's f̄ only when a whole-domain error is first asked for: a GP search scores
  // on the reduced domain, and `generate` never asks (on the Dragon at 96 px the 4×4 reference
  // is 15 M shaded pixels per configuration).
  if (!predicted && reference_.count == 0) {
    auto reference = renderReference(samples_, footprint_);
    if (!reference) return reference.error();
    reference_ = std::move(*reference);
  }
  auto program = cache_->program(variant);
  if (!program) return program.error();
  render::Renderer& renderer = cache_->renderer();
  if (auto ok = renderer.setProgramUniforms(*program, variant.uniforms); !ok) return ok.error();
  if (auto ok = renderer.setParameterBlock(config_.parameter_binding, variant.parameter_block); !ok)
    return ok.error();
  const std::vector<render::Sample>& samples = predicted ? predicted_samples_ : samples_;
  int resolution = predicted ? predicted_resolution_ : footprint_;
  auto start = std::chrono::steady_clock::now();
  render::RenderStats stats;
  bool count_work = !predicted && renderer.canCountWork();
  auto images = renderer.render(asset_, *program, samples,
                                {.resolution = resolution, .count_work = count_work}, &stats);
  if (!images) return images.error();
  if (count_work) work_[variant_key] = stats.work;
  counters_.render_seconds += secondsSince(start);
  counters_.sample_renders += static_cast<int>(samples.size());
  return scoreImages(variant_key, *images, predicted);
}

core::Result<metric::ImageError> VariantEvaluator::predictedErrorFromImages(
    const Variant& variant, const render::ImageBatch8& images) {
  if (!variant.parameter_block.empty())
    return Error{"predicted error from images: the variant has a parameter block"};
  if (images.count != static_cast<int>(predicted_samples_.size()) ||
      images.width != predicted_resolution_ || images.height != predicted_resolution_)
    return Error{"predicted error from images: " + std::to_string(images.count) + " images of " +
                 std::to_string(images.width) + " px, expected " +
                 std::to_string(predicted_samples_.size()) + " of " +
                 std::to_string(predicted_resolution_)};
  const uint64_t variant_key = variantKey(variant);
  if (auto cached = cache_->findError(variant_key, predicted_configuration_key_)) return *cached;
  return scoreImages(variant_key, images, /*predicted=*/true);
}

metric::ImageError VariantEvaluator::scoreImages(uint64_t variant_key,
                                                 const render::ImageBatch8& images,
                                                 bool predicted) {
  metric::ImageError error =
      metric::imageError(images, predicted ? predicted_reference_ : reference_);
  if (predicted) {
    ++counters_.predicted;
    // eq. (6) sums over pixels: rescale to the footprint's pixel count.
    const int resolution = predicted_resolution_;
    double scale = double(footprint_) * footprint_ / (double(resolution) * resolution);
    error.epsilon *= scale;
    error.coverage_px *= scale;
  } else {
    ++counters_.rendered;
  }
  cache_->storeError(variant_key, predicted ? predicted_configuration_key_ : configuration_key_,
                     error);
  return error;
}

}  // namespace duolod::shader
