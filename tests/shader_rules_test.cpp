// Shader simplification rules (rules.hpp): each rule on a small hand-written shader with a
// predictable result — checked in the IR (what is stored) and, once per rule, in a rendered
// full-screen quad — plus determinism, clean failure of stale sites, and every site of every rule
// applied once to the reference shaders with the result validated.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/rules.hpp"
#include "shader/scoring.hpp"
#include "shader_rules_support.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

// A pass-through vertex stage for a quad given in clip space: no matrices, so a test fragment
// stage sees uv across the whole tile.
const char* kQuadVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 3) in vec2 inUV0;
layout(location = 0) out vec2 vUV;
void main() {
  vUV = inUV0;
  gl_Position = vec4(inPosition.xy, 0.0, 1.0);
}
)";

ShaderProgram programOrDie(const std::string& vertex_source, const std::string& fragment_source) {
  auto vertex = compileToSpirv(vertex_source, Stage::kVertex, "test.vert");
  auto fragment = compileToSpirv(fragment_source, Stage::kFragment, "test.frag");
  EXPECT_TRUE(vertex.ok()) << (vertex.ok() ? "" : vertex.error().message);
  EXPECT_TRUE(fragment.ok()) << (fragment.ok() ? "" : fragment.error().message);
  if (!vertex.ok() || !fragment.ok()) return {};
  auto program = parseProgram(*vertex, *fragment);
  EXPECT_TRUE(program.ok()) << (program.ok() ? "" : program.error().message);
  return program.ok() ? *program : ShaderProgram{};
}

std::vector<RuleSite> sitesOfKind(const std::vector<RuleSite>& sites, RuleKind kind,
                                  Stage stage = Stage::kFragment) {
  std::vector<RuleSite> found;
  for (const RuleSite& site : sites)
    if (site.kind == kind && site.stage == stage) found.push_back(site);
  return found;
}

ShaderProgram applyOrDie(const ShaderProgram& program, const RuleSite& site,
                         const RuleContext& context = {}) {
  auto applied = applyRule(program, site, context);
  EXPECT_TRUE(applied.ok()) << (applied.ok() ? "" : applied.error().message);
  if (!applied.ok()) return program;
  for (bool optimize : {false, true}) {
    auto words = emitProgram(*applied, optimize);
    EXPECT_TRUE(words.ok()) << site.description << ": "
                            << (words.ok() ? "" : words.error().message);
  }
  return *applied;
}

// The value stored into the fragment output `outColor` by the entry function (the last store).
ir::Id storedOutput(const ir::Module& module) {
  ir::Id output = ir::kNoId;
  for (const ir::Instruction& instruction : module.types_values)
    if (instruction.opcode == spv::OpVariable && module.name(instruction.result_id) == "outColor")
      output = instruction.result_id;
  ir::Id stored = ir::kNoId;
  for (const ir::Block& block : module.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions)
      if (instruction.opcode == spv::OpStore && instruction.operands[0] == output)
        stored = instruction.operands[1];
  return stored;
}

size_t countOpcode(const ir::Module& module, spv::Op opcode) {
  size_t count = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks)
      for (const ir::Instruction& instruction : block.instructions)
        count += instruction.opcode == opcode;
  return count;
}

// ---- rendering: a full-screen quad with uv 0..1 and an optional texture at binding 0 ----

class RuleRender : public test_rules::RendererFixture {
 protected:
  // A clip-space quad; base colour factor `factor`; a `texture` at binding 0 when given.
  static core::Asset quadAsset(core::Vec4 factor, const core::ImageRGBA8* texture) {
    core::Asset asset;
    asset.source_path = "quad";
    asset.mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    asset.mesh.normals.assign(4, core::Vec3{0, 0, 1});
    asset.mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    asset.mesh.indices = {0, 1, 2, 0, 2, 3};
    asset.mesh.submeshes = {{0, 6, 0}};
    core::Material material;
    material.base_color_factor = factor;
    if (texture) {
      asset.textures.push_back({.name = "test texture", .image = *texture, .srgb = false});
      material.base_color_texture = 0;
    }
    asset.materials = {material};
    return asset;
  }

