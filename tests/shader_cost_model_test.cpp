// The cost models of shader/cost_model.hpp and the block-count instrumentation of
// shader/instrument.hpp, on small hand-written shaders whose counts can be checked by hand.
// Deterministic only: counts of ops and of block executions, never time.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>

#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/cost_model.hpp"
#include "shader/instrument.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

ir::Module compileModule(const std::string& source, Stage stage, const std::string& name) {
  auto words = compileToSpirv(source, stage, name);
  EXPECT_TRUE(words.ok()) << (words.ok() ? "" : words.error().message);
  if (!words.ok()) return {};
  auto module = ir::parseModule(*words);
  EXPECT_TRUE(module.ok()) << (module.ok() ? "" : module.error().message);
  return module.ok() ? *module : ir::Module{};
}

using test::readShader;

double at(const OpClassCounts& counts, OpClass op_class) {
  return counts[static_cast<int>(op_class)];
}

// outColor = c * c + c on a vec4: one vec4 multiply and one vec4 add = 8 float ops; glslang
// (no optimisation) loads vColor once per use (3 loads) and stores outColor once.
const char* kArithmeticShader = R"(#version 450
layout(location = 0) in vec4 vColor;
layout(location = 0) out vec4 outColor;
void main() { outColor = vColor * vColor + vColor; }
)";

// One texture sample, one sine and one vec4 × scalar.
const char* kTextureShader = R"(#version 450
layout(binding = 0) uniform sampler2D uTexture;
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() { outColor = texture(uTexture, vUV) * sin(vUV.x); }
)";

TEST(ShaderCostModel, CountsArithmeticByComponent) {
  ir::Module module = compileModule(kArithmeticShader, Stage::kFragment, "arith.frag");
  OpClassCounts counts = staticOpCounts(module);
  EXPECT_EQ(at(counts, OpClass::kFloatArithmetic), 8);
  EXPECT_EQ(at(counts, OpClass::kTranscendental), 0);
  EXPECT_EQ(at(counts, OpClass::kTextureSample), 0);
  EXPECT_EQ(at(counts, OpClass::kMemory), 4);       // 3 OpLoad + 1 OpStore
  EXPECT_EQ(at(counts, OpClass::kControlFlow), 1);  // OpReturn
  // He et al.: 8 scalar ops, no texture.
  EXPECT_EQ(heStaticCost(module), 8);
}

TEST(ShaderCostModel, HeCountsTexturesAtOneHundred) {
  ir::Module module = compileModule(kTextureShader, Stage::kFragment, "texture.frag");
  OpClassCounts counts = staticOpCounts(module);
  EXPECT_EQ(at(counts, OpClass::kTextureSample), 1);
  EXPECT_EQ(at(counts, OpClass::kTranscendental), 1);   // sin of a scalar
  EXPECT_EQ(at(counts, OpClass::kFloatArithmetic), 4);  // vec4 × float
  // 4 + 1 scalar ops + 100 × 1 texture op.
  EXPECT_EQ(heStaticCost(module), 105);
  // The program heuristic adds the stages.
  ir::Module arithmetic = compileModule(kArithmeticShader, Stage::kFragment, "arith.frag");
  EXPECT_EQ(heStaticCost(arithmetic, module), 113);
}

TEST(ShaderCostModel, MatrixAndDotProductsCountMultiplyAdds) {
  ir::Module module = compileModule(R"(#version 450
layout(location = 0) in vec4 vPosition;
layout(location = 0) out vec4 outColor;
layout(std140, binding = 0) uniform Frame { mat4 uMatrix; };
void main() { outColor = uMatrix * vPosition + vec4(dot(vPosition.xyz, vPosition.xyz)); }
)",
                                    Stage::kFragment, "matrix.frag");
  // mat4 × vec4 = 16 multiply-adds, dot of vec3 = 3, vec4 add = 4.
  EXPECT_EQ(at(staticOpCounts(module), OpClass::kFloatArithmetic), 16 + 3 + 4);
}

// A loop with a constant trip count of 4 and a branch: the static count sees each block once, the
// dynamic count with executions per invocation scales each block by how often it runs.
const char* kLoopShader = R"(#version 450
layout(location = 0) in vec4 vColor;
layout(location = 0) out vec4 outColor;
void main() {
  vec4 sum = vec4(0.0);
  for (int i = 0; i < 4; ++i) sum += vColor * float(i);
  if (gl_FragCoord.x < 8.0) sum = sin(sum);
  outColor = sum;
}
)";

