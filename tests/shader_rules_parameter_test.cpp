// Moving to parameter (He et al. 2015; Liang et al. §4.1): a fragment value → its average over the
// domain, a uniform set by the CPU. The average comes from an instrumented render
// (value_average.cpp). On a square with uv 0..1 seen from the front, uv.x is uniform over the
// covered pixels, so v = 0.25 + 0.5 uv.x averages to 0.5 and w = 4 uv.x − 3 to −1 (outside [0, 1]:
// the encoding must survive the 8-bit targets).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "shader/rules_internal.hpp"
#include "shader/value_average.hpp"
#include "shader/value_rewrite.hpp"
#include "shader_rules_support.hpp"

namespace duolod::shader {
namespace {

using namespace test_rules;

const char* kRampFragment = R"(#version 450 core
layout(location = 1) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  float v = 0.25 + 0.5 * vUV.x;
  float w = 4.0 * vUV.x - 3.0;
  vec2 doubled = vUV * 2.0;
  outColor = vec4(v, v, v, 1.0) + vec4(w, doubled, 0.0) * 0.0;
}
)";

class MoveToParameter : public RendererFixture {
 protected:
  void SetUp() override {
    RendererFixture::SetUp();
    if (IsSkipped()) return;
    auto asset = renderer_->uploadAsset(tiltedSquare());
    ASSERT_TRUE(asset.ok()) << asset.error().message;
    asset_ = *asset;
    averager_ = std::make_unique<ValueAverager>(*renderer_, asset_,
                                                std::vector<render::Sample>{frontSample()},
                                                AverageOptions{.resolution = 64});
    context_.average_value = averager_->function();
  }
  void TearDown() override {
    if (asset_ >= 0) renderer_->releaseAsset(asset_);
  }
  std::vector<float> averageOf(const ShaderProgram& program, const std::string& name) {
    std::vector<RuleSite> sites = findMoveToParameterSites(program, context_);
    const RuleSite* site = siteNamed(sites, name);
    EXPECT_NE(site, nullptr) << name;
    if (!site) return {};
    auto average = averager_->average(program, Stage::kFragment, site->target);
    EXPECT_TRUE(average.ok()) << (average.ok() ? "" : average.error().message);
    return average.ok() ? *average : std::vector<float>{};
  }

  render::Renderer::AssetId asset_ = -1;
  std::unique_ptr<ValueAverager> averager_;
  RuleContext context_;
};

TEST_F(MoveToParameter, AveragesOverCoveredPixels) {
  ShaderProgram program = makeProgram(passThroughVertex(), kRampFragment);
  std::vector<float> v = averageOf(program, "v");
  ASSERT_EQ(v.size(), 1u);
  EXPECT_NEAR(v[0], 0.5f, 0.01f);
  std::vector<float> w = averageOf(program, "w");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NEAR(w[0], -1.0f, 0.02f);
  std::vector<float> doubled = averageOf(program, "doubled");
  ASSERT_EQ(doubled.size(), 2u);
  EXPECT_NEAR(doubled[0], 1.0f, 0.02f);
  EXPECT_NEAR(doubled[1], 1.0f, 0.02f);
  // Asking again is answered from the cache.
  int renders = averager_->counters().renders;
  averageOf(program, "v");
  EXPECT_EQ(averager_->counters().renders, renders);
}

