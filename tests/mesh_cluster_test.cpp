// Vertex clustering: fewer triangles, every output vertex within one cell of the input (bounds
// included), no degenerate or repeated triangles, UV seams kept per side when asked, bad input
// survives.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <set>

#include "duolod/mesh.hpp"
#include "mesh_test_meshes.hpp"

namespace duolod {
namespace {
using core::Mesh;
using core::Vec3;

float roughBumps(float x, float y) {
  return 0.1f * std::sin(6.0f * x + 0.3f) * std::cos(5.0f * y);
}

TEST(SimplifyCluster, GridReducesAndStaysWithinOneCell) {
  Mesh grid = test::gridMesh(40, 1.0f, roughBumps);
  const int resolution = 8;
  auto result = mesh::simplifyCluster(grid, {.grid_resolution = resolution});
  const Mesh& out = result.mesh;
  EXPECT_LT(out.triangleCount(), grid.triangleCount() / 10);
  EXPECT_GT(out.triangleCount(), 0u);
  ASSERT_TRUE(core::validateMesh(out).ok());
  const float cell = 1.0f / resolution;
  core::Bounds in = core::computeBounds(grid), got = core::computeBounds(out);
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(got.min[k], in.min[k] - 1e-6f);
    EXPECT_LE(got.max[k], in.max[k] + 1e-6f);
    EXPECT_LT(got.min[k] - in.min[k], cell) << "axis " << k;
    EXPECT_LT(in.max[k] - got.max[k], cell) << "axis " << k;
  }
  // Every input vertex has an output vertex within one cell diagonal (and vice versa).
  for (Vec3 p : grid.positions) {
    float nearest = INFINITY;
    for (Vec3 q : out.positions) nearest = std::min(nearest, core::length(p - q));
    EXPECT_LT(nearest, cell * std::sqrt(3.0f));
  }
  EXPECT_LT(result.error, cell * std::sqrt(3.0f));
}

TEST(SimplifyCluster, NoDegenerateOrRepeatedTriangles) {
  Mesh sphere = test::icosphere(4, 1.0f, test::lumps);
  auto result = mesh::simplifyCluster(sphere, {.grid_resolution = 10});
  const Mesh& out = result.mesh;
  std::set<std::array<uint32_t, 3>> seen;
  for (size_t t = 0; t < out.triangleCount(); ++t) {
    const uint32_t* i = &out.indices[t * 3];
    EXPECT_TRUE(!(out.positions[i[0]] == out.positions[i[1]]) &&
                !(out.positions[i[1]] == out.positions[i[2]]) &&
                !(out.positions[i[0]] == out.positions[i[2]]));
    std::array<uint32_t, 3> key = {i[0], i[1], i[2]};
    std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
    EXPECT_TRUE(seen.insert(key).second) << "repeated triangle " << t;
  }
  // A finer grid keeps more.
  auto finer = mesh::simplifyCluster(sphere, {.grid_resolution = 30});
  EXPECT_GT(finer.mesh.triangleCount(), out.triangleCount());
}

// With keep_attribute_seams a cell on the seam yields one vertex per side: no triangle mixes the
// charts' UVs. Without it the two sides average into one vertex.
TEST(SimplifyCluster, KeepsUvSeams) {
  Mesh seamed = test::seamGrid(32, roughBumps);
  auto kept = mesh::simplifyCluster(seamed, {.grid_resolution = 7, .keep_attribute_seams = true});
  ASSERT_EQ(kept.mesh.uv0.size(), kept.mesh.vertexCount());
  for (size_t t = 0; t < kept.mesh.triangleCount(); ++t) {
    int left = 0;
    for (int k = 0; k < 3; ++k) left += kept.mesh.uv0[kept.mesh.indices[t * 3 + k]].x < 0.5f;
    EXPECT_TRUE(left == 0 || left == 3) << "triangle " << t << " spans both charts";
  }
  auto merged =
      mesh::simplifyCluster(seamed, {.grid_resolution = 7, .keep_attribute_seams = false});
  bool mixed = false;
  for (const auto& uv : merged.mesh.uv0) mixed |= uv.x > 0.3f && uv.x < 0.7f;
  EXPECT_TRUE(mixed) << "without seams the seam cells should average both charts";
}

TEST(SimplifyCluster, BadInput) {
  EXPECT_EQ(mesh::simplifyCluster(Mesh{}, {}).mesh.triangleCount(), 0u);
  Mesh grid = test::gridMesh(10, 1.0f, roughBumps);
  grid.positions[5].x = std::numeric_limits<float>::quiet_NaN();
  grid.indices.insert(grid.indices.end(), {0, 0, 1, 0, 1, 2, 3, 4, 12345});
  grid.submeshes = {{0, uint32_t(grid.indices.size()), 0}};
  for (int resolution : {-3, 0, 1, 2, 1000000}) {
    auto result = mesh::simplifyCluster(grid, {.grid_resolution = resolution});
    for (uint32_t i : result.mesh.indices) EXPECT_LT(i, result.mesh.vertexCount());
    for (Vec3 p : result.mesh.positions) EXPECT_TRUE(core::isFinite(p));
  }
  // A box wider than a float holds (a sphere of radius near the largest float): still a grid of
  // cells, not one cell with nothing left (found by fuzzing).
  Mesh huge = test::icosphere(3, std::numeric_limits<float>::max() * 0.999f);
  for (int resolution : {2, 3, 7}) {
    auto coarse = mesh::simplifyCluster(huge, {.grid_resolution = resolution});
    EXPECT_GT(coarse.mesh.triangleCount(), 0u) << resolution;
    EXPECT_TRUE(core::validateMesh(coarse.mesh).ok()) << resolution;
    EXPECT_TRUE(std::isfinite(coarse.error)) << resolution;  // the largest move, in double
  }
  Mesh flat = test::gridMesh(10);  // zero extent along z
  auto result = mesh::simplifyCluster(flat, {.grid_resolution = 4});
  EXPECT_TRUE(core::validateMesh(result.mesh).ok());
  for (Vec3 p : result.mesh.positions) EXPECT_EQ(p.z, 0.0f);
}

}  // namespace
}  // namespace duolod
