// The progressive record (Hoppe, "Progressive meshes", SIGGRAPH 1996): replaying a prefix of the
// collapse sequence gives the intermediate mesh, and the paper's §5.1 picks K of those prefixes as
// the LOD candidates, where the error changes most.
//
// extractMeshes replays the record once: each wedge keeps a linked list of the corners that use
// it; a step re-points the removed wedge's corners to the kept wedge (O(its degree)), kills the
// triangles that became degenerate, and splices the lists. Snapshots read the current state, so
// K candidates cost one replay plus the size of the K outputs.
#include <algorithm>
#include <cmath>
#include <optional>

#include "duolod/mesh.hpp"
#include "mesh/attributes.hpp"

namespace duolod::mesh {
namespace {

// Appends one value of `values` (index i) to every present stream of `out`.
void appendValue(core::Mesh& out, const core::Mesh& values, uint32_t i) {
  out.positions.push_back(values.positions[i]);
  if (!values.normals.empty()) out.normals.push_back(values.normals[i]);
  if (!values.tangents.empty()) out.tangents.push_back(values.tangents[i]);
  if (!values.uv0.empty()) out.uv0.push_back(values.uv0[i]);
  if (!values.uv1.empty()) out.uv1.push_back(values.uv1[i]);
  if (!values.colors.empty()) out.colors.push_back(values.colors[i]);
}

// Rounds a step count up to the end of the collapse it falls into, and clamps it to the record.
size_t roundToCollapse(const ProgressiveRecord& record, size_t count) {
  count = std::min(count, record.steps.size());
  while (count > 0 && count < record.steps.size() && record.steps[count - 1].continues) ++count;
  return count;
}

class Replay {
 public:
  explicit Replay(const ProgressiveRecord& record) : record_(record) {
    const core::Mesh& base = record.base;
    const size_t wedges = base.vertexCount();
    const size_t corners = base.indices.size() - base.indices.size() % 3;
    corner_wedge_.assign(base.indices.begin(), base.indices.begin() + corners);
    triangle_alive_.assign(corners / 3, 1);
    live_triangles_ = corners / 3;
    value_of_.resize(wedges);
    for (uint32_t w = 0; w < wedges; ++w) value_of_[w] = w;
    first_corner_.assign(wedges, kAbsent);
    corner_next_.assign(corners, kAbsent);
    for (size_t c = corners; c-- > 0;) {
      uint32_t w = corner_wedge_[c];
      if (w >= wedges) {  // out-of-range index (not produced by the engine): drop the triangle
        if (triangle_alive_[c / 3]) triangle_alive_[c / 3] = 0, --live_triangles_;
        continue;
      }
      corner_next_[c] = first_corner_[w];
      first_corner_[w] = uint32_t(c);
    }
    vertex_mark_.assign(wedges, kAbsent);
    remap_.assign(wedges, kAbsent);
    wedge_removed_.assign(wedges, 0);
    for (uint32_t t = 0; t < triangle_alive_.size(); ++t)
      if (triangle_alive_[t]) live_list_.push_back(t);
    wedge_list_.resize(wedges);
    for (uint32_t w = 0; w < wedges; ++w) wedge_list_[w] = w;
  }

  void apply(const CollapseStep& step) {
    const size_t wedges = first_corner_.size();
    if (step.removed >= wedges || step.kept >= wedges) return;
    if (step.kept_value < record_.values.positions.size()) value_of_[step.kept] = step.kept_value;
    if (step.removed == step.kept) return;  // value update only
    wedge_removed_[step.removed] = 1;
    uint32_t head = kAbsent, tail = kAbsent;
    for (uint32_t c = first_corner_[step.removed]; c != kAbsent;) {
      uint32_t next = corner_next_[c];
      uint32_t t = c / 3;
      if (triangle_alive_[t]) {
        corner_wedge_[c] = step.kept;
        uint32_t* w = &corner_wedge_[size_t(t) * 3];
        if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2]) {
          triangle_alive_[t] = 0;
          --live_triangles_;
        } else {
          if (head == kAbsent) head = c;
          if (tail != kAbsent) corner_next_[tail] = c;
          tail = c;
        }
      }
      c = next;
    }
    if (tail != kAbsent) {
      corner_next_[tail] = first_corner_[step.kept];
      first_corner_[step.kept] = head;
    }
    first_corner_[step.removed] = kAbsent;
  }

