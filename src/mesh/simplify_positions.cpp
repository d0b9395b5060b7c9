// Position-only fast path of simplifyQuadric. The algorithm is the collapse engine's pass ordering
// (collapse_engine.hpp, kPasses; Garland & Heckbert 1997 quadrics, the link condition of Dey,
// Edelsbrunner et al. 1999, the flip test, borders sliding along themselves), the data layout is
// built for it instead of for the general engine (attributes, seams, materials, lazy costs):
//   - vertices are positions (prepareWorkingMesh welds and cleans the input as prepareMesh would,
//     in one go with the spatial sort), so there are no wedges; on large meshes they and the
//     triangles are renumbered in a spatial order, and only the record and the output see the
//     prepared mesh's ids;
//   - the index buffer is compacted at the start of every pass, and adjacency is rebuilt from it
//     as a flat vertex -> corner table (a counting sort, no lists, no unlinking);
//   - within a pass every vertex takes part in at most one collapse, so a collapse `from` -> `to`
//     is a one-level remap (remap[from] = to) read when triangles are walked, and the triangles on
//     the edge are flagged dead; a collapse's endpoints were untouched in this pass, so their
//     corner tables are exact (up to the remap and the dead flags);
//   - vertex kinds (free, on a border line, locked) are found once: collapses keep them, and a
//     border vertex keeps its two border neighbours, updated when the border collapses; a free
//     vertex whose planes spread as around a spike has its angle sum checked, and a spike tip is
//     pinned by a point quadric (quadric.hpp, as the engine's QuadricModel::pinSpikeTips does);
//   - candidates are read off the triangles (free endpoints) and the border neighbours, priced at
//     the best of the endpoints and the midpoint from each endpoint's quadric expanded around its
//     own position, in float with SSE (PricingRecord), and the optimal placement is solved (in
//     double) only for the collapses applied (as CostModel::refinePlacement does), and not in
//     the coarse passes far above the target (passIsCoarse, collapse_engine.hpp);
//   - on large meshes (in spatial order) both cores work: a pass's pricing in parts, and its
//     collapses in two halves of the vertex ids, each half's collapses away from the cut on one
//     core, then those near the cut (applyHalves; second_core.hpp). The result is the same on one
//     core or two; against one run in cost order, the collapses near the cut come after the
//     others, and in a pass that may reach the target each half stops at its share;
//   - at the coarse end (greedyTailTriangles), the last collapses (at most 2000 triangles, 1/16 of
//     the input) use a greedy queue, cheapest first and priced at the optimal placement as the
//     engine's kGreedy; unlike the engine's, an entry whose endpoint changed is priced again only
//     when it comes up, as the survivors' edge (runGreedy). The corner table then grows by
//     chaining: a vertex's triangles are its own corners and those of the vertices it absorbed,
//     and the remap becomes a union-find.
// Everything the engine checks is checked here too (tests/mesh_simplify_test.cpp runs both paths:
// its meshes with attributes, materials or endpoint placement take the engine).
// Speed (bench/RESULTS.md, issue 3): 0.72-1.35x meshoptimizer 0.18's wall clock on 2 cores
// (paired timing, bench/simplify_ab.sh, session 45: meshes in spatial order 0.72-0.99x on both
// cores, the smaller ones 1.14-1.35x at 10% and 1% on one), 1.1-1.6x its instructions
// (bench/simplify_callgrind.sh, one core). The
// wall clock is the measure: the pass pricing and the pass order are written without
// data-dependent branches (masks, selects, radix passes) and the apply loop prefetches the
// candidates ahead; each executes more instructions than the branchy code it replaced, and runs
// faster. Bunny 10% by phase (session 16): set-up 25% (preparation, quadrics, classification,
// pricing records), pass pricing 16%, compaction, corner tables and order 12%, applying collapses
// 39% (the fan walks wait on memory), greedy tail 8%. Tried and not kept: re-using prices between
// passes (only 16% of the edges keep both endpoints untouched), a branch-free edge list before
// the pricing, corners that carry their triangle's other vertices (3x the table: slower on bunny;
// as 8-byte fan entries without dead flags: same speed), a greedy tail of 1000 triangles (-2%,
// Hausdorff mixed), no optimal placement in the passes (-4%, Hausdorff and mean clearly worse),
// meshopt's coarse cost order (-4%, Hausdorff worse than meshopt in 1-2 cells), no greedy tail
// at any target (-10%, armadillo 1% Hausdorff 1.27x meshopt's: it now runs at the coarse end
// only), choosing in cost order but applying in vertex order (+5%: failed collapses then hold
// their locks, passes yield less), fine passes instead of the greedy tail (Hausdorff above
// meshopt's at armadillo 10% and 1%) and a greedy tail queued by the fixed-point prices and
// solved when popped (no faster: its fan walks and queue cost, not its solves; the lazy
// re-pricing of runGreedy saves the fan walks). Set-up alone (a run to 100%) is 0.96-1.23x
// meshopt's; the passes at 50% are faster than meshopt's.
// The rest of the gap is work meshopt 0.18 does not do (it prices by one quadric at the other
// endpoint, has no link condition, tests one fan, places at endpoints, has no greedy tail):
// without the greedy tail, the optimal placement, the midpoint and the link condition this code
// runs at 0.68-0.97x meshopt's time (geomean 0.83), and its error is then worse than meshopt's in
// 14 of the 21 position-only cells; the link condition costs 7.8%, the midpoint 5.9%, the greedy
// tail 5.1%, the optimal placement 1.7% (bench/guarantees-experiment.patch; bench/RESULTS.md,
// issue 3, session 19).
#include "mesh/simplify_positions.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <utility>

#include "mesh/spatial_order.hpp"
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "mesh/attributes.hpp"
#include "mesh/quadric.hpp"
#include "mesh/quaternary_heap.hpp"
#include "mesh/radix_order.hpp"
#include "mesh/second_core.hpp"

namespace duolod::mesh {
namespace {

constexpr uint32_t kNext[3] = {1, 2, 0};
constexpr uint32_t kPrevious[3] = {2, 0, 1};

// The greedy tail's queue entries: cheapest first, ties by `from`, then `to`, in a 4-ary heap
// (quaternary_heap.hpp) over one 64-bit key (the cost's order key, then `from`) and then `to`
// and `id`: no float compares, half the levels of std::push_heap/pop_heap's binary heap (its
// sifts and pops were 3-4% of our time at 10% on ChineseDragon-10kv, by perf). (One 128-bit
// compare instead of the key's, branch-free: 2-8% slower, the key's branch is predictable.)
// Entries that differ only in `id` are the same edge priced at different times, of which at most
// one is current, or priced twice in the same state (two stale entries that came up as the same
// edge: runGreedy), so their order does not change what is applied. `id` numbers the pricings
// (TailPricing): an entry is current while neither endpoint has changed since it was priced
// (PositionSimplifier::changed_at_), and then its placement is still the optimal one.
struct QueuedCandidate {
  uint64_t key;  // orderKey(cost) << 32 | from
  uint64_t to_id;  // to << 32 | id
  uint32_t from() const { return uint32_t(key); }
  uint32_t to() const { return uint32_t(to_id >> 32); }
  uint32_t id() const { return uint32_t(to_id); }
  float cost() const {
    const uint32_t bits = uint32_t(key >> 32);
    float cost;
    std::memcpy(&cost, &bits, 4);
    return cost;
  }
  struct Before {
    bool operator()(const QueuedCandidate& a, const QueuedCandidate& b) const {
      return a.key != b.key ? a.key < b.key : a.to_id < b.to_id;
    }
  };
};
// What the greedy tail found when it priced a candidate: where the survivor goes (so that
// applying it needs no second solve) and whether that is the `to` end.
struct TailPricing {
  Vec3d placement;
  bool endpoint_only;
};
using TailQueue = QuaternaryHeap<QueuedCandidate, QueuedCandidate::Before>;

// A pass candidate: `from` collapses into `to`; the survivor goes to the fixed point `at`
// (quadric.hpp) unless the optimal placement is better when it is applied.
struct PassCandidate {
  uint32_t from, to;
  float cost;
  uint8_t at;
  bool endpoint_only;
};

uint32_t costBits(double cost) {
  float f = std::isfinite(cost) ? float(cost) : std::numeric_limits<float>::max();
  if (!(f >= 0)) f = f < 0 ? 0.0f : std::numeric_limits<float>::max();
  uint32_t bits;
  std::memcpy(&bits, &f, 4);
  return bits;
}

// What pass pricing reads of a vertex, in one 64-byte line of floats: its position relative to
// the bounding-box centre (|p| <= 1/2, so float keeps ~3e-8 of the diagonal), its quadric's value
// e = Q(p) and half gradient g = A p + b there (computed in double, so the expansion is exact up to
// the final rounding), and A as its diagonal and doubled off-diagonal. Around p,
// Q(p + d) = e + 2 g·d + dᵀAd: the merged quadric of an edge is evaluated at its fixed points from
// the two endpoints' expansions (no merged copy). Floats, four to an SSE register: the pass order
// is by float cost anyway (the keys are float bits), and the optimal placement of an applied
// collapse is still solved in double.
struct alignas(16) PricingRecord {
  float position[4];   // x, y, z, e
  float gradient[4];   // gx, gy, gz, 0
  float diagonal[4];   // a00, a11, a22, 0
  float off_twice[4];  // 2 a01, 2 a02, 2 a12, 0
};

PricingRecord pricingRecord(const Quadric& q, Vec3d p, Vec3d centre) {
  const double gx = q.a00 * p.x + q.a01 * p.y + q.a02 * p.z + q.b0;
  const double gy = q.a01 * p.x + q.a11 * p.y + q.a12 * p.z + q.b1;
  const double gz = q.a02 * p.x + q.a12 * p.y + q.a22 * p.z + q.b2;
  return {{float(p.x - centre.x), float(p.y - centre.y), float(p.z - centre.z),
           float(evaluateQuadric(q, p))},
          {float(gx), float(gy), float(gz), 0},
          {float(q.a00), float(q.a11), float(q.a22), 0},
          {float(2 * q.a01), float(2 * q.a02), float(2 * q.a12), 0}};
}

// The price of the edge a -> b at its cheapest fixed point (quadric.hpp's priceAtFixedPoints in
// float): the merged quadric at b, at a and at the midpoint, from the two records
// (d = a - b): Qa(b) = ea - 2 ga·d + dᵀAa d, Qb(a) = eb + 2 gb·d + dᵀAb d, Q(b) = Qa(b) + eb,
// Q(a) = ea + Qb(a), Q(mid) = (Q(a) + Q(b)) / 2 - dᵀ(Aa + Ab)d / 4; an endpoint-only edge is
// priced at b. Ties go to b, then a. Each dot product sums its x, y, z terms as (x + y) + z, with
// SSE and without.
struct PricedEdge {
  float cost;
  uint8_t at;  // kFixedAtB, kFixedAtA or kFixedAtMid
};
inline PricedEdge priceEdge(const PricingRecord& a, const PricingRecord& b, bool endpoint_only) {
#if defined(__SSE2__)
  // Lane 3 holds ea - eb, which must not reach the products: squared it underflows to a
  // denormal when the quadrics' values are tiny (flat regions), and denormal arithmetic costs
  // ~100 cycles per operation (fandisk: 15% of the whole run). Zeroed, every lane-3 term is 0.
  const __m128 xyz = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
  const __m128 d = _mm_and_ps(_mm_sub_ps(_mm_load_ps(a.position), _mm_load_ps(b.position)), xyz);
  const __m128 squares = _mm_mul_ps(d, d);  // xx, yy, zz
  const __m128 crosses = _mm_mul_ps(_mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 1, 0, 0)),
                                    _mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 2, 2, 1)));  // xy, xz, yz
  __m128 fa = _mm_add_ps(_mm_mul_ps(_mm_load_ps(a.diagonal), squares),
                         _mm_mul_ps(_mm_load_ps(a.off_twice), crosses));
  __m128 fb = _mm_add_ps(_mm_mul_ps(_mm_load_ps(b.diagonal), squares),
                         _mm_mul_ps(_mm_load_ps(b.off_twice), crosses));
  __m128 sa = _mm_mul_ps(_mm_load_ps(a.gradient), d);
  __m128 sb = _mm_mul_ps(_mm_load_ps(b.gradient), d);
  _MM_TRANSPOSE4_PS(fa, fb, sa, sb);  // rows: the x, y, z, w terms of the four dot products
  const __m128 sums = _mm_add_ps(_mm_add_ps(fa, fb), sa);  // form_a, form_b, slope_a, slope_b
  // The rest in scalar SSE with masks instead of branches: which fixed point is cheapest is a
  // coin flip to the branch predictor (the branches cost ~20% of the pass pricing). The
  // operations are those of the plain C++ below, in the same order (max_ss(0, x) is
  // std::max(x, 0.0f), NaN and -0 included).
  const __m128 form_a = sums;
  const __m128 form_b = _mm_shuffle_ps(sums, sums, _MM_SHUFFLE(1, 1, 1, 1));
  const __m128 slope_a = _mm_shuffle_ps(sums, sums, _MM_SHUFFLE(2, 2, 2, 2));
  const __m128 slope_b = _mm_shuffle_ps(sums, sums, _MM_SHUFFLE(3, 3, 3, 3));
  const __m128 zero = _mm_setzero_ps(), two = _mm_set_ss(2.0f);
  const __m128 both = _mm_add_ss(_mm_load_ss(&a.position[3]), _mm_load_ss(&b.position[3]));
  const __m128 at_b =
      _mm_max_ss(zero, _mm_add_ss(_mm_sub_ss(both, _mm_mul_ss(two, slope_a)), form_a));
  const __m128 at_a =
      _mm_max_ss(zero, _mm_add_ss(_mm_add_ss(both, _mm_mul_ss(two, slope_b)), form_b));
  const __m128 at_mid = _mm_sub_ss(_mm_mul_ss(_mm_set_ss(0.5f), _mm_add_ss(at_a, at_b)),
                                   _mm_mul_ss(_mm_set_ss(0.25f), _mm_add_ss(form_a, form_b)));
  const __m128 free_placement = _mm_castsi128_ps(_mm_set1_epi32(endpoint_only ? 0 : -1));
  const __m128 take_a = _mm_and_ps(_mm_cmplt_ss(at_a, at_b), free_placement);
  const __m128 cost_ab = _mm_or_ps(_mm_and_ps(take_a, at_a), _mm_andnot_ps(take_a, at_b));
  const __m128 take_mid = _mm_and_ps(_mm_cmplt_ss(at_mid, cost_ab), free_placement);
  const __m128 cost = _mm_or_ps(_mm_and_ps(take_mid, _mm_max_ss(zero, at_mid)),
                                _mm_andnot_ps(take_mid, cost_ab));
  const int a_bit = _mm_movemask_ps(take_a) & 1, mid_bit = _mm_movemask_ps(take_mid) & 1;
  return {_mm_cvtss_f32(cost), uint8_t(mid_bit << 1 | (a_bit & ~mid_bit))};