TEST_F(MoveToParameter, MovedValueRendersFlat) {
  ShaderProgram original = makeProgram(passThroughVertex(), kRampFragment);
  std::vector<RuleSite> sites = findMoveToParameterSites(original, context_);
  const RuleSite* site = siteNamed(sites, "v");
  ASSERT_NE(site, nullptr);
  auto moved = applyMoveToParameter(original, *site, context_);
  ASSERT_TRUE(moved.ok()) << moved.error().message;
  ASSERT_EQ(moved->parameters.size(), 1u);
  const ParameterValue& parameter = moved->parameters[0];
  EXPECT_EQ(parameter.location, context_.first_parameter_location);
  EXPECT_EQ(parameter.components, 1);
  EXPECT_NEAR(parameter.value[0], 0.5f, 0.01f);
  EXPECT_LT(bodyInstructionCount(moved->fragment), bodyInstructionCount(original.fragment));
  ASSERT_FALSE(emitValidated(*moved, "moved").fragment.empty());

  // The CPU's value baked in (what setting the uniform does), the square renders flat 0.5; the
  // original is a ramp (the control).
  ShaderProgram baked = *moved;
  ASSERT_TRUE(bakeParameters(baked.fragment, baked.parameters).ok());
  for (bool is_moved : {false, true}) {
    render::ImageBatch8 image = renderSquare(emitValidated(is_moved ? baked : original, "render"));
    ASSERT_FALSE(image.pixels.empty());
    int lowest = 255, highest = 0;
    for (size_t i = 0; i < image.pixels.size(); i += 4) {
      if (image.pixels[i + 3] == 0) continue;
      lowest = std::min<int>(lowest, image.pixels[i]);
      highest = std::max<int>(highest, image.pixels[i]);
    }
    if (is_moved) {
      EXPECT_NEAR(lowest, 127.5, 1.5);
      EXPECT_NEAR(highest, 127.5, 1.5);
    } else {
      EXPECT_GT(highest - lowest, 100);
    }
  }
}

TEST_F(MoveToParameter, ParametersComposeAndAreBakedForLaterAverages) {
  ShaderProgram program = makeProgram(passThroughVertex(), kRampFragment);
  for (const char* name : {"v", "w"}) {
    std::vector<RuleSite> sites = findMoveToParameterSites(program, context_);
    const RuleSite* site = siteNamed(sites, name);
    ASSERT_NE(site, nullptr) << name;
    auto moved = applyMoveToParameter(program, *site, context_);
    ASSERT_TRUE(moved.ok()) << moved.error().message;
    program = std::move(*moved);
  }
  ASSERT_EQ(program.parameters.size(), 2u);
  EXPECT_EQ(program.parameters[0].location, 40u);
  EXPECT_EQ(program.parameters[1].location, 41u);
  EXPECT_NEAR(program.parameters[1].value[0], -1.0f, 0.02f);
  emitValidated(program, "two parameters");
  // The output colour, averaged on the twice-moved program, sees the baked parameters: (v, v, v,
  // 1).
  ir::DefUse uses(program.fragment);
  ir::Id color = ir::kNoId;
  for (ir::Id value : candidateValues(program.fragment, uses, spv::ExecutionModelFragment))
    if (ir::componentCount(uses, uses.def(value)->type_id) == 4) color = value;  // the last vec4
  ASSERT_NE(color, ir::kNoId);
  auto average = averager_->average(program, Stage::kFragment, color);
  ASSERT_TRUE(average.ok()) << average.error().message;
  EXPECT_NEAR((*average)[0], 0.5f, 0.01f);
  EXPECT_NEAR((*average)[3], 1.0f, 0.001f);
}

// A real shader (calls, loops, uniform blocks in the slice): averages of bounded terms of
// noise_phong land in their ranges — diffuse = max(n·l, 0) in (0, 1], the specular strength
// mix(0.35, 0.2, vein) in [0.2, 0.35].
TEST_F(MoveToParameter, AveragesTermsOfTheNoiseShader) {
  ShaderProgram program =
      makeProgram(readShaderFile("noise_phong.vert"), readShaderFile("noise_phong.frag"));
  std::vector<float> diffuse = averageOf(program, "diffuse");
  ASSERT_EQ(diffuse.size(), 1u);
  EXPECT_GT(diffuse[0], 0.05f);
  EXPECT_LE(diffuse[0], 1.0f);
  std::vector<float> strength = averageOf(program, "specularStrength");
  ASSERT_EQ(strength.size(), 1u);
  EXPECT_GE(strength[0], 0.2f - 1e-4f);
  EXPECT_LE(strength[0], 0.35f + 1e-4f);
}

