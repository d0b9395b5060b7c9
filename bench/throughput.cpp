// Evaluation throughput: how many view × light renders (and full-domain error evaluations) per
// second the renderer sustains at a footprint s_d, for plain renders and for 4×4 supersampled
// references. Wall clock around the whole call (which ends in a blocking readback, so the GPU has
// finished), median of repeats. This number bounds every optimizer later on.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include "bench_support.hpp"
#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "support/options.hpp"

using namespace duolod;
using bench::median;
using bench::medianSeconds;

namespace {


}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{
      "duolod throughput benchmark: renders and error evaluations per second"};
  std::string asset_path = std::string(DUOLOD_ASSET_DIR) + "/gltf/WaterBottle/WaterBottle.gltf";
  std::string shader_name = "pbr";
  std::vector<int> footprints = {64, 128, 256};
  int repeats = 5, supersample = 4;
  app.add("--asset", asset_path, "asset to render");
  app.add("--shader", shader_name, "duolod shader name");
  app.add("--footprints", footprints, "s_d values in pixels");
  app.add("--repeats", repeats, "timed repeats per cell (median)");
  app.add("--supersample", supersample, "reference k");
  bool shared_textures = false;
  app.flag("--shared-textures", shared_textures,
           "draw the asset's textures from a render::SharedTextures context");
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;

  auto asset = io::loadAsset(asset_path);
  if (!asset) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 1;
  // --shared-textures: the timed renderer draws the textures of another renderer's context
  // (render::SharedTextures, as generate's compile-ahead workers do).
  std::unique_ptr<render::Renderer> owner;
  render::ContextOptions context;
  if (shared_textures) {
    auto made = render::Renderer::create();
    if (!made) return std::fprintf(stderr, "%s\n", made.error().message.c_str()), 1;
    owner = std::move(*made);
    auto uploaded = owner->uploadAsset(*asset);
    if (!uploaded) return std::fprintf(stderr, "%s\n", uploaded.error().message.c_str()), 1;
    auto shared = owner->shareTextures(*uploaded);
    if (!shared) return std::fprintf(stderr, "%s\n", shared.error().message.c_str()), 1;
    context.textures = std::move(*shared);
  }
  auto renderer = render::Renderer::create(context);
  if (!renderer) return std::fprintf(stderr, "%s\n", renderer.error().message.c_str()), 1;
  auto source = render::loadShaderPair(shader_name);
  if (!source) return std::fprintf(stderr, "%s\n", source.error().message.c_str()), 1;
  auto program = (*renderer)->compileProgram(*source);
  if (!program) return std::fprintf(stderr, "%s\n", program.error().message.c_str()), 1;
  auto asset_id = (*renderer)->uploadAsset(*asset);
  if (!asset_id) return std::fprintf(stderr, "%s\n", asset_id.error().message.c_str()), 1;
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  std::vector<render::Sample> samples = render::domainSamples(sphere, sphere.radius * 8);

  std::printf("asset %s (%zu triangles), shader %s, %zu samples (views x lights)\n",
              asset_path.c_str(), asset->mesh.triangleCount(), shader_name.c_str(), samples.size());
  std::printf("device %s; %u hardware threads; median of %d repeats, wall clock\n\n",
              (*renderer)->deviceDescription().c_str(), std::thread::hardware_concurrency(), repeats);
  std::printf("| s_d px | render 100 samples | samples/s | error eval (render+eq.6) | evals/s | "
              "reference %dx%d | ref samples/s |\n", supersample, supersample);
  std::printf("|---:|---:|---:|---:|---:|---:|---:|\n");
  for (int s_d : footprints) {
    render::RenderOptions options{.resolution = s_d};
    render::RenderOptions reference_options{.resolution = s_d, .supersample = supersample};
    auto& r = **renderer;
    auto warm = r.render(*asset_id, *program, samples, options);  // JIT and allocation warm-up
    auto reference = r.renderReference(*asset_id, *program, samples, reference_options);
    if (!warm || !reference) return std::fprintf(stderr, "render failed\n"), 1;
    double render_s = medianSeconds(repeats, [&] {
      return bool(r.render(*asset_id, *program, samples, options));
    });
    double eval_s = medianSeconds(repeats, [&] {
      auto image = r.render(*asset_id, *program, samples, options);
      if (!image) return false;
      volatile double e = metric::imageError(*image, *reference).epsilon;
      (void)e;
      return true;
    });
    double reference_s = medianSeconds(std::max(1, repeats / 2), [&] {
      return bool(r.renderReference(*asset_id, *program, samples, reference_options));
    });
    std::printf("| %d | %.1f ms | %.0f | %.1f ms | %.2f | %.1f ms | %.0f |\n", s_d,
                render_s * 1e3, samples.size() / render_s, eval_s * 1e3, 1.0 / eval_s,
                reference_s * 1e3, samples.size() / reference_s);
  }
  return 0;
}