#else
  const float d[3] = {a.position[0] - b.position[0], a.position[1] - b.position[1],
                      a.position[2] - b.position[2]};
  const float squares[3] = {d[0] * d[0], d[1] * d[1], d[2] * d[2]};
  const float crosses[3] = {d[0] * d[1], d[0] * d[2], d[1] * d[2]};
  auto form = [&](const PricingRecord& r) {
    float t[3];
    for (int i = 0; i < 3; ++i) t[i] = r.diagonal[i] * squares[i] + r.off_twice[i] * crosses[i];
    return (t[0] + t[1]) + t[2];
  };
  auto slope = [&](const PricingRecord& r) {
    return (r.gradient[0] * d[0] + r.gradient[1] * d[1]) + r.gradient[2] * d[2];
  };
  const float form_a = form(a), form_b = form(b), slope_a = slope(a), slope_b = slope(b);
  const float both = a.position[3] + b.position[3];
  const float at_b = std::max(both - 2 * slope_a + form_a, 0.0f);
  const float at_a = std::max(both + 2 * slope_b + form_b, 0.0f);
  const float at_mid = 0.5f * (at_a + at_b) - 0.25f * (form_a + form_b);
  PricedEdge priced{at_b, kFixedAtB};
  if (!endpoint_only) {
    if (at_a < priced.cost) priced = {at_a, kFixedAtA};
    if (at_mid < priced.cost) priced = {std::max(at_mid, 0.0f), kFixedAtMid};
  }
  return priced;
#endif
}

// Below this many vertices every per-vertex array of the simplifier (~230 bytes a vertex in all)
// nearly fits in a core's L2 (1 MiB here), and sorting costs more than it saves (measured, every
// mesh sorted: fandisk and WaterBottle 9-50% slower, Avocado and spot within 6%).
constexpr uint32_t kSpatialOrderMinimum = 8192;
// Meshes in spatial order (so that the two halves of the ids are two regions, and the cores
// write to different cache lines) use both cores: a pass's pricing in at most
// kTwoCorePricingParts parts of at least 1024 triangles (while it has kTwoCorePricingMinimum
// triangles or more), and its collapses in two halves (applyHalves, kHalvesMargin in runPasses).
// Halves split by a plane instead (ids of both sides on every cache line) were slower than one
// core. Smaller meshes gained nothing measurable: sorted into spatial order, WaterBottle and
// fandisk (positions) lost more than the second core gave; in their input order (which keeps the
// halves apart: 2-3% of their triangles cross) they ran as fast as on one core (bench/RESULTS.md,
// issue 3, session 45).
constexpr size_t kTwoCorePricingMinimum = 4096;
constexpr uint32_t kTwoCorePricingParts = 16;
constexpr double kHalvesMargin = 1.5;

// What a fan walk reads of each neighbour, in half a cache line: its survivor (the remap), the
// walk's mark, and (for the flip test) its position. Three arrays cost the apply loop three
// cache misses per neighbour on meshes whose vertex ids are in no spatial order (bunny00).
struct alignas(32) VertexState {
  Vec3d position;  // normalized (bounding-box diagonal 1)
  uint32_t remap;  // survivor of a vertex collapsed in this pass (itself if none)
  uint32_t mark;   // the last round (nextRound) that marked it
};

// What one run of collapses uses besides the mesh: scratch for the two fans and the edge, the
// rounds of vertex marks, and (for a half of a pass applied beside the other, applyHalves) the
// tallies and record steps it adds, merged afterwards.
struct Collapser {
  // The other two corners of each moving triangle of a collapse's endpoints (room for every
  // triangle, so they are filled without capacity checks).
  uint32_t *from_fan = nullptr, *to_fan = nullptr;
  uint32_t edge_triangles[2] = {kAbsent, kAbsent};
  uint32_t edge_triangle_count = 0;
  uint32_t round = 0;  // the last round (nextRound) it used
  // A half's tallies: triangles removed, the largest error, the counts, the steps (triangles_after
  // counted from the pass's start, kept_value into `values`; cumulative_error set when merged).
  size_t removed = 0;
  double max_error = 0;
  SimplifyStats stats;
  std::vector<CollapseStep> steps;
  std::vector<core::Vec3> values;
};

class PositionSimplifier {
 public:
  PositionSimplifier(const core::Mesh& input, const SimplifyOptions& options)
      : input_(input), options_(options) {}
  SimplifyResult run();

 private:
  void setUp();
  void prepareWorkingMesh();
  uint32_t material() const { return input_.submeshes.empty() ? 0 : input_.submeshes[0].material; }
  void buildAdjacency();
  void clearAbsorbed();
  void classify();
  void pinIfSpikeTip(uint32_t v);
  void compact();
  void pushCandidate(uint32_t from, uint32_t to, bool endpoint_only);
  void emitEdge(uint32_t a, uint32_t b);
  void collectCandidates();
  void allocatePassArrays();
  void runPasses(size_t pass_target, size_t tail, size_t tail_capacity);
  void runGreedy();
  // kGreedy: in the greedy tail (survivors are chains, triangles come from absorbed vertices
  // too, placement is the optimal one); a template so that the passes pay for none of it.
  // `placement`: the greedy tail's optimal placement, found when the candidate was priced.
  // kHalf: one of the two halves of a pass applied side by side (applyHalves): the tallies and
  // record steps go to the collapser, not to the simplifier's.
  template <bool kGreedy, bool kHalf = false>
  bool tryCollapse(const PassCandidate& candidate, uint32_t pass, Collapser& collapser,
                   Vec3d placement = {});
  template <bool kHalf>
  void applyCollapse(uint32_t from, uint32_t to, Vec3d position, double cost, uint32_t pass,
                     Collapser& collapser);
  template <bool kHalf>
  size_t applyInOrder(const PassCandidate* begin, const PassCandidate* end, uint32_t pass,
                      Collapser& collapser, size_t limit, const PassCandidate** stopped = nullptr);
  size_t applyHalves(const PassCandidate* order, size_t count, PassCandidate* scratch,
                     uint32_t pass, size_t pass_target);
  bool fanFlips(const uint32_t* fan, uint32_t size, Vec3d corner, Vec3d moved) const;
  template <class Emit>
  void forEachTriangleEdge(size_t begin, size_t end, Emit&& emit);
  template <class Emit>
  void forEachBorderEdge(Emit&& emit);
  template <class Emit>
  void forEachCandidateEdge(Emit&& emit);
  SimplifyResult finish();
  // The surviving vertex of v: one level within a pass, a chain (with path halving) in the greedy
  // tail.
  uint32_t resolve(uint32_t v) {
    VertexState* s = vertices_.data();
    if (!greedy_) return s[v].remap;
    while (s[v].remap != v) v = s[v].remap = s[s[v].remap].remap;
    return v;
  }
  // Calls f(triangle, corner k of v in it) for each live triangle of v: its own corners and those
  // of the vertices it absorbed (greedy tail; within a pass nothing is absorbed).
  template <class F>
  void forEachTriangle(uint32_t v, F&& f) {
    for (uint32_t u = v; u != kAbsent; u = absorbed_next_[u])
      for (uint32_t i = corner_start_[u]; i < corner_start_[u + 1]; ++i) {
        const uint32_t c = corners_[i], t = c >> 2;
        if (!dead_[t]) f(t, c & 3);
      }
  }
  uint32_t nextRound() { return nextRound(collapsers_[0]); }
  // (A half's collapser never wraps: applyHalves leaves room for every round it may use.)
  uint32_t nextRound(Collapser& collapser) {
    if (++collapser.round == 0) {
      for (VertexState& s : vertices_) s.mark = 0;
      collapser.round = 1;
    }
    return collapser.round;
  }
  // Errors in asset units: the root mean squared distance of the merged quadric.
  double errorOf(double cost, double weight) const {
    return std::sqrt(std::max(cost, 0.0) / (weight > 0 ? weight : 1.0)) * scale_;
  }

  const core::Mesh& input_;
  SimplifyOptions options_;
  uint32_t vertex_count_ = 0;
  Vec3d origin_;  // the used vertices' bounding box: its minimum, diagonal and maximum
  double scale_ = 1;
  Vec3d box_max_;

  // The working order of the vertices and triangles (prepareWorkingMesh): input_id_[v] is the
  // prepared mesh's id of working vertex v. Only the progressive record and the output order
  // see input ids.
  std::vector<uint32_t> input_id_;
  // The input triangle of each triangle of indices_, kept through compaction; empty when the
  // triangles keep their input order.
  std::vector<uint32_t> triangle_input_id_;
  uint32_t prepared_triangle_count_ = 0;
  std::vector<VertexState> vertices_;
  std::vector<core::Vec3> asset_positions_;  // asset units, exact while unmoved
  std::vector<Quadric> quadrics_;
  // quadrics_ around the positions, for the passes (every record is written before it is read:
  // no value-initialization of megabytes)
  PricingRecord* pricing_ = nullptr;
  Vec3d centre_;                        // of the bounding box, in the normalized frame
  std::vector<VertexKind> kinds_;
  std::vector<uint32_t> border_neighbors_;  // two per constrained vertex
  std::vector<uint32_t> constrained_;       // the constrained vertices
  std::vector<uint8_t> alive_;
  std::vector<uint32_t> pass_lock_;  // the pass that last touched a vertex

  std::vector<uint32_t> indices_;  // live triangles, compacted at the start of a pass
  std::vector<uint8_t> dead_;      // per triangle of indices_: collapsed in this pass
  size_t live_triangles_ = 0;
  std::vector<uint32_t> corner_start_;  // per vertex, into corners_ (vertex_count_ + 1)
  // Corners (triangle << 2 | k, so that no division is needed to split them) grouped by vertex.
  std::vector<uint32_t> corners_;
  std::vector<uint32_t> cursor_;
  // Greedy tail: the vertices absorbed into a vertex, as a chain through absorbed_next_.
  bool greedy_ = false;
  bool coarse_pass_ = false;  // passIsCoarse: the survivor stays where it was priced
  std::vector<uint32_t> absorbed_next_, absorbed_last_;
  // Greedy tail: the pricings so far (QueuedCandidate::id), and per vertex how many there were
  // when its quadric or position last changed (entries priced before that are stale).
  std::vector<TailPricing> tail_pricing_;
  std::vector<uint32_t> changed_at_;
  TailQueue queue_;
  bool filling_ = false;  // appending to queue_ before one heapify

  // [0] applies every collapse but the second half's of a pass applied in halves ([1]).
  Collapser collapsers_[2];
  // A pass's collapses in two halves, the vertex ids below and above the middle (applyHalves), and
  // per vertex the last pass in which one of its triangles had vertices in both.
  bool in_halves_ = false;
  std::vector<uint32_t> near_other_half_;
  // Pass candidates, their order keys (orderKey of the cost), the cheap and the rest part of a
  // pass, and the radix order's scratch (radix_order.hpp): room for every candidate of the
  // first pass (allocatePassArrays).
  PassCandidate *pass_candidates_ = nullptr, *pass_cheap_ = nullptr, *pass_rest_ = nullptr;
  uint32_t* pass_keys_ = nullptr;  // orderKey of each pass candidate
  uint32_t* pass_key_scratch_ = nullptr;
  uint32_t* histograms_ = nullptr;  // 3 * kDigits
  // These arrays, pricing_ and the fans, in one block (allocatePassArrays).
  std::unique_ptr<std::byte[]> pass_memory_;
  size_t pass_candidate_count_ = 0;

