// Renderer tests with analytically known answers: coverage of a quad, a constant colour, ε of an
// image with itself, ε growing with a vertex displacement, supersampled coverage, GLSL vs SPIR-V.
#include "duolod/render.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <thread>

#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/shader.hpp"
#include "mesh_test_meshes.hpp"
#include "render/batch_memory.hpp"
#include "render/slow_requests.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
using core::Vec3;

// A 2×2 square in the z = 0 plane facing +z, one material with the given constant colour.
core::Asset squareAsset(core::Vec4 color) {
  core::Asset asset;
  asset.source_path = "square";
  asset.mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  asset.mesh.normals.assign(4, Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  core::Material material;
  material.base_color_factor = color;
  asset.materials = {material};
  return asset;
}

// A camera on +z at distance `distance` whose field of view makes the square cover exactly half the
// image side: tan(fov/2) = 2 / distance.
render::Sample frontSample(float distance) {
  render::Sample sample;
  sample.eye = {0, 0, distance};
  sample.light = sample.eye;
  sample.view = core::lookAt(sample.eye, {0, 0, 0}, {0, 1, 0});
  sample.projection = core::perspective(2 * std::atan(2.0f / distance), 1.0f, 0.1f, 100.0f);
  return sample;
}

class RendererTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto created = render::Renderer::create();
    if (!created) {
      failure_ = created.error().message;
      return;
    }
    renderer_ = std::move(created.value()).release();
    auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
    ASSERT_TRUE(source) << source.error().message;
    auto program = renderer_->compileProgram(*source);
    ASSERT_TRUE(program) << program.error().message;
    constant_program_ = *program;
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  void SetUp() override {
    ASSERT_NE(renderer_, nullptr) << "no OpenGL 4.5 context: " << failure_;
  }

  static inline render::Renderer* renderer_ = nullptr;
  static inline render::Renderer::ProgramId constant_program_ = -1;
  static inline std::string failure_;
};

TEST_F(RendererTest, SquareCoversKnownPixelsWithConstantColour) {
  auto asset = renderer_->uploadAsset(squareAsset({0.25f, 0.5f, 0.75f, 1}));
  ASSERT_TRUE(asset) << asset.error().message;
  render::Sample sample = frontSample(4.0f);
  auto batch = renderer_->render(*asset, constant_program_, std::span(&sample, 1), {.resolution = 64});
  ASSERT_TRUE(batch) << batch.error().message;
  int covered = 0;
  for (int p = 0; p < 64 * 64; ++p) {
    const uint8_t* px = batch->tile(0) + p * 4;
    if (px[3] == 0) continue;
    ++covered;
    EXPECT_NEAR(px[0], 64, 1);   // 0.25 * 255
    EXPECT_NEAR(px[1], 128, 1);  // 0.5 * 255
    EXPECT_NEAR(px[2], 191, 1);  // 0.75 * 255
  }
  // Half the side of a 64-pixel image: edges fall on pixel boundaries 16 and 48.
  EXPECT_EQ(covered, 32 * 32);
  // The top-left covered pixel is (16, 16): row order is top first.
  EXPECT_EQ(batch->tile(0)[(15 * 64 + 16) * 4 + 3], 0);
  EXPECT_EQ(batch->tile(0)[(16 * 64 + 16) * 4 + 3], 255);
  renderer_->releaseAsset(*asset);
}

// A material's double_sided (glTF's doubleSided) draws its back faces: the square seen from
// behind covers its 32 x 32 pixels when double-sided and none when not; as the reference too.
TEST_F(RendererTest, DoubleSidedMaterialsShowTheirBackFaces) {
  render::Sample behind = frontSample(4.0f);
  behind.eye = {0, 0, -4};
  behind.light = behind.eye;
  behind.view = core::lookAt(behind.eye, {0, 0, 0}, {0, 1, 0});
  for (bool double_sided : {false, true}) {
    core::Asset square = squareAsset({1, 1, 1, 1});
    square.materials[0].double_sided = double_sided;
    auto asset = renderer_->uploadAsset(square);
    ASSERT_TRUE(asset) << asset.error().message;
    auto batch =
        renderer_->render(*asset, constant_program_, std::span(&behind, 1), {.resolution = 64});
    ASSERT_TRUE(batch) << batch.error().message;
    int covered = 0;
    for (int p = 0; p < 64 * 64; ++p) covered += batch->tile(0)[p * 4 + 3] > 0;
    EXPECT_EQ(covered, double_sided ? 32 * 32 : 0) << "double_sided " << double_sided;
    auto reference = renderer_->renderReference(*asset, constant_program_, std::span(&behind, 1),
                                                {.resolution = 16, .supersample = 2});
    ASSERT_TRUE(reference) << reference.error().message;
    EXPECT_EQ(metric::checkReferenceCoverage(*reference).ok(), double_sided);
    renderer_->releaseAsset(*asset);
  }
}

// glTF asks for a double-sided material's back faces to be lit with their normal reversed. Seen
// and lit from behind, the flat square must then look as it does seen and lit from the front (the
// two pictures are mirror images). Before, the back face kept the front's normal, facing away from
// the light: only the ambient term lit it (mean red of 255: pbr 45 against 199, blend 21 against
// 250).
TEST_F(RendererTest, DoubleSidedBackFacesAreLitWithTheirNormalReversed) {
  render::Sample behind = frontSample(4.0f);
  behind.eye = {0, 0, -4};
  behind.light = behind.eye;
  behind.view = core::lookAt(behind.eye, {0, 0, 0}, {0, 1, 0});
  const render::Sample sides[] = {frontSample(4.0f), behind};
  core::Asset square = squareAsset({0.8f, 0.6f, 0.4f, 1});
  square.materials[0].double_sided = true;
  auto asset = renderer_->uploadAsset(square);
  ASSERT_TRUE(asset) << asset.error().message;
  for (const char* shader : {"pbr", "blend"}) {
    auto source = render::loadShaderPair(test::sourcePath(std::string("shaders/") + shader));
    ASSERT_TRUE(source) << source.error().message;
    auto program = renderer_->compileProgram(*source);
    ASSERT_TRUE(program) << program.error().message;
    auto batch = renderer_->render(*asset, *program, sides, {.resolution = 64});
    ASSERT_TRUE(batch) << batch.error().message;
    double mean_red[2] = {0, 0};
    for (int side = 0; side < 2; ++side) {
      int covered = 0;
      for (int p = 0; p < 64 * 64; ++p) {
        if (batch->tile(side)[p * 4 + 3] <= 0) continue;
        ++covered;
        mean_red[side] += batch->tile(side)[p * 4];
      }
      ASSERT_EQ(covered, 32 * 32) << shader << " side " << side;
      mean_red[side] /= covered;
    }
    EXPECT_GT(mean_red[0], 150) << shader << ": the lit front is bright (of 255)";
    EXPECT_NEAR(mean_red[1], mean_red[0], 1.0) << shader << ": the back, lit from behind";
  }
  renderer_->releaseAsset(*asset);
}

// Coverage of the square scaled by `scale` with the camera scaled along (the same picture).
// Returns -1 and the message when the render is refused.
int scaledSquareCoverage(render::Renderer& renderer, render::Renderer::ProgramId program,
                         float scale, std::string& message) {
  core::Asset asset = squareAsset({1, 1, 1, 1});
  for (Vec3& p : asset.mesh.positions) p = p * scale;
  auto id = renderer.uploadAsset(asset);
  if (!id) return message = id.error().message, -1;
  render::Sample sample = frontSample(4.0f * scale);
  sample.projection =
      core::perspective(2 * std::atan(0.5f), 1.0f, 0.1f * scale, 100.0f * scale);
  auto batch = renderer.render(*id, program, std::span(&sample, 1), {.resolution = 64});
  renderer.releaseAsset(*id);
  if (!batch) return message = batch.error().message, -1;
  int covered = 0;
  for (int p = 0; p < 64 * 64; ++p) covered += batch->tile(0)[p * 4 + 3] != 0;
  return covered;
}

// 32-bit shading squares distances: far beyond 1e18 units the image came out empty without a
// word (an asset 1e20 across, even with the constant shader). Such requests are refused with a
// message; large but representable scenes still render the same picture as at unit scale.
// Two Renderers in one thread (a caller's own and generateLod's, say): each makes its context
// current when it is used. Before, the second one's creation left its context current, so the
// first drew into it (the second's objects, under the same names) and reported success.
TEST(RendererContexts, EachRendererDrawsWithItsOwnContext) {
  auto first = render::Renderer::create();
  if (!first) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << first.error().message;
  auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
  ASSERT_TRUE(source) << source.error().message;
  auto drawn = [&](render::Renderer& renderer, render::Renderer::AssetId asset,
                   render::Renderer::ProgramId program) {
    render::Sample sample = frontSample(4.0f);
    auto batch = renderer.render(asset, program, std::span(&sample, 1), {.resolution = 32});
    EXPECT_TRUE(batch) << batch.error().message;
    return batch ? tileImage(*batch, 0).pixels : std::vector<uint8_t>{};
  };
  auto red = (*first)->uploadAsset(squareAsset({1, 0, 0, 1}));
  auto red_program = (*first)->compileProgram(*source);
  ASSERT_TRUE(red && red_program);
  const std::vector<uint8_t> before = drawn(**first, *red, *red_program);
  {
    auto second = render::Renderer::create();
    ASSERT_TRUE(second) << second.error().message;
    core::Asset small = squareAsset({0, 1, 0, 1});
    for (Vec3& p : small.mesh.positions) p = p * 0.5f;
    auto green = (*second)->uploadAsset(small);
    auto green_program = (*second)->compileProgram(*source);
    ASSERT_TRUE(green && green_program);
    const std::vector<uint8_t> other = drawn(**second, *green, *green_program);
    EXPECT_NE(other, before);
    EXPECT_EQ(drawn(**first, *red, *red_program), before) << "with a second renderer alive";
    EXPECT_EQ(drawn(**second, *green, *green_program), other);
  }
  EXPECT_EQ(drawn(**first, *red, *red_program), before) << "after the second one is gone";
}

