// duolod lod: the parts of the joint mesh + shader LOD of Liang et al., "Automatic Mesh and Shader
// Level of Detail" (IEEE TVCG) that do not depend on how candidates are made: the distance levels
// and their error bounds (§3.1, eq. 3/4), the pair search over sorted mesh and shader candidates
// (§5.3, Algorithm 2) and its 2D brute-force counterpart, the smoothest path through the levels'
// pair sets (§6.1, Algorithm 3, eq. 5), merging inefficient levels (§6.2), and the HTML report.
//
// Everything that renders is a callback (an evaluator), so the optimizers drive these functions
// with real renders and the tests drive them with hand-made tables.
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"

namespace duolod::lod {

// ---------------------------------------------------------------------------------------------
// Levels and bounds (§3.1, §3.3, §7).

enum class LevelSpacing {
  kLinear,     // d_i evenly spaced in [d_near, d_far] ("divide the distance into N levels", §3.3)
  kGeometric,  // d_i in geometric progression: equal steps in projected size
};

struct LevelOptions {
  // d_near, d_far, Q and e_max of eq. (4). The defaults (e_max = 0.1, Q = 0.5) are the most common
  // values of the paper's Table 1; tableOneBound() has the per-asset rows.
  metric::BoundConfig bound;
  int level_count = 10;  // N: the paper's default (§7)
  LevelSpacing spacing = LevelSpacing::kLinear;
  render::Display display;
  // Screen width / height: screen coverage is a fraction of the screen's area (as MSFT_lod loaders
  // such as Babylon.js use it).
  float screen_aspect = 16.0f / 9.0f;
};

// One row of Table 1: the bound the paper used for that asset.
struct AssetBoundRow {
  std::string_view asset;
  float e_max = 0;
  float q = 0;
};
std::span<const AssetBoundRow> tableOneBounds();
// The row for `asset` (case-insensitive: "dragon", "imrod", "couch", "rocket", "statue").
std::optional<AssetBoundRow> tableOneBound(std::string_view asset);

struct DistanceLevel {
  int index = 0;
  double distance = 0;   // d_i, in asset units from the bounding-sphere centre
  int footprint_px = 0;  // side of the square image the object covers (render::footprintPixels)
  double per_pixel_bound = 0;  // e_a(d_i), eq. (4)
  // π/4·footprint²: the pixels of the bounding sphere's disc. An estimate of s_d (eq. 3) before any
  // image exists; the optimizers use the reference's measured coverage (metric::ImageError).
  double disc_coverage_px = 0;
  double screen_coverage = 0;  // disc pixels / screen pixels, in [0, 1]
};

// The N levels between d_near and d_far (level 0 at d_near, where e_a = 0: the original). Requires
// 1 <= level_count <= kMaxLevelCount and d_far > d_near (checked: bad options are an Error).
constexpr int kMaxLevelCount = 1000;
core::Result<std::vector<DistanceLevel>> distanceLevels(const core::Sphere& bounds,
                                                        const LevelOptions& options);
// eq. (3): the largest ε_a a pair may have at this level, e_a(d_i)·s_d.
inline double errorBound(const DistanceLevel& level, double coverage_px) {
  return level.per_pixel_bound * coverage_px;
}
// Fraction of the screen area covered by the bounding sphere's disc at `distance`.
double screenCoverage(const core::Sphere& bounds, double distance, const render::Display& display,
                      float screen_aspect);

// ---------------------------------------------------------------------------------------------
// Pair search (§5.3, Algorithm 2). Mesh candidates are indexed 0 (the original M_0) .. K−1 (the
// coarsest); shader candidates by their own index, visited in the order SortByError gives.

struct PairEvaluation {
  double error = 0;  // ε_a of eq. (1)/(6) against the supersampled original at d_i
  double cost = 0;   // t = Cost(f(M, S, d_i)), measured or predicted (any unit, the same for all)
};
// Renders (or predicts) the pair (M_mesh, S_shader) at the level being searched.
using PairEvaluator = std::function<core::Result<PairEvaluation>(int mesh, int shader)>;

struct EvaluatedPair {
  int mesh = 0;
  int shader = 0;       // the shader candidate's own index
  int shader_rank = 0;  // its position in the SortByError order
  double error = 0;
  double cost = 0;
  bool within_bound = false;  // eq. (3)
};

struct PairSearchOptions {
  double error_bound = 0;        // e_a(d_i)·s_{d_i} (errorBound())
  double time_tolerance = 0.05;  // T: keep pairs with (t_n − t_0)/t_0 < T
  // When a pair breaks the bound, find the next feasible finer mesh by bisection instead of one
  // step at a time. Same result when the error grows with the mesh index (the order Algorithm 2
  // already relies on), O(L·log K) evaluations instead of O(K + L): with K = 500 candidates the
  // linear walk renders hundreds of meshes per level.
  bool bisect_meshes = false;
  // Optional, per mesh index: its size (triangles). The bisection then stops once the feasible
  // and infeasible meshes bracketing the boundary differ by at most `bisection_stop` of the
  // feasible one's size, and takes the feasible one: the meshes between cost about the same (a
  // pair's cost follows its mesh's size), so the renders that would find the exact boundary
  // cannot change the choice by more than that fraction, well inside T. K = 500 candidates are
  // often a few triangles apart, where the exact bisection spends half its renders.
  std::span<const double> mesh_sizes = {};
  double bisection_stop = 0;
  // Optional: told about each visited pair as soon as it cannot be in `optimal` (out of the
  // bound, or more than T above the cheapest feasible pair visited so far, which only falls), so
  // that a caller holding the pair's render for later comparisons can let it go.
  std::function<void(int mesh, int shader)> on_discarded = nullptr;
};

struct PairSearchResult {
  std::vector<EvaluatedPair> visited;  // every evaluation in order: the search path of Fig. 2
  std::vector<EvaluatedPair>
      optimal;  // within the bound and within T of the cheapest, cheapest first
  int evaluations = 0;
};

// SortByError (Algorithm 1, line 6): shader indices ordered by increasing error on M_0 at d_i
// (ties keep index order).
std::vector<int> sortByError(std::span<const double> error_on_original_mesh);

// Algorithm 2: from (M_{K−1}, S_0), step to a finer mesh while the pair breaks the bound, else
// record it and step to the next shader. At most K + L evaluations. An evaluator error stops the
// search and is returned.
core::Result<PairSearchResult> searchPairs(int mesh_count, std::span<const int> shader_order,
                                           const PairEvaluator& evaluate,
                                           const PairSearchOptions& options);
// The 2D brute force the paper compares with: all K·L pairs.
core::Result<PairSearchResult> searchPairsBruteForce(int mesh_count,
                                                     std::span<const int> shader_order,
                                                     const PairEvaluator& evaluate,
                                                     const PairSearchOptions& options);

// Pair evaluation by real renders: ε_a of eq. (6) against the supersampled original (M_0, S_0) at
// one level's distance over the view × light domain (§7), and a cost that is either measured (wall
// clock around the render, median of repeats; §7 "Cost") or given by a prediction callback.
// Results are cached per (mesh, shader): Algorithm 2 and the brute force share them.
struct RenderedPairOptions {
  int supersample = 4;  // k of the reference f̄ (eq. 1)
  render::Display display;  // fixes the footprint s_d the images are rendered at
  render::DomainOptions domain;
  // Measured cost: > 0 renders each pair this many extra times and takes the median wall clock in
  // milliseconds. 0: cost comes from `predicted_cost` (required then).
  int timing_repeats = 0;
  std::function<double(int mesh, int shader)> predicted_cost;
};

class RenderedPairEvaluator {
 public:
  // `meshes[k]` are uploaded meshes M_0 (the original) .. M_{K−1}; `shaders[s]` compiled programs,
  // shaders[0] the original S_0. Renders the reference (M_0, S_0) at `distance`.
  static core::Result<RenderedPairEvaluator> create(
      render::Renderer& renderer, std::vector<render::Renderer::AssetId> meshes,
      std::vector<render::Renderer::ProgramId> shaders, const core::Sphere& bounds, double distance,
      RenderedPairOptions options);