  SimplifyStats stats_;
  // Held from the set-up on when the mesh is in spatial order (in_halves_); empty otherwise.
  std::optional<SecondCore> second_core_;
  double max_error_ = 0;
  ProgressiveRecord record_;
  // A pass's cheap part holds at least the edges up to this cost (kFreeCollapseError).
  float free_cost_ = 0;
};

void PositionSimplifier::setUp() {
  prepareWorkingMesh();
  live_triangles_ = indices_.size() / 3;
  alive_.assign(vertex_count_, 1);
  pass_lock_.assign(vertex_count_, 0);
  cursor_.resize(vertex_count_);

  // Plane quadrics (Garland & Heckbert 1997 eq. 2), weighted by planeWeight (quadric.hpp).
  quadrics_.assign(vertex_count_, Quadric{});
  size_t t = 0;
#if defined(__SSE2__)
  // Two triangles at a time, one per lane: triangleQuadric's operations in the same order (so the
  // same bits), with its three square roots and its division shared by the pair (they were the
  // loop's critical path). Each lane's plane is then added to its corners' quadrics, the first
  // triangle's before the second's, as in the scalar loop. The pairs are built in registers, not
  // loaded from a plane in memory: a 16-byte load of two 8-byte stores is not forwarded from the
  // store buffer and waits for them to retire (set-up 4-5% slower).
  static_assert(sizeof(Quadric) == 11 * sizeof(double), "Quadric is 11 packed doubles");
  const VertexState* vertices = vertices_.data();
  const __m128d zero = _mm_setzero_pd(), half = _mm_set1_pd(0.5), one = _mm_set1_pd(1.0),
                sign = _mm_set1_pd(-0.0);
  const __m128d infinity = _mm_set1_pd(std::numeric_limits<double>::infinity());
  auto add_plane = [&](const uint32_t* v, __m128d p0, __m128d p1, __m128d p2, __m128d p3,
                       __m128d p4, double weight) {
    for (int k = 0; k < 3; ++k) {
      double* q = &quadrics_[v[k]].a00;
      _mm_storeu_pd(q, _mm_add_pd(_mm_loadu_pd(q), p0));
      _mm_storeu_pd(q + 2, _mm_add_pd(_mm_loadu_pd(q + 2), p1));
      _mm_storeu_pd(q + 4, _mm_add_pd(_mm_loadu_pd(q + 4), p2));
      _mm_storeu_pd(q + 6, _mm_add_pd(_mm_loadu_pd(q + 6), p3));
      _mm_storeu_pd(q + 8, _mm_add_pd(_mm_loadu_pd(q + 8), p4));
      q[10] += weight;
    }
  };
  for (; t + 2 <= live_triangles_; t += 2) {
    const uint32_t* v = &indices_[t * 3];
    const Vec3d &a0 = vertices[v[0]].position, &b0 = vertices[v[1]].position,
                &c0 = vertices[v[2]].position, &a1 = vertices[v[3]].position,
                &b1 = vertices[v[4]].position, &c1 = vertices[v[5]].position;
    const __m128d ax = _mm_set_pd(a1.x, a0.x), ay = _mm_set_pd(a1.y, a0.y),
                  az = _mm_set_pd(a1.z, a0.z);
    const __m128d ex = _mm_sub_pd(_mm_set_pd(b1.x, b0.x), ax),
                  ey = _mm_sub_pd(_mm_set_pd(b1.y, b0.y), ay),
                  ez = _mm_sub_pd(_mm_set_pd(b1.z, b0.z), az);
    const __m128d fx = _mm_sub_pd(_mm_set_pd(c1.x, c0.x), ax),
                  fy = _mm_sub_pd(_mm_set_pd(c1.y, c0.y), ay),
                  fz = _mm_sub_pd(_mm_set_pd(c1.z, c0.z), az);
    // cross(e, f), dot as (x + y) + z, as collapse_engine.hpp's cross and dot.
    const __m128d cx = _mm_sub_pd(_mm_mul_pd(ey, fz), _mm_mul_pd(ez, fy));
    const __m128d cy = _mm_sub_pd(_mm_mul_pd(ez, fx), _mm_mul_pd(ex, fz));
    const __m128d cz = _mm_sub_pd(_mm_mul_pd(ex, fy), _mm_mul_pd(ey, fx));
    const __m128d double_area = _mm_sqrt_pd(_mm_add_pd(
        _mm_add_pd(_mm_mul_pd(cx, cx), _mm_mul_pd(cy, cy)), _mm_mul_pd(cz, cz)));
    // triangleQuadric's test: 0 < double_area < infinity (NaN fails).
    const int proper = _mm_movemask_pd(_mm_and_pd(_mm_cmpgt_pd(double_area, zero),
                                                  _mm_cmplt_pd(double_area, infinity)));
    if (proper == 0) continue;
    // planeWeight(area) of a position-only mesh, sqrt(sqrt(area)) (quadric.hpp: change both).
    const __m128d w = _mm_sqrt_pd(_mm_sqrt_pd(_mm_mul_pd(half, double_area)));
    const __m128d inverse = _mm_div_pd(one, double_area);
    const __m128d nx = _mm_mul_pd(cx, inverse), ny = _mm_mul_pd(cy, inverse),
                  nz = _mm_mul_pd(cz, inverse);
    const __m128d d = _mm_xor_pd(sign, _mm_add_pd(_mm_add_pd(_mm_mul_pd(nx, ax),
                                                             _mm_mul_pd(ny, ay)),
                                                  _mm_mul_pd(nz, az)));  // -dot(n, a)
    // planeQuadric(n, d, w, w), lane by lane the same products.
    const __m128d wx = _mm_mul_pd(w, nx), wy = _mm_mul_pd(w, ny), wz = _mm_mul_pd(w, nz),
                  wd = _mm_mul_pd(w, d);
    const __m128d a00 = _mm_mul_pd(wx, nx), a01 = _mm_mul_pd(wx, ny), a02 = _mm_mul_pd(wx, nz),
                  a11 = _mm_mul_pd(wy, ny), a12 = _mm_mul_pd(wy, nz), a22 = _mm_mul_pd(wz, nz),
                  q0 = _mm_mul_pd(wd, nx), q1 = _mm_mul_pd(wd, ny), q2 = _mm_mul_pd(wd, nz),
                  qc = _mm_mul_pd(wd, d);
    if (proper & 1)
      add_plane(v, _mm_unpacklo_pd(a00, a01), _mm_unpacklo_pd(a02, a11),
                _mm_unpacklo_pd(a12, a22), _mm_unpacklo_pd(q0, q1), _mm_unpacklo_pd(q2, qc),
                _mm_cvtsd_f64(w));
    if (proper & 2)
      add_plane(v + 3, _mm_unpackhi_pd(a00, a01), _mm_unpackhi_pd(a02, a11),
                _mm_unpackhi_pd(a12, a22), _mm_unpackhi_pd(q0, q1), _mm_unpackhi_pd(q2, qc),
                _mm_cvtsd_f64(_mm_unpackhi_pd(w, w)));
  }
#endif
  for (; t < live_triangles_; ++t) {  // the last, odd triangle (all of them without SSE2)
    const uint32_t* v = &indices_[t * 3];
    Quadric plane;
    if (!triangleQuadric(vertices_[v[0]].position, vertices_[v[1]].position,
                         vertices_[v[2]].position, plane))
      continue;
    for (int k = 0; k < 3; ++k) addQuadric(quadrics_[v[k]], plane);
  }
}

// The engine's frame of a bounding box: origin at its minimum, diagonal 1.
void frameOf(const core::Bounds& bounds, Vec3d& origin, double& scale) {
  if (bounds.empty()) return;
  origin = {bounds.min.x, bounds.min.y, bounds.min.z};
  const Vec3d size = boxSize(bounds);
  const double diagonal = std::sqrt(dot(size, size));
  scale = diagonal > 0 && std::isfinite(diagonal) ? diagonal : 1.0;
}