TEST(ShaderCostModel, DynamicCountsScaleBlocksByExecutions) {
  ir::Module module = compileModule(kLoopShader, Stage::kFragment, "loop.frag");
  std::vector<BlockOps> blocks = blockOpCounts(module);
  ASSERT_GT(blocks.size(), 3u);
  // Every block once reproduces the static count.
  std::vector<double> once(blocks.size(), 1.0);
  EXPECT_EQ(dynamicOpCounts(module, once), staticOpCounts(module));
  // The sine's block (the only transcendental: a vec4 sine, 4 ops) at half the invocations: 2.
  std::vector<double> half = once;
  int sine_blocks = 0;
  for (size_t b = 0; b < blocks.size(); ++b)
    if (at(blocks[b].ops, OpClass::kTranscendental) > 0) half[b] = 0.5, ++sine_blocks;
  EXPECT_EQ(sine_blocks, 1);
  EXPECT_EQ(at(dynamicOpCounts(module, half), OpClass::kTranscendental), 2);
}

TEST(ShaderCostModel, InstrumentedModulesValidate) {
  ir::Module loop = compileModule(kLoopShader, Stage::kFragment, "loop.frag");
  auto instrumented = instrumentBlockCounts(loop, kFragmentCounterBinding);
  ASSERT_TRUE(instrumented.ok()) << instrumented.error().message;
  EXPECT_EQ(instrumented->counter_count, static_cast<int>(blockOpCounts(loop).size()));
  auto valid = validateSpirv(ir::emitModule(instrumented->module), "instrumented loop.frag");
  EXPECT_TRUE(valid.ok()) << (valid.ok() ? "" : valid.error().message);
  // One atomic add per block.
  OpClassCounts added = staticOpCounts(instrumented->module);
  OpClassCounts original = staticOpCounts(loop);
  EXPECT_EQ(at(added, OpClass::kMemory) - at(original, OpClass::kMemory),
            2 * instrumented->counter_count);  // OpAccessChain + OpAtomicIAdd

  for (const char* name : {"pbr", "noise_phong", "blend"}) {
    for (auto [extension, stage] : {std::pair{".vert", Stage::kVertex},
                                    std::pair{".frag", Stage::kFragment}}) {
      std::string file = std::string(name) + extension;
      ir::Module module = compileModule(readShader(file), stage, file);
      auto copy = instrumentBlockCounts(module, kVertexCounterBinding);
      ASSERT_TRUE(copy.ok()) << copy.error().message;
      auto check = validateSpirv(ir::emitModule(copy->module), "instrumented " + file);
      EXPECT_TRUE(check.ok()) << (check.ok() ? "" : check.error().message);
    }
  }
}

TEST(ShaderCostModel, NonNegativeLeastSquaresByHand) {
  // b = 2·a0 + 3·a1 exactly: the unconstrained solution is non-negative, so NNLS finds it.
  std::vector<std::vector<double>> rows{{1, 0}, {0, 1}, {1, 1}};
  std::vector<double> targets{2, 3, 5};
  auto exact = solveNonNegativeLeastSquares(rows, targets);
  ASSERT_TRUE(exact.ok()) << exact.error().message;
  EXPECT_NEAR((*exact)[0], 2, 1e-9);
  EXPECT_NEAR((*exact)[1], 3, 1e-9);
  // Rows (1,0), (1,1) with targets (1.5, 1): least squares is exact at (1.5, −0.5). NNLS clamps
  // the second weight to 0 and refits the first alone: x0 = mean(1.5, 1) = 1.25.
  std::vector<std::vector<double>> clamp_rows{{1, 0}, {1, 1}};
  std::vector<double> clamp_targets{1.5, 1.0};
  auto clamped = solveNonNegativeLeastSquares(clamp_rows, clamp_targets);
  ASSERT_TRUE(clamped.ok()) << clamped.error().message;
  EXPECT_NEAR((*clamped)[0], 1.25, 1e-9);
  EXPECT_EQ((*clamped)[1], 0);
  // Bad input is an error, not a crash.
  EXPECT_FALSE(solveNonNegativeLeastSquares({}, {}).ok());
  EXPECT_FALSE(solveNonNegativeLeastSquares({{1, 2}, {3}}, std::vector<double>{1, 2}).ok());
}

