// Rendered images against stored golden images, with a tolerance (not bit-exact: rasterizers and
// llvmpipe versions differ in the last bit). Set DUOLOD_UPDATE_GOLDEN=1 to rewrite the goldens
// after checking the new images by eye.
#include <gtest/gtest.h>

#include <cstdlib>

#include "duolod/io.hpp"
#include "duolod/render.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

struct Comparison {
  double mean_abs = 0;          // mean |a − b| over all channels, in 8-bit levels
  double fraction_over_8 = 0;   // pixels with any channel differing by more than 8 levels
};

Comparison compare(const core::ImageRGBA8& a, const core::ImageRGBA8& b) {
  Comparison c;
  size_t pixels = size_t(a.width) * a.height, over = 0;
  double sum = 0;
  for (size_t p = 0; p < pixels; ++p) {
    int worst = 0;
    for (int ch = 0; ch < 4; ++ch) {
      int d = std::abs(int(a.pixels[p * 4 + ch]) - int(b.pixels[p * 4 + ch]));
      sum += d;
      worst = std::max(worst, d);
    }
    if (worst > 8) ++over;
  }
  c.mean_abs = sum / (pixels * 4.0);
  c.fraction_over_8 = double(over) / pixels;
  return c;
}

TEST(GoldenImage, WaterBottleAtOneMetre) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  auto renderer = render::Renderer::create();
  ASSERT_TRUE(renderer) << renderer.error().message;
  auto source = render::loadShaderPair(test::sourcePath("shaders/pbr"));
  ASSERT_TRUE(source);
  auto program = (*renderer)->compileProgram(*source);
  ASSERT_TRUE(program) << program.error().message;
  auto id = (*renderer)->uploadAsset(*asset);
  ASSERT_TRUE(id);
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  // What `duolod render WaterBottle.gltf --distance 1 --view 0 --light 0` draws.
  int resolution = render::footprintPixels(sphere, 1.0f, render::Display{});
  ASSERT_EQ(resolution, 369);
  auto samples = render::domainSamples(sphere, 1.0f);
  auto batch = (*renderer)->render(*id, *program, std::span(samples.data(), 1), {.resolution = resolution});
  ASSERT_TRUE(batch) << batch.error().message;
  core::ImageRGBA8 image = render::tileImage(*batch, 0);

  std::string golden_path = test::sourcePath("tests/golden/waterbottle_d1_view0_light0.png");
  if (std::getenv("DUOLOD_UPDATE_GOLDEN")) {
    ASSERT_TRUE(io::writePng(image, golden_path));
    GTEST_SKIP() << "golden image rewritten: " << golden_path;
  }
  auto golden = io::readImage(golden_path);
  ASSERT_TRUE(golden) << golden.error().message;
  ASSERT_EQ(golden->width, image.width);
  ASSERT_EQ(golden->height, image.height);
  Comparison c = compare(image, *golden);
  EXPECT_LT(c.mean_abs, 0.5) << "mean difference in 8-bit levels";
  EXPECT_LT(c.fraction_over_8, 0.002) << "fraction of pixels off by more than 8 levels";

  // And the picture is of something: the bottle covers a good part of the frame, corners are empty.
  size_t covered = 0;
  for (size_t p = 0; p < image.pixels.size() / 4; ++p) covered += image.pixels[p * 4 + 3] > 0;
  EXPECT_GT(covered, image.pixels.size() / 4 / 5);
  EXPECT_EQ(image.pixels[3], 0);
}

}  // namespace
}  // namespace duolod
