// Error evaluation of shader variants for the search (Liang et al. §5.2; issue 4 item 5): the image
// error of eq. (6) of a variant against the supersampled reference f̄ (eq. 1) of the ORIGINAL
// shader over the view × light domain (§7), at the footprint of a (mesh, distance) configuration,
// and a cheaper predicted error on part of the domain at a lower resolution. llvmpipe compiles
// every program (~0.2 s), so programs are cached by a hash of their SPIR-V words and errors by
// (variant, configuration); the caches are shared between configurations, levels and searches.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "duolod/metric.hpp"
#include "duolod/render.hpp"

namespace duolod::shader {

// A shader variant as a search hands it over: the SPIR-V of both stages, plus the values the CPU
// sets for it. "Moving to parameter" (He et al. 2015, n → average(n)) turns an expression into
// such a value, either a plain uniform at an explicit location or a member of an extra std140
// uniform block.
struct Variant {
  render::SpirvBinary spirv;
  std::vector<render::UniformValue> uniforms;
  std::vector<uint8_t> parameter_block;  // std140 bytes; empty = the variant has no block
};
// Identifies the compiled program: the words of both stages.
uint64_t programKey(const Variant& variant);
// Identifies the rendered images: the words plus every CPU-set value.
uint64_t variantKey(const Variant& variant);

// Compiled programs by programKey (failures too, so a bad variant costs one attempt) and image
// errors by (variantKey, configuration key). Owns the programs it compiles, so it must not outlive
// the renderer.
class EvaluationCache {
 public:
  explicit EvaluationCache(render::Renderer& renderer);
  ~EvaluationCache();
  EvaluationCache(const EvaluationCache&) = delete;
  EvaluationCache& operator=(const EvaluationCache&) = delete;

  render::Renderer& renderer() { return renderer_; }
  core::Result<render::Renderer::ProgramId> program(const Variant& variant);
  std::optional<metric::ImageError> findError(uint64_t variant_key, uint64_t configuration_key);
  void storeError(uint64_t variant_key, uint64_t configuration_key, const metric::ImageError& error);

  struct Counters {
    int programs_compiled = 0;  // distinct variants compiled successfully
    int compile_failures = 0;   // distinct variants that failed (each tried once)
    int program_hits = 0;       // program() answered from the cache
    int error_hits = 0;         // findError() answered from the cache
    double compile_seconds = 0;
  };
  const Counters& counters() const { return counters_; }

 private:
  struct PairHash {
    size_t operator()(const std::pair<uint64_t, uint64_t>& key) const {
      return static_cast<size_t>(key.first ^ (key.second * 0x9e3779b97f4a7c15ull));
    }
  };
  render::Renderer& renderer_;
  std::unordered_map<uint64_t, core::Result<render::Renderer::ProgramId>> programs_;
  std::unordered_map<std::pair<uint64_t, uint64_t>, metric::ImageError, PairHash> errors_;
  Counters counters_;
};

// One (mesh, distance, domain) configuration.
struct EvaluationConfig {
  float distance = 10.0f;  // camera distance from the bounding-sphere centre, in mesh units
  render::Display display;
  render::DomainOptions domain;
  int supersample = 4;  // k of the reference f̄ (eq. 1)
  // The predicted error renders `predicted_views` views (evenly spaced in the domain's order) ×
  // `predicted_lights` lights per view (evenly spaced, the centre light first) at
  // `predicted_resolution_scale` × the footprint, but never below `predicted_min_resolution` (nor
  // above the footprint), against a reference of the same reduced domain.
  // The resolution defaults to the footprint because the error measures aliasing, which changes
  // with resolution: on the Dragon with noise_phong at 128 px (bench/shader_eval, bench/RESULTS.md)
  // predicting at 64 px misranked the close noise variants (Spearman 0.93 over 15 variants, the
  // original predicted worse than 3 octaves), at 128 px it ranked them (0.996); a 49 px footprint
  // predicted at 25 px put the 1-octave version ahead of the original. Fewer samples (5 of 100)
  // alone make the prediction ~15× cheaper than the rendered error.
  int predicted_views = 5;
  int predicted_lights = 1;
  float predicted_resolution_scale = 1.0f;
  int predicted_min_resolution = 64;
  int parameter_binding = 2;  // uniform block binding of Variant::parameter_block
  // Identifies the materials and textures when one cache serves several assets (the mesh itself
  // is hashed by the evaluator).
  uint64_t asset_key = 0;
};

class VariantEvaluator {
 public:
  // Renders the reduced domain's reference of `original` for the configuration (the whole
  // domain's waits for the first renderedError()). `asset` is the uploaded `mesh`
  // (its bounds place the cameras, its content keys the error cache).
  static core::Result<std::unique_ptr<VariantEvaluator>> create(
      std::shared_ptr<EvaluationCache> cache, render::Renderer::AssetId asset,
      const core::Mesh& mesh, const Variant& original, const EvaluationConfig& config);

