// Work counters (ARB_pipeline_statistics_query), CPU-set uniforms and parameter blocks, and the
// draw-timing protocol of the renderer, on scenes whose answers can be worked out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "duolod/render.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
using core::Vec3;

// A rectangle `width` × `height` in the z = 0 plane facing +z (two triangles, 4 vertices, 6
// indices), one white material.
core::Asset rectangleAsset(float width, float height) {
  core::Asset asset;
  asset.source_path = "rectangle";
  float x = width / 2, y = height / 2;
  asset.mesh.positions = {{-x, -y, 0}, {x, -y, 0}, {x, y, 0}, {-x, y, 0}};
  asset.mesh.normals.assign(4, Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  asset.materials = {core::Material{}};
  return asset;
}

// A camera on the +z axis (or the −z axis, seeing the back face) whose image spans 4 units at
// z = 0: a 64-pixel tile then shows 16 pixels per unit, and edges at integer multiples of 1/16
// fall on pixel boundaries.
render::Sample axisSample(bool from_front) {
  render::Sample sample;
  float distance = from_front ? 4.0f : -4.0f;
  sample.eye = {0, 0, distance};
  sample.light = sample.eye;
  sample.view = core::lookAt(sample.eye, {0, 0, 0}, {0, 1, 0});
  sample.projection = core::perspective(2 * std::atan(2.0f / 4.0f), 1.0f, 0.1f, 100.0f);
  return sample;
}

constexpr const char* kVertex = R"(#version 450 core
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) in vec3 inPosition;
void main() { gl_Position = uProjection * uView * uModel * vec4(inPosition, 1.0); }
)";
// Colour from a CPU-set plain uniform (location 3) plus a parameter block (binding 2).
constexpr const char* kFragment = R"(#version 450 core
layout(location = 3) uniform vec4 uTint;
layout(std140, binding = 2) uniform Parameters { vec4 uOffset; };
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(uTint.rgb + uOffset.rgb, 1.0); }
)";

class RenderCountersTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    renderer_ = test::createRenderer(failure_);
    if (!renderer_) return;
    auto program = renderer_->compileProgram(
        render::GlslSource{kVertex, kFragment, "counters.vert", "counters.frag"});
    ASSERT_TRUE(program) << program.error().message;
    program_ = *program;
    auto asset = renderer_->uploadAsset(rectangleAsset(2.0f, 1.0f));
    ASSERT_TRUE(asset) << asset.error().message;
    asset_ = *asset;
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  void SetUp() override {
    ASSERT_NE(renderer_, nullptr) << "no OpenGL 4.5 context: " << failure_;
    uint8_t zeros[16] = {};
    ASSERT_TRUE(renderer_->setParameterBlock(2, zeros));
  }
  static bool isLlvmpipe() { return test::contains(renderer_->deviceDescription(), "llvmpipe"); }

  static inline render::Renderer* renderer_ = nullptr;
  static inline render::Renderer::ProgramId program_ = -1;
  static inline render::Renderer::AssetId asset_ = -1;
  static inline std::string failure_;
};

// Fragment invocations as llvmpipe counts them (measured): it shades whole 4×4-pixel blocks, and a
// triangle adds 16 for every block it touches. The rectangle's edges lie on block boundaries and
// its diagonal (slope 1/2) passes through 8 blocks that both triangles touch.
uint64_t llvmpipeRectangleFragments(int width_px, int height_px) {
  int full_blocks = (width_px / 4) * (height_px / 4);
  int diagonal_blocks = width_px / 4;  // one block per block column at slope 1/2 (width = 2·height)
  return 16u * uint64_t(full_blocks + diagonal_blocks);
}