TEST(ShaderCostModel, VertexOpScaleMultipliesTheVertexStageOpsAndIsRecovered) {
  CostWeights weights;
  weights.per_op[static_cast<int>(OpClass::kFloatArithmetic)] = 1;
  weights.per_vertex_invocation = 3;
  CostFeatures features;
  features.vertex_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 10;
  features.fragment_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 20;
  features.vertex_invocations = 100;
  features.fragment_invocations = 1000;
  weights.vertex_op_scale = 2;
  EXPECT_EQ(predictCost(features, weights), 100 * (3 + 2 * 10) + 1000 * 20);  // V (w_v + 2·10) + F·20
  // Measurements made with scale 3 and 4× the weights' absolute level (another machine load):
  // the fit finds 3 (to its 5% grid) whatever the common factor.
  std::vector<CostFeatures> set;
  std::vector<double> seconds;
  CostWeights truth = weights;
  truth.vertex_op_scale = 3;
  for (int i = 0; i < 10; ++i) {
    CostFeatures f = features;
    f.vertex_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 10.0 + 40 * (i % 4);
    f.fragment_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 5.0 + 7 * i;
    set.push_back(f);
    seconds.push_back(4 * predictCost(f, truth));
  }
  weights.vertex_op_scale = 1;
  EXPECT_NEAR(fitVertexOpScale(set, seconds, weights), 3.0, 0.15);
  // The stored calibration carries one (llvmpipe shades vertices on one thread).
  EXPECT_GT(calibratedCostWeights().vertex_op_scale, 1.0);
}

TEST(ShaderCostModel, CommonScaleFactorByHand) {
  CostWeights weights;
  weights.per_op[static_cast<int>(OpClass::kFloatArithmetic)] = 1;
  auto features = [](double fragment_ops) {
    CostFeatures f;
    f.fragment_ops[static_cast<int>(OpClass::kFloatArithmetic)] = fragment_ops;
    f.fragment_invocations = 1;
    return f;
  };
  // Predicted 10 and 30 where 10 and 10 were measured: r = 1 and 3, α = Σr / Σr² = 4/10, and
  // α·r = 0.4 and 1.2 (residual 0.36 + 0.04).
  std::vector<CostFeatures> set{features(10), features(30), features(50)};
  std::vector<double> seconds{10, 10, 0};  // the third has no measurement: left out
  CostScaleFit fit = fitCostScale(set, seconds, weights);
  EXPECT_EQ(fit.points, 2u);
  EXPECT_DOUBLE_EQ(fit.factor, 0.4);
  EXPECT_DOUBLE_EQ(fit.residual, 0.4);
  EXPECT_DOUBLE_EQ(fit.smallest_ratio, 0.4);
  EXPECT_DOUBLE_EQ(fit.largest_ratio, 1.2);
  // Predictions 12.5x too high everywhere (weights calibrated on a loaded machine): α = 0.08 and
  // nothing left over.
  const std::vector<double> loaded{0.8, 2.4, 4.0};
  fit = fitCostScale(set, loaded, weights);
  EXPECT_EQ(fit.points, 3u);
  EXPECT_NEAR(fit.factor, 0.08, 1e-15);
  EXPECT_NEAR(fit.residual, 0, 1e-24);
  // Nothing measured: the neutral factor, no points.
  const std::vector<double> none{0, 0, 0};
  fit = fitCostScale(set, none, weights);
  EXPECT_EQ(fit.points, 0u);
  EXPECT_EQ(fit.factor, 1);
}

