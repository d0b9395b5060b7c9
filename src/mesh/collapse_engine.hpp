// The edge-collapse engine shared by every collapse cost (quadric now, image-driven later): the
// greedy loop of Hoppe 1996 / Garland & Heckbert 1997 with the topology and attribute rules, and a
// narrow CostModel interface that only prices candidates and places the survivor.
//
// Vocabulary. A *position* is a point of the surface; a *wedge* is a mesh vertex (Hoppe 1998,
// "Efficient implementation of progressive meshes"): several wedges share a position where an
// attribute is discontinuous (UV seams, hard normals, colour borders). Collapses act on positions;
// every wedge of the removed position merges into the wedge of the survivor on the same side of
// the seam, so discontinuities survive.
//
// Rules (checked by the engine, never by the model):
//   - the link condition (Dey, Edelsbrunner et al. 1999, "Topology preserving edge contraction"):
//     the two endpoints' common neighbours are exactly the edge's opposite vertices, plus the
//     tetrahedron case (no duplicate triangle may appear) and, with the border closed by a
//     virtual vertex, its edge part (a triangle whose three edges are border edges, all that is
//     left of an edge-connected component, does not collapse: the component stays); its vertex
//     part (no interior edge between two border vertices) holds by the feature-line rules below;
//   - feature lines: border edges (one triangle), attribute seams (the two triangles use different
//     wedges at an endpoint) and material borders (different submeshes, unless allowed). A
//     position on no feature line is *free*; one on exactly two feature edges of the same kind is
//     *constrained* and only slides along them; anything else (line ends, junctions, corners
//     where the line turns by more than 60°, non-manifold edges or fans, more than kMaxWedges
//     wedges, non-finite positions) is *locked*;
//   - no triangle normal may turn by 90° or more, or collapse to zero area;
//   - the survivor may move away from its own position only when it is free, or constrained on
//     the same line, and every one of its wedges takes part in the merge; otherwise the model is
//     told `endpoint_only`.
// Lazy invalidation: each position has a stamp bumped when its quadric/neighbourhood changes; a
// heap entry remembers both endpoints' stamps and is skipped when either changed.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "duolod/mesh.hpp"
#include "mesh/attributes.hpp"