bool samePosition(core::Vec3 a, core::Vec3 b) {  // finite: bitwise equal with ±0 folded
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

// The working mesh, straight from the input: what prepareMeshWithPositions and then a spatial
// sort did in two steps (a hash table, a copy of the mesh and more sweeps), in one. The result is
// the same, id for id:
//   - welding: equal positions (bitwise, ±0 folded) are one vertex, represented by the first of
//     them in input order. Equal positions have equal codes (Morton codes on large meshes, a
//     position hash on small ones), so after a stable sort by code they are neighbours;
//   - cleaning: triangles out of range or with two corners on one vertex are dropped, and of
//     duplicate triangles (the same three vertices in the same turning sense) the first is kept;
//     vertices no kept triangle uses are dropped. The kept ones, in input order, are the prepared
//     mesh (its ids are what the progressive record and the output order see: input_id_);
//   - order: on large meshes the vertices in Morton order of their position and the triangles by
//     their lowest working vertex; small meshes keep the input order. Every phase walks a
//     vertex's neighbours (pricing reads two 64-byte records per edge, a collapse walks two
//     fans); on a mesh whose ids are in no spatial order (CGAL's bunny00: the median triangle
//     spans 15k ids) each of those reads misses the cache, in this order most of them hit lines
//     that a nearby vertex brought in (bench/RESULTS.md, issue 3, session 10).
// Both sorts are stable counting sorts, so the order is a function of the input alone.
void PositionSimplifier::prepareWorkingMesh() {
  const core::Mesh& m = input_;
  const uint32_t n = uint32_t(m.vertexCount());
  const size_t triangles = m.indices.size() / 3;

  // Weld: equal positions get equal codes, so after a stable sort by code they are neighbours.
  // Large meshes sort by Morton code over the box of all vertices (that order is the working
  // order too, below); small ones by a 16-bit hash of the position, two byte-digit passes
  // instead of three 10-bit ones (the Morton sort cost small meshes more than the hash table it
  // replaced).
  const bool morton_weld = n >= kSpatialOrderMinimum;
  core::Bounds all;
  MortonFrame frame;
  std::vector<uint32_t> code(n), sorted(n);
  if (morton_weld) {
    for (core::Vec3 p : m.positions) all.extend(p);
    double all_scale = 1;
    frameOf(all, frame.origin, all_scale);
    frame.inverse_scale = 1.0 / all_scale;
    for (uint32_t v = 0; v < n; ++v) code[v] = frame.code(m.positions[v]), sorted[v] = v;
    sortByCode(sorted, code, 10, 3);
  } else {
    for (uint32_t v = 0; v < n; ++v) {
      uint32_t bits[3];
      positionBits(m.positions[v], bits);
      const uint64_t h = (uint64_t(bits[0]) << 32 | bits[1]) * 0x9e3779b97f4a7c15ull ^
                         uint64_t(bits[2]) * 0xc2b2ae3d27d4eb4full;
      code[v] = uint32_t(h >> 48);
      sorted[v] = v;
    }
    sortByCode(sorted, code, 8, 2);
  }
  std::vector<uint32_t> representative(n);
  for (uint32_t begin = 0, end = 0; begin < n; begin = end) {
    for (end = begin + 1; end < n && code[sorted[end]] == code[sorted[begin]]; ++end) {
    }
    if (end - begin <= 16) {  // a cell holds a few vertices: compare each with those before it
      for (uint32_t i = begin; i < end; ++i) {
        const uint32_t v = sorted[i];
        representative[v] = v;
        for (uint32_t j = begin; j < i; ++j)
          if (samePosition(m.positions[sorted[j]], m.positions[v])) {
            representative[v] = representative[sorted[j]];
            break;
          }
      }
    } else {  // a crowded cell (a far outlier squeezes the box): by position, then index
      std::vector<uint32_t> cell(sorted.begin() + begin, sorted.begin() + end);
      std::sort(cell.begin(), cell.end(), [&](uint32_t a, uint32_t b) {
        const core::Vec3 p = m.positions[a], q = m.positions[b];
        if (p.x != q.x) return p.x < q.x;
        if (p.y != q.y) return p.y < q.y;
        if (p.z != q.z) return p.z < q.z;
        return a < b;
      });
      for (size_t i = 0; i < cell.size(); ++i)
        representative[cell[i]] = i > 0 && samePosition(m.positions[cell[i - 1]],
                                                         m.positions[cell[i]])
                                      ? representative[cell[i - 1]]
                                      : cell[i];
    }
  }

  // Proper triangles (in range, three distinct vertices) and the vertices they use.
  std::vector<uint32_t> corners(triangles * 3);
  std::vector<uint8_t> proper(triangles, 0), used(n, 0);
  // In named values, not an array: the array went through memory, and copying two of its
  // 4-byte entries into `corners` as one 8-byte load is not store-forwarded (it waited for the
  // stores to retire: ~10% of the set-up on WaterBottle).
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t i0 = m.indices[t * 3], i1 = m.indices[t * 3 + 1], i2 = m.indices[t * 3 + 2];
    if (!(i0 < n && i1 < n && i2 < n)) continue;
    const uint32_t r0 = representative[i0], r1 = representative[i1], r2 = representative[i2];
    if (r0 == r1 || r1 == r2 || r0 == r2) continue;
    proper[t] = 1;
    corners[t * 3] = r0, corners[t * 3 + 1] = r1, corners[t * 3 + 2] = r2;
    used[r0] = used[r1] = used[r2] = 1;
  }
  // The prepared ids (the used vertices in input order) and the frame of their box.
  std::vector<uint32_t> prepared_id(n, kAbsent);
  core::Bounds bounds;
  uint32_t count = 0;
  for (uint32_t v = 0; v < n; ++v)
    if (used[v]) prepared_id[v] = count++, bounds.extend(m.positions[v]);
  vertex_count_ = count;
  frameOf(bounds, origin_, scale_);
  const double inverse_scale = 1.0 / scale_;
  if (!bounds.empty()) {
    box_max_ = {bounds.max.x, bounds.max.y, bounds.max.z};
    centre_ = boxSize(bounds) * (0.5 * inverse_scale);
  }

  // Working ids: Morton order in the used vertices' frame on large meshes (the weld's order when
  // the two boxes agree, as they do when every vertex is used), else the prepared order.
  const bool spatial = count >= kSpatialOrderMinimum;
  in_halves_ = spatial;
  std::vector<uint32_t> working_id(n, kAbsent);
  input_id_.resize(count);
  std::vector<uint32_t> source(count);  // input vertex of each working vertex
  if (spatial) {
    if (std::memcmp(&bounds, &all, sizeof bounds) != 0) {
      frame = {origin_, inverse_scale};
      for (uint32_t v = 0; v < n; ++v)
        if (used[v]) code[v] = frame.code(m.positions[v]);
      sorted.clear();
      for (uint32_t v = 0; v < n; ++v)
        if (used[v]) sorted.push_back(v);
      sortByCode(sorted, code, 10, 3);
    }
    uint32_t w = 0;
    for (uint32_t v : sorted)
      if (used[v]) working_id[v] = w, source[w] = v, input_id_[w] = prepared_id[v], ++w;
  } else {
    for (uint32_t v = 0; v < n; ++v)
      if (used[v]) working_id[v] = prepared_id[v], source[prepared_id[v]] = v;
    for (uint32_t w = 0; w < count; ++w) input_id_[w] = w;
  }
  asset_positions_.resize(count);
  vertices_.resize(count);
  for (uint32_t w = 0; w < count; ++w) {
    const core::Vec3 a = m.positions[source[w]];
    asset_positions_[w] = a;
    vertices_[w] = {{(a.x - origin_.x) * inverse_scale, (a.y - origin_.y) * inverse_scale,
                     (a.z - origin_.z) * inverse_scale},
                    w,
                    0};
  }

  // Duplicate triangles share their lowest working vertex: bucket the proper triangles by it (a
  // counting sort, stable, so each bucket lists its triangles in input order) and compare within
  // buckets the two corners that follow the lowest (the same turning sense). Each triangle goes
  // to its bucket as its corners from the lowest on, with which corner that was, and is compared
  // as it arrives with the triangles before it there (about two: no second sweep).
  std::vector<uint32_t> bucket_start(size_t(count) + 1, 0);
  uint32_t proper_count = 0;
  for (size_t t = 0; t < triangles; ++t) {
    if (!proper[t]) continue;
    uint32_t* c = &corners[t * 3];
    c[0] = working_id[c[0]], c[1] = working_id[c[1]], c[2] = working_id[c[2]];
    ++bucket_start[std::min({c[0], c[1], c[2]}) + 1];
    ++proper_count;
  }
  for (uint32_t w = 0; w < count; ++w) bucket_start[w + 1] += bucket_start[w];
  struct Bucketed {
    uint32_t triangle;    // input triangle << 2 | its corner that is the lowest
    uint32_t corners[3];  // from the lowest on
  };
  std::unique_ptr<Bucketed[]> bucketed(new Bucketed[proper_count]);
  {
    std::vector<uint32_t> cursor(bucket_start.begin(), bucket_start.end() - 1);
    for (size_t t = 0; t < triangles; ++t) {
      if (!proper[t]) continue;
      const uint32_t* c = &corners[t * 3];
      const uint32_t first = c[0] < c[1] ? (c[0] < c[2] ? 0 : 2) : (c[1] < c[2] ? 1 : 2);
      const uint32_t lowest = c[first], next = c[kNext[first]], previous = c[kPrevious[first]];
      uint32_t& end = cursor[lowest];
      for (uint32_t j = bucket_start[lowest]; j < end; ++j)
        if (bucketed[j].corners[1] == next && bucketed[j].corners[2] == previous) {
          proper[t] = 0;  // a later copy
          break;
        }
      bucketed[end++] = {uint32_t(t) << 2 | first, {lowest, next, previous}};
    }
  }

  // The kept triangles: prepared ids in input order, working order by lowest vertex (large
  // meshes) or input order.
  std::vector<uint32_t> prepared_triangle(spatial ? triangles : 0);
  uint32_t kept = 0;
  for (size_t t = 0; t < triangles; ++t)
    if (proper[t]) {
      if (spatial) prepared_triangle[t] = kept;
      ++kept;
    }
  prepared_triangle_count_ = kept;
  indices_.resize(size_t(kept) * 3);
  uint32_t* out = indices_.data();
  if (spatial) {
    triangle_input_id_.resize(kept);
    uint32_t slot = 0;
    for (uint32_t i = 0; i < proper_count; ++i) {
      const Bucketed& b = bucketed[i];
      const uint32_t t = b.triangle >> 2, first = b.triangle & 3;
      if (!proper[t]) continue;
      uint32_t* o = out + size_t(slot) * 3;
      o[first] = b.corners[0], o[kNext[first]] = b.corners[1], o[kPrevious[first]] = b.corners[2];
      triangle_input_id_[slot++] = prepared_triangle[t];
    }
  } else {
    for (size_t t = 0; t < triangles; ++t)
      if (proper[t]) out = std::copy_n(&corners[t * 3], 3, out);
  }

  // The record starts from the prepared mesh (prepareMeshWithPositions' result).
  if (options_.record) {
    core::Mesh& base = record_.base;
    base.positions.resize(count);
    for (uint32_t v = 0; v < n; ++v)
      if (used[v]) base.positions[prepared_id[v]] = m.positions[v];
    base.indices.resize(size_t(kept) * 3);
    uint32_t* base_out = base.indices.data();
    for (size_t t = 0; t < triangles; ++t)
      if (proper[t])
        for (int k = 0; k < 3; ++k) *base_out++ = input_id_[corners[t * 3 + k]];
    base.submeshes = {{0, uint32_t(base.indices.size()), material()}};
    record_.values.positions = base.positions;
  }
}

// The vertex -> corner table of indices_ (counting sort; corners of a vertex in triangle order).
void PositionSimplifier::buildAdjacency() {
  corner_start_.assign(vertex_count_ + 1, 0);
  for (uint32_t v : indices_) ++corner_start_[v + 1];
  for (uint32_t v = 0; v < vertex_count_; ++v) corner_start_[v + 1] += corner_start_[v];
  std::copy_n(corner_start_.begin(), vertex_count_, cursor_.begin());
  corners_.resize(indices_.size());
  const uint32_t triangle_count = uint32_t(indices_.size() / 3);
  const uint32_t* indices = indices_.data();
  uint32_t* corners = corners_.data();
  uint32_t* cursor = cursor_.data();
  for (uint32_t t = 0; t < triangle_count; ++t, indices += 3) {
    const uint32_t a = indices[0], b = indices[1], c = indices[2];
    corners[cursor[a]++] = t << 2;
    corners[cursor[b]++] = t << 2 | 1;
    corners[cursor[c]++] = t << 2 | 2;
  }
  dead_.assign(indices_.size() / 3, 0);
}

// No vertex has absorbed another (the passes never chain; the greedy tail starts each fill from
// a compacted index buffer).
void PositionSimplifier::clearAbsorbed() {
  absorbed_next_.assign(vertex_count_, kAbsent);
  absorbed_last_.resize(vertex_count_);
  for (uint32_t v = 0; v < vertex_count_; ++v) absorbed_last_[v] = v;
}

// Vertex kinds as the engine's classifyPositions finds them for a position-only mesh with one
// submesh: free (no feature edge), constrained (exactly two border edges, not a corner), locked
// (non-manifold edge or fan, corner, line end or junction, lock_border); plus the penalty planes
// of the border edges. Per vertex, each neighbour is recorded as the next corner (edge v -> n) and
// the previous corner (n -> v) of the triangles: a neighbour seen twice the same way is a
// non-manifold edge, one seen only one way is a border edge, and walking the fan from triangle to
// triangle across the edges seen both ways must reach every triangle (one fan).
void PositionSimplifier::classify() {
  kinds_.assign(vertex_count_, VertexKind::kLocked);
  border_neighbors_.assign(size_t(vertex_count_) * 2, kAbsent);
  std::vector<uint32_t> as_next_buffer(vertex_count_, kAbsent);
  std::vector<uint32_t> as_previous_buffer(vertex_count_, kAbsent);
  uint32_t max_degree = 0;
  for (uint32_t v = 0; v < vertex_count_; ++v)
    max_degree = std::max(max_degree, corner_start_[v + 1] - corner_start_[v]);
  std::vector<uint32_t> nexts_buffer(max_degree), previouses_buffer(max_degree);
  // Raw pointers: the stores below cannot alias them.
  uint32_t* as_next = as_next_buffer.data();
  uint32_t* as_previous = as_previous_buffer.data();
  uint32_t* nexts = nexts_buffer.data();
  uint32_t* previouses = previouses_buffer.data();
  const uint32_t* indices = indices_.data();
  const uint32_t* corners = corners_.data();
  for (uint32_t v = 0; v < vertex_count_; ++v) {
    const uint32_t begin = corner_start_[v], degree = corner_start_[v + 1] - begin;
    if (degree == 0) continue;
    bool locked = false;
    // Neighbours joined to v by two triangles running the same way (a misoriented or
    // non-manifold edge) get this round as their mark (taken on the first such edge).
    uint32_t doubled_round = 0;
    auto doubled = [&](uint32_t n) {
      if (doubled_round == 0) doubled_round = nextRound();
      vertices_[n].mark = doubled_round;
      locked = true;
    };
    for (uint32_t i = 0; i < degree; ++i) {
      const uint32_t c = corners[begin + i], t = c >> 2, k = c & 3;
      const uint32_t n = indices[t * 3 + kNext[k]], p = indices[t * 3 + kPrevious[k]];
      nexts[i] = n, previouses[i] = p;
      if (as_next[n] != kAbsent)
        doubled(n);  // two triangles run v -> n
      else
        as_next[n] = i;
      if (as_previous[p] != kAbsent)
        doubled(p);
      else
        as_previous[p] = i;
    }
    if (!locked) {
      // Most vertices are interior: their fan is one cycle through all their corners, across
      // v -> n edges, and then no edge is a border edge (every next is some corner's previous).
      // Walked first, so that the border sweep below runs only for the others.
      uint32_t i = 0, steps = 0;
      do {
        i = as_previous[nexts[i]];
        ++steps;
      } while (i != kAbsent && i != 0 && steps <= degree);
      if (i == 0 && steps == degree) {
        for (uint32_t j = 0; j < degree; ++j)
          as_next[nexts[j]] = as_previous[previouses[j]] = kAbsent;
        kinds_[v] = VertexKind::kFree;
        continue;
      }
    }
    uint32_t border_count = 0, fan_start = 0;
    uint32_t line[2] = {kAbsent, kAbsent};
    auto border_edge = [&](uint32_t n, uint32_t i) {
      if (border_count < 2) line[border_count] = n;
      ++border_count;
      if (n < v) return;  // its penalty plane once, from the lower end
      const uint32_t t = corners_[begin + i] >> 2;
      const Vec3d face_normal = unitTriangleNormal(vertices_[indices_[t * 3]].position,
                                                   vertices_[indices_[t * 3 + 1]].position,
                                                   vertices_[indices_[t * 3 + 2]].position);
      Quadric plane;
      if (featureEdgeQuadric(vertices_[v].position, vertices_[n].position, face_normal, plane)) {
        addQuadric(quadrics_[v], plane);
        addQuadric(quadrics_[n], plane);
      }
    };
    // An edge that two triangles run the same way is no border (the surface goes on across it),
    // so it gets no penalty plane: its ends are locked (as they are in the engine), so a plane
    // through them would never price a collapse (one into a locked vertex stays where it is), and
    // the misoriented edges of a mesh whose triangles face both ways (CGAL's blobby-shuffled:
    // 3069 of its 6075 edges) cost two planes each. (`locked` is set then: kind and fan do not
    // matter.)
    auto is_doubled = [&](uint32_t n) {
      return doubled_round != 0 && vertices_[n].mark == doubled_round;
    };
    for (uint32_t i = 0; i < degree; ++i) {
      if (as_previous[nexts[i]] == kAbsent && !is_doubled(nexts[i])) border_edge(nexts[i], i);
      if (as_next[previouses[i]] == kAbsent && !is_doubled(previouses[i]))
        border_edge(previouses[i], i), fan_start = i;
    }
    // One fan: from its first triangle (after the border edge, if any) across v -> n edges.
    uint32_t reached = 0;
    for (uint32_t i = fan_start; i != kAbsent && reached <= degree;) {
      ++reached;
      i = as_previous[nexts[i]];
      if (i == fan_start) break;
    }
    for (uint32_t i = 0; i < degree; ++i) as_next[nexts[i]] = as_previous[previouses[i]] = kAbsent;
    if (locked || reached != degree || (border_count > 0 && options_.lock_border)) continue;
    if (border_count == 0) {
      kinds_[v] = VertexKind::kFree;
    } else if (border_count == 2 &&
               !isLineCorner(vertices_[line[0]].position, vertices_[v].position,
                             vertices_[line[1]].position)) {
      kinds_[v] = VertexKind::kConstrained;
      border_neighbors_[v * 2] = line[0];
      border_neighbors_[v * 2 + 1] = line[1];
      constrained_.push_back(v);
    }
  }
}

