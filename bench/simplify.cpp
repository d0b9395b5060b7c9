// Simplification benchmark: duolod's quadric simplifier against meshoptimizer 0.18's
// meshopt_simplify (the baseline, same run, same machine) on CGAL's demo meshes and the shared
// assets, at 50%, 10% and 1% of the triangles. Per cell: time (median of repeats), output
// triangles, and the symmetric Hausdorff and mean surface distance to the input (duolod's
// surfaceDistance for both, so the measure is the same), with the ratios ours / meshopt.
//
// Meshes: positional arguments, or the defaults below. CGAL's meshes come from the Debian package
// libcgal-demo: run scripts/fetch-bench-data.sh [DIR] and pass --data-dir DIR (default
// $DUOLOD_DATA_DIR, else /tmp/duolod-data). Meshes are loaded as they are (no generated normals or
// tangents); duolod uses whatever attributes a file has, meshoptimizer sees positions only.
#include <CLI/CLI.hpp>
#include <meshoptimizer.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "duolod/io.hpp"
#include "duolod/mesh.hpp"

using namespace duolod;

namespace {

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

template <class F>
double medianSeconds(int repeats, F&& run) {
  std::vector<double> times;
  for (int r = 0; r < repeats; ++r) {
    auto start = std::chrono::steady_clock::now();
    run();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return median(times);
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      size_t colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  return "unknown CPU";
}

std::string attributeList(const core::Mesh& m) {
  std::string s = "position";
  if (!m.normals.empty()) s += "+normal";
  if (!m.tangents.empty()) s += "+tangent";
  if (!m.uv0.empty()) s += "+uv0";
  if (!m.colors.empty()) s += "+color";
  return s;
}

double ratio(double ours, double theirs) {
  if (theirs > 0) return ours / theirs;
  return ours > 0 ? INFINITY : 1.0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"duolod simplification benchmark: quadric vs meshopt_simplify 0.18"};
  std::vector<std::string> meshes;
  std::string data_dir;
  if (const char* env = std::getenv("DUOLOD_DATA_DIR")) data_dir = env;
  if (data_dir.empty()) data_dir = "/tmp/duolod-data";
  std::vector<double> ratios = {0.5, 0.1, 0.01};
  int repeats = 3;
  size_t samples = 100000;
  bool endpoint = false;
  float attribute_weight = 1.0f;
  app.add_option("meshes", meshes, "mesh files (.off .obj .ply .gltf .glb); default: CGAL + shared");
  app.add_option("--data-dir", data_dir, "folder given to scripts/fetch-bench-data.sh")
      ->capture_default_str();
  app.add_option("--ratios", ratios, "target triangle ratios")->capture_default_str();
  app.add_option("--repeats", repeats, "timed repeats per cell (median)")->capture_default_str();
  app.add_option("--samples", samples, "surface samples per mesh and direction (0: no distances)")
      ->capture_default_str();
  app.add_flag("--endpoint", endpoint, "duolod with Placement::kEndpoint (like meshopt 0.18)");
  app.add_option("--attribute-weight", attribute_weight, "duolod SimplifyOptions::attribute_weight")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  if (meshes.empty()) {
    std::string cgal = data_dir + "/cgal/data/meshes/";
    std::string shared = std::string(DUOLOD_ASSET_DIR) + "/";
    meshes = {cgal + "bunny00.off",
              cgal + "armadillo.off",
              cgal + "ChineseDragon-10kv.off",
              cgal + "fandisk.off",
              shared + "gltf/WaterBottle/WaterBottle.gltf",
              shared + "gltf/Avocado/Avocado.gltf",
              shared + "obj/spot/spot.obj"};
  }

  std::printf("machine: %s, %u hardware threads (nproc); single-threaded runs\n",
              cpuModel().c_str(), std::thread::hardware_concurrency());
  std::printf("duolod simplifyQuadric (placement %s, record off) vs meshopt_simplify %d.%02d "
              "(target_error 1.0, options 0); time = median of %d; distances = duolod "
              "surfaceDistance, %zu samples each way, in 1e-3 of the bounding-box diagonal\n\n",
              endpoint ? "endpoint" : "optimal", MESHOPTIMIZER_VERSION / 1000,
              (MESHOPTIMIZER_VERSION % 1000) / 10, repeats, samples);
  std::printf("| mesh | tris in | target | tris ours | tris meshopt | ms ours | ms meshopt | "
              "time ratio | Hausdorff ours | Hausdorff meshopt | ratio | mean ours | mean meshopt "
              "| ratio |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");

  std::vector<std::string> skipped;
  double worst_time = 0, worst_hausdorff = 0, worst_mean = 0;
  std::vector<std::string> progressive_lines;
  for (const std::string& path : meshes) {
    if (!std::filesystem::exists(path)) {
      skipped.push_back(path);
      continue;
    }
    io::LoadOptions load{.load_textures = false, .generate_normals = false,
                         .generate_tangents = false, .weld = true};
    auto asset = io::loadAsset(path, load);
    if (!asset) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), asset.error().message.c_str());
      continue;
    }
    const core::Mesh& input = asset->mesh;
    const std::string name = std::filesystem::path(path).stem().string();
    const double diagonal = core::length(core::computeBounds(input).size());
    const double unit = diagonal > 0 ? diagonal * 1e-3 : 1.0;
    std::fprintf(stderr, "%s: %zu triangles, %zu vertices, %s\n", name.c_str(),
                 input.triangleCount(), input.vertexCount(), attributeList(input).c_str());

    // §5.1: one recorded run down to 1%, then K = 500 candidates extracted in one sweep.
    {
      mesh::SimplifyOptions options{.target_triangles = input.triangleCount() / 100,
                                    .record = true};
      auto recorded = mesh::simplifyQuadric(input, options);
      auto start = std::chrono::steady_clock::now();
      auto candidates = mesh::chooseCandidates(recorded.record, 500);
      auto chosen_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      auto meshes = mesh::extractMeshes(recorded.record, candidates);
      double extract_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() - chosen_s;
      size_t total = 0;
      for (const core::Mesh& m : meshes) total += m.triangleCount();
      char line[256];
      std::snprintf(line, sizeof line, "| %s | %zu | %zu | %.1f | %zu | %.2f | %.1f | %zu |",
                    name.c_str(), input.triangleCount(), recorded.record.steps.size(),
                    recorded.stats.seconds * 1e3, candidates.size(), chosen_s * 1e3,
                    extract_s * 1e3, total);
      progressive_lines.push_back(line);
    }

    for (double r : ratios) {
      const size_t target = std::max<size_t>(1, size_t(double(input.triangleCount()) * r + 0.5));
      mesh::SimplifyOptions options{
          .target_triangles = target,
          .placement = endpoint ? mesh::Placement::kEndpoint : mesh::Placement::kOptimal,
          .attribute_weight = attribute_weight,
          .record = false};
      mesh::SimplifyResult ours;
      double ours_s = medianSeconds(repeats, [&] { ours = mesh::simplifyQuadric(input, options); });

      std::vector<unsigned int> destination(input.indices.size());
      size_t index_count = 0;
      float meshopt_error = 0;
      double meshopt_s = medianSeconds(repeats, [&] {
        index_count = meshopt_simplify(destination.data(), input.indices.data(),
                                       input.indices.size(), &input.positions[0].x,
                                       input.vertexCount(), sizeof(core::Vec3), target * 3, 1.0f,
                                       0, &meshopt_error);
      });
      core::Mesh theirs;
      theirs.positions = input.positions;
      theirs.indices.assign(destination.begin(), destination.begin() + index_count);

      mesh::SurfaceDistance d_ours, d_theirs;  // --samples 0 skips them (for profiling)
      if (samples > 0) {
        d_ours = mesh::surfaceDistance(input, ours.mesh, samples);
        d_theirs = mesh::surfaceDistance(input, theirs, samples);
      }
      double time_ratio = ratio(ours_s, meshopt_s);
      double hausdorff_ratio = ratio(d_ours.hausdorff, d_theirs.hausdorff);
      double mean_ratio = ratio(d_ours.mean, d_theirs.mean);
      worst_time = std::max(worst_time, time_ratio);
      worst_hausdorff = std::max(worst_hausdorff, hausdorff_ratio);
      worst_mean = std::max(worst_mean, mean_ratio);
      std::printf("| %s | %zu | %zu (%g%%) | %zu | %zu | %.2f | %.2f | %.2f | %.3f | %.3f | %.2f | "
                  "%.4f | %.4f | %.2f |\n",
                  name.c_str(), input.triangleCount(), target, r * 100, ours.mesh.triangleCount(),
                  theirs.triangleCount(), ours_s * 1e3, meshopt_s * 1e3, time_ratio,
                  d_ours.hausdorff / unit, d_theirs.hausdorff / unit, hausdorff_ratio,
                  d_ours.mean / unit, d_theirs.mean / unit, mean_ratio);
      std::fflush(stdout);
    }
  }
  std::printf("\nworst ratios (ours / meshopt; target <= 1.0): time %.2f, Hausdorff %.2f, mean "
              "%.2f\n", worst_time, worst_hausdorff, worst_mean);
  std::printf("\nprogressive record (simplifyQuadric to 1%% with record on; K = 500 candidates, "
              "extracted by one extractMeshes sweep)\n\n");
  std::printf("| mesh | tris in | steps | simplify ms | candidates | choose ms | extract ms | "
              "triangles extracted |\n|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const std::string& line : progressive_lines) std::printf("%s\n", line.c_str());
  for (const std::string& path : skipped)
    std::printf("skipped (not found): %s — run scripts/fetch-bench-data.sh or pass --data-dir\n",
                path.c_str());
  return 0;
}
