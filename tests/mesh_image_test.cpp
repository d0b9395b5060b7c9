// Image-driven simplification (§4.2): hand-checkable behaviour on generated meshes with the
// constant shader, where only silhouettes can change the image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "duolod/mesh.hpp"
#include "duolod/metric.hpp"
#include "mesh_test_meshes.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

// Distance at which a bounding sphere of `radius` spans `pixels` on the default display.
float distanceForPixels(float radius, int pixels) {
  render::Display display;
  float screen_half = std::tan(display.fov_y_deg * 3.14159265f / 360.0f);
  return radius / std::sin(std::atan(pixels / float(display.height_px) * screen_half));
}

class ImageSimplifyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto created = render::Renderer::create();
    ASSERT_TRUE(created) << "no OpenGL 4.5 context: " << created.error().message;
    renderer_ = std::move(created.value());
    auto shader = render::loadShaderPair(test::sourcePath("shaders/constant"));
    ASSERT_TRUE(shader) << shader.error().message;
    shader_ = *shader;
    // 5,120 triangles with edges of ~0.08 on a unit sphere.
    asset_.mesh = test::icosphere(4, 1.0f, test::lumps);
    asset_.source_path = "icosphere";
    core::Material material;
    material.base_color_factor = {0.8f, 0.5f, 0.2f, 1};
    asset_.materials = {material};
  }
  std::unique_ptr<render::Renderer> renderer_;
  render::GlslSource shader_;
  core::Asset asset_;
};

TEST_F(ImageSimplifyTest, EdgesLongerThanAPixelNeverCollapse) {
  // At 300 px across, every edge spans several pixels (D = 1 px, §4.2).
  mesh::ImageSimplifyOptions options;
  options.target_triangles = 100;
  options.distance = distanceForPixels(1.0f, 300);
  mesh::ImageSimplifyStats stats;
  auto result = mesh::simplifyImage(*renderer_, asset_, shader_, options, &stats);
  ASSERT_TRUE(result) << result.error().message;
  EXPECT_EQ(result->mesh.triangleCount(), asset_.mesh.triangleCount());
  EXPECT_EQ(result->stats.collapses, 0u);
  EXPECT_GT(stats.rejected_long_edges, 0u);
  EXPECT_EQ(stats.rendered_evaluations, 0u);  // nothing legal was ever worth rendering
}

TEST_F(ImageSimplifyTest, ALargerEdgeLimitLetsALargeFootprintCoarsen) {
  // At 60 px across the edges span ~2.4 px: D = 1 keeps them all, D = 4 lets them go (generate's
  // and simplify's --max-edge-pixels).
  mesh::ImageSimplifyOptions options;
  options.target_triangles = asset_.mesh.triangleCount() - 100;
  options.distance = distanceForPixels(1.0f, 60);
  mesh::ImageSimplifyStats paper;
  auto kept = mesh::simplifyImage(*renderer_, asset_, shader_, options, &paper);
  ASSERT_TRUE(kept) << kept.error().message;
  EXPECT_EQ(kept->stats.collapses, 0u);
  EXPECT_GT(paper.rejected_long_edges, 0u);
  options.max_edge_pixels = 4;
  mesh::ImageSimplifyStats relaxed;
  auto coarser = mesh::simplifyImage(*renderer_, asset_, shader_, options, &relaxed);
  ASSERT_TRUE(coarser) << coarser.error().message;
  EXPECT_LE(coarser->mesh.triangleCount(), options.target_triangles);
  EXPECT_LT(relaxed.rejected_long_edges, paper.rejected_long_edges);
}

