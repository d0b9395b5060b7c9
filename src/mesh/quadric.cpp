// Quadric collapse cost. Based on:
//   Garland & Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997
//     (plane quadrics, §5; area weighting and boundary-preserving planes, Garland's thesis §4.5);
//   Hoppe, "New quadric metric for simplifying meshes with appearance attributes", IEEE
//     Visualization 1999 (attribute quadrics, §4; wedges, §5);
//   Lindstrom, "Out-of-core simplification of large polygonal models", SIGGRAPH 2000 (solving the
//     placement by a truncated eigen-decomposition when A is ill-conditioned, §3.2).
// All quantities are in the engine's normalized units (bounding-box diagonal 1), so the same mesh
// at any scale simplifies the same way; errors are converted back to asset units.
#include "mesh/quadric.hpp"

#include "mesh/run_both.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace duolod::mesh {
namespace {

// Weight of the planes that hold feature lines (open borders, seams, material borders) in place,
// relative to the weight of a face plane of the same size: strong enough that a border
// vertex sliding off its line costs more than flattening a bump of the same extent.
constexpr double kFeatureWeight = 4.0;

// Attribute weights after normalization (normals are unit vectors, UVs are divided by the UV
// bounding-box diagonal, colours are in [0, 1]). A normal deviation of 1 (60°) then weighs like a
// deviation of kNormalWeight diagonals. On a surface of curvature radius R, collapsing an edge of
// length h moves it by ~h²/R but turns normals by ~h/R, so the normal term outweighs geometry by
// (w/h)²: with h ~ 0.5-2% of the diagonal (typical assets), w = 0.005 keeps geometry leading
// (bench/simplify: 0.02 made WaterBottle's mean distance 6x worse than without attributes, 0.005
// costs ~1.5x there) while attributes still steer placement and break ties. The optimal
// attribute values (Hoppe's s*) do not depend on these weights. Multiplied by
// SimplifyOptions::attribute_weight.
constexpr double kNormalWeight = 0.005;
constexpr double kUvWeight = 0.01;
constexpr double kColorWeight = 0.01;

// Placement: A counts as well conditioned when det(A) > kDeterminantRatio * trace(A)³, which for
// a 3x3 positive semi-definite matrix bounds its condition number by about 1 / (8 * ratio) = 1e4.
constexpr double kDeterminantRatio = 1.25e-5;
// Eigenvalues below this fraction of the largest are treated as zero (Lindstrom 2000 uses 1e-3).
constexpr double kEigenCutoff = 1e-3;
// The damped solve's shift as a fraction of trace(A) (about kEigenCutoff of the largest
// eigenvalue, which is between trace / 3 and trace).
constexpr double kDamping = 5e-4;
// A "well-conditioned" minimizer further than this many edge lengths from the edge's midpoint is
// distrusted (nearly parallel planes put it far away) and the fallback decides.
constexpr double kMaxMoveEdges = 3.0;

Vec3d normalized(Vec3d v) {
  double len = std::sqrt(dot(v, v));
  return len > 0 ? v * (1.0 / len) : Vec3d{0, 0, 0};
}

// The helpers below run for every candidate (hundreds of thousands per mesh): forced inline, so
// the quadric stays in registers instead of being reloaded behind a call.
#define DUOLOD_HOT [[gnu::always_inline]] inline

DUOLOD_HOT void addInto(Quadric& q, const Quadric& o) { addQuadric(q, o); }

DUOLOD_HOT double quadricValue(const Quadric& q, Vec3d p) { return evaluateQuadric(q, p); }

// target[i] += source[i] for i < n, two doubles at a time: each element's addition is the same
// IEEE operation, so the same bits as the plain loop, which g++ 12 at -O2 leaves scalar (the
// wedges' attribute quadrics, 11 + 4m doubles, summed three times a triangle in begin() were
// 5% of the attribute-aware mode's instructions on bunny with normals).
DUOLOD_HOT void addDoubles(double* target, const double* source, size_t n) {
  size_t i = 0;
#if defined(__SSE2__)
  for (; i + 2 <= n; i += 2)
    _mm_storeu_pd(target + i, _mm_add_pd(_mm_loadu_pd(target + i), _mm_loadu_pd(source + i)));
#endif
  for (; i < n; ++i) target[i] += source[i];
}

}  // namespace

