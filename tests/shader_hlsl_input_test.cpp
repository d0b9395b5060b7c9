// HLSL input (shader::hlslToGlsl): an HLSL shader on duolod's interface becomes GLSL 450 that
// renders what the same shader written in GLSL renders, with the interface's bindings and
// readable names; broken HLSL is an error naming the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>

#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/rules.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

// shaders/hlsl/lambert.*.hlsl written in GLSL by hand.
const char* kGlslTwinVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 3) in vec2 inUV0;
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) out vec3 vWorldPosition;
layout(location = 1) out vec3 vWorldNormal;
layout(location = 2) out vec2 vUV;
void main() {
  vec4 world = uModel * vec4(inPosition, 1.0);
  vWorldPosition = world.xyz;
  vWorldNormal = mat3(uNormalMatrix) * inNormal;
  vUV = inUV0;
  gl_Position = uProjection * (uView * world);
}
)";
const char* kGlslTwinFragment = R"(#version 450 core
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(std140, binding = 1) uniform Material {
  vec4 uBaseColorFactor; vec4 uEmissiveFactor; vec4 uMaterialParams; vec4 uTextureFlags;
  vec4 uTextureFlags2;
};
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(location = 0) in vec3 vWorldPosition;
layout(location = 1) in vec3 vWorldNormal;
layout(location = 2) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 n = normalize(vWorldNormal);
  vec3 l = normalize(uLightPosition.xyz - vWorldPosition);
  vec3 albedo = uBaseColorFactor.rgb * texture(uBaseColorTexture, vUV).rgb;
  vec3 lit = albedo * (uAmbientColor.rgb + uLightColor.rgb * max(dot(n, l), 0.0));
  outColor = vec4(pow(clamp(lit, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);
}
)";

std::string exampleHlsl(const char* file) {
  return test::readText(test::sourcePath(std::string("shaders/hlsl/") + file));
}

// A vertex stage's options on duolod's interface: its inputs placed by semantic where the
// renderer binds the mesh's streams (as the CLI compiles an HLSL vertex shader).
CompileOptions onTheInterface() {
  CompileOptions options;
  options.vertex_input_locations = render::hlslVertexInputLocations();
  return options;
}

TEST(HlslInput, TheExampleBecomesGlslOnTheInterface) {
  auto vertex = hlslToGlsl(exampleHlsl("lambert.vert.hlsl"), Stage::kVertex, "lambert.vert.hlsl",
                           onTheInterface());
  ASSERT_TRUE(vertex.ok()) << vertex.error().message;
  auto fragment =
      hlslToGlsl(exampleHlsl("lambert.frag.hlsl"), Stage::kFragment, "lambert.frag.hlsl");
  ASSERT_TRUE(fragment.ok()) << fragment.error().message;
  // The interface: attribute locations by semantic, block bindings from registers, the
  // texture and its sampler as one sampler2D at the texture's binding.
  for (const char* expected :
       {"layout(location = 0) in vec3 input_position", "layout(location = 1) in vec3 input_normal",
        "layout(location = 3) in vec2 input_uv", "layout(binding = 0, std140) uniform Frame",
        "} frame;", "layout(location = 0) out vec3 out_worldPosition"})
    EXPECT_TRUE(test::contains(*vertex, expected)) << expected << "\n" << *vertex;
  for (const char* expected : {"layout(binding = 1, std140) uniform Material", "} material;",
                               "layout(binding = 0) uniform sampler2D uBaseColorTexture;",
                               "layout(location = 0) out vec4 outColor;"})
    EXPECT_TRUE(test::contains(*fragment, expected)) << expected << "\n" << *fragment;
  EXPECT_FALSE(test::contains(*fragment, "uBaseColorSampler")) << *fragment;
  // What it emits is GLSL duolod compiles as it compiles a user's.
  EXPECT_TRUE(compileToSpirv(*vertex, Stage::kVertex, "vertex").ok());
  EXPECT_TRUE(compileToSpirv(*fragment, Stage::kFragment, "fragment").ok());
}

