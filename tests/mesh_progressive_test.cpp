// The progressive record: replaying all steps gives the simplifier's result exactly, replaying
// none gives the input, the one-sweep extractMeshes equals extractMesh count by count (and
// countTriangles their triangle counts), candidates
// are ascending, unique, bracketed by 0 and the end and never split a seam collapse, and 500
// candidates of a 75k-triangle record extract well under a second.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <numeric>
#include <random>
#include <set>

#include "duolod/mesh.hpp"
#include "mesh_test_meshes.hpp"

namespace duolod {
namespace {
using core::Mesh;

float gentleBumps(float x, float y) {
  return 0.05f * std::sin(6.0f * x + 0.3f) * std::cos(5.0f * y);
}

void expectSameMesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.vertexCount(), b.vertexCount());
  ASSERT_EQ(a.indices, b.indices);
  for (size_t v = 0; v < a.vertexCount(); ++v) {
    EXPECT_TRUE(a.positions[v] == b.positions[v]) << "vertex " << v;
  }
  ASSERT_EQ(a.normals.size(), b.normals.size());
  for (size_t v = 0; v < a.normals.size(); ++v) EXPECT_TRUE(a.normals[v] == b.normals[v]);
  ASSERT_EQ(a.uv0.size(), b.uv0.size());
  for (size_t v = 0; v < a.uv0.size(); ++v) {
    EXPECT_EQ(a.uv0[v].x, b.uv0[v].x);
    EXPECT_EQ(a.uv0[v].y, b.uv0[v].y);
  }
  ASSERT_EQ(a.submeshes.size(), b.submeshes.size());
  for (size_t s = 0; s < a.submeshes.size(); ++s) {
    EXPECT_EQ(a.submeshes[s].first_index, b.submeshes[s].first_index);
    EXPECT_EQ(a.submeshes[s].index_count, b.submeshes[s].index_count);
    EXPECT_EQ(a.submeshes[s].material, b.submeshes[s].material);
  }
}

TEST(ProgressiveRecord, FullReplayIsTheResultAndEmptyReplayIsTheInput) {
  for (const Mesh& input :
       {test::icosphere(3, 1.0f, test::lumps), test::seamGrid(16, gentleBumps)}) {
    auto result = mesh::simplifyQuadric(input, {.target_triangles = input.triangleCount() / 8});
    const auto& record = result.record;
    ASSERT_FALSE(record.steps.empty());
    expectSameMesh(mesh::extractMesh(record, record.steps.size()), result.mesh);
    expectSameMesh(mesh::extractMesh(record, record.steps.size() + 100), result.mesh);
    expectSameMesh(mesh::extractMesh(record, 0), input);
    EXPECT_EQ(record.steps.back().triangles_after, result.mesh.triangleCount());
    // Cumulative error is monotone and ends at the reported error.
    for (size_t i = 1; i < record.steps.size(); ++i)
      EXPECT_GE(record.steps[i].cumulative_error, record.steps[i - 1].cumulative_error);
    EXPECT_FLOAT_EQ(record.steps.back().cumulative_error, float(result.error));
  }
}

