// The quadric collapse cost: Garland & Heckbert 1997 plane quadrics (weighted by planeWeight),
// Hoppe 1999 attribute quadrics for normals, UVs and colours, penalty planes along feature lines,
// and the optimal placement with a well-conditioned fallback. Private to src/mesh; simplifyQuadric
// (simplify_quadric.cpp) plugs it into the collapse engine.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

// A symmetric 4x4 quadric Q(p) = pᵀAp + 2bᵀp + c over positions, plus the summed weight of the
// face planes it was accumulated from (planeWeight; errors in distance units divide by it).
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
  double b0 = 0, b1 = 0, b2 = 0;
  double c = 0;
  double weight = 0;
};

// weight * (n·p + d)², n of unit length; `area` is what it adds to Quadric::weight.
inline Quadric planeQuadric(Vec3d n, double d, double weight, double area) {
  Quadric q;
  q.a00 = weight * n.x * n.x, q.a01 = weight * n.x * n.y, q.a02 = weight * n.x * n.z;
  q.a11 = weight * n.y * n.y, q.a12 = weight * n.y * n.z, q.a22 = weight * n.z * n.z;
  q.b0 = weight * d * n.x, q.b1 = weight * d * n.y, q.b2 = weight * d * n.z;
  q.c = weight * d * d;
  q.weight = area;
  return q;
}
inline void addQuadric(Quadric& q, const Quadric& o) {
  q.a00 += o.a00, q.a01 += o.a01, q.a02 += o.a02, q.a11 += o.a11, q.a12 += o.a12;
  q.a22 += o.a22, q.b0 += o.b0, q.b1 += o.b1, q.b2 += o.b2, q.c += o.c, q.weight += o.weight;
}
// Q(p), clamped at 0 (rounding can leave a tiny negative).
inline double evaluateQuadric(const Quadric& q, Vec3d p) {
  const double ax = q.a00 * p.x + q.a01 * p.y + q.a02 * p.z;
  const double ay = q.a01 * p.x + q.a11 * p.y + q.a12 * p.z;
  const double az = q.a02 * p.x + q.a12 * p.y + q.a22 * p.z;
  const double value =
      p.x * ax + p.y * ay + p.z * az + 2 * (q.b0 * p.x + q.b1 * p.y + q.b2 * p.z) + q.c;
  return std::max(value, 0.0);
}

// The weight of a face's plane, from its area: area^(1/4). Garland & Heckbert 1997 weight planes
// by area (a collapse is priced by how much surface it displaces; Garland's thesis §4.5 weighs
// this against unweighted planes, area^0). Real meshes spend small triangles where the shape has
// detail (scans, adaptively decimated and modelled assets), and full area weighting makes those
// details cheap to flatten: a thin horn costs its small area times its height². Between the two,
// area^α keeps large flat regions weighty and lets dense detail count. Every plane of a mesh
// (feature planes too, featureEdgeQuadric) goes through the same power, and errors divide by the
// summed weights (Quadric::weight). Measured (bench/simplify, Hausdorff ratio to meshopt_simplify
// 0.18, median over 5 input orders; the sweep in bench/RESULTS.md, issue 3, session 11): on the
// position-only rows, 4 of 21 cells were worse than meshopt at α = 1, none at 1/4; the count is
// sensitive to α (1-4 cells at 0.85 down to 0.35, and at 0), the geometric mean of the ratios
// falls steadily (0.71 at α = 1, 0.60 at 1/4), the mean distance stays below meshopt's.
// Meshes with attributes use area^0.9 (`with_attributes`): their attribute quadrics (Hoppe 1999)
// share the face's weight, and their attribute weights (quadric.cpp) were set against area. There,
// 1/4 rendered spot.obj at 10% worse (eq. 6's ε 679.6 -> 789.8) and put two attribute rows above
// meshopt; 0.9 leaves none above (spot 50%: 1.15 under area weighting, 0.80), for a rendered ε
// 0.5-6% higher than under area weighting (spot 10% 679.6 -> 722.4).
// (The fast path's set-up, simplify_positions.cpp, computes the position-only weight in SSE2
// lanes, two triangles at a time: a change here must be made there too.)
inline double planeWeight(double area, bool with_attributes = false) {
  return with_attributes ? std::pow(area, 0.9) : std::sqrt(std::sqrt(area));
}

// The plane quadric of a triangle (Garland & Heckbert 1997 eq. 2, weighted by planeWeight of its
// area); false (q untouched) for a zero-area or non-finite triangle. Inline: once per triangle.
inline bool triangleQuadric(const Vec3d& p0, const Vec3d& p1, const Vec3d& p2, Quadric& q,
                            bool with_attributes = false) {
  const Vec3d cross_product = cross(p1 - p0, p2 - p0);
  const double double_area = std::sqrt(dot(cross_product, cross_product));
  if (!(double_area > 0) || !std::isfinite(double_area)) return false;
  const double weight = planeWeight(0.5 * double_area, with_attributes);
  const Vec3d n = cross_product * (1.0 / double_area);
  q = planeQuadric(n, -dot(n, p0), weight, weight);
  return true;
}
// The penalty plane through the feature edge [a, b], perpendicular to the surface
// (`face_normal`: the sum of the unit normals of the edge's triangles; Garland & Heckbert 1997
// §6.1): sliding a border vertex off its line costs, sliding along it does not. False (q
// untouched) when the plane is undefined.
bool featureEdgeQuadric(Vec3d a, Vec3d b, Vec3d face_normal, Quadric& q,
                        bool with_attributes = false);