// A square textured with a 64×64 checker of two colours (pbr draws its base colour texture).
core::Asset checkerSquare(uint8_t tint) {
  core::Asset asset = squareAsset({1, 1, 1, 1});
  asset.mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  core::Texture checker;
  checker.name = "checker";
  checker.srgb = true;
  checker.image.width = checker.image.height = 64;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const bool dark = ((x / 8) + (y / 8)) % 2 != 0;
      checker.image.pixels.insert(checker.image.pixels.end(),
                                  {uint8_t(dark ? 30 : 220), tint, uint8_t(dark ? 200 : 40), 255});
    }
  asset.textures = {checker};
  asset.materials[0].base_color_texture = 0;
  return asset;
}

// Compile-ahead workers draw their search thread's textures (SharedTextures) instead of uploading
// copies: the images must be the ones their own upload gives, on another thread, while the
// textures' renderer draws too, and after it is gone; another asset's textures are not used.
TEST(RendererSharedTextures, ASharingRendererDrawsWhatItsOwnUploadDraws) {
  auto owner = render::Renderer::create();
  if (!owner) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << owner.error().message;
  auto source = render::loadShaderPair(test::sourcePath("shaders/pbr"));
  ASSERT_TRUE(source) << source.error().message;
  const core::Asset asset = checkerSquare(90);
  std::vector<render::Sample> samples;
  for (float distance : {3.0f, 4.0f, 6.0f}) samples.push_back(frontSample(distance));
  auto drawn = [&](render::Renderer& renderer, render::Renderer::AssetId id) {
    auto program = renderer.compileProgram(*source);
    EXPECT_TRUE(program) << program.error().message;
    if (!program) return std::vector<uint8_t>{};
    auto batch = renderer.render(id, *program, samples, {.resolution = 48});
    EXPECT_TRUE(batch) << batch.error().message;
    renderer.releaseProgram(*program);
    return batch ? batch->pixels : std::vector<uint8_t>{};
  };
  auto owned = (*owner)->uploadAsset(asset);
  ASSERT_TRUE(owned) << owned.error().message;
  const std::vector<uint8_t> expected = drawn(**owner, *owned);
  EXPECT_EQ((*owner)->uploadedTextureBytes(), size_t(64 * 64 * 4 * 4 / 3));
  ASSERT_FALSE(expected.empty());
  auto shared = (*owner)->shareTextures(*owned);
  ASSERT_TRUE(shared) << shared.error().message;
  EXPECT_TRUE((*shared)->matches(asset));
  EXPECT_EQ((*shared)->textureBytes(), size_t(64 * 64 * 4 * 4 / 3));
  EXPECT_FALSE((*shared)->matches(checkerSquare(91))) << "one channel of every texel differs";
  EXPECT_FALSE((*owner)->shareTextures(7)) << "an unknown asset id";

  std::vector<uint8_t> on_the_thread, other_on_the_thread, other_alone, after_owner;
  std::promise<void> owner_gone;
  std::promise<void> first_draws_done;
  std::thread worker([&, owner_gone = owner_gone.get_future()]() mutable {
    auto sharing = render::Renderer::create({.textures = *shared});
    first_draws_done.set_value();  // (even when it failed: the main thread must not wait)
    ASSERT_TRUE(sharing) << sharing.error().message;
    auto copy = (*sharing)->uploadAsset(core::Asset(asset));  // a copy, as the workers get
    ASSERT_TRUE(copy) << copy.error().message;
    on_the_thread = drawn(**sharing, *copy);
    EXPECT_EQ((*sharing)->uploadedTextureBytes(), 0u) << "drawn from the shared textures";
    auto other = (*sharing)->uploadAsset(checkerSquare(160));  // uploads its own textures
    ASSERT_TRUE(other) << other.error().message;
    other_on_the_thread = drawn(**sharing, *other);
    EXPECT_EQ((*sharing)->uploadedTextureBytes(), size_t(64 * 64 * 4 * 4 / 3));
    (*sharing)->releaseAsset(*other);
    // The textures' renderer goes first: this one still draws them (the share group keeps
    // them; nobody deletes names in another context).
    owner_gone.wait();
    auto again = (*sharing)->uploadAsset(asset);
    ASSERT_TRUE(again) << again.error().message;
    after_owner = drawn(**sharing, *again);
  });
  first_draws_done.get_future().wait();
  const std::vector<uint8_t> meanwhile = drawn(**owner, *owned);  // the owner draws meanwhile
  shared->reset();
  owner->reset();
  owner_gone.set_value();
  worker.join();
  EXPECT_EQ(meanwhile, expected);
  EXPECT_EQ(on_the_thread, expected) << "the shared textures on another thread";
  EXPECT_EQ(after_owner, expected) << "after the textures' renderer is gone";
  auto alone = render::Renderer::create();
  ASSERT_TRUE(alone);
  auto id = (*alone)->uploadAsset(checkerSquare(160));
  ASSERT_TRUE(id);
  other_alone = drawn(**alone, *id);
  EXPECT_NE(other_alone, expected);
  EXPECT_EQ(other_on_the_thread, other_alone) << "another asset's textures: its own upload";
}

// An asset whose parts disagree is refused before anything reaches the GPU (a texture with fewer
// pixels than its size was read past its end).
TEST_F(RendererTest, InconsistentAssetsAreRefused) {
  core::Asset asset = squareAsset({1, 1, 1, 1});
  asset.textures.push_back({.name = "short", .image = {512, 512, std::vector<uint8_t>(16)}});
  asset.materials[0].base_color_texture = 0;
  auto short_pixels = renderer_->uploadAsset(asset);
  ASSERT_FALSE(short_pixels);
  EXPECT_TRUE(test::contains(short_pixels.error().message, "holds 16 bytes"))
      << short_pixels.error().message;
  asset = squareAsset({1, 1, 1, 1});
  asset.mesh.submeshes[0].material = 5;
  auto material = renderer_->uploadAsset(asset);
  ASSERT_FALSE(material);
  EXPECT_TRUE(test::contains(material.error().message, "material 5")) << material.error().message;
}

TEST_F(RendererTest, HugeCoordinatesAreRefusedWithAReason) {
  std::string message;
  const int unit = scaledSquareCoverage(*renderer_, constant_program_, 1.0f, message);
  EXPECT_EQ(unit, 32 * 32) << message;
  for (float scale : {1e-10f, 1e10f, 1e17f})
    EXPECT_EQ(scaledSquareCoverage(*renderer_, constant_program_, scale, message), unit)
        << "scale " << scale << ": " << message;
  for (float scale : {1e19f, 1e20f, 1e30f}) {
    message.clear();
    EXPECT_EQ(scaledSquareCoverage(*renderer_, constant_program_, scale, message), -1)
        << "scale " << scale;
    EXPECT_NE(message.find("scale the asset down"), std::string::npos) << message;
  }
  // ... and tiny ones: a sphere 1e-30 across rendered blank (found by fuzzing).
  for (float scale : {1e-19f, 1e-30f}) {
    message.clear();
    EXPECT_EQ(scaledSquareCoverage(*renderer_, constant_program_, scale, message), -1)
        << "scale " << scale;
    EXPECT_NE(message.find("scale the asset up"), std::string::npos) << message;
  }
  // A small asset seen from too far away: the camera is named.
  core::Asset square = squareAsset({1, 1, 1, 1});
  auto id = renderer_->uploadAsset(square);
  ASSERT_TRUE(id);
  render::Sample far = frontSample(1e20f);
  auto batch = renderer_->render(*id, constant_program_, std::span(&far, 1), {.resolution = 16});
  ASSERT_FALSE(batch);
  EXPECT_NE(batch.error().message.find("sample 0's camera"), std::string::npos)
      << batch.error().message;
  renderer_->releaseAsset(*id);
}

TEST_F(RendererTest, SupersampledReferenceHasFractionalEdgeCoverage) {
  auto asset = renderer_->uploadAsset(squareAsset({1, 1, 1, 1}));
  ASSERT_TRUE(asset);
  // Square spans 0.4 of the image side: 25.6 of 64 pixels, so its edges cut pixels in part.
  render::Sample sample = frontSample(4.0f);
  sample.projection = core::perspective(2 * std::atan(1.0f / (4.0f * 0.4f)), 1.0f, 0.1f, 100.0f);
  auto reference = renderer_->renderReference(*asset, constant_program_, std::span(&sample, 1),
                                              {.resolution = 64, .supersample = 4});
  ASSERT_TRUE(reference) << reference.error().message;
  double coverage = metric::tileCoverage(reference->tile(0), 64 * 64);
  // Exact area 25.6² = 655.36; a 4×4 grid per pixel quantizes each edge to 1/4 px.
  EXPECT_NEAR(coverage, 25.6 * 25.6, 25.6 * 4 * 0.25);
  bool fractional = false;
  for (int p = 0; p < 64 * 64; ++p) {
    float alpha = reference->tile(0)[p * 4 + 3];
    if (alpha > 0.05f && alpha < 0.95f) fractional = true;
  }
  EXPECT_TRUE(fractional);
  renderer_->releaseAsset(*asset);
}

TEST_F(RendererTest, ErrorOfImageWithItselfIsZeroAndGrowsWithDisplacement) {
  core::Asset base = squareAsset({0.8f, 0.6f, 0.4f, 1});
  auto base_id = renderer_->uploadAsset(base);
  ASSERT_TRUE(base_id);
  core::Sphere sphere = core::computeBoundingSphere(base.mesh);
  std::vector<render::Sample> samples = render::domainSamples(sphere, 5.0f);
  ASSERT_EQ(samples.size(), 100u);
  render::RenderOptions options{.resolution = 48};
  auto image = renderer_->render(*base_id, constant_program_, samples, options);
  ASSERT_TRUE(image);
  auto again = renderer_->render(*base_id, constant_program_, samples, options);
  ASSERT_TRUE(again);
  EXPECT_EQ(metric::imageError(*image, *again).epsilon, 0.0);

  double previous = 0;
  for (float shift : {0.1f, 0.3f, 0.6f}) {
    core::Asset moved = base;
    moved.mesh.positions[2] = moved.mesh.positions[2] + Vec3{shift, shift, 0};
    auto moved_id = renderer_->uploadAsset(moved);
    ASSERT_TRUE(moved_id);
    auto moved_image = renderer_->render(*moved_id, constant_program_, samples, options);
    ASSERT_TRUE(moved_image);
    double epsilon = metric::imageError(*moved_image, *image).epsilon;
    EXPECT_GT(epsilon, previous) << "shift " << shift;
    previous = epsilon;
    renderer_->releaseAsset(*moved_id);
  }
  renderer_->releaseAsset(*base_id);
}