TEST_F(RenderCountersTest, QuadCountsItsPixelsAndVertices) {
  render::Sample sample = axisSample(true);
  render::RenderStats stats;
  auto image = renderer_->render(asset_, program_, std::span(&sample, 1),
                                 {.resolution = 64, .count_work = true}, &stats);
  ASSERT_TRUE(image) << image.error().message;
  const render::WorkCounts& work = stats.work;
  // 2 × 1 units at 16 px per unit: 32 × 16 = 512 covered pixels, at x 16..48, y 24..40.
  int covered = 0;
  for (int p = 0; p < 64 * 64; ++p) covered += image->tile(0)[p * 4 + 3] > 0;
  ASSERT_EQ(covered, 512);
  EXPECT_EQ(work.primitives_submitted, 2u);
  EXPECT_EQ(work.clipping_input_primitives, 2u);
  EXPECT_EQ(work.clipping_output_primitives, 2u);
  if (isLlvmpipe()) {
    // llvmpipe shades each of the 4 indexed vertices once (not once per index: 6).
    EXPECT_EQ(work.vertex_invocations, 4u);
    EXPECT_EQ(work.fragment_invocations, llvmpipeRectangleFragments(32, 16));  // 640
  } else {
    EXPECT_GE(work.vertex_invocations, 4u);
    EXPECT_LE(work.vertex_invocations, 6u);
    EXPECT_GE(work.fragment_invocations, 512u);
  }
}

TEST_F(RenderCountersTest, CountsAddUpOverSamplesAndScaleWithSupersampling) {
  std::vector<render::Sample> samples = {axisSample(true), axisSample(true), axisSample(true)};
  render::RenderStats once, thrice, reference;
  ASSERT_TRUE(renderer_->render(asset_, program_, std::span(samples.data(), 1),
                                {.resolution = 64, .count_work = true}, &once));
  ASSERT_TRUE(renderer_->render(asset_, program_, samples, {.resolution = 64, .count_work = true},
                                &thrice));
  EXPECT_EQ(thrice.work.vertex_invocations, 3 * once.work.vertex_invocations);
  EXPECT_EQ(thrice.work.fragment_invocations, 3 * once.work.fragment_invocations);
  EXPECT_EQ(thrice.work.primitives_submitted, 6u);
  // A 2×-supersampled reference counts the 128-pixel render (64 × 32 pixels), not the box filter.
  ASSERT_TRUE(renderer_->renderReference(asset_, program_, std::span(samples.data(), 1),
                                         {.resolution = 64, .supersample = 2, .count_work = true},
                                         &reference));
  EXPECT_EQ(reference.work.primitives_submitted, 2u);
  if (isLlvmpipe()) {
    EXPECT_EQ(reference.work.fragment_invocations, llvmpipeRectangleFragments(64, 32));  // 2304
  } else {
    EXPECT_GE(reference.work.fragment_invocations, 4u * 512u);
  }
}

TEST_F(RenderCountersTest, BackFacesAreSubmittedButNotShaded) {
  render::Sample sample = axisSample(false);
  render::RenderStats stats;
  ASSERT_TRUE(renderer_->render(asset_, program_, std::span(&sample, 1),
                                {.resolution = 64, .count_work = true}, &stats));
  EXPECT_EQ(stats.work.primitives_submitted, 2u);
  EXPECT_EQ(stats.work.fragment_invocations, 0u);
}

TEST_F(RenderCountersTest, WithoutCountingTheCountsStayZero) {
  render::Sample sample = axisSample(true);
  render::RenderStats stats;
  ASSERT_TRUE(renderer_->render(asset_, program_, std::span(&sample, 1), {.resolution = 64},
                                &stats));
  EXPECT_EQ(stats.work.fragment_invocations, 0u);
  EXPECT_EQ(stats.work.vertex_invocations, 0u);
}

