// Edge-collapse engine (see collapse_engine.hpp for the rules). Based on:
//   Hoppe, "Progressive meshes", SIGGRAPH 1996 (collapse sequence, wedges);
//   Garland & Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997
//     (greedy loop over a priority queue of edge collapses);
//   Dey, Edelsbrunner, Guha, Nekhayev, "Topology preserving edge contraction", 1999 (link
//     condition).
// Data layout: flat arrays only. Each position keeps a singly linked list of its triangle corners
// (corner_next), spliced in O(degree) on a collapse; dead triangles are unlinked lazily whenever
// the engine walks a list. The queue is a heap (4-ary: half the depth of a binary heap, and a
// node's children share a cache line) of directed candidates stamped with both endpoints'
// versions. Positions are numbered along a Morton curve. No allocation happens per collapse once
// the scratch buffers have grown.
//
// Two orderings (EngineOptions::ordering). kGreedy: the strict queue above, re-pricing the edges
// a collapse invalidated (the image-driven mode needs it: lazy refinement, ring-2 invalidation).
// kPasses (simplifyQuadric on position-only meshes): per pass, every live edge is priced once
// (edges with a free endpoint read straight off the triangles, no neighbour gathering), the
// prices are partitioned at the goal rank (nth_element) and the cheap part sorted; edges are
// applied in order, skipping any that shares an endpoint with one applied in this pass (so no
// stale price is ever used), up to 1.5x the goal-rank price; the last <= 2000 triangles
// (<= 1/16 of the input) go through the greedy queue. The quadric model prices pass candidates
// at the best of the endpoints and the midpoint and solves the optimal placement only for the
// collapse being applied (CostModel::refinePlacement).
//
// Position-only meshes with optimal placement and one submesh no longer come here:
// simplifyQuadric runs them through the dedicated fast path (simplify_positions.cpp), which is
// this engine's kPasses + greedy tail on a different data layout. kPasses here still serves
// position-only meshes with endpoint placement, several submeshes or non-finite positions.
//
// Cost, measured (callgrind, `LP_NUM_THREADS=0 valgrind --tool=callgrind build/bench/bench_simplify
// bunny00.off --gltfpack "" --samples 0 --repeats 1 --ratios 0.1 --no-progressive`, bunny 75k
// triangles -> 10%). This engine's kPasses: 430M instructions for simplifyQuadric (706M with the
// greedy queue alone), 2.8x meshoptimizer 0.18's meshopt_simplify (153M): applying the ~34k
// collapses 128M (3.8k each: the flip test of both fans 36M, gathering `from` 24M, the link
// condition 24M, optimal placement 19M, the splice and bookkeeping 15M); pricing ~305k pass
// candidates ~65M; classification 57M (a neighbour gather per position); preparation (welding,
// triangle dedup) 31M; quadrics 26M; engine state and Morton order 19M; the greedy tail ~30M;
// candidate collection, partition and sort ~40M. The layout was the limit (per-position corner
// lists walked by gatherNeighbors, a neighbour gather per candidate), hence the fast path with
// per-pass flat corner tables: same algorithm, nearly the same quality table, 1.1-2.0x meshopt's
// wall clock (see simplify_positions.cpp and bench/RESULTS.md, issue 3, for where its time goes).
// Lazy re-pricing in the greedy queue was tried earlier: 29% fewer pricings but 15% more
// instructions (each stale entry needs a gather to be re-priced).
#include "mesh/collapse_engine.hpp"
#include "mesh/quaternary_heap.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <utility>

namespace duolod::mesh {
namespace {

uint64_t mixHash(uint64_t h) {  // splitmix64 finalizer: spreads bits for linear probing
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  h ^= h >> 31;
  return h;
}

uint64_t hashWords(const uint32_t* words, size_t count, uint64_t seed = 0) {
  uint64_t h = seed;
  for (size_t i = 0; i < count; ++i) h = mixHash(h ^ (words[i] + 0x9e3779b97f4a7c15ull));
  return h;
}

// Open addressing with linear probing over item indices; the caller supplies hash and equality.
class IndexTable {
 public:
  explicit IndexTable(size_t expected) {
    size_t capacity = 16;
    while (capacity < expected * 2) capacity *= 2;
    slots_.assign(capacity, kAbsent);
  }
  // Returns the index of an equal item already present, or inserts `item` and returns it.
  template <class Equal>
  uint32_t findOrInsert(uint32_t item, uint64_t hash, Equal&& equal) {
    size_t mask = slots_.size() - 1;
    for (size_t i = hash & mask;; i = (i + 1) & mask) {
      uint32_t slot = slots_[i];
      if (slot == kAbsent) return slots_[i] = item;
      if (equal(slot)) return slot;
    }
  }

