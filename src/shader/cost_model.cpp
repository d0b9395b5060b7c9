// Shader cost models: He et al. 2015's static heuristic and ours (Liang et al. §5.2), with the
// non-negative least-squares calibration of the per-opcode-class weights (Lawson & Hanson 1974).
#include "shader/cost_model.hpp"

#include <glslang/SPIRV/GLSL.std.450.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace duolod::shader {

using core::Error;

std::string_view opClassName(OpClass op_class) {
  switch (op_class) {
    case OpClass::kFloatArithmetic: return "float arithmetic";
    case OpClass::kIntegerLogic: return "integer/logic";
    case OpClass::kTranscendental: return "transcendental";
    case OpClass::kTextureSample: return "texture sample";
    case OpClass::kMemory: return "memory";
    case OpClass::kConversionComposite: return "conversion/composite";
    case OpClass::kControlFlow: return "control flow";
  }
  return "?";
}

namespace {

double componentsOf(const ir::DefUse& uses, ir::Id type_id) {
  uint32_t components = type_id == ir::kNoId ? 0 : ir::typeInfo(uses, type_id).components;
  return components ? components : 1;
}

// Components of the value an id names (its type's).
double operandComponents(const ir::DefUse& uses, ir::Id value) {
  const ir::Instruction* definition = uses.def(value);
  return definition ? componentsOf(uses, definition->type_id) : 1;
}

bool isGlslStd450(const ir::Module& module, ir::Id set) {
  for (const ir::Instruction& import : module.ext_inst_imports)
    if (import.result_id == set) return import.literalString(0) == "GLSL.std.450";
  return false;
}

// GLSL.std.450 extended instructions: the transcendental ones (a polynomial or table evaluation in
// a software rasteriser, a special-function unit on a GPU), the integer ones, the rest float.
InstructionCost classifyExtInst(const ir::Module& module, const ir::DefUse& uses,
                                const ir::Instruction& instruction, double result_components) {
  if (instruction.operands.size() < 2 || !isGlslStd450(module, instruction.operands[0]))
    return {OpClass::kFloatArithmetic, result_components};
  auto first_argument_components = [&] {
    return instruction.operands.size() > 2 ? operandComponents(uses, instruction.operands[2]) : 1;
  };
  switch (static_cast<GLSLstd450>(instruction.operands[1])) {
    case GLSLstd450Sin: case GLSLstd450Cos: case GLSLstd450Tan: case GLSLstd450Asin:
    case GLSLstd450Acos: case GLSLstd450Atan: case GLSLstd450Sinh: case GLSLstd450Cosh:
    case GLSLstd450Tanh: case GLSLstd450Asinh: case GLSLstd450Acosh: case GLSLstd450Atanh:
    case GLSLstd450Atan2: case GLSLstd450Pow: case GLSLstd450Exp: case GLSLstd450Log:
    case GLSLstd450Exp2: case GLSLstd450Log2: case GLSLstd450Sqrt: case GLSLstd450InverseSqrt:
    case GLSLstd450Determinant: case GLSLstd450MatrixInverse: case GLSLstd450Normalize:
    case GLSLstd450Refract:
      return {OpClass::kTranscendental, result_components};
    case GLSLstd450Length:
    case GLSLstd450Distance:  // a scalar from a vector: the square root of a dot product
      return {OpClass::kTranscendental, first_argument_components()};
    case GLSLstd450SAbs: case GLSLstd450SSign: case GLSLstd450UMin: case GLSLstd450SMin:
    case GLSLstd450UMax: case GLSLstd450SMax: case GLSLstd450UClamp: case GLSLstd450SClamp:
    case GLSLstd450FindILsb: case GLSLstd450FindSMsb: case GLSLstd450FindUMsb:
      return {OpClass::kIntegerLogic, result_components};
    default: return {OpClass::kFloatArithmetic, result_components};
  }
}

}  // namespace