TEST_F(RenderCountersTest, UniformsAndParameterBlockReachTheShader) {
  render::Sample sample = axisSample(true);
  render::UniformValue tint{.location = 3, .components = 4, .value = {0.25f, 0.5f, 0, 1}};
  ASSERT_TRUE(renderer_->setProgramUniforms(program_, std::span(&tint, 1)));
  float offset[4] = {0, 0, 0.75f, 0};
  ASSERT_TRUE(renderer_->setParameterBlock(
      2, std::span(reinterpret_cast<const uint8_t*>(offset), sizeof offset)));
  auto image = renderer_->render(asset_, program_, std::span(&sample, 1), {.resolution = 64});
  ASSERT_TRUE(image) << image.error().message;
  const uint8_t* centre = image->tile(0) + (32 * 64 + 32) * 4;
  EXPECT_NEAR(centre[0], 64, 1);   // 0.25 from the plain uniform
  EXPECT_NEAR(centre[1], 128, 1);  // 0.5
  EXPECT_NEAR(centre[2], 191, 1);  // 0.75 from the parameter block
}

TEST_F(RenderCountersTest, BadUniformsAndBlocksAreErrors) {
  render::UniformValue missing{.location = 7, .components = 4};
  auto status = renderer_->setProgramUniforms(program_, std::span(&missing, 1));
  ASSERT_FALSE(status);
  EXPECT_TRUE(test::contains(status.error().message, "location 7")) << status.error().message;
  render::UniformValue no_location{.location = -1};
  EXPECT_FALSE(renderer_->setProgramUniforms(program_, std::span(&no_location, 1)));
  render::UniformValue tint{.location = 3, .components = 4};
  EXPECT_FALSE(renderer_->setProgramUniforms(12345, std::span(&tint, 1)));
  uint8_t bytes[16] = {};
  EXPECT_FALSE(renderer_->setParameterBlock(0, bytes));  // the frame block's binding
  EXPECT_FALSE(renderer_->setParameterBlock(-1, bytes));
}

// Wall time itself cannot be asserted; the protocol's deterministic parts can.
TEST_F(RenderCountersTest, DrawTimingFollowsItsProtocol) {
  std::vector<render::Sample> samples(4, axisSample(true));
  render::TimingOptions options{.resolution = 64, .repeats = 3, .min_repeat_seconds = 0.002,
                                .max_passes_per_repeat = 50};
  render::Renderer::ProgramId programs[] = {program_, program_};
  auto times = renderer_->measureDrawTimes(asset_, programs, samples, options);
  ASSERT_TRUE(times) << times.error().message;
  ASSERT_EQ(times->size(), 2u);
  for (const render::DrawTime& time : *times) {
    EXPECT_EQ(time.repeats, 3);
    EXPECT_GE(time.passes_per_repeat, 1);
    EXPECT_LE(time.passes_per_repeat, 50);
    EXPECT_GT(time.pass_seconds, 0);
    EXPECT_GE(time.seconds, 0);
    EXPECT_EQ(time.clear_seconds, times->front().clear_seconds);  // one shared baseline
  }
  auto single = renderer_->measureDrawTime(asset_, program_, samples, options);
  ASSERT_TRUE(single) << single.error().message;
  EXPECT_EQ(single->repeats, 3);
  // Timing leaves the renderer able to render the same image as before.
  auto image = renderer_->render(asset_, program_, std::span(samples.data(), 1), {.resolution = 64});
  ASSERT_TRUE(image);
  EXPECT_EQ(image->tile(0)[(32 * 64 + 32) * 4 + 3], 255);
}

TEST_F(RenderCountersTest, DrawTimingRejectsBadRequests) {
  std::vector<render::Sample> samples(1, axisSample(true));
  EXPECT_FALSE(renderer_->measureDrawTimes(asset_, {}, samples, {}));
  EXPECT_FALSE(renderer_->measureDrawTime(asset_, 9999, samples, {}));
  EXPECT_FALSE(renderer_->measureDrawTime(asset_, program_, {}, {}));
  EXPECT_FALSE(renderer_->measureDrawTime(asset_, program_, samples, {.repeats = 0}));
}

}  // namespace
}  // namespace duolod
