// Basic-block execution counting for the cost model (Liang et al. §5.2; shader/cost_model.hpp):
// a COPY of a stage's module in which every basic block atomically adds 1 to its own counter in a
// shader storage buffer, so one render of the training samples tells how often each block runs.
// Divided by the stage's invocation count (ARB_pipeline_statistics_query) that gives per-block
// executions per invocation, which loop trip counts and branch probabilities make differ from 1.
//
// Why atomics in an SSBO rather than a CPU interpretation of the SPIR-V: the counts then come from
// the real inputs (interpolated varyings, textures, uniforms) of every shaded vertex and pixel, and
// the work is a single render per variant; the counts are exact integers, so they are
// deterministic for a device and input (unlike time). Fragment helper invocations (the unused
// lanes of llvmpipe's 4×4 blocks, or of a GPU's 2×2 quads) do not execute atomics, so a fragment
// entry block counts covered pixels while the pipeline statistics count every shaded lane: the
// per-invocation counts then fold that coverage ratio in, which is what a cost per invocation needs.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"
#include "shader/cost_model.hpp"
#include "shader/ir.hpp"

namespace duolod::shader {

// SSBO bindings of the counters (clear of everything shaders/INTERFACE.md uses; SSBO bindings
// are their own namespace in OpenGL, but keep them apart from the UBOs anyway for readability).
inline constexpr uint32_t kVertexCounterBinding = 6;
inline constexpr uint32_t kFragmentCounterBinding = 7;

struct InstrumentedModule {
  ir::Module module;
  // One counter per block, in blockOpCounts() order (functions in module order, blocks in function
  // order): counter i counts executions of that block, summed over all invocations.
  int counter_count = 0;
  uint32_t binding = 0;
};

// The module with `buffer DuolodBlockCounts { uint count[]; }` at `binding` and, at the start of
// every block (after its OpPhis, and after the entry block's OpVariables), an OpAtomicIAdd of 1
// into the block's counter. The copy validates like the original (tested). Fails on a module
// without functions.
core::Result<InstrumentedModule> instrumentBlockCounts(const ir::Module& module, uint32_t binding);

// Block execution counts of both stages of a program over some samples.
struct BlockProfile {
  std::vector<double> vertex_executions;    // per vertex invocation, one per block
  std::vector<double> fragment_executions;  // per fragment invocation, one per block
  std::vector<uint64_t> vertex_totals, fragment_totals;  // raw counter values
  // Invocations of the instrumented render (ARB_pipeline_statistics_query).
  uint64_t vertex_invocations = 0, fragment_invocations = 0;
};

// Renders `samples` once with the instrumented copies of `vertex` and `fragment` at
// `resolution` and reads the counters back. The renderer's GL context must be current on this
// thread (it is, on the thread that created it). Counters are 32-bit: a block may run at most
// 2^32 − 1 times over the whole render (the profile fails loudly if a counter saturates).
core::Result<BlockProfile> profileBlockCounts(render::Renderer& renderer,
                                              render::Renderer::AssetId asset,
                                              const ir::Module& vertex, const ir::Module& fragment,
                                              std::span<const render::Sample> samples,
                                              int resolution);

// Our model's features (cost_model.hpp) of a program in a configuration: per-invocation op counts
// from `profile` (of this very program), and the configuration's invocations per draw.
CostFeatures profiledCostFeatures(const ir::Module& vertex, const ir::Module& fragment,
                                  const BlockProfile& profile, double vertex_invocations_per_draw,
                                  double fragment_invocations_per_draw);

}  // namespace duolod::shader