TEST_F(ImageSimplifyTest, FarAwayHalvesWithLittleImageChangeAndTracksItsError) {
  // At 20 px across an edge is ~0.8 px: collapses are legal and mostly invisible.
  float distance = distanceForPixels(1.0f, 20);
  mesh::ImageSimplifyOptions options;
  options.target_triangles = 2560;
  options.distance = distance;
  std::vector<size_t> progress;
  options.progress = [&](size_t triangles) { progress.push_back(triangles); };
  mesh::ImageSimplifyStats stats;
  auto result = mesh::simplifyImage(*renderer_, asset_, shader_, options, &stats);
  ASSERT_TRUE(result) << result.error().message;
  EXPECT_LE(result->mesh.triangleCount(), 2560u);
  // Progress: reported as it goes (at least once per refined batch), never growing, ending at
  // the result's count.
  EXPECT_GE(progress.size(), stats.refine_batches);
  ASSERT_FALSE(progress.empty());
  EXPECT_TRUE(std::is_sorted(progress.rbegin(), progress.rend()));
  EXPECT_EQ(progress.front(), asset_.mesh.triangleCount());  // after the first priced batch
  EXPECT_EQ(progress.back(), result->mesh.triangleCount());
  EXPECT_GT(stats.rendered_evaluations, 0u);
  // The image error moves by a small fraction of the aliasing the original already has.
  EXPECT_LT(std::abs(stats.final_error - stats.initial_error), 0.5 * stats.initial_error)
      << "initial " << stats.initial_error << " final " << stats.final_error;
  // The rendered costs of the applied collapses add up to the measured change: the model prices
  // what it then does (up to staleness of costs whose neighbourhood changed after pricing).
  double measured = stats.final_error - stats.initial_error;
  EXPECT_NEAR(stats.predicted_change, measured, 0.5 * std::abs(measured) + 0.05 * stats.initial_error);

  // At equal triangle count the image-driven result is no worse in the image than quadrics.
  mesh::SimplifyResult quadric = mesh::simplifyQuadric(
      asset_.mesh, {.target_triangles = result->mesh.triangleCount(), .record = false});
  auto program = renderer_->compileProgram(shader_);
  auto original = renderer_->uploadAsset(asset_);
  ASSERT_TRUE(program && original);
  core::Sphere sphere = core::computeBoundingSphere(asset_.mesh);
  auto samples = render::domainSamples(sphere, distance);
  auto reference = renderer_->renderReference(*original, *program, samples,
                                              {.resolution = stats.footprint_px, .supersample = 4});
  ASSERT_TRUE(reference);
  auto quadric_id = renderer_->uploadMesh(*original, quadric.mesh);
  ASSERT_TRUE(quadric_id);
  auto quadric_image = renderer_->render(*quadric_id, *program, samples, {.resolution = stats.footprint_px});
  ASSERT_TRUE(quadric_image);
  double quadric_error = metric::imageError(*quadric_image, *reference).epsilon;
  EXPECT_LE(stats.final_error, quadric_error * 1.02)
      << "image-driven " << stats.final_error << " quadric " << quadric_error;
  std::printf("icosphere 5120 -> %zu: eps initial %.4f, image-driven %.4f (predicted change "
              "%.4f), quadric %.4f; %zu rendered evaluations\n",
              result->mesh.triangleCount(), stats.initial_error, stats.final_error,
              stats.predicted_change, quadric_error, stats.rendered_evaluations);
}

// A start whose own error is already over the target affords no collapse: it comes back as it is,
// without a single rendered evaluation (the LOD cascade's far levels).
TEST_F(ImageSimplifyTest, AStartOverTheErrorTargetIsReturnedWithoutPricing) {
  mesh::ImageSimplifyOptions options;
  options.distance = distanceForPixels(1.0f, 20);
  options.target_error = 1e-9;  // below the original's own aliasing against f̄
  mesh::ImageSimplifyStats stats;
  auto result = mesh::simplifyImage(*renderer_, asset_, shader_, options, &stats);
  ASSERT_TRUE(result) << result.error().message;
  EXPECT_GT(stats.initial_error, options.target_error);
  EXPECT_EQ(result->mesh.triangleCount(), asset_.mesh.triangleCount());
  EXPECT_EQ(result->stats.collapses, 0u);
  EXPECT_EQ(stats.rendered_evaluations, 0u);
}

