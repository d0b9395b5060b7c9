// Per-pixel → per-vertex (Wang et al. 2014; Liang et al. §4.1): a fragment value computed from
// interpolated inputs and uniforms moves to the vertex stage behind a new varying. On a square
// whose corner normals lean outwards, `normalize(n) * 0.5 + 0.5` per pixel differs from the
// Gouraud version; after the rule the image must equal a hand-written Gouraud shader.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"
#include "shader_rules_support.hpp"

namespace duolod::shader {
namespace {

using namespace test_rules;

const char* kPerPixelFragment = R"(#version 450 core
layout(location = 0) in vec3 vNormal;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 c = normalize(vNormal) * 0.5 + 0.5;
  outColor = vec4(c, 1.0);
}
)";

// The same shading written per vertex by hand.
std::string gouraudVertex(const std::string& color_expression, const std::string& extra = "") {
  return std::string("#version 450 core\n") + kFrameBlock + extra + R"(
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 vColor;
void main() {
  vColor = )" +
         color_expression + R"(;
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";
}
const char* kGouraudFragment = R"(#version 450 core
layout(location = 0) in vec3 vColor;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(vColor, 1.0); }
)";

int maxDifference(const render::ImageBatch8& a, const render::ImageBatch8& b) {
  EXPECT_EQ(a.pixels.size(), b.pixels.size());
  int worst = 0;
  for (size_t i = 0; i < std::min(a.pixels.size(), b.pixels.size()); ++i)
    worst = std::max(worst, std::abs(int(a.pixels[i]) - int(b.pixels[i])));
  return worst;
}

class PerVertex : public RendererFixture {
 protected:
  // Applies the rule at the site named `value_name` and checks the result renders like the
  // hand-written Gouraud program and unlike the per-pixel original.
  void expectGouraud(const ShaderProgram& original, const std::string& value_name,
                     const std::string& gouraud_vertex) {
    RuleContext context;
    std::vector<RuleSite> sites = findPerVertexSites(original, context);
    const RuleSite* site = siteNamed(sites, value_name);
    ASSERT_NE(site, nullptr) << "no per-vertex site for " << value_name << " among "
                             << sites.size();
    auto moved = applyPerVertex(original, *site, context);
    ASSERT_TRUE(moved.ok()) << moved.error().message;
    EXPECT_LT(bodyInstructionCount(moved->fragment), bodyInstructionCount(original.fragment));

    render::ImageBatch8 per_pixel = renderSquare(emitValidated(original, "original"));
    render::ImageBatch8 per_vertex = renderSquare(emitValidated(*moved, "per-vertex"));
    render::ImageBatch8 by_hand =
        renderSquare(emitValidated(makeProgram(gouraud_vertex, kGouraudFragment), "by hand"));
    ASSERT_FALSE(per_vertex.pixels.empty());
    EXPECT_LE(maxDifference(per_vertex, by_hand), 1) << "not the Gouraud image";
    // The control: the per-pixel image really is different, so the comparison can fail.
    EXPECT_GE(maxDifference(per_pixel, by_hand), 10);
  }
};

TEST_F(PerVertex, NormalColourBecomesGouraud) {
  expectGouraud(makeProgram(passThroughVertex(), kPerPixelFragment), "c",
                gouraudVertex("normalize(inNormal) * 0.5 + 0.5"));
}

// A uniform block only the fragment stage declared is declared in the vertex stage (same binding
// and layout), and a called function is copied.
TEST_F(PerVertex, CopiesFunctionsAndDeclaresMissingBlocks) {
  const char* material = R"(
layout(std140, binding = 1) uniform Material {
  vec4 uBaseColorFactor; vec4 uEmissiveFactor; vec4 uMaterialParams; vec4 uTextureFlags;
  vec4 uTextureFlags2;
};
)";
  std::string fragment = std::string("#version 450 core\n") + material + R"(
layout(location = 0) in vec3 vNormal;
layout(location = 0) out vec4 outColor;
vec3 encodeNormal(vec3 n) { return normalize(n) * 0.5 + 0.5; }
void main() {
  vec3 tinted = encodeNormal(vNormal) * uBaseColorFactor.rgb;
  outColor = vec4(tinted, 1.0);
}
)";
  ShaderProgram original = makeProgram(passThroughVertex(), fragment);
  expectGouraud(
      original, "tinted",
      gouraudVertex("(normalize(inNormal) * 0.5 + 0.5) * uBaseColorFactor.rgb", material));
}

// Values the vertex stage cannot compute are not offered: a texture sample, gl_FragCoord, a local
// written twice, an input the vertex stage does not write.
TEST(PerVertexSites, OnlyValuesTheVertexStageCanCompute) {
  const char* fragment = R"(#version 450 core
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(location = 0) in vec3 vNormal;
layout(location = 1) in vec2 vUV;
layout(location = 5) in vec3 vNotWritten;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 textured = texture(uBaseColorTexture, vUV).rgb * 2.0;
  vec3 screen = gl_FragCoord.xyz * 0.01;
  vec3 twice = vNormal * 2.0;
  twice = twice * 3.0;
  vec3 missing = vNotWritten * 4.0;
  vec3 fine = vNormal * 5.0;
  outColor = vec4(textured + screen + twice + missing + fine, 1.0);
}
)";
  ShaderProgram program = makeProgram(passThroughVertex(), fragment);
  std::vector<RuleSite> sites = findPerVertexSites(program, {});
  EXPECT_EQ(siteNamed(sites, "textured"), nullptr);
  EXPECT_EQ(siteNamed(sites, "screen"), nullptr);
  EXPECT_EQ(siteNamed(sites, "missing"), nullptr);
  EXPECT_NE(siteNamed(sites, "fine"), nullptr);
  // `twice` is written twice: its first value (vNormal * 2) can move, the local cannot.
  for (const RuleSite& site : sites) {
    auto applied = applyPerVertex(program, site, {});
    ASSERT_TRUE(applied.ok()) << site.description << ": " << applied.error().message;
    emitValidated(*applied, site.description);
  }
}

