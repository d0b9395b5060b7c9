// duolod metric: the image error of eq. (6), projected size, and the error bound of eq. (3)/(4)
// (Liang et al., "Automatic Mesh and Shader Level of Detail", §3.1–3.2).
#pragma once

#include "duolod/render.hpp"

namespace duolod::metric {

struct ImageError {
  // eq. (6): per sample, the sum over pixels of the squared L2 norm of the RGB difference (RGB in
  // [0,1]); averaged over the samples (views × lights).
  double epsilon = 0;
  // Mean covered pixels per sample of the reference (sum of its alpha): s_d of eq. (3).
  double coverage_px = 0;
  // epsilon / coverage_px: the per-pixel error e_a is compared with.
  double per_pixel = 0;
  int samples = 0;
};

// Error of `image` against the reference `reference`. Batches of different shapes (or whose
// pixels do not fill their shape) give an infinite epsilon and per_pixel, which no bound accepts.
ImageError imageError(const render::ImageBatch8& image, const render::ImageBatchF& reference);
ImageError imageError(const render::ImageBatch8& image, const render::ImageBatch8& reference);
ImageError imageError(const render::ImageBatchF& image, const render::ImageBatchF& reference);

// Sum over pixels of |rgb_a − rgb_b|² for one tile pair (the integrand of eq. 6).
double tileSquaredError(const uint8_t* a, const float* b, size_t pixel_count);

// Covered pixels of one tile: the sum of alpha.
double tileCoverage(const float* rgba, size_t pixel_count);

// Refuses a reference (f̄ of the original shader) whose alpha is 0 in every pixel: s_d of eq. (3)
// is the sum of its alpha (shaders/INTERFACE.md: alpha 1 where the object is), so against such a
// reference every variant's per-pixel error is 0 and any simplification passes. Its cause is a
// shader that writes no alpha (`out vec3`, undefined alpha: 0 on llvmpipe) or alpha 0.
core::Status checkReferenceCoverage(const render::ImageBatchF& reference);

// The absolute per-pixel error bound of eq. (4): e_a(d) = ((d − d_near)/(d_far − d_near))^Q·e_max,
// with d clamped into [d_near, d_far]; 0 at d_near for every Q.
struct BoundConfig {
  float d_near = 1.0f;
  float d_far = 10.0f;
  float q = 0.5f;       // Q ∈ [0, 1]: how fast quality may degrade with distance
  float e_max = 0.1f;   // maximum absolute per-pixel error
};
double perPixelBound(const BoundConfig& config, double distance);
// eq. (3): ε_a < e_a(d)·s_d.
bool withinBound(const ImageError& error, const BoundConfig& config, double distance);

}  // namespace duolod::metric