TEST(HlslInput, TheExampleRendersAsItsGlslTwin) {
  DUOLOD_REQUIRE_ASSET(path, "obj/spot/spot.obj");
  std::string failure;
  std::unique_ptr<render::Renderer> renderer(test::createRenderer(failure));
  if (!renderer) FAIL() << failure;
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  auto id = renderer->uploadAsset(*asset);
  ASSERT_TRUE(id.ok()) << id.error().message;

  auto vertex = hlslToGlsl(exampleHlsl("lambert.vert.hlsl"), Stage::kVertex, "lambert.vert.hlsl",
                           onTheInterface());
  auto fragment =
      hlslToGlsl(exampleHlsl("lambert.frag.hlsl"), Stage::kFragment, "lambert.frag.hlsl");
  ASSERT_TRUE(vertex.ok() && fragment.ok());
  auto from_hlsl = renderer->compileProgram({*vertex, *fragment, "hlsl.vert", "hlsl.frag"});
  ASSERT_TRUE(from_hlsl.ok()) << from_hlsl.error().message;
  auto twin =
      renderer->compileProgram({kGlslTwinVertex, kGlslTwinFragment, "twin.vert", "twin.frag"});
  ASSERT_TRUE(twin.ok()) << twin.error().message;

  const core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  std::vector<render::Sample> all = render::domainSamples(sphere, sphere.radius * 3.0f);
  std::vector<render::Sample> samples;
  for (size_t i = 0; i < all.size(); i += 23) samples.push_back(all[i]);
  const render::RenderOptions options{.resolution = 96};
  auto expected = renderer->render(*id, *twin, samples, options);
  ASSERT_TRUE(expected.ok()) << expected.error().message;
  auto actual = renderer->render(*id, *from_hlsl, samples, options);
  ASSERT_TRUE(actual.ok()) << actual.error().message;
  ASSERT_EQ(actual->pixels.size(), expected->pixels.size());
  int largest = 0;
  size_t covered = 0, lit = 0;
  for (size_t i = 0; i < expected->pixels.size(); ++i) {
    largest = std::max(largest, std::abs(int(actual->pixels[i]) - int(expected->pixels[i])));
    if (i % 4 == 3 && expected->pixels[i] > 0) {
      ++covered;
      if (expected->pixels[i - 3] > 40) ++lit;
    }
  }
  EXPECT_GT(covered, 2000u) << "the object must be visible";
  EXPECT_GT(lit, covered / 4) << "and lit, not black";
  // The same image up to float rounding (the HLSL path computes 1/2.2 as a constant).
  EXPECT_LE(largest, 1);
  renderer->releaseAsset(*id);
}

TEST(HlslInput, BrokenShadersAreErrorsNamingTheFile) {
  auto broken = hlslToGlsl("float4 main() : SV_Target {\n  return float4(1, 2);\n}\n",
                           Stage::kFragment, "broken.hlsl");
  ASSERT_FALSE(broken.ok());
  EXPECT_TRUE(test::contains(broken.error().message, "broken.hlsl")) << broken.error().message;
  CompileOptions options;
  options.entry_point = "PSMain";
  auto missing =
      hlslToGlsl(exampleHlsl("lambert.frag.hlsl"), Stage::kFragment, "lambert.frag.hlsl", options);
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(test::contains(missing.error().message, "PSMain")) << missing.error().message;
  // One texture under two sampler states has no single sampler2D to become.
  auto two_samplers = hlslToGlsl(R"(Texture2D uBaseColorTexture : register(t0);
SamplerState uLinear : register(s0);
SamplerState uPoint : register(s1);
float4 main(float4 position : SV_Position, float2 uv : TEXCOORD0) : SV_Target {
  return uBaseColorTexture.Sample(uLinear, uv) + uBaseColorTexture.Sample(uPoint, uv);
}
)",
                                 Stage::kFragment, "two.hlsl");
  ASSERT_FALSE(two_samplers.ok());
  EXPECT_TRUE(test::contains(two_samplers.error().message, "two.hlsl: texture 'uBaseColorTexture'"))
      << two_samplers.error().message;
}

// What a fragment shader of the interface reads, for the tests below.
const char* kFragmentHeader = R"(Texture2D uBaseColorTexture : register(t0);
SamplerState uBaseColorSampler : register(s0);
Texture2D uNormalTexture : register(t2);
SamplerState uNormalSampler : register(s2);
)";

