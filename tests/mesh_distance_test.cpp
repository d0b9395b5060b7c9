// Surface distance by sampling: exact answers for a mesh against itself (0), a square against the
// same square lifted by 0.1 (everything 0.1), and a square against itself shifted sideways by 0.5
// (Hausdorff 0.5, mean 0.125 each way); determinism per seed; empty meshes; large-mesh speed.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "duolod/mesh.hpp"
#include "mesh_test_meshes.hpp"

namespace duolod {
namespace {
using core::Mesh;

Mesh translated(Mesh mesh, core::Vec3 offset) {
  for (auto& p : mesh.positions) p = p + offset;
  return mesh;
}

TEST(SurfaceDistance, MeshAgainstItselfIsZero) {
  Mesh sphere = test::icosphere(3, 1.0f, test::lumps);
  auto d = mesh::surfaceDistance(sphere, sphere, 20000);
  EXPECT_LT(d.hausdorff, 1e-6);
  EXPECT_LT(d.mean, 1e-7);
  EXPECT_LT(d.rms, 1e-7);
}

TEST(SurfaceDistance, LiftedSquareIsAtDistanceZeroPointOne) {
  Mesh square = test::gridMesh(1);
  Mesh lifted = translated(square, {0, 0, 0.1f});
  auto d = mesh::surfaceDistance(square, lifted, 5000);
  EXPECT_NEAR(d.hausdorff, 0.1, 1e-6);
  EXPECT_NEAR(d.mean, 0.1, 1e-6);
  EXPECT_NEAR(d.rms, 0.1, 1e-6);
  // A finer triangulation of the same square changes nothing.
  auto fine = mesh::surfaceDistance(test::gridMesh(7), lifted, 5000);
  EXPECT_NEAR(fine.hausdorff, 0.1, 1e-6);
  EXPECT_NEAR(fine.mean, 0.1, 1e-6);
}

// In-plane shift by 0.5: a point at x of the first square is max(0, 0.5 - x) from the second,
// so the one-sided mean is ∫0^0.5 (0.5 - x) dx = 0.125 and the maximum 0.5 (both ways alike).
TEST(SurfaceDistance, ShiftedSquareHasKnownMeanAndMaximum) {
  Mesh square = test::gridMesh(4);
  Mesh shifted = translated(square, {0.5f, 0, 0});
  auto d = mesh::surfaceDistance(square, shifted, 100000);
  EXPECT_NEAR(d.hausdorff, 0.5, 1e-6);  // vertices are measured too: the corner is exact
  EXPECT_NEAR(d.mean, 0.125, 2e-3);
  EXPECT_NEAR(d.rms, std::sqrt(0.125 / 3.0), 2e-3);  // ∫0^0.5 (0.5 - x)² dx = 1/24
}

// Half of a square against the whole: every point of the half lies on the whole (0), the whole's
// far edge is 0.5 from the half.
TEST(SurfaceDistance, OneSidedMaximaOfAHalfSquare) {
  Mesh whole = test::gridMesh(4);
  Mesh half = whole;
  for (core::Vec3& p : half.positions) p.x *= 0.5f;
  auto d = mesh::surfaceDistance(whole, half, 20000);
  EXPECT_NEAR(d.max_a_to_b, 0.5, 1e-6);
  EXPECT_NEAR(d.max_b_to_a, 0.0, 1e-6);
  EXPECT_EQ(d.hausdorff, std::max(d.max_a_to_b, d.max_b_to_a));
  EXPECT_FLOAT_EQ(d.farthest_a_to_b.x, 1.0f);  // on the whole's far edge
  auto swapped = mesh::surfaceDistance(half, whole, 20000);
  EXPECT_NEAR(swapped.max_a_to_b, 0.0, 1e-6);
  EXPECT_NEAR(swapped.max_b_to_a, 0.5, 1e-6);
}
// The farthest point of a right triangle from tiny patches at its corners is the middle of the
// hypotenuse, sqrt(1/2) from every corner: one random sample would not find it, the dense grid on
// the worst triangle does.
TEST(SurfaceDistance, MaximumInsideATriangleIsFoundWithFewSamples) {
  Mesh triangle;
  triangle.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  triangle.indices = {0, 1, 2};
  triangle.submeshes = {{0, 3, 0}};
  Mesh corners;
  const float e = 1e-4f;
  for (core::Vec3 c : triangle.positions) {
    const uint32_t first = uint32_t(corners.positions.size());
    corners.positions.insert(corners.positions.end(), {c, {c.x + e, c.y, c.z}, {c.x, c.y + e, c.z}});
    corners.indices.insert(corners.indices.end(), {first, first + 1, first + 2});
  }
  corners.submeshes = {{0, uint32_t(corners.indices.size()), 0}};
  auto d = mesh::surfaceDistance(triangle, corners, 1);
  EXPECT_NEAR(d.max_a_to_b, std::sqrt(0.5), 2e-4);
  EXPECT_NEAR(d.farthest_a_to_b.x, 0.5f, 1e-6f);  // the middle of the hypotenuse
  EXPECT_NEAR(d.farthest_a_to_b.y, 0.5f, 1e-6f);
}
TEST(SurfaceDistance, DeterministicPerSeed) {
  Mesh a = test::icosphere(3, 1.0f, test::lumps);
  Mesh b = test::icosphere(2, 1.0f);
  auto first = mesh::surfaceDistance(a, b, 10000, 7);
  auto again = mesh::surfaceDistance(a, b, 10000, 7);
  EXPECT_EQ(first.hausdorff, again.hausdorff);
  EXPECT_EQ(first.mean, again.mean);
  auto other = mesh::surfaceDistance(a, b, 10000, 8);
  EXPECT_NEAR(other.mean, first.mean, 0.05 * first.mean);
}

// Copies of a triangle (in any corner order) are one triangle to measure against: 4,000 of them
// in one place, which no bounding box can split, took 11 s (found by fuzzing). The distances are
// those of the single triangle.
TEST(SurfaceDistance, PiledCopiesOfATriangleAreOne) {
  Mesh one;
  one.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  one.indices = {0, 1, 2};
  Mesh pile = one;
  pile.indices.clear();
  for (int i = 0; i < 4000; ++i)
    for (uint32_t k : {0u, 1u, 2u}) pile.indices.push_back((k + uint32_t(i)) % 3);
  const Mesh lifted = translated(test::gridMesh(3), {0, 0, 0.25f});
  const auto single = mesh::surfaceDistance(lifted, one, 2000);
  const auto piled = mesh::surfaceDistance(lifted, pile, 2000);
  EXPECT_DOUBLE_EQ(piled.max_a_to_b, single.max_a_to_b);
  EXPECT_NEAR(piled.mean, single.mean, 1e-12);
}

TEST(SurfaceDistance, EmptyMeshes) {
  auto none = mesh::surfaceDistance(Mesh{}, Mesh{});
  EXPECT_EQ(none.hausdorff, 0);
  auto one = mesh::surfaceDistance(test::gridMesh(2), Mesh{});
  EXPECT_TRUE(std::isinf(one.hausdorff));
  auto zero_samples = mesh::surfaceDistance(test::gridMesh(2), test::gridMesh(3), 0);
  EXPECT_LT(zero_samples.hausdorff, 1e-6);  // vertices only
}

// The bench's workload: ~80k triangles against a simplified copy, 100k samples each way.
TEST(SurfaceDistance, LargeMeshIsFast) {
  Mesh big = test::icosphere(6, 1.0f, test::lumps);  // 81,920 triangles
  Mesh small = test::icosphere(3, 1.0f, test::lumps);
  auto start = std::chrono::steady_clock::now();
  auto d = mesh::surfaceDistance(big, small, 100000);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("81920 vs 1280 triangles, 100k samples each way: %.3f s (hausdorff %.5f mean %.5f)\n",
              seconds, d.hausdorff, d.mean);
  EXPECT_GT(d.hausdorff, 0);
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_LT(seconds, 5.0);
#endif
}

}  // namespace
}  // namespace duolod