TEST(PerVertexSites, StaleSiteFailsCleanly) {
  ShaderProgram program = makeProgram(passThroughVertex(), kPerPixelFragment);
  std::vector<RuleSite> sites = findPerVertexSites(program, {});
  const RuleSite* site = siteNamed(sites, "c");
  ASSERT_NE(site, nullptr);
  auto once = applyPerVertex(program, *site, {});
  ASSERT_TRUE(once.ok()) << once.error().message;
  auto twice = applyPerVertex(*once, *site, {});  // the value was removed
  EXPECT_FALSE(twice.ok());
  // Two different values compose, each with its own varying location.
  std::vector<RuleSite> remaining = findPerVertexSites(*once, {});
  for (const RuleSite& other : remaining) {
    auto composed = applyPerVertex(*once, other, {});
    ASSERT_TRUE(composed.ok()) << composed.error().message;
    emitValidated(*composed, other.description);
  }
}

// After moving to parameter, a value reading the new uniform can still move per vertex: the
// vertex stage declares the same loose uniform at the same location (one uniform once linked).
TEST_F(PerVertex, ComposesWithMovingToParameter) {
  const char* fragment = R"(#version 450 core
layout(location = 0) in vec3 vNormal;
layout(location = 1) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  float v = 0.25 + 0.5 * vUV.x;
  vec3 c = normalize(vNormal) * v;
  outColor = vec4(c, 1.0);
}
)";
  ShaderProgram program = makeProgram(passThroughVertex(), fragment);
  RuleContext context;
  context.average_value = [](const ShaderProgram&, Stage, ir::Id) {
    return core::Result<std::vector<float>>(std::vector<float>{0.5f});
  };
  std::vector<RuleSite> parameter_sites = findMoveToParameterSites(program, context);
  const RuleSite* v = siteNamed(parameter_sites, "v");
  ASSERT_NE(v, nullptr);
  auto with_parameter = applyMoveToParameter(program, *v, context);
  ASSERT_TRUE(with_parameter.ok()) << with_parameter.error().message;
  std::vector<RuleSite> vertex_sites = findPerVertexSites(*with_parameter, context);
  const RuleSite* c = siteNamed(vertex_sites, "c");
  ASSERT_NE(c, nullptr);
  auto moved = applyPerVertex(*with_parameter, *c, context);
  ASSERT_TRUE(moved.ok()) << moved.error().message;
  ir::DefUse vertex_uses(moved->vertex);
  std::vector<ir::LooseUniform> uniforms = ir::looseUniforms(moved->vertex, vertex_uses);
  ASSERT_EQ(uniforms.size(), 1u);
  EXPECT_EQ(uniforms[0].location, context.first_parameter_location);
  render::ImageBatch8 image = renderSquare(emitValidated(*moved, "parameter then per-vertex"));
  EXPECT_FALSE(image.pixels.empty());
}

// The reference shaders: how many sites, and every sampled application validates; a few link.
class PerVertexReference : public RendererFixture,
                           public ::testing::WithParamInterface<const char*> {};

TEST_P(PerVertexReference, SampledSitesValidateAndLink) {
  std::string name = GetParam();
  ShaderProgram program =
      makeProgram(readShaderFile(name + ".vert"), readShaderFile(name + ".frag"));
  std::vector<RuleSite> sites = findPerVertexSites(program, {});
  std::cout << "[ per-vertex ] " << name << ": " << sites.size() << " sites\n";
  ASSERT_FALSE(sites.empty()) << name;
  // DUOLOD_ALL_SITES=1 applies every site and lists them (for measurements; slower).
  const bool all_sites = std::getenv("DUOLOD_ALL_SITES") != nullptr;
  const size_t sample = all_sites ? sites.size() : std::min<size_t>(20, sites.size());
  if (all_sites)
    for (const RuleSite& site : sites) std::cout << "    " << site.description << "\n";
  const size_t linked = 3;
  for (size_t k = 0; k < sample; ++k) {
    const RuleSite& site = sites[k * sites.size() / sample];
    auto applied = applyPerVertex(program, site, {});
    ASSERT_TRUE(applied.ok()) << site.description << ": " << applied.error().message;
    EXPECT_LT(bodyInstructionCount(applied->fragment), bodyInstructionCount(program.fragment) + 2)
        << site.description;
    render::SpirvBinary binary = emitValidated(*applied, name + " " + site.description);
    if (k % (sample / linked + 1) == 0 && !binary.fragment.empty()) {
      auto compiled = renderer_->compileProgram(binary);
      EXPECT_TRUE(compiled.ok()) << site.description << ": "
                                 << (compiled.ok() ? "" : compiled.error().message);
      if (compiled.ok()) renderer_->releaseProgram(*compiled);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Shaders, PerVertexReference,
                         ::testing::Values("noise_phong", "pbr", "blend"));

}  // namespace
}  // namespace duolod::shader
