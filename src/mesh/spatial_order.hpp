// Spatial order of a mesh's vertices (Morton codes sorted by a stable radix sort), shared by the
// position-only fast path (simplify_positions.cpp) and the attribute-aware engine's input order
// (simplify_quadric.cpp). On meshes whose ids are in no spatial order (CGAL's bunny00: the median
// triangle spans 15k ids) every walk of a vertex's neighbours misses the cache; in Morton order
// most neighbours share lines a nearby vertex brought in (bench/RESULTS.md, issue 3, sessions 10
// and 44). Private to src/mesh.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "duolod/core.hpp"
#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

// The Morton code of a position: 10 bits per axis of its place in the frame (origin, scale: the
// bounding box's longest side maps to at most 1), interleaved into 30. Non-finite coordinates
// land in cell 0 or 1023: any code will do, the order only has to be a function of the input.
struct MortonFrame {
  Vec3d origin;
  double inverse_scale = 1;
  uint32_t code(core::Vec3 p) const {
    auto spread = [](uint32_t x) {
      x = (x | x << 16) & 0x030000ff;
      x = (x | x << 8) & 0x0300f00f;
      x = (x | x << 4) & 0x030c30c3;
      x = (x | x << 2) & 0x09249249;
      return x;
    };
    auto cell = [&](float value, double o) {
      const double t = (double(value) - o) * inverse_scale * 1023.0;
      return uint32_t(t > 0 ? (t < 1023 ? t : 1023) : 0);
    };
    return spread(cell(p.x, origin.x)) | spread(cell(p.y, origin.y)) << 1 |
           spread(cell(p.z, origin.z)) << 2;
  }
};

// Sorts `ids` stably by code[id] (LSD radix, `digits` digits of `digit_bits` <= 10 bits).
inline void sortByCode(std::vector<uint32_t>& ids, const std::vector<uint32_t>& code,
                       int digit_bits, int digits) {
  std::vector<uint32_t> scratch(ids.size());
  const uint32_t buckets = 1u << digit_bits, mask = buckets - 1;
  uint32_t histogram[1024];
  for (int level = 0; level < digits; ++level) {
    const int shift = digit_bits * level;
    std::fill_n(histogram, buckets, 0u);
    for (uint32_t v : ids) ++histogram[(code[v] >> shift) & mask];
    uint32_t sum = 0;
    for (uint32_t b = 0; b < buckets; ++b) sum += std::exchange(histogram[b], sum);
    for (uint32_t v : ids) scratch[histogram[(code[v] >> shift) & mask]++] = v;
    ids.swap(scratch);
  }
}

}  // namespace duolod::mesh