TEST_F(RendererTest, SpirvProgramRendersLikeGlsl) {
  auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
  ASSERT_TRUE(source);
  auto vertex = shader::compileToSpirv(source->vertex, shader::Stage::kVertex, source->vertex_name);
  ASSERT_TRUE(vertex) << vertex.error().message;
  auto fragment =
      shader::compileToSpirv(source->fragment, shader::Stage::kFragment, source->fragment_name);
  ASSERT_TRUE(fragment) << fragment.error().message;
  ASSERT_TRUE(shader::validateSpirv(*vertex, "vertex"));
  auto program = renderer_->compileProgram(render::SpirvBinary{*vertex, *fragment});
  ASSERT_TRUE(program) << program.error().message;
  auto asset = renderer_->uploadAsset(squareAsset({0.1f, 0.9f, 0.3f, 1}));
  ASSERT_TRUE(asset);
  render::Sample sample = frontSample(4.0f);
  auto from_glsl = renderer_->render(*asset, constant_program_, std::span(&sample, 1), {.resolution = 32});
  auto from_spirv = renderer_->render(*asset, *program, std::span(&sample, 1), {.resolution = 32});
  ASSERT_TRUE(from_glsl && from_spirv);
  EXPECT_EQ(from_glsl->pixels, from_spirv->pixels);
  renderer_->releaseProgram(*program);
  renderer_->releaseAsset(*asset);
}

// A uniform its SPIR-V declares but the driver optimized away has no active location: setting it
// does nothing, as its value can change nothing (a value moved to a parameter in a branch that
// never writes the output aborted `shader`'s search). A location the program never declared, or
// a value of the wrong type for an active uniform, is still an error naming the location.
TEST_F(RendererTest, UniformsTheDriverOptimizedAwayAreSkipped) {
  const std::string vertex =
      "#version 450 core\nlayout(location = 0) in vec3 p;\n"
      "void main() { gl_Position = vec4(p, 1.0); }\n";
  const std::string fragment =
      "#version 450 core\nlayout(location = 40) uniform vec3 unused;\n"
      "layout(location = 41) uniform vec4 tint;\nlayout(location = 0) out vec4 c;\n"
      "void main() { c = tint; }\n";
  auto vertex_words = shader::compileToSpirv(vertex, shader::Stage::kVertex, "p.vert");
  auto fragment_words = shader::compileToSpirv(fragment, shader::Stage::kFragment, "tint.frag");
  ASSERT_TRUE(vertex_words && fragment_words);
  auto program = renderer_->compileProgram(render::SpirvBinary{*vertex_words, *fragment_words});
  ASSERT_TRUE(program) << program.error().message;
  const render::UniformValue unused{40, 3, {1, 2, 3, 0}};
  EXPECT_TRUE(renderer_->setProgramUniforms(*program, std::span(&unused, 1)));
  const render::UniformValue tint{41, 4, {1, 0, 0, 1}};
  EXPECT_TRUE(renderer_->setProgramUniforms(*program, std::span(&tint, 1)));
  for (const render::UniformValue& wrong :
       {render::UniformValue{41, 3, {1, 0, 0, 0}}, render::UniformValue{9, 2, {}}}) {
    core::Status refused = renderer_->setProgramUniforms(*program, std::span(&wrong, 1));
    ASSERT_FALSE(refused);
    EXPECT_TRUE(test::contains(refused.error().message, "no " + std::to_string(wrong.components) +
                                                            "-float uniform at location " +
                                                            std::to_string(wrong.location)))
        << refused.error().message;
  }
  renderer_->releaseProgram(*program);
}

TEST_F(RendererTest, CompileErrorsCarryTheShaderLog) {
  render::GlslSource broken{"#version 450 core\nvoid main() { gl_Position = vec4(0); }\n",
                            "#version 450 core\nlayout(location=0) out vec4 c;\nvoid main() { c = "
                            "undefined_thing; }\n",
                            "ok.vert", "broken.frag"};
  auto program = renderer_->compileProgram(broken);
  ASSERT_FALSE(program);
  EXPECT_NE(program.error().message.find("broken.frag"), std::string::npos);
  EXPECT_NE(program.error().message.find("undefined_thing"), std::string::npos);

  auto bad_spirv = renderer_->compileProgram(render::SpirvBinary{{1, 2, 3}, {4, 5, 6}});
  ASSERT_FALSE(bad_spirv);
  EXPECT_NE(bad_spirv.error().message.find("magic"), std::string::npos);
}

TEST_F(RendererTest, AVertexStageThatNeverWritesThePositionIsRefused) {
  // A fragment shader given as the vertex stage compiles as one: it would draw nothing.
  const std::string fragment =
      "#version 450 core\nlayout(location=0) out vec4 c;\n"
      "void main() { c = vec4(1); } // gl_Position = vec4(0); in a comment\n"
      "/* gl_Position */ float my_gl_Position_x;\n";
  auto program =
      renderer_->compileProgram(render::GlslSource{fragment, fragment, "red.frag", "red.frag"});
  ASSERT_FALSE(program);
  EXPECT_TRUE(test::contains(program.error().message,
                             "red.frag: the vertex stage never writes gl_Position"))
      << program.error().message;
  // The same with a write of gl_Position compiles.
  const std::string vertex = "#version 450 core\nvoid main(){gl_Position=vec4(0);}\n";
  auto good =
      renderer_->compileProgram(render::GlslSource{vertex, fragment, "ok.vert", "red.frag"});
  ASSERT_TRUE(good) << good.error().message;
  renderer_->releaseProgram(*good);
}

// A batch whose images do not fit in the machine's memory is refused with the figures before
// anything is drawn (`error --pixels 4095`: 100 float images of 4095² pixels, 27 GB, aborted with
// std::bad_alloc). 100 samples of 16384² pixels are 107 GB as 8-bit, 429 GB as floats.
TEST_F(RendererTest, BatchesLargerThanMemoryAreRefusedWithTheFigures) {
  const double memory = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  if (memory >= 107e9) GTEST_SKIP() << "this machine has " << memory / 1e9 << " GB of memory";
  core::Asset square = squareAsset({1, 1, 1, 1});
  auto id = renderer_->uploadAsset(square);
  ASSERT_TRUE(id);
  const std::vector<render::Sample> samples(100, frontSample(3.0f));
  const render::RenderOptions huge{.resolution = 16384};
  auto plain = renderer_->render(*id, constant_program_, samples, huge);
  ASSERT_FALSE(plain);
  EXPECT_NE(plain.error().message.find("100 images of 16384 x 16384 pixels take 107.4 GB as 8-bit"),
            std::string::npos)
      << plain.error().message;
  EXPECT_NE(plain.error().message.find("of memory: render fewer pixels or samples"),
            std::string::npos)
      << plain.error().message;
  auto reference = renderer_->renderReference(*id, constant_program_, samples, huge);
  ASSERT_FALSE(reference);
  EXPECT_NE(reference.error().message.find("take 429.5 GB as float"), std::string::npos)
      << reference.error().message;
  // One sample of 4096² pixels (67 MB) is drawn.
  auto one =
      renderer_->render(*id, constant_program_, std::span(samples.data(), 1), {.resolution = 4096});
  EXPECT_TRUE(one) << one.error().message;
  renderer_->releaseAsset(*id);
}

// A batch that fits the machine but not what is free now (other processes, this one's own
// images) is refused too, with both figures: the allocation would succeed and the kernel's
// out-of-memory killer end the process once its pages were touched.
TEST(BatchMemory, BatchesBeyondTheAvailableMemoryAreRefusedWithTheFigures) {
  using render::internal::checkBatchMemory;
  const render::internal::MachineMemory busy{.total = 25.3e9, .available = 3.1e9};
  // 100 float images of 2000² pixels: 6.4 GB.
  auto refused = checkBatchMemory(100, 2000, 16, "as float RGBA", busy);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("100 images of 2000 x 2000 pixels take 6.4 GB as float "
                                         "RGBA, more than the 3.1 GB of memory available now "
                                         "(of this machine's 25.3 GB)"),
            std::string::npos)
      << refused.error().message;
  EXPECT_TRUE(
      checkBatchMemory(100, 2000, 16, "as float RGBA", {.total = 25.3e9, .available = 7e9}));
  EXPECT_TRUE(checkBatchMemory(100, 2000, 16, "as float RGBA", {.total = 25.3e9, .available = 0}))
      << "an unknown available figure refuses nothing";
  auto beyond = checkBatchMemory(100, 4095, 16, "as float RGBA", busy);
  ASSERT_FALSE(beyond);
  EXPECT_NE(beyond.error().message.find("more than this machine's 25.3 GB of memory"),
            std::string::npos)
      << beyond.error().message;
  // This machine's own figures are read: both known on Linux.
  const render::internal::MachineMemory here = render::internal::machineMemory();
  EXPECT_GT(here.total, 0.0);
  EXPECT_GT(here.available, 0.0);
}