  // Renders `program` (optimised form, as the evaluator does) over the quad at `resolution`.
  static core::ImageRGBA8 renderQuad(const ShaderProgram& program, const core::Asset& asset,
                                     int resolution) {
    auto words = emitProgram(program, true);
    EXPECT_TRUE(words.ok()) << (words.ok() ? "" : words.error().message);
    if (!words.ok()) return {};
    auto asset_id = renderer_->uploadAsset(asset);
    EXPECT_TRUE(asset_id.ok()) << (asset_id.ok() ? "" : asset_id.error().message);
    auto program_id = renderer_->compileProgram(render::SpirvBinary{words->vertex, words->fragment});
    EXPECT_TRUE(program_id.ok()) << (program_id.ok() ? "" : program_id.error().message);
    if (!asset_id.ok() || !program_id.ok()) return {};
    render::Sample sample;
    auto batch = renderer_->render(*asset_id, *program_id, std::span(&sample, 1),
                                   {.resolution = resolution});
    renderer_->releaseProgram(*program_id);
    renderer_->releaseAsset(*asset_id);
    EXPECT_TRUE(batch.ok()) << (batch.ok() ? "" : batch.error().message);
    return batch.ok() ? render::tileImage(*batch, 0) : core::ImageRGBA8{};
  }

  static const uint8_t* pixel(const core::ImageRGBA8& image, int x, int y) {
    return image.pixels.data() + (static_cast<size_t>(y) * static_cast<size_t>(image.width) +
                                  static_cast<size_t>(x)) * 4;
  }
};

// ------------------------------------------------------------------------------------------------
// Operation removal

const char* kProductFragment = R"(#version 450 core
layout(location = 0) in vec4 vA;
layout(location = 1) in vec4 vB;
layout(location = 2) in float vS;
layout(location = 0) out vec4 outColor;
void main() {
  outColor = (vA * vS) * vB + vec4(dot(vA, vB));
}
)";
const char* kProductVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec4 vA;
layout(location = 1) out vec4 vB;
layout(location = 2) out float vS;
void main() {
  vA = vec4(inPosition, 1.0) * 0.5;
  vB = vec4(0.25);
  vS = 2.0;
  gl_Position = vec4(inPosition, 1.0);
}
)";

TEST(ShaderRules, OperationRemovalSitesAreTypeCorrect) {
  ShaderProgram program = programOrDie(kProductVertex, kProductFragment);
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval);
  // vA * vS (vec4 × float): keep vA, or splat vS; (vA * vS) * vB: either; ... + vec4(dot): either.
  // dot(vA, vB) itself is a float from two vec4s: never offered.
  ir::DefUse uses(program.fragment);
  std::map<ir::Id, int> per_operation;
  for (const RuleSite& site : sites) {
    ++per_operation[site.target];
    EXPECT_NE(uses.def(site.target)->opcode, spv::OpDot) << site.description;
  }
  EXPECT_EQ(per_operation.size(), 3u);
  for (const auto& [target, count] : per_operation) EXPECT_EQ(count, 2) << target;
  // The vertex stage's position is never simplified, vA's scale is.
  std::vector<RuleSite> vertex_sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval, Stage::kVertex);
  EXPECT_EQ(vertex_sites.size(), 2u);
}

// A position computed in a function (as HLSL's entry point returns it, in a struct) is protected
// through the call: no operation of that function is offered, while vA's scale in main still is.
TEST(ShaderRules, OperationRemovalKeepsAPositionComputedInAFunction) {
  const char* vertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec4 vA;
layout(location = 1) out vec4 vB;
layout(location = 2) out float vS;
layout(std140, binding = 0) uniform Frame { mat4 uModel; mat4 uView; mat4 uProjection; };
vec4 scaled(vec4 p) { return p * 2.0; }
vec4 clipPosition(vec3 p) { return uProjection * (uView * (uModel * scaled(vec4(p, 1.0)))); }
void main() {
  vA = vec4(inPosition, 1.0) * 0.5;
  vB = vec4(0.25);
  vS = 2.0;
  gl_Position = clipPosition(inPosition);
}
)";
  ShaderProgram program = programOrDie(vertex, kProductFragment);
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval, Stage::kVertex);
  ASSERT_EQ(sites.size(), 2u);  // vA's scale: keep either operand
  for (const RuleSite& site : sites)
    EXPECT_TRUE(test::contains(site.description, "vertex main: mul(vec4(")) << site.description;
}

TEST(ShaderRules, OperationRemovalStoresTheKeptOperand) {
  ShaderProgram program = programOrDie(kProductVertex, R"(#version 450 core
layout(location = 0) in vec4 vA;
layout(location = 1) in vec4 vB;
layout(location = 0) out vec4 outColor;
void main() { outColor = vA * vB; }
)");
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval);
  ASSERT_EQ(sites.size(), 2u);
  for (uint32_t kept = 0; kept < 2; ++kept) {
    ShaderProgram removed = applyOrDie(program, sites[kept]);
    // outColor now stores the load of vA (kept 0) or of vB (kept 1), and the product is gone.
    ir::DefUse uses(removed.fragment);
    const ir::Instruction* stored = uses.def(storedOutput(removed.fragment));
    ASSERT_NE(stored, nullptr);
    ASSERT_EQ(stored->opcode, spv::OpLoad);
    EXPECT_EQ(removed.fragment.name(stored->operands[0]), kept == 0 ? "vA" : "vB");
    EXPECT_EQ(countOpcode(removed.fragment, spv::OpFMul), 0u);
    EXPECT_EQ(countOpcode(removed.fragment, spv::OpLoad), 1u);  // the other load is dead, removed
    ASSERT_EQ(removed.history.size(), 1u);
    EXPECT_EQ(removed.history[0], sites[kept].description);
  }
}

