// Position-only fast path of simplifyQuadric. The algorithm is the collapse engine's pass ordering
// (collapse_engine.hpp, kPasses; Garland & Heckbert 1997 quadrics, the link condition of Dey,
// Edelsbrunner et al. 1999, the flip test, borders sliding along themselves), the data layout is
// built for it instead of for the general engine (attributes, seams, materials, lazy costs):
//   - vertices are positions (prepareMesh welds a position-only mesh to one vertex per position),
//     so there are no wedges, and vertex ids are the prepared mesh's;
//   - the index buffer is compacted at the start of every pass, and adjacency is rebuilt from it
//     as a flat vertex -> corner table (a counting sort, no lists, no unlinking);
//   - within a pass every vertex takes part in at most one collapse, so a collapse `from` -> `to`
//     is a one-level remap (remap[from] = to) read when triangles are walked, and the triangles on
//     the edge are flagged dead; a collapse's endpoints were untouched in this pass, so their
//     corner tables are exact (up to the remap and the dead flags);
//   - vertex kinds (free, on a border line, locked) are found once: collapses keep them, and a
//     border vertex keeps its two border neighbours, updated when the border collapses;
//   - candidates are read off the triangles (free endpoints) and the border neighbours, priced at
//     the best of the endpoints and the midpoint, and the optimal placement is solved only for the
//     collapses applied (as CostModel::refinePlacement does).
// The last collapses (EngineOptions::greedy_tail_triangles, at most 1/16 of the input) go to the
// general engine's greedy queue on the compacted mesh, with the accumulated quadrics, the same
// normalized frame and the same locked vertices, so the result is the engine's algorithm.
#include "mesh/simplify_positions.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <limits>

#include "mesh/attributes.hpp"
#include "mesh/quadric.hpp"

namespace duolod::mesh {
namespace {

constexpr uint32_t kNext[3] = {1, 2, 0};
constexpr uint32_t kPrevious[3] = {2, 0, 1};

// A pass candidate: `from` collapses into `to`; the survivor goes to the fixed point `at`
// (quadric.hpp) unless the optimal placement is better when it is applied.
struct PassCandidate {
  uint32_t from, to;
  double cost;
  float error;
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

class PositionSimplifier {
 public:
  PositionSimplifier(const PreparedMesh& prepared, const SimplifyOptions& options)
      : base_(prepared.mesh), options_(options) {}
  SimplifyResult run();

 private:
  void setUp();
  void buildAdjacency();
  void classify();
  void compact();
  void pushCandidate(uint32_t from, uint32_t to, bool endpoint_only);
  void collectCandidates();
  bool tryCollapse(const PassCandidate& candidate, uint32_t pass);
  bool fanFlips(const std::vector<uint32_t>& fan, Vec3d corner, Vec3d moved) const;
  void applyCollapse(uint32_t from, uint32_t to, Vec3d position, double cost, uint32_t pass);
  SimplifyResult finish();
  uint32_t nextRound() {
    if (++round_ == 0) {
      std::fill(mark_.begin(), mark_.end(), 0);
      round_ = 1;
    }
    return round_;
  }
  // Errors in asset units: the root mean squared distance of the merged quadric.
  double errorOf(double cost, double weight) const {
    return std::sqrt(std::max(cost, 0.0) / (weight > 0 ? weight : 1.0)) * scale_;
  }

  const core::Mesh& base_;
  SimplifyOptions options_;
  uint32_t vertex_count_ = 0;
  Vec3d origin_;
  double scale_ = 1;

  std::vector<Vec3d> positions_;           // normalized (bounding-box diagonal 1)
  std::vector<core::Vec3> asset_positions_;  // asset units, exact while unmoved
  std::vector<Quadric> quadrics_;
  std::vector<VertexKind> kinds_;
  std::vector<uint32_t> border_neighbors_;  // two per constrained vertex
  std::vector<uint32_t> constrained_;       // the constrained vertices
  std::vector<uint32_t> remap_;             // survivor of a vertex collapsed in this pass
  std::vector<uint8_t> alive_;
  std::vector<uint32_t> pass_lock_;         // the pass that last touched a vertex