// readMachineMemory on a fake system: a scratch folder holding /proc/meminfo (24 GB available, no
// swap) and `files` (path under the root, contents), for a machine of 25.3 GB.
render::internal::MachineMemory fakeSystemMemory(
    const std::string& name, const std::vector<std::pair<std::string, std::string>>& files) {
  const std::filesystem::path root = test::scratchDir(name);
  std::vector<std::pair<std::string, std::string>> all = files;
  all.emplace_back("proc/meminfo",
                   "MemTotal:       24683568 kB\nMemFree:        20000000 kB\n"
                   "MemAvailable:   24000000 kB\nSwapTotal:             0 kB\n"
                   "SwapFree:              0 kB\n");
  for (const auto& [relative, text] : all) {
    std::filesystem::create_directories((root / relative).parent_path());
    std::ofstream(root / relative) << text;
  }
  return render::internal::readMachineMemory(root.string(), 25.3e9);
}

// The figures within a control group's limit: a container (cgroup v2) or a job (v1) that may use
// 4 GB on a 25 GB machine is ended by the kernel at 4 GB, so that is the memory a batch must fit.
// What the group holds in inactive file pages (reclaimable cache) does not count as used.
TEST(BatchMemory, ControlGroupLimitsAreTheMachinesMemory) {
  const double machine = 25.3e9, available = 24000000.0 * 1024;
  // No control group file: the machine's figures.
  render::internal::MachineMemory m = fakeSystemMemory("memory_bare", {});
  EXPECT_DOUBLE_EQ(m.total, machine);
  EXPECT_DOUBLE_EQ(m.available, available);

  // cgroup v2, the process in /ci/job (limit 4 GB) below /ci (limit 6 GB); 1.5 GB used of which
  // 0.5 GB inactive file pages.
  const std::vector<std::pair<std::string, std::string>> job = {
      {"proc/self/cgroup", "0::/ci/job\n"},
      {"sys/fs/cgroup/ci/memory.max", "6000000000\n"},
      {"sys/fs/cgroup/ci/job/memory.max", "4000000000\n"},
      {"sys/fs/cgroup/ci/job/memory.current", "1500000000\n"},
      {"sys/fs/cgroup/ci/job/memory.stat",
       "anon 1000000000\nfile 500000000\nactive_file 0\ninactive_file 500000000\n"}};
  m = fakeSystemMemory("memory_v2", job);
  EXPECT_DOUBLE_EQ(m.total, 4e9);
  EXPECT_DOUBLE_EQ(m.available, 3e9);
  // A batch of 6.4 GB is refused against the group's figures.
  auto refused = render::internal::checkBatchMemory(100, 2000, 16, "as float RGBA", m);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find(
                "more than the process's control group's limit of 4.0 GB of memory"),
            std::string::npos)
      << refused.error().message;
  // An unlimited group ("max") leaves the machine's figures.
  auto unlimited = job;
  unlimited[1].second = unlimited[2].second = "max\n";
  m = fakeSystemMemory("memory_v2_max", unlimited);
  EXPECT_DOUBLE_EQ(m.total, machine);
  EXPECT_DOUBLE_EQ(m.available, available);

  // Inside a container the group's path is not under the mount, whose root holds its files.
  m = fakeSystemMemory("memory_container", {{"proc/self/cgroup", "0::/docker/0123abcd\n"},
                                            {"sys/fs/cgroup/memory.max", "2000000000\n"},
                                            {"sys/fs/cgroup/memory.current", "500000000\n"}});
  EXPECT_DOUBLE_EQ(m.total, 2e9);
  EXPECT_DOUBLE_EQ(m.available, 1.5e9);

  // cgroup v1 (a hybrid system: the memory controller on its own hierarchy), "no limit" at the
  // root as v1 writes it, 3 GB on the group.
  m = fakeSystemMemory("memory_v1",
                       {{"proc/self/cgroup", "5:cpu,cpuacct:/\n4:memory:/runner/7\n0::/\n"},
                        {"sys/fs/cgroup/memory/memory.limit_in_bytes", "9223372036854771712\n"},
                        {"sys/fs/cgroup/memory/runner/7/memory.limit_in_bytes", "3000000000\n"},
                        {"sys/fs/cgroup/memory/runner/7/memory.usage_in_bytes", "1000000000\n"},
                        {"sys/fs/cgroup/memory/runner/7/memory.stat",
                         "cache 400000000\ntotal_inactive_file 250000000\n"}});
  EXPECT_DOUBLE_EQ(m.total, 3e9);
  EXPECT_DOUBLE_EQ(m.available, 2.25e9);
}

TEST(Domain, DodecahedronHasTwentyUnitViewsAndFiveLightsEach) {
  auto directions = render::viewDirections(render::ViewSet::kDodecahedron);
  ASSERT_EQ(directions.size(), 20u);
  // All adjacent vertex pairs of a unit dodecahedron subtend the same angle: the minimum pairwise
  // dot product among neighbours is √5/3 ≈ 0.745.
  for (size_t i = 0; i < directions.size(); ++i) {
    EXPECT_NEAR(core::length(directions[i]), 1.0f, 1e-6f);
    float best = -1;
    for (size_t j = 0; j < directions.size(); ++j)
      if (i != j) best = std::max(best, core::dot(directions[i], directions[j]));
    EXPECT_NEAR(best, std::sqrt(5.0f) / 3.0f, 1e-5f);
  }
  core::Sphere sphere{{1, 2, 3}, 0.5f};
  auto samples = render::domainSamples(sphere, 4.0f);
  ASSERT_EQ(samples.size(), 100u);
  for (const render::Sample& s : samples) {
    EXPECT_NEAR(core::length(s.eye - sphere.center), 4.0f, 1e-4f);
    // Lights lie on the plane through the camera orthogonal to the view direction.
    Vec3 direction = core::normalize(s.eye - sphere.center);
    EXPECT_NEAR(core::dot(s.light - s.eye, direction), 0.0f, 1e-4f);
  }
  EXPECT_EQ(render::viewDirections(render::ViewSet::kIcosahedron).size(), 12u);
}

TEST(Domain, UprightViewsStayInTheirBandAndHeldOutViewsAreNew) {
  auto training = render::viewDirections(render::ViewSet::kUpright);
  auto held_out = render::viewDirections(render::heldOutViews(render::ViewSet::kUpright));
  ASSERT_EQ(training.size(), 20u);
  ASSERT_EQ(held_out.size(), 12u);
  auto elevation_deg = [](Vec3 d) { return std::asin(d.y) * 180.0f / 3.14159265f; };
  std::map<int, int> per_ring;
  for (Vec3 d : training) {
    EXPECT_NEAR(core::length(d), 1.0f, 1e-5f);
    ++per_ring[int(std::lround(elevation_deg(d)))];
  }
  EXPECT_EQ(per_ring, (std::map<int, int>{{-10, 5}, {5, 5}, {20, 5}, {35, 5}}));
  float closest = 1.0f;  // cosine of the smallest angle between a held-out and a training view
  for (Vec3 h : held_out) {
    EXPECT_GE(elevation_deg(h), -10.0f);
    EXPECT_LE(elevation_deg(h), 43.0f);
    for (Vec3 t : training) closest = std::min(closest, 1.0f - core::dot(h, t));
  }
  EXPECT_GT(closest, 1e-3f);  // no held-out view repeats a training view
  // Distinct training views, so the 20 × 5 samples are 100 different images.
  for (size_t i = 0; i < training.size(); ++i)
    for (size_t j = i + 1; j < training.size(); ++j)
      EXPECT_LT(core::dot(training[i], training[j]), 0.99f);
  EXPECT_EQ(render::heldOutViews(render::ViewSet::kDodecahedron), render::ViewSet::kIcosahedron);
  auto samples = render::domainSamples({{0, 0, 0}, 1.0f}, 4.0f, {.views = render::ViewSet::kUpright});
  EXPECT_EQ(samples.size(), 100u);
}

TEST(Domain, FootprintMatchesTheProjectedSphere) {
  // fov 90°: tan(45°) = 1. r = 1, d = 2: tan(asin(1/2)) = 1/√3 → 1000/√3 = 577.35 → 578 px.
  EXPECT_EQ(render::footprintPixels({{0, 0, 0}, 1.0f}, 2.0f, {90.0f, 1000}), 578);
  // Twice as far, roughly half the pixels.
  EXPECT_EQ(render::footprintPixels({{0, 0, 0}, 1.0f}, 20.0f, {90.0f, 1000}), 51);
}

// The inverses of the footprint: distanceForDiameterPixels (what --pixels means) and
// distanceForFootprint (where generate and error put d_near and d_far), also where the object is
// wider than the asked footprint at 1e4 radii (a 1° field of view on a 4000-pixel display: the
// search stopped there and returned 1e4 radii, where spot spanned ~46 px instead of 16).
TEST(Domain, DistanceForAFootprintIsItsInverse) {
  const core::Sphere sphere{{1, 2, 3}, 0.5f};
  for (const render::Display display : {render::Display{}, render::Display{1.0f, 4000}}) {
    for (int pixels : {16, 256, 4000}) {
      const float d = render::distanceForFootprint(sphere, pixels, display);
      EXPECT_LE(render::footprintPixels(sphere, d, display), pixels) << pixels;
      EXPECT_GT(render::footprintPixels(sphere, d * 0.999f, display), pixels) << pixels;
      const float exact = render::distanceForDiameterPixels(sphere, pixels, display);
      EXPECT_NEAR(render::projectedDiameterPixels(sphere, exact, display), pixels, 1e-3 * pixels);
    }
  }
}

TEST(Metric, BoundFollowsEquationFour) {
  metric::BoundConfig config{.d_near = 1, .d_far = 5, .q = 0.5f, .e_max = 0.2f};
  EXPECT_DOUBLE_EQ(metric::perPixelBound(config, 1.0), 0.0);
  EXPECT_NEAR(metric::perPixelBound(config, 2.0), std::sqrt(0.25) * 0.2, 1e-7);
  EXPECT_NEAR(metric::perPixelBound(config, 5.0), 0.2, 1e-7);
  EXPECT_NEAR(metric::perPixelBound(config, 9.0), 0.2, 1e-7);  // clamped beyond d_far
  metric::ImageError error{.epsilon = 9.9, .coverage_px = 100};
  EXPECT_TRUE(metric::withinBound(error, config, 5.0));  // 9.9 < 0.2 * 100
  error.epsilon = 20.5;
  EXPECT_FALSE(metric::withinBound(error, config, 5.0));
  // Q = 0: e_max from just beyond d_near on, but 0 at d_near itself (pow(0, 0) gave e_max).
  config.q = 0;
  EXPECT_DOUBLE_EQ(metric::perPixelBound(config, 1.0), 0.0);
  EXPECT_NEAR(metric::perPixelBound(config, 1.5), 0.2, 1e-7);
}