TEST(ShaderRules, OperationRemovalSplatsAScalar) {
  ShaderProgram program = programOrDie(kProductVertex, kProductFragment);
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval);
  ir::DefUse uses(program.fragment);
  auto splat = std::find_if(sites.begin(), sites.end(), [&](const RuleSite& site) {
    return uses.def(site.target)->opcode == spv::OpVectorTimesScalar && site.choice == 1;
  });
  ASSERT_NE(splat, sites.end());
  ShaderProgram removed = applyOrDie(program, *splat);
  EXPECT_EQ(countOpcode(removed.fragment, spv::OpVectorTimesScalar), 0u);
  EXPECT_EQ(countOpcode(removed.fragment, spv::OpCompositeConstruct),
            countOpcode(program.fragment, spv::OpCompositeConstruct) + 1);
}

TEST(ShaderRules, LoopCounterIsNeverRemoved) {
  ShaderProgram program = programOrDie(kQuadVertex, R"(#version 450 core
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  float sum = 0.0;
  for (int i = 0; i < 4; i = i + 1) sum = sum + vUV.x;
  outColor = vec4(sum);
}
)");
  for (const RuleSite& site :
       sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval)) {
    ir::DefUse uses(program.fragment);
    EXPECT_NE(uses.def(site.target)->opcode, spv::OpIAdd) << site.description;
  }
}

TEST_F(RuleRender, OperationRemovalRendersTheKeptOperand) {
  ShaderProgram program = programOrDie(kQuadVertex, R"(#version 450 core
layout(std140, binding = 1) uniform Material { vec4 uBaseColorFactor; };
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(vUV, 0.25, 1.0) * uBaseColorFactor; }
)");
  core::Asset asset = quadAsset({0.5f, 0.5f, 0.5f, 1.0f}, nullptr);
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kOperationRemoval);
  ASSERT_EQ(sites.size(), 2u);
  ASSERT_EQ(sites[0].choice, 0u);
  const int size = 16;
  core::ImageRGBA8 before = renderQuad(program, asset, size);
  core::ImageRGBA8 after = renderQuad(applyOrDie(program, sites[0]), asset, size);
  ASSERT_EQ(after.pixels.size(), size_t(size * size * 4));
  // Blue: 0.25 * 0.5 before, 0.25 after; red follows u (halved before).
  EXPECT_NEAR(pixel(before, 8, 8)[2], 32, 1);
  EXPECT_NEAR(pixel(after, 8, 8)[2], 64, 1);
  for (int x : {1, 8, 14}) {
    float u = (static_cast<float>(x) + 0.5f) / size;
    EXPECT_NEAR(pixel(after, x, 8)[0], u * 255, 1.5) << x;
    EXPECT_NEAR(pixel(before, x, 8)[0], u * 0.5f * 255, 1.5) << x;
  }
}

// ------------------------------------------------------------------------------------------------
// Texture average and texture mip

const char* kTextureFragment = R"(#version 450 core
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() { outColor = texture(uBaseColorTexture, vUV); }
)";

RuleContext greyAverages() {
  RuleContext context;
  context.texture_averages[0] = {0.5f, 0.5f, 0.5f, 1.0f};
  return context;
}

// The OpImageSample* instruction of the fragment stage (the test shaders have one).
const ir::Instruction* fragmentSample(const ir::Module& module) {
  for (const ir::Block& block : module.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions)
      if (instruction.opcode == spv::OpImageSampleImplicitLod) return &instruction;
  return nullptr;
}

TEST(ShaderRules, TextureAverageStoresTheAverageConstant) {
  ShaderProgram program = programOrDie(kQuadVertex, kTextureFragment);
  // No average known for binding 0: not offered.
  EXPECT_TRUE(sitesOfKind(enumerateSites(program, {}), RuleKind::kTextureAverage).empty());
  RuleContext context;
  context.texture_averages[0] = {0.25f, 0.5f, 0.75f, 1.0f};
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, context), RuleKind::kTextureAverage);
  ASSERT_EQ(sites.size(), 1u);
  EXPECT_NE(sites[0].description.find("uBaseColorTexture"), std::string::npos);
  ShaderProgram averaged = applyOrDie(program, sites[0], context);
  ir::DefUse uses(averaged.fragment);
  EXPECT_EQ(ir::constantAsFloats(uses, storedOutput(averaged.fragment)),
            (std::vector<float>{0.25f, 0.5f, 0.75f, 1.0f}));
  EXPECT_EQ(fragmentSample(averaged.fragment), nullptr);
  EXPECT_EQ(countOpcode(averaged.fragment, spv::OpLoad), 0u);  // the sampler and uv loads went too
  // The sample is gone: a mip site on it is stale now.
  std::vector<RuleSite> mip = sitesOfKind(enumerateSites(program, context), RuleKind::kTextureMip);
  ASSERT_EQ(mip.size(), 3u);
  auto stale = applyRule(averaged, mip[0], context);
  ASSERT_FALSE(stale.ok());
  EXPECT_NE(stale.error().message.find("no longer"), std::string::npos) << stale.error().message;
}