TEST(HlslInput, TexturesPassedToFunctionsKeepTheirBindings) {
  // Before legalization the texture reached the sample as a function-local copy, which
  // SPIRV-Cross declared as a uniform of its own ('param') with no binding: unit 0 was sampled.
  auto glsl = hlslToGlsl(std::string(kFragmentHeader) + R"(
float3 fetch(Texture2D t, SamplerState s, float2 uv) { return t.Sample(s, uv).rgb; }
float4 main(float4 position : SV_Position, float2 uv : TEXCOORD0) : SV_Target {
  return float4(fetch(uBaseColorTexture, uBaseColorSampler, uv) +
                fetch(uNormalTexture, uNormalSampler, uv), 1);
}
)",
                         Stage::kFragment, "helper.hlsl");
  ASSERT_TRUE(glsl.ok()) << glsl.error().message;
  EXPECT_TRUE(test::contains(*glsl, "layout(binding = 2) uniform sampler2D uNormalTexture;"))
      << *glsl;
  EXPECT_TRUE(test::contains(*glsl, "layout(binding = 0) uniform sampler2D uBaseColorTexture;"))
      << *glsl;
  EXPECT_FALSE(test::contains(*glsl, "param")) << *glsl;
  // One function: the entry point is inlined into main(), so the shader rules see its values as
  // values of the entry point (they refused everything in a separate _main()).
  EXPECT_FALSE(test::contains(*glsl, "_main(")) << *glsl;
  auto example =
      hlslToGlsl(exampleHlsl("lambert.frag.hlsl"), Stage::kFragment, "lambert.frag.hlsl");
  ASSERT_TRUE(example.ok()) << example.error().message;
  EXPECT_FALSE(test::contains(*example, "_main(")) << *example;

  // Two sampler states on one texture through a helper are the same error as directly.
  auto two_samplers = hlslToGlsl(std::string(kFragmentHeader) + R"(
float4 fetch(Texture2D t, SamplerState s, float2 uv) { return t.Sample(s, uv); }
float4 main(float4 position : SV_Position, float2 uv : TEXCOORD0) : SV_Target {
  return fetch(uBaseColorTexture, uBaseColorSampler, uv) + fetch(uBaseColorTexture, uNormalSampler, uv);
}
)",
                                 Stage::kFragment, "two.hlsl");
  ASSERT_FALSE(two_samplers.ok());
  EXPECT_TRUE(test::contains(two_samplers.error().message, "two.hlsl: texture 'uBaseColorTexture'"))
      << two_samplers.error().message;
}

TEST(HlslInput, TheExampleOffersTheRulesWhatItsGlslTwinOffers) {
  // Before legalization the HLSL entry point was a function of its own: the value rules refused
  // its values and the whole vertex stage counted as computing the position (23 sites against
  // the twin's 46, none per-vertex).
  auto sitesOf = [](const std::string& vertex, const std::string& fragment) {
    auto v = compileToSpirv(vertex, Stage::kVertex, "vertex");
    auto f = compileToSpirv(fragment, Stage::kFragment, "fragment");
    EXPECT_TRUE(v.ok() && f.ok());
    std::array<int, 6> per_rule{};
    if (!v.ok() || !f.ok()) return per_rule;
    auto program = parseProgram(*v, *f);
    EXPECT_TRUE(program.ok());
    if (!program.ok()) return per_rule;
    RuleContext context;
    context.average_value = [](const ShaderProgram&, Stage, ir::Id) -> core::Result<std::vector<float>> {
      return std::vector<float>{0.5f};
    };
    context.texture_averages[0] = {0.5f, 0.5f, 0.5f, 1.0f};
    for (const RuleSite& site : enumerateSites(*program, context)) ++per_rule.at(size_t(site.kind));
    return per_rule;
  };
  auto vertex = hlslToGlsl(exampleHlsl("lambert.vert.hlsl"), Stage::kVertex, "lambert.vert.hlsl",
                           onTheInterface());
  auto fragment =
      hlslToGlsl(exampleHlsl("lambert.frag.hlsl"), Stage::kFragment, "lambert.frag.hlsl");
  ASSERT_TRUE(vertex.ok() && fragment.ok());
  const std::array<int, 6> from_hlsl = sitesOf(*vertex, *fragment);
  const std::array<int, 6> from_glsl = sitesOf(kGlslTwinVertex, kGlslTwinFragment);
  EXPECT_EQ(from_hlsl, from_glsl);
  EXPECT_GT(from_hlsl[size_t(RuleKind::kPerVertex)], 0);
}

