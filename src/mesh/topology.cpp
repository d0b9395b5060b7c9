// The surface's topology by position (mesh.hpp, SurfaceTopology): edges found by sorting the
// triangles' directed edges by their undirected key, so a run of equal keys is one edge and its
// directions tell a consistent pair (opposite ways) from a misoriented one (the same way).
#include <algorithm>
#include <cstdint>
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

}  // namespace duolod::mesh