// In the vertex stage, a displacement map's sample and a loop summing the position (as skinning
// does) shape the geometry: neither is offered, while a sample and a loop that feed only a varying
// are.
TEST(ShaderRules, VertexSamplesAndLoopsThePositionDependsOnAreNotOffered) {
  ShaderProgram program = programOrDie(R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 3) in vec2 inUV0;
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(binding = 3) uniform sampler2D uOcclusionTexture;
layout(location = 0) out vec2 vUV;
void main() {
  vec3 moved = inPosition;
  for (int i = 0; i < 4; ++i) moved += vec3(0.01 * float(i));
  float tint = 0.0;
  for (int j = 0; j < 3; ++j) tint += 0.1;
  float height = textureLod(uOcclusionTexture, inUV0, 0.0).r;
  vUV = inUV0 * textureLod(uBaseColorTexture, inUV0, 0.0).rg * tint;
  gl_Position = vec4(moved.xy, height, 1.0);
}
)",
                                       kTextureFragment);
  RuleContext context;
  context.texture_averages[0] = {0.5f, 0.5f, 0.5f, 1.0f};
  context.texture_averages[3] = {0.5f, 0.5f, 0.5f, 1.0f};
  std::vector<RuleSite> sites = enumerateSites(program, context);
  std::vector<RuleSite> averages = sitesOfKind(sites, RuleKind::kTextureAverage, Stage::kVertex);
  ASSERT_EQ(averages.size(), 1u);
  EXPECT_TRUE(test::contains(averages[0].description, "uBaseColorTexture"))
      << averages[0].description;
  std::vector<RuleSite> loops = sitesOfKind(sites, RuleKind::kLoopTruncation, Stage::kVertex);
  ASSERT_FALSE(loops.empty());
  for (const RuleSite& loop : loops)
    EXPECT_TRUE(test::contains(loop.description, "loop over j")) << loop.description;
}

// The Bias / Lod operand id of a sample (the first after the image-operand mask), or kNoId.
ir::Id lodOperand(const ir::Instruction& sample, uint32_t bit) {
  if (sample.operands.size() < 3 || !(sample.operands[2] & bit)) return ir::kNoId;
  return sample.operands[3];
}

TEST(ShaderRules, TextureMipAddsOrExtendsTheLodBias) {
  ShaderProgram program = programOrDie(kQuadVertex, kTextureFragment);
  std::vector<RuleSite> sites = sitesOfKind(enumerateSites(program, {}), RuleKind::kTextureMip);
  ASSERT_EQ(sites.size(), 3u);
  EXPECT_EQ(sites[1].choice, 2u);
  ShaderProgram coarser = applyOrDie(program, sites[1]);
  const ir::Instruction* sample = fragmentSample(coarser.fragment);
  ASSERT_NE(sample, nullptr);
  EXPECT_EQ(sample->result_id, sites[1].target);  // ids stay stable
  ir::DefUse uses(coarser.fragment);
  EXPECT_EQ(ir::constantFloatValue(uses, lodOperand(*sample, spv::ImageOperandsBiasMask)), 2.0f);
  // Applied again (composable): the bias becomes bias + 1 computed in the shader.
  ShaderProgram twice = applyOrDie(coarser, sites[0]);
  const ir::Instruction* again = fragmentSample(twice.fragment);
  ir::DefUse twice_uses(twice.fragment);
  const ir::Instruction* sum = twice_uses.def(lodOperand(*again, spv::ImageOperandsBiasMask));
  ASSERT_NE(sum, nullptr);
  EXPECT_EQ(sum->opcode, spv::OpFAdd);

  // An existing bias and an offset: the bias is extended, the offset kept after it.
  ShaderProgram biased = programOrDie(kQuadVertex, R"(#version 450 core
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() { outColor = textureOffset(uBaseColorTexture, vUV, ivec2(1, 0), 0.5); }
)");
  std::vector<RuleSite> biased_sites =
      sitesOfKind(enumerateSites(biased, {}), RuleKind::kTextureMip);
  ASSERT_EQ(biased_sites.size(), 3u);
  ShaderProgram biased_coarser = applyOrDie(biased, biased_sites[0]);
  const ir::Instruction* offset_sample = fragmentSample(biased_coarser.fragment);
  ASSERT_NE(offset_sample, nullptr);
  EXPECT_EQ(offset_sample->operands[2],
            uint32_t(spv::ImageOperandsBiasMask | spv::ImageOperandsConstOffsetMask));
  EXPECT_EQ(offset_sample->operands.size(), 5u);

  // Explicit LOD in the vertex stage: the Lod grows.
  ShaderProgram vertex_lod = programOrDie(R"(#version 450 core
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec2 vUV;
void main() {
  vUV = textureLod(uBaseColorTexture, inPosition.xy, 1.0).xy;
  gl_Position = vec4(inPosition, 1.0);
}
)", R"(#version 450 core
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(vUV, 0.0, 1.0); }
)");
  std::vector<RuleSite> vertex_sites =
      sitesOfKind(enumerateSites(vertex_lod, {}), RuleKind::kTextureMip, Stage::kVertex);
  ASSERT_EQ(vertex_sites.size(), 3u);
  applyOrDie(vertex_lod, vertex_sites[2]);
}