  // eq. (6) error of the variant over the whole domain at the footprint against f̄ of the original.
  core::Result<metric::ImageError> renderedError(const Variant& variant);
  // The same on the reduced domain at the lower resolution. epsilon and coverage_px are scaled by
  // (footprint / predicted resolution)² so they estimate the full-resolution values; per_pixel is
  // as measured.
  core::Result<metric::ImageError> predictedError(const Variant& variant);
  // predictedError() from images of the variant already rendered on predictedSamples() at
  // predictedResolution() (e.g. by the cost model's instrumented render); cached alike. The
  // variant must not use a parameter block (the images were rendered without one).
  core::Result<metric::ImageError> predictedErrorFromImages(const Variant& variant,
                                                            const render::ImageBatch8& images);
  const std::vector<render::Sample>& predictedSamples() const { return predicted_samples_; }

  // The device's work for the variant's whole-domain render (vertex and fragment invocations, the
  // counts §5.2's cost model multiplies): known once renderedError() has rendered it, when the
  // device can count (Renderer::canCountWork()).
  std::optional<render::WorkCounts> work(const Variant& variant) const;

  int footprint() const { return footprint_; }
  int predictedResolution() const { return predicted_resolution_; }
  int sampleCount() const { return static_cast<int>(samples_.size()); }
  int predictedSampleCount() const { return static_cast<int>(predicted_samples_.size()); }
  std::shared_ptr<EvaluationCache> cache() const { return cache_; }

  struct Counters {
    int rendered = 0;         // renderedError() calls that rendered the whole domain
    int predicted = 0;        // predictedError() calls that rendered the reduced domain
    int sample_renders = 0;   // view × light images rendered, both kinds
    double render_seconds = 0;
    double reference_seconds = 0;
  };
  const Counters& counters() const { return counters_; }

 private:
  VariantEvaluator() = default;
  core::Result<metric::ImageError> evaluate(const Variant& variant, bool predicted);
  // f̄ of the original on `samples`, k×k supersampled.
  core::Result<render::ImageBatchF> renderReference(std::span<const render::Sample> samples,
                                                    int resolution);
  // eq. (6) of rendered images against the reference of their kind; counted and cached.
  metric::ImageError scoreImages(uint64_t variant_key, const render::ImageBatch8& images,
                                 bool predicted);

  std::shared_ptr<EvaluationCache> cache_;
  render::Renderer::AssetId asset_ = -1;
  EvaluationConfig config_;
  int footprint_ = 0, predicted_resolution_ = 0;
  std::vector<render::Sample> samples_, predicted_samples_;
  Variant original_;
  render::ImageBatchF reference_;  // of the whole domain: rendered on first use
  render::ImageBatchF predicted_reference_;
  uint64_t configuration_key_ = 0, predicted_configuration_key_ = 0;
  std::unordered_map<uint64_t, render::WorkCounts> work_;  // by variantKey
  Counters counters_;
};

}  // namespace duolod::shader