InstructionCost classifyInstruction(const ir::Module& module, const ir::DefUse& uses,
                                    const ir::Instruction& instruction) {
  const double result = componentsOf(uses, instruction.type_id);
  auto operand = [&](size_t index) {
    return index < instruction.operands.size() ? operandComponents(uses, instruction.operands[index])
                                               : 1.0;
  };
  switch (instruction.opcode) {
    // Float arithmetic, one op per result component.
    case spv::OpFAdd: case spv::OpFSub: case spv::OpFMul: case spv::OpFDiv: case spv::OpFRem:
    case spv::OpFMod: case spv::OpFNegate: case spv::OpVectorTimesScalar:
    case spv::OpMatrixTimesScalar: case spv::OpOuterProduct: case spv::OpSelect:
    case spv::OpIsNan: case spv::OpIsInf: case spv::OpFOrdEqual: case spv::OpFUnordEqual:
    case spv::OpFOrdNotEqual: case spv::OpFUnordNotEqual: case spv::OpFOrdLessThan:
    case spv::OpFUnordLessThan: case spv::OpFOrdGreaterThan: case spv::OpFUnordGreaterThan:
    case spv::OpFOrdLessThanEqual: case spv::OpFUnordLessThanEqual:
    case spv::OpFOrdGreaterThanEqual: case spv::OpFUnordGreaterThanEqual: case spv::OpDPdx:
    case spv::OpDPdy: case spv::OpFwidth: case spv::OpDPdxFine: case spv::OpDPdyFine:
    case spv::OpFwidthFine: case spv::OpDPdxCoarse: case spv::OpDPdyCoarse:
    case spv::OpFwidthCoarse:
      return {OpClass::kFloatArithmetic, result};
    // Products that sum: one multiply-add per element of the larger operand.
    case spv::OpDot: return {OpClass::kFloatArithmetic, operand(0)};
    case spv::OpMatrixTimesVector: return {OpClass::kFloatArithmetic, result * operand(1)};
    case spv::OpVectorTimesMatrix: return {OpClass::kFloatArithmetic, result * operand(0)};
    case spv::OpMatrixTimesMatrix: {
      // (r × k) · (k × c): r·c results of k multiply-adds each; k is the left operand's columns.
      const ir::Instruction* left = uses.def(instruction.operands[0]);
      uint32_t inner = left ? ir::typeInfo(uses, left->type_id).columns : 0;
      return {OpClass::kFloatArithmetic, result * std::max<uint32_t>(inner, 1)};
    }
    case spv::OpExtInst: return classifyExtInst(module, uses, instruction, result);

    // Integer arithmetic and logic.
    case spv::OpIAdd: case spv::OpISub: case spv::OpIMul: case spv::OpSDiv: case spv::OpUDiv:
    case spv::OpSRem: case spv::OpSMod: case spv::OpUMod: case spv::OpSNegate:
    case spv::OpShiftLeftLogical: case spv::OpShiftRightLogical:
    case spv::OpShiftRightArithmetic: case spv::OpBitwiseAnd: case spv::OpBitwiseOr:
    case spv::OpBitwiseXor: case spv::OpNot: case spv::OpBitFieldInsert:
    case spv::OpBitFieldSExtract: case spv::OpBitFieldUExtract: case spv::OpBitReverse:
    case spv::OpBitCount: case spv::OpLogicalAnd: case spv::OpLogicalOr: case spv::OpLogicalNot:
    case spv::OpLogicalEqual: case spv::OpLogicalNotEqual: case spv::OpIEqual:
    case spv::OpINotEqual: case spv::OpUGreaterThan: case spv::OpSGreaterThan:
    case spv::OpUGreaterThanEqual: case spv::OpSGreaterThanEqual: case spv::OpULessThan:
    case spv::OpSLessThan: case spv::OpULessThanEqual: case spv::OpSLessThanEqual:
    case spv::OpIAddCarry: case spv::OpISubBorrow: case spv::OpUMulExtended:
    case spv::OpSMulExtended:
      return {OpClass::kIntegerLogic, result};
    case spv::OpAny: case spv::OpAll: return {OpClass::kIntegerLogic, operand(0)};

    // Conversions and composites: moves and lane shuffles.
    case spv::OpConvertFToU: case spv::OpConvertFToS: case spv::OpConvertSToF:
    case spv::OpConvertUToF: case spv::OpUConvert: case spv::OpSConvert: case spv::OpFConvert:
    case spv::OpQuantizeToF16: case spv::OpBitcast: case spv::OpCompositeConstruct:
    case spv::OpCompositeExtract: case spv::OpCompositeInsert: case spv::OpVectorShuffle:
    case spv::OpVectorExtractDynamic: case spv::OpVectorInsertDynamic: case spv::OpCopyObject:
    case spv::OpTranspose:
      return {OpClass::kConversionComposite, result};

    // Texture operations: one per call, whatever the width (He et al. count calls).
    case spv::OpImageSampleImplicitLod: case spv::OpImageSampleExplicitLod:
    case spv::OpImageSampleDrefImplicitLod: case spv::OpImageSampleDrefExplicitLod:
    case spv::OpImageSampleProjImplicitLod: case spv::OpImageSampleProjExplicitLod:
    case spv::OpImageSampleProjDrefImplicitLod: case spv::OpImageSampleProjDrefExplicitLod:
    case spv::OpImageFetch: case spv::OpImageGather: case spv::OpImageDrefGather:
    case spv::OpImageRead: case spv::OpImageWrite: case spv::OpImageQuerySizeLod:
    case spv::OpImageQuerySize: case spv::OpImageQueryLod: case spv::OpImageQueryLevels:
    case spv::OpImageQuerySamples:
      return {OpClass::kTextureSample, 1};

    // Memory: per instruction (a vec4 uniform load is one access).
    case spv::OpLoad: case spv::OpStore: case spv::OpAccessChain:
    case spv::OpInBoundsAccessChain: case spv::OpPtrAccessChain: case spv::OpCopyMemory:
    case spv::OpCopyMemorySized: case spv::OpAtomicLoad: case spv::OpAtomicStore:
    case spv::OpAtomicExchange: case spv::OpAtomicCompareExchange: case spv::OpAtomicIIncrement:
    case spv::OpAtomicIDecrement: case spv::OpAtomicIAdd: case spv::OpAtomicISub:
    case spv::OpAtomicSMin: case spv::OpAtomicUMin: case spv::OpAtomicSMax:
    case spv::OpAtomicUMax: case spv::OpAtomicAnd: case spv::OpAtomicOr: case spv::OpAtomicXor:
      return {OpClass::kMemory, 1};

    // Control flow: per instruction.
    case spv::OpBranch: case spv::OpBranchConditional: case spv::OpSwitch: case spv::OpReturn:
    case spv::OpReturnValue: case spv::OpKill: case spv::OpUnreachable:
    case spv::OpFunctionCall: case spv::OpPhi: case spv::OpTerminateInvocation:
    case spv::OpDemoteToHelperInvocationEXT:
      return {OpClass::kControlFlow, 1};

    // Declarations: no work at run time (OpVariable, merges, debug lines, OpUndef, OpSampledImage
    // and OpImage which only pair handles).
    default: return {OpClass::kControlFlow, 0};
  }
}