namespace duolod::mesh {

struct Vec3d {
  double x = 0, y = 0, z = 0;
};
inline Vec3d operator+(Vec3d a, Vec3d b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3d operator-(Vec3d a, Vec3d b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3d operator*(Vec3d a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(Vec3d a, Vec3d b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d cross(Vec3d a, Vec3d b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// A bounding box's extent per axis: the float difference, as the frames have always used (so
// outputs stay bit for bit), except where it overflows near the end of float's range (a box from
// -3e38 to 3e38 is 6e38 wide), then the exact difference in double. With the overflow the frame's
// scale fell back to 1, every price in float was infinite, and the cluster grid was one cell.
inline Vec3d boxSize(const core::Bounds& box) {
  auto extent = [](float lo, float hi) {
    const float size = hi - lo;
    return std::isfinite(size) ? double(size) : double(hi) - double(lo);
  };
  return {extent(box.min.x, box.max.x), extent(box.min.y, box.max.y),
          extent(box.min.z, box.max.z)};
}

// A survivor's position in asset units as floats. An optimal placement may lie outside the
// input's bounding box [lo, hi]; near the end of float's range it may lie beyond what a float
// holds, and its ±inf would be an output no reader accepts. Such a point is clamped into the
// box, coordinate by coordinate, and the function says so (the caller then moves the normalized
// position with it). A point that fits is left as it is: real meshes never get here. (Found by
// fuzzing: meshes scaled to ~3e38.)
inline bool clampIfBeyondFloat(Vec3d& asset, Vec3d lo, Vec3d hi) {
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  if (std::abs(asset.x) <= kFloatMax && std::abs(asset.y) <= kFloatMax &&
      std::abs(asset.z) <= kFloatMax)
    return false;
  asset = {std::clamp(asset.x, lo.x, hi.x), std::clamp(asset.y, lo.y, hi.y),
           std::clamp(asset.z, lo.z, hi.z)};
  return true;
}

enum class VertexKind : uint8_t { kFree, kConstrained, kLocked };

// Feature bits of an edge.
enum : uint8_t {
  kFeatureBorder = 1,
  kFeatureSeam = 2,
  kFeatureMaterial = 4,
  kFeatureNonManifold = 8,  // 3+ triangles, or two triangles with the same orientation
};

// Positions with more wedges than this are locked (they are junctions of several seams anyway).
inline constexpr int kMaxWedges = 4;

// A feature edge of the input, for models that add boundary constraints (penalty planes).
struct FeatureEdge {
  uint32_t a = 0, b = 0;                  // positions
  uint32_t triangles[2] = {kAbsent, kAbsent};  // the edge's triangles (second absent on borders)
  uint8_t features = 0;
};

// What the engine knows, read-only for models. Positions are normalized so that the bounding box
// of the input has diagonal 1 (normalized = (asset - origin) / scale): everything the engine and
// the quadric model compare is then independent of the asset's units.
struct EngineState {
  Vec3d origin;      // the bounding box's minimum
  double scale = 1;  // asset units per normalized unit (the bounding-box diagonal)
  Vec3d box_max;     // the bounding box's maximum

  // Positions.
  std::vector<Vec3d> positions;                 // current, normalized
  std::vector<core::Vec3> asset_positions;      // current, asset units (exact when unmoved)
  std::vector<VertexKind> kinds;
  std::vector<uint8_t> line_features;           // feature bits of a constrained position's line
  std::vector<uint8_t> position_alive;
  std::vector<uint32_t> first_wedge;            // one wedge of the position (ring start)
  std::vector<uint32_t> first_corner;           // head of the position's corner list

  // Wedges (the mesh's vertices).
  std::vector<uint32_t> wedge_position;
  std::vector<uint32_t> wedge_next;             // ring of the wedges sharing a position
  AttributeLayout layout;
  std::vector<float> attributes;                // current, layout.stride floats per wedge

  // Triangles: corner c = 3 * triangle + k holds a wedge.
  std::vector<uint32_t> corners;
  std::vector<uint32_t> corner_next;            // next corner of the same position, or kAbsent
  std::vector<uint32_t> groups;                 // submesh index per triangle
  std::vector<uint8_t> triangle_alive;
  size_t live_triangles = 0;

  std::vector<FeatureEdge> feature_edges;       // of the input, found at start

  uint32_t cornerPosition(uint32_t corner) const { return wedge_position[corners[corner]]; }
  const float* wedgeAttributes(uint32_t wedge) const {
    return attributes.data() + size_t(wedge) * layout.stride;
  }
  // Calls f(corner) for each live triangle corner at position p.
  template <class F>
  void forEachCorner(uint32_t p, F&& f) const {
    for (uint32_t c = first_corner[p]; c != kAbsent; c = corner_next[c])
      if (triangle_alive[c / 3]) f(c);
  }
  // Calls f(wedge) for each wedge of position p.
  template <class F>
  void forEachWedge(uint32_t p, F&& f) const {
    uint32_t first = first_wedge[p];
    if (first == kAbsent) return;
    uint32_t w = first;
    do {
      f(w);
      w = wedge_next[w];
    } while (w != first);
  }
};

// One direction of an edge collapse: position `from` disappears into `to`.
struct CandidateCollapse {
  uint32_t from = 0, to = 0;
  // from_wedges[i] merges into to_wedges[i] (every wedge of `from`; targets may repeat where a
  // seam ends at `to`).
  uint8_t wedge_count = 0;
  std::array<uint32_t, kMaxWedges> from_wedges{};
  std::array<uint32_t, kMaxWedges> to_wedges{};
  // Set by the engine: the survivor must stay at positions[to] (Placement::kEndpoint, or `to` is
  // locked / on another feature line / has wedges outside the merge).
  bool endpoint_only = true;
  // Filled by the model.
  double cost = 0;   // ordering key, smaller collapses first
  double error = 0;  // reported error, in SimplifyOptions::target_error units
  Vec3d position;    // survivor position (normalized); positions[to] when endpoint_only
  // False when `cost` is only an estimate: a model with refineBatchSize() > 0 is asked to refine()
  // such candidates before one of them is applied.
  bool exact = true;
};

struct AppliedCollapse {
  CandidateCollapse candidate;  // as applied (position final)
  size_t removed_triangles = 0;
};

// Prices collapses. The engine calls evaluate() with every candidate invalidated by the last
// collapse in one batch (and the initial fill in large batches), so an expensive model can batch
// its work (one draw/readback per batch for the image-driven cost).
class CostModel {
 public:
  virtual ~CostModel() = default;
  // Once, after the engine has built its state and before the first evaluate().
  virtual void begin(const EngineState& state) { (void)state; }
  // Fills cost, error and position of every candidate (both directions of an edge come as two
  // candidates when both are legal).
  virtual void evaluate(const EngineState& state, std::span<CandidateCollapse> batch) = 0;
  // Attribute values of the survivor's wedges, before the collapse is applied: `values` holds
  // layout.stride floats per merge i (for chosen.to_wedges[i]), prefilled with that wedge's
  // current values (the endpoint's attributes). Keep them for endpoint placement.
  virtual void placeAttributes(const EngineState& state, const CandidateCollapse& chosen,
                               std::span<float> values) {
    (void)state, (void)chosen, (void)values;
  }
  // Lazy pricing for costly models (the image-driven cost): when the cheapest queued candidate is
  // an estimate, the engine takes up to refineBatchSize() estimates from the top of its queue,
  // asks refine() for their exact cost and error, and queues them again. 0 = never.
  virtual size_t refineBatchSize() const { return 0; }
  virtual void refine(const EngineState& state, std::span<CandidateCollapse> batch) {
    (void)state, (void)batch;
  }
  // Pass ordering only (EngineOptions::ordering): called for a candidate about to be applied,
  // before the flip test. A model that priced its candidates cheaply (e.g. the best of a few
  // fixed points) may move the survivor somewhere better here and lower cost and error to match;
  // it must not raise them. If the new position would flip a triangle the engine goes back to the
  // priced one.
  virtual void refinePlacement(const EngineState& state, CandidateCollapse& chosen) {
    (void)state, (void)chosen;
  }
  // Which ordering the next evaluate() calls serve: true while the engine runs passes (a model
  // may then price cheaply and place in refinePlacement), false for the greedy queue (price and
  // place exactly: the queue never calls refinePlacement).
  virtual void setPassPricing(bool passes) { (void)passes; }
  // Once, when the engine stops (state final).
  virtual void end(const EngineState& state) { (void)state; }
  // Just before the collapse is applied (state still the old one).
  virtual void beforeCollapse(const EngineState& state, const CandidateCollapse& chosen) {
    (void)state, (void)chosen;
  }
  // After the collapse is applied (state already updated), for incremental model data.
  virtual void onCollapse(const EngineState& state, const AppliedCollapse& applied) {
    (void)state, (void)applied;
  }
};

// How the engine orders collapses.
//   kGreedy: a strict greedy queue (Garland & Heckbert 1997): always the cheapest edge next, and
//     every collapse re-prices the edges it invalidated. Needed for lazily priced models
//     (refineBatchSize() > 0) and for costs of a wider ring (invalidation_ring 2).
//   kPasses: passes over all edges (as in meshoptimizer's simplifier): price every live edge
//     once, sort by cost, apply the cheapest edges in order while skipping any edge that shares
//     an endpoint with a collapse already applied in this pass (its price is stale), up to the
//     pass's cost limit (pass_cost_slack times the cost of the edge at the pass's goal rank, the
//     number of collapses still needed); then the next pass re-prices what is left. No queue
//     maintenance and no re-pricing per collapse, so several times fewer instructions. The last
//     greedy_tail_triangles go through the greedy queue.
enum class CollapseOrdering : uint8_t { kGreedy, kPasses };

struct EngineOptions {
  size_t target_triangles = 0;                                     // 0 = none
  double target_error = std::numeric_limits<double>::infinity();  // skip collapses above it
  bool endpoint_only = false;                                      // Placement::kEndpoint
  bool lock_border = false;
  bool allow_material_border_collapse = false;
  bool record = true;
  // Which edges a collapse invalidates: 1 = the survivor's edges (costs that depend on the two
  // endpoints only, like quadrics); 2 = also the edges of the survivor's neighbours (costs that
  // look at the surrounding surface, like rendered images).
  int invalidation_ring = 1;
  size_t batch_size = 4096;  // candidates per evaluate() call during the initial fill
  // Candidates rejected by the link/flip tests are not retried until their neighbourhood changes;
  // when the queue runs dry short of the target, the engine refills it from all edges, at most
  // this many times.
  int max_passes = 4;
  CollapseOrdering ordering = CollapseOrdering::kGreedy;
  // kPasses: a pass applies edges up to this multiple of the cost at its goal rank.
  double pass_cost_slack = 1.5;
  // kPasses: the last collapses, from this many triangles above the target (at most 1/16 of the
  // input) down to it, use the greedy queue: the coarsest levels, where each collapse moves the
  // surface most, are ordered exactly (this is where the passes' looser order cost Hausdorff
  // distance), and the queue over a mesh that small is cheap. See greedyTailTriangles.
  size_t greedy_tail_triangles = 2000;
  // kPasses: a pass that applied fewer than this share of the candidates it priced ends the
  // passes, and the greedy queue does the rest (0: never). For models whose pass pricing costs
  // what the queue's does (the quadric model with attributes prices every candidate at its
  // optimal placement): a pass re-prices every edge, the queue only around its collapses. On the
  // flat regions of CAD models the last passes apply a few collapses each (fandisk with normals
  // at 50%: 42, 82 and 8 of ~10k priced), and each cost as much as the queue's whole run there.
  double min_pass_yield = 0;
  // Optional: called with the live triangle count after each pass, each batch of refined prices
  // and each applied collapse of the greedy queue (the image-driven mode's order, where
  // collapses wait on renders), so that a caller can show progress.
  std::function<void(size_t)> progress = nullptr;
  // Optional: set to the wedge (vertex of the mesh given to runCollapseEngine) of each output
  // vertex and the triangle of each output triangle, for a caller that ran the engine on a
  // reordered copy of its mesh and puts the output back in its own order (simplify_quadric.cpp's
  // spatial order).
  std::vector<uint32_t>* output_wedges = nullptr;
  std::vector<uint32_t>* output_triangles = nullptr;
};

// kPasses: how many triangles above `target` the passes stop, for the greedy queue to do the
// rest: greedy_tail_triangles, at most 1/16 of the `input` triangles, and none when the target is
// more than kGreedyTailReach times that. The tail is for the coarse end: where the result is not
// much larger than the tail, ordering its last collapses exactly is what keeps the Hausdorff
// distance down (armadillo at 1%: 1.27x meshopt's without it, 0.68x with it); for a finer target
// the tail is a thin slice of the result, its order changed the error little (bench/simplify at
// 50%, 25% and 15%, median over 5 input orders: every Hausdorff ratio to meshopt stayed below
// 0.95) and it took 5-21% of the time at 50% (bench/RESULTS.md, issue 3, session 13).
constexpr size_t kGreedyTailReach = 4;
// The greedy tail's size at a coarse target: greedy_tail_triangles, at most 1/16 of the `input`
// triangles.
inline size_t greedyTailCapacity(const EngineOptions& options, size_t input) {
  return std::min(options.greedy_tail_triangles, input / 16);
}
inline size_t greedyTailTriangles(const EngineOptions& options, size_t input) {
  const size_t tail = greedyTailCapacity(options, input);
  return options.target_triangles <= kGreedyTailReach * tail ? tail : 0;
}

// kPasses: how a pass ends.
//   - Finishing: when the pass's cheap part (edges up to pass_cost_slack times the goal-rank
//     cost) leaves at most 1/kPassFinishingShare of the goal undone, the rest's edges whose
//     endpoints the pass left untouched (their prices are still exact) finish it, cheapest first,
//     instead of a pass that would re-price every edge for a few collapses. Measured on
//     bench/simplify: one pass fewer at 50% (bunny 7% less time), the other cells unchanged bit for
//     bit; Hausdorff still below meshopt's in every cell (bench/RESULTS.md, issue 3, session 14).
//   - Stalling: a pass that applied at most 1/kPassStallShare of its goal (the cheap edges left
//     are ones the link and flip tests refuse, as on the flat regions of CAD models) ends the
//     passes when at most `tail_capacity` (greedyTailCapacity) triangles remain above the pass
//     target: the greedy queue takes the rest, re-pricing around each collapse instead of every
//     edge per pass (fandisk: its last 2-4 passes, of 1-70 collapses each; 50% 5% less time).
//     Not more: a queue collapse costs about four pass collapses, and with 2000 triangles on any
//     mesh CGAL's anchor_dense (7.6k triangles) at 10% handed 2400 triangles to the queue, 1.78x
//     meshopt's time; capped at 1/16 of the input, 1.28x, Hausdorff no worse (bench/RESULTS.md,
//     issue 3, session 17).
//   - Nearing the tail: a pass that leaves at most 1/kPassTailShare of the greedy tail above the
//     pass target ends the passes; another pass would re-price every edge for a few collapses
//     that the queue makes in cost order anyway (fandisk at 10%: its last two passes applied 57
//     and 3 collapses; 3% less time, Hausdorff unchanged or lower; bench/RESULTS.md, issue 3,
//     session 15).
constexpr size_t kPassFinishingShare = 7, kPassStallShare = 4, kPassTailShare = 4;
// kPasses: a thin cheap part. When the edges up to pass_cost_slack times the goal-rank cost are
// fewer than 5/4 of the goal (the costs climb steeply past the goal rank), the pass takes its
// kThinPassRank times goal cheapest edges instead (and all edges of the same cost as the last of
// them). A pass applies only about a third of its cheap part (a collapse locks its endpoints'
// other edges), so a thin one falls far short of its goal and another pass re-prices every edge:
// fandisk at 50% took 8 passes. Measured on bench/simplify: fandisk's three cells 5-9% less time,
// CGAL's anchor_dense and fandisk_large 9-12%; Hausdorff over 5 orders no worse on the benchmark
// (fandisk 1% 0.64 -> 0.62, its worst order 1.67 -> 0.80), on 24 other meshes 12 cells worse than
// meshopt instead of 13; cells whose cheap part is never thin are unchanged bit for bit
// (bench/RESULTS.md, issue 3, session 17).
constexpr size_t kThinPassRank = 2;
inline bool passCheapPartThin(size_t cheap, size_t goal) {
  return cheap * 4 < goal * 5;
}
inline bool passFinishes(size_t left, size_t goal) {
  return left > 0 && left * kPassFinishingShare <= goal;
}
inline bool passNearsTail(size_t above_target, size_t tail) {
  return above_target > 0 && above_target * kPassTailShare <= tail;
}
inline bool passStalls(size_t applied, size_t goal, size_t above_target, size_t tail_capacity) {
  return applied * kPassStallShare <= goal && above_target > 0 && above_target <= tail_capacity;
}

// kPasses: a coarse pass, one that starts with more than kCoarsePassFactor times the triangles the
// passes stop at (`pass_target`: the target plus the greedy tail), places each survivor where its
// collapse was priced (an endpoint or the midpoint) instead of solving for the optimal placement
// (CostModel::refinePlacement). Its collapses are the cheapest of the run, far below the error the
// last passes and the tail make, so the final error is settled later. Measured on bench/simplify
// (paired A/B, median over 5 input orders for the error, 31 meshes at 50/10/1%): factor 6 made
// the run 1.8% faster (1% cells 3.5-5%, 10% cells 0-3%; 50% cells never coarse) with Hausdorff
// no worse than meshopt's in any benchmark cell and worse in 11 of the 105 cells instead of 12;
// factor 4 gained 2.9% but moved the 10% cells' Hausdorff up by ~20% (armadillo 0.77 -> 0.95);
// factor 2, armadillo 10% 1.44. Pricing at the endpoints only as well (no midpoint) put
// ChineseDragon-10kv at 10% at 1.30 (bench/RESULTS.md, issue 3, session 18).
constexpr size_t kCoarsePassFactor = 6;
inline bool passIsCoarse(size_t live_triangles, size_t pass_target) {
  return pass_target > 0 && live_triangles > kCoarsePassFactor * pass_target;
}

// A feature line turning by more than 60° at a vertex makes it a corner (locked): the corner of a
// border, a UV chart or a material region is a feature point, so it is locked rather than left to
// the balance of penalty and face planes. `before` and `after` are p's two neighbours on the line.
inline bool isLineCorner(Vec3d before, Vec3d p, Vec3d after) {
  constexpr double kCornerTurnCos = 0.5;
  const Vec3d in = p - before, out = after - p;
  const double lengths = std::sqrt(dot(in, in) * dot(out, out));
  return !(lengths > 0) || dot(in, out) < kCornerTurnCos * lengths;
}

// Whether moving a triangle's corner from `corner` to `moved` (the other two corners `b`, `d`
// fixed) turns the triangle by 90° or more or flattens it to zero area (relative to its size). A
// triangle that is already degenerate has no orientation to lose and passes.
inline bool turnsOverOrFlattens(Vec3d corner, Vec3d b, Vec3d d, Vec3d moved) {
  const Vec3d n_old = cross(b - corner, d - corner);
  const Vec3d to_b = b - moved, to_d = d - moved;
  const Vec3d n_new = cross(to_b, to_d);
  const double old_sq = dot(n_old, n_old), new_sq = dot(n_new, n_new);
  if (old_sq <= 0) return false;
  const double edge_scale = std::max(dot(to_b, to_b), dot(to_d, to_d));
  if (new_sq <= 1e-24 * edge_scale * edge_scale || !(new_sq > 0)) return true;
  return dot(n_old, n_new) <= 0;
}

// Bit pattern of a position with -0 folded into +0: equal patterns are what prepareMesh welds.
void positionBits(core::Vec3 p, uint32_t out[3]);
// Position ids: equal positionBits share an id, numbered in order of first appearance. Returns the
// id count.
uint32_t positionIds(const std::vector<core::Vec3>& positions, std::vector<uint32_t>& ids);
// Whether the submeshes tile the index buffer in order (otherwise prepareMesh makes them one).
bool submeshesTile(const core::Mesh& mesh);

// Welds wedges (equal position and attributes), drops unreferenced vertices, triangles with an
// out-of-range index, repeated position or duplicate position triple (same orientation). Vertex
// and triangle order are kept, so a clean mesh comes back unchanged. Submeshes that do not tile
// the index buffer (or none) become one submesh over everything.
core::Mesh prepareMesh(const core::Mesh& mesh);

// prepareMesh's result with what it found on the way: the position id of every vertex (equal
// positions, ±0 folded, share an id; ids 0..position_count-1 in order of first use), so that the
// engine does not hash the positions a second time.
struct PreparedMesh {
  core::Mesh mesh;
  std::vector<uint32_t> position_ids;
  uint32_t position_count = 0;
};
PreparedMesh prepareMeshWithPositions(const core::Mesh& mesh);

// Simplifies a mesh that prepareMesh has already cleaned (the record's base is a copy of it).
SimplifyResult runCollapseEngine(const core::Mesh& prepared, CostModel& model,
                                 const EngineOptions& options);
SimplifyResult runCollapseEngine(const PreparedMesh& prepared, CostModel& model,
                                 const EngineOptions& options);

}  // namespace duolod::mesh