// The unit normal of a triangle, or zero.
Vec3d unitTriangleNormal(Vec3d p0, Vec3d p1, Vec3d p2);

// Spike tips. Where the surface comes to a sharp point (the tail tip of CGAL's cow: four
// triangles, 153° around it), the planes of the tip's triangles nearly contain the spike's axis,
// so its quadric barely grows when the tip moves along the axis, and a cheap collapse cuts the
// spike short (cow at 50%: the tip moved 0.6% of the diagonal, Hausdorff 1.89x meshopt's). Such
// a tip is a free vertex whose corner angles sum to less than π (a smooth vertex has ~2π, a cone
// of half-angle α has 2π sin α: below π for α < 30°). It gets a point quadric
// kSpikePinWeight · W · |x - p|², W its summed plane weights, so that moving it by d costs as
// much as moving d off kSpikePinWeight times its planes (measured 0.25 to 16: bench/RESULTS.md,
// issue 3, session 20). Only free vertices are pinned: a tip on a UV seam or a border is
// constrained (it may still slide along its line) or locked (it never moves).
inline constexpr double kSpikePinWeight = 4.0;
// A cheap test first, on the quadric alone: the unit normals around a spike spread over a cone,
// so A/tr(A) has no dominant eigenvalue (|A|²/tr(A)² is ~1/2 or less around a symmetric spike;
// ~1 on a smooth surface, 1/2 on a right-angled crease). Passes below 3/4. A heuristic, not a
// bound: a lopsided tip (one triangle far weightier than the others) could fail it; the tips of
// the 31 benchmark and survey meshes have 0.38-0.74, and it drops none of them.
inline bool mayBeSpikeTip(const Quadric& q) {
  const double trace = q.a00 + q.a11 + q.a22;
  const double frobenius = q.a00 * q.a00 + q.a11 * q.a11 + q.a22 * q.a22 +
                           2 * (q.a01 * q.a01 + q.a02 * q.a02 + q.a12 * q.a12);
  return trace > 0 && frobenius < 0.75 * trace * trace;
}
// The angle sum at a vertex, corner by corner in any order, as the argument of a product of
// complex numbers (e·f, |e × f|) (each corner's cos and sin scaled by |e||f|: no acos). Each
// factor turns the product by at least 0 and at most π, so the sum has reached π when the
// imaginary part first stops being positive (a product still on the positive real axis has
// turned by 0); the product then becomes NaN for good. A corner of π, a zero-length edge and
// NaN or infinite positions also end it as NaN: such a vertex is not taken for a tip. The
// product is scaled by 2^500 whenever it falls below 2^-500 (exactly: a power of two), so that
// many small corners (a 64-sided cone with edges of 1e-3 of the diagonal) do not underflow.
class AngleSum {
 public:
  void addCorner(Vec3d e, Vec3d f) {  // e, f: the corner's two edges from the vertex
    const Vec3d n = cross(e, f);
    addCorner(dot(e, f), std::sqrt(dot(n, n)));
  }
  // The same from e·f and |e × f| (twice its triangle's area, the same at its three corners).
  void addCorner(double c, double s) {
    double re = re_ * c - im_ * s, im = re_ * s + im_ * c;
    const bool below = (im > 0 || (im == 0 && re > 0)) && std::isfinite(re) && std::isfinite(im);
    if (below && std::abs(re) + im < 0x1p-500) re *= 0x1p500, im *= 0x1p500;
    re_ = below ? re : std::numeric_limits<double>::quiet_NaN();
    im_ = below ? im : std::numeric_limits<double>::quiet_NaN();
  }
  bool belowHalfTurn() const { return im_ > 0; }
 private:
  double re_ = 1, im_ = 0;
};
// Adds the spike tip's point quadric at p to q (Quadric::weight unchanged: errors stay in the
// planes' distance units).
void pinSpikeTip(Quadric& q, Vec3d p);