std::vector<BlockOps> blockOpCounts(const ir::Module& module) {
  ir::DefUse uses(module);
  std::vector<BlockOps> blocks;
  for (const ir::Function& function : module.functions) {
    for (const ir::Block& block : function.blocks) {
      BlockOps counts{.function = function.id(), .block = block.id()};
      for (const ir::Instruction& instruction : block.instructions) {
        InstructionCost cost = classifyInstruction(module, uses, instruction);
        counts.ops[static_cast<int>(cost.op_class)] += cost.count;
      }
      blocks.push_back(counts);
    }
  }
  return blocks;
}

OpClassCounts staticOpCounts(const ir::Module& module) {
  OpClassCounts total{};
  for (const BlockOps& block : blockOpCounts(module))
    for (int k = 0; k < kOpClassCount; ++k) total[k] += block.ops[k];
  return total;
}

OpClassCounts dynamicOpCounts(const ir::Module& module,
                              std::span<const double> executions_per_invocation) {
  std::vector<BlockOps> blocks = blockOpCounts(module);
  assert(blocks.size() == executions_per_invocation.size());
  OpClassCounts total{};
  for (size_t b = 0; b < blocks.size(); ++b)
    for (int k = 0; k < kOpClassCount; ++k)
      total[k] += executions_per_invocation[b] * blocks[b].ops[k];
  return total;
}

double heStaticCost(const ir::Module& module) {
  OpClassCounts counts = staticOpCounts(module);
  auto at = [&](OpClass op_class) { return counts[static_cast<int>(op_class)]; };
  return at(OpClass::kFloatArithmetic) + at(OpClass::kIntegerLogic) +
         at(OpClass::kTranscendental) + kHeTextureWeight * at(OpClass::kTextureSample);
}

