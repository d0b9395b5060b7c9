// shader::checkShaderInterface: a user's pair against what duolod feeds it. duolod's own shaders
// pass without a word; each kind of input that reads zeros is named in a warning; pairs that
// cannot render right are errors naming the file and variable.
#include <gtest/gtest.h>

#include <string>

#include "duolod/shader.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

std::string vertexStage(const std::string& extra_inputs = "") {
  return std::string("#version 450 core\nlayout(location = 0) in vec3 inPosition;\n") +
         extra_inputs + test::kFrameBlock + R"(
layout(location = 0) out vec3 vA;
layout(location = 1) out vec2 vB;
void main() {
  vA = inPosition;
  vB = inPosition.xy;
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";
}

std::string fragmentStage(const std::string& declarations, const std::string& extra_terms) {
  return "#version 450 core\n" + declarations + R"(
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(vA )" +
         extra_terms + R"(, 1.0); }
)";
}

render::GlslSource pair(const std::string& vertex, const std::string& fragment) {
  return {vertex, fragment, "test.vert", "test.frag"};
}

bool anyContains(const std::vector<std::string>& lines, const std::string& text) {
  for (const std::string& line : lines)
    if (line.find(text) != std::string::npos) return true;
  return false;
}

TEST(ShaderInterfaceCheck, DuolodsOwnShadersPassWithoutAWord) {
  for (const char* name : {"pbr", "noise_phong", "blend", "constant"}) {
    auto source = render::loadShaderPair(name);
    ASSERT_TRUE(source.ok()) << source.error().message;
    auto warnings = checkShaderInterface(*source);
    ASSERT_TRUE(warnings.ok()) << name << ": " << warnings.error().message;
    EXPECT_TRUE(warnings->empty()) << name << ": " << warnings->front();
  }
  // The HLSL example, translated as the CLI translates it (inputs placed by semantic).
  CompileOptions vertex_options;
  vertex_options.vertex_input_locations = render::hlslVertexInputLocations();
  auto hlsl = hlslPairToGlsl(test::readText(test::sourcePath("shaders/hlsl/lambert.vert.hlsl")),
                             "lambert.vert.hlsl",
                             test::readText(test::sourcePath("shaders/hlsl/lambert.frag.hlsl")),
                             "lambert.frag.hlsl", vertex_options);
  ASSERT_TRUE(hlsl.ok()) << hlsl.error().message;
  auto warnings = checkShaderInterface({hlsl->vertex, hlsl->fragment, "v", "f"});
  ASSERT_TRUE(warnings.ok()) << warnings.error().message;
  EXPECT_TRUE(warnings->empty()) << warnings->front();
}

TEST(ShaderInterfaceCheck, WhatReadsZerosIsNamed) {
  const std::string declarations = R"(
layout(location = 0) in vec3 vA;
layout(location = 1) in vec2 vB;
layout(std140, binding = 3) uniform Lights { vec4 uLight; };
layout(std430, binding = 6) buffer Data { vec4 data[]; };
layout(location = 3) uniform float uTime;
layout(binding = 0) uniform sampler2D uBase;
layout(binding = 7) uniform sampler2D uOther;
layout(binding = 2) uniform samplerCube uEnv;
)";
  const std::string terms =
      "+ uLight.xyz + data[0].xyz + uTime + texture(uBase, vB).rgb + texture(uOther, vB).rgb + "
      "texture(uEnv, vA).rgb";
  auto warnings = checkShaderInterface(pair(vertexStage("layout(location = 7) in vec3 inExtra;\n"),
                                            fragmentStage(declarations, terms)));
  ASSERT_TRUE(warnings.ok()) << warnings.error().message;
  for (const char* expected :
       {"test.vert: vertex input 'inExtra' at location 7 is fed no mesh stream",
        "test.frag: 'uOther' at binding 7 is bound to no texture",
        "test.frag: 'uEnv' at binding 2 is a samplerCube",
        "test.frag: uniform block 'Lights' at binding 3 is neither Frame nor Material",
        "test.frag: storage block 'Data' at binding 6 gets no buffer",
        "test.frag: uniform 'uTime' at location 3 is set by nothing"})
    EXPECT_TRUE(anyContains(*warnings, expected)) << expected;
  EXPECT_EQ(warnings->size(), 6u);
  // Bindings that feed them: the input and the texture are fed, the rest still read zeros.
  render::Bindings bindings;
  bindings.color = 7;
  bindings.emissive = 7;
  auto bound = checkShaderInterface(pair(vertexStage("layout(location = 7) in vec3 inExtra;\n"),
                                         fragmentStage(declarations, terms)),
                                    bindings);
  ASSERT_TRUE(bound.ok()) << bound.error().message;
  EXPECT_FALSE(anyContains(*bound, "inExtra"));
  EXPECT_FALSE(anyContains(*bound, "uOther"));
  EXPECT_EQ(bound->size(), 4u);
}