TEST(ShaderCostModel, PredictionIsTheWeightedSum) {
  CostFeatures features;
  features.vertex_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 10;
  features.fragment_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 20;
  features.fragment_ops[static_cast<int>(OpClass::kTextureSample)] = 2;
  features.vertex_invocations = 100;
  features.fragment_invocations = 1000;
  CostWeights weights;
  weights.per_op[static_cast<int>(OpClass::kFloatArithmetic)] = 1;
  weights.per_op[static_cast<int>(OpClass::kTextureSample)] = 50;
  weights.per_vertex_invocation = 3;
  weights.per_fragment_invocation = 5;
  weights.per_draw = 7;
  // V (w_v + 10) + F (w_f + 20 + 2·50) + w_draw
  EXPECT_EQ(predictCost(features, weights), 100 * 13 + 1000 * 125 + 7);
  // Calibration recovers weights that generated the measurements exactly.
  std::vector<CostFeatures> set;
  std::vector<double> seconds;
  for (int i = 0; i < 12; ++i) {
    CostFeatures f = features;
    f.fragment_ops[static_cast<int>(OpClass::kFloatArithmetic)] = 5.0 + 3 * i;
    f.fragment_ops[static_cast<int>(OpClass::kTextureSample)] = i % 4;
    f.fragment_invocations = 500.0 + 100 * (i % 5);
    f.vertex_invocations = 50.0 + 10 * (i % 3);
    set.push_back(f);
    seconds.push_back(predictCost(f, weights));
  }
  auto calibrated = calibrateCostWeights(set, seconds, "test");
  ASSERT_TRUE(calibrated.ok()) << calibrated.error().message;
  for (size_t i = 0; i < set.size(); ++i)
    EXPECT_NEAR(predictCost(set[i], *calibrated), seconds[i], 1e-6 * seconds[i]);
}

// ---- block counts from an instrumented render ----

// The 2×2 square z = 0 seen head-on so that it covers exactly the middle half of the image side:
// at 64 px, 32 × 32 = 1024 covered pixels, half of them at object x < 0.
core::Asset unitSquare() {
  core::Asset asset;
  asset.source_path = "square";
  asset.mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  asset.mesh.normals.assign(4, core::Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  asset.materials = {core::Material{}};
  return asset;
}

render::Sample headOnSample() {
  render::Sample sample;
  sample.eye = {0, 0, 4};
  sample.light = sample.eye;
  sample.view = core::lookAt(sample.eye, {0, 0, 0}, {0, 1, 0});
  sample.projection = core::perspective(2 * std::atan(2.0f / 4.0f), 1.0f, 0.1f, 100.0f);
  return sample;
}

const char* kPositionVertexShader = R"(#version 450
layout(location = 0) in vec3 inPosition;
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) out vec3 vObjectPosition;
void main() {
  vObjectPosition = inPosition;
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";

// A loop of exactly 4 iterations and a branch taken where object x < 0 (half the pixels).
const char* kLoopBranchShader = R"(#version 450
layout(location = 0) in vec3 vObjectPosition;
layout(location = 0) out vec4 outColor;
void main() {
  vec4 sum = vec4(0.0);
  for (int i = 0; i < 4; ++i) sum += vec4(vObjectPosition, 1.0) * float(i);
  if (vObjectPosition.x < 0.0) sum = sin(sum);
  outColor = sum;
}
)";

TEST(ShaderCostProfile, LoopAndBranchCountsPerInvocation) {
  auto renderer = render::Renderer::create();
  if (!renderer.ok()) GTEST_SKIP() << "SKIPPED: no OpenGL context: " << renderer.error().message;
  auto asset = (*renderer)->uploadAsset(unitSquare());
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  ir::Module vertex = compileModule(kPositionVertexShader, Stage::kVertex, "position.vert");
  ir::Module fragment = compileModule(kLoopBranchShader, Stage::kFragment, "loop.frag");
  std::vector<render::Sample> samples{headOnSample()};
  auto profile = profileBlockCounts(**renderer, *asset, vertex, fragment, samples, 64);
  ASSERT_TRUE(profile.ok()) << profile.error().message;

  // Every pixel centre inside the square ran the shader once; llvmpipe's statistics count whole
  // 4×4 blocks, so at least as many.
  EXPECT_EQ(profile->fragment_runs, 32u * 32u);
  EXPECT_GE(profile->fragment_invocations, profile->fragment_runs);
  EXPECT_GE(profile->vertex_runs, 4u);

  std::vector<BlockOps> blocks = blockOpCounts(fragment);
  ASSERT_EQ(profile->fragment_executions.size(), blocks.size());
  EXPECT_EQ(profile->fragment_executions[0], 1.0);  // the entry block, once per invocation
  int loop_bodies = 0, branches = 0;
  for (size_t b = 0; b < blocks.size(); ++b) {
    // The loop body is the block converting i to float; the branch the one with the sine.
    if (at(blocks[b].ops, OpClass::kConversionComposite) > 0 &&
        at(blocks[b].ops, OpClass::kFloatArithmetic) >= 4) {
      EXPECT_EQ(profile->fragment_executions[b], 4.0) << "loop body";
      ++loop_bodies;
    }
    if (at(blocks[b].ops, OpClass::kTranscendental) > 0) {
      EXPECT_EQ(profile->fragment_executions[b], 0.5) << "branch taken at x < 0";
      ++branches;
    }
  }
  EXPECT_EQ(loop_bodies, 1);
  EXPECT_EQ(branches, 1);
  // Dynamic counts: the vec4 sine is 4 transcendental ops, run by half the pixels: 2 per invocation.
  OpClassCounts dynamic = dynamicOpCounts(fragment, profile->fragment_executions);
  EXPECT_EQ(at(dynamic, OpClass::kTranscendental), 2);
  // The vertex stage has no control flow: its one block runs once per vertex.
  ASSERT_EQ(profile->vertex_executions.size(), 1u);
  EXPECT_EQ(profile->vertex_executions[0], 1.0);
}

