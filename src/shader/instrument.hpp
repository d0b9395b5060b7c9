// Basic-block execution counting for the cost model (Liang et al. §5.2; shader/cost_model.hpp):
// a COPY of a stage's module in which every basic block atomically adds 1 to its own counter in a
// shader storage buffer, so one render of the training samples tells how often each block runs;
// loop trip counts and branch probabilities make that differ from once per invocation.
//
// Why atomics in an SSBO rather than a CPU interpretation of the SPIR-V: the counts then come from
// the real inputs (interpolated varyings, textures, uniforms) of every shaded vertex and pixel, and
// the work is a single render per variant; the counts are exact integers, so they are
// deterministic for a device and input (unlike time).
//
// Per invocation means per invocation that RAN the shader, i.e. counter / entry-block counter, not
// counter / pipeline-statistics invocations: fragment helper lanes (the uncovered lanes of
// llvmpipe's 4×4 blocks, or of a GPU's 2×2 quads) execute the shader but not its atomics, and
// ARB_pipeline_statistics_query counts them. Dividing by the entry block's count gives the work
// of one invocation; the model then multiplies it by the statistics' count, which includes the
// helper lanes that do the same work (measured on llvmpipe: tests/render_counters_test.cpp).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"
#include "shader/cost_model.hpp"
#include "shader/ir.hpp"

namespace duolod::shader {

// SSBO bindings of the counters: by default 6 and 7 (clear of everything shaders/INTERFACE.md
// uses; SSBO bindings are their own namespace in OpenGL, but kept apart from the UBOs anyway for
// readability).
inline constexpr uint32_t kVertexCounterBinding = 6;
inline constexpr uint32_t kFragmentCounterBinding = 7;
// The counters' bindings for a program: the first two from 6 up that neither stage's own storage
// blocks use, skipping 14-15 (the image-driven mode's), so that a shader's own buffer is never
// the counters' (its writes would count, the counts would be its data).
std::pair<uint32_t, uint32_t> counterBindings(const ir::Module& vertex, const ir::Module& fragment);

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
  std::vector<double> vertex_executions;    // per vertex invocation that ran, one per block
  std::vector<double> fragment_executions;  // per fragment invocation that ran, one per block
  std::vector<uint64_t> vertex_totals, fragment_totals;  // raw counter values
  // Invocations that ran (the entry blocks' counters), and the pipeline statistics' invocation
  // counts of the same render (these include fragment helper lanes).
  uint64_t vertex_runs = 0, fragment_runs = 0;
  uint64_t vertex_invocations = 0, fragment_invocations = 0;
};

// Renders `samples` once with the instrumented copies of `vertex` and `fragment` at
// `resolution` and reads the counters back. The renderer's GL context must be current on this
// thread (it is, on the thread that created it). Counters are 32-bit: a block may run at most
// 2^32 − 1 times over the whole render (the profile fails loudly if a counter saturates).
// With `uniforms` set on the instrumented program (a variant's CPU-set parameters) its images
// are the variant's own (the counters change no colour), returned in `images` when given: the
// searches then price a variant's predicted error from this same render, one compile instead of
// two (llvmpipe's shader compiles are most of a search's time).
core::Result<BlockProfile> profileBlockCounts(render::Renderer& renderer,
                                              render::Renderer::AssetId asset,
                                              const ir::Module& vertex, const ir::Module& fragment,
                                              std::span<const render::Sample> samples,
                                              int resolution,
                                              std::span<const render::UniformValue> uniforms = {},
                                              render::ImageBatch8* images = nullptr);

// Our model's features (cost_model.hpp) of a program in a configuration: per-invocation op counts
// from `profile` (of this very program), and the configuration's invocations per draw.
CostFeatures profiledCostFeatures(const ir::Module& vertex, const ir::Module& fragment,
                                  const BlockProfile& profile, double vertex_invocations_per_draw,
                                  double fragment_invocations_per_draw);

}  // namespace duolod::shader