TEST(MoveToParameterSites, OfferedOnlyWithAveragingAndOutsideLoops) {
  const char* fragment = R"(#version 450 core
layout(location = 1) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  float scaled = vUV.x * 3.0;
  float sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    float term = vUV.y * float(i);
    sum += term;
  }
  outColor = vec4(scaled, sum, 0.0, 1.0);
}
)";
  ShaderProgram program = makeProgram(passThroughVertex(), fragment);
  EXPECT_TRUE(findMoveToParameterSites(program, {}).empty());  // no average_value
  RuleContext context;
  context.average_value = [](const ShaderProgram&, Stage, ir::Id) {
    return core::Result<std::vector<float>>(std::vector<float>{0.25f});
  };
  std::vector<RuleSite> sites = findMoveToParameterSites(program, context);
  EXPECT_NE(siteNamed(sites, "scaled"), nullptr);
  EXPECT_EQ(siteNamed(sites, "term"), nullptr);
  // A wrong component count from the averager is an error, not a broken module.
  const RuleSite* outside = siteNamed(sites, "scaled");
  ASSERT_NE(outside, nullptr);
  context.average_value = [](const ShaderProgram&, Stage, ir::Id) {
    return core::Result<std::vector<float>>(std::vector<float>{1, 2, 3});
  };
  EXPECT_FALSE(applyMoveToParameter(program, *outside, context).ok());
}

// The reference shaders: how many sites, and every sampled application validates; a few link.
// The middle of the names rules give new uniforms and varyings: one '_' for each run of other
// characters and none at the ends, since GLSL reserves "__" and SPIRV-Cross rewrites such names
// (the summary's "uAverage__316_40" was declared as uAverage_316_40).
TEST(IdentifierFrom, NoDoubleOrOuterUnderscores) {
  EXPECT_EQ(identifierFrom("%316"), "316");
  EXPECT_EQ(identifierFrom("outColor"), "outColor");
  EXPECT_EQ(identifierFrom("a.b->c"), "a_b_c");
  EXPECT_EQ(identifierFrom("__x__y__"), "x_y");
  EXPECT_EQ(identifierFrom("%"), "value");
  EXPECT_EQ(identifierFrom(""), "value");
  // A described expression is cut at a word boundary near 32 characters.
  const std::string long_name =
      identifierFrom("mul(dot(normalize(N), L), max(uObjectInfo.w, 0.5))");
  EXPECT_LE(long_name.size(), 33u);
  EXPECT_EQ(long_name.rfind("mul_dot_normalize_N_L_max", 0), 0u) << long_name;
  EXPECT_NE(long_name.back(), '_');
}

class MoveToParameterReference : public RendererFixture,
                                 public ::testing::WithParamInterface<const char*> {};

