// Shader cost models (Liang et al. §5.2; issue 4 item 4), private to src/shader.
//
// Two predictors of what a (shader variant, mesh, distance) configuration costs to draw:
//
//  * He et al. 2015 ("Extending the graphics pipeline with adaptive, multi-rate shading", their
//    shader-simplification cost heuristic): a static count over the SPIR-V of both stages,
//    `scalar ops + 100 × texture ops`, vector operations counting one op per component. It ignores
//    how often each instruction runs (loops, branches) and how many vertices and pixels are shaded.
//
//  * Ours, the paper's extension with vertex and pixel counts (§5.2): per-opcode-class weights ×
//    per-block dynamic execution counts per invocation (from an instrumented run of the variant over
//    the training samples, shader/instrument.hpp), for each stage, × the vertex and fragment
//    invocation counts of the configuration (ARB_pipeline_statistics_query), plus a fixed cost per
//    draw:
//        cost = V · c_v + F · c_f + draws · w_draw,
//        c_s  = w_invocation_s + m_s Σ_k w_k · n_{s,k}   (n_{s,k}: class-k ops per invocation of
//               stage s; m_fragment = 1, m_vertex = vertex_op_scale: llvmpipe shades vertices on
//               one thread and fragments on every core)
//    The weights are calibrated against measured llvmpipe wall time by non-negative least squares
//    (bench/shader_cost.cpp) and stored in a versioned table, so prediction needs no timing.
//
// DESIGN.md "Measuring cost": static instruction counts rank shaders poorly (Spearman ≈ 0.7); counts
// weighted by dynamic block execution rank them well (≈ 0.96).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "duolod/core.hpp"
#include "shader/ir.hpp"