// A shader's own storage block at binding 7, the fragment counters' default: the counters move
// past it, so it reads zeros (duolod binds it no buffer) and the branch it decides never runs.
// Aliased with the counters, it read the entry block's count and the branch ran everywhere.
const char* kStorageBranchShader = R"(#version 450
layout(location = 0) in vec3 vObjectPosition;
layout(std430, binding = 7) buffer Data { uint data[]; };
layout(location = 0) out vec4 outColor;
void main() {
  vec4 sum = vec4(vObjectPosition, 1.0);
  if (data[0] > 0u) sum = sin(sum);
  outColor = sum;
}
)";

TEST(ShaderCostProfile, AShadersOwnStorageBlockIsNotTheCounters) {
  ir::Module vertex = compileModule(kPositionVertexShader, Stage::kVertex, "position.vert");
  ir::Module fragment = compileModule(kStorageBranchShader, Stage::kFragment, "storage.frag");
  ir::Module plain = compileModule(kLoopBranchShader, Stage::kFragment, "loop.frag");
  EXPECT_EQ(counterBindings(vertex, plain), std::make_pair(6u, 7u));
  EXPECT_EQ(counterBindings(vertex, fragment), std::make_pair(6u, 8u));
  // Arrays of storage blocks take a binding per element.
  for (auto [declaration, expected] :
       {std::pair{"layout(std430, binding = 6) buffer Data { uint data[]; } blocks[2];",
                  std::make_pair(8u, 9u)},
        std::pair{"layout(std430, binding = 5) buffer Data { uint data[]; } blocks[3];",
                  std::make_pair(8u, 9u)}}) {
    const std::string source = std::string("#version 450\n") + declaration +
                               "\nlayout(location = 0) out vec4 outColor;\n"
                               "void main() { outColor = vec4(float(blocks[1].data[0])); }\n";
    EXPECT_EQ(
        counterBindings(vertex, compileModule(source.c_str(), Stage::kFragment, "arrays.frag")),
        expected)
        << declaration;
  }

  auto renderer = render::Renderer::create();
  if (!renderer.ok()) GTEST_SKIP() << "SKIPPED: no OpenGL context: " << renderer.error().message;
  auto asset = (*renderer)->uploadAsset(unitSquare());
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  std::vector<render::Sample> samples{headOnSample()};
  auto profile = profileBlockCounts(**renderer, *asset, vertex, fragment, samples, 64);
  ASSERT_TRUE(profile.ok()) << profile.error().message;
  EXPECT_EQ(profile->fragment_runs, 32u * 32u);
  std::vector<BlockOps> blocks = blockOpCounts(fragment);
  int branches = 0;
  for (size_t b = 0; b < blocks.size(); ++b)
    if (at(blocks[b].ops, OpClass::kTranscendental) > 0) {
      EXPECT_EQ(profile->fragment_executions[b], 0.0) << "the unbound block reads zeros";
      ++branches;
    }
  EXPECT_EQ(branches, 1);
}

}  // namespace
}  // namespace duolod::shader