// A start mesh is drawn as generate draws its candidates: over the original's upload, with the
// original's materials and bounding sphere (Renderer::uploadMesh). Object-space procedural shading
// scales with that sphere (noise_phong), so a start mesh drawn with its own sphere was
// priced against a different pattern. With `uploaded`, the caller's upload is used and kept.
TEST_F(ImageSimplifyTest, AStartMeshIsDrawnWithTheOriginalsSphereAndUpload) {
  auto noise = render::loadShaderPair(test::sourcePath("shaders/noise_phong"));
  ASSERT_TRUE(noise) << noise.error().message;
  // The start: the sphere without its x > 0 half (its own bounding sphere clearly differs),
  // its used vertices renumbered in order.
  core::Mesh start;
  std::vector<uint32_t> id(asset_.mesh.positions.size(), UINT32_MAX);
  for (size_t t = 0; t < asset_.mesh.triangleCount(); ++t) {
    const uint32_t* corner = &asset_.mesh.indices[t * 3];
    bool capped = false;
    for (int k = 0; k < 3; ++k) capped |= asset_.mesh.positions[corner[k]].x > 0.0f;
    if (capped) continue;
    for (int k = 0; k < 3; ++k) {
      if (id[corner[k]] == UINT32_MAX) {
        id[corner[k]] = uint32_t(start.positions.size());
        start.positions.push_back(asset_.mesh.positions[corner[k]]);
        if (!asset_.mesh.normals.empty()) start.normals.push_back(asset_.mesh.normals[corner[k]]);
      }
      start.indices.push_back(id[corner[k]]);
    }
  }
  start.submeshes = {{0, uint32_t(start.indices.size()), 0}};
  const core::Sphere sphere = core::computeBoundingSphere(asset_.mesh);
  const core::Sphere own = core::computeBoundingSphere(start);
  ASSERT_GT(core::length(own.center - sphere.center) + std::abs(own.radius - sphere.radius),
            0.05f * sphere.radius);

  mesh::ImageSimplifyOptions options;
  options.distance = distanceForPixels(1.0f, 40);
  options.target_error = 1e-9;  // the start comes back unpriced: only its own error is measured
  options.start = &start;
  auto program = renderer_->compileProgram(*noise);
  ASSERT_TRUE(program) << program.error().message;
  const auto samples = render::domainSamples(sphere, options.distance, options.domain);
  const int resolution = render::footprintPixels(sphere, options.distance, options.display);
  auto reference =
      renderer_->renderReference(*renderer_->uploadAsset(asset_), *program, samples,
                                 {.resolution = resolution, .supersample = options.supersample});
  ASSERT_TRUE(reference) << reference.error().message;
  options.reference = &*reference;
  auto original = renderer_->uploadAsset(asset_);
  ASSERT_TRUE(original) << original.error().message;
  auto drawn = renderer_->uploadMesh(*original, start);
  ASSERT_TRUE(drawn);
  auto images = renderer_->render(*drawn, *program, samples, {.resolution = resolution});
  ASSERT_TRUE(images) << images.error().message;
  const double expected = metric::imageError(*images, *reference).epsilon;

  for (bool given_upload : {false, true}) {
    options.uploaded = given_upload ? *original : -1;
    mesh::ImageSimplifyStats stats;
    auto result = mesh::simplifyImage(*renderer_, asset_, *noise, options, &stats);
    ASSERT_TRUE(result) << result.error().message;
    EXPECT_EQ(result->mesh.triangleCount(), start.triangleCount());
    EXPECT_DOUBLE_EQ(stats.initial_error, expected) << "given upload: " << given_upload;
  }
  // The caller's upload is still there.
  EXPECT_TRUE(renderer_->render(*original, *program, samples, {.resolution = resolution}));
}

TEST_F(ImageSimplifyTest, RefusesWithoutADistance) {
  mesh::ImageSimplifyOptions options;
  options.target_triangles = 10;  // and no distance
  auto result = mesh::simplifyImage(*renderer_, asset_, shader_, options);
  ASSERT_FALSE(result);
  EXPECT_NE(result.error().message.find("distance"), std::string::npos);
}

// Options out of their range are refused by name (a tile of 0 pixels or a batch of 0 candidates
// ran a different algorithm without a word; a display 0 pixels high simplified for 1 pixel).
TEST_F(ImageSimplifyTest, OptionsOutOfRangeAreNamed) {
  struct Case {
    const char* option;
    std::function<void(mesh::ImageSimplifyOptions&)> set;
  };
  for (const Case& c : std::vector<Case>{
           {"tile_size", [](auto& o) { o.tile_size = 0; }},
           {"refine_batch", [](auto& o) { o.refine_batch = 0; }},
           {"supersample", [](auto& o) { o.supersample = 0; }},
           {"max_edge_pixels", [](auto& o) { o.max_edge_pixels = -1; }},
           {"display.height_px", [](auto& o) { o.display.height_px = 0; }},
           {"display.fov_y_deg", [](auto& o) { o.display.fov_y_deg = 0; }},
       }) {
    mesh::ImageSimplifyOptions options;
    options.distance = distanceForPixels(1.0f, 20);
    options.target_triangles = 10;
    c.set(options);
    auto result = mesh::simplifyImage(*renderer_, asset_, shader_, options);
    ASSERT_FALSE(result) << c.option;
    EXPECT_NE(result.error().message.find(c.option), std::string::npos) << result.error().message;
  }
}

}  // namespace
}  // namespace duolod
