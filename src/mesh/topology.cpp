// The surface's topology by position (mesh.hpp, SurfaceTopology): edges found by sorting the
// triangles' directed edges by their undirected key, so a run of equal keys is one edge and its
// directions tell a consistent pair (opposite ways) from a misoriented one (the same way).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <unordered_map>
#include <vector>

#include "duolod/mesh.hpp"

namespace duolod::mesh {

SurfaceTopology surfaceTopology(const core::Mesh& mesh) {
  // Weld by the coordinates' bits, with -0 as +0 (x + 0.0f turns -0 into +0).
  std::unordered_map<uint64_t, std::vector<std::pair<core::Vec3, uint32_t>>> buckets;
  std::vector<uint32_t> welded(mesh.vertexCount());
  uint32_t welded_count = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const core::Vec3 p = mesh.positions[v];
    if (!core::isFinite(p)) {  // no order among NaNs: a vertex of its own
      welded[v] = welded_count++;
      continue;
    }
    const core::Vec3 key{p.x + 0.0f, p.y + 0.0f, p.z + 0.0f};
    uint32_t bits[3];
    std::memcpy(bits, &key.x, 4), std::memcpy(bits + 1, &key.y, 4),
        std::memcpy(bits + 2, &key.z, 4);
    const uint64_t hash = (uint64_t(bits[0]) * 0x9E3779B97F4A7C15ull) ^
                          (uint64_t(bits[1]) * 0xC2B2AE3D27D4EB4Full) ^ uint64_t(bits[2]);
    auto& bucket = buckets[hash];
    auto same = std::find_if(bucket.begin(), bucket.end(), [&](const auto& entry) {
      return entry.first.x == key.x && entry.first.y == key.y && entry.first.z == key.z;
    });
    if (same != bucket.end()) {
      welded[v] = same->second;
    } else {
      bucket.push_back({key, welded_count});
      welded[v] = welded_count++;
    }
  }

  // Each directed edge a -> b as (min << 32 | max) << 1 | (a > b): sorted, an edge's uses are
  // adjacent, and the low bit says which way each runs along it.
  SurfaceTopology topology;
  std::vector<uint8_t> used(welded_count, 0);
  std::vector<uint64_t> directed;
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
      directed.push_back(key << 1 | (a > b ? 1 : 0));
    }
  }
  topology.vertices = size_t(std::count(used.begin(), used.end(), 1));
  std::sort(directed.begin(), directed.end());
  for (size_t i = 0; i < directed.size();) {
    size_t end = i + 1;
    while (end < directed.size() && directed[end] >> 1 == directed[i] >> 1) ++end;
    const size_t uses = end - i;
    ++topology.edges;
    if (uses == 1) ++topology.border_edges;
    if (uses > 2) ++topology.non_manifold_edges;
    // Sorted, a pair's two low bits differ exactly when the triangles run opposite ways.
    if (uses == 2 && (directed[i] & 1) == (directed[i + 1] & 1)) ++topology.misoriented_edges;
    i = end;
  }
  return topology;
}

}  // namespace duolod::mesh