// A free vertex whose corner angles sum to less than π is a spike tip: pinned (quadric.hpp).
// |e × f| is computed again here, for the candidates only: the set-up's double areas kept in a
// per-triangle array cost more (fresh pages every call: bunny 50% 1-4% slower, with no candidate).
void PositionSimplifier::pinIfSpikeTip(uint32_t v) {
  const Vec3d p = vertices_[v].position;
  AngleSum angles;
  for (uint32_t i = corner_start_[v], end = corner_start_[v + 1]; i < end; ++i) {
    const uint32_t t = corners_[i] >> 2, k = corners_[i] & 3;
    angles.addCorner(vertices_[indices_[t * 3 + kNext[k]]].position - p,
                     vertices_[indices_[t * 3 + kPrevious[k]]].position - p);
    if (!angles.belowHalfTurn()) return;  // most candidates pass π within a few corners
  }
  pinSpikeTip(quadrics_[v], p);
}

// Applies this pass's collapses to the index buffer and drops the dead triangles.
void PositionSimplifier::compact() {
  size_t out = 0;
  const size_t triangles = indices_.size() / 3;
  uint32_t* input_ids = triangle_input_id_.empty() ? nullptr : triangle_input_id_.data();
  if (!greedy_) {  // a one-level remap, over raw pointers (the stores cannot alias the reads)
    uint32_t* indices = indices_.data();
    const VertexState* vertices = vertices_.data();
    const uint8_t* dead = dead_.data();
    for (size_t t = 0; t < triangles; ++t) {
      if (dead[t]) continue;
      const uint32_t a = vertices[indices[t * 3]].remap, b = vertices[indices[t * 3 + 1]].remap,
                     c = vertices[indices[t * 3 + 2]].remap;
      indices[out] = a, indices[out + 1] = b, indices[out + 2] = c;
      if (input_ids) input_ids[out / 3] = input_ids[t];
      out += 3;
    }
  } else {
    for (size_t t = 0; t < triangles; ++t) {
      if (dead_[t]) continue;
      for (int k = 0; k < 3; ++k) indices_[out + k] = resolve(indices_[t * 3 + k]);
      if (input_ids) input_ids[out / 3] = input_ids[t];
      out += 3;
    }
  }
  indices_.resize(out);
  if (input_ids) triangle_input_id_.resize(out / 3);
}

// Greedy tail: prices the candidate at its optimal placement (found again when it is applied) and
// queues it.
void PositionSimplifier::pushCandidate(uint32_t from, uint32_t to, bool endpoint_only) {
  Quadric q = quadrics_[from];
  addQuadric(q, quadrics_[to]);
  double cost = 0;
  Vec3d placement = vertices_[to].position;
  if (endpoint_only)
    cost = evaluateQuadric(q, placement);
  else
    placement = minimizeQuadric(q, vertices_[from].position, placement, &cost);
  if (!std::isfinite(cost) ||
      (std::isfinite(options_.target_error) && !(errorOf(cost, q.weight) <= options_.target_error)))
    return;
  const QueuedCandidate queued{uint64_t(orderKey(float(cost))) << 32 | from,
                               uint64_t(to) << 32 | uint32_t(tail_pricing_.size())};
  tail_pricing_.push_back({placement, endpoint_only});
  if (filling_)
    queue_.append(queued);
  else
    queue_.push(queued);
}

// The candidate of the edge {a, b} (both alive), by the rules of collectCandidates.
void PositionSimplifier::emitEdge(uint32_t a, uint32_t b) {
  const VertexKind ka = kinds_[a], kb = kinds_[b];
  if (ka == VertexKind::kFree && kb == VertexKind::kFree)
    pushCandidate(std::min(a, b), std::max(a, b), false);
  else if (ka == VertexKind::kFree)
    pushCandidate(a, b, true);
  else if (kb == VertexKind::kFree)
    pushCandidate(b, a, true);
  else if (ka == VertexKind::kLocked && kb == VertexKind::kLocked)
    return;
  else if (ka == VertexKind::kConstrained &&
           (border_neighbors_[a * 2] == b || border_neighbors_[a * 2 + 1] == b))
    pushCandidate(kb == VertexKind::kLocked ? a : std::min(a, b),
                  kb == VertexKind::kLocked ? b : std::max(a, b), kb == VertexKind::kLocked);
  else if (kb == VertexKind::kConstrained && ka == VertexKind::kLocked &&
           (border_neighbors_[b * 2] == a || border_neighbors_[b * 2 + 1] == a))
    pushCandidate(b, a, true);
}

// Every live edge once: an edge with a free endpoint is interior and manifold (a free vertex has
// no feature edge, and collapses keep it so), taken from the triangle where it runs from the
// lower to the higher id; only a free end may go, and it goes to the other end exactly when that
// one is not free. Border edges come from the constrained vertices' border neighbours: between
// two constrained vertices either may go (free placement, priced once), into a locked one only
// the constrained end, to the locked end exactly. Edges between two non-free vertices that are not
// border edges never collapse (a constrained vertex only slides along its line).
template <class Emit>
void PositionSimplifier::forEachTriangleEdge(size_t begin, size_t end, Emit&& emit) {
  const VertexKind* kinds = kinds_.data();
  const uint32_t* indices = indices_.data();
  // (Only where the records outgrow the L2 cache, as for the spatial order.)
  const PricingRecord* pricing =
      greedy_ || vertex_count_ < kSpatialOrderMinimum ? nullptr : pricing_;
  constexpr size_t kAhead = 8;
  for (size_t t = begin; t < end; ++t) {
    const uint32_t* v = indices + t * 3;
    if (pricing && t + kAhead < end) {
      // The pass pricing reads the records of each triangle's corners: they are spread over
      // megabytes, so a few triangles ahead they are fetched while this one is priced.
      const uint32_t* ahead = v + 3 * kAhead;
      __builtin_prefetch(&pricing[ahead[0]]);
      __builtin_prefetch(&pricing[ahead[1]]);
      __builtin_prefetch(&pricing[ahead[2]]);
    }
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[kNext[k]];
      if (a >= b) continue;  // (never equal: the pricing parts' room counts on it)
      const bool a_free = kinds[a] == VertexKind::kFree, b_free = kinds[b] == VertexKind::kFree;
      if (a_free)
        emit(a, b, !b_free);
      else if (b_free)
        emit(b, a, true);
    }
  }
}

template <class Emit>
void PositionSimplifier::forEachBorderEdge(Emit&& emit) {
  const VertexKind* kinds = kinds_.data();
  for (uint32_t v : constrained_) {
    if (!alive_[v]) continue;
    for (int i = 0; i < 2; ++i) {
      const uint32_t n = border_neighbors_[v * 2 + i];
      if (kinds[n] == VertexKind::kLocked)
        emit(v, n, true);
      else if (v < n)
        emit(v, n, false);
    }
  }
}

template <class Emit>
void PositionSimplifier::forEachCandidateEdge(Emit&& emit) {
  forEachTriangleEdge(0, indices_.size() / 3, emit);
  forEachBorderEdge(emit);
}

void PositionSimplifier::collectCandidates() {
  if (greedy_) {
    forEachCandidateEdge([&](uint32_t from, uint32_t to, bool endpoint_only) {
      pushCandidate(from, to, endpoint_only);
    });
    return;
  }
  // Pass pricing, inline over raw pointers (this runs for every edge of every pass): the merged
  // quadric Q = Qa + Qb at b, a and the midpoint, with d = a - b (as priceAtFixedPoints; ties to
  // b, then a): Qa(b) = ea - 2 ga·d + dᵀAa d, Qb(a) = eb + 2 gb·d + dᵀAb d,
  // Q(mid) = (Q(a) + Q(b)) / 2 - dᵀ(Aa + Ab)d / 4.
  const Quadric* quadrics = quadrics_.data();
  const PricingRecord* pricing = pricing_;
  const bool has_error_target = std::isfinite(options_.target_error);
  // Prices the edges `walk` emits into out and keys; the number kept.
  auto price = [&](PassCandidate* out, uint32_t* keys, auto&& walk) {
    size_t count = 0;
    // Inlined into the edge walk (a call per edge costs ~15% of the pricing in saved registers).
    walk([&](uint32_t from, uint32_t to, bool endpoint_only) __attribute__((always_inline)) {
      const auto [cost, at] = priceEdge(pricing[from], pricing[to], endpoint_only);
      if (!std::isfinite(cost)) return;
      if (has_error_target &&
          !(errorOf(cost, quadrics[from].weight + quadrics[to].weight) <= options_.target_error))
        return;
      keys[count] = orderKey(cost);
      out[count] = {from, to, cost, at, endpoint_only};
      ++count;
    });
    return count;
  };
  const size_t triangles = indices_.size() / 3;
  size_t count = 0;
  if (second_core_ && second_core_->available() && triangles >= kTwoCorePricingMinimum) {
    // In parts on both cores (second_core.hpp), each into its own room (at most two candidates a
    // triangle: of its three edges one or two run from a lower to a higher id), then moved
    // together in part order: the same candidates in the same order as one walk.
    const uint32_t parts = uint32_t(std::min<size_t>(kTwoCorePricingParts, triangles / 1024));
    size_t kept[kTwoCorePricingParts];
    auto begin_of = [&](uint32_t part) { return triangles * part / parts; };
    second_core_->forEach(parts, [&](uint32_t part) {
      const size_t begin = begin_of(part), end = begin_of(part + 1);
      kept[part] = price(pass_candidates_ + 2 * begin, pass_keys_ + 2 * begin,
                         [&](auto&& emit) { forEachTriangleEdge(begin, end, emit); });
    });
    for (uint32_t part = 0; part < parts; ++part) {
      const size_t begin = 2 * begin_of(part);
      if (begin != count) {
        std::memmove(pass_candidates_ + count, pass_candidates_ + begin,
                     kept[part] * sizeof(PassCandidate));
        std::memmove(pass_keys_ + count, pass_keys_ + begin, kept[part] * sizeof(uint32_t));
      }
      count += kept[part];
    }
  } else {
    count = price(pass_candidates_, pass_keys_,
                  [&](auto&& emit) { forEachTriangleEdge(0, triangles, emit); });
  }
  count += price(pass_candidates_ + count, pass_keys_ + count,
                 [&](auto&& emit) { forEachBorderEdge(emit); });
  pass_candidate_count_ = count;
}