// Batches that do not match are never within a bound, and nothing is read past a buffer.
// s_d (eq. 3) is the reference's alpha: a reference with alpha 0 everywhere (a shader writing a
// vec3 or alpha 0) would make every error 0, so it is refused; one covered pixel is enough.
TEST(Metric, AReferenceWithoutAlphaIsRefused) {
  render::ImageBatchF reference{
      .width = 2, .height = 2, .count = 2, .pixels = std::vector<float>(2 * 2 * 4 * 2, 0.5f)};
  for (size_t i = 3; i < reference.pixels.size(); i += 4) reference.pixels[i] = 0;
  core::Status refused = metric::checkReferenceCoverage(reference);
  ASSERT_FALSE(refused);
  EXPECT_TRUE(test::contains(refused.error().message, "alpha is 0 in every pixel of its"))
      << refused.error().message;
  reference.pixels[4 * 5 + 3] = 0.25f;  // one pixel of the second tile
  EXPECT_TRUE(metric::checkReferenceCoverage(reference));
}

TEST(Metric, MismatchedBatchesGiveAnInfiniteError) {
  render::ImageBatch8 image{
      .width = 4, .height = 4, .count = 2, .pixels = std::vector<uint8_t>(4 * 4 * 4 * 2, 255)};
  render::ImageBatchF reference{
      .width = 4, .height = 4, .count = 2, .pixels = std::vector<float>(4 * 4 * 4 * 2, 1.0f)};
  EXPECT_EQ(metric::imageError(image, reference).epsilon, 0.0);
  render::ImageBatchF fewer = reference;
  fewer.count = 1;
  fewer.pixels.resize(4 * 4 * 4);
  render::ImageBatchF wider = reference;
  wider.width = 8;  // pixels no longer fill the shape
  render::ImageBatch8 short_pixels = image;
  short_pixels.pixels.resize(10);
  for (const metric::ImageError& error :
       {metric::imageError(image, fewer), metric::imageError(image, wider),
        metric::imageError(short_pixels, reference)}) {
    EXPECT_TRUE(std::isinf(error.epsilon));
    EXPECT_FALSE(metric::withinBound(error, {}, 5.0));
  }
}

}  // namespace
}  // namespace duolod

namespace duolod {
namespace {

TEST_F(RendererTest, MultisamplingGivesPartialEdgeCoverage) {
  auto asset = renderer_->uploadAsset(squareAsset({1, 1, 1, 1}));
  ASSERT_TRUE(asset);
  render::Sample sample = frontSample(4.0f);
  sample.projection = core::perspective(2 * std::atan(1.0f / (4.0f * 0.4f)), 1.0f, 0.1f, 100.0f);
  auto plain = renderer_->render(*asset, constant_program_, std::span(&sample, 1), {.resolution = 64});
  auto msaa = renderer_->render(*asset, constant_program_, std::span(&sample, 1),
                                {.resolution = 64, .msaa_samples = 4});
  ASSERT_TRUE(plain && msaa) << (plain ? msaa.error().message : plain.error().message);
  int plain_partial = 0, msaa_partial = 0;
  for (int p = 0; p < 64 * 64; ++p) {
    uint8_t a = plain->tile(0)[p * 4 + 3], b = msaa->tile(0)[p * 4 + 3];
    plain_partial += a > 0 && a < 255;
    msaa_partial += b > 0 && b < 255;
  }
  EXPECT_EQ(plain_partial, 0);  // without MSAA a pixel is either covered or not
  EXPECT_GT(msaa_partial, 50);  // the 4 edges of a 25.6-pixel square cut ~100 pixels
  renderer_->releaseAsset(*asset);
}

TEST_F(RendererTest, ManySamplesSpanSeveralAtlasChunksInOrder) {
  // Large tiles force several atlas passes; tile i must still hold sample i.
  auto asset = renderer_->uploadAsset(squareAsset({1, 0, 0, 1}));
  ASSERT_TRUE(asset);
  std::vector<render::Sample> samples;
  for (int i = 0; i < 6; ++i) {
    render::Sample s = frontSample(4.0f + i);  // farther → smaller square
    s.projection = core::perspective(2 * std::atan(2.0f / 4.0f), 1.0f, 0.1f, 100.0f);
    samples.push_back(s);
  }
  render::RenderStats stats;
  auto batch = renderer_->render(*asset, constant_program_, samples, {.resolution = 3000}, &stats);
  ASSERT_TRUE(batch) << batch.error().message;
  EXPECT_GT(stats.chunks, 1);
  int previous = 1 << 30;
  for (int i = 0; i < 6; ++i) {
    int covered = 0;
    for (size_t p = 0; p < size_t(3000) * 3000; ++p) covered += batch->tile(i)[p * 4 + 3] > 0;
    EXPECT_LT(covered, previous) << "tile " << i;
    previous = covered;
  }
  renderer_->releaseAsset(*asset);
}

// An attribute location past the 16 OpenGL guarantees is refused when the file is read (it was
// "OpenGL error 1281" at the first draw, naming neither file nor key), and a block marked unused
// (-1) is not bound (the same GL error).
TEST(Bindings, LocationsStayWithinWhatOpenGLGuarantees) {
  auto past = render::parseBindings(R"({"attributes": {"normal": 16}})", "b.json");
  ASSERT_FALSE(past);
  EXPECT_TRUE(
      test::contains(past.error().message,
                     "b.json: 'attributes.normal' must be an integer from -1 (unused) to 15"))
      << past.error().message;
  EXPECT_TRUE(render::parseBindings(R"({"attributes": {"normal": 15}, "blocks": {"material": 31}})",
                                    "b.json"));
  // A key given twice was taken silently, the last one winning.
  auto twice = render::parseBindings(R"({"attributes": {"normal": 2, "normal": 1}})", "b.json");
  ASSERT_FALSE(twice);
  EXPECT_TRUE(test::contains(twice.error().message, "b.json: key 'normal' is given twice"))
      << twice.error().message;
  EXPECT_TRUE(render::parseBindings(R"({"attributes": {"normal": 2}, "textures": {"normal": 1}})",
                                    "b.json"));
  auto unused = render::parseBindings(R"({"blocks": {"material": -1}})", "b.json");
  ASSERT_TRUE(unused) << unused.error().message;
  auto renderer = render::Renderer::create({.bindings = *unused});
  if (!renderer) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << renderer.error().message;
  auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
  ASSERT_TRUE(source) << source.error().message;
  auto program = (*renderer)->compileProgram(*source);
  ASSERT_TRUE(program) << program.error().message;
  auto asset = (*renderer)->uploadAsset(squareAsset({0.2f, 0.4f, 0.6f, 1}));
  ASSERT_TRUE(asset) << asset.error().message;
  render::Sample sample = frontSample(4.0f);
  auto images = (*renderer)->render(*asset, *program, std::span(&sample, 1), {.resolution = 16});
  EXPECT_TRUE(images) << images.error().message;
}

TEST(Bindings, ParsesAndRejectsWithTheKeyNamed) {
  auto parsed = render::parseBindings(
      R"({"attributes": {"position": 2, "uv0": -1}, "textures": {"baseColor": 7}})", "b.json");
  ASSERT_TRUE(parsed) << parsed.error().message;
  EXPECT_EQ(parsed->position, 2);
  EXPECT_EQ(parsed->uv0, -1);
  EXPECT_EQ(parsed->base_color, 7);
  EXPECT_EQ(parsed->normal, 1);  // untouched default

  auto unknown = render::parseBindings(R"({"attributes": {"colour": 5}})", "b.json");
  ASSERT_FALSE(unknown);
  EXPECT_NE(unknown.error().message.find("attributes.colour"), std::string::npos);
  auto range = render::parseBindings(R"({"blocks": {"frame": 99}})", "b.json");
  ASSERT_FALSE(range);
  EXPECT_NE(range.error().message.find("blocks.frame"), std::string::npos);
  // Two given at one location are refused; a given one takes a default's location, and the
  // input left at that default becomes unused (it would otherwise be bound over it).
  auto clash = render::parseBindings(R"({"attributes": {"position": 0, "normal": 0}})", "b.json");
  ASSERT_FALSE(clash);
  EXPECT_NE(clash.error().message.find("are both 0"), std::string::npos) << clash.error().message;
  auto taken = render::parseBindings(
      R"({"attributes": {"position": 2}, "textures": {"emissive": 0}})", "b.json");
  ASSERT_TRUE(taken) << taken.error().message;
  EXPECT_EQ(taken->position, 2);
  EXPECT_EQ(taken->tangent, -1);
  EXPECT_EQ(taken->emissive, 0);
  EXPECT_EQ(taken->base_color, -1);
  EXPECT_EQ(taken->normal, 1);
  auto broken = render::parseBindings("{not json", "b.json");
  ASSERT_FALSE(broken);
  EXPECT_NE(broken.error().message.find("b.json"), std::string::npos);
}

}  // namespace
}  // namespace duolod