TEST_P(MoveToParameterReference, SampledSitesValidateAndLink) {
  std::string name = GetParam();
  ShaderProgram program =
      makeProgram(readShaderFile(name + ".vert"), readShaderFile(name + ".frag"));
  RuleContext context;
  // Structure only here: any value of the right size (the real averages are tested above).
  context.average_value = [](const ShaderProgram& of, Stage, ir::Id value) {
    ir::DefUse uses(of.fragment);
    return core::Result<std::vector<float>>(
        std::vector<float>(ir::componentCount(uses, uses.def(value)->type_id), 0.5f));
  };
  std::vector<RuleSite> sites = findMoveToParameterSites(program, context);
  std::cout << "[ moving to parameter ] " << name << ": " << sites.size() << " sites\n";
  ASSERT_FALSE(sites.empty());
  // DUOLOD_ALL_SITES=1 applies every site and lists them (for measurements; slower).
  const bool all_sites = std::getenv("DUOLOD_ALL_SITES") != nullptr;
  const size_t sample = all_sites ? sites.size() : std::min<size_t>(20, sites.size());
  if (all_sites)
    for (const RuleSite& site : sites) std::cout << "    " << site.description << "\n";
  const size_t linked = 3;
  for (size_t k = 0; k < sample; ++k) {
    const RuleSite& site = sites[k * sites.size() / sample];
    auto applied = applyMoveToParameter(program, site, context);
    ASSERT_TRUE(applied.ok()) << site.description << ": " << applied.error().message;
    render::SpirvBinary binary = emitValidated(*applied, name + " " + site.description);
    if (k % (sample / linked + 1) == 0 && !binary.fragment.empty()) {
      auto compiled = renderer_->compileProgram(binary);
      EXPECT_TRUE(compiled.ok()) << site.description << ": "
                                 << (compiled.ok() ? "" : compiled.error().message);
      if (compiled.ok()) renderer_->releaseProgram(*compiled);
    }
  }
}

// Replacing the end of a long dependence chain kills the whole chain (each value, its variable
// and its store), and one call of removeDeadCode finds it all: a second call removes nothing.
// Also the site enumeration's answers on such a shader: every chain value is a site.
TEST(DeadCode, ALongChainGoesInOneCall) {
  constexpr int kLength = 300;
  std::string fragment =
      "#version 450 core\nlayout(location = 1) in vec2 vUV;\n"
      "layout(location = 0) out vec4 outColor;\nvoid main() {\n"
      "  float a0 = vUV.x;\n";
  for (int i = 1; i < kLength; ++i)
    fragment +=
        "  float a" + std::to_string(i) + " = a" + std::to_string(i - 1) + " * 1.01 + vUV.y;\n";
  fragment += "  outColor = vec4(a" + std::to_string(kLength - 1) + ", 0.0, 0.0, 1.0);\n}\n";
  ShaderProgram program = makeProgram(passThroughVertex(), fragment);
  ir::Id last = ir::kNoId;  // the value stored into a299
  size_t multiplies = 0;
  for (const ir::Block& block : program.fragment.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions) {
      if (instruction.opcode == spv::OpFAdd) last = instruction.result_id;
      multiplies += instruction.opcode == spv::OpFMul;
    }
  ASSERT_EQ(multiplies, static_cast<size_t>(kLength - 1));

  RuleContext context;
  context.average_value = [](const ShaderProgram&, Stage, ir::Id) {
    return core::Result<std::vector<float>>(std::vector<float>{0.5f});
  };
  std::vector<RuleSite> sites = findMoveToParameterSites(program, context);
  // Each multiply and add, and outColor's vec4 (it computes through a299).
  EXPECT_EQ(sites.size(), static_cast<size_t>(2 * (kLength - 1) + 1));

  size_t before = bodyInstructionCount(program.fragment);
  ir::Id type = ir::DefUse(program.fragment).def(last)->type_id;
  ir::Id uniform = program.fragment.addLooseUniform(type, "uLast", 40);
  ASSERT_TRUE(replaceValueByLoad(program.fragment, last, uniform).ok());
  // Per chain link: a load of the previous variable, the multiply, the add, a load of vUV.y's
  // component, the store; then the first link's and the variables. What stays: outColor's store,
  // its construct, the new load, the return.
  EXPECT_LT(bodyInstructionCount(program.fragment), 12u);
  EXPECT_GT(before - bodyInstructionCount(program.fragment),
            static_cast<size_t>(5 * (kLength - 1)));
  EXPECT_EQ(removeDeadCode(program.fragment), 0u);
  emitValidated(program, "chain");
}

INSTANTIATE_TEST_SUITE_P(Shaders, MoveToParameterReference,
                         ::testing::Values("noise_phong", "pbr", "blend"));

}  // namespace
}  // namespace duolod::shader