double heStaticCost(const ir::Module& vertex, const ir::Module& fragment) {
  return heStaticCost(vertex) + heStaticCost(fragment);
}

// ---------------------------------------------------------------------------------------------

CostFeatures staticCostFeatures(const ir::Module& vertex, const ir::Module& fragment,
                                double vertex_invocations_per_draw,
                                double fragment_invocations_per_draw) {
  return {.vertex_ops = staticOpCounts(vertex),
          .fragment_ops = staticOpCounts(fragment),
          .vertex_invocations = vertex_invocations_per_draw,
          .fragment_invocations = fragment_invocations_per_draw};
}

std::array<double, kCostModelParameterCount> costDesignRow(const CostFeatures& features) {
  std::array<double, kCostModelParameterCount> row{};
  for (int k = 0; k < kOpClassCount; ++k)
    row[k] = features.vertex_invocations * features.vertex_ops[k] +
             features.fragment_invocations * features.fragment_ops[k];
  row[kOpClassCount] = features.vertex_invocations;
  row[kOpClassCount + 1] = features.fragment_invocations;
  row[kOpClassCount + 2] = 1;  // one draw
  return row;
}

std::array<double, kCostModelParameterCount> weightVector(const CostWeights& weights) {
  std::array<double, kCostModelParameterCount> vector{};
  std::copy(weights.per_op.begin(), weights.per_op.end(), vector.begin());
  vector[kOpClassCount] = weights.per_vertex_invocation;
  vector[kOpClassCount + 1] = weights.per_fragment_invocation;
  vector[kOpClassCount + 2] = weights.per_draw;
  return vector;
}

CostWeights weightsFromVector(std::span<const double> vector, std::string version) {
  assert(vector.size() == kCostModelParameterCount);
  CostWeights weights;
  std::copy(vector.begin(), vector.begin() + kOpClassCount, weights.per_op.begin());
  weights.per_vertex_invocation = vector[kOpClassCount];
  weights.per_fragment_invocation = vector[kOpClassCount + 1];
  weights.per_draw = vector[kOpClassCount + 2];
  weights.version = std::move(version);
  return weights;
}

std::vector<std::string> costModelParameterNames() {
  std::vector<std::string> names;
  for (int k = 0; k < kOpClassCount; ++k)
    names.emplace_back(opClassName(static_cast<OpClass>(k)));
  names.insert(names.end(), {"vertex invocation", "fragment invocation", "draw"});
  return names;
}

double predictCost(const CostFeatures& features, const CostWeights& weights) {
  CostFeatures scaled = features;
  for (double& ops : scaled.vertex_ops) ops *= weights.vertex_op_scale;
  auto row = costDesignRow(scaled);
  auto w = weightVector(weights);
  double cost = 0;
  for (int i = 0; i < kCostModelParameterCount; ++i) cost += row[i] * w[i];
  return cost;
}