namespace duolod {
namespace {

// Every triangle of `mesh`, copied once per tile: the soup that reproduces whole regions.
render::Renderer::RegionSoup soupOfWholeMesh(const core::Mesh& mesh,
                                             const std::vector<render::Renderer::RegionTile>& tiles) {
  render::Renderer::RegionSoup soup;
  soup.tiles = tiles;
  for (uint32_t t = 0; t < tiles.size(); ++t)
    for (const core::Submesh& sub : mesh.submeshes)
      for (uint32_t i = sub.first_index; i < sub.first_index + sub.index_count; i += 3) {
        for (int k = 0; k < 3; ++k) {
          uint32_t v = mesh.indices[i + k];
          soup.triangles.positions.push_back(mesh.positions[v]);
          if (!mesh.normals.empty()) soup.triangles.normals.push_back(mesh.normals[v]);
          if (!mesh.tangents.empty()) soup.triangles.tangents.push_back(mesh.tangents[v]);
          if (!mesh.uv0.empty()) soup.triangles.uv0.push_back(mesh.uv0[v]);
        }
        soup.triangle_tile.push_back(t);
        soup.triangle_material.push_back(sub.material);
      }
  return soup;
}

// A duolod shader (shaders/NAME) compiled as is and wrapped for region rendering.
struct RegionPrograms {
  render::Renderer::ProgramId plain = -1, region = -1;
};
core::Result<RegionPrograms> compileForRegions(render::Renderer& renderer, const std::string& name) {
  auto source = render::loadShaderPair(test::sourcePath("shaders/" + name));
  if (!source) return source.error();
  auto plain = renderer.compileProgram(*source);
  if (!plain) return plain.error();
  auto region = renderer.compileRegionProgram(*source);
  if (!region) return region.error();
  return RegionPrograms{*plain, *region};
}

// A renderer of its own with `drawing_threads`, an icosphere uploaded and a duolod shader compiled
// plain and for regions.
struct RegionSetup {
  std::unique_ptr<render::Renderer> renderer;
  core::Asset asset;
  render::Renderer::AssetId id = -1;
  RegionPrograms programs;
};
core::Result<RegionSetup> regionSetup(int drawing_threads, int subdivisions,
                                      const std::string& shader) {
  RegionSetup setup;
  auto created = render::Renderer::create({.drawing_threads = drawing_threads});
  if (!created) return created.error();
  setup.renderer = std::move(created.value());
  setup.asset.mesh = test::icosphere(subdivisions);
  setup.asset.source_path = "icosphere";
  auto id = setup.renderer->uploadAsset(setup.asset);
  if (!id) return id.error();
  setup.id = *id;
  auto programs = compileForRegions(*setup.renderer, shader);
  if (!programs) return programs.error();
  setup.programs = *programs;
  return setup;
}

TEST_F(RendererTest, RegionTilesReproduceTheFullViewPixels) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  auto id = renderer_->uploadAsset(*asset);
  ASSERT_TRUE(id);
  auto programs = compileForRegions(*renderer_, "pbr");
  ASSERT_TRUE(programs) << programs.error().message;
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  const int resolution = 96, tile = 16;
  auto samples = render::domainSamples(sphere, 1.5f);
  auto full = renderer_->render(*id, programs->plain, samples, {.resolution = resolution});
  ASSERT_TRUE(full);
  // Tiles in several views, including ones straddling the image border.
  std::vector<render::Renderer::RegionTile> tiles = {
      {0, 40, 40}, {3, 10, 60}, {7, 80, 0}, {19, 48, 30}, {12, 0, 0}};
  auto soup = soupOfWholeMesh(asset->mesh, tiles);
  render::RenderStats stats;
  auto regions = renderer_->renderRegions(*id, programs->region, soup, samples, 5, resolution,
                                          tile, &stats);
  ASSERT_TRUE(regions) << regions.error().message;
  ASSERT_EQ(regions->count, int(tiles.size()) * 5);
  size_t compared = 0, differing = 0, covered = 0, last_bit = 0;
  for (size_t t = 0; t < tiles.size(); ++t)
    for (int light = 0; light < 5; ++light) {
      const uint8_t* region = regions->tile(int(t) * 5 + light);
      const uint8_t* view = full->tile(tiles[t].view_index * 5 + light);
      for (int y = 0; y < tile; ++y)
        for (int x = 0; x < tile; ++x) {
          int vx = tiles[t].x0 + x, vy = tiles[t].y0 + y;
          if (vx >= resolution || vy >= resolution) continue;  // outside the view
          const uint8_t* a = region + (y * tile + x) * 4;
          const uint8_t* b = view + (vy * resolution + vx) * 4;
          ++compared;
          covered += b[3] > 0;
          int worst = 0;
          for (int c = 0; c < 4; ++c) worst = std::max(worst, std::abs(int(a[c]) - int(b[c])));
          differing += worst > 2;
          last_bit += worst > 0;
        }
    }
  EXPECT_GT(covered, compared / 4) << "the tiles should see the bottle";
  // Tiles are drawn at their view's own window coordinates (in layers), so the rasterizer sees
  // the full view's vertices; only the clip planes at the region's edges may move an interpolated
  // value by a last bit.
  EXPECT_EQ(differing, 0u) << differing << " of " << compared << " pixels differ";
  EXPECT_LE(last_bit, compared / 100) << last_bit << " of " << compared << " differ in a last bit";
  EXPECT_EQ(stats.draws, int(tiles.size()) * 5);
}

// Small views, where every tile overlaps every other: 1000 tiles × 5 lights in two columns need
// 2500 layers, more than llvmpipe's 2048. (Found by generate --views upright on WaterBottle at
// 16 px.) The batch is split and drawn in parts; every tile still holds its region of the full
// view. Before it, 300 then 400 tiles: the layered target grows by doubling (750 → 1500 layers)
// and must stop at the device's limit (it failed as "incomplete" at 60 px). One drawing context,
// so that the parts counted are the layer limit's alone.
TEST_F(RendererTest, RegionTilesBeyondTheLayerLimitAreDrawnInParts) {
  auto setup = regionSetup(1, 1, "noise_phong");
  ASSERT_TRUE(setup) << setup.error().message;
  render::Renderer& renderer = *setup->renderer;
  const core::Asset& asset = setup->asset;
  const render::Renderer::AssetId id = setup->id;
  const RegionPrograms& programs = setup->programs;
  const int resolution = 16, tile = 8;
  auto samples = render::domainSamples(core::computeBoundingSphere(asset.mesh), 4.0f);
  auto full = renderer.render(id, programs.plain, samples, {.resolution = resolution});
  ASSERT_TRUE(full);
  for (int tile_count : {300, 400, 1000}) {
  SCOPED_TRACE(tile_count);
  std::vector<render::Renderer::RegionTile> tiles;
  for (int t = 0; t < tile_count; ++t) tiles.push_back({t % 20, 4 + t % 3, 4 + t % 5});
  render::RenderStats stats;
  auto regions = renderer.renderRegions(id, programs.region, soupOfWholeMesh(asset.mesh, tiles),
                                        samples, 5, resolution, tile, &stats);
  ASSERT_TRUE(regions) << regions.error().message;
  ASSERT_EQ(regions->count, tile_count * 5);
  // Every tile overlaps every other: a layer each, in two columns.
  EXPECT_EQ(stats.chunks, (tile_count + 1) / 2 * 5 > 2048 ? 2 : 1);  // in parts past the limit
  size_t differing = 0, covered = 0;
  for (int t = 0; t < tile_count; ++t)
    for (int light = 0; light < 5; ++light) {
      const uint8_t* region = regions->tile(t * 5 + light);
      const uint8_t* view = full->tile(tiles[t].view_index * 5 + light);
      for (int y = 0; y < tile; ++y)
        for (int x = 0; x < tile; ++x) {
          const uint8_t* a = region + (y * tile + x) * 4;
          const uint8_t* b = view + ((tiles[t].y0 + y) * resolution + tiles[t].x0 + x) * 4;
          covered += b[3] > 0;
          int worst = 0;
          for (int c = 0; c < 4; ++c) worst = std::max(worst, std::abs(int(a[c]) - int(b[c])));
          differing += worst > 2;
        }
    }
  EXPECT_GT(covered, size_t(tile_count) * 5 * tile * tile / 2);
  EXPECT_EQ(differing, 0u);
  }
}

}  // namespace
}  // namespace duolod

namespace duolod {
namespace {

// A diffuse point-lit shader, and two "simplifications" of it that only hold for an object at
// the origin as modelled, both found by operation removal when every training sample had the
// identity model matrix: normalize(light − position) reduced to normalize(light) (Avocado's
// separate LOD), and the normal matrix dropped from the normal's transform (its interleaved LOD).
enum class LitVariant { kFull, kLightFromOrigin, kNoNormalMatrix };
render::GlslSource litShader(LitVariant variant) {
  const std::string frame = R"(
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
)";
  const std::string vertex = "#version 450 core\n" + frame + R"(
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 vWorldPosition;
layout(location = 1) out vec3 vWorldNormal;
void main() {
  vec4 world = uModel * vec4(inPosition, 1.0);
  vWorldPosition = world.xyz;
  vWorldNormal = )" + std::string(variant == LitVariant::kNoNormalMatrix
                                      ? "inNormal;"
                                      : "mat3(uNormalMatrix) * inNormal;") + R"(
  gl_Position = uProjection * (uView * world);
})";
  const std::string fragment = "#version 450 core\n" + frame + R"(
layout(location = 0) in vec3 vWorldPosition;
layout(location = 1) in vec3 vWorldNormal;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 toLight = )" + std::string(variant == LitVariant::kLightFromOrigin
                                      ? "normalize(uLightPosition.xyz);"
                                      : "normalize(uLightPosition.xyz - vWorldPosition);") + R"(
  outColor = vec4(vec3(max(dot(normalize(vWorldNormal), toLight), 0.0)), 1.0);
})";
  return {vertex, fragment, "lit.vert", "lit.frag"};
}