  size_t liveTriangles() const { return live_triangles_; }

  core::Mesh snapshot() {
    const core::Mesh& values = record_.values;
    // Drop the triangles and wedges that died since the last snapshot (the lists only shrink, so
    // late, small snapshots cost little).
    compactLive();
    core::Mesh out;
    // Referenced wedges in their original order: mark, then number.
    for (uint32_t t : live_list_) {
      const uint32_t* w = &corner_wedge_[size_t(t) * 3];
      vertex_mark_[w[0]] = vertex_mark_[w[1]] = vertex_mark_[w[2]] = 0;
    }
    size_t vertex_count = 0;
    for (uint32_t w : wedge_list_) vertex_count += vertex_mark_[w] == 0;
    reserveStreams(out, values, vertex_count);
    uint32_t next = 0;
    for (uint32_t w : wedge_list_) {
      if (vertex_mark_[w] != 0) continue;
      vertex_mark_[w] = kAbsent;  // leave the marks clean for the next snapshot
      remap_[w] = next++;
      appendValue(out, values, value_of_[w]);
    }
    out.indices.resize(live_list_.size() * 3);
    uint32_t* index = out.indices.data();
    for (uint32_t t : live_list_) {
      const uint32_t* w = &corner_wedge_[size_t(t) * 3];
      index[0] = remap_[w[0]], index[1] = remap_[w[1]], index[2] = remap_[w[2]];
      index += 3;
    }
    out.submeshes = record_.base.submeshes;
    size_t cursor = 0;  // live_list_ is in triangle order, so each submesh is one run of it
    uint32_t first = 0;
    for (core::Submesh& sub : out.submeshes) {
      const size_t end = size_t(sub.first_index / 3) + sub.index_count / 3;
      uint32_t live = 0;
      while (cursor < live_list_.size() && live_list_[cursor] < end) ++cursor, ++live;
      sub.first_index = first;
      sub.index_count = live * 3;
      first += live * 3;
    }
    return out;
  }

 private:
  void compactLive() {
    size_t kept = 0;
    for (uint32_t t : live_list_)
      if (triangle_alive_[t]) live_list_[kept++] = t;
    live_list_.resize(kept);
    kept = 0;
    for (uint32_t w : wedge_list_)
      if (!wedge_removed_[w]) wedge_list_[kept++] = w;
    wedge_list_.resize(kept);
  }

  static void reserveStreams(core::Mesh& out, const core::Mesh& values, size_t n) {
    out.positions.reserve(n);
    if (!values.normals.empty()) out.normals.reserve(n);
    if (!values.tangents.empty()) out.tangents.reserve(n);
    if (!values.uv0.empty()) out.uv0.reserve(n);
    if (!values.uv1.empty()) out.uv1.reserve(n);
    if (!values.colors.empty()) out.colors.reserve(n);
  }

  const ProgressiveRecord& record_;
  std::vector<uint32_t> corner_wedge_;
  std::vector<uint8_t> triangle_alive_;
  size_t live_triangles_ = 0;
  std::vector<uint32_t> value_of_;
  std::vector<uint32_t> first_corner_;
  std::vector<uint32_t> corner_next_;
  std::vector<uint32_t> vertex_mark_;
  std::vector<uint32_t> remap_;
  std::vector<uint8_t> wedge_removed_;
  std::vector<uint32_t> live_list_;   // live triangles, ascending (compacted at snapshots)
  std::vector<uint32_t> wedge_list_;  // wedges not merged away, ascending (idem)
};

}  // namespace

std::vector<core::Mesh> extractMeshes(const ProgressiveRecord& record,
                                      std::span<const size_t> step_counts) {
  std::vector<core::Mesh> meshes;
  meshes.reserve(step_counts.size());
  Replay replay(record);
  size_t applied = 0;
  for (size_t requested : step_counts) {
    size_t count = roundToCollapse(record, requested);
    // Counts must ascend; a smaller one after a larger cannot be replayed forwards, so it gets
    // a fresh replay (correct, just not incremental).
    if (count < applied) {
      meshes.push_back(extractMesh(record, count));
      continue;
    }
    for (; applied < count; ++applied) replay.apply(record.steps[applied]);
    meshes.push_back(replay.snapshot());
  }
  return meshes;
}

