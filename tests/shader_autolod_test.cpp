// Olano's single LOD shader: four hand-written levels with clashing parameters and varyings are
// combined into one program; rendered with autoLOD at each threshold, it draws exactly (ε = 0) what
// that level draws alone.
#include <gtest/gtest.h>

#include <cmath>

#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/autolod.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

std::string vertexSource(const std::string& extra_declarations, const std::string& extra_code) {
  return std::string("#version 450 core\nlayout(location = 0) in vec3 inPosition;\n") +
         test::kFrameBlock + "layout(location = 0) out vec3 vObjectPosition;\n" +
         extra_declarations + "void main() {\n  vObjectPosition = inPosition;\n" + extra_code +
         "  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));\n}\n";
}

std::string fragmentSource(const std::string& declarations, const std::string& body) {
  return std::string("#version 450 core\n") + test::kFrameBlock +
         "layout(location = 0) in vec3 vObjectPosition;\nlayout(location = 0) out vec4 "
         "outColor;\n" +
         declarations + "void main() {\n" + body + "}\n";
}

// Level 0, the "original": a helper function with a loop (stripes on the object-space position).
const std::string kOriginalFragment = fragmentSource(R"(
float stripes(vec3 p) {
  float sum = 0.0;
  for (int octave = 0; octave < 3; ++octave) sum += 0.25 * sin(p.x * float(4 << octave));
  return sum;
}
)", "  outColor = vec4(0.5 + stripes(vObjectPosition), 0.3, 0.6 + 0.3 * vObjectPosition.y, 1.0);\n");

// Level 1: a parameter at location 40 and a vec3 varying at location 16 (a per-vertex move).
const std::string kLevel1Vertex =
    vertexSource("layout(location = 16) out vec3 vMoved;\n", "  vMoved = 0.5 + 0.25 * inPosition;\n");
const std::string kLevel1Fragment = fragmentSource(
    "layout(location = 16) in vec3 vMoved;\nlayout(location = 40) uniform float uAverage;\n",
    "  outColor = vec4(vMoved.x, uAverage, vMoved.y, 1.0);\n");

// Level 2: clashes with level 1 on both: another value at location 40, a float at location 16.
const std::string kLevel2Vertex =
    vertexSource("layout(location = 16) out float vShade;\n", "  vShade = 0.5 + 0.5 * inPosition.y;\n");
const std::string kLevel2Fragment = fragmentSource(
    "layout(location = 16) in float vShade;\nlayout(location = 40) uniform float uAverage;\n",
    "  outColor = vec4(uAverage, vShade, 0.2, 1.0);\n");

// Level 3, "nearly constant": the original's vertex stage, a constant colour.
const std::string kConstantFragment = fragmentSource("", "  outColor = vec4(0.4, 0.3, 0.6, 1.0);\n");

std::vector<uint32_t> compiled(const std::string& source, Stage stage) {
  auto words = compileToSpirv(source, stage, stage == Stage::kVertex ? "level.vert" : "level.frag");
  EXPECT_TRUE(words) << words.error().message;
  return words ? *words : std::vector<uint32_t>{};
}

ShaderProgram program(const std::string& vertex, const std::string& fragment,
                      std::vector<ParameterValue> parameters) {
  ShaderProgram result;
  auto parsed_vertex = ir::parseModule(compiled(vertex, Stage::kVertex));
  auto parsed_fragment = ir::parseModule(compiled(fragment, Stage::kFragment));
  EXPECT_TRUE(parsed_vertex && parsed_fragment);
  if (parsed_vertex) result.vertex = *parsed_vertex;
  if (parsed_fragment) result.fragment = *parsed_fragment;
  result.parameters = std::move(parameters);
  return result;
}