// Lawson–Hanson active-set NNLS. Columns are scaled to unit norm first (the op counts and the
// per-draw column differ by ~10^6), the passive-set subproblems solved by column-pivoting QR,
// which also copes with collinear columns (e.g. vertex invocations constant per asset).
core::Result<std::vector<double>> solveNonNegativeLeastSquares(
    const std::vector<std::vector<double>>& rows, std::span<const double> targets) {
  if (rows.empty() || rows.size() != targets.size())
    return Error{"NNLS: " + std::to_string(rows.size()) + " rows for " +
                 std::to_string(targets.size()) + " targets"};
  const int m = static_cast<int>(rows.size()), n = static_cast<int>(rows[0].size());
  if (n == 0) return Error{"NNLS: no unknowns"};
  Eigen::MatrixXd a(m, n);
  Eigen::VectorXd b(m);
  for (int i = 0; i < m; ++i) {
    if (static_cast<int>(rows[i].size()) != n)
      return Error{"NNLS: row " + std::to_string(i) + " has " + std::to_string(rows[i].size()) +
                   " entries, expected " + std::to_string(n)};
    for (int j = 0; j < n; ++j) {
      if (!std::isfinite(rows[i][j]) || !std::isfinite(targets[i]))
        return Error{"NNLS: row " + std::to_string(i) + " is not finite"};
      a(i, j) = rows[i][j];
    }
    b(i) = targets[i];
  }
  Eigen::VectorXd scale = a.colwise().norm().transpose();
  for (int j = 0; j < n; ++j) {
    scale(j) = scale(j) > 0 ? 1.0 / scale(j) : 0.0;
    a.col(j) *= scale(j);
  }

  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(n, false);
  const double tolerance = 1e-12 * std::max(1.0, b.norm());
  auto solvePassive = [&]() {
    std::vector<int> columns;
    for (int j = 0; j < n; ++j)
      if (passive[j]) columns.push_back(j);
    Eigen::MatrixXd sub(m, static_cast<int>(columns.size()));
    for (size_t c = 0; c < columns.size(); ++c) sub.col(static_cast<int>(c)) = a.col(columns[c]);
    Eigen::VectorXd solution = sub.colPivHouseholderQr().solve(b);
    Eigen::VectorXd z = Eigen::VectorXd::Zero(n);
    for (size_t c = 0; c < columns.size(); ++c) z(columns[c]) = solution(static_cast<int>(c));
    return z;
  };
  for (int outer = 0; outer < 3 * n + 10; ++outer) {
    Eigen::VectorXd gradient = a.transpose() * (b - a * x);
    int best = -1;
    for (int j = 0; j < n; ++j)
      if (!passive[j] && scale(j) > 0 && gradient(j) > tolerance &&
          (best < 0 || gradient(j) > gradient(best)))
        best = j;
    if (best < 0) break;
    passive[best] = true;
    for (int inner = 0; inner < 3 * n + 10; ++inner) {
      Eigen::VectorXd z = solvePassive();
      double step = 1;
      int blocking = -1;
      for (int j = 0; j < n; ++j) {
        if (passive[j] && z(j) <= 0) {
          double denominator = x(j) - z(j);
          double candidate = denominator > 0 ? x(j) / denominator : 0;
          if (candidate < step) step = candidate, blocking = j;
        }
      }
      if (blocking < 0) {
        x = z;
        break;
      }
      x += step * (z - x);
      for (int j = 0; j < n; ++j)
        if (passive[j] && (j == blocking || x(j) <= 1e-15)) passive[j] = false, x(j) = 0;
    }
  }
  std::vector<double> result(n);
  for (int j = 0; j < n; ++j) result[j] = std::max(0.0, x(j) * scale(j));
  return result;
}

core::Result<CostWeights> calibrateCostWeights(std::span<const CostFeatures> features,
                                               std::span<const double> measured_seconds,
                                               std::string version) {
  if (features.size() != measured_seconds.size() || features.empty())
    return Error{"cost calibration: " + std::to_string(features.size()) + " configurations for " +
                 std::to_string(measured_seconds.size()) + " measurements"};
  std::vector<std::vector<double>> rows;
  std::vector<double> targets;
  for (size_t i = 0; i < features.size(); ++i) {
    if (!(measured_seconds[i] > 0))
      return Error{"cost calibration: measurement " + std::to_string(i) + " is not positive"};
    auto row = costDesignRow(features[i]);
    std::vector<double> relative(row.begin(), row.end());
    for (double& value : relative) value /= measured_seconds[i];
    rows.push_back(std::move(relative));
    targets.push_back(1.0);
  }
  auto solution = solveNonNegativeLeastSquares(rows, targets);
  if (!solution.ok()) return solution.error();
  return weightsFromVector(*solution, std::move(version));
}

CostScaleFit fitCostScale(std::span<const CostFeatures> features,
                          std::span<const double> measured_seconds, const CostWeights& weights) {
  std::vector<double> ratios;  // predicted / measured
  for (size_t i = 0; i < features.size() && i < measured_seconds.size(); ++i)
    if (measured_seconds[i] > 0) ratios.push_back(predictCost(features[i], weights) / measured_seconds[i]);
  double sum = 0, squares = 0;
  for (double r : ratios) sum += r, squares += r * r;
  if (!(squares > 0)) return {};
  CostScaleFit fit;
  fit.factor = sum / squares;  // argmin Σ (α r − 1)²
  fit.points = ratios.size();
  fit.smallest_ratio = std::numeric_limits<double>::infinity();
  fit.largest_ratio = 0;
  for (double r : ratios) {
    const double scaled = fit.factor * r;
    fit.residual += (scaled - 1) * (scaled - 1);
    fit.smallest_ratio = std::min(fit.smallest_ratio, scaled);
    fit.largest_ratio = std::max(fit.largest_ratio, scaled);
  }
  return fit;
}

