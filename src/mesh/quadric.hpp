// The quadric collapse cost: Garland & Heckbert 1997 plane quadrics (area-weighted), Hoppe 1999
// attribute quadrics for normals, UVs and colours, penalty planes along feature lines, and the
// optimal placement with a well-conditioned fallback. Private to src/mesh; simplifyQuadric
// (simplify_quadric.cpp) plugs it into the collapse engine.
#pragma once

#include <cstdint>
#include <vector>

#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

// A symmetric 4x4 quadric Q(p) = pᵀAp + 2bᵀp + c over positions, plus the area it was
// accumulated over (for errors in distance units).
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
  double b0 = 0, b1 = 0, b2 = 0;
  double c = 0;
  double weight = 0;
};

// weight * (n·p + d)², n of unit length; `area` is what it adds to Quadric::weight.
Quadric planeQuadric(Vec3d n, double d, double weight, double area);
void addQuadric(Quadric& q, const Quadric& other);
double evaluateQuadric(const Quadric& q, Vec3d p);

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