std::vector<ShaderProgram> testLevels() {
  std::string plain_vertex = vertexSource("", "");
  return {program(plain_vertex, kOriginalFragment, {}),
          program(kLevel1Vertex, kLevel1Fragment, {{"uAverage", 40, 1, {0.75f, 0, 0, 0}}}),
          program(kLevel2Vertex, kLevel2Fragment, {{"uAverage", 40, 1, {0.25f, 0, 0, 0}}}),
          program(plain_vertex, kConstantFragment, {})};
}

const std::vector<float> kThresholds = {0.0f, 1.0f, 2.5f, 4.0f};

render::SpirvBinary binary(const ShaderProgram& program) {
  return {ir::emitModule(program.vertex), ir::emitModule(program.fragment)};
}

std::vector<render::UniformValue> uniforms(const std::vector<ParameterValue>& parameters) {
  std::vector<render::UniformValue> values;
  for (const ParameterValue& parameter : parameters)
    values.push_back({static_cast<int>(parameter.location), parameter.components, parameter.value});
  return values;
}

// The switch's name and location are checked on the original before any search: a user uniform
// at location 39 (or named autoLOD) failed `shader` and `generate` only once every level was made.
TEST(AutoLodTest, AnOriginalHoldingTheSwitchsPlaceIsRefusedFirst) {
  const std::string plain_vertex = vertexSource("", "");
  EXPECT_TRUE(
      checkRoomForAutoLod(program(plain_vertex, kOriginalFragment, {}), "o.vert", "o.frag"));
  const ShaderProgram at_39 =
      program(plain_vertex,
              fragmentSource("layout(location = 39) uniform float uExposure;\n",
                             "  outColor = vec4(uExposure, 0.0, 0.0, 1.0);\n"),
              {});
  core::Status refused = checkRoomForAutoLod(at_39, "o.vert", "exposure.frag");
  ASSERT_FALSE(refused);
  EXPECT_TRUE(
      test::contains(refused.error().message, "exposure.frag: uniform 'uExposure' at location 39"))
      << refused.error().message;
  const ShaderProgram named = program(vertexSource("layout(location = 7) uniform float autoLOD;\n",
                                                   "  vObjectPosition.x += autoLOD;\n"),
                                      kConstantFragment, {});
  refused = checkRoomForAutoLod(named, "named.vert", "o.frag");
  ASSERT_FALSE(refused);
  EXPECT_TRUE(
      test::contains(refused.error().message, "named.vert: uniform 'autoLOD' at location 7"))
      << refused.error().message;
}

TEST(AutoLodTest, LevelSelectionFollowsThresholds) {
  EXPECT_EQ(autoLodLevel(kThresholds, 0.0f), 0);
  EXPECT_EQ(autoLodLevel(kThresholds, -3.0f), 0);  // below the first threshold: the original
  EXPECT_EQ(autoLodLevel(kThresholds, 0.99f), 0);
  EXPECT_EQ(autoLodLevel(kThresholds, 1.0f), 1);
  EXPECT_EQ(autoLodLevel(kThresholds, 2.5f), 2);
  EXPECT_EQ(autoLodLevel(kThresholds, 100.0f), 3);
  EXPECT_EQ(autoLodLevel(kThresholds, std::nanf("")), 0);
}

