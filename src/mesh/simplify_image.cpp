// Image-driven simplification (Liang et al. §4.2, §5.1): the collapse engine with the image cost
// model, set up at one distance of the paper's view × light domain.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "duolod/mesh.hpp"
#include "duolod/metric.hpp"
#include "mesh/collapse_engine.hpp"
#include "mesh/image_cost.hpp"

namespace duolod::mesh {
namespace {

// What one run made in the renderer, released however the run ends (an error return included).
class RendererScratch {
 public:
  explicit RendererScratch(render::Renderer& renderer) : renderer_(renderer) {}
  ~RendererScratch() {
    for (render::Renderer::AssetId asset : assets_) renderer_.releaseAsset(asset);
    for (render::Renderer::ProgramId program : programs_) renderer_.releaseProgram(program);
  }
  RendererScratch(const RendererScratch&) = delete;
  RendererScratch& operator=(const RendererScratch&) = delete;
  core::Result<render::Renderer::AssetId> asset(core::Result<render::Renderer::AssetId> made) {
    if (made) assets_.push_back(*made);
    return made;
  }
  core::Result<render::Renderer::ProgramId> program(
      core::Result<render::Renderer::ProgramId> made) {
    if (made) programs_.push_back(*made);
    return made;
  }

 private:
  render::Renderer& renderer_;
  std::vector<render::Renderer::AssetId> assets_;
  std::vector<render::Renderer::ProgramId> programs_;
};

}  // namespace

core::Result<SimplifyResult> simplifyImage(render::Renderer& renderer, const core::Asset& asset,
                                           const render::GlslSource& shader,
                                           const ImageSimplifyOptions& options,
                                           ImageSimplifyStats* stats) {
  using core::Error;
  auto start = std::chrono::steady_clock::now();
  if (!(options.distance > 0 && std::isfinite(options.distance)))
    return Error{"image-driven simplification needs a finite distance > 0"};
  // Each option named, with its range (a tile of 0 pixels or a batch of 0 candidates changed
  // the algorithm without a word).
  auto refuse = [](const std::string& option, const std::string& range, double value) {
    return Error{"image-driven simplification: " + option + " must be " + range + ", got " +
                 std::to_string(value)};
  };
  if (options.supersample < 1 || options.supersample > 16)
    return refuse("supersample", "in [1, 16]", options.supersample);
  if (options.tile_size < 1) return refuse("tile_size", ">= 1", options.tile_size);
  if (options.refine_batch < 1) return refuse("refine_batch", ">= 1", double(options.refine_batch));
  if (!(options.max_edge_pixels > 0))
    return refuse("max_edge_pixels", "> 0", options.max_edge_pixels);
  if (options.display.height_px < 1)
    return refuse("display.height_px", ">= 1", options.display.height_px);
  if (!(options.display.fov_y_deg > 0 && options.display.fov_y_deg < 180))
    return refuse("display.fov_y_deg", "in (0, 180)", options.display.fov_y_deg);
  if (std::isnan(options.target_error))
    return refuse("target_error", "a number", options.target_error);
  core::Asset prepared_asset = asset;
  prepared_asset.mesh = prepareMesh(options.start ? *options.start : asset.mesh);
  if (prepared_asset.mesh.triangleCount() == 0) return Error{"the mesh has no valid triangles"};

  RendererScratch scratch(renderer);
  auto program = scratch.program(renderer.compileProgram(shader));
  if (!program) return program.error();
  auto region_program = scratch.program(renderer.compileRegionProgram(shader));
  if (!region_program) return region_program.error();
  // The meshes drawn here share the original's materials and textures, and its bounding sphere
  // (uploadMesh), as generate's candidates do when their pairs are rendered: object-space
  // procedural shading (noise_phong scales its noise by the radius) is then the same as there.
  core::Result<render::Renderer::AssetId> original_id = options.uploaded;
  if (options.uploaded < 0) original_id = scratch.asset(renderer.uploadAsset(asset));
  if (!original_id) return original_id.error();
  auto prepared_id = scratch.asset(renderer.uploadMesh(*original_id, prepared_asset.mesh));
  if (!prepared_id) return prepared_id.error();

  // Frame everything by the original's bounding sphere, as the LOD levels will be.
  core::Sphere sphere = core::computeBoundingSphere(asset.mesh);
  const int resolution = render::footprintPixels(sphere, options.distance, options.display);
  std::vector<render::Sample> samples =
      render::domainSamples(sphere, options.distance, options.domain);
  core::Result<render::ImageBatchF> reference = render::ImageBatchF{};
  if (options.reference) {
    if (options.reference->count != int(samples.size()) || options.reference->width != resolution)
      return Error{"image-driven simplification: the given reference does not match the domain (" +
                   std::to_string(options.reference->count) + " samples of " +
                   std::to_string(options.reference->width) + " px, expected " +
                   std::to_string(samples.size()) + " of " + std::to_string(resolution) + ")"};
  } else {
    reference = renderer.renderReference(*original_id, *program, samples,
                                         {.resolution = resolution,
                                          .supersample = options.supersample});
    if (!reference) return reference.error();
    if (auto covered = metric::checkReferenceCoverage(*reference); !covered) return covered.error();
  }
  const render::ImageBatchF& reference_images = options.reference ? *options.reference : *reference;
  auto current = renderer.render(*prepared_id, *program, samples, {.resolution = resolution});
  if (!current) return current.error();
  const double initial_error = metric::imageError(*current, reference_images).epsilon;
  double reference_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  ImageCostSetup setup;
  setup.renderer = &renderer;
  setup.asset = *prepared_id;
  setup.region_program = *region_program;
  setup.program = *program;
  setup.samples = samples;
  setup.lights_per_view = int(samples.size() / render::viewDirections(options.domain.views).size());
  setup.resolution = resolution;
  setup.tile_size = options.tile_size;
  setup.max_edge_pixels = options.max_edge_pixels;
  setup.refine_batch = options.refine_batch;
  setup.reference = &reference_images;
  setup.current = std::move(current.value());
  for (const core::Submesh& sub : prepared_asset.mesh.submeshes)
    setup.group_material.push_back(sub.material);
  ImageCostModel model(std::move(setup));

  EngineOptions engine_options;
  engine_options.target_triangles = options.target_triangles;
  engine_options.target_error = options.target_error;
  engine_options.endpoint_only = true;  // §4.2: place-to-endpoints
  engine_options.lock_border = options.lock_border;
  engine_options.allow_material_border_collapse = options.allow_material_border_collapse;
  engine_options.record = options.record;
  // A start already at or over the error target affords no collapse (one that lowers ε is rare):
  // return it as it is rather than price every edge with renders to find none. The LOD cascade
  // meets this at most far levels (the previous level's coarsest mesh is already at this one's
  // bound): 5 of the Dragon's 9 levels, ~8 s of rendering.
  if (std::isfinite(options.target_error) && initial_error >= options.target_error)
    engine_options.target_triangles = prepared_asset.mesh.triangleCount();
  // Only the survivor's edges are re-priced: their geometry changed. Edges one ring further keep
  // their rendered cost, slightly stale (their pixels changed a little), which costs no quality
  // measurably and saves most of the rendering (see bench/RESULTS.md).
  engine_options.invalidation_ring = 1;
  engine_options.progress = options.progress;
  SimplifyResult result = runCollapseEngine(prepared_asset.mesh, model, engine_options);

  // The result's error, rendered whole: the model's running sum is only refreshed lazily.
  double final_error = initial_error;
  if (model.failure().empty()) {
    auto simplified_id = scratch.asset(renderer.uploadMesh(*original_id, result.mesh));
    if (!simplified_id) return simplified_id.error();
    auto image = renderer.render(*simplified_id, *program, samples, {.resolution = resolution});
    if (!image) return image.error();
    final_error = metric::imageError(*image, reference_images).epsilon;
    if (std::getenv("DUOLOD_DEBUG")) {
      double tracked = model.currentError();
      double from_images = metric::imageError(model.currentImages(), reference_images).epsilon;
      double images_vs_truth = metric::imageError(model.currentImages(), *image).epsilon;
      std::fprintf(stderr,
                   "image model: tracked error %.4f, of its images %.4f, true %.4f; its images "
                   "differ from a full render by %.4f\n",
                   tracked, from_images, final_error, images_vs_truth);
    }
  }
  if (!model.failure().empty()) return Error{"image-driven simplification: " + model.failure()};
  if (stats) {
    const ImageCostStats& s = model.stats();
    stats->footprint_px = resolution;
    stats->initial_error = initial_error;
    stats->final_error = final_error;
    stats->rendered_evaluations = s.rendered_evaluations;
    stats->refine_batches = s.refine_batches;
    stats->refreshed_regions = s.refreshed_regions;
    stats->copied_regions = s.copied_regions;
    stats->full_renders = s.full_renders;
    stats->rejected_long_edges = s.rejected_long_edges;
    stats->rejected_wide_regions = s.rejected_wide_regions;
    stats->unseen_views = s.unseen_views;
    stats->reference_seconds = reference_seconds;
    stats->render_seconds = s.render_seconds;
    stats->predicted_change = s.predicted_change;
    stats->total_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return result;
}

}  // namespace duolod::mesh