// From 8192 positions on, the attribute-aware engine runs on a copy in Morton order
// (simplify_quadric.cpp) and puts its output and record back in the input's order. A grid with a
// UV seam and normals (9,409 positions, above the 8192 from which the engine reorders), its
// vertices and each submesh's triangles shuffled (ids in no spatial order, as in scanned meshes):
// the record still replays to the result and to the input, and the output keeps the submeshes.
TEST(ProgressiveRecord, ALargeShuffledMeshReplaysInItsOwnOrder) {
  Mesh grid = test::seamGrid(96, gentleBumps);
  const uint32_t half = uint32_t(grid.indices.size() / 6) * 3;
  grid.submeshes = {{0, half, 0}, {half, uint32_t(grid.indices.size()) - half, 1}};
  std::mt19937 rng(7);
  std::vector<uint32_t> vertex_order(grid.vertexCount());
  std::iota(vertex_order.begin(), vertex_order.end(), 0u);
  std::shuffle(vertex_order.begin(), vertex_order.end(), rng);
  Mesh input = grid;
  std::vector<uint32_t> new_id(grid.vertexCount());
  for (uint32_t i = 0; i < vertex_order.size(); ++i) {
    const uint32_t v = vertex_order[i];
    new_id[v] = i;
    input.positions[i] = grid.positions[v];
    input.normals[i] = grid.normals[v];
    input.uv0[i] = grid.uv0[v];
  }
  for (const core::Submesh& sub : grid.submeshes) {
    std::vector<uint32_t> triangles(sub.index_count / 3);
    std::iota(triangles.begin(), triangles.end(), sub.first_index / 3);
    std::shuffle(triangles.begin(), triangles.end(), rng);
    for (size_t i = 0; i < triangles.size(); ++i)
      for (int k = 0; k < 3; ++k)
        input.indices[sub.first_index + i * 3 + k] = new_id[grid.indices[triangles[i] * 3 + k]];
  }
  ASSERT_GE(input.vertexCount(), 8192u);

  auto result = mesh::simplifyQuadric(input, {.target_triangles = input.triangleCount() / 10});
  const auto& record = result.record;
  ASSERT_FALSE(record.steps.empty());
  EXPECT_LE(result.mesh.triangleCount(), input.triangleCount() / 10);
  EXPECT_TRUE(core::validateMesh(result.mesh).ok());
  expectSameMesh(mesh::extractMesh(record, record.steps.size()), result.mesh);
  expectSameMesh(mesh::extractMesh(record, 0), input);
  ASSERT_EQ(result.mesh.submeshes.size(), 2u);
  EXPECT_GT(result.mesh.submeshes[0].index_count, 0u);
  EXPECT_GT(result.mesh.submeshes[1].index_count, 0u);
  // The seam is still there: its positions keep two UV charts (u below 0.45 and above 0.75).
  size_t left = 0, right = 0;
  for (size_t v = 0; v < result.mesh.vertexCount(); ++v)
    if (std::abs(result.mesh.positions[v].x - 0.5f) < 1e-6f)
      (result.mesh.uv0[v].x < 0.45f ? left : right) += 1;
  EXPECT_GT(left, 0u);
  EXPECT_EQ(left, right);
  // The same input gives the same output.
  auto again = mesh::simplifyQuadric(input, {.target_triangles = input.triangleCount() / 10});
  expectSameMesh(again.mesh, result.mesh);
}

// A large position-only mesh (40,962 positions: the fast path in spatial order) has its passes'
// collapses applied in two halves, each recording its own steps, merged afterwards
// (simplify_positions.cpp, applyHalves): the merged record must still replay to the result, count
// its triangles step by step and keep its largest error so far.
TEST(ProgressiveRecord, ALargePositionOnlyMeshReplaysThroughItsHalves) {
  const Mesh input = test::icosphere(6, 1.0f, test::lumps);
  for (size_t target : {input.triangleCount() / 3, size_t(400)}) {
    auto result = mesh::simplifyQuadric(input, {.target_triangles = target});
    const auto& record = result.record;
    ASSERT_FALSE(record.steps.empty());
    EXPECT_EQ(result.mesh.triangleCount(), target);
    expectSameMesh(mesh::extractMesh(record, record.steps.size()), result.mesh);
    expectSameMesh(mesh::extractMesh(record, 0), input);
    size_t triangles = input.triangleCount();
    float cumulative = 0;
    for (size_t i = 0; i < record.steps.size(); ++i) {
      const mesh::CollapseStep& step = record.steps[i];
      ASSERT_TRUE(step.triangles_after + 1 == triangles || step.triangles_after + 2 == triangles)
          << "step " << i << ": " << triangles << " -> " << step.triangles_after;
      triangles = step.triangles_after;
      cumulative = std::max(cumulative, step.error);
      ASSERT_EQ(step.cumulative_error, cumulative) << "step " << i;
      ASSERT_LT(step.kept_value, record.values.positions.size()) << "step " << i;
    }
    EXPECT_EQ(triangles, result.mesh.triangleCount());
    EXPECT_FLOAT_EQ(record.steps.back().cumulative_error, float(result.error));
    // A prefix replays to its own triangle count.
    const size_t middle = record.steps.size() / 2;
    EXPECT_EQ(mesh::extractMesh(record, middle).triangleCount(),
              record.steps[middle - 1].triangles_after);
  }
}