TEST_F(RendererTest, PlacementMovesTheWorldNotTheImageAndExposesOriginOnlyShaders) {
  core::Asset asset;
  asset.source_path = "icosphere";
  asset.mesh = test::icosphere(3);
  asset.mesh.normals = asset.mesh.positions;
  asset.mesh.submeshes = {{0, static_cast<uint32_t>(asset.mesh.indices.size()), 0}};
  asset.materials = {core::Material{}};
  auto id = renderer_->uploadAsset(asset);
  ASSERT_TRUE(id) << id.error().message;

  const core::Sphere sphere = core::computeBoundingSphere(asset.mesh);
  const float distance = 4.0f;
  auto as_modelled = render::domainSamples(sphere, distance, {.place_objects = false});
  auto placed = render::domainSamples(sphere, distance);
  ASSERT_EQ(placed.size(), as_modelled.size());
  for (size_t i = 0; i < placed.size(); ++i) {
    EXPECT_EQ(as_modelled[i].placement.m, core::Mat4::identity().m);
    // Scale 0.5–2, and the translation 0.75–1.25 × 1.5 × the camera distance × that scale.
    const core::Mat4& pose = placed[i].placement;
    const float scale = core::length(core::transformVector(pose, {1, 0, 0}));
    EXPECT_GE(scale, 0.5f - 1e-4f) << i;
    EXPECT_LE(scale, 2.0f + 1e-4f) << i;
    EXPECT_NEAR(core::length(core::transformVector(pose, {0, 0, 1})), scale, 1e-4f) << i;
    const float offset = core::length(core::transformPoint(pose, {0, 0, 0})) / scale;
    EXPECT_GE(offset, 0.75f * 1.5f * distance - 1e-3f) << i;
    EXPECT_LE(offset, 1.25f * 1.5f * distance + 1e-3f) << i;
    // The object-relative camera is the same.
    EXPECT_EQ(placed[i].eye.x, as_modelled[i].eye.x);
  }

  const render::RenderOptions options{.resolution = 48};
  auto render = [&](LitVariant variant, const std::vector<render::Sample>& samples) {
    auto program = renderer_->compileProgram(litShader(variant));
    EXPECT_TRUE(program) << program.error().message;
    auto images = renderer_->render(*id, *program, samples, options);
    EXPECT_TRUE(images) << images.error().message;
    renderer_->releaseProgram(*program);
    return std::move(*images);
  };
  const auto full_as_modelled = render(LitVariant::kFull, as_modelled);
  const auto full_placed = render(LitVariant::kFull, placed);
  // Moving, turning and scaling object, camera and light together changes only float rounding...
  const double placement_change = metric::imageError(full_placed, full_as_modelled).epsilon;
  // ...while each origin-only variant, right or nearly right as modelled, is far off once placed.
  for (LitVariant variant : {LitVariant::kLightFromOrigin, LitVariant::kNoNormalMatrix}) {
    const double as_modelled_error =
        metric::imageError(render(variant, as_modelled), full_as_modelled).epsilon;
    const double placed_error = metric::imageError(render(variant, placed), full_placed).epsilon;
    std::printf("variant %d: %.4g as modelled, %.4g placed; the placement alone changes %.4g\n",
                static_cast<int>(variant), as_modelled_error, placed_error, placement_change);
    EXPECT_LT(placement_change, 0.01 * placed_error);
    EXPECT_GT(placed_error, 3 * as_modelled_error + 10);
  }
  renderer_->releaseAsset(*id);
}

TEST(RendererDevices, ChoosesAnEglDeviceOrSaysHowManyExist) {
  // Mesa lists at least its software device; a GPU machine lists its GPUs too.
  auto first = render::Renderer::create({.device = 0});
  ASSERT_TRUE(first) << first.error().message;
  EXPECT_FALSE((*first)->deviceDescription().empty());
  first.value().reset();
  auto missing = render::Renderer::create({.device = 999});
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("999"), std::string::npos);
}

// A program for region rendering whose colour comes from a plain uniform (location 40) and a
// parameter block (binding 2), what setProgramUniforms and setParameterBlock give a simplified
// shader, and from gl_FragCoord.x: a tile in the second column of a layer is drawn 64 or more
// pixels to the right, so its blue channel tells which column it was drawn in.
using test::kFrameBlock;
constexpr const char* kTintedVertex = R"(
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 vNormal;
void main() {
  vNormal = inNormal;
  gl_Position = uProjection * uView * uModel * vec4(inPosition, 1.0);
}
)";
constexpr const char* kTintedFragment = R"(
layout(location = 40) uniform vec4 uTint;
layout(std140, binding = 2) uniform Parameters { vec4 uOffset; };
layout(location = 0) in vec3 vNormal;
layout(location = 0) out vec4 outColor;
void main() {
  float light = max(dot(normalize(vNormal), normalize(uLightPosition.xyz)), 0.0);
  outColor = vec4(uTint.rg * light + uOffset.rg, gl_FragCoord.x / 256.0, 1.0);
}
)";
render::GlslSource tintedShader() {
  const std::string header = std::string("#version 450 core\n") + kFrameBlock;
  return {header + kTintedVertex, header + kTintedFragment, "tinted.vert", "tinted.frag"};
}

// Tiles over the views in uneven numbers (view v has v % 3 + 1 of them, in view order: 39), so
// that where the views are split between two contexts (about half way, after 19 or 21 tiles), the
// second part's tiles change their place's parity: the column a tile is drawn in must come from
// its place in the whole call. Some overlap, some lie at the image border, some are narrower than
// a tile.
std::vector<render::Renderer::RegionTile> unevenTiles(int resolution) {
  std::vector<render::Renderer::RegionTile> tiles;
  for (int v = 0; v < 20; ++v)
    for (int k = 0; k <= v % 3; ++k) {
      const int t = int(tiles.size());
      tiles.push_back({v, (t * 7) % (resolution - 8), (t * 13) % (resolution - 8),
                       t % 3 == 0 ? 9 : 0, t % 5 == 0 ? 5 : 0});
    }
  return tiles;
}

// A second drawing context (ContextOptions::drawing_threads = 2) draws part of each call's views
// on a thread of its own, with its own copy of the region program: its tiles must be the ones a
// single context draws, bit for bit, also after the program's uniforms and the parameter block
// change between calls (a uniform set in the first context never reached a shared program's
// other context), and when a part is drawn in pieces past the layer limit.
TEST(RendererDrawingThreads, TwoContextsDrawTheTilesOneContextDraws) {
  core::Asset asset;
  asset.mesh = test::icosphere(4);
  asset.source_path = "icosphere";
  const core::Sphere sphere = core::computeBoundingSphere(asset.mesh);
  struct Case {
    const char* what;
    int resolution, tile;
    std::vector<render::Renderer::RegionTile> tiles;
    core::Mesh mesh;  // drawn in every tile
  };
  std::vector<Case> cases;
  cases.push_back({"uneven views at 48 px", 48, 16, unevenTiles(48), asset.mesh});
  cases.push_back({"views wider than a bin, 100 px", 100, 16, unevenTiles(100), asset.mesh});
  {
    // Every tile overlaps every other: a layer each, past 2048 layers in each context.
    std::vector<render::Renderer::RegionTile> crowded;
    for (int t = 0; t < 1800; ++t) crowded.push_back({t % 20, 4 + t % 3, 4 + t % 5});
    cases.push_back({"past the layer limit", 16, 8, std::move(crowded), test::icosphere(1)});
  }
  const render::GlslSource tinted = tintedShader();
  // images[threads - 1][case][round]
  std::vector<render::ImageBatch8> images[2];
  std::vector<int> chunks[2];
  for (int threads : {1, 2}) {
    auto created = render::Renderer::create({.drawing_threads = threads});
    ASSERT_TRUE(created) << created.error().message;
    render::Renderer& renderer = **created;
    auto id = renderer.uploadAsset(asset);
    ASSERT_TRUE(id) << id.error().message;
    auto region = renderer.compileRegionProgram(tinted);
    ASSERT_TRUE(region) << region.error().message;
    for (const Case& c : cases) {
      const auto samples = render::domainSamples(sphere, 4.0f);
      const auto soup = soupOfWholeMesh(c.mesh, c.tiles);
      for (int round = 0; round < 3; ++round) {
        const render::UniformValue tint{
            .location = 40, .components = 4, .value = {0.2f + 0.3f * round, 0.5f, 0.9f, 1}};
        ASSERT_TRUE(renderer.setProgramUniforms(*region, std::span(&tint, 1)));
        const float offset[4] = {0, 0.1f * round, 0, 0};
        ASSERT_TRUE(renderer.setParameterBlock(
            2, std::span(reinterpret_cast<const uint8_t*>(offset), sizeof offset)));
        render::RenderStats stats;
        auto regions = renderer.renderRegions(*id, *region, soup, samples, 5, c.resolution,
                                              c.tile, &stats);
        ASSERT_TRUE(regions) << c.what << ": " << regions.error().message;
        images[threads - 1].push_back(std::move(regions.value()));
        chunks[threads - 1].push_back(stats.chunks);
      }
    }
  }
  ASSERT_EQ(images[0].size(), images[1].size());
  for (size_t i = 0; i < images[0].size(); ++i) {
    const Case& c = cases[i / 3];
    SCOPED_TRACE(std::string(c.what) + ", round " + std::to_string(i % 3));
    // Split: one part more than one context drew (past the layer limit both draw in pieces).
    if (chunks[0][i] == 1) {
      EXPECT_EQ(chunks[1][i], 2) << "the views should have been split";
    }
    ASSERT_EQ(images[0][i].pixels.size(), images[1][i].pixels.size());
    size_t differing = 0, covered = 0;
    for (size_t p = 0; p < images[0][i].pixels.size(); p += 4) {
      covered += images[0][i].pixels[p + 3] > 0;
      differing += std::memcmp(&images[0][i].pixels[p], &images[1][i].pixels[p], 4) != 0;
    }
    EXPECT_GT(covered, images[0][i].pixels.size() / 4 / 8) << "the tiles should see the sphere";
    EXPECT_EQ(differing, 0u);
    // The rounds' tints differ, so each round's images must too (the uniform reached the shader).
    if (i % 3 > 0) {
      EXPECT_NE(images[1][i].pixels, images[1][i - 1].pixels);
    }
  }
  EXPECT_GE(chunks[0][6], 2) << "the crowded case should pass the layer limit";
  EXPECT_GE(chunks[1][6], 4) << "each context's part should pass the layer limit";
}