// A 32×32 checkerboard of 4-texel black and white cells: mip levels 0-2 keep pure cells, level 3
// and coarser are grey (each texel covers 2×2 cells).
core::ImageRGBA8 checkerTexture() {
  core::ImageRGBA8 image{.width = 32, .height = 32, .pixels = {}};
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      uint8_t value = ((x / 4 + y / 4) % 2) ? 255 : 0;
      image.pixels.insert(image.pixels.end(), {value, value, value, 255});
    }
  return image;
}

// Largest difference of a channel from `value` over the image's red channel, and the spread.
int maxDeviation(const core::ImageRGBA8& image, int value) {
  int worst = 0;
  for (size_t i = 0; i < image.pixels.size(); i += 4)
    worst = std::max(worst, std::abs(int(image.pixels[i]) - value));
  return worst;
}

TEST_F(RuleRender, TextureAverageAndMipRenderGrey) {
  core::ImageRGBA8 texture = checkerTexture();
  core::Asset asset = quadAsset({1, 1, 1, 1}, &texture);
  ShaderProgram program = programOrDie(kQuadVertex, kTextureFragment);
  RuleContext context = greyAverages();
  std::vector<RuleSite> sites = enumerateSites(program, context);
  const int size = 32;  // one texel per pixel: mip level 0 without a bias
  core::ImageRGBA8 original = renderQuad(program, asset, size);
  ASSERT_EQ(original.pixels.size(), size_t(size * size * 4));
  EXPECT_GE(maxDeviation(original, 128), 127);  // black and white cells

  std::vector<RuleSite> average = sitesOfKind(sites, RuleKind::kTextureAverage);
  ASSERT_EQ(average.size(), 1u);
  EXPECT_LE(maxDeviation(renderQuad(applyOrDie(program, average[0], context), asset, size), 128), 1);

  std::vector<RuleSite> mip = sitesOfKind(sites, RuleKind::kTextureMip);
  ASSERT_EQ(mip.size(), 3u);
  ASSERT_EQ(mip[0].choice, 1u);
  ASSERT_EQ(mip[2].choice, 3u);
  // One level coarser still shows pure cells; three levels coarser is the 2×2-cell average.
  EXPECT_GE(maxDeviation(renderQuad(applyOrDie(program, mip[0]), asset, size), 128), 126);
  EXPECT_LE(maxDeviation(renderQuad(applyOrDie(program, mip[2]), asset, size), 128), 2);
}