// duolod reads the colour at location 0 and counts the object's pixels by its alpha: a fragment
// stage must write a float vec4 there (an array's element 0 is what location 0 gets).
TEST(ShaderInterfaceCheck, TheColourIsAVec4AtLocationZero) {
  const std::string in = "#version 450 core\nlayout(location = 0) in vec3 vA;\n";
  struct Case {
    const char* body;
    const char* refusal;  // nullptr: accepted
  };
  const Case cases[] = {
      {"layout(location = 0) out vec4 outColor[2];\n"
       "void main() { outColor[0] = vec4(vA, 1.0); outColor[1] = vec4(1.0); }\n",
       nullptr},
      {"void main() {}\n", "test.frag: writes no colour output at location 0"},
      {"layout(location = 3) out vec4 outColor;\nvoid main() { outColor = vec4(vA, 1.0); }\n",
       "test.frag: writes no colour output at location 0"},
      {"layout(location = 0) out vec3 outColor;\nvoid main() { outColor = vA; }\n",
       "its colour output 'outColor' at location 0 is a vec3, which leaves alpha undefined"},
      {"layout(location = 0) out uvec4 outColor;\nvoid main() { outColor = uvec4(vA, 1.0); }\n",
       "is a uvec4, which a colour attachment cannot take"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.body);
    auto checked = checkShaderInterface(pair(vertexStage(), in + c.body));
    if (!c.refusal) {
      EXPECT_TRUE(checked.ok()) << checked.error().message;
      continue;
    }
    ASSERT_FALSE(checked.ok());
    EXPECT_NE(checked.error().message.find(c.refusal), std::string::npos)
        << checked.error().message;
  }
}

TEST(ShaderInterfaceCheck, PairsThatCannotRenderRightAreErrors) {
  auto missing = checkShaderInterface(
      pair(vertexStage(),
           fragmentStage("layout(location = 0) in vec3 vA;\nlayout(location = 2) in vec2 vC;\n",
                         "+ vec3(vC, 0.0)")));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find(
                "test.frag: fragment input 'vC' at location 2: test.vert writes no output"),
            std::string::npos)
      << missing.error().message;

  auto mistyped = checkShaderInterface(
      pair(vertexStage(),
           fragmentStage("layout(location = 0) in vec3 vA;\nlayout(location = 1) in vec3 vB;\n",
                         "+ vB")));
  ASSERT_FALSE(mistyped.ok());
  EXPECT_NE(mistyped.error().message.find("'vB' at location 1 is a vec3, but test.vert's output "
                                          "there, 'vB', is a vec2"),
            std::string::npos)
      << mistyped.error().message;

  auto shared_unit = checkShaderInterface(
      pair(vertexStage(),
           fragmentStage("layout(location = 0) in vec3 vA;\nlayout(location = 1) in vec2 vB;\n"
                         "layout(binding = 0) uniform sampler2D uBase;\n"
                         "layout(binding = 0) uniform samplerCube uEnv;\n",
                         "+ texture(uBase, vB).rgb + texture(uEnv, vA).rgb")));
  ASSERT_FALSE(shared_unit.ok());
  EXPECT_NE(shared_unit.error().message.find("share texture unit 0"), std::string::npos)
      << shared_unit.error().message;

  // The right pair passes.
  auto fine = checkShaderInterface(
      pair(vertexStage(),
           fragmentStage("layout(location = 0) in vec3 vA;\nlayout(location = 1) in vec2 vB;\n",
                         "+ vec3(vB, 0.0)")));
  ASSERT_TRUE(fine.ok()) << fine.error().message;
  EXPECT_TRUE(fine->empty());
}

// What OpenGL accepts passes (a review's false errors): a fragment input the code never reads
// (nothing reads it undefined), varyings split by component, an unused sampler sharing a unit,
// a fragment input reading one element of an array output. A sampler array takes consecutive
// units, each compared.
TEST(ShaderInterfaceCheck, WhatOpenGLAcceptsPasses) {
  const std::string vertex =
      std::string("#version 450 core\nlayout(location = 0) in vec3 inPosition;\n") +
      test::kFrameBlock + R"(
layout(location = 0) out vec3 vA;
layout(location = 1, component = 0) out vec2 vLow;
layout(location = 1, component = 2) out vec2 vHigh;
layout(location = 2) out vec4 vArray[2];
void main() {
  vA = inPosition;
  vLow = inPosition.xy;
  vHigh = inPosition.yz;
  vArray[0] = vec4(inPosition, 1.0);
  vArray[1] = vec4(inPosition.zyx, 1.0);
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";
  const std::string fragment = fragmentStage(R"(
layout(location = 0) in vec3 vA;
layout(location = 1) in vec2 vLow;
layout(location = 1, component = 2) in vec2 vHigh;
layout(location = 3) in vec4 vSecond;
layout(location = 9) in vec3 vNeverRead;
layout(binding = 0) uniform sampler2D uBase;
layout(binding = 0) uniform samplerCube uNeverSampled;
)",
                                             "+ texture(uBase, vLow + vHigh).rgb + vSecond.xyz");
  auto accepted = checkShaderInterface(pair(vertex, fragment));
  ASSERT_TRUE(accepted.ok()) << accepted.error().message;
  EXPECT_TRUE(accepted->empty()) << accepted->front();

  auto arrays = checkShaderInterface(
      pair(vertexStage(),
           fragmentStage("layout(location = 0) in vec3 vA;\nlayout(location = 1) in vec2 vB;\n"
                         "layout(binding = 0) uniform sampler2D uPair[2];\n"
                         "layout(binding = 1) uniform samplerCube uEnv;\n",
                         "+ texture(uPair[0], vB).rgb + texture(uPair[1], vB).rgb + "
                         "texture(uEnv, vA).rgb")));
  ASSERT_FALSE(arrays.ok());
  EXPECT_NE(arrays.error().message.find("'uEnv' (a samplerCube) and test.frag: 'uPair[1]' (a "
                                        "sampler2D) share texture unit 1"),
            std::string::npos)
      << arrays.error().message;
}

}  // namespace
}  // namespace duolod::shader
