// simplifyQuadric: the collapse engine driven by the quadric cost (quadric.hpp). The fast mode and
// the geometric baseline of the paper's mesh simplification (§4.2 uses the same engine with an
// image-driven cost). Pass ordering, then the greedy queue for the last collapses
// (collapse_engine.hpp). Position-only meshes price at fixed points (the optimal placement solved
// only for the collapses applied) and run in the position-only fast path (simplify_positions.hpp)
// when it applies; meshes with attributes price every candidate at its optimal placement, and
// large ones run in spatial order (orderSpatially).
#include <chrono>
#include <cmath>
#include <numeric>
#include <span>

#include "duolod/mesh.hpp"
#include "mesh/collapse_engine.hpp"
#include "mesh/quadric.hpp"
#include "mesh/simplify_positions.hpp"
#include "mesh/spatial_order.hpp"

namespace duolod::mesh {
namespace {

// From this many positions on, the attribute-aware engine runs on a copy of the prepared mesh in
// spatial order, and its output and record are put back in the prepared mesh's order. Its state
// per position and wedge (quadrics, attribute quadrics, corner tables, the pass candidates and
// the queue: several hundred bytes) outgrows the 1 MiB L2 cache, and on a mesh whose ids are in
// no spatial order (scans: CGAL's bunny00, the median triangle spanning 15k ids) every walk of a
// neighbourhood misses it. The order can change a result (the quadrics are summed in triangle
// order, so their roundings move, and equal prices go in another order), but bunny00, armadillo
// and ChineseDragon-10kv with normals gave the same output bit for bit. At 4096, fandisk with
// normals (6.5k positions, flat CAD faces full of equal prices) changed, and its Hausdorff
// distance at 1% went from 0.93 to 1.11 times meshopt's (median over 5 input orders) for a gain
// of at most 13%; on the shared assets (2.4-2.9k positions, cache-resident already) the reorder
// cost 3-7%. bench/RESULTS.md, issue 3, session 44. (Position-only meshes that take the engine,
// not the fast path, keep their order: not measured.)
constexpr uint32_t kEngineSpatialOrderMinimum = 8192;

// `to`'s vertex i is `from`'s vertex order[i], in every stream `from` has.
void gatherVertices(const core::Mesh& from, std::span<const uint32_t> order, core::Mesh& to) {
  auto gather = [&](auto& out, const auto& in) {
    if (in.empty()) return;
    out.resize(order.size());
    for (size_t i = 0; i < order.size(); ++i) out[i] = in[order[i]];
  };
  gather(to.positions, from.positions);
  gather(to.normals, from.normals);
  gather(to.tangents, from.tangents);
  gather(to.uv0, from.uv0);
  gather(to.uv1, from.uv1);
  gather(to.colors, from.colors);
}

// The prepared mesh with its positions in Morton order (the wedges of a position together) and
// each submesh's triangles by their lowest vertex, as the position-only fast path orders its
// working mesh. Both sorts are stable, so the order is a function of the input alone.
struct SpatialOrder {
  PreparedMesh mesh;
  // mesh's vertex i is the prepared mesh's vertex source_vertex[i], and its triangle i the
  // prepared mesh's triangle source_triangle[i].
  std::vector<uint32_t> source_vertex;
  std::vector<uint32_t> source_triangle;
};

SpatialOrder orderSpatially(const PreparedMesh& prepared) {
  const core::Mesh& m = prepared.mesh;
  const uint32_t n = uint32_t(m.vertexCount()), positions = prepared.position_count;
  const uint32_t triangles = uint32_t(m.triangleCount());
  SpatialOrder order;

  // The frame of the finite positions (one infinite coordinate would put every other position
  // in one cell); the others get some code, and the order stays a function of the input.
  core::Bounds bounds;
  for (core::Vec3 p : m.positions)
    if (core::isFinite(p)) bounds.extend(p);
  MortonFrame frame;
  if (!bounds.empty()) {
    frame.origin = {bounds.min.x, bounds.min.y, bounds.min.z};
    const Vec3d size = boxSize(bounds);
    const double diagonal = std::sqrt(dot(size, size));
    frame.inverse_scale = diagonal > 0 && std::isfinite(diagonal) ? 1.0 / diagonal : 1.0;
  }
  std::vector<uint32_t> code(positions, 0);
  for (uint32_t w = 0; w < n; ++w) code[prepared.position_ids[w]] = frame.code(m.positions[w]);
  std::vector<uint32_t> by_code(positions);
  std::iota(by_code.begin(), by_code.end(), 0u);
  sortByCode(by_code, code, 10, 3);
  std::vector<uint32_t>& rank = code;  // each position's place in Morton order
  for (uint32_t i = 0; i < positions; ++i) rank[by_code[i]] = i;

  // Wedges by their position's rank (a counting sort: wedges of a position keep their order).
  std::vector<uint32_t> start(size_t(positions) + 1, 0);
  for (uint32_t w = 0; w < n; ++w) ++start[rank[prepared.position_ids[w]] + 1];
  for (uint32_t i = 0; i < positions; ++i) start[i + 1] += start[i];
  order.source_vertex.resize(n);
  std::vector<uint32_t> ordered_id(n);
  for (uint32_t w = 0; w < n; ++w) {
    const uint32_t i = start[rank[prepared.position_ids[w]]]++;
    order.source_vertex[i] = w;
    ordered_id[w] = i;
  }

  // Triangles by their lowest ordered vertex, then (stably) by submesh.
  std::vector<uint32_t> lowest(triangles);
  for (uint32_t t = 0; t < triangles; ++t) {
    const uint32_t* c = &m.indices[size_t(t) * 3];
    lowest[t] = std::min({ordered_id[c[0]], ordered_id[c[1]], ordered_id[c[2]]});
  }
  std::vector<uint32_t> by_lowest(triangles);
  std::iota(by_lowest.begin(), by_lowest.end(), 0u);
  sortByCode(by_lowest, lowest, 10, n <= (1u << 20) ? 2 : 3);
  std::vector<uint32_t> group(triangles, 0);  // prepareMeshWithPositions' submeshes tile it
  for (uint32_t s = 0; s < m.submeshes.size(); ++s) {
    const uint32_t first = m.submeshes[s].first_index / 3;
    std::fill_n(group.begin() + first, m.submeshes[s].index_count / 3, s);
  }
  std::vector<uint32_t> group_start(std::max<size_t>(m.submeshes.size(), 1) + 1, 0);
  for (uint32_t t = 0; t < triangles; ++t) ++group_start[group[t] + 1];
  for (size_t s = 0; s + 1 < group_start.size(); ++s) group_start[s + 1] += group_start[s];
  order.source_triangle.resize(triangles);
  for (uint32_t t : by_lowest) order.source_triangle[group_start[group[t]]++] = t;

  core::Mesh& out = order.mesh.mesh;
  gatherVertices(m, order.source_vertex, out);
  out.indices.resize(m.indices.size());
  for (uint32_t i = 0; i < triangles; ++i)
    for (int k = 0; k < 3; ++k)
      out.indices[size_t(i) * 3 + k] =
          ordered_id[m.indices[size_t(order.source_triangle[i]) * 3 + k]];
  out.submeshes = m.submeshes;
  order.mesh.position_count = positions;
  order.mesh.position_ids.resize(n);
  for (uint32_t i = 0; i < n; ++i)
    order.mesh.position_ids[i] = rank[prepared.position_ids[order.source_vertex[i]]];
  return order;
}

// Puts a result of the engine on `order.mesh` back in the prepared mesh's order: the output's
// vertices and triangles in the order of their sources (as the engine orders its output), the
// record's base, values and steps in the prepared mesh's ids.
void restoreOrder(SimplifyResult& result, const PreparedMesh& prepared, const SpatialOrder& order,
                  std::span<const uint32_t> output_wedges,
                  std::span<const uint32_t> output_triangles, bool record) {
  const core::Mesh& ordered = result.mesh;
  auto by_source = [](std::span<const uint32_t> ids, const std::vector<uint32_t>& source) {
    std::vector<uint32_t> slot(source.size(), kAbsent), sorted;
    for (uint32_t i = 0; i < ids.size(); ++i) slot[source[ids[i]]] = i;
    sorted.reserve(ids.size());
    for (uint32_t i : slot)
      if (i != kAbsent) sorted.push_back(i);
    return sorted;  // the output's items, by source
  };
  const std::vector<uint32_t> vertices = by_source(output_wedges, order.source_vertex);
  const std::vector<uint32_t> triangles = by_source(output_triangles, order.source_triangle);
  std::vector<uint32_t> new_vertex(vertices.size());
  for (uint32_t i = 0; i < vertices.size(); ++i) new_vertex[vertices[i]] = i;
  core::Mesh restored;
  gatherVertices(ordered, vertices, restored);
  restored.indices.resize(ordered.indices.size());
  for (size_t i = 0; i < triangles.size(); ++i)
    for (int k = 0; k < 3; ++k)
      restored.indices[i * 3 + k] = new_vertex[ordered.indices[size_t(triangles[i]) * 3 + k]];
  restored.submeshes = ordered.submeshes;  // each submesh keeps its triangles
  result.mesh = std::move(restored);

  if (!record) return;
  ProgressiveRecord& r = result.record;
  r.base = prepared.mesh;
  const uint32_t n = uint32_t(order.source_vertex.size());
  std::vector<uint32_t> value_order(r.values.vertexCount());
  std::iota(value_order.begin(), value_order.end(), 0u);
  for (uint32_t i = 0; i < n; ++i) value_order[order.source_vertex[i]] = i;
  core::Mesh values;
  gatherVertices(r.values, value_order, values);
  r.values = std::move(values);
  for (CollapseStep& step : r.steps) {
    step.removed = order.source_vertex[step.removed];
    step.kept = order.source_vertex[step.kept];
    // (The engine appends a value for every step, so kept_value >= n; a base value would be a
    // vertex of the reordered base.)
    if (step.kept_value < n) step.kept_value = order.source_vertex[step.kept_value];
  }
}

}  // namespace

SimplifyResult simplifyQuadric(const core::Mesh& mesh, const SimplifyOptions& options) {
  auto start = std::chrono::steady_clock::now();
  auto fast = [&](const core::Mesh& m) {
    SimplifyResult result = simplifyPositions(m, options);
    result.stats.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  if (positionFastPathApplies(mesh, options)) return fast(mesh);
  PreparedMesh prepared = prepareMeshWithPositions(mesh);
  if (positionFastPathApplies(prepared.mesh, options)) return fast(prepared.mesh);
  // With attributes the passes price every candidate at its optimal placement, as the greedy
  // queue does: ordered by the best of the fixed points, the attribute quadrics' prices misjudged
  // curved regions, whose collapses are cheap only off the edge (WaterBottle at 50%: the knurled
  // cap lost its highlights, the pbr render 0.00065 -> 0.0022 per pixel even with passes only
  // down to 75%; exactly priced 0.00064). bench/RESULTS.md, issue 3, session 43.
  const bool has_attributes = attributeLayout(prepared.mesh).stride != 0;
  QuadricModel model({.endpoint_only = options.placement == Placement::kEndpoint,
                      .price_at_fixed_points = !has_attributes,
                      .attribute_weight = options.attribute_weight});
  EngineOptions engine_options{
      .target_triangles = options.target_triangles,
      .target_error = options.target_error,
      .endpoint_only = options.placement == Placement::kEndpoint,
      .lock_border = options.lock_border,
      .allow_material_border_collapse = options.allow_material_border_collapse,
      .record = options.record,
      // Passes, then the greedy queue at the coarse end, with or without attributes. The
      // attribute-aware meshes took the greedy queue throughout until session 43: each collapse
      // re-priced the survivor's edges (~7 evaluations, each a Hoppe reduction and a solve) and
      // most queue pops were stale entries. Exactly priced passes: bunny with normals to 10%
      // 464 -> 278 ms; the pbr and UV renders of tests/mesh_attributes_render_test.cpp as good or
      // better (spot 10% 0.0370 -> 0.0361 per pixel); on 7 meshes with attributes at 50/10/1%,
      // Hausdorff ratios to meshopt over 5 orders geomean 0.745 -> 0.749, mean 0.622 -> 0.616.
      // With attributes and only an error to stop at, the greedy queue throughout, as before:
      // with no triangle target there is no greedy tail at the coarse end, and on spot at
      // --error 0.02 the passes' Hausdorff distance was 1.7x the queue's (0.079 against 0.046).
      .ordering = has_attributes && options.target_triangles == 0 ? CollapseOrdering::kGreedy
                                                                  : CollapseOrdering::kPasses,
      // Exactly priced passes cost what the queue does per candidate: hand over to it once a
      // pass applies fewer than 1 in 100 (fandisk with normals at 50%: 169M -> 150M
      // instructions, the greedy queue's 152M; bunny, armadillo and the shared assets unchanged).
      .min_pass_yield = has_attributes ? 0.01 : 0.0,
      .progress = options.progress,
  };
  SimplifyResult result;
  if (has_attributes && prepared.position_count >= kEngineSpatialOrderMinimum) {
    const SpatialOrder order = orderSpatially(prepared);
    std::vector<uint32_t> output_wedges, output_triangles;
    engine_options.output_wedges = &output_wedges;
    engine_options.output_triangles = &output_triangles;
    result = runCollapseEngine(order.mesh, model, engine_options);
    restoreOrder(result, prepared, order, output_wedges, output_triangles, options.record);
  } else {
    result = runCollapseEngine(prepared, model, engine_options);
  }
  result.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace duolod::mesh
