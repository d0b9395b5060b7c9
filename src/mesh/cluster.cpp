// Vertex clustering: the fast, coarse mode. Based on:
//   Rossignac & Borrel, "Multi-resolution 3D approximations for rendering complex scenes", 1993
//     (uniform grid, one representative per cell, degenerate triangles dropped);
//   Lindstrom, "Out-of-core simplification of large polygonal models", SIGGRAPH 2000 (the
//     representative minimizes the cell's plane quadric);
//   Willmott, "Rapid simplification of multi-attribute meshes", HPG 2011 (attribute seams: cluster
//     per cell *and* attribute region, so a UV seam through a cell keeps both sides' UVs).
// A cell's wedges are split into attribute regions by connectivity: two wedges of the cell that
// share a triangle edge are on the same side of every seam (a seam edge's triangles use different
// wedges), so they merge; wedges of one position but different attributes never do.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

#include "duolod/mesh.hpp"
#include "mesh/attributes.hpp"
#include "mesh/collapse_engine.hpp"
#include "mesh/quadric.hpp"

namespace duolod::mesh {
namespace {

uint32_t findRoot(std::vector<uint32_t>& parent, uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

SimplifyResult simplifyCluster(const core::Mesh& mesh, const ClusterOptions& options) {
  auto start = std::chrono::steady_clock::now();
  SimplifyResult result;
  const core::Mesh base = prepareMesh(mesh);
  const size_t wedges = base.vertexCount();
  const size_t triangles = base.triangleCount();
  const AttributeLayout layout = attributeLayout(base);
  const std::vector<float> attributes = packAttributes(base, layout);

  core::Bounds bounds;
  for (core::Vec3 p : base.positions)
    if (core::isFinite(p)) bounds.extend(p);
  if (bounds.empty() || triangles == 0) {
    result.mesh = base;
    result.stats.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  }

  // Grid: `resolution` cells along the longest side; cells are cubes.
  const int resolution = std::clamp(options.grid_resolution, 1, 1 << 16);
  const Vec3d box = boxSize(bounds);
  const double size[3] = {box.x, box.y, box.z};
  const double longest = std::max({box.x, box.y, box.z});
  const double cell = longest > 0 ? longest / resolution : 1.0;
  int64_t dims[3];
  for (int k = 0; k < 3; ++k)
    dims[k] = std::clamp<int64_t>(int64_t(std::ceil(size[k] / cell)), 1, resolution);

  // Cell of each wedge (kAbsent for non-finite positions: their triangles are dropped).
  std::vector<uint32_t> cell_of(wedges, kAbsent);
  std::vector<int64_t> cell_key;           // per dense cell id
  std::unordered_map<int64_t, uint32_t> cell_id;
  cell_id.reserve(wedges);
  for (size_t w = 0; w < wedges; ++w) {
    core::Vec3 p = base.positions[w];
    if (!core::isFinite(p)) continue;
    int64_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = std::clamp<int64_t>(int64_t((double(p[k]) - bounds.min[k]) / cell), 0, dims[k] - 1);
    int64_t key = c[0] + dims[0] * (c[1] + dims[1] * c[2]);
    auto [it, inserted] = cell_id.emplace(key, uint32_t(cell_key.size()));
    if (inserted) cell_key.push_back(key);
    cell_of[w] = it->second;
  }
  const size_t cells = cell_key.size();

  // Cell quadrics (positions in cell units relative to the box minimum, for conditioning) and
  // vertex means as the fallback representative.
  std::vector<Quadric> quadric(cells);
  std::vector<Vec3d> mean(cells, Vec3d{});
  std::vector<uint32_t> members(cells, 0);
  auto local = [&](core::Vec3 p) {
    return Vec3d{(p.x - bounds.min.x) / cell, (p.y - bounds.min.y) / cell,
                 (p.z - bounds.min.z) / cell};
  };
  for (size_t w = 0; w < wedges; ++w) {
    if (cell_of[w] == kAbsent) continue;
    mean[cell_of[w]] = mean[cell_of[w]] + local(base.positions[w]);
    ++members[cell_of[w]];
  }
  std::vector<double> wedge_area(wedges, 0.0);
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t* v = &base.indices[t * 3];
    if (cell_of[v[0]] == kAbsent || cell_of[v[1]] == kAbsent || cell_of[v[2]] == kAbsent) continue;
    Vec3d p0 = local(base.positions[v[0]]), p1 = local(base.positions[v[1]]),
          p2 = local(base.positions[v[2]]);
    Vec3d n = cross(p1 - p0, p2 - p0);
    double double_area = std::sqrt(dot(n, n));
    if (!(double_area > 0)) continue;
    n = n * (1.0 / double_area);
    Quadric plane = planeQuadric(n, -dot(n, p0), 0.5 * double_area, 0.5 * double_area);
    for (int k = 0; k < 3; ++k) {
      addQuadric(quadric[cell_of[v[k]]], plane);
      wedge_area[v[k]] += double_area / 6;  // a third of the triangle's area
    }
  }
  std::vector<core::Vec3> representative(cells);
  double max_move = 0;
  for (size_t c = 0; c < cells; ++c) {
    int64_t key = cell_key[c];
    Vec3d lo{double(key % dims[0]), double((key / dims[0]) % dims[1]),
             double(key / (dims[0] * dims[1]))};
    Vec3d center = mean[c] * (1.0 / members[c]);
    Vec3d p = minimizeQuadricNear(quadric[c], center, std::sqrt(3.0));
    // Clamp into the cell so the simplified surface stays within one cell of the input.
    p = {std::clamp(p.x, lo.x, lo.x + 1), std::clamp(p.y, lo.y, lo.y + 1),
         std::clamp(p.z, lo.z, lo.z + 1)};
    Vec3d at{bounds.min.x + p.x * cell, bounds.min.y + p.y * cell, bounds.min.z + p.z * cell};
    // (The last cell may reach past the box, and past float's range near its end.)
    clampIfBeyondFloat(at, {bounds.min.x, bounds.min.y, bounds.min.z},
                       {bounds.max.x, bounds.max.y, bounds.max.z});
    representative[c] = {float(at.x), float(at.y), float(at.z)};
  }
  for (size_t w = 0; w < wedges; ++w)
    if (cell_of[w] != kAbsent) {
      const core::Vec3 p = base.positions[w], r = representative[cell_of[w]];
      double move = core::length(p - r);
      if (!std::isfinite(move)) {  // float's squares overflow beyond ~1e19: the same in double
        const Vec3d d{double(p.x) - r.x, double(p.y) - r.y, double(p.z) - r.z};
        move = std::sqrt(dot(d, d));
      }
      max_move = std::max(max_move, move);
    }

  // Clusters: per cell, or per (cell, attribute region) when seams are kept.
  std::vector<uint32_t> parent(wedges);
  for (uint32_t w = 0; w < wedges; ++w) parent[w] = w;
  const bool split_regions = options.keep_attribute_seams && layout.stride > 0;
  if (split_regions) {
    for (size_t t = 0; t < triangles; ++t)
      for (int k = 0; k < 3; ++k) {
        uint32_t u = base.indices[t * 3 + k], v = base.indices[t * 3 + (k + 1) % 3];
        if (cell_of[u] != kAbsent && cell_of[u] == cell_of[v])
          parent[findRoot(parent, u)] = findRoot(parent, v);
      }
  } else {
    std::vector<uint32_t> first_in_cell(cells, kAbsent);
    for (uint32_t w = 0; w < wedges; ++w) {
      if (cell_of[w] == kAbsent) continue;
      if (first_in_cell[cell_of[w]] == kAbsent)
        first_in_cell[cell_of[w]] = w;
      else
        parent[findRoot(parent, w)] = findRoot(parent, first_in_cell[cell_of[w]]);
    }
  }

  // Output vertices: one per cluster, numbered by the cluster's first wedge; attributes are the
  // area-weighted mean of the members.
  std::vector<uint32_t> output_of(wedges, kAbsent);
  std::vector<uint32_t> cluster_output(wedges, kAbsent);
  std::vector<double> sums;
  std::vector<double> weights;
  uint32_t output_count = 0;
  for (uint32_t w = 0; w < wedges; ++w) {
    if (cell_of[w] == kAbsent) continue;
    uint32_t root = findRoot(parent, w);
    if (cluster_output[root] == kAbsent) cluster_output[root] = output_count++;
    output_of[w] = cluster_output[root];
  }
  sums.assign(size_t(output_count) * layout.stride, 0.0);
  weights.assign(output_count, 0.0);
  std::vector<uint32_t> output_cell(output_count, kAbsent);
  std::vector<uint32_t> output_first(output_count, kAbsent);
  for (uint32_t w = 0; w < wedges; ++w) {
    uint32_t o = output_of[w];
    if (o == kAbsent) continue;
    if (output_first[o] == kAbsent) output_first[o] = w;
    output_cell[o] = cell_of[w];
    double weight = wedge_area[w] > 0 ? wedge_area[w] : 1e-30;
    weights[o] += weight;
    const float* a = attributes.data() + size_t(w) * layout.stride;
    for (uint32_t k = 0; k < layout.stride; ++k)
      sums[size_t(o) * layout.stride + k] += weight * (std::isfinite(a[k]) ? a[k] : 0.0f);
  }
  core::Mesh& out = result.mesh;
  std::vector<float> value(layout.stride);
  for (uint32_t o = 0; o < output_count; ++o) {
    for (uint32_t k = 0; k < layout.stride; ++k)
      value[k] = float(sums[size_t(o) * layout.stride + k] / weights[o]);
    renormalizeAttributes(layout, value.data());
    appendVertex(out, layout, representative[output_cell[o]], value.data());
  }

  // Triangles: drop those with two corners in one cell, and repeats of a cell triple (same
  // orientation); keep order and submesh grouping.
  bool has_groups = !base.submeshes.empty();
  std::vector<uint32_t> group_count(base.submeshes.size(), 0);
  std::unordered_map<uint64_t, std::vector<uint32_t>> seen;  // hash -> kept triangle cell triples
  seen.reserve(triangles);
  std::vector<uint32_t> kept_cells;
  auto group_of = [&](size_t t) {
    for (size_t s = 0; s < base.submeshes.size(); ++s) {
      const core::Submesh& sub = base.submeshes[s];
      if (t * 3 >= sub.first_index && t * 3 < size_t(sub.first_index) + sub.index_count) return s;
    }
    return size_t(0);
  };
  size_t group = 0;
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t* v = &base.indices[t * 3];
    uint32_t o[3] = {output_of[v[0]], output_of[v[1]], output_of[v[2]]};
    if (o[0] == kAbsent || o[1] == kAbsent || o[2] == kAbsent) continue;
    uint32_t c[3] = {output_cell[o[0]], output_cell[o[1]], output_cell[o[2]]};
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
    int first = c[0] < c[1] ? (c[0] < c[2] ? 0 : 2) : (c[1] < c[2] ? 1 : 2);
    uint32_t key[3] = {c[first], c[(first + 1) % 3], c[(first + 2) % 3]};
    uint64_t hash = (uint64_t(key[0]) * 0x9e3779b97f4a7c15ull) ^ (uint64_t(key[1]) << 21) ^
                    (uint64_t(key[2]) * 0xc2b2ae3d27d4eb4full);
    std::vector<uint32_t>& bucket = seen[hash];
    bool duplicate = false;
    for (uint32_t kept : bucket)
      duplicate |= kept_cells[kept * 3] == key[0] && kept_cells[kept * 3 + 1] == key[1] &&
                   kept_cells[kept * 3 + 2] == key[2];
    if (duplicate) continue;
    bucket.push_back(uint32_t(kept_cells.size() / 3));
    kept_cells.insert(kept_cells.end(), key, key + 3);
    out.indices.insert(out.indices.end(), o, o + 3);
    if (has_groups) {
      const core::Submesh& sub = base.submeshes[group];
      if (t * 3 < sub.first_index || t * 3 >= size_t(sub.first_index) + sub.index_count)
        group = group_of(t);
      ++group_count[group];
    }
  }
  if (has_groups) {
    out.submeshes = base.submeshes;
    uint32_t first = 0;
    for (size_t s = 0; s < out.submeshes.size(); ++s) {
      out.submeshes[s].first_index = first;
      out.submeshes[s].index_count = group_count[s] * 3;
      first += group_count[s] * 3;
    }
  }

  // Unreferenced cluster vertices (all of whose triangles dropped) are removed.
  std::vector<uint32_t> used(output_count, kAbsent);
  for (uint32_t i : out.indices) used[i] = 0;
  core::Mesh compact;
  uint32_t next = 0;
  for (uint32_t o = 0; o < output_count; ++o) {
    if (used[o] == kAbsent) continue;
    used[o] = next++;
    compact.positions.push_back(out.positions[o]);
    if (!out.normals.empty()) compact.normals.push_back(out.normals[o]);
    if (!out.tangents.empty()) compact.tangents.push_back(out.tangents[o]);
    if (!out.uv0.empty()) compact.uv0.push_back(out.uv0[o]);
    if (!out.uv1.empty()) compact.uv1.push_back(out.uv1[o]);
    if (!out.colors.empty()) compact.colors.push_back(out.colors[o]);
  }
  for (uint32_t& i : out.indices) i = used[i];
  compact.indices = std::move(out.indices);
  compact.submeshes = std::move(out.submeshes);
  result.mesh = std::move(compact);
  result.error = max_move;
  result.stats.collapses = wedges - result.mesh.vertexCount();
  result.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace duolod::mesh