std::vector<size_t> countTriangles(const ProgressiveRecord& record,
                                   std::span<const size_t> step_counts) {
  std::vector<size_t> counts;
  counts.reserve(step_counts.size());
  std::optional<Replay> replay;
  size_t applied = 0;
  for (size_t requested : step_counts) {
    const size_t count = roundToCollapse(record, requested);
    if (!replay || count < applied) replay.emplace(record), applied = 0;  // (as extractMeshes)
    for (; applied < count; ++applied) replay->apply(record.steps[applied]);
    counts.push_back(replay->liveTriangles());
  }
  return counts;
}

core::Mesh extractMesh(const ProgressiveRecord& record, size_t step_count) {
  Replay replay(record);
  size_t count = roundToCollapse(record, step_count);
  for (size_t i = 0; i < count; ++i) replay.apply(record.steps[i]);
  return replay.snapshot();
}

std::vector<size_t> chooseCandidates(const ProgressiveRecord& record, size_t k) {
  const auto& steps = record.steps;
  // Prefix lengths that end a collapse (0 = the base mesh).
  std::vector<size_t> prefixes = {0};
  for (size_t i = 0; i < steps.size(); ++i)
    if (!steps[i].continues || i + 1 == steps.size()) prefixes.push_back(i + 1);
  if (k == 0) return {};
  if (prefixes.size() <= k) return prefixes;
  if (k == 1) return {prefixes.back()};

  auto error_after = [&](size_t prefix) -> double {
    return prefix == 0 ? 0.0 : std::max(0.0, double(steps[prefix - 1].cumulative_error));
  };
  auto triangles_after = [&](size_t prefix) -> double {
    return prefix == 0 ? double(record.base.triangleCount())
                       : double(steps[prefix - 1].triangles_after);
  };
  // A floor for the log scale: a millionth of the final error (zero-error runs have no jumps).
  const double final_error = error_after(prefixes.back());
  const double floor = final_error > 0 ? final_error * 1e-6 : 0.0;

  // Jump in front of prefix i+1 (the collapses from prefixes[i] to prefixes[i+1]); the candidate
  // is prefixes[i], the last mesh before the error rises.
  struct Jump {
    double size;
    size_t index;  // into prefixes: the candidate
  };
  std::vector<Jump> jumps;
  for (size_t i = 0; i + 1 < prefixes.size(); ++i) {
    double before = error_after(prefixes[i]), after = error_after(prefixes[i + 1]);
    if (floor <= 0 || after <= before) continue;
    jumps.push_back({std::log(after + floor) - std::log(before + floor), i});
  }
  std::vector<uint8_t> chosen(prefixes.size(), 0);
  chosen.front() = chosen.back() = 1;
  size_t remaining = k - 2;
  std::stable_sort(jumps.begin(), jumps.end(),
                   [](const Jump& a, const Jump& b) { return a.size > b.size; });
  for (const Jump& jump : jumps) {
    if (remaining == 0) break;
    if (chosen[jump.index]) continue;
    chosen[jump.index] = 1;
    --remaining;
  }
  // Not enough jumps: spread the rest evenly by triangle count (targets at equal steps between
  // the base and the final count, each taking the nearest unchosen prefix).
  if (remaining > 0) {
    const double first_triangles = triangles_after(prefixes.front());
    const double last_triangles = triangles_after(prefixes.back());
    const size_t slots = remaining;
    for (size_t s = 1; s <= slots && remaining > 0; ++s) {
      double target =
          first_triangles + (last_triangles - first_triangles) * double(s) / double(slots + 1);
      // Triangle counts fall along the record: binary search the first prefix at or below.
      size_t lo = 0, hi = prefixes.size() - 1;
      while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (triangles_after(prefixes[mid]) > target)
          lo = mid + 1;
        else
          hi = mid;
      }
      for (size_t offset = 0; offset < prefixes.size(); ++offset) {  // nearest unchosen
        if (lo + offset < prefixes.size() && !chosen[lo + offset]) {
          chosen[lo + offset] = 1;
          --remaining;
          break;
        }
        if (offset <= lo && !chosen[lo - offset]) {
          chosen[lo - offset] = 1;
          --remaining;
          break;
        }
      }
    }
  }
  std::vector<size_t> result;
  for (size_t i = 0; i < prefixes.size(); ++i)
    if (chosen[i]) result.push_back(prefixes[i]);
  return result;
}

}  // namespace duolod::mesh