Vec3d unitTriangleNormal(Vec3d p0, Vec3d p1, Vec3d p2) {
  return normalized(cross(p1 - p0, p2 - p0));
}

bool featureEdgeQuadric(Vec3d a, Vec3d b, Vec3d face_normal, Quadric& q,
                        bool with_attributes) {
  const Vec3d e = b - a;
  const Vec3d n = normalized(cross(e, face_normal));
  if (dot(n, n) == 0 || !std::isfinite(n.x)) return false;
  // 2 kFeatureWeight times the weight of a face of area |e|² / 2 (a right triangle on e), which
  // is kFeatureWeight |e|² under plain area weighting.
  const double weight = 2 * kFeatureWeight * planeWeight(0.5 * dot(e, e), with_attributes);
  q = planeQuadric(n, -dot(n, a), weight, 0.0);
  return true;
}

void pinSpikeTip(Quadric& q, Vec3d p) {
  const double w = kSpikePinWeight * q.weight;
  q.a00 += w, q.a11 += w, q.a22 += w;
  q.b0 -= w * p.x, q.b1 -= w * p.y, q.b2 -= w * p.z;
  q.c += w * dot(p, p);
}

namespace {

// The right-hand side r = -(A center + b) of A x = r, for the offset x from `center`.
DUOLOD_HOT Vec3d residual(const Quadric& q, Vec3d center) {
  return {-(q.a00 * center.x + q.a01 * center.y + q.a02 * center.z + q.b0),
          -(q.a01 * center.x + q.a11 * center.y + q.a12 * center.z + q.b1),
          -(q.a02 * center.x + q.a12 * center.y + q.a22 * center.z + q.b2)};
}

// Solves (A + mu I) x = r by cofactors. With `min_det` > 0 it gives up (false) as soon as the
// determinant shows the system is not well conditioned, before the rest of the work.
DUOLOD_HOT bool solveShifted(const Quadric& q, double mu, Vec3d r, double min_det, Vec3d& x) {
  const double a00 = q.a00 + mu, a11 = q.a11 + mu, a22 = q.a22 + mu;
  const double c00 = a11 * a22 - q.a12 * q.a12;
  const double c01 = q.a02 * q.a12 - q.a01 * a22;
  const double c02 = q.a01 * q.a12 - q.a02 * a11;
  const double det = a00 * c00 + q.a01 * c01 + q.a02 * c02;
  if (!(det > min_det) || !(det > 0)) return false;
  const double c11 = a00 * a22 - q.a02 * q.a02;
  const double c12 = q.a01 * q.a02 - a00 * q.a12;
  const double c22 = a00 * a11 - q.a01 * q.a01;
  const double inv = 1.0 / det;
  x = {(c00 * r.x + c01 * r.y + c02 * r.z) * inv, (c01 * r.x + c11 * r.y + c12 * r.z) * inv,
       (c02 * r.x + c12 * r.y + c22 * r.z) * inv};
  return true;
}

// Minimizer of q as an offset from `center`, accepted within sqrt(max_move_sq) of it. Returns
// true with `exact` when A is well conditioned. Otherwise returns false and `damped` holds the
// minimizer of q + mu |p - center|² with mu a small fraction of A's trace: along A's strong
// directions that is the minimizer, along the weak ones (flat or cylindrical neighbourhoods) it
// stays at `center`. This is Tikhonov's smooth version of Lindstrom's truncated pseudo-inverse,
// at the price of one 3x3 solve instead of an eigen-decomposition (this runs for every candidate).
DUOLOD_HOT bool solveAround(const Quadric& q, Vec3d center, double max_move_sq, Vec3d& exact,
                            Vec3d& damped) {
  const Vec3d r = residual(q, center);
  const double trace = q.a00 + q.a11 + q.a22;
  damped = center;
  if (!(trace > 0)) return false;
  Vec3d x;
  if (solveShifted(q, 0.0, r, kDeterminantRatio * trace * trace * trace, x) &&
      dot(x, x) <= max_move_sq) {
    exact = center + x;
    return true;
  }
  if (solveShifted(q, kDamping * trace, r, 0.0, x) && dot(x, x) <= max_move_sq &&
      std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z))
    damped = center + x;
  return false;
}

}  // namespace