  core::Result<PairEvaluation> evaluate(int mesh, int shader);
  // A PairEvaluator calling evaluate() on this object: valid while it stays where it is (a moved
  // evaluator must hand out a new one).
  PairEvaluator evaluator() {
    return [this](int mesh, int shader) { return evaluate(mesh, shader); };
  }
  // s_d of eq. (3): the reference's mean covered pixels per sample.
  double coveragePixels() const { return coverage_px_; }
  int footprintPixels() const { return footprint_px_; }
  int renderedPairs() const { return rendered_pairs_; }  // cache misses

 private:
  RenderedPairEvaluator() = default;
  render::Renderer* renderer_ = nullptr;
  std::vector<render::Renderer::AssetId> meshes_;
  std::vector<render::Renderer::ProgramId> shaders_;
  std::vector<render::Sample> samples_;
  render::ImageBatchF reference_;
  RenderedPairOptions options_;
  double coverage_px_ = 0;
  int footprint_px_ = 0;
  int rendered_pairs_ = 0;
  std::vector<std::optional<PairEvaluation>> cache_;  // [mesh * shader_count + shader]
};

// ---------------------------------------------------------------------------------------------
// Smoothest path (§6.1, Algorithm 3).

// A directed graph with non-negative weights, as adjacency lists.
struct WeightedGraph {
  struct Edge {
    int to = 0;
    double weight = 0;
  };
  std::vector<std::vector<Edge>> out_edges;  // per node
  int addNode() {
    out_edges.emplace_back();
    return static_cast<int>(out_edges.size()) - 1;
  }
  void addEdge(int from, int to, double weight) { out_edges[from].push_back({to, weight}); }
};

struct ShortestPath {
  std::vector<int> nodes;  // source .. target; empty when the target is unreachable
  double length = 0;
};
// Dijkstra (1959) with a binary heap. Edges whose weight is not finite and >= 0 (they are image
// errors) are skipped; a source or target out of range gives an empty path.
ShortestPath dijkstra(const WeightedGraph& graph, int source, int target);

// Transition error ε_t of eq. (5): the pair `from` of level `level` and the pair `to` of level
// level + 1, both rendered at d_{level+1}.
using TransitionEvaluator = std::function<core::Result<double>(int level, const EvaluatedPair& from,
                                                               const EvaluatedPair& to)>;

struct TransitionEdge {
  int level = 0;  // from level → level + 1
  int from = 0;   // index into level_pairs[level]
  int to = 0;     // index into level_pairs[level + 1]
  double error = 0;
};
struct SmoothPath {
  std::vector<int> choice;         // per level, the index of the chosen pair in its set
  std::vector<double> transition;  // per level i < N−1, ε_t(i) along the path
  double total_transition = 0;
  std::vector<TransitionEdge> edges;  // the whole graph G, for the report
  int evaluations = 0;
};
// Algorithm 3: builds G over the pair sets of adjacent levels (every set must be non-empty) and
// returns the path with the minimum total transition error.
core::Result<SmoothPath> smoothestPath(std::span<const std::vector<EvaluatedPair>> level_pairs,
                                       const TransitionEvaluator& transition_error);

// ---------------------------------------------------------------------------------------------
// Merging inefficient levels (§6.2).

// Cost(f(M_l, S_l, d_i)) of level l's chosen pair at distance level i, and of the original pair
// (M_0, S_0) at level i (t_0 in §6.2).
using LevelCostEvaluator = std::function<core::Result<double>(int pair_level, int distance_level)>;
using OriginalCostEvaluator = std::function<core::Result<double>(int distance_level)>;

struct MergeDecision {
  int level = 0;
  int previous = 0;          // the kept level before it, whose pair would cover d_i if dropped
  double previous_cost = 0;  // t_{i−1}: the previous kept pair at d_i
  double cost = 0;           // t_i
  double original_cost = 0;  // t_0
  double gain = 0;           // (t_{i−1} − t_i)/t_0
  bool dropped = false;
};
struct MergeResult {
  std::vector<int> kept_levels;          // always starts with level 0
  std::vector<MergeDecision> decisions;  // one per level >= 1
};
// Drops level i when (t_{i−1} − t_i)/t_0 < W, walking from level 1 outwards; after a drop, the
// previous kept level is compared with the next one.
core::Result<MergeResult> mergeInefficientLevels(int level_count, const LevelCostEvaluator& cost,
                                                 const OriginalCostEvaluator& original_cost,
                                                 double min_gain = 0.04 /* W */);

// ---------------------------------------------------------------------------------------------
// The HTML report (self-contained: inline CSS and SVG, images as PNG data URIs). Plain data, so an
// optimizer fills it as it goes; absent parts are left out.

struct ReportImage {
  std::string caption;
  core::ImageRGBA8 image;
};
struct ReportLevel {
  int index = 0;
  double distance = 0;
  double screen_coverage = 0;
  size_t triangles = 0;
  std::string shader_summary;   // in words, e.g. "Phong per vertex, noise 2 octaves"
  double error = 0;             // ε_a
  double error_bound = 0;       // e_a·s_d
  double transition_error = 0;  // ε_t to the next level
  double predicted_cost = 0;
  double measured_cost = 0;
  std::vector<ReportImage> images;  // e.g. wireframe, level render, reference
};
struct ReportSeries {
  std::string name;  // e.g. "joint", "mesh only"
  std::vector<double> x, y;
};
struct ReportPlot {
  std::string title, x_label, y_label;
  std::vector<ReportSeries> series;
};
struct ReportSearch {
  std::string title;  // e.g. "level 3, d = 4.2"
  int mesh_count = 0, shader_count = 0;
  PairSearchResult result;
};
struct ReportTransitions {
  std::vector<std::vector<EvaluatedPair>> level_pairs;
  SmoothPath path;
};
struct ReportData {
  std::string title;
  std::vector<std::pair<std::string, std::string>> facts;  // asset, display, bound, timings...
  std::vector<ReportLevel> levels;
  std::vector<ReportPlot> plots;
  std::vector<ReportSearch> searches;
  std::optional<ReportTransitions> transitions;
};
std::string renderReportHtml(const ReportData& data);
// Writes renderReportHtml() atomically.
core::Status writeReport(const ReportData& data, const std::string& path);


// ---------------------------------------------------------------------------------------------
// Generating a joint mesh + shader LOD (Algorithm 1 end to end; src/lod/generate.cpp).

enum class Optimizer {
  kSeparate,     // §5: mesh and shader candidates made apart, then searched in 1D (Algorithm 2)
  kInterleaved,  // §4.3: GP generations, each variant paired with a mesh simplified to the bound
};
enum class LodScope {
  kJoint,       // mesh and shader
  kMeshOnly,    // the original shader throughout (Lindstrom & Turk style mesh LOD)
  kShaderOnly,  // the original mesh throughout (He et al. style shader LOD)
};
enum class CostSource {
  kPredicted,  // the cost model (shader/cost_model.hpp): deterministic
  kMeasured,   // wall clock around glFinish, median of repeats, on the active device
};
enum class MeshCandidateMode {
  // §4.2/§5.1: image-driven simplification per level against f̄ of the original, each level's
  // candidates continued past its coarsest mesh by quadric collapses (a quarter of K)
  kImage,
  kQuadric,  // one quadric record shared by all levels (fast; the pair search still renders)
};

struct GenerateProgress {
  std::string_view stage;  // "mesh candidates", "shader candidates", "pair search", ...
  double fraction = 0;     // of this stage, in [0, 1]
  // A finished step worth a line in a log ("level 3: 19994 -> 2310 triangles, ..."); usually empty.
  std::string_view detail;
};

struct GenerateOptions {
  // When levels.bound.d_near / d_far are 0 (the default here), they are placed where the object's
  // footprint is near_footprint_px / far_footprint_px pixels on levels.display.
  LevelOptions levels = [] {
    LevelOptions automatic;
    automatic.bound.d_near = 0;
    automatic.bound.d_far = 0;
    return automatic;
  }();
  int near_footprint_px = 256;
  int far_footprint_px = 16;
  Optimizer optimizer = Optimizer::kSeparate;
  LodScope scope = LodScope::kJoint;
  CostSource cost_source = CostSource::kPredicted;
  MeshCandidateMode mesh_mode = MeshCandidateMode::kImage;
  size_t mesh_candidates = 500;  // K (§5.1)
  // kImage: D of §4.2, the longest edge (screen pixels at the level's distance, in any view) an
  // image-driven collapse may remove. The paper's 1 keeps the near levels' meshes fine (a
  // 96-pixel Spot stops at 5,008 of 5,856 triangles well inside its bound); larger values let
  // them coarsen until the error bound stops them (bench/RESULTS.md, session 51).
  float max_edge_pixels = 1.0f;
  // Shader candidates (§5.2): GP Pareto fronts at this many evenly chosen levels, each on this
  // many of the level's mesh candidates (the paper: 4 levels × top-10 meshes).
  int shader_search_levels = 4;
  int shader_search_meshes = 1;
  int population = 16;
  int generations = 8;
  uint64_t seed = 1;
  int max_shader_candidates = 24;  // the union of the fronts is thinned to this many
  // Offer moving to parameter (He et al. 2015) in the GP searches: a value the shader computes
  // becomes a uniform holding its average over the training domain, measured by an instrumented
  // render at this resolution. Off by default: on the Dragon + noise_phong it made the run 10%
  // slower (averaging renders) and, with the same GP budget, every chosen level 1–9% costlier.
  bool move_to_parameter = false;
  int average_resolution = 64;
  double time_tolerance = 0.05;    // T (Algorithm 2)
  double merge_min_gain = 0.04;    // W (§6.2)
  int supersample = 4;             // k of f̄
  // The searches aim at (1 − bound_margin) × the bound of eq. (3): errors on views and lights
  // outside the training domain run a few percent above the training error (up to 6% measured
  // on the Dragon and Spot), and every level must hold its bound there too.
  double bound_margin = 0.1;
  // The training views (§7's domain): the paper's sphere (kDodecahedron), or kUpright for objects
  // that stand on the ground and are seen from around eye height. The held-out check uses the
  // matching held-out set (render::heldOutViews).
  render::ViewSet views = render::ViewSet::kDodecahedron;
  bool brute_force = false;        // 2D search over all pairs (the paper's comparison column)
  // Algorithm 2's bisection stops when its bracketing meshes differ by at most this fraction of
  // their triangles (PairSearchOptions::bisection_stop); 0 = find the exact boundary.
  double bisection_stop = 0.01;
  // Interleaved optimizer (§4.3): the top N% of each generation seed the next; generation depth.
  double interleaved_top_fraction = 0.2;
  int interleaved_generations = 3;
  int device = -1;  // EGL device; -1 = Mesa surfaceless
  // The shader's interface locations and bindings (render::Bindings; the CLI's --bindings), for
  // every context the run makes.
  render::Bindings bindings = {};
  // Compile the shader searches' coming variants in worker threads, one per core, each with its
  // own GL context (the search's CPU work and llvmpipe's compiles otherwise keep one core busy
  // and the other idle). The results are the same either way.
  bool compile_ahead = true;
  // Render SortByError's pairs (every shader candidate on the original mesh, per level) ahead on
  // a second thread with its own GL context while the pair search walks (llvmpipe shades
  // vertices and bins triangles on the drawing thread, which leaves a core idle otherwise). The
  // results are the same either way.
  bool sort_prefetch = true;
  std::function<void(const GenerateProgress&)> progress;
};

struct GeneratedLevel {
  DistanceLevel level;
  double switch_distance = 0;  // where the runtime starts using this level
  core::Mesh mesh;
  render::SpirvBinary readable;   // unoptimised SPIR-V (for cross-compilation and reading)
  render::SpirvBinary optimized;  // what was rendered and timed
  std::vector<render::UniformValue> parameters;  // values the CPU sets (moving to parameter)
  std::vector<std::string> parameter_names;      // one per parameter
  std::string shader_summary;
  int mesh_candidate = 0, shader_candidate = 0;
  double error = 0, error_bound = 0;  // ε_a (eq. 6) and e_a(d_i)·s_d (eq. 3)
  double transition_error = 0;        // ε_t to the next kept level (eq. 5), 0 for the last
  bool original_fallback = false;     // no pair was within the bound: the original is kept
  double predicted_cost = 0;          // seconds per draw, the cost model
  double measured_cost = 0;           // seconds per draw (wall clock), 0 when not measured
  double original_measured_cost = 0;  // the original pair, measured in the same call
};

struct HeldOutCheck {
  int level = 0;           // index into GenerateResult::levels (dropped levels: -1)
  int distance_level = 0;  // index into GenerateResult::all_levels
  double error = 0, bound = 0;
  bool within = false;
  bool original_fallback = false;
  // Dropped levels: the held-out error, at this level's distance, of the finer level before it,
  // which covers its distances instead (-1 otherwise).
  double covering_error = -1;
};

struct GenerateTimings {
  // Wall clock of each stage. The separate optimizer's GP searches (§5.2) run alongside the mesh
  // stage as its levels complete: shader_seconds is only what they add after it, and
  // shader_search_seconds their own wall clock (summed over configurations).
  // setup_seconds: the GL context, the shader's compile and the levels' supersampled references
  // of f̄ (eq. 1), before the mesh stage.
  double setup_seconds = 0, mesh_seconds = 0, shader_seconds = 0, optimization_seconds = 0,
         export_seconds = 0, total_seconds = 0;
  double shader_search_seconds = 0;
};

struct GenerateResult {
  std::vector<GeneratedLevel> levels;  // the kept levels, finest first
  std::vector<DistanceLevel> all_levels;
  // The bound the levels were made with: options.levels.bound with d_near and d_far placed (by
  // the footprints when they were 0).
  metric::BoundConfig bound;
  std::vector<HeldOutCheck> held_out;  // every kept level on held-out views and lights
  // Levels the optimizer kept but that broke their bound on the held-out views and lights: they
  // are left out of the chain (the finer level before each covers its distances).
  std::vector<HeldOutCheck> dropped;
  GenerateTimings timings;
  int pair_evaluations = 0, transition_evaluations = 0, shader_candidates = 0;
  // Renders made for the transition errors alone (pairs not rendered at that distance before, or
  // whose render was dropped), and the most bytes of pair renders held at once for them (only
  // those of the levels' pair sets are kept once a level's search ends).
  int transition_renders = 0;
  size_t kept_render_bytes_peak = 0;
  std::vector<int> mesh_candidates;  // per level
  std::string device, cost_source;
  ReportData report;
};

// Runs the whole pipeline on `asset` with `shader` (the original S_0). Errors: the shader does not
// compile, the GPU context fails, bad options.
core::Result<GenerateResult> generateLod(const core::Asset& asset, const render::GlslSource& shader,
                                         const GenerateOptions& options);

// Writes the output folder: lod.gltf (MSFT_lod chain), per level the shaders (SPIR-V, GLSL 450,
// GLSL ES 300, HLSL), the single autoLOD shader, lod.json and report.html. `directory` must not
// exist or be empty unless `force`; it must not be the asset's folder. All or nothing
// (io::OutputFolder): a failure leaves the folder as it was, with `force` too.
core::Status writeLodOutput(const GenerateResult& result, const core::Asset& asset,
                            const GenerateOptions& options, const std::string& directory,
                            bool force);

}  // namespace duolod::lod