TEST(ProgressiveRecord, PrefixTriangleCountsMatchTheSteps) {
  Mesh input = test::icosphere(3, 1.0f, test::lumps);
  auto result = mesh::simplifyQuadric(input, {.target_triangles = 40});
  const auto& record = result.record;
  for (size_t count : {size_t(1), size_t(10), record.steps.size() / 2, record.steps.size() - 1}) {
    Mesh prefix = mesh::extractMesh(record, count);
    EXPECT_EQ(prefix.triangleCount(), record.steps[count - 1].triangles_after) << count;
    EXPECT_TRUE(core::validateMesh(prefix).ok());
    // A closed mesh stays closed at every prefix.
    for (const auto& [edge, n] : test::edgeTriangleCounts(prefix)) EXPECT_EQ(n, 2);
  }
}

TEST(ProgressiveRecord, ExtractMeshesEqualsExtractMesh) {
  Mesh input = test::seamGrid(20, gentleBumps);
  auto result = mesh::simplifyQuadric(input, {.target_triangles = 20});
  const auto& record = result.record;
  std::vector<size_t> counts = {0, 1, 2, 5, record.steps.size() / 3, record.steps.size() / 2,
                                record.steps.size()};
  auto meshes = mesh::extractMeshes(record, counts);
  ASSERT_EQ(meshes.size(), counts.size());
  for (size_t i = 0; i < counts.size(); ++i) {
    SCOPED_TRACE(counts[i]);
    expectSameMesh(meshes[i], mesh::extractMesh(record, counts[i]));
  }
}

// countTriangles replays without building meshes (generate sizes its candidates by it and
// extracts only those it draws): the same counts as the extracted meshes', for prefixes inside a
// seam collapse (rounded up alike), past the end, and out of order.
TEST(ProgressiveRecord, CountTrianglesEqualsTheExtractedMeshes) {
  Mesh input = test::seamGrid(20, gentleBumps);
  auto result = mesh::simplifyQuadric(input, {.target_triangles = 20});
  const auto& record = result.record;
  std::vector<size_t> counts;
  for (size_t i = 0; i < record.steps.size(); i += 7) counts.push_back(i);
  size_t inside = 0;  // a prefix that ends inside a multi-step (seam) collapse
  for (size_t i = 0; i + 1 < record.steps.size(); ++i)
    if (record.steps[i].continues) {
      inside = i + 1;
      break;
    }
  ASSERT_GT(inside, 0u) << "the seam grid's record has no multi-step collapse";
  counts.push_back(inside);
  counts.push_back(record.steps.size());
  counts.push_back(record.steps.size() + 5);
  counts.push_back(3);  // smaller than the one before: a fresh replay
  const std::vector<size_t> triangles = mesh::countTriangles(record, counts);
  ASSERT_EQ(triangles.size(), counts.size());
  const std::vector<Mesh> meshes = mesh::extractMeshes(record, counts);
  std::set<size_t> distinct;
  for (size_t i = 0; i < counts.size(); ++i) {
    EXPECT_EQ(triangles[i], meshes[i].triangleCount()) << "prefix " << counts[i];
    distinct.insert(triangles[i]);
  }
  EXPECT_GT(distinct.size(), counts.size() / 2);  // the counts do move along the record
  EXPECT_EQ(triangles[counts.size() - 3], result.mesh.triangleCount());
  EXPECT_TRUE(mesh::countTriangles(mesh::ProgressiveRecord{}, counts) ==
              std::vector<size_t>(counts.size(), 0));
}

// A seam collapse takes one step per wedge; a prefix ending inside it is rounded up, so the two
// sides of the seam never disagree on a position (which would open a crack).
TEST(ProgressiveRecord, SeamCollapsesAreNeverSplit) {
  Mesh input = test::seamGrid(16, gentleBumps);
  auto result = mesh::simplifyQuadric(input, {.target_triangles = 30});
  const auto& record = result.record;
  size_t split = 0;
  for (size_t i = 0; i + 1 < record.steps.size(); ++i)
    if (record.steps[i].continues) split = i + 1;  // prefix ending in the middle of a collapse
  ASSERT_GT(split, 0u) << "expected at least one seam collapse";
  Mesh rounded = mesh::extractMesh(record, split);
  expectSameMesh(rounded, mesh::extractMesh(record, split + 1));
  for (size_t count : mesh::chooseCandidates(record, 50))
    if (count > 0) {
      EXPECT_FALSE(record.steps[count - 1].continues) << count;
    }
}