// turnsOverOrFlattens (collapse_engine.hpp) for each triangle (corner, fan[i], fan[i + 1]) of a
// fan, two triangles per step in SSE2 doubles: the same operations in the same order, so the
// same answers bit for bit, in about half the instructions (the scalar test was ~10% of the
// instructions on bunny 10%).
__attribute__((always_inline)) inline bool PositionSimplifier::fanFlips(const uint32_t* fan,
                                                                        uint32_t size, Vec3d corner,
                                                                        Vec3d moved) const {
#if defined(__SSE2__)
  const VertexState* vertices = vertices_.data();
  const __m128d cx = _mm_set1_pd(corner.x), cy = _mm_set1_pd(corner.y), cz = _mm_set1_pd(corner.z);
  const __m128d mx = _mm_set1_pd(moved.x), my = _mm_set1_pd(moved.y), mz = _mm_set1_pd(moved.z);
  const __m128d zero = _mm_setzero_pd(), tiny = _mm_set1_pd(1e-24);
  for (uint32_t i = 0; i < size; i += 4) {
    // A lone last triangle fills both lanes.
    const uint32_t j = i + 2 < size ? i + 2 : i;
    const Vec3d& b0 = vertices[fan[i]].position;
    const Vec3d& d0 = vertices[fan[i + 1]].position;
    const Vec3d& b1 = vertices[fan[j]].position;
    const Vec3d& d1 = vertices[fan[j + 1]].position;
    const __m128d bx = _mm_set_pd(b1.x, b0.x), by = _mm_set_pd(b1.y, b0.y),
                  bz = _mm_set_pd(b1.z, b0.z);
    const __m128d dx = _mm_set_pd(d1.x, d0.x), dy = _mm_set_pd(d1.y, d0.y),
                  dz = _mm_set_pd(d1.z, d0.z);
    // n_old = cross(b - corner, d - corner)
    const __m128d ux = _mm_sub_pd(bx, cx), uy = _mm_sub_pd(by, cy), uz = _mm_sub_pd(bz, cz);
    const __m128d vx = _mm_sub_pd(dx, cx), vy = _mm_sub_pd(dy, cy), vz = _mm_sub_pd(dz, cz);
    const __m128d ox = _mm_sub_pd(_mm_mul_pd(uy, vz), _mm_mul_pd(uz, vy));
    const __m128d oy = _mm_sub_pd(_mm_mul_pd(uz, vx), _mm_mul_pd(ux, vz));
    const __m128d oz = _mm_sub_pd(_mm_mul_pd(ux, vy), _mm_mul_pd(uy, vx));
    // n_new = cross(b - moved, d - moved)
    const __m128d px = _mm_sub_pd(bx, mx), py = _mm_sub_pd(by, my), pz = _mm_sub_pd(bz, mz);
    const __m128d qx = _mm_sub_pd(dx, mx), qy = _mm_sub_pd(dy, my), qz = _mm_sub_pd(dz, mz);
    const __m128d nx = _mm_sub_pd(_mm_mul_pd(py, qz), _mm_mul_pd(pz, qy));
    const __m128d ny = _mm_sub_pd(_mm_mul_pd(pz, qx), _mm_mul_pd(px, qz));
    const __m128d nz = _mm_sub_pd(_mm_mul_pd(px, qy), _mm_mul_pd(py, qx));
    auto dot = [](__m128d ax, __m128d ay, __m128d az, __m128d bx_, __m128d by_, __m128d bz_) {
      return _mm_add_pd(_mm_add_pd(_mm_mul_pd(ax, bx_), _mm_mul_pd(ay, by_)), _mm_mul_pd(az, bz_));
    };
    const __m128d old_sq = dot(ox, oy, oz, ox, oy, oz), new_sq = dot(nx, ny, nz, nx, ny, nz);
    const __m128d to_b_sq = dot(px, py, pz, px, py, pz), to_d_sq = dot(qx, qy, qz, qx, qy, qz);
    // std::max(to_b_sq, to_d_sq): maxpd returns its second operand on ties and NaN, as std::max
    // returns its first.
    const __m128d edge_scale = _mm_max_pd(to_d_sq, to_b_sq);
    const __m128d flattens =
        _mm_or_pd(_mm_cmple_pd(new_sq, _mm_mul_pd(_mm_mul_pd(tiny, edge_scale), edge_scale)),
                  _mm_cmpngt_pd(new_sq, zero));
    const __m128d turns = _mm_cmple_pd(dot(ox, oy, oz, nx, ny, nz), zero);
    // A triangle that was already degenerate (old_sq <= 0) never counts.
    const __m128d flips = _mm_and_pd(_mm_cmpnle_pd(old_sq, zero), _mm_or_pd(flattens, turns));
    if (_mm_movemask_pd(flips)) return true;
  }
  return false;
#else
  for (uint32_t i = 0; i < size; i += 2)
    if (turnsOverOrFlattens(corner, vertices_[fan[i]].position, vertices_[fan[i + 1]].position,
                            moved))
      return true;
  return false;
#endif
}

// The link condition on a surface with a border (Dey, Edelsbrunner et al. 1999: the border
// closed by a virtual vertex joined to every border vertex) asks one thing more of a border edge:
// its triangle's other two edges must not both be border edges too. Such a triangle is joined to
// nothing across an edge: all that is left of an edge-connected component (or an ear hanging on
// one vertex), and its collapse would remove it (WaterBottle's cap and the Avocado's skin went at
// 0.5%, each a disc by then one triangle). The edge's endpoints' other triangles (`from_fan`,
// `to_fan`: their other two corners) hold no edge to `opposite` exactly when both those edges
// are border edges.
bool isolatedTriangle(uint32_t opposite, const uint32_t* from_fan, uint32_t from_fan_size,
                      const uint32_t* to_fan, uint32_t to_fan_size) {
  for (uint32_t i = 0; i < from_fan_size; ++i)
    if (from_fan[i] == opposite) return false;
  for (uint32_t i = 0; i < to_fan_size; ++i)
    if (to_fan[i] == opposite) return false;
  return true;
}

// The collapse of one priced candidate, checked against the current topology (its endpoints are
// untouched in this pass, but their neighbours may have moved): the link condition, then the
// optimal placement if it beats the priced point without turning a triangle over, else the
// priced point, then the flip test.
template <bool kGreedy, bool kHalf>
bool PositionSimplifier::tryCollapse(const PassCandidate& candidate, uint32_t pass,
                                     Collapser& collapser, Vec3d placement) {
  const uint32_t from = candidate.from, to = candidate.to;
  // Raw pointers, so that the stores below (marks, fans) do not make the compiler reload the
  // vectors' data pointers.
  VertexState* vertices = vertices_.data();
  const uint32_t* indices = indices_.data();
  const uint32_t* corners = corners_.data();
  const uint32_t* corner_start = corner_start_.data();
  const uint32_t* absorbed_next = absorbed_next_.data();
  const uint8_t* dead = dead_.data();
  auto survivor = [&](uint32_t v) {
    if constexpr (kGreedy)
      return resolve(v);
    else
      return vertices[v].remap;
  };
  auto for_each_triangle = [&](uint32_t v, auto&& f) {
    for (uint32_t u = v; u != kAbsent; u = kGreedy ? absorbed_next[u] : kAbsent)
      for (uint32_t i = corner_start[u], end = corner_start[u + 1]; i < end; ++i) {
        const uint32_t c = corners[i], t = c >> 2;
        if (!dead[t]) f(t, c & 3);
      }
  };

  // from's triangles: the ones on the edge (they die), the others (they move); mark from's
  // neighbours.
  SimplifyStats& stats = kHalf ? collapser.stats : stats_;
  const uint32_t near_round = nextRound(collapser);
  uint32_t* from_fan = collapser.from_fan;
  uint32_t from_fan_size = 0, edge_count = 0;
  uint32_t opposite[2] = {kAbsent, kAbsent};
  for_each_triangle(from, [&](uint32_t t, uint32_t k) {
    const uint32_t b = survivor(indices[t * 3 + kNext[k]]);
    const uint32_t d = survivor(indices[t * 3 + kPrevious[k]]);
    vertices[b].mark = vertices[d].mark = near_round;
    if (b == to || d == to) {
      if (edge_count < 2) {
        opposite[edge_count] = b == to ? d : b;
        collapser.edge_triangles[edge_count] = t;
      }
      ++edge_count;
      return;
    }
    from_fan[from_fan_size] = b;
    from_fan[from_fan_size + 1] = d;
    from_fan_size += 2;
  });
  collapser.edge_triangle_count = edge_count;
  if (edge_count == 0 || edge_count > 2 || (edge_count == 2 && opposite[0] == opposite[1])) {
    ++stats.rejected_topology;
    return false;
  }
  // Link condition (Dey, Edelsbrunner et al. 1999): the common neighbours of the endpoints are
  // exactly the edge's opposite vertices; no duplicate triangle may appear (a tetrahedron
  // where (from, o1, o2) and (to, o1, o2) both exist); and a border edge's triangle may not be
  // joined to nothing across an edge (isolatedTriangle).
  bool from_has_opposite_pair = false;
  if (edge_count == 2)
    for (uint32_t i = 0; i < from_fan_size; i += 2) {
      const uint32_t b = from_fan[i], d = from_fan[i + 1];
      from_has_opposite_pair |=
          (b == opposite[0] && d == opposite[1]) || (b == opposite[1] && d == opposite[0]);
    }
  const uint32_t counted_round = nextRound(collapser);
  uint32_t common = 0, to_fan_size = 0;
  uint32_t* to_fan = collapser.to_fan;
  bool duplicate = false;
  for_each_triangle(to, [&](uint32_t t, uint32_t k) {
    const uint32_t x = survivor(indices[t * 3 + kNext[k]]);
    const uint32_t y = survivor(indices[t * 3 + kPrevious[k]]);
    if (x != from && vertices[x].mark == near_round) vertices[x].mark = counted_round, ++common;
    if (y != from && vertices[y].mark == near_round) vertices[y].mark = counted_round, ++common;
    if (x == from || y == from) return;
    if (from_has_opposite_pair &&
        ((x == opposite[0] && y == opposite[1]) || (x == opposite[1] && y == opposite[0])))
      duplicate = true;
    to_fan[to_fan_size] = x;
    to_fan[to_fan_size + 1] = y;
    to_fan_size += 2;
  });
  if (common != edge_count || duplicate ||
      (edge_count == 1 && isolatedTriangle(opposite[0], from_fan, from_fan_size, to_fan,
                                           to_fan_size))) {
    ++stats.rejected_topology;
    return false;
  }

  const Vec3d at_from = vertices_[from].position, at_to = vertices_[to].position;
  auto flips = [&](Vec3d p) {
    const bool moves_to = p.x != at_to.x || p.y != at_to.y || p.z != at_to.z;
    // from's triangles keep their shape when the survivor sits where `from` was.
    const bool moves_from = p.x != at_from.x || p.y != at_from.y || p.z != at_from.z;
    return (moves_from && fanFlips(from_fan, from_fan_size, at_from, p)) ||
           (moves_to && fanFlips(to_fan, to_fan_size, at_to, p));
  };
  Vec3d priced = candidate.endpoint_only ? at_to : fixedPoint(at_from, at_to, candidate.at);
  if (kGreedy && !candidate.endpoint_only) {  // priced at the optimal placement: place it there
    priced = placement;
  } else if (!candidate.endpoint_only && candidate.cost > 0 && !coarse_pass_) {
    // (At a price of 0 nothing is better: minimizeQuadric's values are >= 0. Flat regions.)
    Quadric q = quadrics_[from];
    addQuadric(q, quadrics_[to]);
    double value = 0;
    const Vec3d best = minimizeQuadric(q, at_from, at_to, &value);
    const bool moved = best.x != priced.x || best.y != priced.y || best.z != priced.z;
    if (value < candidate.cost && moved && std::isfinite(best.x) && std::isfinite(best.y) &&
        std::isfinite(best.z) && !flips(best)) {
      applyCollapse<kHalf>(from, to, best, value, pass, collapser);
      return true;
    }
  }
  if (flips(priced)) {
    ++stats.rejected_flip;
    return false;
  }
  applyCollapse<kHalf>(from, to, priced, candidate.cost, pass, collapser);
  return true;
}

template <bool kHalf>
void PositionSimplifier::applyCollapse(uint32_t from, uint32_t to, Vec3d position, double cost,
                                       uint32_t pass, Collapser& collapser) {
  const uint32_t removed = collapser.edge_triangle_count;
  for (uint32_t i = 0; i < removed; ++i) dead_[collapser.edge_triangles[i]] = 1;
  if constexpr (kHalf)
    collapser.removed += removed;
  else
    live_triangles_ -= removed;
  vertices_[from].remap = to;
  alive_[from] = 0;
  pass_lock_[from] = pass_lock_[to] = pass;
  if (greedy_) {  // `to` takes over from's triangles
    absorbed_next_[absorbed_last_[to]] = from;
    absorbed_last_[to] = absorbed_last_[from];
    changed_at_[to] = uint32_t(tail_pricing_.size());
  }
  addQuadric(quadrics_[to], quadrics_[from]);
  const Vec3d at_to = vertices_[to].position, at_from = vertices_[from].position;
  if (position.x != at_to.x || position.y != at_to.y || position.z != at_to.z) {
    if (position.x == at_from.x && position.y == at_from.y && position.z == at_from.z) {
      asset_positions_[to] = asset_positions_[from];
    } else {
      Vec3d a = origin_ + position * scale_;
      if (clampIfBeyondFloat(a, origin_, box_max_)) position = (a - origin_) * (1.0 / scale_);
      asset_positions_[to] = {float(a.x), float(a.y), float(a.z)};
    }
    vertices_[to].position = position;
  }
  if (!greedy_) pricing_[to] = pricingRecord(quadrics_[to], vertices_[to].position, centre_);
  // A border collapse: from's other border neighbour now borders on `to`.
  if (kinds_[from] == VertexKind::kConstrained) {
    const uint32_t* line = &border_neighbors_[from * 2];
    const uint32_t other = line[0] == to ? line[1] : line[0];
    auto replace = [&](uint32_t v, uint32_t old_neighbor, uint32_t new_neighbor) {
      if (kinds_[v] != VertexKind::kConstrained) return;
      for (int i = 0; i < 2; ++i)
        if (border_neighbors_[v * 2 + i] == old_neighbor)
          border_neighbors_[v * 2 + i] = new_neighbor;
    };
    replace(other, from, to);
    replace(to, from, other);
  }

  const double error = errorOf(cost, quadrics_[to].weight);
  double& max_error = kHalf ? collapser.max_error : max_error_;
  max_error = std::max(max_error, error);
  ++(kHalf ? collapser.stats : stats_).collapses;
  if (options_.record) {
    std::vector<CollapseStep>& steps = kHalf ? collapser.steps : record_.steps;
    std::vector<core::Vec3>& values = kHalf ? collapser.values : record_.values.positions;
    CollapseStep step;
    step.removed = input_id_[from];
    step.kept = input_id_[to];
    step.kept_value = uint32_t(values.size());
    step.triangles_after = uint32_t(kHalf ? live_triangles_ - collapser.removed : live_triangles_);
    step.error = float(error);
    step.cumulative_error = float(max_error);
    steps.push_back(step);
    values.push_back(asset_positions_[to]);
  }
}

