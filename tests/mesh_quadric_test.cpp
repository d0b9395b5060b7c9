// Plane weights of the quadric cost (src/mesh/quadric.hpp, planeWeight): a face's plane weighs
// area^(1/4) (area^0.9 on meshes with attributes), a feature plane 2 kFeatureWeight (= 8) times
// a face of area |e|² / 2 through the same weighting. Checked by evaluating each quadric one unit
// off its plane, where its value is its weight.
#include <gtest/gtest.h>

#include <cmath>

#include "mesh/quadric.hpp"

namespace duolod::mesh {
namespace {

// The right triangle with legs 2 on the z = 0 plane: area 2.
const Vec3d kP0{0, 0, 0}, kP1{2, 0, 0}, kP2{0, 2, 0};

TEST(QuadricWeights, FacePlaneWeighsTheFourthRootOfItsArea) {
  Quadric q;
  ASSERT_TRUE(triangleQuadric(kP0, kP1, kP2, q));
  EXPECT_DOUBLE_EQ(q.weight, std::pow(2.0, 0.25));
  EXPECT_DOUBLE_EQ(evaluateQuadric(q, {0.3, 0.7, 1.0}), std::pow(2.0, 0.25));
  EXPECT_DOUBLE_EQ(evaluateQuadric(q, {0.3, 0.7, 0.0}), 0.0);  // on the plane
}

TEST(QuadricWeights, WithAttributesTheFacePlaneWeighsNearlyItsArea) {
  Quadric q;
  ASSERT_TRUE(triangleQuadric(kP0, kP1, kP2, q, /*with_attributes=*/true));
  EXPECT_DOUBLE_EQ(q.weight, std::pow(2.0, 0.9));
  EXPECT_DOUBLE_EQ(evaluateQuadric(q, {5.0, -1.0, -1.0}), std::pow(2.0, 0.9));
}

TEST(QuadricWeights, SmallFacesWeighRelativelyMore) {
  // A face 16x smaller in area weighs half as much (16^(1/4) = 2), not 16x less.
  Quadric big, small;
  ASSERT_TRUE(triangleQuadric(kP0, kP1, kP2, big));
  ASSERT_TRUE(triangleQuadric(kP0, kP1 * 0.25, kP2 * 0.25, small));
  EXPECT_DOUBLE_EQ(big.weight / small.weight, 2.0);
}

TEST(QuadricWeights, FeaturePlaneWeighsEightFacesOfHalfItsSquaredLength) {
  // The edge from the origin to (2, 0, 0) on a surface facing +z: its penalty plane is y = 0.
  const Vec3d a{0, 0, 0}, b{2, 0, 0}, face_normal{0, 0, 1};
  Quadric q, with_attributes;
  ASSERT_TRUE(featureEdgeQuadric(a, b, face_normal, q));
  ASSERT_TRUE(featureEdgeQuadric(a, b, face_normal, with_attributes, /*with_attributes=*/true));
  EXPECT_DOUBLE_EQ(evaluateQuadric(q, {1.0, 1.0, 3.0}), 8.0 * std::pow(2.0, 0.25));
  EXPECT_DOUBLE_EQ(evaluateQuadric(with_attributes, {1.0, 1.0, 3.0}), 8.0 * std::pow(2.0, 0.9));
  EXPECT_DOUBLE_EQ(q.weight, 0.0);  // feature planes add no surface
}

}  // namespace
}  // namespace duolod::mesh