TEST(AutoLodTest, MergedModulesValidateAndMoveOnlyTheClashes) {
  std::vector<ShaderProgram> levels = testLevels();
  auto lod = buildAutoLodShader(levels, kThresholds);
  ASSERT_TRUE(lod) << lod.error().message;
  // Level 2's parameter (another value at 40) and varying (a float at 16) move; level 1's stay.
  EXPECT_EQ(lod->moved_parameters, 1);
  EXPECT_EQ(lod->moved_varyings, 1);
  ASSERT_EQ(lod->program.parameters.size(), 2u);
  EXPECT_EQ(lod->program.parameters[0].location, 40u);
  EXPECT_EQ(lod->program.parameters[1].location, 41u);
  EXPECT_EQ(lod->program.parameters[1].value[0], 0.25f);
  // Levels 0 and 3 share their vertex stage; 1 and 2 have their own.
  EXPECT_EQ(lod->distinct_vertex_stages, 3);
  EXPECT_EQ(lod->vertex_stage_of_level, (std::vector<int>{0, 1, 2, 0}));
  EXPECT_TRUE(validateSpirv(ir::emitModule(lod->program.vertex), "vertex"));
  EXPECT_TRUE(validateSpirv(ir::emitModule(lod->program.fragment), "fragment"));
  ASSERT_EQ(lod->program.history.size(), 4u);
  EXPECT_TRUE(test::contains(lod->program.history[0], "original"));

  // The fragment stage has the original's helper once per level that calls it, renamed per level.
  ir::DefUse uses(lod->program.fragment);
  auto loose = ir::looseUniforms(lod->program.fragment, uses);
  bool has_autolod = false;
  for (const ir::LooseUniform& uniform : loose)
    has_autolod |= uniform.name == "autoLOD" && uniform.location == 39u;
  EXPECT_TRUE(has_autolod);
  EXPECT_EQ(lod->program.fragment.functions.size(), 6u);  // the new main, 4 level mains, stripes
}

TEST(AutoLodTest, OneVertexStageWhenAllLevelsShareIt) {
  std::string plain_vertex = vertexSource("", "");
  std::vector<ShaderProgram> levels = {program(plain_vertex, kOriginalFragment, {}),
                                       program(plain_vertex, kConstantFragment, {})};
  std::vector<float> thresholds = {0.0f, 1.0f};
  auto lod = buildAutoLodShader(levels, thresholds);
  ASSERT_TRUE(lod) << lod.error().message;
  EXPECT_EQ(lod->distinct_vertex_stages, 1);
  EXPECT_EQ(ir::emitModule(lod->program.vertex), ir::emitModule(levels[0].vertex));
}

TEST(AutoLodTest, BadInputsAreClearErrors) {
  std::vector<ShaderProgram> levels = testLevels();
  std::vector<float> decreasing = {0.0f, 2.0f, 1.0f, 3.0f};
  auto not_increasing = buildAutoLodShader(levels, decreasing);
  ASSERT_FALSE(not_increasing);
  EXPECT_TRUE(test::contains(not_increasing.error().message, "increase")) << not_increasing.error().message;
  std::vector<float> too_few = {0.0f};
  EXPECT_FALSE(buildAutoLodShader(levels, too_few));
  AutoLodOptions taken{.autolod_location = 40};
  auto clash = buildAutoLodShader(levels, kThresholds, taken);
  ASSERT_FALSE(clash);
  EXPECT_TRUE(test::contains(clash.error().message, "location 40")) << clash.error().message;
}