// A texture the material lacks is bound to a solid texel (white; flat normal for the normal map):
// its average is that texel, so removing its samples leaves the image as it was. (Found on the
// Avocado: the blend shader's occlusion and emissive layers sampled white and were never offered.)
TEST_F(RuleRender, MissingTexturesAverageToTheTexelBoundInTheirPlace) {
  core::Asset asset = quadAsset({1, 1, 1, 1}, nullptr);
  RuleContext context;
  context.texture_averages = textureAverages(asset);
  ASSERT_TRUE(context.texture_averages.count(0));
  ASSERT_TRUE(context.texture_averages.count(2));
  EXPECT_EQ(context.texture_averages[0], (std::array<float, 4>{1, 1, 1, 1}));
  EXPECT_FLOAT_EQ(context.texture_averages[2][0], 128.0f / 255.0f);
  EXPECT_FLOAT_EQ(context.texture_averages[2][2], 1.0f);

  ShaderProgram program = programOrDie(kQuadVertex, R"(#version 450 core
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(binding = 2) uniform sampler2D uNormalTexture;
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 base = texture(uBaseColorTexture, vUV).rgb;
  vec3 normal = texture(uNormalTexture, vUV * 3.0).rgb;
  outColor = vec4(base.r * 0.5, normal.r, normal.b * 0.25, 1.0);
}
)");
  std::vector<RuleSite> average =
      sitesOfKind(enumerateSites(program, context), RuleKind::kTextureAverage);
  ASSERT_EQ(average.size(), 2u);
  ShaderProgram folded = applyOrDie(program, average[0], context);
  std::vector<RuleSite> left =
      sitesOfKind(enumerateSites(folded, context), RuleKind::kTextureAverage);
  ASSERT_EQ(left.size(), 1u);
  folded = applyOrDie(folded, left[0], context);
  EXPECT_TRUE(sitesOfKind(enumerateSites(folded, context), RuleKind::kTextureAverage).empty());
  const int size = 8;
  core::ImageRGBA8 original = renderQuad(program, asset, size);
  core::ImageRGBA8 after = renderQuad(folded, asset, size);
  ASSERT_EQ(original.pixels.size(), size_t(size * size * 4));
  ASSERT_EQ(after.pixels.size(), original.pixels.size());
  EXPECT_NEAR(pixel(original, 4, 4)[0], 128, 1);  // white base colour, halved
  EXPECT_NEAR(pixel(original, 4, 4)[1], 128, 1);  // the flat normal's 0.5
  EXPECT_NEAR(pixel(original, 4, 4)[2], 64, 1);
  EXPECT_EQ(after.pixels, original.pixels);
}

// ------------------------------------------------------------------------------------------------
// Loop truncation

// A fragment stage summing 0.1 per iteration of `loop_header` (which declares i).
std::string countingFragment(const std::string& loop_header) {
  return "#version 450 core\nlayout(location = 0) in vec2 vUV;\n"
         "layout(location = 0) out vec4 outColor;\nvoid main() {\n  float sum = 0.0;\n  " +
         loop_header + " sum += 0.1;\n  outColor = vec4(sum, sum, sum, 1.0);\n}\n";
}

struct LoopCase {
  const char* header;
  uint32_t trip_count;
};

TEST(ShaderRules, LoopTripCountsOfCountedLoops) {
  const LoopCase cases[] = {
      {"for (int i = 0; i < 4; ++i)", 4},
      {"for (int i = 10; i > 0; i -= 3)", 4},  // 10, 7, 4, 1
      {"for (uint i = 0u; i <= 5u; i++)", 6},
      {"for (int i = 2; 9 > i; i += 2)", 4},   // bound on the left: 2, 4, 6, 8
      {"for (int i = 0; i != 12; i += 4)", 3},
      {"for (int i = 0; i < 40; ++i)", 40},
  };
  for (const LoopCase& loop : cases) {
    ShaderProgram program = programOrDie(kQuadVertex, countingFragment(loop.header));
    std::vector<RuleSite> sites =
        sitesOfKind(enumerateSites(program, {}), RuleKind::kLoopTruncation);
    ASSERT_FALSE(sites.empty()) << loop.header;
    // Short loops offer every shorter count; long ones powers of two and three quarters.
    std::vector<uint32_t> choices;
    for (const RuleSite& site : sites) choices.push_back(site.choice);
    std::vector<uint32_t> expected;
    if (loop.trip_count <= 8) {
      for (uint32_t k = 1; k < loop.trip_count; ++k) expected.push_back(k);
    } else {
      expected = {1, 2, 4, 8, 16, 30, 32};
    }
    EXPECT_EQ(choices, expected) << loop.header;
    EXPECT_NE(sites[0].description.find(std::to_string(loop.trip_count) + " → 1 iterations"),
              std::string::npos)
        << sites[0].description;
    // Truncating twice: the second site now asks for more than the loop runs.
    ShaderProgram once = applyOrDie(program, sites[0]);
    if (sites.size() > 1) {
      EXPECT_FALSE(applyRule(once, sites[1], {}).ok()) << loop.header;
    }
  }
}

TEST(ShaderRules, LoopsWithoutACertainTripCountAreNotOffered) {
  const char* headers[] = {
      "for (int i = 0; i < int(vUV.x * 8.0); ++i)",         // bound not a constant
      "for (int i = 0; i < 4; i += int(vUV.y) + 1)",         // step not a constant
      "for (int i = 0; i < 4; ++i) { if (vUV.x > 0.5) ++i; }",  // counter written in the body
      "for (int i = 0; i < 3000000; ++i)",                   // beyond the simulated trip limit
  };
  for (const char* header : headers) {
    ShaderProgram program = programOrDie(kQuadVertex, countingFragment(header));
    EXPECT_TRUE(sitesOfKind(enumerateSites(program, {}), RuleKind::kLoopTruncation).empty())
        << header;
  }
}

