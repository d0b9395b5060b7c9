// Image-driven simplification (the paper's mode, §4.2) against quadric simplification at the same
// triangle count, at one distance: time, and the image error of eq. (6) of both results against
// the same supersampled reference over the 20 views × 5 lights.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "duolod/io.hpp"
#include "duolod/mesh.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "support/options.hpp"

using namespace duolod;

namespace {

std::string defaultMesh() {
  const char* dir = std::getenv("DUOLOD_DATA_DIR");
  std::string root = dir ? dir : "/tmp/duolod-data";
  return root + "/cgal/data/meshes/ChineseDragon-10kv.off";
}

}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{"duolod image-driven vs quadric simplification at one distance"};
  std::string mesh_path = defaultMesh(), shader_name = "noise_phong";
  int pixels = 128;
  double ratio = 0.25;
  int supersample = 4;
  size_t refine_batch = 32;
  app.add("--refine-batch", refine_batch, "candidates priced per rendering batch");
  app.add("--mesh", mesh_path, "mesh file (scripts/fetch-bench-data.sh fetches the default)");
  app.add("--shader", shader_name);
  app.add("--pixels", pixels, "footprint s_d: the object spans this many pixels");
  app.add("--ratio", ratio, "target fraction of the triangles");
  app.add("--supersample", supersample);
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;

  if (!std::filesystem::exists(mesh_path)) {
    std::fprintf(stderr, "%s not found: run scripts/fetch-bench-data.sh first\n", mesh_path.c_str());
    return 1;
  }
  auto asset = io::loadAsset(mesh_path);
  if (!asset) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 1;
  auto renderer = render::Renderer::create();
  if (!renderer) return std::fprintf(stderr, "%s\n", renderer.error().message.c_str()), 1;
  auto& r = **renderer;
  auto shader = render::loadShaderPair(shader_name);
  if (!shader) return std::fprintf(stderr, "%s\n", shader.error().message.c_str()), 1;

  render::Display display;
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  float screen_half = std::tan(display.fov_y_deg * 3.14159265f / 360.0f);
  float distance = sphere.radius / std::sin(std::atan(pixels / float(display.height_px) * screen_half));
  size_t target = size_t(asset->mesh.triangleCount() * ratio);

  mesh::ImageSimplifyOptions options;
  options.target_triangles = target;
  options.distance = distance;
  options.supersample = supersample;
  options.refine_batch = refine_batch;
  mesh::ImageSimplifyStats stats;
  auto start = std::chrono::steady_clock::now();
  auto image_result = mesh::simplifyImage(r, *asset, *shader, options, &stats);
  double image_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!image_result) return std::fprintf(stderr, "%s\n", image_result.error().message.c_str()), 1;

  start = std::chrono::steady_clock::now();
  mesh::SimplifyResult quadric = mesh::simplifyQuadric(
      asset->mesh, {.target_triangles = image_result->mesh.triangleCount(), .record = false});
  double quadric_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Both results against the same reference.
  auto program = r.compileProgram(*shader);
  auto original = r.uploadAsset(*asset);
  if (!program || !original) return std::fprintf(stderr, "setup failed\n"), 1;
  auto samples = render::domainSamples(sphere, distance);
  auto reference = r.renderReference(*original, *program, samples,
                                     {.resolution = stats.footprint_px, .supersample = supersample});
  if (!reference) return std::fprintf(stderr, "%s\n", reference.error().message.c_str()), 1;
  auto errorOf = [&](const core::Mesh& mesh) {
    core::Asset copy = *asset;
    copy.mesh = mesh;
    auto id = r.uploadAsset(copy);
    auto image = r.render(*id, *program, samples, {.resolution = stats.footprint_px});
    r.releaseAsset(*id);
    return metric::imageError(*image, *reference);
  };
  metric::ImageError original_error = errorOf(asset->mesh);
  metric::ImageError image_error = errorOf(image_result->mesh);
  metric::ImageError quadric_error = errorOf(quadric.mesh);

  std::printf("mesh %s (%zu triangles), shader %s, s_d %d px (distance %.3f), reference %dx%d, "
              "100 samples; device %s\n\n",
              mesh_path.c_str(), asset->mesh.triangleCount(), shader_name.c_str(),
              stats.footprint_px, distance, supersample, supersample, r.deviceDescription().c_str());
  std::printf("| mode | triangles | epsilon (eq. 6) | per-pixel | time |\n|---|---:|---:|---:|---:|\n");
  std::printf("| original | %zu | %.3f | %.5f | - |\n", asset->mesh.triangleCount(),
              original_error.epsilon, original_error.per_pixel);
  std::printf("| image-driven | %zu | %.3f | %.5f | %.1f s |\n", image_result->mesh.triangleCount(),
              image_error.epsilon, image_error.per_pixel, image_seconds);
  std::printf("| quadric | %zu | %.3f | %.5f | %.3f s |\n", quadric.mesh.triangleCount(),
              quadric_error.epsilon, quadric_error.per_pixel, quadric_seconds);
  std::printf("\nimage-driven: %zu rendered evaluations in %zu batches (%.1f s rendering), "
              "%zu regions re-rendered, %zu copied, %zu full re-renders, %zu long-edge and %zu wide-region refusals, %zu unseen views skipped, reference %.1f s\n",
              stats.rendered_evaluations, stats.refine_batches, stats.render_seconds,
              stats.refreshed_regions, stats.copied_regions, stats.full_renders, stats.rejected_long_edges, stats.rejected_wide_regions,
              stats.unseen_views, stats.reference_seconds);
  std::printf("predicted change of epsilon %.3f, measured %.3f\n", stats.predicted_change,
              stats.final_error - stats.initial_error);
  std::printf("ratio epsilon image/quadric: %.3f\n", image_error.epsilon / quadric_error.epsilon);
  return 0;
}