namespace {

DUOLOD_HOT Vec3d minimizeOnEdge(const Quadric& q, Vec3d a, Vec3d b, double* error) {
  const Vec3d mid = (a + b) * 0.5;
  const double edge_sq = dot(b - a, b - a);
  Vec3d exact, damped;  // damped = mid when no damped solution is found
  if (solveAround(q, mid, kMaxMoveEdges * kMaxMoveEdges * edge_sq, exact, damped)) {
    // The minimizer on an endpoint up to rounding is that endpoint: features such as corners
    // then stay exactly where they were instead of moving by 1e-17.
    const double snap_sq = 1e-20 * edge_sq;
    if (dot(exact - b, exact - b) <= snap_sq) exact = b;
    if (dot(exact - a, exact - a) <= snap_sq) exact = a;
    if (error) *error = quadricValue(q, exact);
    return exact;
  }
  // Ill-conditioned: the best of the endpoints, the midpoint and the damped solution; ties go to
  // the earlier (an endpoint keeps an input position exactly). The damped point minimizes
  // q(p) + mu |p - mid|², so q(damped) <= q(mid) whenever it was found: mid needs no evaluation
  // then.
  Vec3d best = b;
  double best_error = quadricValue(q, b);
  if (double e = quadricValue(q, a); e < best_error) best_error = e, best = a;
  if (double e = quadricValue(q, damped); e < best_error) best_error = e, best = damped;
  if (error) *error = best_error;
  return best;
}

}  // namespace

Vec3d minimizeQuadric(const Quadric& q, Vec3d a, Vec3d b, double* error) {
  return minimizeOnEdge(q, a, b, error);
}

Vec3d minimizeQuadricNear(const Quadric& q, Vec3d center, double max_distance) {
  Vec3d exact, damped;
  const double max_move_sq = max_distance * max_distance;
  if (solveAround(q, center, max_move_sq, exact, damped)) return exact;
  // Ill-conditioned: here (once per cell, not per candidate) the exact truncated pseudo-inverse
  // of Lindstrom 2000 §3.2 is affordable: minimize along A's significant eigenvectors only.
  Eigen::Matrix3d m;
  m << q.a00, q.a01, q.a02, q.a01, q.a11, q.a12, q.a02, q.a12, q.a22;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
  eigen.computeDirect(m);
  const Eigen::Vector3d values = eigen.eigenvalues();  // ascending
  if (!(values(2) > 0)) return center;
  const Eigen::Matrix3d vectors = eigen.eigenvectors();
  const Vec3d r = residual(q, center);
  const Eigen::Vector3d rhs(r.x, r.y, r.z);
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i)
    if (values(i) > kEigenCutoff * values(2))
      x += vectors.col(i) * (vectors.col(i).dot(rhs) / values(i));
  if (!x.allFinite() || x.squaredNorm() > max_move_sq) return damped;
  return center + Vec3d{x(0), x(1), x(2)};
}