  std::vector<uint32_t> indices_;           // live triangles, compacted at the start of a pass
  std::vector<uint8_t> dead_;               // per triangle of indices_: collapsed in this pass
  size_t live_triangles_ = 0;
  std::vector<uint32_t> corner_start_;      // per vertex, into corners_ (vertex_count_ + 1)
  std::vector<uint32_t> corners_;           // corners (3 * triangle + k) grouped by vertex
  std::vector<uint32_t> cursor_;

  std::vector<PassCandidate> candidates_;
  std::vector<uint64_t> order_;             // (cost bits << 32 | candidate index)
  std::vector<uint32_t> mark_;
  uint32_t round_ = 0;
  std::vector<uint32_t> from_fan_, to_fan_;  // the other two corners of each moving triangle
  uint32_t edge_triangles_[2] = {kAbsent, kAbsent};
  uint32_t edge_triangle_count_ = 0;

  SimplifyStats stats_;
  double max_error_ = 0;
  ProgressiveRecord record_;
};

void PositionSimplifier::setUp() {
  const core::Mesh& m = base_;
  vertex_count_ = uint32_t(m.vertexCount());
  core::Bounds bounds;
  for (core::Vec3 p : m.positions) bounds.extend(p);
  if (!bounds.empty()) {  // the engine's frame: origin at the box minimum, diagonal 1
    origin_ = {bounds.min.x, bounds.min.y, bounds.min.z};
    const core::Vec3 size = bounds.size();
    const double diagonal = std::sqrt(double(size.x) * size.x + double(size.y) * size.y +
                                      double(size.z) * size.z);
    scale_ = diagonal > 0 && std::isfinite(diagonal) ? diagonal : 1.0;
  }
  const double inverse_scale = 1.0 / scale_;
  asset_positions_ = m.positions;
  positions_.resize(vertex_count_);
  for (uint32_t v = 0; v < vertex_count_; ++v) {
    const core::Vec3 a = m.positions[v];
    positions_[v] = {(a.x - origin_.x) * inverse_scale, (a.y - origin_.y) * inverse_scale,
                     (a.z - origin_.z) * inverse_scale};
  }
  indices_ = m.indices;
  live_triangles_ = indices_.size() / 3;
  remap_.resize(vertex_count_);
  for (uint32_t v = 0; v < vertex_count_; ++v) remap_[v] = v;
  alive_.assign(vertex_count_, 1);
  pass_lock_.assign(vertex_count_, 0);
  mark_.assign(vertex_count_, 0);
  cursor_.resize(vertex_count_);

  // Area-weighted plane quadrics (Garland & Heckbert 1997 eq. 2).
  quadrics_.assign(vertex_count_, Quadric{});
  for (size_t t = 0; t < live_triangles_; ++t) {
    const uint32_t* v = &indices_[t * 3];
    Quadric plane;
    if (!triangleQuadric(positions_[v[0]], positions_[v[1]], positions_[v[2]], plane)) continue;
    for (int k = 0; k < 3; ++k) addQuadric(quadrics_[v[k]], plane);
  }
}

// The vertex -> corner table of indices_ (counting sort; corners of a vertex in triangle order).
void PositionSimplifier::buildAdjacency() {
  corner_start_.assign(vertex_count_ + 1, 0);
  for (uint32_t v : indices_) ++corner_start_[v + 1];
  for (uint32_t v = 0; v < vertex_count_; ++v) corner_start_[v + 1] += corner_start_[v];
  std::copy_n(corner_start_.begin(), vertex_count_, cursor_.begin());
  corners_.resize(indices_.size());
  const uint32_t corner_count = uint32_t(indices_.size());
  for (uint32_t c = 0; c < corner_count; ++c) corners_[cursor_[indices_[c]]++] = c;
  dead_.assign(indices_.size() / 3, 0);
}

// Vertex kinds as the engine's classifyPositions finds them for a position-only mesh with one
// submesh: free (no feature edge), constrained (exactly two border edges, not a corner), locked
// (non-manifold edge or fan, corner, line end or junction, lock_border); plus the penalty planes
// of the feature edges.
void PositionSimplifier::classify() {
  kinds_.assign(vertex_count_, VertexKind::kLocked);
  border_neighbors_.assign(size_t(vertex_count_) * 2, kAbsent);
  struct Neighbor {
    uint32_t vertex;
    uint32_t outgoing, incoming;  // triangles where the edge runs v -> n, n -> v
    uint32_t local[2];            // the first two of them, as indices into v's corners
  };
  std::vector<Neighbor> neighbors;
  std::vector<uint32_t> slot(vertex_count_, kAbsent), union_find;
  for (uint32_t v = 0; v < vertex_count_; ++v) {
    const uint32_t begin = corner_start_[v], degree = corner_start_[v + 1] - begin;
    if (degree == 0) continue;
    neighbors.clear();
    auto add = [&](uint32_t n, bool outgoing, uint32_t local) {
      if (slot[n] == kAbsent) {
        slot[n] = uint32_t(neighbors.size());
        neighbors.push_back({n, 0, 0, {local, kAbsent}});
      } else {
        Neighbor& nb = neighbors[slot[n]];
        if (nb.outgoing + nb.incoming == 1) nb.local[1] = local;
      }
      Neighbor& nb = neighbors[slot[n]];
      (outgoing ? nb.outgoing : nb.incoming) += 1;
    };
    for (uint32_t i = 0; i < degree; ++i) {
      const uint32_t c = corners_[begin + i], t = c / 3, k = c - t * 3;
      add(indices_[t * 3 + kNext[k]], true, i);
      add(indices_[t * 3 + kPrevious[k]], false, i);
    }
    for (const Neighbor& nb : neighbors) slot[nb.vertex] = kAbsent;

    union_find.resize(degree);
    for (uint32_t i = 0; i < degree; ++i) union_find[i] = i;
    auto find = [&](uint32_t i) {
      while (union_find[i] != i) i = union_find[i] = union_find[union_find[i]];
      return i;
    };
    bool locked = false;
    uint32_t feature_count = 0;
    uint32_t line[2] = {kAbsent, kAbsent};
    for (const Neighbor& nb : neighbors) {
      const uint32_t count = nb.outgoing + nb.incoming;
      if (count == 2) union_find[find(nb.local[0])] = find(nb.local[1]);
      if (count == 2 && nb.outgoing == 1) continue;  // manifold, consistently oriented
      const bool border = count == 1;
      if (!border || options_.lock_border) locked = true;
      if (feature_count < 2) line[feature_count] = nb.vertex;
      ++feature_count;
      if (nb.vertex < v) continue;
      // Penalty plane of the feature edge (once, from its lower end).
      Vec3d face_normal{0, 0, 0};
      for (uint32_t i = 0; i < std::min(count, 2u); ++i) {
        const uint32_t t = corners_[begin + nb.local[i]] / 3;
        face_normal = face_normal + unitTriangleNormal(positions_[indices_[t * 3]],
                                                       positions_[indices_[t * 3 + 1]],
                                                       positions_[indices_[t * 3 + 2]]);
      }
      Quadric plane;
      if (featureEdgeQuadric(positions_[v], positions_[nb.vertex], face_normal, plane)) {
        addQuadric(quadrics_[v], plane);
        addQuadric(quadrics_[nb.vertex], plane);
      }
    }
    uint32_t fans = 0;
    for (uint32_t i = 0; i < degree; ++i) fans += find(i) == i;
    if (locked || fans > 1) continue;
    if (feature_count == 0) {
      kinds_[v] = VertexKind::kFree;
    } else if (feature_count == 2 &&
               !isLineCorner(positions_[line[0]], positions_[v], positions_[line[1]])) {
      kinds_[v] = VertexKind::kConstrained;
      border_neighbors_[v * 2] = line[0];
      border_neighbors_[v * 2 + 1] = line[1];
      constrained_.push_back(v);
    }
  }
}

// Applies this pass's collapses to the index buffer and drops the dead triangles.
void PositionSimplifier::compact() {
  size_t out = 0;
  const size_t triangles = indices_.size() / 3;
  for (size_t t = 0; t < triangles; ++t) {
    if (dead_[t]) continue;
    for (int k = 0; k < 3; ++k) indices_[out + k] = remap_[indices_[t * 3 + k]];
    out += 3;
  }
  indices_.resize(out);
}

void PositionSimplifier::pushCandidate(uint32_t from, uint32_t to, bool endpoint_only) {
  Quadric q = quadrics_[from];
  addQuadric(q, quadrics_[to]);
  PassCandidate c{from, to, 0, 0, kFixedAtB, endpoint_only};
  c.cost = endpoint_only ? evaluateQuadric(q, positions_[to])
                         : priceAtFixedPoints(q, positions_[from], positions_[to], c.at);
  // The error is needed here only to hold an error target; applied collapses compute their own.
  if (std::isfinite(options_.target_error)) c.error = float(errorOf(c.cost, q.weight));
  candidates_.push_back(c);
}

// Every live edge once: an edge with a free endpoint is interior and manifold (a free vertex has
// no feature edge, and collapses keep it so), taken from the triangle where it runs from the
// lower to the higher id; only a free end may go, and it goes to the other end exactly when that
// one is not free. Border edges come from the constrained vertices' border neighbours: between
// two constrained vertices either may go (free placement, priced once), into a locked one only
// the constrained end, to the locked end exactly. Edges between two non-free vertices that are not
// border edges never collapse (a constrained vertex only slides along its line).
void PositionSimplifier::collectCandidates() {
  candidates_.clear();
  const size_t triangles = indices_.size() / 3;
  const VertexKind* kinds = kinds_.data();
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t* v = &indices_[t * 3];
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[kNext[k]];
      if (a > b) continue;
      const bool a_free = kinds[a] == VertexKind::kFree, b_free = kinds[b] == VertexKind::kFree;
      if (a_free)
        pushCandidate(a, b, !b_free);
      else if (b_free)
        pushCandidate(b, a, true);
    }
  }
  for (uint32_t v : constrained_) {
    if (!alive_[v]) continue;
    for (int i = 0; i < 2; ++i) {
      const uint32_t n = border_neighbors_[v * 2 + i];
      if (kinds[n] == VertexKind::kLocked)
        pushCandidate(v, n, true);
      else if (v < n)
        pushCandidate(v, n, false);
    }
  }
}

bool PositionSimplifier::fanFlips(const std::vector<uint32_t>& fan, Vec3d corner,
                                  Vec3d moved) const {
  for (size_t i = 0; i < fan.size(); i += 2)
    if (turnsOverOrFlattens(corner, positions_[fan[i]], positions_[fan[i + 1]], moved))
      return true;
  return false;
}

// The collapse of one priced candidate, checked against the current topology (its endpoints are
// untouched in this pass, but their neighbours may have moved): the link condition, then the
// optimal placement if it beats the priced point without turning a triangle over, else the
// priced point, then the flip test.
bool PositionSimplifier::tryCollapse(const PassCandidate& candidate, uint32_t pass) {
  const uint32_t from = candidate.from, to = candidate.to;
  const uint32_t* indices = indices_.data();
  const uint32_t* remap = remap_.data();
  uint32_t* mark = mark_.data();

  // from's triangles: the ones on the edge (they die), the others (they move); mark from's
  // neighbours.
  const uint32_t near_round = nextRound();
  from_fan_.clear();
  edge_triangle_count_ = 0;
  uint32_t opposite[2] = {kAbsent, kAbsent};
  for (uint32_t i = corner_start_[from]; i < corner_start_[from + 1]; ++i) {
    const uint32_t c = corners_[i], t = c / 3, k = c - t * 3;
    if (dead_[t]) continue;
    const uint32_t b = remap[indices[t * 3 + kNext[k]]], d = remap[indices[t * 3 + kPrevious[k]]];
    mark[b] = mark[d] = near_round;
    if (b == to || d == to) {
      if (edge_triangle_count_ < 2) {
        opposite[edge_triangle_count_] = b == to ? d : b;
        edge_triangles_[edge_triangle_count_] = t;
      }
      ++edge_triangle_count_;
      continue;
    }
    from_fan_.push_back(b);
    from_fan_.push_back(d);
  }
  const uint32_t edge_count = edge_triangle_count_;
  if (edge_count == 0 || edge_count > 2 || (edge_count == 2 && opposite[0] == opposite[1])) {
    ++stats_.rejected_topology;
    return false;
  }
  // Link condition (Dey, Edelsbrunner et al. 1999): the common neighbours of the endpoints are
  // exactly the edge's opposite vertices; and no duplicate triangle may appear (a tetrahedron
  // where (from, o1, o2) and (to, o1, o2) both exist).
  bool from_has_opposite_pair = false;
  if (edge_count == 2)
    for (size_t i = 0; i < from_fan_.size(); i += 2) {
      const uint32_t b = from_fan_[i], d = from_fan_[i + 1];
      from_has_opposite_pair |= (b == opposite[0] && d == opposite[1]) ||
                                (b == opposite[1] && d == opposite[0]);
    }
  const uint32_t counted_round = nextRound();
  uint32_t common = 0;
  bool duplicate = false;
  to_fan_.clear();
  for (uint32_t i = corner_start_[to]; i < corner_start_[to + 1]; ++i) {
    const uint32_t c = corners_[i], t = c / 3, k = c - t * 3;
    if (dead_[t]) continue;
    const uint32_t x = remap[indices[t * 3 + kNext[k]]], y = remap[indices[t * 3 + kPrevious[k]]];
    const bool on_edge = x == from || y == from;
    for (uint32_t n : {x, y}) {
      if (n != from && mark[n] == near_round) {
        mark[n] = counted_round;
        ++common;
      }
    }
    if (on_edge) continue;
    if (from_has_opposite_pair && ((x == opposite[0] && y == opposite[1]) ||
                                   (x == opposite[1] && y == opposite[0])))
      duplicate = true;
    to_fan_.push_back(x);
    to_fan_.push_back(y);
  }
  if (common != edge_count || duplicate) {
    ++stats_.rejected_topology;
    return false;
  }

  const Vec3d at_from = positions_[from], at_to = positions_[to];
  auto flips = [&](Vec3d p) {
    const bool moves_to = p.x != at_to.x || p.y != at_to.y || p.z != at_to.z;
    return fanFlips(from_fan_, at_from, p) || (moves_to && fanFlips(to_fan_, at_to, p));
  };
  const Vec3d priced = candidate.endpoint_only ? at_to
                                               : fixedPoint(at_from, at_to, candidate.at);
  if (!candidate.endpoint_only) {
    Quadric q = quadrics_[from];
    addQuadric(q, quadrics_[to]);
    double value = 0;
    const Vec3d best = minimizeQuadric(q, at_from, at_to, &value);
    const bool moved = best.x != priced.x || best.y != priced.y || best.z != priced.z;
    if (value < candidate.cost && moved && std::isfinite(best.x) && std::isfinite(best.y) &&
        std::isfinite(best.z) && !flips(best)) {
      applyCollapse(from, to, best, value, pass);
      return true;
    }
  }
  if (flips(priced)) {
    ++stats_.rejected_flip;
    return false;
  }
  applyCollapse(from, to, priced, candidate.cost, pass);
  return true;
}

void PositionSimplifier::applyCollapse(uint32_t from, uint32_t to, Vec3d position, double cost,
                                       uint32_t pass) {
  for (uint32_t i = 0; i < edge_triangle_count_; ++i) dead_[edge_triangles_[i]] = 1;
  live_triangles_ -= edge_triangle_count_;
  remap_[from] = to;
  alive_[from] = 0;
  pass_lock_[from] = pass_lock_[to] = pass;
  addQuadric(quadrics_[to], quadrics_[from]);
  const Vec3d at_to = positions_[to], at_from = positions_[from];
  if (position.x != at_to.x || position.y != at_to.y || position.z != at_to.z) {
    positions_[to] = position;
    if (position.x == at_from.x && position.y == at_from.y && position.z == at_from.z) {
      asset_positions_[to] = asset_positions_[from];
    } else {
      const Vec3d a = origin_ + position * scale_;
      asset_positions_[to] = {float(a.x), float(a.y), float(a.z)};
    }
  }
  // A border collapse: from's other border neighbour now borders on `to`.
  if (kinds_[from] == VertexKind::kConstrained) {
    const uint32_t* line = &border_neighbors_[from * 2];
    const uint32_t other = line[0] == to ? line[1] : line[0];
    auto replace = [&](uint32_t v, uint32_t old_neighbor, uint32_t new_neighbor) {
      if (kinds_[v] != VertexKind::kConstrained) return;
      for (int i = 0; i < 2; ++i)
        if (border_neighbors_[v * 2 + i] == old_neighbor) border_neighbors_[v * 2 + i] = new_neighbor;
    };
    replace(other, from, to);
    replace(to, from, other);
  }

  const double error = errorOf(cost, quadrics_[to].weight);
  max_error_ = std::max(max_error_, error);
  ++stats_.collapses;
  if (options_.record) {
    CollapseStep step;
    step.removed = from;
    step.kept = to;
    step.kept_value = uint32_t(record_.values.positions.size());
    step.triangles_after = uint32_t(live_triangles_);
    step.error = float(error);
    step.cumulative_error = float(max_error_);
    record_.steps.push_back(step);
    record_.values.positions.push_back(asset_positions_[to]);
  }
}

// The mesh as it is (no tail needed), or the greedy tail by the general engine.
SimplifyResult PositionSimplifier::finish() {
  SimplifyResult result;
  const bool reached = options_.target_triangles > 0 && live_triangles_ <= options_.target_triangles;
  // The compacted mesh: referenced vertices in id order, triangles in order.
  std::vector<uint32_t> compact_id(vertex_count_, kAbsent);
  for (uint32_t v : indices_) compact_id[v] = 0;
  std::vector<uint32_t> original_id;
  PreparedMesh current;
  core::Mesh& mesh = current.mesh;
  for (uint32_t v = 0; v < vertex_count_; ++v) {
    if (compact_id[v] == kAbsent) continue;
    compact_id[v] = uint32_t(original_id.size());
    original_id.push_back(v);
    mesh.positions.push_back(asset_positions_[v]);
  }
  mesh.indices.resize(indices_.size());
  for (size_t i = 0; i < indices_.size(); ++i) mesh.indices[i] = compact_id[indices_[i]];
  const uint32_t material = base_.submeshes.empty() ? 0 : base_.submeshes[0].material;
  mesh.submeshes = {{0, uint32_t(mesh.indices.size()), material}};
  result.stats = stats_;
  result.error = max_error_;
  if (reached || mesh.indices.empty()) {
    result.mesh = std::move(mesh);
    if (options_.record) result.record = std::move(record_);
    return result;
  }

  current.position_count = uint32_t(original_id.size());
  current.position_ids.resize(original_id.size());
  std::vector<Quadric> quadrics(original_id.size());
  std::vector<uint8_t> locked(original_id.size());
  for (uint32_t i = 0; i < original_id.size(); ++i) {
    current.position_ids[i] = i;
    quadrics[i] = quadrics_[original_id[i]];
    locked[i] = kinds_[original_id[i]] == VertexKind::kLocked;
  }
  QuadricModel model({.endpoint_only = false,
                      .price_at_fixed_points = false,
                      .attribute_weight = options_.attribute_weight,
                      .initial_quadrics = &quadrics});
  EngineOptions engine_options{
      .target_triangles = options_.target_triangles,
      .target_error = options_.target_error,
      .lock_border = options_.lock_border,
      .record = options_.record,
      .ordering = CollapseOrdering::kGreedy,
      .given_frame = true,
      .frame_origin = origin_,
      .frame_scale = scale_,
      .locked_vertices = &locked,
  };
  SimplifyResult tail = runCollapseEngine(current, model, engine_options);
  result.mesh = std::move(tail.mesh);
  result.error = std::max(result.error, tail.error);
  result.stats.collapses += tail.stats.collapses;
  result.stats.rejected_topology += tail.stats.rejected_topology;
  result.stats.rejected_flip += tail.stats.rejected_flip;
  result.stats.rejected_border += tail.stats.rejected_border;
  if (options_.record) {
    // The tail's record is over the compacted mesh: back to the base's vertex ids and values.
    const uint32_t tail_base = uint32_t(current.mesh.vertexCount());
    const uint32_t offset = uint32_t(record_.values.positions.size());
    for (CollapseStep step : tail.record.steps) {
      step.removed = original_id[step.removed];
      step.kept = original_id[step.kept];
      step.kept_value = offset + (step.kept_value - tail_base);
      step.cumulative_error = std::max(step.cumulative_error, float(max_error_));
      record_.steps.push_back(step);
    }
    const auto& values = tail.record.values.positions;
    record_.values.positions.insert(record_.values.positions.end(), values.begin() + tail_base,
                                    values.end());
    result.record = std::move(record_);
  }
  return result;
}

SimplifyResult PositionSimplifier::run() {
  setUp();
  buildAdjacency();
  classify();
  if (options_.record) {
    record_.base = base_;
    record_.values.positions = base_.positions;
  }
  EngineOptions defaults;
  size_t tail = std::min(defaults.greedy_tail_triangles, live_triangles_ / 16);
  if (const char* e = std::getenv("DUOLOD_TAIL")) tail = std::min<size_t>(std::atoi(e), tail);  // EXPERIMENT
  const size_t pass_target = options_.target_triangles > 0 ? options_.target_triangles + tail : 0;
  auto reached = [&] { return live_triangles_ <= pass_target; };
  for (uint32_t pass = 1; !reached(); ++pass) {
    if (pass > 1) {
      compact();
      buildAdjacency();
    }
    collectCandidates();
    order_.clear();
    for (uint32_t i = 0; i < candidates_.size(); ++i) {
      const PassCandidate& c = candidates_[i];
      if (!(c.error <= options_.target_error) || !std::isfinite(c.cost)) continue;
      order_.push_back(uint64_t(costBits(c.cost)) << 32 | i);
    }
    if (order_.empty()) break;
    // As the engine's runPasses: the collapses still needed (about two triangles each) set the
    // goal rank; edges up to pass_cost_slack times its cost are applied in order, the rest wait
    // for the next pass unless none of the cheap ones could be applied.
    const size_t goal = pass_target > 0 ? (live_triangles_ - pass_target + 1) / 2 : 0;
    auto first_rest = order_.end();
    if (goal > 0 && goal < order_.size()) {
      std::nth_element(order_.begin(), order_.begin() + goal, order_.end());
      float goal_cost;
      const uint32_t goal_bits = uint32_t(order_[goal] >> 32);
      std::memcpy(&goal_cost, &goal_bits, 4);
      const uint64_t limit =
          uint64_t(costBits(double(goal_cost) * defaults.pass_cost_slack)) << 32 | 0xffffffffu;
      first_rest = std::partition(order_.begin(), order_.end(),
                                  [&](uint64_t key) { return key <= limit; });
    }
    std::sort(order_.begin(), first_rest);
    size_t applied = 0;
    auto apply_range = [&](auto begin, auto end) {
      for (auto it = begin; it != end && !reached(); ++it) {
        const PassCandidate& c = candidates_[uint32_t(*it)];
        if (pass_lock_[c.from] == pass || pass_lock_[c.to] == pass) continue;
        if (tryCollapse(c, pass)) ++applied;
      }
    };
    apply_range(order_.begin(), first_rest);
    if (applied == 0 && first_rest != order_.end()) {
      std::sort(first_rest, order_.end());
      apply_range(first_rest, order_.end());
    }
    if (applied == 0) break;
  }
  compact();
  return finish();
}

}  // namespace

bool positionFastPathApplies(const PreparedMesh& prepared, const SimplifyOptions& options) {
  const core::Mesh& m = prepared.mesh;
  if (options.placement != Placement::kOptimal || attributeLayout(m).stride != 0 ||
      m.submeshes.size() != 1 || m.vertexCount() >= kAbsent / 2)
    return false;
  for (core::Vec3 p : m.positions)
    if (!core::isFinite(p)) return false;
  return true;
}

SimplifyResult simplifyPositions(const PreparedMesh& prepared, const SimplifyOptions& options) {
  PositionSimplifier simplifier(prepared, options);
  return simplifier.run();
}

}  // namespace duolod::mesh