TEST(HlslInput, APairsVaryingsMatchBySemantic) {
  // The example's vertex stage writes worldPosition (TEXCOORD0), worldNormal (TEXCOORD1) and uv
  // (TEXCOORD2); this pixel shader reads two of them, in another order, one in lower case. By
  // declaration order they were locations 0 and 1: uv read worldPosition, with no error.
  const std::string fragment = R"(cbuffer Frame : register(b0) { float4x4 uModel; };
struct PixelInput {
  float4 position : SV_Position;
  float2 uv : TEXCOORD2;
  float3 worldNormal : texcoord1;
};
float4 main(PixelInput input) : SV_Target {
  return float4(input.uv, input.worldNormal.x, 1);
}
)";
  auto pair = hlslPairToGlsl(exampleHlsl("lambert.vert.hlsl"), "lambert.vert.hlsl", fragment,
                             "subset.frag.hlsl", onTheInterface());
  ASSERT_TRUE(pair.ok()) << pair.error().message;
  EXPECT_TRUE(test::contains(pair->vertex, "layout(location = 1) out vec3")) << pair->vertex;
  EXPECT_TRUE(test::contains(pair->vertex, "layout(location = 2) out vec2")) << pair->vertex;
  EXPECT_TRUE(test::contains(pair->fragment, "layout(location = 2) in vec2")) << pair->fragment;
  EXPECT_TRUE(test::contains(pair->fragment, "layout(location = 1) in vec3")) << pair->fragment;
  // What one stage alone gives: declaration order.
  auto alone = hlslToGlsl(fragment, Stage::kFragment, "subset.frag.hlsl");
  ASSERT_TRUE(alone.ok()) << alone.error().message;
  EXPECT_TRUE(test::contains(*alone, "layout(location = 0) in vec2")) << *alone;

  // An input that no output writes is an error naming it, its semantic and what is written.
  std::string unwritten = fragment;
  unwritten.replace(unwritten.find("TEXCOORD2"), 9, "COLOR");
  auto missing = hlslPairToGlsl(exampleHlsl("lambert.vert.hlsl"), "lambert.vert.hlsl", unwritten,
                                "missing.frag.hlsl", onTheInterface());
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(test::contains(missing.error().message, "missing.frag.hlsl: input '")) << missing.error().message;
  EXPECT_TRUE(test::contains(missing.error().message,
                             "(COLOR0) is not written by the vertex stage (its outputs: TEXCOORD0, "
                             "TEXCOORD1, TEXCOORD2)"))
      << missing.error().message;
}