void QuadricModel::begin(const EngineState& state) {
  const AttributeLayout& layout = state.layout;
  const size_t wedge_count = state.wedge_position.size();
  const double w = options_.attribute_weight;

  // Attribute dimensions that enter the quadric (tangents follow the normal instead).
  source_offset_.clear();
  source_scale_.clear();
  auto uv_scale = [&](uint32_t offset) {  // 1 / diagonal of the UV bounding box
    float lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (size_t v = 0; v < wedge_count; ++v)
      for (int k = 0; k < 2; ++k) {
        float x = state.wedgeAttributes(uint32_t(v))[offset + k];
        if (!std::isfinite(x)) continue;
        lo[k] = std::min(lo[k], x), hi[k] = std::max(hi[k], x);
      }
    double dx = hi[0] - lo[0], dy = hi[1] - lo[1];
    double diagonal = std::sqrt(dx * dx + dy * dy);
    return diagonal > 0 && std::isfinite(diagonal) ? 1.0 / diagonal : 1.0;
  };
  auto add_dims = [&](uint32_t offset, uint32_t count, double scale) {
    if (offset == kAbsent || !(scale > 0)) return;
    for (uint32_t k = 0; k < count; ++k) {
      source_offset_.push_back(offset + k);
      source_scale_.push_back(scale);
    }
  };
  add_dims(layout.normal, 3, w * kNormalWeight);
  if (layout.uv0 != kAbsent) add_dims(layout.uv0, 2, w * kUvWeight * uv_scale(layout.uv0));
  if (layout.uv1 != kAbsent) add_dims(layout.uv1, 2, w * kUvWeight * uv_scale(layout.uv1));
  add_dims(layout.color, 4, w * kColorWeight);
  dims_ = uint32_t(source_offset_.size());
  attribute_stride_ = dims_ > 0 ? 11 + 4 * dims_ : 0;

  geometric_.assign(state.positions.size(), Quadric{});
  attribute_.assign(wedge_count * attribute_stride_, 0.0);
  scratch_.assign(attribute_stride_, 0.0);
  std::vector<double> triangle_quadric(attribute_stride_);
  std::vector<double> values(3 * size_t(dims_));

  const size_t triangles = state.triangle_alive.size();
  for (size_t t = 0; t < triangles; ++t) {
    if (!state.triangle_alive[t]) continue;
    uint32_t wedge[3], position[3];
    Vec3d p[3];
    bool finite = true;
    for (int k = 0; k < 3; ++k) {
      wedge[k] = state.corners[t * 3 + k];
      position[k] = state.wedge_position[wedge[k]];
      p[k] = state.positions[position[k]];
      finite &= std::isfinite(p[k].x) && std::isfinite(p[k].y) && std::isfinite(p[k].z);
    }
    if (!finite) continue;
    const Vec3d e1 = p[1] - p[0], e2 = p[2] - p[0];
    Quadric plane;
    if (!triangleQuadric(p[0], p[1], p[2], plane, /*with_attributes=*/dims_ > 0)) continue;
    const double weight = plane.weight;  // planeWeight of the area; the attributes share it
    for (int k = 0; k < 3; ++k) addInto(geometric_[position[k]], plane);

    if (dims_ == 0) continue;
    // Hoppe 1999 §4: per attribute j the linear function g_j·p + d_j that interpolates the three
    // corner values in the triangle's plane; the quadric is weight * Σ_j (g_j·p + d_j - s_j)².
    const double g11 = dot(e1, e1), g12 = dot(e1, e2), g22 = dot(e2, e2);
    const double gram = g11 * g22 - g12 * g12;
    const bool solvable = gram > 1e-30 * g11 * g22;
    std::fill(triangle_quadric.begin(), triangle_quadric.end(), 0.0);
    double* q = triangle_quadric.data();
    double* column = q + 11;
    double* bs = q + 11 + 3 * dims_;
    q[10] = weight;
    for (uint32_t j = 0; j < dims_; ++j) {
      double s[3];
      for (int k = 0; k < 3; ++k) {
        float raw = state.wedgeAttributes(wedge[k])[source_offset_[j]];
        s[k] = std::isfinite(raw) ? raw * source_scale_[j] : 0.0;
      }
      Vec3d g{0, 0, 0};
      if (solvable) {
        double d1 = s[1] - s[0], d2 = s[2] - s[0];
        double alpha = (g22 * d1 - g12 * d2) / gram, beta = (g11 * d2 - g12 * d1) / gram;
        g = e1 * alpha + e2 * beta;
      }
      double d = solvable ? s[0] - dot(g, p[0]) : (s[0] + s[1] + s[2]) / 3.0;
      q[0] += weight * g.x * g.x, q[1] += weight * g.x * g.y, q[2] += weight * g.x * g.z;
      q[3] += weight * g.y * g.y, q[4] += weight * g.y * g.z, q[5] += weight * g.z * g.z;
      q[6] += weight * d * g.x, q[7] += weight * d * g.y, q[8] += weight * d * g.z;
      q[9] += weight * d * d;
      column[3 * j] = -weight * g.x, column[3 * j + 1] = -weight * g.y, column[3 * j + 2] = -weight * g.z;
      bs[j] = -weight * d;
    }
    for (int k = 0; k < 3; ++k) {
      addDoubles(attribute_.data() + size_t(wedge[k]) * attribute_stride_, q, attribute_stride_);
    }
  }

  // Penalty planes through feature edges, perpendicular to the surface (Garland & Heckbert 1997
  // §6.1): sliding a border vertex inwards or outwards costs, sliding along the line does not.
  for (const FeatureEdge& edge : state.feature_edges) {
    // A misoriented or non-manifold edge is no border: the surface goes on across it. Its ends
    // are locked (classifyPositions), so a plane through them would never price a collapse.
    if (edge.features & kFeatureNonManifold) continue;
    Vec3d face_normal{0, 0, 0};
    for (uint32_t t : edge.triangles) {
      if (t == kAbsent) continue;
      const auto corner = [&](uint32_t c) { return state.positions[state.cornerPosition(c)]; };
      face_normal = face_normal + unitTriangleNormal(corner(t * 3), corner(t * 3 + 1),
                                                     corner(t * 3 + 2));
    }
    Quadric plane;
    if (!featureEdgeQuadric(state.positions[edge.a], state.positions[edge.b], face_normal, plane,
                            /*with_attributes=*/dims_ > 0))
      continue;
    addInto(geometric_[edge.a], plane);
    addInto(geometric_[edge.b], plane);
  }

  pinSpikeTips(state);  // quadric.hpp, kSpikePinWeight
}