// The compacted result: referenced vertices and triangles in input order.
SimplifyResult PositionSimplifier::finish() {
  SimplifyResult result;
  std::vector<uint32_t> compact_id(vertex_count_, kAbsent);
  for (uint32_t v : indices_) compact_id[v] = 0;
  core::Mesh& mesh = result.mesh;
  mesh.positions.reserve(std::min<size_t>(vertex_count_, indices_.size()));
  std::vector<uint32_t> working_id(vertex_count_);
  for (uint32_t w = 0; w < vertex_count_; ++w) working_id[input_id_[w]] = w;
  for (uint32_t input = 0; input < vertex_count_; ++input) {
    const uint32_t v = working_id[input];
    if (compact_id[v] == kAbsent) continue;
    compact_id[v] = uint32_t(mesh.positions.size());
    mesh.positions.push_back(asset_positions_[v]);
  }
  mesh.indices.resize(indices_.size());
  if (triangle_input_id_.empty()) {
    for (size_t i = 0; i < indices_.size(); ++i) mesh.indices[i] = compact_id[indices_[i]];
  } else {  // back in input triangle order (a counting sort over the input triangles)
    std::vector<uint32_t> working_of(prepared_triangle_count_, kAbsent);
    for (size_t t = 0; t < triangle_input_id_.size(); ++t)
      working_of[triangle_input_id_[t]] = uint32_t(t);
    size_t out = 0;
    for (uint32_t t : working_of) {
      if (t == kAbsent) continue;
      for (int k = 0; k < 3; ++k) mesh.indices[out++] = compact_id[indices_[size_t(t) * 3 + k]];
    }
  }
  mesh.submeshes = {{0, uint32_t(mesh.indices.size()), material()}};
  result.stats = stats_;
  result.error = max_error_;
  if (options_.record) result.record = std::move(record_);
  return result;
}

// Tries the candidates from begin to end in order, skipping those whose endpoint a collapse of
// this pass touched, until the live triangles are down to `limit` (kHalf: until the half's
// collapses have removed `limit` triangles or may remove too many with one more); the number
// applied. `stopped`, if given: where it stopped.
template <bool kHalf>
size_t PositionSimplifier::applyInOrder(const PassCandidate* begin, const PassCandidate* end,
                                        uint32_t pass, Collapser& collapser, size_t limit,
                                        const PassCandidate** stopped) {
  size_t applied = 0;
  constexpr ptrdiff_t kAhead = 8;
  const PassCandidate* c = begin;
  for (; c != end && (kHalf ? collapser.removed + 2 <= limit : live_triangles_ > limit); ++c) {
    if (end - c > kAhead) {
      // The endpoints of a collapse a few places ahead are random vertices: their quadrics,
      // positions and corner ranges are fetched while this one is checked.
      const PassCandidate& next = c[kAhead];
      const char* qf = reinterpret_cast<const char*>(&quadrics_[next.from]);
      const char* qt = reinterpret_cast<const char*>(&quadrics_[next.to]);
      __builtin_prefetch(qf);
      __builtin_prefetch(qf + 64);
      __builtin_prefetch(qt);
      __builtin_prefetch(qt + 64);
      __builtin_prefetch(&vertices_[next.from]);
      __builtin_prefetch(&vertices_[next.to]);
      __builtin_prefetch(&corner_start_[next.from]);
      __builtin_prefetch(&corner_start_[next.to]);
      // Half as far ahead, their corner ranges (corner_start_ is fetched by now).
      const PassCandidate& nearer = c[kAhead / 2];
      __builtin_prefetch(&corners_[corner_start_[nearer.from]]);
      __builtin_prefetch(&corners_[corner_start_[nearer.to]]);
    }
    if (pass_lock_[c->from] == pass || pass_lock_[c->to] == pass) continue;
    if (tryCollapse<false, kHalf>(*c, pass, collapser)) ++applied;
  }
  if (stopped) *stopped = c;
  return applied;
}

// The cheap part of a pass (`order`, `count` candidates in cost order) applied in runs: the
// collapses inside each half (both endpoints away from the cut: no triangle of either reaches the
// other half), the two halves side by side on two cores (second_core.hpp), each up to its share
// of the triangles left to remove; then, here, those near the cut, then what either half left
// for lack of its share. A collapse reads and writes only its endpoints' triangles and their
// vertices, so a collapse inside one half never sees one inside the other: each half's run gives
// what it would give alone, and the result is the same on one core or two. Against one run in
// cost order, the collapses near the cut come after the others, and the halves' leftovers after
// those (runPasses keeps a pass likely to reach the target in one run). `scratch` has room for
// `count` candidates. The number applied.
size_t PositionSimplifier::applyHalves(const PassCandidate* order, size_t count,
                                       PassCandidate* scratch, uint32_t pass, size_t pass_target) {
  // Which vertices have a triangle across the cut, as the triangles are at the pass's start.
  const uint32_t* indices = indices_.data();
  const uint32_t cut = vertex_count_ / 2;
  uint32_t* near = near_other_half_.data();
  for (size_t t = 0, triangles = indices_.size() / 3; t < triangles; ++t) {
    const uint32_t a = indices[t * 3] >= cut, b = indices[t * 3 + 1] >= cut,
                   c = indices[t * 3 + 2] >= cut;
    if ((a ^ b) | (a ^ c))
      near[indices[t * 3]] = near[indices[t * 3 + 1]] = near[indices[t * 3 + 2]] = pass;
  }
  auto side = [&](const PassCandidate& c) -> uint32_t {  // 0, 1, or 2 near the cut
    return near[c.from] == pass || near[c.to] == pass ? 2 : c.from >= cut;
  };
  // Each half uses its own rounds of marks: room for two a candidate.
  Collapser& first = collapsers_[0];
  Collapser& second = collapsers_[1];
  if (uint64_t(first.round) + 2 * uint64_t(count) + 2 > std::numeric_limits<uint32_t>::max()) {
    for (VertexState& s : vertices_) s.mark = 0;
    first.round = 0;
  }
  size_t sizes[3] = {0, 0, 0};
  for (size_t i = 0; i < count; ++i) ++sizes[side(order[i])];
  PassCandidate* runs[3] = {scratch, scratch + sizes[0], scratch + sizes[0] + sizes[1]};
  size_t filled[3] = {0, 0, 0};
  for (size_t i = 0; i < count; ++i) {
    const uint32_t s = side(order[i]);
    runs[s][filled[s]++] = order[i];
  }
  second.round = first.round;
  for (int part = 0; part < 2; ++part) {
    Collapser& c = part == 0 ? first : second;
    c.removed = 0;
    c.max_error = max_error_;
    c.stats = {};
    c.steps.clear();
    c.values.clear();
    if (options_.record) {  // room for a step a candidate: no allocation on the helper
      c.steps.reserve(sizes[part]);
      c.values.reserve(sizes[part]);
    }
  }
  // The triangles the passes may still remove, shared in proportion to the halves'
  // candidates: neither half knows how far the other got, so each stops where it alone might
  // overshoot its share, and what is left of both is tried after the collapses near the cut.
  const size_t removable = live_triangles_ - pass_target;
  const size_t inside = sizes[0] + sizes[1];
  size_t shares[2];
  shares[0] = inside ? size_t(double(removable) * double(sizes[0]) / double(inside)) : 0;
  shares[1] = removable - shares[0];
  size_t applied[2] = {0, 0};
  const PassCandidate* stopped[2] = {runs[0], runs[1]};
  second_core_->forEach(2, [&](uint32_t part) {
    applied[part] = applyInOrder<true>(runs[part], runs[part] + sizes[part], pass,
                                       part == 0 ? first : second, shares[part], &stopped[part]);
  });
  first.round = std::max(first.round, second.round);

  // The halves' tallies and record steps, the first half's first: each step's triangle count
  // and largest error so far as they are in that order.
  float cumulative = float(max_error_);
  const uint32_t live_before = uint32_t(live_triangles_);
  uint32_t in_order = live_before;
  for (Collapser* c : {&first, &second}) {
    stats_.collapses += c->stats.collapses;
    stats_.rejected_topology += c->stats.rejected_topology;
    stats_.rejected_flip += c->stats.rejected_flip;
    if (options_.record) {
      const uint32_t value_base = uint32_t(record_.values.positions.size());
      uint32_t in_half = live_before;
      for (CollapseStep step : c->steps) {
        in_order -= in_half - step.triangles_after;
        in_half = step.triangles_after;
        step.triangles_after = in_order;
        step.kept_value += value_base;
        cumulative = std::max(cumulative, step.error);
        step.cumulative_error = cumulative;
        record_.steps.push_back(step);
      }
      record_.values.positions.insert(record_.values.positions.end(), c->values.begin(),
                                      c->values.end());
    }
    live_triangles_ -= c->removed;
  }
  max_error_ = std::max(first.max_error, second.max_error);
  size_t total = applied[0] + applied[1] +
                 applyInOrder<false>(runs[2], runs[2] + sizes[2], pass, first, pass_target);
  for (int part = 0; part < 2; ++part)
    total += applyInOrder<false>(stopped[part], runs[part] + sizes[part], pass, first, pass_target);
  return total;
}

// `tail`: the greedy tail's triangles (pass_target is the target plus those, or 0 for none);
// `tail_capacity`: how many a stalled pass may leave to it (passStalls).
void PositionSimplifier::runPasses(size_t pass_target, size_t tail, size_t tail_capacity) {
  auto reached = [&] { return live_triangles_ <= pass_target; };
  EngineOptions defaults;
  // The share of the last pass's cheap part that was applied (before the first pass, about what
  // first passes apply: 0.18-0.41 on the benchmark's CGAL meshes and turbine at 50/10/1%).
  double last_yield = 1.0 / 3;
  for (uint32_t pass = 1; !reached(); ++pass) {
    if (pass > 1) {
      compact();
      buildAdjacency();
    }
    coarse_pass_ = passIsCoarse(live_triangles_, pass_target);  // collapse_engine.hpp
    collectCandidates();
    if (pass_candidate_count_ == 0) break;
    ++stats_.passes;
    // As the engine's runPasses: the collapses still needed (about two triangles each) set the
    // goal rank; edges up to pass_cost_slack times its cost (or the kThinPassRank times goal
    // cheapest, when those are fewer than passCheapPartThin allows) are applied in order, the
    // rest wait for the next pass unless none of the cheap ones could be applied. Both parts keep
    // the pricing order among equal costs.
    const size_t count = pass_candidate_count_;
    const size_t goal = pass_target > 0 ? (live_triangles_ - pass_target + 1) / 2 : 0;
    PassCandidate* const candidates = pass_candidates_;
    PassCandidate* const cheap = pass_cheap_;
    PassCandidate* const rest = pass_rest_;
    const PassCandidate* order = nullptr;
    size_t cheap_count = count, rest_count = 0;
    const uint32_t* keys = pass_keys_;
    uint32_t limit = ~0u;  // the cheap part's largest key
    if (goal > 0 && goal < count) {
      const uint32_t goal_key =
          selectKey(keys, count, goal, histograms_, pass_key_scratch_);
      float goal_cost;
      std::memcpy(&goal_cost, &goal_key, 4);
      limit =
          std::max(costBits(double(goal_cost) * defaults.pass_cost_slack), costBits(free_cost_));
      auto gather_cheap = [&] {
        cheap_count = 0;
        for (size_t i = 0; i < count; ++i) {  // the store always, the count when kept: no branch
          cheap[cheap_count] = candidates[i];
          cheap_count += keys[i] <= limit;
        }
      };
      gather_cheap();
      if (passCheapPartThin(cheap_count, goal) && kThinPassRank * goal < count) {
        limit = selectKey(keys, count, kThinPassRank * goal, histograms_, pass_key_scratch_);
        gather_cheap();
      }
      rest_count = count - cheap_count;
      // Ordered with the rest's buffer as scratch: the candidates stay as priced, for the rest.
      order = sortByKey(cheap, rest, cheap_count, histograms_);
    } else {
      order = sortByKey(candidates, cheap, count, histograms_);
    }
    // The rest (in pricing order), gathered only when it is needed (rarely); `open_only`: only
    // the edges whose endpoints this pass left untouched.
    auto gather_rest = [&](bool open_only) {
      size_t gathered = 0;
      for (size_t i = 0; i < count; ++i) {  // the store always, the count when kept
        const PassCandidate& c = candidates[i];
        rest[gathered] = c;
        const bool open = pass_lock_[c.from] != pass && pass_lock_[c.to] != pass;
        gathered += keys[i] > limit && (open || !open_only);
      }
      return gathered;
    };
    size_t applied = 0;
    auto apply_range = [&](const PassCandidate* begin, const PassCandidate* end) {
      applied += applyInOrder<false>(begin, end, pass, collapsers_[0], pass_target);
    };
    // In halves on two cores (applyHalves) unless this pass is likely to reach the target: each
    // half stops at its share then, not where one run in cost order would, and the last pass
    // before the target shapes the result most (always in halves, the 1% cells of the CGAL
    // meshes' Hausdorff distances moved by up to 0.2 of meshopt's; bench/RESULTS.md, issue 3,
    // session 45). Likely: its cheap part, applied at the last pass's yield, removes two triangles
    // a collapse and comes within a margin of the target.
    const double expected_removed = 2.0 * double(cheap_count) * last_yield;
    if (in_halves_ && (pass_target == 0 ||
                       expected_removed * kHalvesMargin < double(live_triangles_ - pass_target)))
      applied += applyHalves(order, cheap_count, order == rest ? cheap : rest, pass, pass_target);
    else
      apply_range(order, order + cheap_count);
    last_yield = cheap_count > 0 ? double(applied) / double(cheap_count) : 0.0;
    const size_t left = reached() ? 0 : (live_triangles_ - pass_target + 1) / 2;
    if (applied == 0 && rest_count > 0) {  // the cheap part is spent: its buffers are scratch
      const size_t gathered = gather_rest(false);
      order = sortByKey(rest, cheap, gathered, histograms_);
      apply_range(order, order + gathered);
    } else if (passFinishes(left, goal) && rest_count > 0) {  // collapse_engine.hpp
      const size_t open = gather_rest(true);
      order = sortByKey(rest, cheap, open, histograms_);
      apply_range(order, order + open);
    }
    if (options_.progress) options_.progress(live_triangles_);
    if (applied == 0) break;
    const size_t above_target = reached() ? 0 : live_triangles_ - pass_target;
    if (passStalls(applied, goal, above_target, tail_capacity) || passNearsTail(above_target, tail))
      break;
  }
  coarse_pass_ = false;
  compact();
}

