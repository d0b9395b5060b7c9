// The surface's topology by position (mesh.hpp, SurfaceTopology) and its repair
// (orientConsistently): edges found by sorting the triangles' directed edges by their undirected
// key, so a run of equal keys is one edge and its directions tell a consistent pair (opposite
// ways) from a misoriented one (the same way).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <tuple>
#include <utility>
#include <vector>

#include "duolod/mesh.hpp"
#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

SurfaceTopology surfaceTopology(const core::Mesh& mesh) {
  std::vector<uint32_t> welded;  // as the simplifier welds: equal bits, -0 as +0
  const uint32_t welded_count = positionIds(mesh.positions, welded);

  // Each directed edge a -> b as its undirected key (min << 32 | max) and whether it runs from the
  // higher end: sorted, an edge's uses are adjacent.
  SurfaceTopology topology;
  std::vector<uint8_t> used(welded_count, 0);
  std::vector<std::pair<uint64_t, bool>> directed;
  directed.reserve(mesh.indices.size());
  const size_t index_count = mesh.indices.size() - mesh.indices.size() % 3;
  for (size_t t = 0; t < index_count; t += 3) {
    uint32_t v[3];
    bool in_range = true;
    for (int k = 0; k < 3; ++k) {
      const uint32_t index = mesh.indices[t + k];
      in_range &= index < welded.size();
      v[k] = in_range ? welded[index] : 0;
    }
    if (!in_range || v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
    ++topology.triangles;
    for (int k = 0; k < 3; ++k) {
      used[v[k]] = 1;
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      const uint64_t key = uint64_t(std::min(a, b)) << 32 | std::max(a, b);
      directed.push_back({key, a > b});
    }
  }
  topology.vertices = size_t(std::count(used.begin(), used.end(), 1));
  std::sort(directed.begin(), directed.end());
  for (size_t i = 0; i < directed.size();) {
    size_t end = i + 1;
    while (end < directed.size() && directed[end].first == directed[i].first) ++end;
    const size_t uses = end - i;
    ++topology.edges;
    if (uses == 1) ++topology.border_edges;
    if (uses > 2) ++topology.non_manifold_edges;
    if (uses == 2 && directed[i].second == directed[i + 1].second) ++topology.misoriented_edges;
    i = end;
  }
  return topology;
}

OrientationRepair orientConsistently(core::Mesh& mesh) {
  std::vector<uint32_t> welded;
  positionIds(mesh.positions, welded);
  const uint32_t triangle_count = uint32_t(mesh.indices.size() / 3);
  auto corners = [&](uint32_t t, uint32_t v[3]) {  // false: out of range or degenerate
    for (int k = 0; k < 3; ++k) {
      const uint32_t index = mesh.indices[size_t(t) * 3 + k];
      if (index >= welded.size()) return false;
      v[k] = welded[index];
    }
    return v[0] != v[1] && v[1] != v[2] && v[0] != v[2];
  };

  // Directed edges (undirected key, triangle, whether it runs from the higher end), sorted: an
  // edge's uses are adjacent, in triangle order.
  std::vector<std::tuple<uint64_t, uint32_t, bool>> directed;
  directed.reserve(mesh.indices.size());
  for (uint32_t t = 0; t < triangle_count; ++t) {
    uint32_t v[3];
    if (!corners(t, v)) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      directed.emplace_back(uint64_t(std::min(a, b)) << 32 | std::max(a, b), t, a > b);
    }
  }
  std::sort(directed.begin(), directed.end());

  // Links between the two triangles of each edge on exactly two (`same`: both run it the same
  // way, so exactly one of them must turn), as a triangle -> links table; a triangle on another
  // edge (border, non-manifold) makes its part open.
  struct Link {
    uint32_t other;
    bool same;
  };
  std::vector<uint32_t> link_start(size_t(triangle_count) + 1, 0);
  std::vector<uint8_t> open(triangle_count, 0);
  auto for_each_pair = [&](auto&& f) {
    for (size_t i = 0; i < directed.size();) {
      size_t end = i + 1;
      while (end < directed.size() && std::get<0>(directed[end]) == std::get<0>(directed[i])) ++end;
      if (end - i == 2)
        f(std::get<1>(directed[i]), std::get<1>(directed[i + 1]),
          std::get<2>(directed[i]) == std::get<2>(directed[i + 1]));
      else
        for (size_t j = i; j < end; ++j) open[std::get<1>(directed[j])] = 1;
      i = end;
    }
  };
  for_each_pair([&](uint32_t a, uint32_t b, bool) { ++link_start[a + 1], ++link_start[b + 1]; });
  for (uint32_t t = 0; t < triangle_count; ++t) link_start[t + 1] += link_start[t];
  std::vector<Link> links(link_start.back());
  std::vector<uint32_t> cursor(link_start.begin(), link_start.end() - 1);
  for_each_pair([&](uint32_t a, uint32_t b, bool same) {
    links[cursor[a]++] = {b, same};
    links[cursor[b]++] = {a, same};
  });

  // Each part from its lowest triangle, breadth first: turn[t] as the links ask, relative to the
  // first; a link that asks otherwise than an earlier one makes the part non-orientable.
  OrientationRepair repair;
  constexpr uint8_t kUnseen = 2;
  std::vector<uint8_t> turn(triangle_count, kUnseen);
  std::vector<uint32_t> part;
  for (uint32_t first = 0; first < triangle_count; ++first) {
    uint32_t v[3];
    if (turn[first] != kUnseen || !corners(first, v)) continue;
    part.assign(1, first);
    turn[first] = 0;
    bool orientable = true, closed = true;
    for (size_t i = 0; i < part.size(); ++i) {
      const uint32_t t = part[i];
      closed &= !open[t];
      for (uint32_t l = link_start[t]; l < link_start[t + 1]; ++l) {
        const uint8_t wanted = turn[t] ^ uint8_t(links[l].same);
        uint8_t& other = turn[links[l].other];
        if (other == kUnseen) {
          other = wanted;
          part.push_back(links[l].other);
        } else if (other != wanted) {
          orientable = false;
        }
      }
    }
    ++repair.parts;
    if (!orientable) {
      ++repair.non_orientable_parts;
      continue;  // left as it was
    }
    // Which of the part's two orientations: outwards for a closed part (the enclosed volume, by
    // the divergence theorem, is positive), else the one most of its area already has.
    // (The volume's cones from a point of the part rather than the origin: less cancellation.)
    const core::Vec3 o = mesh.positions[mesh.indices[size_t(first) * 3]];
    double volume = 0, turned_area = 0, kept_area = 0;
    for (uint32_t t : part) {
      const core::Vec3* p[3];
      for (int k = 0; k < 3; ++k) p[k] = &mesh.positions[mesh.indices[size_t(t) * 3 + k]];
      const double ax = double(p[0]->x) - o.x, ay = double(p[0]->y) - o.y,
                   az = double(p[0]->z) - o.z;
      const double ex = double(p[1]->x) - p[0]->x, ey = double(p[1]->y) - p[0]->y,
                   ez = double(p[1]->z) - p[0]->z;
      const double fx = double(p[2]->x) - p[0]->x, fy = double(p[2]->y) - p[0]->y,
                   fz = double(p[2]->z) - p[0]->z;
      const double cx = ey * fz - ez * fy, cy = ez * fx - ex * fz, cz = ex * fy - ey * fx;
      const double area = std::sqrt(cx * cx + cy * cy + cz * cz);
      (turn[t] ? turned_area : kept_area) += area;
      volume += (turn[t] ? -1.0 : 1.0) * (ax * cx + ay * cy + az * cz);
    }
    const bool flip_all =
        closed && std::isfinite(volume) && volume != 0 ? volume < 0 : turned_area > kept_area;
    for (uint32_t t : part) {
      if (!(turn[t] ^ uint8_t(flip_all))) continue;
      std::swap(mesh.indices[size_t(t) * 3 + 1], mesh.indices[size_t(t) * 3 + 2]);
      ++repair.turned_triangles;
    }
  }
  return repair;
}

}  // namespace duolod::mesh