// The free positions whose planes spread as around a spike (mayBeSpikeTip), then their angle
// sums, in one sweep over the triangles when there are any.
void QuadricModel::pinSpikeTips(const EngineState& state) {
  const uint32_t position_count = uint32_t(state.positions.size());
  std::vector<uint8_t> maybe_tip(position_count, 0);
  bool any_maybe_tip = false;
  for (uint32_t p = 0; p < position_count; ++p)
    if (state.kinds[p] == VertexKind::kFree && mayBeSpikeTip(geometric_[p]))
      maybe_tip[p] = 1, any_maybe_tip = true;
  if (!any_maybe_tip) return;
  std::vector<AngleSum> angles(position_count);
  const size_t triangles = state.triangle_alive.size();
  for (size_t t = 0; t < triangles; ++t) {
    if (!state.triangle_alive[t]) continue;
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t p = state.cornerPosition(uint32_t(t * 3 + k));
      if (!maybe_tip[p]) continue;
      const Vec3d at = state.positions[p];
      const uint32_t next = state.cornerPosition(uint32_t(t * 3 + (k + 1) % 3));
      const uint32_t previous = state.cornerPosition(uint32_t(t * 3 + (k + 2) % 3));
      angles[p].addCorner(state.positions[next] - at, state.positions[previous] - at);
    }
  }
  for (uint32_t p = 0; p < position_count; ++p)
    if (maybe_tip[p] && angles[p].belowHalfTurn()) pinSpikeTip(geometric_[p], state.positions[p]);
}

const double* QuadricModel::mergedAttributeQuadric(const CandidateCollapse& candidate,
                                                   uint32_t target) {
  const double* own = attribute_.data() + size_t(target) * attribute_stride_;
  std::copy_n(own, attribute_stride_, scratch_.data());
  for (uint32_t i = 0; i < candidate.wedge_count; ++i) {
    if (candidate.to_wedges[i] != target) continue;
    addDoubles(scratch_.data(),
               attribute_.data() + size_t(candidate.from_wedges[i]) * attribute_stride_,
               attribute_stride_);
  }
  return scratch_.data();
}