// Prices the collapse of edge [a, b] (b the survivor) at the best of b, a and the midpoint for
// the merged quadric q (three evaluations around b, no solve): returns Q at the chosen point and
// sets `at` (kFixedAtB, kFixedAtA, kFixedAtMid). Ties go to b, then a (input positions are kept
// exactly). Inline: this runs for every edge of every pass.
// Around b, with g = A b + b_q and d = a - b: Q(b + t d) = Q(b) + 2t g·d + t² dᵀAd.
enum : uint8_t { kFixedAtB, kFixedAtA, kFixedAtMid };
inline Vec3d fixedPoint(Vec3d a, Vec3d b, uint8_t at) {
  return at == kFixedAtB ? b : at == kFixedAtA ? a : (a + b) * 0.5;
}
inline double priceAtFixedPoints(const Quadric& q, Vec3d a, Vec3d b, uint8_t& at) {
  const Vec3d g{q.a00 * b.x + q.a01 * b.y + q.a02 * b.z + q.b0,
                q.a01 * b.x + q.a11 * b.y + q.a12 * b.z + q.b1,
                q.a02 * b.x + q.a12 * b.y + q.a22 * b.z + q.b2};
  const Vec3d d = a - b;
  const double at_b = std::max(dot(b, g) + q.b0 * b.x + q.b1 * b.y + q.b2 * b.z + q.c, 0.0);
  const double slope = dot(g, d);
  const double curvature = q.a00 * d.x * d.x + q.a11 * d.y * d.y + q.a22 * d.z * d.z +
                           2 * (q.a01 * d.x * d.y + q.a02 * d.x * d.z + q.a12 * d.y * d.z);
  const double at_a = std::max(at_b + 2 * slope + curvature, 0.0);
  const double at_mid = at_b + slope + 0.25 * curvature;
  double value = at_b;
  at = kFixedAtB;
  if (at_a < value) value = at_a, at = kFixedAtA;
  if (at_mid < value) value = std::max(at_mid, 0.0), at = kFixedAtMid;
  return value;
}

// The minimizer of q near the segment [a, b]: the exact solution when A is well conditioned and
// the point stays near the edge (snapped to an endpoint it equals up to rounding, so corners stay
// put exactly); otherwise the best of the endpoints, the midpoint and a damped solve around the
// midpoint (weak directions of A stay at the midpoint), ties to the endpoints. `error`, when
// given, receives q at the returned point.
Vec3d minimizeQuadric(const Quadric& q, Vec3d a, Vec3d b, double* error = nullptr);
// The minimizer of q within `max_distance` of `center`: exact when well conditioned, else the
// truncated pseudo-inverse around `center` (Lindstrom 2000, Eigen's 3x3 eigen-decomposition);
// `center` when neither stays within reach. For vertex clustering, where there is no edge.
Vec3d minimizeQuadricNear(const Quadric& q, Vec3d center, double max_distance);

struct QuadricModelOptions {
  bool endpoint_only = false;
  // Price free collapses at the best of the endpoints and the midpoint (three evaluations, no
  // solve) and solve the optimal placement only in refinePlacement, for the collapses the engine
  // applies (CollapseOrdering::kPasses). The price is then an upper bound of the optimal cost.
  bool price_at_fixed_points = false;
  float attribute_weight = 1.0f;
};

class QuadricModel final : public CostModel {
 public:
  explicit QuadricModel(const QuadricModelOptions& options) : options_(options) {}

  void begin(const EngineState& state) override;
  void evaluate(const EngineState& state, std::span<CandidateCollapse> batch) override;
  void placeAttributes(const EngineState& state, const CandidateCollapse& chosen,
                       std::span<float> values) override;
  void refinePlacement(const EngineState& state, CandidateCollapse& chosen) override;
  void setPassPricing(bool passes) override {
    fixed_point_pricing_ = passes && options_.price_at_fixed_points;
  }
  void onCollapse(const EngineState& state, const AppliedCollapse& applied) override;

 private:
  // Sums the attribute quadrics of the wedges that merge into `target` (and target's own) into
  // scratch_, returns a pointer to it (for placeAttributes).
  const double* mergedAttributeQuadric(const CandidateCollapse& candidate, uint32_t target);
  Quadric reducedMergedQuadric(const CandidateCollapse& candidate, uint32_t target) const;
  // The geometric quadric of the merged position, and the total (plus the attribute quadrics of
  // the survivor's wedges, minimized over the attributes) that prices and places it.
  void mergedQuadrics(const EngineState& state, const CandidateCollapse& candidate,
                      Quadric& geometric, Quadric& total) const;
  // Adds the reduced attribute quadrics of the survivor's wedges to `total`.
  void addReducedAttributes(const EngineState& state, const CandidateCollapse& candidate,
                            Quadric& total) const;
  // Adds the spike tips' point quadrics to geometric_ (see kSpikePinWeight).
  void pinSpikeTips(const EngineState& state);

  QuadricModelOptions options_;
  bool fixed_point_pricing_ = false;
  // Per position: plane quadrics plus feature-line penalty planes.
  std::vector<Quadric> geometric_;
  // Per wedge, Hoppe's attribute quadric over (p, s) with s the m weighted attribute values:
  //   [0..5] A (sym 3x3), [6..8] b_p, [9] c, [10] area (the s-s block is area * I),
  //   [11 + 3j .. 13 + 3j] column j of B (p-s block), [11 + 3m + j] b_s[j].
  std::vector<double> attribute_;
  uint32_t dims_ = 0;              // m
  uint32_t attribute_stride_ = 0;  // 11 + 4m
  std::vector<uint32_t> source_offset_;  // per dimension: float offset in the packed attributes
  std::vector<double> source_scale_;     // per dimension: weight applied to the raw value
  std::vector<double> scratch_;
};

}  // namespace duolod::mesh