double fitVertexOpScale(std::span<const CostFeatures> features,
                        std::span<const double> measured_seconds, const CostWeights& weights,
                        double max_scale) {
  double best_scale = 1, best_residual = std::numeric_limits<double>::infinity();
  CostWeights trial = weights;
  for (double scale = 1; scale <= max_scale * 1.0001; scale *= 1.05) {
    trial.vertex_op_scale = scale;
    const CostScaleFit fit = fitCostScale(features, measured_seconds, trial);
    if (fit.points > 0 && fit.residual < best_residual) best_residual = fit.residual, best_scale = scale;
  }
  return best_scale;
}

// Version "llvmpipe-2026-11-22c" = the per-op and invocation weights of "llvmpipe-2026-11-22b",
// calibrated on Mesa 22.3.6 llvmpipe (LLVM 15, 256-bit SIMD;
// 2 cores shared with other jobs, no GPU) by
//   build/bench/bench_shader_cost --resolutions 128 64 --repeats 7
// (49 variants of pbr / noise_phong / blend on WaterBottle / Spot / Avocado, 20 views, at 128 and
// 64 px: 98 configurations), from its "weights calibrated on all points" line. bench/RESULTS.md
// checks them against a later, independent run. Units: seconds per op, per invocation, per draw.
// NNLS zeroes the classes whose cost the others already explain on this device (llvmpipe's JIT
// folds most conversions and moves into the arithmetic around them).
// Version c adds vertex_op_scale = 2: the vertex stage's ops cost twice the fragment stage's
// (llvmpipe shades vertices on one thread). fitVertexOpScale on noise_phong with six
// per-vertex-rule variants (`bench_shader_cost --only noise_phong --per-vertex turbulence nDotL
// radiance outColor diffuse normal`) gave 1.89 and 2.53 on Spot, 2.18 and 3.07 on the Dragon;
// over all 110 points of the three shaders 1.16-1.71, because a larger scale shifts whole assets
// against each other (the per-op weights were fitted without it). 2 keeps the pooled Spearman
// above 0.95 and noise_phong's at 0.99 (bench/RESULTS.md, cost model section).
// Version "llvmpipe-2026-11-24d" = version c with every weight times 0.0911, the median of the
// common factors (fitCostScale) of three idle runs of the command above on this project's
// reference machine (2 cores, load < 1.3: 0.0911, 0.0921, 0.0893). Versions b and c were measured with the machine
// shared (load average ~25 on 2 cores), which left the ranks usable but every absolute cost
// 8-14x too high: `generate` printed 30.2 ms per draw for Spot's original at 256 px against a
// measured 2.49 ms. One factor changes no rank, so no search's choice changes; in a fourth idle
// run the 98 configurations' predictions were 0.75-1.33x their measured time (median 0.96, common
// factor 0.98; bench/RESULTS.md, cost model section).
namespace {
CostWeights withVertexOpScale(CostWeights weights, double scale) {
  weights.vertex_op_scale = scale;
  return weights;
}

CostWeights scaledBy(CostWeights weights, double factor, std::string version) {
  for (double& w : weights.per_op) w *= factor;
  weights.per_vertex_invocation *= factor;
  weights.per_fragment_invocation *= factor;
  weights.per_draw *= factor;
  weights.version = std::move(version);
  return weights;
}
}  // namespace

const CostWeights& calibratedCostWeights() {
  static const CostWeights weights = scaledBy(withVertexOpScale(weightsFromVector(
      std::array<double, kCostModelParameterCount>{
          8.345776e-11,  // float arithmetic (per component)
          1.414071e-11,  // integer/logic
          0.0,           // transcendental
          3.017172e-08,  // texture sample
          6.564002e-09,  // memory
          0.0,           // conversion/composite
          0.0,           // control flow
          1.867042e-07,  // per vertex invocation
          0.0,           // per fragment invocation
          0.0,           // per draw
      },
      "llvmpipe-2026-11-22c"), 2.0), 0.0911, "llvmpipe-2026-11-24d");
  return weights;
}

}  // namespace duolod::shader