// A quad in front of the camera covering most of the tile.
core::Asset quadAsset() {
  core::Asset asset;
  asset.source_path = "quad";
  asset.mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  asset.mesh.normals.assign(4, core::Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  asset.materials = {core::Material{}};
  return asset;
}

// Two cameras in front of the quad (both see its front face).
std::vector<render::Sample> frontSamples() {
  std::vector<render::Sample> samples(2);
  for (size_t i = 0; i < samples.size(); ++i) {
    samples[i].eye = {0.3f * static_cast<float>(i), 0, 4};
    samples[i].light = samples[i].eye;
    samples[i].view = core::lookAt(samples[i].eye, {0, 0, 0}, {0, 1, 0});
    samples[i].projection = core::perspective(0.8f, 1.0f, 0.1f, 100.0f);
  }
  return samples;
}

TEST(AutoLodTest, EachThresholdRendersItsLevelExactly) {
  auto created = render::Renderer::create();
  if (!created) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << created.error().message;
  render::Renderer& renderer = **created;
  std::vector<ShaderProgram> levels = testLevels();
  auto lod = buildAutoLodShader(levels, kThresholds);
  ASSERT_TRUE(lod) << lod.error().message;

  auto asset = renderer.uploadAsset(quadAsset());
  ASSERT_TRUE(asset) << asset.error().message;
  std::vector<render::Sample> samples = frontSamples();
  auto lod_program = renderer.compileProgram(binary(lod->program));
  ASSERT_TRUE(lod_program) << lod_program.error().message;

  std::vector<std::vector<uint8_t>> level_images;
  for (size_t k = 0; k < levels.size(); ++k) {
    auto alone = renderer.compileProgram(binary(levels[k]));
    ASSERT_TRUE(alone) << alone.error().message;
    ASSERT_TRUE(renderer.setProgramUniforms(*alone, uniforms(levels[k].parameters)));
    auto expected = renderer.render(*asset, *alone, samples, {.resolution = 48});
    ASSERT_TRUE(expected) << expected.error().message;
    level_images.push_back(expected->pixels);

    std::vector<render::UniformValue> values = uniforms(lod->program.parameters);
    values.push_back({39, 1, {kThresholds[k], 0, 0, 0}});
    ASSERT_TRUE(renderer.setProgramUniforms(*lod_program, values));
    auto actual = renderer.render(*asset, *lod_program, samples, {.resolution = 48});
    ASSERT_TRUE(actual) << actual.error().message;
    EXPECT_EQ(actual->pixels, expected->pixels) << "autoLOD = " << kThresholds[k] << ", level " << k;
  }
  // The quad covers pixels, and the levels really differ, so the comparison above could fail.
  size_t covered = 0;
  for (size_t i = 3; i < level_images[0].size(); i += 4) covered += level_images[0][i] != 0;
  EXPECT_GT(covered, level_images[0].size() / 16);
  for (size_t k = 1; k < level_images.size(); ++k) EXPECT_NE(level_images[k], level_images[k - 1]);
}

// Olano's frozen snapshot: with autoLOD and the parameters frozen into constants, the LOD shader
// draws each level exactly as the level frozen with its own parameters, with no uniform set.
TEST(AutoLodTest, FrozenAtEachThresholdRendersItsLevelExactly) {
  auto created = render::Renderer::create();
  if (!created) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << created.error().message;
  render::Renderer& renderer = **created;
  std::vector<ShaderProgram> levels = testLevels();
  auto lod = buildAutoLodShader(levels, kThresholds);
  ASSERT_TRUE(lod) << lod.error().message;
  auto asset = renderer.uploadAsset(quadAsset());
  ASSERT_TRUE(asset) << asset.error().message;
  std::vector<render::Sample> samples = frontSamples();

  auto renderFrozen = [&](const ShaderProgram& program, std::vector<ParameterValue> values) {
    auto frozen = freezeUniforms(program, values);
    EXPECT_TRUE(frozen) << frozen.error().message;
    EXPECT_TRUE(frozen->parameters.empty());
    auto id = renderer.compileProgram(binary(*frozen));
    EXPECT_TRUE(id) << id.error().message;
    auto images = renderer.render(*asset, *id, samples, {.resolution = 48});
    EXPECT_TRUE(images) << images.error().message;
    renderer.releaseProgram(*id);
    return images->pixels;
  };
  std::vector<uint8_t> previous;
  for (size_t k = 0; k < levels.size(); ++k) {
    std::vector<uint8_t> expected = renderFrozen(levels[k], levels[k].parameters);
    std::vector<ParameterValue> values = lod->program.parameters;
    values.push_back({"autoLOD", 39, 1, {kThresholds[k] + 0.25f, 0, 0, 0}});  // inside level k
    EXPECT_EQ(renderFrozen(lod->program, values), expected) << "level " << k;
    EXPECT_NE(expected, previous);
    previous = expected;
  }
  // Freezing a float at a vec3's location is refused.
  std::vector<ParameterValue> wrong = {{"uAverage", 40, 3, {1, 2, 3, 0}}};
  EXPECT_FALSE(freezeUniforms(levels[1], wrong));
}

}  // namespace
}  // namespace duolod::shader
