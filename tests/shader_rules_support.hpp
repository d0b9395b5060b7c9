// Shared by the shader rule tests (shader_rules_test, and the value rules: moving to parameter,
// per-vertex): one renderer per test binary, a lit square, a frontal camera, a small vertex stage
// on the duolod interface, and compile/render helpers for ShaderPrograms.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/rules.hpp"
#include "test_support.hpp"

namespace duolod::shader::test_rules {

// The Frame block of shaders/INTERFACE.md, for hand-written test stages.
using ::duolod::test::kFrameBlock;

// Passes the object-space normal (location 0) and uv (location 1) on.
inline std::string passThroughVertex() {
  return std::string("#version 450 core\n") + kFrameBlock + R"(
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 3) in vec2 inUV0;
layout(location = 0) out vec3 vNormal;
layout(location = 1) out vec2 vUV;
void main() {
  vNormal = inNormal;
  vUV = inUV0;
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";
}

// A 2×2 square in z = 0 facing +z; uv (0,0) at (-1,-1) to (1,1) at (1,1); the normals lean
// outwards at the corners (unnormalised), so per-pixel and per-vertex normalisation differ.
inline core::Asset tiltedSquare() {
  core::Asset asset;
  asset.source_path = "tilted square";
  asset.mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  asset.mesh.normals = {
      {-0.9f, -0.9f, 0.4f}, {0.9f, -0.9f, 0.4f}, {0.9f, 0.9f, 0.4f}, {-0.9f, 0.9f, 0.4f}};
  asset.mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  core::Material material;
  material.base_color_factor = {0.8f, 0.6f, 0.4f, 1};
  asset.materials = {material};
  return asset;
}

// A camera on +z whose field of view makes the square cover the middle half of the image.
inline render::Sample frontSample(float distance = 4) {
  render::Sample sample;
  sample.eye = {0, 0, distance};
  sample.light = sample.eye;
  sample.view = core::lookAt(sample.eye, {0, 0, 0}, {0, 1, 0});
  sample.projection = core::perspective(2 * std::atan(2.0f / distance), 1.0f, 0.1f, 100.0f);
  return sample;
}

inline std::vector<uint32_t> compileStage(const std::string& source, Stage stage,
                                          const std::string& name) {
  auto words = compileToSpirv(source, stage, name);
  EXPECT_TRUE(words.ok()) << name << ": " << (words.ok() ? "" : words.error().message);
  return words.ok() ? *words : std::vector<uint32_t>{};
}

inline std::string readShaderFile(const std::string& file) {
  std::ifstream in(test::sourcePath("shaders/" + file));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Both stages parsed into a ShaderProgram (rules.hpp), straight from the IR.
inline ShaderProgram makeProgram(const std::string& vertex_source,
                                 const std::string& fragment_source) {
  ShaderProgram program;
  auto vertex = ir::parseModule(compileStage(vertex_source, Stage::kVertex, "test.vert"));
  auto fragment = ir::parseModule(compileStage(fragment_source, Stage::kFragment, "test.frag"));
  EXPECT_TRUE(vertex.ok() && fragment.ok());
  if (vertex.ok()) program.vertex = *vertex;
  if (fragment.ok()) program.fragment = *fragment;
  return program;
}

// Emits and validates both stages; empty words on failure (with a test failure).
inline render::SpirvBinary emitValidated(const ShaderProgram& program, const std::string& what) {
  render::SpirvBinary binary{ir::emitModule(program.vertex), ir::emitModule(program.fragment)};
  auto vertex_ok = validateSpirv(binary.vertex, what + " (vertex)");
  auto fragment_ok = validateSpirv(binary.fragment, what + " (fragment)");
  EXPECT_TRUE(vertex_ok.ok()) << (vertex_ok.ok() ? "" : vertex_ok.error().message);
  EXPECT_TRUE(fragment_ok.ok()) << (fragment_ok.ok() ? "" : fragment_ok.error().message);
  if (!vertex_ok.ok() || !fragment_ok.ok()) return {};
  return binary;
}

// Instructions in the function bodies of a module (what a stage executes, before clean-up).
inline size_t bodyInstructionCount(const ir::Module& module) {
  size_t count = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks) count += block.instructions.size();
  return count;
}

// The site whose description mentions `name` (e.g. "fragment: v → its average over the domain"), or
// nullptr.
inline const RuleSite* siteNamed(const std::vector<RuleSite>& sites, const std::string& name) {
  for (const RuleSite& site : sites)
    if (site.description.find(": " + name + " ") != std::string::npos) return &site;
  return nullptr;
}

// One renderer per test binary; tests skip loudly when there is no OpenGL 4.5 context.
class RendererFixture : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto created = render::Renderer::create();
    if (!created) {
      failure_ = created.error().message;
      return;
    }
    renderer_ = std::move(created.value()).release();
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  void SetUp() override {
    if (!renderer_) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << failure_;
  }
  // Renders `binary` on the square from the front; empty on failure (with a test failure).
  render::ImageBatch8 renderSquare(const render::SpirvBinary& binary, int resolution = 64) {
    auto asset = renderer_->uploadAsset(tiltedSquare());
    EXPECT_TRUE(asset.ok());
    auto program = renderer_->compileProgram(binary);
    EXPECT_TRUE(program.ok()) << (program.ok() ? "" : program.error().message);
    render::ImageBatch8 images;
    if (asset.ok() && program.ok()) {
      std::vector<render::Sample> samples = {frontSample()};
      auto rendered = renderer_->render(*asset, *program, samples, {.resolution = resolution});
      EXPECT_TRUE(rendered.ok()) << (rendered.ok() ? "" : rendered.error().message);
      if (rendered.ok()) images = std::move(*rendered);
    }
    if (program.ok()) renderer_->releaseProgram(*program);
    if (asset.ok()) renderer_->releaseAsset(*asset);
    return images;
  }

  static inline render::Renderer* renderer_ = nullptr;
  static inline std::string failure_;
};

}  // namespace duolod::shader::test_rules