TEST(ChooseCandidates, AscendingUniqueWithBothEnds) {
  Mesh input = test::icosphere(4, 1.0f, test::lumps);
  auto result = mesh::simplifyQuadric(input, {.target_triangles = 20});
  const auto& record = result.record;
  for (size_t k : {size_t(2), size_t(3), size_t(10), size_t(100), size_t(500), size_t(100000)}) {
    auto candidates = mesh::chooseCandidates(record, k);
    ASSERT_FALSE(candidates.empty());
    EXPECT_LE(candidates.size(), k);
    EXPECT_EQ(candidates.front(), 0u);
    EXPECT_EQ(candidates.back(), record.steps.size());
    for (size_t i = 1; i < candidates.size(); ++i) EXPECT_LT(candidates[i - 1], candidates[i]);
    if (k <= record.steps.size()) {
      EXPECT_EQ(candidates.size(), k);
    }
  }
  EXPECT_TRUE(mesh::chooseCandidates(record, 0).empty());
}

// The candidate before the biggest relative jump is always chosen.
TEST(ChooseCandidates, PicksThePrefixBeforeTheLargestJump) {
  mesh::ProgressiveRecord record;
  record.base = test::gridMesh(4);
  float errors[] = {0, 0, 0.001f, 0.001f, 0.5f, 0.5f, 0.6f, 0.7f};
  float cumulative = 0;
  uint32_t triangles = 32;
  for (float e : errors) {
    cumulative = std::max(cumulative, e);
    record.steps.push_back({.triangles_after = triangles -= 2, .error = e,
                            .cumulative_error = cumulative});
  }
  // On the log scale the largest jump is the first departure from zero (prefix 2 is the smallest
  // exact mesh), the next is 0.001 -> 0.5 (prefix 4 precedes it).
  EXPECT_EQ(mesh::chooseCandidates(record, 3), (std::vector<size_t>{0, 2, 8}));
  EXPECT_EQ(mesh::chooseCandidates(record, 4), (std::vector<size_t>{0, 2, 4, 8}));
  // No error at all: the candidates spread evenly by triangle count.
  for (auto& step : record.steps) step.error = step.cumulative_error = 0;
  auto even = mesh::chooseCandidates(record, 3);
  EXPECT_EQ(even, (std::vector<size_t>{0, 4, 8}));
}

// §5.1: K = 500 candidates from one run over ~80k triangles, in one sweep.
TEST(ProgressiveRecord, FiveHundredCandidatesOfALargeMeshExtractQuickly) {
  Mesh input = test::icosphere(6, 1.0f, test::lumps);  // 81,920 triangles
  auto result = mesh::simplifyQuadric(input, {.target_triangles = 100});
  const auto& record = result.record;
  auto candidates = mesh::chooseCandidates(record, 500);
  ASSERT_EQ(candidates.size(), 500u);
  auto start = std::chrono::steady_clock::now();
  auto meshes = mesh::extractMeshes(record, candidates);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  size_t total_triangles = 0;
  for (const Mesh& m : meshes) total_triangles += m.triangleCount();
  std::printf("simplify %zu -> %zu triangles: %.3f s; 500 candidates (%zu triangles in all): "
              "%.3f s\n", input.triangleCount(), result.mesh.triangleCount(),
              result.stats.seconds, total_triangles, seconds);
  EXPECT_EQ(meshes.front().triangleCount(), input.triangleCount());
  EXPECT_EQ(meshes.back().triangleCount(), result.mesh.triangleCount());
  // Each candidate matches a one-off extraction (the sweep is a replay, not an approximation).
  for (size_t i : {size_t(1), size_t(250), size_t(499)})
    EXPECT_EQ(meshes[i].indices, mesh::extractMesh(record, candidates[i]).indices) << i;
  // Wall time is the benchmark's business (bench_simplify prints it; a loaded CI machine must not
  // fail a test): here only report it.
  RecordProperty("extract_500_seconds", std::to_string(seconds));
}

TEST(ProgressiveRecord, EmptyRecord) {
  mesh::ProgressiveRecord record;
  EXPECT_EQ(mesh::extractMesh(record, 5).triangleCount(), 0u);
  EXPECT_EQ(mesh::chooseCandidates(record, 10), (std::vector<size_t>{0}));
  auto result = mesh::simplifyQuadric(Mesh{}, {});
  EXPECT_EQ(mesh::extractMesh(result.record, 0).triangleCount(), 0u);
}

}  // namespace
}  // namespace duolod