namespace {

// Hoppe 1999 §4: minimizing over the attributes s = -(Bᵀp + b_s) / area leaves a quadric in p
// alone: A - B Bᵀ / area, b_p - B b_s / area, c - |b_s|² / area. Here for the sum of the
// attribute quadrics `sources`, summed element by element as they are read. kSources is their count
// when it is known at compile time (1: a wedge alone, 2: merged with one other, a free position's
// collapse), 0 for any: the generic loop over a runtime count for each of the 11 + 4m elements was
// half of the reduction's instructions. The same operations in the same order either way, so the
// same bits.
template <uint32_t kSources>
DUOLOD_HOT Quadric reduceSources(const double* const* sources, uint32_t count, uint32_t dims) {
  auto sum = [&](uint32_t k) {
    if constexpr (kSources == 1) {
      return sources[0][k];
    } else if constexpr (kSources == 2) {
      return sources[0][k] + sources[1][k];
    } else {
      double v = sources[0][k];
      for (uint32_t i = 1; i < count; ++i) v += sources[i][k];
      return v;
    }
  };
  Quadric r;
  r.a00 = sum(0), r.a01 = sum(1), r.a02 = sum(2), r.a11 = sum(3), r.a12 = sum(4), r.a22 = sum(5);
  r.b0 = sum(6), r.b1 = sum(7), r.b2 = sum(8), r.c = sum(9);
  const double area = sum(10);
  if (!(area > 0)) return r;
  const double inv = 1.0 / area;
  for (uint32_t j = 0; j < dims; ++j) {
    const double x = sum(11 + 3 * j), y = sum(12 + 3 * j), z = sum(13 + 3 * j);
    const double s = sum(11 + 3 * dims + j);
    r.a00 -= x * x * inv, r.a01 -= x * y * inv, r.a02 -= x * z * inv;
    r.a11 -= y * y * inv, r.a12 -= y * z * inv, r.a22 -= z * z * inv;
    r.b0 -= x * s * inv, r.b1 -= y * s * inv, r.b2 -= z * s * inv;
    r.c -= s * s * inv;
  }
  return r;
}

}  // namespace

// The attribute quadric of `target` merged with those of the wedges that merge into it, reduced
// (this runs for every candidate).
Quadric QuadricModel::reducedMergedQuadric(const CandidateCollapse& candidate,
                                           uint32_t target) const {
  const double* sources[1 + kMaxWedges];
  uint32_t count = 0;
  sources[count++] = attribute_.data() + size_t(target) * attribute_stride_;
  for (uint32_t i = 0; i < candidate.wedge_count; ++i)
    if (candidate.to_wedges[i] == target)
      sources[count++] = attribute_.data() + size_t(candidate.from_wedges[i]) * attribute_stride_;
  if (count == 1) return reduceSources<1>(sources, count, dims_);
  if (count == 2) return reduceSources<2>(sources, count, dims_);
  return reduceSources<0>(sources, count, dims_);
}

void QuadricModel::addReducedAttributes(const EngineState& state, const CandidateCollapse& cand,
                                        Quadric& total) const {
  // Every wedge of the survivor: merged ones with their sources, the others as they are.
  state.forEachWedge(cand.to, [&](uint32_t w) { addInto(total, reducedMergedQuadric(cand, w)); });
}

void QuadricModel::mergedQuadrics(const EngineState& state, const CandidateCollapse& cand,
                                  Quadric& geometric, Quadric& total) const {
  geometric = geometric_[cand.from];
  addInto(geometric, geometric_[cand.to]);
  total = geometric;
  if (dims_ > 0) addReducedAttributes(state, cand, total);
}

// From this many candidates on, evaluate prices a batch with attributes on two cores (runBoth,
// ~0.3 us a price with Hoppe's reduction; the position-only prices at fixed points cost a tenth
// of that and stay on one). From 1024 on instead, WaterBottle and spot were no faster.
constexpr size_t kTwoCorePricingMinimum = 4096;