TEST_F(RuleRender, LoopTruncationRendersFewerIterations) {
  core::Asset asset = quadAsset({1, 1, 1, 1}, nullptr);
  for (const char* header : {"for (int i = 0; i < 4; ++i)", "for (int i = 10; i > 0; i -= 3)"}) {
    ShaderProgram program = programOrDie(kQuadVertex, countingFragment(header));
    std::vector<RuleSite> sites =
        sitesOfKind(enumerateSites(program, {}), RuleKind::kLoopTruncation);
    ASSERT_EQ(sites.size(), 3u);
    ASSERT_EQ(sites[1].choice, 2u);
    // 4 × 0.1 before, 2 × 0.1 after.
    EXPECT_LE(maxDeviation(renderQuad(program, asset, 8), 102), 1) << header;
    EXPECT_LE(maxDeviation(renderQuad(applyOrDie(program, sites[1]), asset, 8), 51), 1) << header;
  }
}

TEST(ShaderRules, NoisePhongOctaveLoopIsTruncatable) {
  ShaderProgram program =
      programOrDie(test_rules::readShaderFile("noise_phong.vert"), test_rules::readShaderFile("noise_phong.frag"));
  std::vector<RuleSite> sites =
      sitesOfKind(enumerateSites(program, {}), RuleKind::kLoopTruncation);
  ASSERT_EQ(sites.size(), 3u);  // glslang keeps the loop (no unrolling without optimisation)
  EXPECT_NE(sites[0].description.find("octave in fbm: 4 → 1"), std::string::npos)
      << sites[0].description;
}

// ------------------------------------------------------------------------------------------------
// Determinism, stale sites, the reference shaders

TEST(ShaderRules, EnumerationIsDeterministicAndStaleSitesFailCleanly) {
  ShaderProgram program = programOrDie(kProductVertex, kProductFragment);
  std::vector<RuleSite> first = enumerateSites(program, {});
  EXPECT_EQ(first, enumerateSites(programOrDie(kProductVertex, kProductFragment), {}));
  std::vector<RuleSite> fragment = sitesOfKind(first, RuleKind::kOperationRemoval);
  ASSERT_GE(fragment.size(), 2u);
  // Removing `(vA * vS) * vB` keeping vB removes `vA * vS`: its sites are now stale.
  ir::DefUse uses(program.fragment);
  auto outer = std::find_if(fragment.begin(), fragment.end(), [&](const RuleSite& site) {
    const ir::Instruction* op = uses.def(site.target);
    return op->opcode == spv::OpFMul && uses.def(op->operands[0])->opcode == spv::OpVectorTimesScalar &&
           site.choice == 1;
  });
  ASSERT_NE(outer, fragment.end());
  ShaderProgram removed = applyOrDie(program, *outer);
  for (const RuleSite& site : fragment) {
    if (uses.def(site.target)->opcode != spv::OpVectorTimesScalar) continue;
    auto stale = applyRule(removed, site, {});
    ASSERT_FALSE(stale.ok());
    EXPECT_NE(stale.error().message.find("no longer"), std::string::npos) << stale.error().message;
  }
  // A vertex-stage site survives the fragment rewrite and still applies.
  std::vector<RuleSite> vertex = sitesOfKind(first, RuleKind::kOperationRemoval, Stage::kVertex);
  ASSERT_FALSE(vertex.empty());
  ShaderProgram both = applyOrDie(removed, vertex[0]);
  EXPECT_EQ(both.history.size(), 2u);
  // An out-of-range choice is refused.
  RuleSite bad = fragment[0];
  bad.choice = 7;
  EXPECT_FALSE(applyRule(program, bad, {}).ok());
}

class ReferenceShaderRules : public ::testing::TestWithParam<const char*> {};