namespace duolod::shader {

// What an instruction costs, by kind. Counts are per scalar component for value-producing classes
// (a vec3 add counts 3, a mat4 × vec4 counts 16) and per instruction for the others.
enum class OpClass {
  kFloatArithmetic,      // add, mul, fma, dot, mix, clamp, floor, comparisons, selects, derivatives
  kIntegerLogic,         // integer arithmetic, bit operations, shifts, boolean logic
  kTranscendental,       // GLSL.std.450 sin/cos/exp/log/pow/sqrt/inversesqrt/normalize/length...
  kTextureSample,        // OpImageSample*, OpImageFetch, OpImageGather*, image queries: per call
  kMemory,               // OpLoad, OpStore, OpAccessChain, OpCopyMemory: per instruction
  kConversionComposite,  // conversions, bitcasts, composite construct/extract/insert, shuffles
  kControlFlow,          // branches, switches, calls, returns, kill, phis: per instruction
};
inline constexpr int kOpClassCount = 7;
std::string_view opClassName(OpClass op_class);  // "float arithmetic", ...

using OpClassCounts = std::array<double, kOpClassCount>;

// The class of one function-body instruction and how many ops it counts, or count 0 for
// instructions that do no work (OpVariable, merge declarations, OpLine, OpUndef...).
struct InstructionCost {
  OpClass op_class = OpClass::kFloatArithmetic;
  double count = 0;
};
InstructionCost classifyInstruction(const ir::Module& module, const ir::DefUse& uses,
                                    const ir::Instruction& instruction);

// Per basic block op counts, in the order every block-indexed vector uses: functions in module order,
// blocks in function order (the instrumented run's counter index of a block is its index here).
struct BlockOps {
  ir::Id function = ir::kNoId;
  ir::Id block = ir::kNoId;  // the label id
  OpClassCounts ops{};
};
std::vector<BlockOps> blockOpCounts(const ir::Module& module);

// Op counts of the whole module, every block once (static).
OpClassCounts staticOpCounts(const ir::Module& module);
// Op counts per invocation: Σ_blocks executions(block) × ops(block). `executions_per_invocation`
// holds one entry per blockOpCounts() block (precondition).
OpClassCounts dynamicOpCounts(const ir::Module& module,
                              std::span<const double> executions_per_invocation);

// He et al. 2015: scalar ops (float, integer/logic and transcendental components) + 100 × texture
// ops, counted statically over one module.
inline constexpr double kHeTextureWeight = 100;
double heStaticCost(const ir::Module& module);
// The heuristic for a program: the sum over its vertex and fragment modules.
double heStaticCost(const ir::Module& vertex, const ir::Module& fragment);

// ---------------------------------------------------------------------------------------------
// Ours (§5.2).

// Everything the cost of one configuration depends on, per draw of the object (one view).
struct CostFeatures {
  OpClassCounts vertex_ops{};    // class-k ops per vertex invocation (dynamic)
  OpClassCounts fragment_ops{};  // class-k ops per fragment invocation (dynamic)
  double vertex_invocations = 0;    // V per draw (pipeline statistics)
  double fragment_invocations = 0;  // F per draw
};

// The model's weights, in seconds (the unit of the calibration's measurements).
struct CostWeights {
  OpClassCounts per_op{};            // w_k, shared by both stages (the same per-opcode table)
  double per_vertex_invocation = 0;  // launching one vertex invocation
  double per_fragment_invocation = 0;
  double per_draw = 0;               // fixed cost of one draw (state, binning, setup)
  // Multiplies the per-op weights in the vertex stage: llvmpipe shades vertices on one thread and
  // fragments on every core, so the same op costs more per vertex. Not part of the linear fit
  // (weightVector); fitted afterwards (fitVertexOpScale).
  double vertex_op_scale = 1;
  std::string version;               // which calibration (see calibratedCostWeights())
};

// The features with every block counted once per invocation (no profile): "static counts × V, F",
// the ablation that shows what the dynamic counts add.
CostFeatures staticCostFeatures(const ir::Module& vertex, const ir::Module& fragment,
                                double vertex_invocations_per_draw,
                                double fragment_invocations_per_draw);

// Predicted seconds of one draw: V·c_v + F·c_f + w_draw.
double predictCost(const CostFeatures& features, const CostWeights& weights);

// The design row of one configuration for the linear model, in the order of
// costModelParameterNames(): per-op classes, then vertex invocations, fragment invocations, draw.
inline constexpr int kCostModelParameterCount = kOpClassCount + 3;
std::array<double, kCostModelParameterCount> costDesignRow(const CostFeatures& features);
std::array<double, kCostModelParameterCount> weightVector(const CostWeights& weights);
CostWeights weightsFromVector(std::span<const double> vector, std::string version);
std::vector<std::string> costModelParameterNames();

// Non-negative least squares (Lawson & Hanson 1974, "Solving Least Squares Problems", ch. 23):
// x >= 0 minimising ‖A x − b‖₂. `rows` are the rows of A. Errors on empty or inconsistent input.
core::Result<std::vector<double>> solveNonNegativeLeastSquares(
    const std::vector<std::vector<double>>& rows, std::span<const double> targets);

// Calibrates the weights on measured seconds per draw by NNLS on relative errors (each row divided
// by its measurement, so a cheap variant weighs as much as an expensive one: ranks are what the
// search needs).
core::Result<CostWeights> calibrateCostWeights(std::span<const CostFeatures> features,
                                               std::span<const double> measured_seconds,
                                               std::string version);

// The common factor α that best fits `weights`' predictions to `measured_seconds` (α·predicted
// against measured, least squared relative error, in closed form: α = Σr / Σr² over the ratios
// r = predicted / measured), and the spread it leaves (α·r over the points). α = 1 means the
// weights' absolute scale is right on the machine that measured; scaling every weight by α
// changes no rank.
struct CostScaleFit {
  double factor = 1;
  double residual = 0;        // Σ (α r − 1)²
  double smallest_ratio = 0;  // min and max of α r
  double largest_ratio = 0;
  size_t points = 0;          // configurations with a measurement
};
CostScaleFit fitCostScale(std::span<const CostFeatures> features,
                          std::span<const double> measured_seconds, const CostWeights& weights);

// The vertex_op_scale in [1, max_scale] that best fits `measured_seconds` with `weights`' other
// terms: per scale, the best common factor α (the relative fit of α·predicted to measured, in
// closed form), then the scale with the least squared relative error, on a geometric grid. The
// common factor leaves the per-op weights of another run usable: ranks are what the searches use.
double fitVertexOpScale(std::span<const CostFeatures> features,
                        std::span<const double> measured_seconds, const CostWeights& weights,
                        double max_scale = 16);

// The weights calibrated on this project's reference machine (bench/shader_cost.cpp, Mesa
// llvmpipe), with the command that produced them in cost_model.cpp.
const CostWeights& calibratedCostWeights();

}  // namespace duolod::shader
