// Pair evaluation by real renders for SearchPairs (Liang et al., "Automatic Mesh and Shader Level
// of Detail", §5.3, Algorithm 2 line 6 `Evaluation(M_i, S_j, d)`): the image error of eq. (6)
// against the supersampled original over the view × light domain of §7, and the pair's cost.
#include <algorithm>

#include "duolod/lod.hpp"

namespace duolod::lod {

core::Result<RenderedPairEvaluator> RenderedPairEvaluator::create(
    render::Renderer& renderer, std::vector<render::Renderer::AssetId> meshes,
    std::vector<render::Renderer::ProgramId> shaders, const core::Sphere& bounds, double distance,
    RenderedPairOptions options) {
  if (meshes.empty() || shaders.empty())
    return core::Error{"rendered pair evaluation: needs at least one mesh and one shader"};
  if (options.timing_repeats <= 0 && !options.predicted_cost)
    return core::Error{"rendered pair evaluation: no cost: set timing_repeats or predicted_cost"};
  if (options.supersample < 1)
    return core::Error{"rendered pair evaluation: supersample must be at least 1"};
  RenderedPairEvaluator evaluator;
  evaluator.renderer_ = &renderer;
  evaluator.meshes_ = std::move(meshes);
  evaluator.shaders_ = std::move(shaders);
  evaluator.options_ = std::move(options);
  evaluator.footprint_px_ =
      render::footprintPixels(bounds, static_cast<float>(distance), evaluator.options_.display);
  evaluator.samples_ =
      render::domainSamples(bounds, static_cast<float>(distance), evaluator.options_.domain);
  // f̄(M, S, d) of eq. (1): the original pair, supersampled k×k and box-filtered.
  auto reference = renderer.renderReference(
      evaluator.meshes_[0], evaluator.shaders_[0], evaluator.samples_,
      {.resolution = evaluator.footprint_px_, .supersample = evaluator.options_.supersample});
  if (!reference)
    return core::Error{"rendered pair evaluation: reference: " + reference.error().message};
  if (auto covered = metric::checkReferenceCoverage(*reference); !covered) return covered.error();
  evaluator.reference_ = std::move(*reference);
  double coverage = 0;
  const size_t tile_pixels = size_t(evaluator.reference_.width) * evaluator.reference_.height;
  for (int i = 0; i < evaluator.reference_.count; ++i)
    coverage += metric::tileCoverage(evaluator.reference_.tile(i), tile_pixels);
  evaluator.coverage_px_ = evaluator.reference_.count ? coverage / evaluator.reference_.count : 0;
  evaluator.cache_.assign(evaluator.meshes_.size() * evaluator.shaders_.size(), std::nullopt);
  return evaluator;
}

core::Result<PairEvaluation> RenderedPairEvaluator::evaluate(int mesh, int shader) {
  if (mesh < 0 || size_t(mesh) >= meshes_.size() || shader < 0 || size_t(shader) >= shaders_.size())
    return core::Error{"rendered pair evaluation: no pair (mesh " + std::to_string(mesh) +
                       ", shader " + std::to_string(shader) + ")"};
  std::optional<PairEvaluation>& cached = cache_[size_t(mesh) * shaders_.size() + shader];
  if (cached) return *cached;
  const render::RenderOptions render_options{.resolution = footprint_px_};
  auto image = renderer_->render(meshes_[mesh], shaders_[shader], samples_, render_options);
  if (!image) return core::Error{image.error().message};
  PairEvaluation evaluation;
  evaluation.error = metric::imageError(*image, reference_).epsilon;  // eq. (6)
  if (options_.timing_repeats > 0) {
    // Wall clock around glFinish and readback (RenderStats), median of the repeats: llvmpipe's
    // GL_TIME_ELAPSED is wrong (DESIGN.md, "Measuring cost").
    std::vector<double> seconds;
    for (int repeat = 0; repeat < options_.timing_repeats; ++repeat) {
      render::RenderStats stats;
      auto timed =
          renderer_->render(meshes_[mesh], shaders_[shader], samples_, render_options, &stats);
      if (!timed) return core::Error{timed.error().message};
      seconds.push_back(stats.seconds);
    }
    std::nth_element(seconds.begin(), seconds.begin() + seconds.size() / 2, seconds.end());
    evaluation.cost = seconds[seconds.size() / 2] * 1000.0;
  } else {
    evaluation.cost = options_.predicted_cost(mesh, shader);
  }
  ++rendered_pairs_;
  cached = evaluation;
  return evaluation;
}

}  // namespace duolod::lod
