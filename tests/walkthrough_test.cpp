// The walk-through scene (src/runtime/walkthrough.hpp) and Renderer::renderScene on cases whose
// answers can be worked out by hand: instances land where their model matrices put them, the
// scene is seeded, and every visible object gets the level its distance calls for.
#include <gtest/gtest.h>

#include <cmath>

#include "duolod/render.hpp"
#include "runtime/walkthrough.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
using core::Vec3;

core::Mat4 translation(Vec3 t) {
  core::Mat4 m = core::Mat4::identity();
  m.at(0, 3) = t.x;
  m.at(1, 3) = t.y;
  m.at(2, 3) = t.z;
  return m;
}

// A unit square in the z = 0 plane facing +z, one material of colour `rgb`.
core::Asset coloredSquare(Vec3 rgb) {
  core::Asset asset;
  asset.mesh.positions = {{-0.5f, -0.5f, 0}, {0.5f, -0.5f, 0}, {0.5f, 0.5f, 0}, {-0.5f, 0.5f, 0}};
  asset.mesh.normals.assign(4, Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  core::Material material;
  material.base_color_factor = {rgb.x, rgb.y, rgb.z, 1};
  asset.materials = {material};
  return asset;
}

TEST(Walkthrough, SceneFrameDrawsEachInstanceWhereItsModelPutsIt) {
  std::string failure;
  std::unique_ptr<render::Renderer> renderer(test::createRenderer(failure));
  if (!renderer) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << failure;
  auto shader = render::loadShaderPair("constant");
  ASSERT_TRUE(shader) << shader.error().message;
  auto program = renderer->compileProgram(*shader);
  ASSERT_TRUE(program) << program.error().message;
  auto red = renderer->uploadAsset(coloredSquare({1, 0, 0}));
  auto green = renderer->uploadAsset(coloredSquare({0, 1, 0}));
  ASSERT_TRUE(red && green);

  // Camera at z = 4 seeing 4 units across 64 pixels: 16 pixels per unit at z = 0.
  render::SceneCamera camera;
  camera.width = camera.height = 64;
  camera.eye = {0, 0, 4};
  camera.light = camera.eye;
  camera.view = core::lookAt(camera.eye, {0, 0, 0}, {0, 1, 0});
  camera.projection = core::perspective(2 * std::atan(2.0f / 4.0f), 1.0f, 0.1f, 100.0f);
  const std::vector<render::InstanceBatch> batches = {
      {.asset = *red, .program = *program, .models = {translation({-1, 0, 0}),
                                                      translation({1, 1, 0})}},
      {.asset = *green, .program = *program, .models = {translation({1, -1, 0})}}};
  auto frame = renderer->renderScene(batches, camera,
                                     {.read_back = true, .count_work = renderer->canCountWork()});
  ASSERT_TRUE(frame) << frame.error().message;
  EXPECT_EQ(frame->draws, 3);
  ASSERT_EQ(frame->image.width, 64);
  auto pixel = [&](int x, int y) {  // rows top first: +y world is up, so a smaller row
    const uint8_t* p = &frame->image.pixels[(size_t(y) * 64 + x) * 4];
    return std::array<int, 4>{p[0], p[1], p[2], p[3]};
  };
  EXPECT_EQ(pixel(16, 32), (std::array<int, 4>{255, 0, 0, 255}));  // (-1, 0)
  EXPECT_EQ(pixel(48, 16), (std::array<int, 4>{255, 0, 0, 255}));  // (1, 1)
  EXPECT_EQ(pixel(48, 48), (std::array<int, 4>{0, 255, 0, 255}));  // (1, -1)
  EXPECT_EQ(pixel(32, 32), (std::array<int, 4>{0, 0, 0, 0}));      // nothing at the centre
  if (renderer->canCountWork()) {
    EXPECT_EQ(frame->work.primitives_submitted, 6u);
    // Per batch: the two red squares and the green one, each square 2×2 units = 32×32 pixels at
    // the same block alignment (llvmpipe counts fragment invocations per block, not per pixel);
    // the batches add up to the whole frame's counts.
    auto per_batch = renderer->renderScene(
        batches, camera, {.count_work = true, .count_work_per_batch = true});
    ASSERT_TRUE(per_batch) << per_batch.error().message;
    ASSERT_EQ(per_batch->batch_work.size(), 2u);
    EXPECT_EQ(per_batch->batch_work[0].primitives_submitted, 4u);
    EXPECT_EQ(per_batch->batch_work[1].primitives_submitted, 2u);
    EXPECT_EQ(per_batch->batch_work[0].fragment_invocations,
              2 * per_batch->batch_work[1].fragment_invocations);
    EXPECT_GT(per_batch->batch_work[1].fragment_invocations, 0u);
    EXPECT_EQ(per_batch->work.fragment_invocations, frame->work.fragment_invocations);
    EXPECT_EQ(per_batch->work.primitives_submitted, 6u);
  }

  // Bad ids are errors, not crashes.
  const render::InstanceBatch bad{.asset = 99, .program = *program, .models = {}};
  EXPECT_FALSE(renderer->renderScene(std::span(&bad, 1), camera));
}

TEST(Walkthrough, SceneIsSeededAndLevelsFollowDistance) {
  core::Asset square = coloredSquare({1, 1, 1});
  const core::Mesh* kinds[] = {&square.mesh};
  runtime::WalkSceneOptions options{.objects = 49, .seed = 7, .frames = 5};
  const runtime::WalkScene scene = runtime::buildWalkScene(kinds, options);
  ASSERT_EQ(scene.instances.size(), 49u);
  ASSERT_EQ(scene.path.size(), 5u);
  const runtime::WalkScene again = runtime::buildWalkScene(kinds, options);
  for (size_t i = 0; i < scene.instances.size(); ++i)
    EXPECT_EQ(scene.instances[i].model.m, again.instances[i].model.m) << i;
  options.seed = 8;
  EXPECT_NE(runtime::buildWalkScene(kinds, options).instances[0].model.m,
            scene.instances[0].model.m);
  for (const runtime::WalkInstance& instance : scene.instances) {
    EXPECT_LE(std::abs(instance.center.x), scene.half_extent);
    const float centre_above_lowest = core::computeBoundingSphere(square.mesh).center.y + 0.5f;
    EXPECT_NEAR(instance.center.y, instance.scale * centre_above_lowest, 1e-4f);  // on the ground
  }

  // Three levels switching at 5 and 15 units (asset units = world units / scale).
  runtime::Configuration configuration;
  runtime::KindLevels levels;
  levels.assets = {10, 11, 12};
  levels.programs = {20, 21, 22};
  levels.policy.levels.resize(3);
  levels.policy.levels[1].switch_distance = 5;
  levels.policy.levels[2].switch_distance = 15;
  configuration.kinds.push_back(levels);
  runtime::FrameSelector selector(configuration, scene, {.hysteresis = 0});
  const runtime::CameraPose& pose = scene.path[2];
  const render::SceneCamera camera = runtime::sceneCamera(pose, 320, 180, 45);
  const auto frame = selector.select(pose, camera);
  ASSERT_GT(frame.visible, 0);
  int counted = 0, previous_level = -1;
  for (const render::InstanceBatch& batch : frame.batches) {
    const int level = batch.asset - 10;
    ASSERT_GE(level, 0);
    EXPECT_EQ(batch.program, 20 + level);
    EXPECT_GT(level, previous_level) << "one batch per level, finest first";
    previous_level = level;
    for (const core::Mat4& model : batch.models) {
      ++counted;
      const runtime::WalkInstance* instance = nullptr;
      for (const runtime::WalkInstance& candidate : scene.instances)
        if (candidate.model.m == model.m) instance = &candidate;
      ASSERT_NE(instance, nullptr);
      const double distance = core::length(instance->center - pose.eye) / instance->scale;
      EXPECT_EQ(level, distance >= 15 ? 2 : distance >= 5 ? 1 : 0) << distance;
    }
  }
  EXPECT_EQ(counted, frame.visible);
  EXPECT_LT(frame.visible, 49) << "the camera sees part of the field, not all of it";
}

// Table 4's scene: every grid point holds one model of every kind, its parts on a ring around the
// point (so each part is its own instance, with its own level); --objects counts models.
TEST(Walkthrough, CompoundModelsHoldEveryKindAroundTheirGridPoint) {
  core::Asset square = coloredSquare({1, 1, 1}), other = coloredSquare({1, 0, 0});
  const core::Mesh* kinds[] = {&square.mesh, &other.mesh, &square.mesh};
  runtime::WalkSceneOptions options{.objects = 16, .seed = 3, .frames = 2};
  options.compound = true;
  const runtime::WalkScene scene = runtime::buildWalkScene(kinds, options);
  ASSERT_EQ(scene.instances.size(), 48u);
  for (size_t model = 0; model < 16; ++model) {
    core::Vec3 middle{0, 0, 0};
    for (int part = 0; part < 3; ++part) {
      const runtime::WalkInstance& instance = scene.instances[model * 3 + part];
      EXPECT_EQ(instance.kind, part);
      middle = middle + instance.center * (1.0f / 3.0f);
    }
    // The parts sit on a ring of part_ring radii around the model's point, 120° apart.
    for (int part = 0; part < 3; ++part) {
      const core::Vec3 d = scene.instances[model * 3 + part].center - middle;
      EXPECT_NEAR(std::sqrt(d.x * d.x + d.z * d.z), options.part_ring, 1e-3f);
    }
  }
  options.compound = false;
  EXPECT_EQ(runtime::buildWalkScene(kinds, options).instances.size(), 16u);
}

}  // namespace
}  // namespace duolod
