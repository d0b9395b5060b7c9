// Image error of Liang et al., eq. (6): squared L2 of pixelwise RGB differences summed over the
// image, averaged over views × lights; and the per-pixel bound of eq. (4) it is tested against.
#include <algorithm>
#include <cmath>
#include <limits>

#include "duolod/metric.hpp"

namespace duolod::metric {
namespace {

constexpr float kInv255 = 1.0f / 255.0f;

template <class A, class B>
double squaredError(const A* a, const B* b, size_t pixel_count, float scale_a, float scale_b) {
  double sum = 0;
  for (size_t p = 0; p < pixel_count; ++p) {
    float dr = a[p * 4] * scale_a - b[p * 4] * scale_b;
    float dg = a[p * 4 + 1] * scale_a - b[p * 4 + 1] * scale_b;
    float db = a[p * 4 + 2] * scale_a - b[p * 4 + 2] * scale_b;
    sum += dr * dr + dg * dg + db * db;
  }
  return sum;
}

template <class T>
double coverage(const T* rgba, size_t pixel_count, float scale) {
  double sum = 0;
  for (size_t p = 0; p < pixel_count; ++p) sum += rgba[p * 4 + 3] * scale;
  return sum;
}

template <class A, class B>
ImageError batchError(const render::TiledImages<A>& image, const render::TiledImages<B>& reference,
                      float scale_a, float scale_b) {
  ImageError result;
  size_t pixels = size_t(std::max(image.width, 0)) * size_t(std::max(image.height, 0));
  auto holds = [&](const auto& batch) {
    return batch.count >= 0 && batch.pixels.size() == size_t(batch.count) * pixels * 4;
  };
  // Batches of different shapes (or pixels that do not fill their shape) cannot be compared: an
  // infinite error, which no bound accepts, instead of reading past a buffer.
  if (image.width != reference.width || image.height != reference.height ||
      image.count != reference.count || !holds(image) || !holds(reference)) {
    result.epsilon = result.per_pixel = std::numeric_limits<double>::infinity();
    return result;
  }
  result.samples = image.count;
  if (image.count == 0) return result;
  double error_sum = 0, coverage_sum = 0;
  for (int i = 0; i < image.count; ++i) {
    error_sum += squaredError(image.tile(i), reference.tile(i), pixels, scale_a, scale_b);
    coverage_sum += coverage(reference.tile(i), pixels, scale_b);
  }
  result.epsilon = error_sum / image.count;
  result.coverage_px = coverage_sum / image.count;
  result.per_pixel = result.coverage_px > 0 ? result.epsilon / result.coverage_px : 0;
  return result;
}

}  // namespace

ImageError imageError(const render::ImageBatch8& image, const render::ImageBatchF& reference) {
  return batchError(image, reference, kInv255, 1.0f);
}
ImageError imageError(const render::ImageBatch8& image, const render::ImageBatch8& reference) {
  return batchError(image, reference, kInv255, kInv255);
}
ImageError imageError(const render::ImageBatchF& image, const render::ImageBatchF& reference) {
  return batchError(image, reference, 1.0f, 1.0f);
}

double tileSquaredError(const uint8_t* a, const float* b, size_t pixel_count) {
  return squaredError(a, b, pixel_count, kInv255, 1.0f);
}

double tileCoverage(const float* rgba, size_t pixel_count) { return coverage(rgba, pixel_count, 1.0f); }

core::Status checkReferenceCoverage(const render::ImageBatchF& reference) {
  for (size_t i = 3; i < reference.pixels.size(); i += 4)
    if (reference.pixels[i] > 0) return core::okStatus();
  if (reference.count == 0) return core::okStatus();
  return core::Error{
      "the original's alpha is 0 in every pixel of its " + std::to_string(reference.count) +
      " images: duolod counts the object's pixels by the output's alpha (shaders/INTERFACE.md: "
      "`out vec4 outColor`, alpha 1 where the object is), so every error would be 0. Write "
      "alpha 1 (a vec3 output leaves it undefined); or no view sees the object's front faces "
      "(a one-sided surface: make its material double-sided)"};
}

double perPixelBound(const BoundConfig& config, double distance) {
  double span = std::max(1e-9, double(config.d_far) - config.d_near);
  double t = std::clamp((distance - config.d_near) / span, 0.0, 1.0);
  // At d_near the bound is 0 for every Q, Q = 0 too (pow(0, 0) is 1): the original's distance.
  if (!(t > 0)) return 0;
  return std::pow(t, double(config.q)) * config.e_max;  // eq. (4)
}

bool withinBound(const ImageError& error, const BoundConfig& config, double distance) {
  return error.epsilon < perPixelBound(config, distance) * error.coverage_px;  // eq. (3)
}

}  // namespace duolod::metric