void QuadricModel::evaluate(const EngineState& state, std::span<CandidateCollapse> batch) {
  auto price = [&](std::span<CandidateCollapse> part) {
    for (CandidateCollapse& cand : part) {
      // (Summed here rather than through mergedQuadrics: the error needs the geometric quadric
      // apart from the total, and this runs for every edge of every pass, where summing it twice
      // and copying it through memory showed.)
      Quadric geometric = geometric_[cand.from];
      addInto(geometric, geometric_[cand.to]);
      Quadric total = geometric;
      if (dims_ > 0) addReducedAttributes(state, cand, total);
      const Vec3d a = state.positions[cand.from], b = state.positions[cand.to];
      double value = 0;
      if (cand.endpoint_only) {
        cand.position = b;
        value = quadricValue(total, b);
      } else if (fixed_point_pricing_) {
        uint8_t at = kFixedAtB;
        value = priceAtFixedPoints(total, a, b, at);
        cand.position = fixedPoint(a, b, at);
      } else {
        cand.position = minimizeOnEdge(total, a, b, &value);
      }
      // The cost is the weighted quadric itself (Garland & Heckbert's Q(v)): squared distance
      // times the weight (planeWeight of the area) it applies to, so a collapse that moves a large
      // region a little and one that moves a small region a lot are compared by how much surface
      // they displace. (Dividing by the weight, i.e. ordering by mean squared distance, was
      // measured worse: bench/simplify's mean distance 10-40% higher, Hausdorff worse on 6 of 21
      // cells instead of 3.) The reported error is the root (weighted) mean squared distance in
      // asset units.
      cand.cost = value;
      const double area = geometric.weight > 0 ? geometric.weight : 1.0;
      const double geometric_value = dims_ == 0 ? value : quadricValue(geometric, cand.position);
      cand.error = std::sqrt(geometric_value / area) * state.scale;
    }
  };
  // Each price reads the model and the state only, so a large batch (a pass prices every live
  // edge: with attributes a third of the run's instructions, bunny with normals to 10%) is priced
  // in two halves on the machine's two cores, with the same prices as one loop.
  if (dims_ > 0 && batch.size() >= kTwoCorePricingMinimum) {
    const size_t half = batch.size() / 2;
    runBoth([&] { price(batch.first(half)); }, [&] { price(batch.subspan(half)); });
  } else {
    price(batch);
  }
}

void QuadricModel::refinePlacement(const EngineState& state, CandidateCollapse& chosen) {
  if (chosen.endpoint_only || !fixed_point_pricing_) return;
  Quadric geometric, total;
  mergedQuadrics(state, chosen, geometric, total);
  double value = 0;
  const Vec3d p = minimizeOnEdge(total, state.positions[chosen.from], state.positions[chosen.to],
                                 &value);
  if (!(value < chosen.cost)) return;
  chosen.position = p;
  chosen.cost = value;
  const double area = geometric.weight > 0 ? geometric.weight : 1.0;
  chosen.error = std::sqrt(quadricValue(geometric, p) / area) * state.scale;
}

void QuadricModel::placeAttributes(const EngineState& state, const CandidateCollapse& chosen,
                                   std::span<float> values) {
  // Attributes change only when the position does; a pinned survivor keeps its own.
  if (dims_ == 0 || chosen.endpoint_only) return;
  const uint32_t stride = state.layout.stride;
  const Vec3d p = chosen.position;
  for (uint32_t i = 0; i < chosen.wedge_count; ++i) {
    const double* q = mergedAttributeQuadric(chosen, chosen.to_wedges[i]);
    const double area = q[10];
    if (!(area > 0)) continue;
    const double* column = q + 11;
    const double* bs = q + 11 + 3 * dims_;
    float* out = values.data() + size_t(i) * stride;
    for (uint32_t j = 0; j < dims_; ++j) {
      // Hoppe 1999: the optimal attribute at p, s = -(B_jᵀ p + b_s[j]) / area.
      double s = -(column[3 * j] * p.x + column[3 * j + 1] * p.y + column[3 * j + 2] * p.z + bs[j]) /
                 area;
      double value = s / source_scale_[j];
      if (std::isfinite(value)) out[source_offset_[j]] = float(value);
    }
    renormalizeAttributes(state.layout, out);
  }
}

void QuadricModel::onCollapse(const EngineState& state, const AppliedCollapse& applied) {
  (void)state;
  const CandidateCollapse& c = applied.candidate;
  addInto(geometric_[c.to], geometric_[c.from]);
  if (dims_ == 0) return;
  for (uint32_t i = 0; i < c.wedge_count; ++i) {
    addDoubles(attribute_.data() + size_t(c.to_wedges[i]) * attribute_stride_,
               attribute_.data() + size_t(c.from_wedges[i]) * attribute_stride_, attribute_stride_);
  }
}

}  // namespace duolod::mesh
