// The surface's topology by position (mesh.hpp, SurfaceTopology) and its repair
// (orientConsistently): edges found by sorting the triangles' directed edges by their undirected
// key, so a run of equal keys is one edge and its directions tell a consistent pair (opposite
// ways) from a misoriented one (the same way).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "duolod/mesh.hpp"
#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

namespace {

// A triangle's directed edge a -> b, by position: its undirected key (min << 32 | max), the
// triangle, and whether it runs from the higher end.
struct DirectedEdge {
  uint64_t key;
  uint32_t triangle;
  bool from_higher;
  auto operator<=>(const DirectedEdge&) const = default;
};

// The directed edges of a mesh's proper triangles (welded by position as the simplifier welds:
// equal bits, -0 as +0; no index out of range, no two corners on one position), sorted: an
// edge's uses are adjacent, in triangle order.
struct WeldedEdges {
  uint32_t positions = 0;       // welded
  std::vector<uint8_t> proper;  // per triangle
  std::vector<DirectedEdge> directed;
};
WeldedEdges weldedEdges(const core::Mesh& mesh) {
  WeldedEdges edges;
  std::vector<uint32_t> welded;
  edges.positions = positionIds(mesh.positions, welded);
  const uint32_t triangle_count = uint32_t(mesh.indices.size() / 3);
  edges.proper.assign(triangle_count, 0);
  edges.directed.reserve(size_t(triangle_count) * 3);
  for (uint32_t t = 0; t < triangle_count; ++t) {
    uint32_t v[3];
    bool in_range = true;
    for (int k = 0; k < 3; ++k) {
      const uint32_t index = mesh.indices[size_t(t) * 3 + k];
      in_range &= index < welded.size();
      v[k] = in_range ? welded[index] : 0;
    }
    if (!in_range || v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
    edges.proper[t] = 1;
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      edges.directed.push_back({uint64_t(std::min(a, b)) << 32 | std::max(a, b), t, a > b});
    }
  }
  std::sort(edges.directed.begin(), edges.directed.end());
  return edges;
}

// Calls f(first, count) for each edge: its run of uses in `directed`.
template <class F>
void forEachEdge(const std::vector<DirectedEdge>& directed, F&& f) {
  for (size_t i = 0; i < directed.size();) {
    size_t end = i + 1;
    while (end < directed.size() && directed[end].key == directed[i].key) ++end;
    f(&directed[i], end - i);
    i = end;
  }
}

}  // namespace

SurfaceTopology surfaceTopology(const core::Mesh& mesh) {
  const WeldedEdges edges = weldedEdges(mesh);
  SurfaceTopology topology;
  topology.triangles = size_t(std::count(edges.proper.begin(), edges.proper.end(), 1));
  std::vector<uint8_t> used(edges.positions, 0);
  for (const DirectedEdge& e : edges.directed) used[e.key >> 32] = used[uint32_t(e.key)] = 1;
  topology.vertices = size_t(std::count(used.begin(), used.end(), 1));
  forEachEdge(edges.directed, [&](const DirectedEdge* uses, size_t count) {
    ++topology.edges;
    if (count == 1) ++topology.border_edges;
    if (count > 2) ++topology.non_manifold_edges;
    if (count == 2 && uses[0].from_higher == uses[1].from_higher) ++topology.misoriented_edges;
  });
  return topology;
}

OrientationRepair orientConsistently(core::Mesh& mesh) {
  const WeldedEdges edges = weldedEdges(mesh);
  const uint32_t triangle_count = uint32_t(edges.proper.size());

  // Links between the two triangles of each edge on exactly two (`same`: both run it the same
  // way, so exactly one of them must turn), as a triangle -> links table; a triangle on another
  // edge (border, non-manifold) makes its part open.
  struct Link {
    uint32_t other;
    bool same;
  };
  std::vector<uint32_t> link_start(size_t(triangle_count) + 1, 0);
  std::vector<uint8_t> open(triangle_count, 0);
  forEachEdge(edges.directed, [&](const DirectedEdge* uses, size_t count) {
    if (count == 2) {
      ++link_start[uses[0].triangle + 1], ++link_start[uses[1].triangle + 1];
    } else {
      for (size_t j = 0; j < count; ++j) open[uses[j].triangle] = 1;
    }
  });
  for (uint32_t t = 0; t < triangle_count; ++t) link_start[t + 1] += link_start[t];
  std::vector<Link> links(link_start.back());
  std::vector<uint32_t> cursor(link_start.begin(), link_start.end() - 1);
  forEachEdge(edges.directed, [&](const DirectedEdge* uses, size_t count) {
    if (count != 2) return;
    const bool same = uses[0].from_higher == uses[1].from_higher;
    links[cursor[uses[0].triangle]++] = {uses[1].triangle, same};
    links[cursor[uses[1].triangle]++] = {uses[0].triangle, same};
  });

  // Each part from its lowest triangle, breadth first: turn[t] as the links ask, relative to the
  // first; a link that asks otherwise than an earlier one makes the part non-orientable.
  OrientationRepair repair;
  constexpr uint8_t kUnseen = 2;
  std::vector<uint8_t> turn(triangle_count, kUnseen);
  std::vector<uint32_t> part;
  for (uint32_t first = 0; first < triangle_count; ++first) {
    if (turn[first] != kUnseen || !edges.proper[first]) continue;
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
