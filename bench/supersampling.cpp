// Aliasing against distance: the image error (eq. 6) of a plain 1×1 render against the k×k
// supersampled reference f̄ (eq. 1), over the paper's 20 views × 5 lights, as the object moves away.
// For a smooth shader the error is edge aliasing only and vanishes with the footprint; for a
// high-frequency shader (procedural noise) the per-pixel error grows as more of the pattern falls
// inside each pixel — the reason the paper measures against a supersampled reference.

#include <cstdio>

#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "support/options.hpp"

using namespace duolod;

int main(int argc, char** argv) {
  duolod::bench::Options app{"duolod supersampling benchmark: 1x1 vs kxk error against distance"};
  std::string asset_path = std::string(DUOLOD_ASSET_DIR) + "/obj/spot/spot.obj";
  std::vector<std::string> shaders = {"constant", "pbr", "noise_phong"};
  std::vector<int> footprints = {256, 128, 64, 32, 16};
  int supersample = 4;
  render::Display display;
  app.add("--asset", asset_path);
  app.add("--shaders", shaders);
  app.add("--footprints", footprints, "s_d values (pixels across the bounding sphere)");
  app.add("--supersample", supersample);
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;

  auto asset = io::loadAsset(asset_path);
  if (!asset) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 1;
  auto renderer = render::Renderer::create();
  if (!renderer) return std::fprintf(stderr, "%s\n", renderer.error().message.c_str()), 1;
  auto& r = **renderer;
  auto asset_id = r.uploadAsset(*asset);
  if (!asset_id) return std::fprintf(stderr, "%s\n", asset_id.error().message.c_str()), 1;
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);

  std::printf("asset %s (%zu triangles); reference %dx%d box filter; 20 views x 5 lights\n",
              asset_path.c_str(), asset->mesh.triangleCount(), supersample, supersample);
  std::printf("display %d px high, fov %.0f deg\n\n", display.height_px, display.fov_y_deg);
  std::printf("| shader | s_d px | distance | epsilon (eq. 6) | coverage px | per-pixel error | "
              "interior px | interior per-pixel (shading aliasing) |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const std::string& name : shaders) {
    auto source = render::loadShaderPair(name);
    if (!source) return std::fprintf(stderr, "%s\n", source.error().message.c_str()), 1;
    auto program = r.compileProgram(*source);
    if (!program) return std::fprintf(stderr, "%s\n", program.error().message.c_str()), 1;
    for (int s_d : footprints) {
      // Distance at which the bounding sphere spans s_d pixels on the display.
      float screen_half = std::tan(display.fov_y_deg * 3.14159265f / 360.0f);
      float distance = sphere.radius / std::sin(std::atan(s_d / float(display.height_px) * screen_half));
      int resolution = render::footprintPixels(sphere, distance, display);
      auto samples = render::domainSamples(sphere, distance);
      auto reference = r.renderReference(*asset_id, *program, samples,
                                         {.resolution = resolution, .supersample = supersample});
      auto image = r.render(*asset_id, *program, samples, {.resolution = resolution});
      if (!reference || !image) return std::fprintf(stderr, "render failed\n"), 1;
      metric::ImageError error = metric::imageError(*image, *reference);
      // Split off the silhouette: pixels fully covered in both images see only shading aliasing.
      double interior_error = 0, interior_pixels = 0;
      for (int t = 0; t < image->count; ++t) {
        const uint8_t* a = image->tile(t);
        const float* b = reference->tile(t);
        for (int p = 0; p < image->width * image->height; ++p) {
          if (a[p * 4 + 3] != 255 || b[p * 4 + 3] < 0.999f) continue;
          interior_error += metric::tileSquaredError(a + p * 4, b + p * 4, 1);
          interior_pixels += 1;
        }
      }
      std::printf("| %s | %d | %.3f | %.3f | %.1f | %.5f | %.1f | %.6f |\n", name.c_str(),
                  resolution, distance, error.epsilon, error.coverage_px, error.per_pixel,
                  interior_pixels / image->count,
                  interior_pixels > 0 ? interior_error / interior_pixels : 0.0);
    }
  }
  return 0;
}