// Every site of every rule applied once to the original: each result validates (plain and
// optimised). Prints the site counts per rule.
TEST_P(ReferenceShaderRules, EverySiteAppliesAndValidates) {
  std::string name = GetParam();
  ShaderProgram program = programOrDie(test_rules::readShaderFile(name + ".vert"), test_rules::readShaderFile(name + ".frag"));
  RuleContext context;
  for (uint32_t binding = 0; binding < 8; ++binding)
    context.texture_averages[binding] = {0.5f, 0.4f, 0.3f, 1.0f};
  std::vector<RuleSite> sites = enumerateSites(program, context);
  EXPECT_EQ(sites, enumerateSites(program, context));
  std::array<int, kRuleKindCount> counts{};
  for (const RuleSite& site : sites) {
    ++counts[static_cast<size_t>(site.kind)];
    auto applied = applyRule(program, site, context);
    ASSERT_TRUE(applied.ok()) << site.description << ": " << applied.error().message;
    auto plain = emitProgram(*applied, false);
    EXPECT_TRUE(plain.ok()) << site.description << ": " << (plain.ok() ? "" : plain.error().message);
  }
  // The optimiser is slower: run it on every 8th variant.
  for (size_t i = 0; i < sites.size(); i += 8) {
    auto applied = applyRule(program, sites[i], context);
    ASSERT_TRUE(applied.ok());
    auto optimized = emitProgram(*applied, true);
    EXPECT_TRUE(optimized.ok()) << sites[i].description << ": "
                                << (optimized.ok() ? "" : optimized.error().message);
  }
  std::string summary = name + ": " + std::to_string(sites.size()) + " sites:";
  for (int kind = 0; kind < kRuleKindCount; ++kind)
    summary += " " + std::string(ruleName(static_cast<RuleKind>(kind))) + " " +
               std::to_string(counts[static_cast<size_t>(kind)]) + ";";
  std::printf("%s\n", summary.c_str());
  // One example description per rule, to read in the log.
  std::array<bool, kRuleKindCount> shown{};
  for (const RuleSite& site : sites)
    if (!shown[static_cast<size_t>(site.kind)]) {
      shown[static_cast<size_t>(site.kind)] = true;
      std::printf("  e.g. %s\n", site.description.c_str());
    }
  EXPECT_GT(counts[static_cast<size_t>(RuleKind::kOperationRemoval)], 0);
}

// What a user reads in summary.json and the console: every site's description names values by
// the shader's own words (variables, members, constants, operations), never by a raw SPIR-V id.
TEST_P(ReferenceShaderRules, DescriptionsNameNoSpirvIds) {
  std::string name = GetParam();
  ShaderProgram program = programOrDie(test_rules::readShaderFile(name + ".vert"),
                                       test_rules::readShaderFile(name + ".frag"));
  RuleContext context;
  for (uint32_t binding = 0; binding < 8; ++binding)
    context.texture_averages[binding] = {0.5f, 0.4f, 0.3f, 1.0f};
  // Only enumeration here: moving to parameter is offered once something could average.
  context.average_value = [](const ShaderProgram&, Stage,
                             ir::Id) -> core::Result<std::vector<float>> {
    return core::Error{"not averaged in this test"};
  };
  std::vector<RuleSite> sites = enumerateSites(program, context);
  ASSERT_FALSE(sites.empty());
  int with_ids = 0;
  for (const RuleSite& site : sites) {
    const size_t percent = site.description.find('%');
    if (percent != std::string::npos && percent + 1 < site.description.size() &&
        std::isdigit(static_cast<unsigned char>(site.description[percent + 1]))) {
      if (++with_ids <= 10) ADD_FAILURE() << site.description;
    }
  }
  EXPECT_EQ(with_ids, 0) << "of " << sites.size() << " sites";
}

// Constants read back exactly (six decimals printed 1/16777216 as 0.0), integer vectors and
// unsigned constants as GLSL spells them (uvec2(8u), not vec2(8)), members by name and a column's
// component by letter.
TEST(RuleDescriptions, ConstantsVectorsAndMembersAsGlslWritesThem) {
  ShaderProgram program = programOrDie(kQuadVertex, R"(#version 450 core
struct Light { vec3 color; float power; };
layout(std140, binding = 2) uniform Lights { Light uLight; };
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
float scaled(Light light, float x) { return light.color.y * x; }
void main() {
  uvec2 cell = uvec2(vUV * 4096.0) >> uvec2(8u);
  float tiny = float(cell.x) * (1.0 / 16777216.0);
  float corner = (mat2(vUV, vUV.yx) * 3.0)[1].y * vUV.x;  // an OpCompositeExtract, two indices
  outColor = vec4(tiny, scaled(uLight, vUV.y), 0.25, corner);
}
)");
  std::vector<RuleSite> sites = enumerateSites(program, {});
  ASSERT_FALSE(sites.empty());
  std::string all;
  for (const RuleSite& site : sites) all += site.description + "\n";
  EXPECT_TRUE(test::contains(all, "5.9604645e-08")) << all;
  EXPECT_TRUE(test::contains(all, "uvec2(8u)")) << all;
  EXPECT_FALSE(test::contains(all, " 0.0)")) << all;
  EXPECT_TRUE(test::contains(all, "light.color.y")) << all;
  EXPECT_TRUE(test::contains(all, "[1].y")) << all;  // a column's component, not "[1][1]"
}

INSTANTIATE_TEST_SUITE_P(Shaders, ReferenceShaderRules,
                         ::testing::Values("pbr", "noise_phong", "blend"));

}  // namespace
}  // namespace duolod::shader