// The greedy queue of Garland & Heckbert 1997 for the last collapses: always the cheapest edge
// next, priced at its optimal placement. A collapse changes the survivor's edges, and their entries
// are priced again lazily: an entry whose endpoint was absorbed or changed since its pricing is,
// when it comes to the top, priced again as the edge between the endpoints' survivors and queued
// again. Its old price is (nearly always) a lower bound of the new one: the merged quadric only
// grows, so an edge is not applied before a cheaper one. The eager way (the engine's runGreedy
// with invalidation ring 1, and this code until session 18) priced all of the survivor's edges
// after each collapse: ~7 solves and queue entries a collapse, most of them stale before they came
// up (bunny 1%: 9468 pops for 1195 collapses). Measured on bench/simplify: geomean 1.047 -> 1.023
// (the cells with a tail 2-7% faster); error over 5 orders unchanged on the benchmark (Hausdorff
// geomean 0.616 -> 0.616, mean 0.559 -> 0.560) and on the survey's 75 cells (11 worse than meshopt
// before and after; anchor_dense 1%, already worse, 1.03 -> 1.31); bench/RESULTS.md, issue 3,
// session 18. A candidate refused by the link or flip test leaves the queue; when the queue runs
// dry short of the target, refusals having been made, it is filled again from all edges, at most
// EngineOptions::max_passes times, but not after a full fill that applied nothing: that fill
// tried every edge of a mesh the next fill would find unchanged, so it would refuse them all
// again (CGAL's boeing, stuck at 2046 triangles on its way to 50%, filled four times: 1.0 of its
// 3.6 ms; bench/RESULTS.md, issue 3, session 40).
void PositionSimplifier::runGreedy() {
  auto reached = [&] {
    return options_.target_triangles > 0 && live_triangles_ <= options_.target_triangles;
  };
  // The first fill is seeded with the edges cheapest at their fixed points (the passes' float
  // prices), kGreedySeedsPerCollapse per collapse still needed, instead of solving every edge at
  // its optimal placement (at 50% the tail needs ~1000 collapses out of ~60k edges on bunny). The
  // seeds' entries are priced again as they come up, as above, and if the seeds run out
  // short of the target the next fill takes every edge. Measured on bench/simplify: same output
  // on every mesh and ratio there (bunny 50%: 13% less time); with 4 seeds per collapse,
  // Hausdorff moved both ways (bunny 10% 0.90 -> 1.24, spot 50% 1.11 -> 0.98), so the seeds stay
  // generous.
  constexpr size_t kGreedySeedsPerCollapse = 8;
  bool seeded = false;
  uint32_t seed_limit = 0;
  if (options_.target_triangles > 0 && !reached()) {
    const size_t needed = (live_triangles_ - options_.target_triangles + 1) / 2;
    const size_t seeds = needed * kGreedySeedsPerCollapse;
    // A closed mesh has 1.5 edges per triangle: no pricing when the seeds would be all of them.
    if (seeds < live_triangles_ * 3 / 2) {
      collectCandidates();  // the passes' pricing (greedy_ is not set yet)
      if (seeds < pass_candidate_count_) {
        seed_limit = selectKey(pass_keys_, pass_candidate_count_, seeds, histograms_,
                               pass_key_scratch_);
        seeded = true;
      }
    }
  }
  greedy_ = true;
  changed_at_.assign(vertex_count_, 0);
  tail_pricing_.clear();
  for (int fill = 0; fill < EngineOptions{}.max_passes && !reached(); ++fill) {
    buildAdjacency();
    clearAbsorbed();
    queue_.clear();
    filling_ = true;
    const bool from_seeds = seeded && fill == 0;
    if (from_seeds) {
      for (size_t i = 0; i < pass_candidate_count_; ++i)
        if (pass_keys_[i] <= seed_limit) {
          const PassCandidate& c = pass_candidates_[i];
          pushCandidate(c.from, c.to, c.endpoint_only);
        }
    } else {
      collectCandidates();
    }
    filling_ = false;
    queue_.heapify();
    const size_t rejected_before = stats_.rejected_topology + stats_.rejected_flip;
    const size_t collapses_before = stats_.collapses;
    while (!queue_.empty() && !reached()) {
      const QueuedCandidate e = queue_.pop();
      const uint32_t from = e.from(), to = e.to(), id = e.id();
      if (!alive_[from] || !alive_[to] || id < changed_at_[from] || id < changed_at_[to]) {
        const uint32_t a = resolve(from), b = resolve(to);
        if (a != b) emitEdge(a, b);  // priced again and queued (unless it may not collapse)
        continue;
      }
      const TailPricing priced = tail_pricing_[id];
      const PassCandidate c{from, to, e.cost(), kFixedAtB, priced.endpoint_only};
      tryCollapse<true>(c, 0, collapsers_[0], priced.placement);
    }
    compact();
    if (options_.progress) options_.progress(live_triangles_);
    if (!from_seeds && (stats_.rejected_topology + stats_.rejected_flip == rejected_before ||
                        stats_.collapses == collapses_before))
      break;
  }
}

// The pass arrays, the pricing records and the fans, carved out of one block. As separate
// blocks of megabytes they were the top of the heap when a call freed them, so glibc gave them
// back to the system and the next call faulted every page in again (bunny: ~1300 page faults a
// call; 0-8% of its time at 10% and 1%, by run; bench/RESULTS.md, issue 3, session
// 15). Room for every candidate a pass can emit (forEachCandidateEdge): at most two per triangle
// (of a triangle's three edges, one or two run from a lower to a higher id) and two per
// constrained vertex; the mesh only shrinks.
void PositionSimplifier::allocatePassArrays() {
  const size_t edge_room = 2 * (indices_.size() / 3) + 2 * constrained_.size();
  size_t size = 0;
  auto place = [&](size_t bytes) {  // each array at a 64-byte boundary
    const size_t offset = size;
    size += (bytes + 63) & ~size_t(63);
    return offset;
  };
  const size_t candidates_at = place(edge_room * sizeof(PassCandidate));
  const size_t cheap_at = place(edge_room * sizeof(PassCandidate));
  const size_t rest_at = place(edge_room * sizeof(PassCandidate));
  const size_t keys_at = place(edge_room * 4), scratch_at = place(edge_room * 4);
  const size_t histograms_at = place(3 * kDigits * 4);
  const size_t pricing_at = place(vertex_count_ * sizeof(PricingRecord));
  const size_t from_fan_at = place(indices_.size() * 2 * 4);
  const size_t to_fan_at = place(indices_.size() * 2 * 4);
  const size_t second_from_fan_at = in_halves_ ? place(indices_.size() * 2 * 4) : 0;
  const size_t second_to_fan_at = in_halves_ ? place(indices_.size() * 2 * 4) : 0;
  // (Trivial types: the block's bytes become their objects as they are written, C++20.)
  pass_memory_.reset(new std::byte[size + 63]);
  std::byte* base = reinterpret_cast<std::byte*>(
      (reinterpret_cast<uintptr_t>(pass_memory_.get()) + 63) & ~uintptr_t(63));
  pass_candidates_ = reinterpret_cast<PassCandidate*>(base + candidates_at);
  pass_cheap_ = reinterpret_cast<PassCandidate*>(base + cheap_at);
  pass_rest_ = reinterpret_cast<PassCandidate*>(base + rest_at);
  pass_keys_ = reinterpret_cast<uint32_t*>(base + keys_at);
  pass_key_scratch_ = reinterpret_cast<uint32_t*>(base + scratch_at);
  histograms_ = reinterpret_cast<uint32_t*>(base + histograms_at);
  pricing_ = reinterpret_cast<PricingRecord*>(base + pricing_at);
  collapsers_[0].from_fan = reinterpret_cast<uint32_t*>(base + from_fan_at);
  collapsers_[0].to_fan = reinterpret_cast<uint32_t*>(base + to_fan_at);
  if (in_halves_) {
    collapsers_[1].from_fan = reinterpret_cast<uint32_t*>(base + second_from_fan_at);
    collapsers_[1].to_fan = reinterpret_cast<uint32_t*>(base + second_to_fan_at);
  }
}

// Collapses whose error is below this fraction of the bounding-box diagonal are free: a pass takes
// all of them into its cheap part, whatever its goal-rank cost. On the flat regions of CAD models
// thousands of edges price at rounding noise (1e-17 and below in the frame, half of them clamped
// to exactly 0), so the order among them is noise too; a pass whose goal rank fell among them took
// only those up to 1.5 times a noise value (often exactly the zeros), applied a fraction of them
// (locks and flips), and the next pass priced every edge again: fandisk to 70% took 10 passes for
// 1942 collapses, longer than to 50%. At 2^-20 of the diagonal such an error is at the rounding
// of float coordinates (2^-24 of their magnitude) times a few. Meshes whose goal-rank costs lie
// above it are unchanged bit for bit (bench/RESULTS.md, issue 3, session 39).
constexpr double kFreeCollapseError = 1.0 / (1 << 20);

SimplifyResult PositionSimplifier::run() {
  setUp();
  buildAdjacency();
  clearAbsorbed();
  classify();
  if (in_halves_) {
    near_other_half_.assign(vertex_count_, 0);
    second_core_.emplace();
  }
  allocatePassArrays();
  double weight_sum = 0;
  for (uint32_t v = 0; v < vertex_count_; ++v) {
    if (kinds_[v] == VertexKind::kFree && mayBeSpikeTip(quadrics_[v])) pinIfSpikeTip(v);
    pricing_[v] = pricingRecord(quadrics_[v], vertices_[v].position, centre_);
    weight_sum += quadrics_[v].weight;
  }
  // The cost of an edge whose endpoints weigh as much as two average vertices, at an error of
  // kFreeCollapseError (errorOf: the error is sqrt(cost / weight) in the frame, whose diagonal
  // is 1).
  if (vertex_count_ > 0)
    free_cost_ = float(kFreeCollapseError * kFreeCollapseError * 2 * weight_sum / vertex_count_);
  EngineOptions tail_options;
  tail_options.target_triangles = options_.target_triangles;
  const size_t tail = greedyTailTriangles(tail_options, live_triangles_);
  const size_t pass_target = options_.target_triangles > 0 ? options_.target_triangles + tail : 0;
  runPasses(pass_target, tail, greedyTailCapacity(tail_options, live_triangles_));
  runGreedy();
  return finish();
}

}  // namespace

bool positionFastPathApplies(const core::Mesh& m, const SimplifyOptions& options) {
  if (options.placement != Placement::kOptimal || attributeLayout(m).stride != 0 ||
      m.vertexCount() >= kAbsent / 2 ||
      m.indices.size() / 3 >= (size_t(1) << 30))  // corners_ holds triangle << 2
    return false;
  // One submesh, or submeshes that prepareMesh makes one: the passes know no material borders.
  if (m.submeshes.size() > 1 && submeshesTile(m)) return false;
  for (core::Vec3 p : m.positions)
    if (!core::isFinite(p)) return false;
  return true;
}

SimplifyResult simplifyPositions(const core::Mesh& mesh, const SimplifyOptions& options) {
  PositionSimplifier simplifier(mesh, options);
  return simplifier.run();
}

}  // namespace duolod::mesh