// Vertex inputs take the mesh's streams by semantic, as Direct3D binds them: declared in any
// order and without [[vk::location]] (by declaration order the uv read the position stream).
TEST(HlslInput, VertexInputsTakeTheirStreamsBySemantic) {
  std::string vertex = exampleHlsl("lambert.vert.hlsl");
  const std::string declared = R"(struct VertexInput {
  float2 uv : texcoord;
  float3 normal : NORMAL0;
  float3 position : POSITION;
};)";
  const size_t begin = vertex.find("struct VertexInput {");
  ASSERT_NE(begin, std::string::npos);
  vertex.replace(begin, vertex.find("};", begin) + 2 - begin, declared);
  auto glsl = hlslToGlsl(vertex, Stage::kVertex, "reordered.vert.hlsl", onTheInterface());
  ASSERT_TRUE(glsl.ok()) << glsl.error().message;
  for (const char* expected :
       {"layout(location = 3) in vec2 input_uv", "layout(location = 1) in vec3 input_normal",
        "layout(location = 0) in vec3 input_position"})
    EXPECT_TRUE(test::contains(*glsl, expected)) << expected << "\n" << *glsl;
  // Where a bindings file puts a stream, its semantic follows.
  render::Bindings moved;
  moved.uv0 = 7;
  CompileOptions options;
  options.vertex_input_locations = render::hlslVertexInputLocations(moved);
  auto rebound = hlslToGlsl(vertex, Stage::kVertex, "reordered.vert.hlsl", options);
  ASSERT_TRUE(rebound.ok()) << rebound.error().message;
  EXPECT_TRUE(test::contains(*rebound, "layout(location = 7) in vec2 input_uv")) << *rebound;

  // A semantic the mesh has no stream for, and two inputs of one stream, are errors naming them.
  std::string blend = vertex;
  blend.replace(blend.find("texcoord"), 8, "BLENDWEIGHT");
  auto unknown = hlslToGlsl(blend, Stage::kVertex, "blend.vert.hlsl", onTheInterface());
  ASSERT_FALSE(unknown.ok());
  EXPECT_TRUE(
      test::contains(unknown.error().message,
                     "blend.vert.hlsl: vertex input 'input.uv' (BLENDWEIGHT0) is not a stream "
                     "the mesh provides (it provides COLOR0, NORMAL0, POSITION0, "
                     "TANGENT0, TEXCOORD0, TEXCOORD1)"))
      << unknown.error().message;
  std::string twice = vertex;
  twice.replace(twice.find("NORMAL0"), 7, "POSITION");
  auto same = hlslToGlsl(twice, Stage::kVertex, "twice.vert.hlsl", onTheInterface());
  ASSERT_FALSE(same.ok());
  EXPECT_TRUE(test::contains(same.error().message, "have the same semantic POSITION0"))
      << same.error().message;
}

TEST(HlslInput, TextureLoadNeedsNoSamplerState) {
  auto glsl = hlslToGlsl(std::string(kFragmentHeader) + R"(
float4 main(float4 position : SV_Position, float2 uv : TEXCOORD0) : SV_Target {
  return uBaseColorTexture.Load(int3(int2(position.xy), 0)) +
         uBaseColorTexture.Sample(uBaseColorSampler, uv);
}
)",
                         Stage::kFragment, "load.hlsl");
  ASSERT_TRUE(glsl.ok()) << glsl.error().message;
  EXPECT_TRUE(test::contains(*glsl, "texelFetch(uBaseColorTexture")) << *glsl;
  EXPECT_TRUE(test::contains(*glsl, "layout(binding = 0) uniform sampler2D uBaseColorTexture;"))
      << *glsl;
}

TEST(HlslInput, ResourcesWithoutARegisterAreErrorsNamingThem) {
  // The interface binds by number: without register() they would all sit at binding 0.
  auto texture = hlslToGlsl(R"(Texture2D uLooseTexture;
SamplerState uLooseSampler;
float4 main(float4 position : SV_Position, float2 uv : TEXCOORD0) : SV_Target {
  return uLooseTexture.Sample(uLooseSampler, uv);
}
)",
                            Stage::kFragment, "loose.hlsl");
  ASSERT_FALSE(texture.ok()) << *texture;
  EXPECT_TRUE(test::contains(texture.error().message, "loose.hlsl: ")) << texture.error().message;
  EXPECT_TRUE(test::contains(texture.error().message, "has no register()"))
      << texture.error().message;
  auto block = hlslToGlsl(R"(cbuffer Tint { float4 uTint; };
float4 main(float4 position : SV_Position) : SV_Target { return uTint; }
)",
                          Stage::kFragment, "block.hlsl");
  ASSERT_FALSE(block.ok());
  EXPECT_TRUE(test::contains(block.error().message, "block.hlsl: cbuffer 'Tint' has no register()"))
      << block.error().message;
  auto global = hlslToGlsl(R"(float4 gTint;
float4 main(float4 position : SV_Position) : SV_Target { return gTint; }
)",
                           Stage::kFragment, "global.hlsl");
  ASSERT_FALSE(global.ok());
  EXPECT_TRUE(test::contains(global.error().message,
                             "global.hlsl: global variables outside a cbuffer are not supported"))
      << global.error().message;
}

}  // namespace
}  // namespace duolod::shader