 private:
  std::vector<uint32_t> slots_;
};

// Submesh index per triangle when the submeshes tile the index buffer in order; otherwise
// everything is group 0 and `valid` is false.
std::vector<uint32_t> triangleGroups(const core::Mesh& mesh, bool& valid) {
  const size_t triangles = mesh.indices.size() / 3;
  std::vector<uint32_t> groups(triangles, 0);
  valid = submeshesTile(mesh);
  if (!valid) return groups;
  for (uint32_t s = 0; s < mesh.submeshes.size(); ++s) {
    const core::Submesh& sub = mesh.submeshes[s];
    for (uint32_t t = sub.first_index / 3; t < (sub.first_index + sub.index_count) / 3; ++t)
      groups[t] = s;
  }
  return groups;
}

bool isFinite(Vec3d p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// Corner k's successor in its triangle (k + 1) mod 3, without the division.
constexpr uint32_t kNextCorner[3] = {1, 2, 0};

// A queued directed collapse. The survivor's position is kept so the collapse can be applied
// without asking the model again: exactly one endpoint (kAtTo / kAtFrom) or a free point in float.
struct QueuedCollapse {
  float error;
  uint32_t from, to;
  uint32_t stamp_from, stamp_to;
  float x, y, z;
  uint8_t placement;
  uint8_t exact;  // 0: the cost is the model's estimate; refine before applying
};
enum : uint8_t { kAtTo, kAtFrom, kAtPoint };

// The priority queue: a 4-ary min-heap of 64-bit keys (cost bits << 32 | slot). A non-negative
// float's bits order like the float, so one integer compare orders by cost, then by slot (which
// is deterministic). The collapse itself lives in a slot of a pool, so sifting moves 8 bytes and
// a cache line holds a node's four children. Stale entries stay until popped (lazy invalidation).
class CollapseQueue {
 public:
  void clear() {
    keys_.clear();
    slots_.clear();
    free_.clear();
  }
  bool empty() const { return keys_.empty(); }
  // Adds without restoring the heap order; call heapify() before popping.
  void append(float cost, const QueuedCollapse& collapse) { keys_.append(keyOf(cost, collapse)); }
  void push(float cost, const QueuedCollapse& collapse) { keys_.push(keyOf(cost, collapse)); }
  void heapify() { keys_.heapify(); }
  // Removes the cheapest; returns its cost and collapse.
  QueuedCollapse pop(float& cost) {
    const uint64_t top = keys_.pop();
    uint32_t slot = uint32_t(top);
    uint32_t bits = uint32_t(top >> 32);
    std::memcpy(&cost, &bits, 4);
    free_.push_back(slot);
    return slots_[slot];
  }

 private:
  // Stores the collapse in a free slot and returns its key.
  uint64_t keyOf(float cost, const QueuedCollapse& collapse) {
    uint32_t slot;
    if (!free_.empty()) {
      slot = free_.back();
      free_.pop_back();
      slots_[slot] = collapse;
    } else {
      slot = uint32_t(slots_.size());
      slots_.push_back(collapse);
    }
    return uint64_t(costBits(cost)) << 32 | slot;
  }
  static uint32_t costBits(float cost) {
    if (!(cost >= 0)) cost = cost < 0 ? 0.0f : std::numeric_limits<float>::max();  // NaN: last
    uint32_t bits;
    std::memcpy(&bits, &cost, 4);
    return bits;
  }

  QuaternaryHeap<uint64_t> keys_;
  std::vector<QueuedCollapse> slots_;
  std::vector<uint32_t> free_;
};

// A growable array of trivial values for the per-collapse scratch lists: unlike std::vector it
// can be filled through a raw pointer after one capacity check, without initializing first.
template <class T>
class ScratchList {
 public:
  T* begin() { return data_.get(); }
  T* end() { return data_.get() + size_; }
  const T* begin() const { return data_.get(); }
  const T* end() const { return data_.get() + size_; }
  T* data() { return data_.get(); }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  size_t capacity() const { return capacity_; }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  operator std::span<const T>() const { return {data_.get(), size_}; }
  void clear() { size_ = 0; }
  void push_back(const T& value) {
    if (size_ == capacity_) reserve(size_ + 1);
    data_[size_++] = value;
  }
  // Room for at least n values, keeping the first size().
  void reserve(size_t n) {
    if (n <= capacity_) return;
    size_t capacity = std::max<size_t>({16, n, capacity_ * 2});
    std::unique_ptr<T[]> grown(new T[capacity]);
    std::copy_n(data_.get(), size_, grown.get());
    data_ = std::move(grown);
    capacity_ = capacity;
  }
  // After writing through data() (within capacity()).
  void setSize(size_t n) { size_ = n; }

 private:
  std::unique_ptr<T[]> data_;
  size_t size_ = 0, capacity_ = 0;
};

// One neighbour of the position being examined, with the (first two) triangles on the edge.
struct Neighbor {
  uint32_t vertex;
  uint32_t count;            // live triangles on the edge
  uint32_t local[2];         // their index in the incident list
  uint32_t other_corner[2];  // the neighbour's corner in them
  uint8_t outgoing;          // bit i: triangle i runs self -> neighbour
};

class Engine {
 public:
  // `position_ids` (may be null): PreparedMesh::position_ids of `base`.
  Engine(const core::Mesh& base, const std::vector<uint32_t>* position_ids,
         uint32_t position_count, CostModel& model, const EngineOptions& options)
      : base_(base),
        given_position_ids_(position_ids),
        given_position_count_(position_count),
        model_(model),
        options_(options) {}

  SimplifyResult run();

 private:
  void buildState();
  void classifyPositions();
  void gatherNeighbors(uint32_t p);
  uint8_t edgeFeatures(const Neighbor& nb) const;
  bool makeCandidate(uint32_t from, uint32_t to, const Neighbor& nb, bool self_is_from,
                     uint8_t features, CandidateCollapse& out) const;
  void emitEdgeCandidates(uint32_t p, uint32_t done_round);
  void flushBatch(bool heapify_later = false);
  void queueCandidate(const CandidateCollapse& candidate, bool heapify_later);
  bool candidateFor(const QueuedCollapse& entry, CandidateCollapse& out);
  void refineTop(const QueuedCollapse& first);
  bool isStale(const QueuedCollapse& entry) const {
    return !state_.position_alive[entry.from] || !state_.position_alive[entry.to] ||
           stamps_[entry.from] != entry.stamp_from || stamps_[entry.to] != entry.stamp_to;
  }
  // The model refused it (infinite cost and error), e.g. an edge longer than D pixels.
  static bool isForbidden(const QueuedCollapse& entry, float cost) {
    return cost == std::numeric_limits<float>::max() &&
           entry.error == std::numeric_limits<float>::max();
  }
  void fillQueue();
  bool tryCollapse(const QueuedCollapse& entry, float cost);
  bool applyIfLegal(CandidateCollapse& cand, uint8_t placement, const Neighbor& edge);
  bool flips(const CandidateCollapse& cand, uint8_t placement) const;
  const Neighbor* findEdge(uint32_t to) const {
    for (const Neighbor& nb : neighbors_)
      if (nb.vertex == to) return &nb;
    return nullptr;
  }
  uint8_t placementOf(const CandidateCollapse& c) const;
  void runGreedy();
  void runPasses();
  void collectPassCandidates();
  bool tryPassCollapse(const CandidateCollapse& priced);
  bool linkConditionHolds(uint32_t from, uint32_t to, const Neighbor& edge);
  bool flipsOrDegenerates(uint32_t moving, uint32_t other, Vec3d position,
                          std::span<const uint32_t> incident) const;
  void applyCollapse(CandidateCollapse& candidate, uint8_t placement);
  void invalidateAround(uint32_t survivor);
  core::Mesh buildOutput() const;
  uint32_t nextRound() {
    if (++round_ == 0) {  // wrapped: clear the marks once
      std::fill(mark_.begin(), mark_.end(), 0);
      round_ = 1;
    }
    return round_;
  }

  const core::Mesh& base_;
  const std::vector<uint32_t>* given_position_ids_;
  uint32_t given_position_count_;
  CostModel& model_;
  EngineOptions options_;
  EngineState state_;
  std::vector<uint32_t> stamps_;

  // Scratch (sized once).
  std::vector<uint32_t> neighbor_slot_;  // per position: index into neighbors_, or kAbsent
  ScratchList<Neighbor> neighbors_;
  ScratchList<uint32_t> incident_;       // live corners of the gathered position
  ScratchList<uint32_t> to_incident_;    // live corners of the survivor (link/flip tests)
  std::vector<uint32_t> mark_;           // per position: round marks
  uint32_t round_ = 0;
  std::vector<uint32_t> union_find_;
  std::vector<uint32_t> affected_;
  std::vector<CandidateCollapse> batch_;
  std::vector<float> placed_;
  CollapseQueue queue_;
  std::vector<uint64_t> pass_order_;     // kPasses: (cost bits << 32 | batch index)
  std::vector<uint32_t> pass_lock_;      // kPasses: per position, the pass that touched it
  bool coarse_pass_ = false;             // kPasses: passIsCoarse (no placement solve)

  SimplifyStats stats_;
  size_t pass_rejections_ = 0;
  double max_error_ = 0;
  ProgressiveRecord record_;
};

void Engine::buildState() {
  EngineState& s = state_;
  const core::Mesh& m = base_;
  const size_t wedges = m.vertexCount();
  const size_t triangles = m.triangleCount();

  s.layout = attributeLayout(m);
  s.attributes = packAttributes(m, s.layout);
  uint32_t position_count = given_position_count_;
  if (given_position_ids_ && given_position_ids_->size() == wedges)
    s.wedge_position = *given_position_ids_;
  else
    position_count = positionIds(m.positions, s.wedge_position);

  core::Bounds bounds;
  for (core::Vec3 p : m.positions)
    if (core::isFinite(p)) bounds.extend(p);
  if (!bounds.empty()) {
    s.origin = {bounds.min.x, bounds.min.y, bounds.min.z};
    s.box_max = {bounds.max.x, bounds.max.y, bounds.max.z};
    const Vec3d size = boxSize(bounds);
    const double diagonal = std::sqrt(dot(size, size));
    s.scale = diagonal > 0 && std::isfinite(diagonal) ? diagonal : 1.0;
  }
  const double inverse_scale = 1.0 / s.scale;

  // Number positions along a Morton curve: neighbours on the surface get nearby ids, so the
  // per-position arrays (positions, quadrics, list heads, stamps) are walked with few cache misses
  // whatever order the file had. (Wedges and triangles keep the input order.)
  {
    std::vector<uint32_t> representative(position_count, kAbsent);
    for (uint32_t w = 0; w < wedges; ++w)
      if (representative[s.wedge_position[w]] == kAbsent) representative[s.wedge_position[w]] = w;
    auto spread = [](uint64_t v) {  // 10 bits -> every third bit
      v &= 0x3ff;
      v = (v | v << 16) & 0x30000ff;
      v = (v | v << 8) & 0x300f00f;
      v = (v | v << 4) & 0x30c30c3;
      v = (v | v << 2) & 0x9249249;
      return v;
    };
    std::vector<uint32_t> code(position_count);
    for (uint32_t p = 0; p < position_count; ++p) {
      core::Vec3 a = m.positions[representative[p]];
      code[p] = 0x3fffffff;  // non-finite positions last
      if (core::isFinite(a)) {
        uint64_t q[3];
        for (int k = 0; k < 3; ++k) {
          double t = (a[k] - (&s.origin.x)[k]) * inverse_scale;
          q[k] = uint64_t(std::clamp(t, 0.0, 1.0) * 1023.0);
        }
        code[p] = uint32_t(spread(q[0]) | spread(q[1]) << 1 | spread(q[2]) << 2);
      }
    }
    // Stable radix sort of the ids by their 30-bit code, two 15-bit digits (ties keep id order).
    std::vector<uint32_t> order(position_count), sorted(position_count);
    for (uint32_t p = 0; p < position_count; ++p) order[p] = p;
    std::vector<uint32_t> bucket(1u << 15);
    for (int shift : {0, 15}) {
      std::fill(bucket.begin(), bucket.end(), 0);
      for (uint32_t p : order) ++bucket[(code[p] >> shift) & 0x7fff];
      uint32_t sum = 0;
      for (uint32_t& b : bucket) sum += std::exchange(b, sum);
      for (uint32_t p : order) sorted[bucket[(code[p] >> shift) & 0x7fff]++] = p;
      order.swap(sorted);
    }
    std::vector<uint32_t> new_id(position_count);
    for (uint32_t rank = 0; rank < position_count; ++rank) new_id[order[rank]] = rank;
    for (uint32_t w = 0; w < wedges; ++w) s.wedge_position[w] = new_id[s.wedge_position[w]];
  }

  s.positions.assign(position_count, Vec3d{});
  s.asset_positions.assign(position_count, core::Vec3{});
  s.first_wedge.assign(position_count, kAbsent);
  s.wedge_next.assign(wedges, kAbsent);
  std::vector<uint32_t> last_wedge(position_count, kAbsent);
  for (uint32_t w = 0; w < wedges; ++w) {
    uint32_t p = s.wedge_position[w];
    if (s.first_wedge[p] == kAbsent) {
      s.first_wedge[p] = w;
      core::Vec3 a = m.positions[w];
      s.asset_positions[p] = a;
      s.positions[p] = {(a.x - s.origin.x) * inverse_scale, (a.y - s.origin.y) * inverse_scale,
                        (a.z - s.origin.z) * inverse_scale};
    } else {
      s.wedge_next[last_wedge[p]] = w;
    }
    last_wedge[p] = w;
    s.wedge_next[w] = s.first_wedge[p];
  }

  s.corners = m.indices;
  bool groups_valid = false;
  s.groups = triangleGroups(m, groups_valid);
  s.triangle_alive.assign(triangles, 1);
  s.live_triangles = triangles;
  s.first_corner.assign(position_count, kAbsent);
  s.corner_next.assign(triangles * 3, kAbsent);
  for (size_t c = triangles * 3; c-- > 0;) {
    uint32_t p = s.wedge_position[s.corners[c]];
    s.corner_next[c] = s.first_corner[p];
    s.first_corner[p] = uint32_t(c);
  }
  s.position_alive.assign(position_count, 1);
  s.kinds.assign(position_count, VertexKind::kLocked);
  s.line_features.assign(position_count, 0);

  stamps_.assign(position_count, 0);
  neighbor_slot_.assign(position_count, kAbsent);
  mark_.assign(position_count, 0);
}

// Walks p's corner list, unlinking corners of dead triangles, and fills incident_ (p's live
// corners) and neighbors_ (one entry per adjacent position with the edge's triangles).
void Engine::gatherNeighbors(uint32_t p) {
  EngineState& s = state_;
  const uint32_t* corners = s.corners.data();
  const uint32_t* wedge_position = s.wedge_position.data();
  const uint8_t* alive = s.triangle_alive.data();
  uint32_t* next_of = s.corner_next.data();
  uint32_t* slot_of = neighbor_slot_.data();
  // The scratch lists are written through raw pointers (this runs several times per collapse);
  // they grow only for a higher valence than seen before.
  uint32_t* incident = incident_.data();
  Neighbor* neighbors = neighbors_.data();
  uint32_t incident_count = 0, neighbor_count = 0;
  uint32_t previous = kAbsent;
  for (uint32_t c = s.first_corner[p]; c != kAbsent;) {
    const uint32_t next = next_of[c];
    const uint32_t t = c / 3;
    if (!alive[t]) {  // unlink
      if (previous == kAbsent)
        s.first_corner[p] = next;
      else
        next_of[previous] = next;
      c = next;
      continue;
    }
    previous = c;
    if (incident_count == incident_.capacity() || neighbor_count + 2 > neighbors_.capacity()) {
      incident_.setSize(incident_count);
      neighbors_.setSize(neighbor_count);
      incident_.reserve(incident_count + 1);
      neighbors_.reserve(neighbor_count + 2);
      incident = incident_.data();
      neighbors = neighbors_.data();
    }
    const uint32_t local = incident_count;
    incident[incident_count++] = c;
    const uint32_t k = c - t * 3;
    // The corner after p runs p -> n (outgoing), the one before runs n -> p.
    const uint32_t others[2] = {t * 3 + kNextCorner[k], t * 3 + kNextCorner[kNextCorner[k]]};
    for (uint32_t step = 0; step < 2; ++step) {
      const uint32_t other_corner = others[step];
      const uint32_t n = wedge_position[corners[other_corner]];
      if (n == p) continue;  // degenerate triangle (cannot survive preparation; defensive)
      const uint32_t slot = slot_of[n];
      if (slot == kAbsent) {
        slot_of[n] = neighbor_count;
        neighbors[neighbor_count++] =
            Neighbor{n, 1, {local, kAbsent}, {other_corner, kAbsent}, uint8_t(step == 0)};
        continue;
      }
      Neighbor& nb = neighbors[slot];
      if (nb.count < 2) {
        nb.local[nb.count] = local;
        nb.other_corner[nb.count] = other_corner;
        if (step == 0) nb.outgoing |= uint8_t(1u << nb.count);
      }
      ++nb.count;
    }
    c = next;
  }
  for (uint32_t i = 0; i < neighbor_count; ++i) slot_of[neighbors[i].vertex] = kAbsent;
  incident_.setSize(incident_count);
  neighbors_.setSize(neighbor_count);
}

uint8_t Engine::edgeFeatures(const Neighbor& nb) const {
  const EngineState& s = state_;
  if (nb.count == 1) return kFeatureBorder;
  if (nb.count != 2) return kFeatureNonManifold;
  // A manifold, consistently oriented edge runs one way in each triangle.
  if (((nb.outgoing & 1) != 0) == ((nb.outgoing & 2) != 0)) return kFeatureNonManifold;
  uint32_t c0 = incident_[nb.local[0]], c1 = incident_[nb.local[1]];
  uint8_t features = 0;
  if (s.corners[c0] != s.corners[c1] ||
      s.corners[nb.other_corner[0]] != s.corners[nb.other_corner[1]])
    features |= kFeatureSeam;
  if (!options_.allow_material_border_collapse && s.groups[c0 / 3] != s.groups[c1 / 3])
    features |= kFeatureMaterial;
  return features;
}

void Engine::classifyPositions() {
  EngineState& s = state_;
  const uint32_t position_count = uint32_t(s.positions.size());
  for (uint32_t p = 0; p < position_count; ++p) {
    gatherNeighbors(p);
    int wedge_count = 0;
    s.forEachWedge(p, [&](uint32_t) { ++wedge_count; });

    // Fans: triangles around p joined across manifold edges; more than one = non-manifold vertex.
    const uint32_t d = uint32_t(incident_.size());
    union_find_.resize(d);
    for (uint32_t i = 0; i < d; ++i) union_find_[i] = i;
    auto find = [&](uint32_t i) {
      while (union_find_[i] != i) i = union_find_[i] = union_find_[union_find_[i]];
      return i;
    };
    bool locked = !isFinite(s.positions[p]) || wedge_count > kMaxWedges || d == 0;
    int feature_count = 0;
    uint32_t line_neighbors[2] = {kAbsent, kAbsent};
    uint8_t line = 0;
    bool line_consistent = true;
    for (const Neighbor& nb : neighbors_) {
      uint8_t f = edgeFeatures(nb);
      if (f & kFeatureNonManifold) locked = true;
      if (nb.count == 2) union_find_[find(nb.local[0])] = find(nb.local[1]);
      if (f == 0) continue;
      if (feature_count == 0) line = f;
      if (f != line) line_consistent = false;
      if (feature_count < 2) line_neighbors[feature_count] = nb.vertex;
      ++feature_count;
      if ((f & kFeatureBorder) && options_.lock_border) locked = true;
      if (nb.vertex > p)
        s.feature_edges.push_back(
            {p, nb.vertex,
             {incident_[nb.local[0]] / 3, nb.count > 1 ? incident_[nb.local[1]] / 3 : kAbsent},
             f});
    }
    uint32_t fans = 0;
    for (uint32_t i = 0; i < d; ++i) fans += find(i) == i;
    if (fans > 1) locked = true;

    if (locked)
      s.kinds[p] = VertexKind::kLocked;
    else if (feature_count == 0 && wedge_count == 1)
      s.kinds[p] = VertexKind::kFree;
    else if (feature_count == 2 && line_consistent &&
             !isLineCorner(s.positions[line_neighbors[0]], s.positions[p],
                           s.positions[line_neighbors[1]]))
      s.kinds[p] = VertexKind::kConstrained, s.line_features[p] = line;
    else
      s.kinds[p] = VertexKind::kLocked;
  }
}

// The directed collapse from -> to over the edge `nb` (gathered around `from` when self_is_from,
// else around `to`), or false when the rules forbid it.
bool Engine::makeCandidate(uint32_t from, uint32_t to, const Neighbor& nb, bool self_is_from,
                           uint8_t features, CandidateCollapse& out) const {
  const EngineState& s = state_;
  VertexKind from_kind = s.kinds[from];
  if (from_kind == VertexKind::kLocked || (features & kFeatureNonManifold)) return false;
  if (from_kind == VertexKind::kFree ? features != 0 : features != s.line_features[from])
    return false;

  // Wedge pairs (wedge of `from`, wedge of `to`) in the edge's triangles.
  uint32_t pair_from[2], pair_to[2];
  const uint32_t pairs = std::min<uint32_t>(nb.count, 2);
  for (uint32_t i = 0; i < pairs; ++i) {
    uint32_t self_wedge = s.corners[incident_[nb.local[i]]];
    uint32_t other_wedge = s.corners[nb.other_corner[i]];
    pair_from[i] = self_is_from ? self_wedge : other_wedge;
    pair_to[i] = self_is_from ? other_wedge : self_wedge;
  }
  if (pairs == 2 && pair_from[0] == pair_from[1] && pair_to[0] != pair_to[1]) return false;

  out.from = from;
  out.to = to;
  const VertexKind to_kind = s.kinds[to];
  if (from_kind == VertexKind::kFree) {
    // Fast path (most candidates): one wedge, merging into the wedge across the edge.
    if (pairs == 2 && pair_to[0] != pair_to[1]) return false;
    out.wedge_count = 1;
    out.from_wedges[0] = pair_from[0];
    out.to_wedges[0] = pair_to[0];
    out.endpoint_only = options_.endpoint_only || to_kind != VertexKind::kFree;
    out.position = s.positions[to];
    return true;
  }
  out.wedge_count = 0;
  bool ok = true;
  s.forEachWedge(from, [&](uint32_t w) {
    uint32_t target = kAbsent;
    for (uint32_t i = 0; i < pairs; ++i)
      if (pair_from[i] == w) target = pair_to[i];
    if (target == kAbsent || out.wedge_count >= kMaxWedges) {
      ok = false;
      return;
    }
    out.from_wedges[out.wedge_count] = w;
    out.to_wedges[out.wedge_count] = target;
    ++out.wedge_count;
  });
  if (!ok) return false;

  bool endpoint_only = options_.endpoint_only || to_kind == VertexKind::kLocked ||
                       (to_kind == VertexKind::kFree && features != 0) ||
                       (to_kind == VertexKind::kConstrained && features != s.line_features[to]);
  if (!endpoint_only) {  // every wedge of the survivor must take part in the merge
    s.forEachWedge(to, [&](uint32_t w) {
      bool merged = false;
      for (uint32_t i = 0; i < out.wedge_count; ++i) merged |= out.to_wedges[i] == w;
      if (!merged) endpoint_only = true;
    });
  }
  out.endpoint_only = endpoint_only;
  out.position = s.positions[to];
  return true;
}

// Candidates for every edge of p whose other end is not marked `done_round` (assumes
// gatherNeighbors(p) was just called).
void Engine::emitEdgeCandidates(uint32_t p, uint32_t done_round) {
  CandidateCollapse forward, backward;
  for (const Neighbor& nb : neighbors_) {
    if (mark_[nb.vertex] == done_round || !state_.position_alive[nb.vertex]) continue;
    uint8_t features = edgeFeatures(nb);
    bool has_forward = makeCandidate(p, nb.vertex, nb, true, features, forward);
    // With free placement both directions are the same collapse (the survivor moves to the
    // same point whichever id it keeps): price it once.
    bool has_backward = !(has_forward && !forward.endpoint_only && !options_.endpoint_only &&
                          state_.kinds[p] == state_.kinds[nb.vertex]) &&
                        makeCandidate(nb.vertex, p, nb, false, features, backward);
    if (has_forward && has_backward && !forward.endpoint_only && !backward.endpoint_only)
      has_backward = false;
    if (has_forward) batch_.push_back(forward);
    if (has_backward) batch_.push_back(backward);
  }
}

// Where the candidate puts the survivor: an endpoint exactly, or a free point.
uint8_t Engine::placementOf(const CandidateCollapse& c) const {
  const Vec3d& p = c.position;
  const Vec3d& at_to = state_.positions[c.to];
  const Vec3d& at_from = state_.positions[c.from];
  if (c.endpoint_only || (p.x == at_to.x && p.y == at_to.y && p.z == at_to.z)) return kAtTo;
  if (p.x == at_from.x && p.y == at_from.y && p.z == at_from.z) return kAtFrom;
  return isFinite(p) ? kAtPoint : kAtTo;
}

void Engine::queueCandidate(const CandidateCollapse& c, bool heapify_later) {
  QueuedCollapse e;
  e.error = std::isfinite(c.error) ? float(c.error) : std::numeric_limits<float>::max();
  e.from = c.from;
  e.to = c.to;
  e.stamp_from = stamps_[c.from];
  e.stamp_to = stamps_[c.to];
  const Vec3d& p = c.position;
  e.placement = placementOf(c);
  e.x = float(p.x), e.y = float(p.y), e.z = float(p.z);
  e.exact = c.exact ? 1 : 0;
  float cost = std::isfinite(c.cost) ? float(c.cost) : std::numeric_limits<float>::max();
  if (heapify_later)
    queue_.append(cost, e);
  else
    queue_.push(cost, e);
}

void Engine::flushBatch(bool heapify_later) {
  if (batch_.empty()) return;
  model_.evaluate(state_, batch_);
  for (const CandidateCollapse& c : batch_) queueCandidate(c, heapify_later);
  batch_.clear();
}

bool Engine::candidateFor(const QueuedCollapse& entry, CandidateCollapse& out) {
  gatherNeighbors(entry.from);
  const Neighbor* edge = findEdge(entry.to);
  return edge && makeCandidate(entry.from, entry.to, *edge, true, edgeFeatures(*edge), out);
}

// Lazy pricing: the cheapest entry is an estimate, so price it and the next estimates from the
// top of the queue exactly, in one refine() call, and queue them again.
void Engine::refineTop(const QueuedCollapse& first) {
  std::vector<std::pair<float, QueuedCollapse>> exact_aside;
  CandidateCollapse candidate;
  if (candidateFor(first, candidate)) batch_.push_back(candidate);
  const size_t limit = std::max<size_t>(1, model_.refineBatchSize());
  while (batch_.size() < limit && !queue_.empty()) {
    float cost = 0;
    QueuedCollapse entry = queue_.pop(cost);
    if (isStale(entry) || isForbidden(entry, cost)) continue;
    if (entry.exact) {
      exact_aside.push_back({cost, entry});
      continue;
    }
    if (candidateFor(entry, candidate)) batch_.push_back(candidate);
  }
  if (!batch_.empty()) model_.refine(state_, batch_);
  for (CandidateCollapse& c : batch_) {
    c.exact = true;  // never ask twice for the same state
    queueCandidate(c, false);
  }
  batch_.clear();
  for (const auto& [cost, entry] : exact_aside) queue_.push(cost, entry);
}

void Engine::fillQueue() {
  queue_.clear();
  uint32_t done = nextRound();
  const uint32_t position_count = uint32_t(state_.positions.size());
  for (uint32_t p = 0; p < position_count; ++p) {
    if (!state_.position_alive[p]) continue;
    gatherNeighbors(p);
    mark_[p] = done;
    emitEdgeCandidates(p, done);
    if (batch_.size() >= options_.batch_size) flushBatch(true);
  }
  flushBatch(true);
  queue_.heapify();
}

// Link condition: the common neighbours of the endpoints are exactly the edge's opposite
// vertices (one on a border edge, two inside); no duplicate triangle may appear (a
// tetrahedron-like configuration where (from, o1, o2) and (to, o1, o2) both exist); and a border
// edge's triangle may not be joined to nothing across an edge. Fills to_incident_ with the
// survivor's live corners.
bool Engine::linkConditionHolds(uint32_t from, uint32_t to, const Neighbor& edge) {
  EngineState& s = state_;
  uint32_t opposite[2] = {kAbsent, kAbsent};
  for (uint32_t i = 0; i < edge.count; ++i) {
    uint32_t c = incident_[edge.local[i]];
    uint32_t t = c / 3, k = c - t * 3;
    uint32_t other_k = edge.other_corner[i] - t * 3;
    opposite[i] = s.cornerPosition(t * 3 + (3 - k - other_k));
  }
  if (edge.count == 2 && opposite[0] == opposite[1]) return false;

  uint32_t near_round = nextRound();
  for (const Neighbor& nb : neighbors_) mark_[nb.vertex] = near_round;
  // Does `from` have a triangle (from, o1, o2)? Then `to` must not have (to, o1, o2).
  bool from_has_opposite_pair = false;
  if (edge.count == 2) {
    for (uint32_t c : incident_) {
      uint32_t t = c / 3;
      uint32_t a = s.cornerPosition(t * 3), b = s.cornerPosition(t * 3 + 1),
               d = s.cornerPosition(t * 3 + 2);
      bool has0 = a == opposite[0] || b == opposite[0] || d == opposite[0];
      bool has1 = a == opposite[1] || b == opposite[1] || d == opposite[1];
      from_has_opposite_pair |= has0 && has1;
    }
  }
  uint32_t counted_round = nextRound();
  uint32_t common = 0, to_triangles_at_opposite = 0;
  bool duplicate = false;
  to_incident_.clear();
  uint32_t previous = kAbsent;
  for (uint32_t c = s.first_corner[to]; c != kAbsent;) {
    uint32_t next = s.corner_next[c];
    uint32_t t = c / 3;
    if (!s.triangle_alive[t]) {
      if (previous == kAbsent)
        s.first_corner[to] = next;
      else
        s.corner_next[previous] = next;
      c = next;
      continue;
    }
    previous = c;
    to_incident_.push_back(c);
    uint32_t k = c - t * 3;
    uint32_t x = s.cornerPosition(t * 3 + kNextCorner[k]),
             y = s.cornerPosition(t * 3 + kNextCorner[kNextCorner[k]]);
    for (uint32_t n : {x, y}) {
      if (n == from) continue;
      if (mark_[n] == near_round) {
        mark_[n] = counted_round;
        ++common;
      }
    }
    if (from_has_opposite_pair && ((x == opposite[0] && y == opposite[1]) ||
                                   (x == opposite[1] && y == opposite[0])))
      duplicate = true;
    to_triangles_at_opposite += x == opposite[0] || y == opposite[0];
    c = next;
  }
  if (common != edge.count || duplicate) return false;
  // On a border edge, its triangle's other two edges must not both be border edges: that
  // triangle is all that is left of an edge-connected component (the border closed by a virtual
  // vertex, as simplify_positions.cpp's isolatedTriangle explains).
  if (edge.count == 1 && to_triangles_at_opposite == 1)
    for (const Neighbor& nb : neighbors_)
      if (nb.vertex == opposite[0] && nb.count == 1) return false;
  return true;
}

// Whether moving position `moving` to `position` flips (turns by 90° or more) or flattens any of
// its triangles that do not contain `other` (those die in the collapse).
bool Engine::flipsOrDegenerates(uint32_t moving, uint32_t other, Vec3d position,
                                std::span<const uint32_t> incident) const {
  const EngineState& s = state_;
  for (uint32_t c : incident) {
    uint32_t t = c / 3, k = c - t * 3;
    uint32_t b = s.cornerPosition(t * 3 + kNextCorner[k]);
    uint32_t d = s.cornerPosition(t * 3 + kNextCorner[kNextCorner[k]]);
    if (b == other || d == other) continue;
    if (turnsOverOrFlattens(s.positions[moving], s.positions[b], s.positions[d], position))
      return true;
  }
  return false;
}

void Engine::applyCollapse(CandidateCollapse& cand, uint8_t placement) {
  EngineState& s = state_;
  const uint32_t from = cand.from, to = cand.to;
  const uint32_t stride = s.layout.stride;

  // Survivor attributes, asked before the state changes.
  placed_.resize(size_t(cand.wedge_count) * stride);
  for (uint32_t i = 0; i < cand.wedge_count; ++i)
    std::copy_n(s.wedgeAttributes(cand.to_wedges[i]), stride, placed_.data() + i * stride);
  if (stride > 0) model_.placeAttributes(s, cand, placed_);
  model_.beforeCollapse(s, cand);

  // Rewire from's triangles onto `to`; the ones on the edge die.
  size_t removed = 0;
  uint32_t head = kAbsent, tail = kAbsent;
  for (uint32_t c = s.first_corner[from]; c != kAbsent;) {
    uint32_t next = s.corner_next[c];
    uint32_t t = c / 3;
    if (s.triangle_alive[t]) {
      uint32_t k = c - t * 3;
      uint32_t b = s.cornerPosition(t * 3 + kNextCorner[k]);
      uint32_t d = s.cornerPosition(t * 3 + kNextCorner[kNextCorner[k]]);
      if (b == to || d == to) {
        s.triangle_alive[t] = 0;
        --s.live_triangles;
        ++removed;
      } else {
        uint32_t w = s.corners[c];
        for (uint32_t i = 0; i < cand.wedge_count; ++i)
          if (cand.from_wedges[i] == w) {
            s.corners[c] = cand.to_wedges[i];
            break;
          }
        if (head == kAbsent) head = c;
        if (tail != kAbsent) s.corner_next[tail] = c;
        tail = c;
      }
    }
    c = next;
  }
  if (tail != kAbsent) {
    s.corner_next[tail] = s.first_corner[to];
    s.first_corner[to] = head;
  }
  s.first_corner[from] = kAbsent;
  s.position_alive[from] = 0;

  // Survivor position.
  if (placement == kAtFrom) {
    s.positions[to] = s.positions[from];
    s.asset_positions[to] = s.asset_positions[from];
  } else if (placement == kAtPoint) {
    Vec3d a = s.origin + cand.position * s.scale;
    if (clampIfBeyondFloat(a, s.origin, s.box_max))
      cand.position = (a - s.origin) * (1.0 / s.scale);
    s.positions[to] = cand.position;
    s.asset_positions[to] = {float(a.x), float(a.y), float(a.z)};
  }
  cand.position = s.positions[to];
  for (uint32_t i = 0; i < cand.wedge_count; ++i)
    std::copy_n(placed_.data() + i * stride, stride,
                s.attributes.data() + size_t(cand.to_wedges[i]) * stride);

  max_error_ = std::max(max_error_, cand.error);
  ++stats_.collapses;
  if (options_.record) {
    for (uint32_t i = 0; i < cand.wedge_count; ++i) {
      CollapseStep step;
      step.removed = cand.from_wedges[i];
      step.kept = cand.to_wedges[i];
      step.kept_value = uint32_t(record_.values.positions.size());
      step.triangles_after = uint32_t(s.live_triangles);
      step.error = float(cand.error);
      step.cumulative_error = float(max_error_);
      step.continues = i + 1 < cand.wedge_count;
      record_.steps.push_back(step);
      appendVertex(record_.values, s.layout, s.asset_positions[to], placed_.data() + i * stride);
    }
  }
  model_.onCollapse(s, AppliedCollapse{cand, removed});
}

// Re-prices every edge whose cost may have changed: the survivor's (ring 1), and its neighbours'
// (ring 2), in one batch.
void Engine::invalidateAround(uint32_t survivor) {
  affected_.clear();
  affected_.push_back(survivor);
  if (options_.invalidation_ring >= 2) {
    gatherNeighbors(survivor);
    for (const Neighbor& nb : neighbors_) affected_.push_back(nb.vertex);
  }
  for (uint32_t v : affected_) ++stamps_[v];
  uint32_t done = nextRound();
  for (uint32_t v : affected_) {
    gatherNeighbors(v);
    mark_[v] = done;
    emitEdgeCandidates(v, done);
  }
  flushBatch();
}

bool Engine::tryCollapse(const QueuedCollapse& entry, float cost) {
  const EngineState& s = state_;
  gatherNeighbors(entry.from);
  const Neighbor* edge = findEdge(entry.to);
  if (!edge) return false;  // no longer adjacent (cannot happen with valid stamps; defensive)

  CandidateCollapse cand;
  if (!makeCandidate(entry.from, entry.to, *edge, true, edgeFeatures(*edge), cand)) {
    ++stats_.rejected_border;
    ++pass_rejections_;
    return false;
  }
  uint8_t placement = entry.placement;
  if (cand.endpoint_only && placement != kAtTo) {
    // The survivor became pinned since this was priced: price it again where it must go.
    batch_.push_back(cand);
    flushBatch();
    return false;
  }
  cand.cost = cost;
  cand.error = entry.error;
  if (placement == kAtTo)
    cand.position = s.positions[entry.to];
  else if (placement == kAtFrom)
    cand.position = s.positions[entry.from];
  else
    cand.position = {entry.x, entry.y, entry.z};

  if (!applyIfLegal(cand, placement, *edge)) return false;
  invalidateAround(entry.to);
  return true;
}

// The link condition and the flip test (gatherNeighbors(cand.from) must be current), then the
// collapse.
bool Engine::applyIfLegal(CandidateCollapse& cand, uint8_t placement, const Neighbor& edge) {
  if (!linkConditionHolds(cand.from, cand.to, edge)) {
    ++stats_.rejected_topology;
    ++pass_rejections_;
    return false;
  }
  if (flips(cand, placement)) {
    ++stats_.rejected_flip;
    ++pass_rejections_;
    return false;
  }
  applyCollapse(cand, placement);
  return true;
}

// The flip test of both endpoints' triangles (after linkConditionHolds filled to_incident_).
bool Engine::flips(const CandidateCollapse& cand, uint8_t placement) const {
  return flipsOrDegenerates(cand.from, cand.to, cand.position, incident_) ||
         (placement != kAtTo && flipsOrDegenerates(cand.to, cand.from, cand.position, to_incident_));
}

void Engine::runGreedy() {
  auto reached = [&] { return state_.live_triangles <= options_.target_triangles; };
  for (int pass = 0; pass < std::max(1, options_.max_passes) && !reached(); ++pass) {
    pass_rejections_ = 0;
    const size_t collapses_before = stats_.collapses;
    fillQueue();
    while (!queue_.empty() && !reached()) {
      float cost = 0;
      QueuedCollapse entry = queue_.pop(cost);
      if (isStale(entry) || isForbidden(entry, cost)) continue;
      if (!entry.exact && model_.refineBatchSize() > 0) {
        refineTop(entry);
        if (options_.progress) options_.progress(state_.live_triangles);
        continue;
      }
      if (double(entry.error) > options_.target_error) continue;
      if (tryCollapse(entry, cost) && options_.progress) options_.progress(state_.live_triangles);
    }
    // Refilled only when this fill changed the mesh: a fill that applied nothing tried every
    // edge of a mesh the next one would find unchanged (simplify_positions.cpp, runGreedy).
    if (pass_rejections_ == 0 || stats_.collapses == collapses_before) break;
  }
}

// The candidates of one pass into batch_: every live edge once. An edge with a free endpoint is
// interior and manifold (a free position has no feature edge, and collapses keep it so), so it is
// taken from the triangle where it runs from the lower to the higher id, with everything
// makeCandidate would find read off that triangle: only the free end may go, into the other
// end's wedge in that triangle. Edges between two non-free positions (feature lines, corners)
// go through gatherNeighbors + makeCandidate, from their lower end.
void Engine::collectPassCandidates() {
  const EngineState& s = state_;
  batch_.clear();
  // Room for the candidates at once (about 1.5 per triangle at optimal placement; up to two per
  // edge with endpoint placement or borders, when the vector grows once more). Grown by doubling,
  // the first pass's ~100-byte candidates were copied and their fresh pages faulted in at every
  // step (bunny with normals: 11 MB; page faults 2.9% of the samples, then 0.8%, and the
  // reallocation's 0.8% gone). Room reserved and not touched is address space only.
  batch_.reserve(3 * s.live_triangles + 64);
  const size_t triangles = s.triangle_alive.size();
  const VertexKind* kinds = s.kinds.data();
  CandidateCollapse c;
  c.wedge_count = 1;
  for (size_t t = 0; t < triangles; ++t) {
    if (!s.triangle_alive[t]) continue;
    const uint32_t* w = &s.corners[t * 3];
    const uint32_t p[3] = {s.wedge_position[w[0]], s.wedge_position[w[1]],
                           s.wedge_position[w[2]]};
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t k2 = kNextCorner[k];
      const uint32_t a = p[k], b = p[k2];
      if (a > b) continue;
      const bool a_free = kinds[a] == VertexKind::kFree, b_free = kinds[b] == VertexKind::kFree;
      if (!a_free && !b_free) continue;
      if (a_free) {
        c.from = a, c.to = b, c.from_wedges[0] = w[k], c.to_wedges[0] = w[k2];
        c.endpoint_only = options_.endpoint_only || !b_free;
        c.position = s.positions[b];
        batch_.push_back(c);
      }
      // The other direction: needed when b is free and the placement is tied to the survivor.
      if (b_free && (!a_free || options_.endpoint_only)) {
        c.from = b, c.to = a, c.from_wedges[0] = w[k2], c.to_wedges[0] = w[k];
        c.endpoint_only = options_.endpoint_only || !a_free;
        c.position = s.positions[a];
        batch_.push_back(c);
      }
    }
  }
  const uint32_t position_count = uint32_t(s.positions.size());
  CandidateCollapse forward, backward;
  for (uint32_t p = 0; p < position_count; ++p) {
    if (!s.position_alive[p] || kinds[p] == VertexKind::kFree) continue;
    gatherNeighbors(p);
    for (const Neighbor& nb : neighbors_) {
      if (nb.vertex < p || kinds[nb.vertex] == VertexKind::kFree) continue;
      const uint8_t features = edgeFeatures(nb);
      if (makeCandidate(p, nb.vertex, nb, true, features, forward)) batch_.push_back(forward);
      if (makeCandidate(nb.vertex, p, nb, false, features, backward)) batch_.push_back(backward);
    }
  }
}

// One pass-ordered collapse: the priced candidate, checked again against the current topology
// (its endpoints are untouched in this pass, but their neighbours may have moved).
bool Engine::tryPassCollapse(const CandidateCollapse& priced) {
  gatherNeighbors(priced.from);
  const Neighbor* edge = findEdge(priced.to);
  if (!edge) return false;
  CandidateCollapse cand;
  if (!makeCandidate(priced.from, priced.to, *edge, true, edgeFeatures(*edge), cand)) {
    ++stats_.rejected_border;
    return false;
  }
  cand.cost = priced.cost;
  cand.error = priced.error;
  cand.position = cand.endpoint_only ? state_.positions[cand.to] : priced.position;
  if (!linkConditionHolds(cand.from, cand.to, *edge)) {
    ++stats_.rejected_topology;
    return false;
  }
  if (!cand.endpoint_only && !coarse_pass_) {
    const Vec3d priced_position = cand.position;
    const double priced_cost = cand.cost, priced_error = cand.error;
    model_.refinePlacement(state_, cand);
    if (isFinite(cand.position) && (cand.position.x != priced_position.x ||
                                    cand.position.y != priced_position.y ||
                                    cand.position.z != priced_position.z)) {
      const uint8_t placement = placementOf(cand);
      if (!flips(cand, placement)) {
        applyCollapse(cand, placement);
        return true;
      }
    }
    // Not moved, or the better place flips a triangle: where it was priced.
    cand.position = priced_position, cand.cost = priced_cost, cand.error = priced_error;
  }
  const uint8_t placement = placementOf(cand);
  if (flips(cand, placement)) {
    ++stats_.rejected_flip;
    return false;
  }
  applyCollapse(cand, placement);
  return true;
}

void Engine::runPasses() {
  EngineState& s = state_;
  pass_lock_.assign(s.positions.size(), 0);
  // The passes stop short of the target at the coarse end; the greedy queue does the rest.
  const size_t tail = greedyTailTriangles(options_, s.live_triangles);
  const size_t tail_capacity = greedyTailCapacity(options_, s.live_triangles);
  const size_t pass_target = options_.target_triangles > 0 ? options_.target_triangles + tail : 0;
  auto reached = [&] { return s.live_triangles <= pass_target; };
  model_.setPassPricing(true);
  auto cost_bits = [](double cost) {
    float f = std::isfinite(cost) ? float(cost) : std::numeric_limits<float>::max();
    if (!(f >= 0)) f = f < 0 ? 0.0f : std::numeric_limits<float>::max();
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    return bits;
  };
  for (uint32_t pass = 1; !reached(); ++pass) {
    coarse_pass_ = passIsCoarse(s.live_triangles, pass_target);
    collectPassCandidates();
    if (batch_.empty()) break;
    model_.evaluate(s, batch_);
    pass_order_.clear();
    for (uint32_t i = 0; i < batch_.size(); ++i) {
      const CandidateCollapse& c = batch_[i];
      if (!(c.error <= options_.target_error) || !std::isfinite(c.cost)) continue;
      pass_order_.push_back(uint64_t(cost_bits(c.cost)) << 32 | i);
    }
    if (pass_order_.empty()) break;
    ++stats_.passes;
    // Goal: the collapses still needed (each removes about two triangles). Edges up to
    // pass_cost_slack times the goal-rank cost (or the kThinPassRank * goal cheapest, when those
    // are fewer than passCheapPartThin allows) are taken in order; the rest wait for the next
    // pass, unless none of the taken ones could be applied.
    const size_t goal = pass_target > 0 ? (s.live_triangles - pass_target + 1) / 2 : 0;
    auto first_rest = pass_order_.end();
    if (goal > 0 && goal < pass_order_.size()) {
      std::nth_element(pass_order_.begin(), pass_order_.begin() + goal, pass_order_.end());
      float goal_cost;
      const uint32_t goal_bits = uint32_t(pass_order_[goal] >> 32);
      std::memcpy(&goal_cost, &goal_bits, 4);
      const uint64_t limit =
          uint64_t(cost_bits(double(goal_cost) * options_.pass_cost_slack)) << 32 | 0xffffffffu;
      first_rest = std::partition(pass_order_.begin(), pass_order_.end(),
                                  [&](uint64_t key) { return key <= limit; });
      const size_t thin_rank = kThinPassRank * goal;
      if (passCheapPartThin(size_t(first_rest - pass_order_.begin()), goal) &&
          thin_rank < pass_order_.size()) {
        // The kThinPassRank * goal cheapest and their equals in cost (collapse_engine.hpp).
        std::nth_element(pass_order_.begin(), pass_order_.begin() + thin_rank, pass_order_.end());
        const uint64_t thin_limit = pass_order_[thin_rank] | 0xffffffffu;
        first_rest = std::partition(pass_order_.begin(), pass_order_.end(),
                                    [&](uint64_t key) { return key <= thin_limit; });
      }
    }
    std::sort(pass_order_.begin(), first_rest);
    size_t applied = 0;
    auto apply_range = [&](auto begin, auto end) {
      for (auto it = begin; it != end && !reached(); ++it) {
        const CandidateCollapse& c = batch_[uint32_t(*it)];
        if (pass_lock_[c.from] == pass || pass_lock_[c.to] == pass) continue;
        if (!s.position_alive[c.from] || !s.position_alive[c.to]) continue;
        if (!tryPassCollapse(c)) continue;
        pass_lock_[c.from] = pass_lock_[c.to] = pass;
        ++applied;
      }
    };
    apply_range(pass_order_.begin(), first_rest);
    const size_t left = reached() ? 0 : (s.live_triangles - pass_target + 1) / 2;
    if (applied == 0 && first_rest != pass_order_.end()) {
      std::sort(first_rest, pass_order_.end());
      apply_range(first_rest, pass_order_.end());
    } else if (passFinishes(left, goal) && first_rest != pass_order_.end()) {
      // The rest's edges between endpoints this pass left untouched, cheapest first.
      const auto open_end = std::partition(first_rest, pass_order_.end(), [&](uint64_t key) {
        const CandidateCollapse& c = batch_[uint32_t(key)];
        return pass_lock_[c.from] != pass && pass_lock_[c.to] != pass;
      });
      std::sort(first_rest, open_end);
      apply_range(first_rest, open_end);
    }
    if (options_.progress) options_.progress(s.live_triangles);
    if (applied == 0) break;
    const size_t above_target = reached() ? 0 : s.live_triangles - pass_target;
    if (passStalls(applied, goal, above_target, tail_capacity) || passNearsTail(above_target, tail))
      break;
    if (double(applied) < options_.min_pass_yield * double(pass_order_.size())) break;
  }
  batch_.clear();
}

core::Mesh Engine::buildOutput() const {
  const EngineState& s = state_;
  core::Mesh out;
  const size_t wedges = base_.vertexCount();
  std::vector<uint32_t> remap(wedges, kAbsent);
  if (options_.output_wedges) options_.output_wedges->clear();
  if (options_.output_triangles) options_.output_triangles->clear();
  for (size_t t = 0; t < s.triangle_alive.size(); ++t)
    if (s.triangle_alive[t])
      for (int k = 0; k < 3; ++k) remap[s.corners[t * 3 + k]] = 0;
  uint32_t next = 0;
  for (uint32_t w = 0; w < wedges; ++w) {
    if (remap[w] == kAbsent) continue;
    remap[w] = next++;
    appendVertex(out, s.layout, s.asset_positions[s.wedge_position[w]], s.wedgeAttributes(w));
    if (options_.output_wedges) options_.output_wedges->push_back(w);
  }
  out.indices.reserve(s.live_triangles * 3);
  for (size_t t = 0; t < s.triangle_alive.size(); ++t)
    if (s.triangle_alive[t]) {
      for (int k = 0; k < 3; ++k) out.indices.push_back(remap[s.corners[t * 3 + k]]);
      if (options_.output_triangles) options_.output_triangles->push_back(uint32_t(t));
    }
  out.submeshes = base_.submeshes;
  for (core::Submesh& sub : out.submeshes) {
    uint32_t first_triangle = sub.first_index / 3;
    uint32_t live = 0;
    for (uint32_t t = first_triangle; t < first_triangle + sub.index_count / 3; ++t)
      live += s.triangle_alive[t];
    sub.index_count = live * 3;
  }
  uint32_t first = 0;
  for (core::Submesh& sub : out.submeshes) {
    sub.first_index = first;
    first += sub.index_count;
  }
  return out;
}

SimplifyResult Engine::run() {
  auto start = std::chrono::steady_clock::now();
  buildState();
  classifyPositions();
  model_.begin(state_);
  if (options_.record) {
    record_.base = base_;
    record_.values = base_;
    record_.values.indices.clear();
    record_.values.submeshes.clear();
  }

  if (options_.ordering == CollapseOrdering::kPasses && model_.refineBatchSize() == 0 &&
      options_.invalidation_ring <= 1)
    runPasses();
  model_.setPassPricing(false);
  runGreedy();  // all of it, or the tail after the passes

  model_.end(state_);
  SimplifyResult result;
  result.mesh = buildOutput();
  result.error = max_error_;
  result.stats = stats_;
  if (options_.record) result.record = std::move(record_);
  result.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace

void positionBits(core::Vec3 p, uint32_t out[3]) {
  for (int i = 0; i < 3; ++i) {
    float v = p[i] == 0 ? 0.0f : p[i];
    std::memcpy(&out[i], &v, 4);
  }
}

uint32_t positionIds(const std::vector<core::Vec3>& positions, std::vector<uint32_t>& ids) {
  const size_t n = positions.size();
  ids.assign(n, kAbsent);
  std::vector<uint32_t> bits(n * 3);
  for (size_t v = 0; v < n; ++v) positionBits(positions[v], &bits[v * 3]);
  IndexTable table(n);
  std::vector<uint32_t> first_to_id(n, kAbsent);
  uint32_t count = 0;
  for (uint32_t v = 0; v < n; ++v) {
    // One mixing round over the 96 bits (hashWords would mix three times; this runs per vertex).
    const uint32_t* b = &bits[v * 3];
    const uint64_t hash =
        mixHash((uint64_t(b[0]) << 32 | b[1]) ^ (uint64_t(b[2]) * 0x9e3779b97f4a7c15ull));
    uint32_t first = table.findOrInsert(v, hash, [&](uint32_t other) {
      return std::memcmp(&bits[v * 3], &bits[other * 3], 12) == 0;
    });
    if (first == v) first_to_id[v] = count++;
    ids[v] = first_to_id[first];
  }
  return count;
}

bool submeshesTile(const core::Mesh& mesh) {
  const size_t triangles = mesh.indices.size() / 3;
  size_t covered = 0;
  for (const core::Submesh& sub : mesh.submeshes) {
    if (sub.first_index != covered || sub.index_count % 3 != 0 ||
        size_t(sub.first_index) + sub.index_count > triangles * 3)
      return false;
    covered += sub.index_count;
  }
  return !mesh.submeshes.empty() && covered == triangles * 3;
}

core::Mesh prepareMesh(const core::Mesh& mesh) { return prepareMeshWithPositions(mesh).mesh; }

PreparedMesh prepareMeshWithPositions(const core::Mesh& mesh) {
  const size_t n = mesh.vertexCount();
  const AttributeLayout layout = attributeLayout(mesh);
  std::vector<uint32_t> position_id;
  const uint32_t input_position_count = positionIds(mesh.positions, position_id);

  // Wedges: equal position id and bitwise-equal attributes. Without attributes that is the first
  // vertex of each position id, no hashing needed.
  std::vector<uint32_t> representative(n);
  if (layout.stride == 0) {
    std::vector<uint32_t> first_of_id(input_position_count, kAbsent);
    for (uint32_t v = 0; v < n; ++v) {
      uint32_t& first = first_of_id[position_id[v]];
      if (first == kAbsent) first = v;
      representative[v] = first;
    }
  } else {
    const std::vector<float> packed = packAttributes(mesh, layout);
    IndexTable table(n);
    const uint32_t stride = layout.stride;
    for (uint32_t v = 0; v < n; ++v) {
      const float* a = packed.data() + size_t(v) * stride;
      uint64_t h = hashWords(reinterpret_cast<const uint32_t*>(a), stride, position_id[v]);
      representative[v] = table.findOrInsert(v, h, [&](uint32_t other) {
        return position_id[other] == position_id[v] &&
               std::memcmp(a, packed.data() + size_t(other) * stride, stride * 4) == 0;
      });
    }
  }

  // Triangles: drop out-of-range, repeated-position and duplicate ones, keep order.
  bool groups_valid = false;
  std::vector<uint32_t> groups = triangleGroups(mesh, groups_valid);
  const size_t triangles = mesh.indices.size() / 3;
  // First the proper triangles (in range, three distinct positions), each with its position
  // triple rotated so that the lowest id comes first (same orientation); written through raw
  // pointers into room for every triangle and cut to size afterwards.
  std::vector<uint32_t> kept_indices(triangles * 3);
  std::vector<uint32_t> kept_keys(triangles * 3);
  std::vector<uint32_t> kept_groups(triangles);
  uint32_t* const kept_index_out = kept_indices.data();
  uint32_t* const keys = kept_keys.data();
  const uint32_t* const in = mesh.indices.data();
  uint32_t proper = 0;
  for (size_t t = 0; t < triangles; ++t) {
    uint32_t v[3], p[3];
    bool in_range = true;
    for (int k = 0; k < 3; ++k) {
      uint32_t index = in[t * 3 + k];
      in_range &= index < n;
      v[k] = in_range ? representative[index] : 0;
      p[k] = in_range ? position_id[v[k]] : 0;
    }
    if (!in_range || p[0] == p[1] || p[1] == p[2] || p[0] == p[2]) continue;
    int first = p[0] < p[1] ? (p[0] < p[2] ? 0 : 2) : (p[1] < p[2] ? 1 : 2);
    uint32_t* key = keys + size_t(proper) * 3;
    key[0] = p[first], key[1] = p[(first + 1) % 3], key[2] = p[(first + 2) % 3];
    for (int k = 0; k < 3; ++k) kept_index_out[size_t(proper) * 3 + k] = v[k];
    kept_groups[proper] = groups[t];
    ++proper;
  }
  // Duplicates share their lowest position id: bucket the triangles by it (a counting sort, stable,
  // so each bucket lists its triangles in input order) and compare within buckets, a few
  // triangles each. This replaced a hash table of the keys, whose probes missed the cache on
  // every triangle of a large mesh.
  std::vector<uint8_t> duplicate(proper, 0);
  {
    std::vector<uint32_t> bucket_start(size_t(input_position_count) + 1, 0);
    for (uint32_t t = 0; t < proper; ++t) ++bucket_start[keys[size_t(t) * 3] + 1];
    for (uint32_t i = 0; i < input_position_count; ++i) bucket_start[i + 1] += bucket_start[i];
    std::vector<uint32_t> members(proper), cursor(bucket_start.begin(), bucket_start.end() - 1);
    for (uint32_t t = 0; t < proper; ++t) members[cursor[keys[size_t(t) * 3]]++] = t;
    for (uint32_t b = 0; b < input_position_count; ++b)
      for (uint32_t i = bucket_start[b] + 1; i < bucket_start[b + 1]; ++i) {
        const uint32_t* key = keys + size_t(members[i]) * 3;
        for (uint32_t j = bucket_start[b]; j < i; ++j) {
          const uint32_t* earlier = keys + size_t(members[j]) * 3;
          if (key[1] == earlier[1] && key[2] == earlier[2]) {
            duplicate[members[i]] = 1;
            break;
          }
        }
      }
  }
  uint32_t kept = 0;
  for (uint32_t t = 0; t < proper; ++t) {
    if (duplicate[t]) continue;
    if (kept != t) {
      for (int k = 0; k < 3; ++k)
        kept_index_out[size_t(kept) * 3 + k] = kept_index_out[size_t(t) * 3 + k];
      kept_groups[kept] = kept_groups[t];
    }
    ++kept;
  }
  kept_indices.resize(size_t(kept) * 3);
  kept_groups.resize(kept);

  // Referenced vertices, in their original order, copied stream by stream.
  std::vector<uint32_t> remap(n, kAbsent);
  for (uint32_t v : kept_indices) remap[v] = 0;
  std::vector<uint32_t> kept_vertices;
  kept_vertices.reserve(n);
  for (uint32_t v = 0; v < n; ++v) {
    if (remap[v] == kAbsent) continue;
    remap[v] = uint32_t(kept_vertices.size());
    kept_vertices.push_back(v);
  }
  PreparedMesh prepared;
  core::Mesh& out = prepared.mesh;
  // Position ids of the kept vertices, renumbered densely in order of first use.
  {
    std::vector<uint32_t> dense(input_position_count, kAbsent);
    prepared.position_ids.resize(kept_vertices.size());
    for (size_t i = 0; i < kept_vertices.size(); ++i) {
      uint32_t& id = dense[position_id[kept_vertices[i]]];
      if (id == kAbsent) id = prepared.position_count++;
      prepared.position_ids[i] = id;
    }
  }
  auto copy_stream = [&](auto& to, const auto& from, uint32_t offset) {
    if (offset == kAbsent) return;
    to.resize(kept_vertices.size());
    for (size_t i = 0; i < kept_vertices.size(); ++i) to[i] = from[kept_vertices[i]];
  };
  copy_stream(out.positions, mesh.positions, 0);
  copy_stream(out.normals, mesh.normals, layout.normal);
  copy_stream(out.tangents, mesh.tangents, layout.tangent);
  copy_stream(out.uv0, mesh.uv0, layout.uv0);
  copy_stream(out.uv1, mesh.uv1, layout.uv1);
  copy_stream(out.colors, mesh.colors, layout.color);
  out.indices.resize(kept_indices.size());
  for (size_t i = 0; i < kept_indices.size(); ++i) out.indices[i] = remap[kept_indices[i]];

  if (groups_valid) {
    out.submeshes = mesh.submeshes;
    std::vector<uint32_t> counts(mesh.submeshes.size(), 0);
    for (uint32_t g : kept_groups) ++counts[g];
    uint32_t first = 0;
    for (size_t s = 0; s < out.submeshes.size(); ++s) {
      out.submeshes[s].first_index = first;
      out.submeshes[s].index_count = counts[s] * 3;
      first += counts[s] * 3;
    }
  } else {  // no usable submesh list: one submesh over everything keeps the output valid
    uint32_t material = mesh.submeshes.empty() ? 0 : mesh.submeshes[0].material;
    out.submeshes = {{0, uint32_t(out.indices.size()), material}};
  }
  return prepared;
}

SimplifyResult runCollapseEngine(const core::Mesh& prepared, CostModel& model,
                                 const EngineOptions& options) {
  Engine engine(prepared, nullptr, 0, model, options);
  return engine.run();
}

SimplifyResult runCollapseEngine(const PreparedMesh& prepared, CostModel& model,
                                 const EngineOptions& options) {
  Engine engine(prepared.mesh, &prepared.position_ids, prepared.position_count, model, options);
  return engine.run();
}

}  // namespace duolod::mesh
