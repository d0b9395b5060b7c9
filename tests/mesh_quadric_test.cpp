// Plane weights of the quadric cost (src/mesh/quadric.hpp, planeWeight): a face's plane weighs
// area^(1/4) (area^0.9 on meshes with attributes), a feature plane 2 kFeatureWeight (= 8) times
// a face of area |e|² / 2 through the same weighting. Checked by evaluating each quadric one unit
// off its plane, where its value is its weight. Then the spike tips' pieces (quadric.hpp): the
// angle sum, the prefilter on the quadric and the pin's cost, checked by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>

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

// Spike tips (quadric.hpp): the angle sum as a product of (e·f, |e × f|), compared with π.
Vec3d unitAt(double degrees) {
  const double r = degrees * M_PI / 180.0;
  return {std::cos(r), std::sin(r), 0.0};
}
bool anglesBelowHalfTurn(std::initializer_list<double> corners_degrees, double scale = 1.0) {
  AngleSum sum;
  for (double degrees : corners_degrees) sum.addCorner(Vec3d{scale, 0, 0}, unitAt(degrees) * 3.0);
  return sum.belowHalfTurn();
}

TEST(SpikeTips, AngleSumComparesWithHalfATurn) {
  EXPECT_TRUE(anglesBelowHalfTurn({50, 50, 50}));       // 150°
  EXPECT_FALSE(anglesBelowHalfTurn({50, 50, 50, 50}));  // 200°
  EXPECT_TRUE(anglesBelowHalfTurn({100, 70, 5}));       // 175°, in any order
  EXPECT_TRUE(anglesBelowHalfTurn({5, 70, 100}));
  EXPECT_FALSE(anglesBelowHalfTurn({100, 70, 15}));  // 185°
  EXPECT_FALSE(anglesBelowHalfTurn({170, 170, 170}));  // 510°: not back below once past π
  EXPECT_FALSE(anglesBelowHalfTurn({60, 60, 60, 60, 60, 60}));  // a flat vertex, 360°
  // The edge lengths scale the factors, not their angles.
  EXPECT_TRUE(anglesBelowHalfTurn({20, 20, 20, 20, 20, 20, 20, 20}, 1e-30));  // 160°
  EXPECT_FALSE(AngleSum{}.belowHalfTurn());  // no corner: no tip
}

TEST(SpikeTips, ACornerOfZeroTurnsNothingWhereverItComes) {
  AngleSum first, later;
  first.addCorner({1, 0, 0}, {2, 0, 0});  // 0°: e × f = 0, e·f > 0
  first.addCorner({1, 0, 0}, unitAt(50));
  later.addCorner({1, 0, 0}, unitAt(50));
  later.addCorner({1, 0, 0}, {2, 0, 0});
  EXPECT_TRUE(first.belowHalfTurn());
  EXPECT_TRUE(later.belowHalfTurn());
  AngleSum only_zero;
  only_zero.addCorner({1, 0, 0}, {2, 0, 0});
  EXPECT_FALSE(only_zero.belowHalfTurn());  // no angle at all: not a tip
}

TEST(SpikeTips, ManySmallCornersDoNotUnderflow) {
  // A 64-sided cone's tip with edges of 1e-3: each factor is ~1e-6, the product ~1e-384 unscaled.
  AngleSum tip, flat;
  for (int i = 0; i < 64; ++i) {
    tip.addCorner(Vec3d{1e-3, 0, 0}, unitAt(2.5) * 1e-3);   // 160° in all
    flat.addCorner(Vec3d{1e-3, 0, 0}, unitAt(5.625) * 1e-3);  // 360°
  }
  EXPECT_TRUE(tip.belowHalfTurn());
  EXPECT_FALSE(flat.belowHalfTurn());
}

TEST(SpikeTips, DegenerateCornersEndTheSum) {
  AngleSum straight, empty_edge;
  straight.addCorner({1, 0, 0}, {-1, 0, 0});  // an angle of π: e × f = 0
  EXPECT_FALSE(straight.belowHalfTurn());
  straight.addCorner({1, 0, 0}, unitAt(10));  // stays ended
  EXPECT_FALSE(straight.belowHalfTurn());
  empty_edge.addCorner({0, 0, 0}, {1, 0, 0});
  EXPECT_FALSE(empty_edge.belowHalfTurn());
}

// The planes of a cone's sides, with unit normals at `tilt` degrees from its axis (z).
Quadric coneQuadric(int sides, double tilt) {
  Quadric q;
  for (int i = 0; i < sides; ++i) {
    const double azimuth = 2 * M_PI * i / sides, t = tilt * M_PI / 180.0;
    const Vec3d n{std::sin(t) * std::cos(azimuth), std::sin(t) * std::sin(azimuth), std::cos(t)};
    addQuadric(q, planeQuadric(n, 0.0, 1.0, 1.0));
  }
  return q;
}

TEST(SpikeTips, PlanesMustSpreadAsAroundASpike) {
  EXPECT_TRUE(mayBeSpikeTip(coneQuadric(4, 80)));    // a thin spike: |A|²/tr² = 0.47
  EXPECT_TRUE(mayBeSpikeTip(coneQuadric(3, 60)));    // a cone of half-angle 30°: 0.34
  EXPECT_FALSE(mayBeSpikeTip(coneQuadric(6, 10)));   // a gentle bump: 0.94
  EXPECT_FALSE(mayBeSpikeTip(coneQuadric(1, 45)));   // one plane: 1
  EXPECT_FALSE(mayBeSpikeTip(Quadric{}));            // no plane
}

TEST(SpikeTips, PinCostsItsWeightTimesThePlanesWeightPerSquaredDistance) {
  Quadric q = planeQuadric({0, 0, 1}, 0.0, 2.0, 2.0);  // z = 0, weight 2
  const Vec3d tip{1, 2, 0};
  pinSpikeTip(q, tip);
  EXPECT_DOUBLE_EQ(q.weight, 2.0);  // errors stay in the planes' units
  EXPECT_NEAR(evaluateQuadric(q, tip), 0.0, 1e-12);
  // 0.5 along the plane: only the pin, 4 * 2 * 0.25; 0.5 off it: the plane's 2 * 0.25 as well.
  EXPECT_NEAR(evaluateQuadric(q, {1.5, 2, 0}), 4.0 * 2.0 * 0.25, 1e-12);  // kSpikePinWeight 4
  EXPECT_NEAR(evaluateQuadric(q, {1, 2, 0.5}), (4.0 + 1.0) * 2.0 * 0.25, 1e-12);
}

}  // namespace
}  // namespace duolod::mesh
