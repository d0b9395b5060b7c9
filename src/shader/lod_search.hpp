// Shader LOD for one (mesh, distance) configuration, end to end (Liang et al. §5.2; issue 4 items
// 6-8): compile the GLSL, search rule applications (GP with NSGA-II, or He et al.'s greedy) on the
// predicted cost (our cost model, shader/cost_model.hpp) and the predicted error
// (shader/evaluate.hpp), re-evaluate the resulting variants with the rendered error over the
// whole domain and with measured llvmpipe time, and combine them into Olano's single LOD shader
// (shader/autolod.hpp). The CLI's `duolod shader` and bench/shader_search.cpp are thin layers over
// this.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"
#include "shader/autolod.hpp"
#include "shader/evaluate.hpp"
#include "shader/search.hpp"

namespace duolod::shader {

enum class SearchMethod { kGenetic, kGreedy };

struct ShaderLodOptions {
  float distance = 0;  // camera distance from the bounding-sphere centre, mesh units (> 0)
  render::Display display;
  SearchMethod method = SearchMethod::kGenetic;
  GeneticSearchOptions genetic;
  GreedySearchOptions greedy;
  EvaluationConfig evaluation;  // its distance/display are overwritten by the two above
  // Wall-clock timing of the final variants (draws over the whole domain at the footprint).
  bool measure_time = true;
  render::TimingOptions timing;
  int device = -1;  // EGL device; -1 = Mesa surfaceless
  render::Bindings bindings = {};  // the shader's interface (the CLI's --bindings)
  // Offer "moving to parameter" (He et al. 2015) to the search: each application averages the
  // value by an instrumented render of the predicted-error samples (shader/value_average.hpp) at
  // this resolution. Moving the colour output to a parameter is the front's nearly-constant end.
  bool move_to_parameter = true;
  int average_resolution = 64;
  // Compile the GP's coming variants in worker threads with their own contexts (scoring.hpp);
  // the results are the same either way.
  bool compile_ahead = true;
};

struct ShaderLodVariant {
  SearchVariant search;
  double measured_seconds = 0;  // draw time over the domain (0 when not measured)
  double time_ratio = 0;        // measured_seconds / the original's (0 when not measured)
};

struct ShaderLodReport {
  // The levels: the original (no site) first, then the search's variants by decreasing
  // predicted cost, each predicted cheaper than the original (a front variant that costs as much
  // or more, kept by the search for its lower error, is no level of detail: dropped, counted).
  std::vector<ShaderLodVariant> variants;
  int dropped_costlier = 0;
  // The LOD shader over `variants` in that order, thresholds 0, 1, 2, ...: autoLOD = k selects
  // variants[k].
  AutoLodShader autolod;
  SearchCounters search;
  EvaluationCache::Counters compile;
  VariantEvaluator::Counters evaluation;
  int cost_profiles = 0;  // instrumented renders of the cost model
  int average_renders = 0;  // instrumented renders averaging values (moving to parameter)
  int compiled_ahead = 0;  // cost profiles compiled first by the workers (ShaderLodOptions::compile_ahead)
  int footprint_px = 0;
  int domain_samples = 0;
  std::string device;
  render::Bindings bindings;  // ShaderLodOptions::bindings: the HLSL files' vertex input semantics
  double search_seconds = 0, rerender_seconds = 0, timing_seconds = 0, total_seconds = 0;
};

core::Result<ShaderLodReport> runShaderLod(const core::Asset& asset, const render::GlslSource& source,
                                           const ShaderLodOptions& options);

// Writes into `directory` (created; must not exist or be empty unless `force`): per variant
// levelNN.{vert,frag}.spv, .glsl (450), .es.glsl (ES 300), .hlsl; autolod.{vert,frag}.* likewise;
// summary.json (variants with rules in words, costs, errors, time ratios, counters). All or
// nothing (io::OutputFolder): a failure leaves the folder as it was, with `force` too.
core::Status writeShaderLod(const ShaderLodReport& report, const std::string& directory, bool force);
// The stem of variant `level`'s files: "level00", "level01", ...
std::string levelFileName(size_t level);

}  // namespace duolod::shader