// Regions that show only background have no triangles to draw: the tiles come back empty (zero),
// also when the whole call or one context's part has none. (An empty vertex buffer was a GL error:
// the image-driven mode failed at 96 px once its regions held only the pixels a collapse can
// change.)
TEST(RendererDrawingThreads, TilesWithoutTrianglesAreBackground) {
  auto setup = regionSetup(2, 2, "noise_phong");
  ASSERT_TRUE(setup) << setup.error().message;
  render::Renderer& renderer = *setup->renderer;
  const core::Asset& asset = setup->asset;
  const render::Renderer::AssetId id = setup->id;
  const RegionPrograms& programs = setup->programs;
  const auto samples = render::domainSamples(core::computeBoundingSphere(asset.mesh), 3.0f);
  std::vector<render::Renderer::RegionTile> tiles;
  for (int t = 0; t < 40; ++t) tiles.push_back({t % 20, 20 + t % 5, 20 + t % 7, 4, 3});
  // No triangle at all; then triangles only in the tiles of views 0-4, so that the views the
  // second context draws have none.
  render::Renderer::RegionSoup empty;
  empty.tiles = tiles;
  auto some = soupOfWholeMesh(asset.mesh, tiles);
  render::Renderer::RegionSoup first_views;
  first_views.tiles = tiles;
  for (size_t t = 0; t < some.triangle_tile.size(); ++t) {
    if (tiles[some.triangle_tile[t]].view_index >= 5) continue;
    first_views.triangle_tile.push_back(some.triangle_tile[t]);
    first_views.triangle_material.push_back(some.triangle_material[t]);
    for (int k = 0; k < 3; ++k) {
      first_views.triangles.positions.push_back(some.triangles.positions[t * 3 + k]);
      if (!some.triangles.normals.empty())
        first_views.triangles.normals.push_back(some.triangles.normals[t * 3 + k]);
    }
  }
  for (const auto* soup : {&empty, &first_views}) {
    auto regions = renderer.renderRegions(id, programs.region, *soup, samples, 5, 48, 8);
    ASSERT_TRUE(regions) << regions.error().message;
    ASSERT_EQ(regions->count, int(tiles.size()) * 5);
    size_t covered_first = 0, covered_later = 0;
    for (size_t t = 0; t < tiles.size(); ++t)
      for (int light = 0; light < 5; ++light) {
        const uint8_t* tile = regions->tile(int(t) * 5 + light);
        for (int p = 0; p < 8 * 8; ++p)
          (tiles[t].view_index < 5 ? covered_first : covered_later) += tile[p * 4 + 3] > 0;
      }
    EXPECT_EQ(covered_later, 0u);
    if (soup == &empty)
      EXPECT_EQ(covered_first, 0u);
    else
      EXPECT_GT(covered_first, 0u);
  }
}

// The image-driven simplifier releases its programs and meshes after each level and makes new
// ones for the next (generate's mesh cascade), at another footprint. When both contexts drew with
// one shared program, deleting it crashed llvmpipe at the next draw (generate at its second level;
// this test in its second round). Now the helper's own copy is deleted in its own context.
TEST(RendererDrawingThreads, ProgramsAndAssetsReleasedBetweenCallsAreNotUsedAgain) {
  auto created = render::Renderer::create({.drawing_threads = 2});
  ASSERT_TRUE(created) << created.error().message;
  render::Renderer& renderer = **created;
  core::Asset asset;
  asset.mesh = test::icosphere(3);
  asset.source_path = "icosphere";
  const core::Sphere sphere = core::computeBoundingSphere(asset.mesh);
  for (int round = 0; round < 6; ++round) {
    SCOPED_TRACE(round);
    auto id = renderer.uploadAsset(asset);
    ASSERT_TRUE(id) << id.error().message;
    auto programs = compileForRegions(renderer, round % 2 ? "noise_phong" : "pbr");
    ASSERT_TRUE(programs) << programs.error().message;
    const int resolution = 40 + 12 * round, tile = 8 + 4 * (round % 2);
    const auto samples = render::domainSamples(sphere, 3.0f + round);
    std::vector<render::Renderer::RegionTile> tiles;
    for (int t = 0; t < 60; ++t) tiles.push_back({t % 20, (t * 5) % 32, (t * 11) % 32});
    for (int call = 0; call < 3; ++call) {
      render::RenderStats stats;
      auto regions = renderer.renderRegions(*id, programs->region, soupOfWholeMesh(asset.mesh, tiles),
                                            samples, 5, resolution, tile, &stats);
      ASSERT_TRUE(regions) << regions.error().message;
      EXPECT_EQ(stats.chunks, 2);
    }
    auto full = renderer.render(*id, programs->plain, samples, {.resolution = resolution});
    ASSERT_TRUE(full) << full.error().message;
    renderer.releaseProgram(programs->plain);
    renderer.releaseProgram(programs->region);
    renderer.releaseAsset(*id);
  }
}

// A request still running at the threshold is reported once, then again each time its time
// doubles, never after it ended, and not at all with the sink off. The clock is the test's own:
// reportSlowRequests is given the time to report at (the monitor thread's real-time polls find
// nothing due within the test's few milliseconds).
TEST(SlowRequests, ReportedAtTheThresholdThenEachTimeItDoubles) {
  using std::chrono::seconds;
  std::mutex mutex;
  std::vector<render::SlowRequest> reports;
  render::setSlowRequestSink(30, [&](const render::SlowRequest& request) {
    std::lock_guard lock(mutex);
    reports.push_back(request);
  });
  auto reportCount = [&] {
    std::lock_guard lock(mutex);
    return reports.size();
  };
  std::chrono::steady_clock::time_point began;
  {
    const render::internal::SlowRequestWatch watch(true, "rendering %d images of %d px", 7, 64);
    began = std::chrono::steady_clock::now();
    render::internal::reportSlowRequests(began + seconds(29));
    EXPECT_EQ(reportCount(), 0u);
    render::internal::reportSlowRequests(began + seconds(31));
    ASSERT_EQ(reportCount(), 1u);
    EXPECT_EQ(reports[0].what, "rendering 7 images of 64 px");
    EXPECT_TRUE(reports[0].first_draw);
    EXPECT_EQ(reports[0].report, 0);
    EXPECT_GE(reports[0].seconds, 31.0);
    EXPECT_LT(reports[0].seconds, 32.0);
    // Not again until 60 s, then 120 s.
    render::internal::reportSlowRequests(began + seconds(35));
    render::internal::reportSlowRequests(began + seconds(59));
    EXPECT_EQ(reportCount(), 1u);
    render::internal::reportSlowRequests(began + seconds(61));
    ASSERT_EQ(reportCount(), 2u);
    EXPECT_EQ(reports[1].report, 1);
    render::internal::reportSlowRequests(began + seconds(100));
    EXPECT_EQ(reportCount(), 2u);
    render::internal::reportSlowRequests(began + seconds(121));
    ASSERT_EQ(reportCount(), 3u);
    EXPECT_EQ(reports[2].report, 2);
    // A second request beside it is its own.
    const render::internal::SlowRequestWatch other(false, "timing");
    render::internal::reportSlowRequests(std::chrono::steady_clock::now() + seconds(31));
    ASSERT_EQ(reportCount(), 4u);
    EXPECT_EQ(reports[3].what, "timing");
    EXPECT_FALSE(reports[3].first_draw);
  }
  // Ended: nothing more.
  render::internal::reportSlowRequests(began + seconds(1000));
  EXPECT_EQ(reportCount(), 4u);
  // Off: a request is not even marked.
  render::setSlowRequestSink(30, {});
  {
    const render::internal::SlowRequestWatch watch(true, "unseen");
    render::internal::reportSlowRequests(std::chrono::steady_clock::now() + seconds(1000));
  }
  EXPECT_EQ(reportCount(), 4u);
}

// The renderer marks its requests with what they draw: a render slower than the threshold (here
// 1 µs, reported at the monitor's next poll) is reported with its program's name, as a first
// draw the first time the program draws and not the next.
TEST_F(RendererTest, SlowRendersAreReportedWithTheirProgram) {
  std::mutex mutex;
  std::vector<render::SlowRequest> reports;
  render::setSlowRequestSink(1e-6, [&](const render::SlowRequest& request) {
    std::lock_guard lock(mutex);
    reports.push_back(request);
  });
  auto asset = renderer_->uploadAsset(squareAsset({0.25f, 0.5f, 0.75f, 1}));
  ASSERT_TRUE(asset) << asset.error().message;
  auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
  ASSERT_TRUE(source) << source.error().message;
  source->vertex_name = "slow_test.vert";
  source->fragment_name = "slow_test.frag";
  auto program = renderer_->compileProgram(*source);
  ASSERT_TRUE(program) << program.error().message;
  // Each render lasts until the monitor has reported it: many samples, drawn again and again.
  const std::vector<render::Sample> samples(200, frontSample(4.0f));
  auto renderUntilReported = [&](size_t already) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      auto batch = renderer_->render(*asset, *program, samples, {.resolution = 256});
      EXPECT_TRUE(batch) << batch.error().message;
      std::lock_guard lock(mutex);
      if (reports.size() > already) return;
    }
  };
  renderUntilReported(0);
  render::setSlowRequestSink(30, {});
  std::lock_guard lock(mutex);
  ASSERT_FALSE(reports.empty()) << "no render was reported in 200 attempts";
  const render::SlowRequest first = reports.front();
  EXPECT_EQ(first.what, "rendering 200 images of 256 px with slow_test.vert + slow_test.frag");
  // Only the first attempt holds the program's first draw: the reports that say so come first.
  const auto firstDraws = std::partition_point(
      reports.begin(), reports.end(), [](const render::SlowRequest& r) { return r.first_draw; });
  EXPECT_TRUE(std::none_of(firstDraws, reports.end(),
                           [](const render::SlowRequest& r) { return r.first_draw; }));
  renderer_->releaseProgram(*program);
  renderer_->releaseAsset(*asset);
}

}  // namespace
}  // namespace duolod
