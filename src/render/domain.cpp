// The view × light domain of Liang et al., "Automatic Mesh and Shader Level of Detail", §7:
// cameras at the vertices of a dodecahedron centred on the object, and for each camera 5 point
// lights on the plane through the camera orthogonal to the view direction, at the centre and the
// four ends of a fixed cross.
#include <algorithm>
#include <cmath>

#include "duolod/render.hpp"

namespace duolod::render {
namespace {
using core::Vec3;

constexpr float kPhi = 1.6180339887498949f;  // golden ratio
constexpr float kPi = 3.14159265358979f;

float fractionalPart(float x) { return x - std::floor(x); }

// Point i of n on the unit sphere by the golden-angle spiral (evenly spread, deterministic).
Vec3 spiralDirection(size_t i, size_t n) {
  const float z = 1.0f - 2.0f * (static_cast<float>(i % n) + 0.5f) / static_cast<float>(n);
  const float ring = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float angle = static_cast<float>(i) * 2.39996323f;  // golden angle, radians
  return {ring * std::cos(angle), z, ring * std::sin(angle)};
}

// Sample i of n's pose in the world (Sample::placement): a turn about a spiral axis by an angle,
// a uniform scale in [0.5, 2] and a translation 0.75–1.25 × `distance` × scale along another
// spiral direction, each spread by a different irrational step so that they vary independently.
// The translation is comparable to the camera distance (the camera moves with the object, at
// scale × its distance), so a shader whose result depends on the pose changes visibly.
core::Mat4 placementPose(size_t i, size_t n, float distance) {
  const float index = static_cast<float>(i);
  // Rodrigues' rotation matrix about a unit axis.
  const Vec3 axis = spiralDirection(i * 7 + 3, n);
  const float angle = 2.0f * kPi * fractionalPart(index * 0.7548776662f);
  const float c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  const float scale = std::exp2(2.0f * fractionalPart(index * 0.5698402910f) - 1.0f);
  const Vec3 offset = spiralDirection(i, n) *
                      (distance * scale * (0.75f + 0.5f * fractionalPart(index * 0.6180339887f)));
  core::Mat4 pose = core::Mat4::translation(offset);
  const float rotation[3][3] = {
      {t * axis.x * axis.x + c, t * axis.x * axis.y - s * axis.z, t * axis.x * axis.z + s * axis.y},
      {t * axis.x * axis.y + s * axis.z, t * axis.y * axis.y + c, t * axis.y * axis.z - s * axis.x},
      {t * axis.x * axis.z - s * axis.y, t * axis.y * axis.z + s * axis.x, t * axis.z * axis.z + c}};
  for (int row = 0; row < 3; ++row)
    for (int column = 0; column < 3; ++column) pose.at(row, column) = scale * rotation[row][column];
  return pose;
}

// Keeps a camera outside the sphere it frames, where the framing angle is defined.
float clampedDistance(const core::Sphere& bounds, float distance) {
  return std::max(distance, bounds.radius * 1.001f);
}

}  // namespace

std::vector<Vec3> viewDirections(ViewSet views) {
  std::vector<Vec3> directions;
  if (views == ViewSet::kDodecahedron) {
    // (±1, ±1, ±1), (0, ±1/φ, ±φ), (±1/φ, ±φ, 0), (±φ, 0, ±1/φ)
    for (float x : {-1.f, 1.f})
      for (float y : {-1.f, 1.f})
        for (float z : {-1.f, 1.f}) directions.push_back({x, y, z});
    for (float a : {-1.f, 1.f})
      for (float b : {-1.f, 1.f}) {
        directions.push_back({0, a / kPhi, b * kPhi});
        directions.push_back({a / kPhi, b * kPhi, 0});
        directions.push_back({a * kPhi, 0, b / kPhi});
      }
  } else if (views == ViewSet::kUpright || views == ViewSet::kUprightHeldOut) {
    const bool held_out = views == ViewSet::kUprightHeldOut;
    const float elevations[4] = {-10.0f, 5.0f, 20.0f, 35.0f};
    const int per_ring = held_out ? 3 : 5;
    const float step = 360.0f / per_ring;
    for (int ring = 0; ring < 4; ++ring) {
      // Held out: halfway between the training rings, and azimuths off the training ones.
      const float elevation = (elevations[ring] + (held_out ? 7.5f : 0.0f)) * kPi / 180.0f;
      for (int k = 0; k < per_ring; ++k) {
        const float azimuth =
            (k * step + ring * step / 4 + (held_out ? 9.0f : 0.0f)) * kPi / 180.0f;
        directions.push_back({std::cos(elevation) * std::sin(azimuth), std::sin(elevation),
                              std::cos(elevation) * std::cos(azimuth)});
      }
    }
  } else {
    // (0, ±1, ±φ), (±1, ±φ, 0), (±φ, 0, ±1): the dual's vertices are the dodecahedron's face
    // centres, so no held-out view coincides with a training view.
    for (float a : {-1.f, 1.f})
      for (float b : {-1.f, 1.f}) {
        directions.push_back({0, a, b * kPhi});
        directions.push_back({a, b * kPhi, 0});
        directions.push_back({a * kPhi, 0, b});
      }
  }
  for (Vec3& d : directions) d = core::normalize(d);
  return directions;
}

ViewSet heldOutViews(ViewSet training) {
  switch (training) {
    case ViewSet::kDodecahedron: return ViewSet::kIcosahedron;
    case ViewSet::kUpright: return ViewSet::kUprightHeldOut;
    default: return training;
  }
}

double projectedDiameterPixels(const core::Sphere& bounds, float distance, const Display& display) {
  float d = clampedDistance(bounds, distance);
  // The sphere's silhouette subtends asin(r/d); its projected half-size on the image plane is
  // tan(asin(r/d)) against the display's tan(fov/2) for half the screen height.
  float half_angle = std::asin(std::min(bounds.radius / d, 0.9999f));
  float screen_half = std::tan(display.fov_y_deg * kPi / 360.0f);
  return display.height_px * std::tan(half_angle) / screen_half;
}

int footprintPixels(const core::Sphere& bounds, float distance, const Display& display) {
  const double pixels = projectedDiameterPixels(bounds, distance, display);
  // (NaN, a distance or display that is not a number, is 1, not an undefined conversion.)
  if (!(pixels >= 1)) return 1;
  return pixels >= kMaxTileSize ? kMaxTileSize : static_cast<int>(std::ceil(pixels));
}

float distanceForDiameterPixels(const core::Sphere& bounds, int pixels, const Display& display) {
  const float screen_half = std::tan(display.fov_y_deg * kPi / 360.0f);
  const float half_angle = std::atan(float(pixels) / float(display.height_px) * screen_half);
  return bounds.radius / std::sin(half_angle);
}

float distanceForFootprint(const core::Sphere& bounds, int pixels, const Display& display) {
  float near = bounds.radius * 1.01f, far = bounds.radius * 1e4f;
  // A narrow field of view or a tall display can leave the object larger than `pixels` beyond
  // 1e4 radii: the bracket grows until it is not (before, the search returned 1e4 radii).
  for (int i = 0;
       i < 64 && footprintPixels(bounds, far, display) > pixels && std::isfinite(far * 2.0f); ++i)
    near = far, far *= 2.0f;
  for (int i = 0; i < 60; ++i) {
    const float middle = 0.5f * (near + far);
    if (footprintPixels(bounds, middle, display) > pixels)
      near = middle;
    else
      far = middle;
  }
  return far;
}

std::vector<Sample> domainSamples(const core::Sphere& bounds, float distance,
                                  const DomainOptions& options) {
  float d = clampedDistance(bounds, distance);
  float half_angle = std::asin(std::min(bounds.radius / d, 0.9999f));
  core::Mat4 projection = core::perspective(2 * half_angle, 1.0f, std::max(d - bounds.radius * 1.01f, d * 1e-3f),
                                            d + bounds.radius * 1.01f);
  std::vector<Sample> samples;
  std::vector<Vec3> directions = viewDirections(options.views);
  for (size_t v = 0; v < directions.size(); ++v) {
    Vec3 direction = directions[v];
    Vec3 eye = bounds.center + direction * d;
    Vec3 up = std::fabs(direction.y) > 0.99f ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
    core::Mat4 view = core::lookAt(eye, bounds.center, up);
    // Screen-aligned axes of the light plane.
    Vec3 right = core::normalize(core::cross(-direction, up));
    Vec3 screen_up = core::cross(right, -direction);
    float rotation = options.light_rotation_deg * kPi / 180.0f;
    Vec3 axis_a = right * std::cos(rotation) + screen_up * std::sin(rotation);
    Vec3 axis_b = screen_up * std::cos(rotation) - right * std::sin(rotation);
    float arm = options.light_cross_arm * d;
    std::vector<Vec3> offsets;
    if (options.light_cross_center) offsets.push_back({0, 0, 0});
    for (Vec3 axis : {axis_a, axis_b})
      for (float sign : {1.f, -1.f}) offsets.push_back(axis * (sign * arm));
    for (size_t l = 0; l < offsets.size(); ++l)
      samples.push_back({static_cast<int>(v), static_cast<int>(l), eye, eye + offsets[l], view,
                         projection, core::Mat4::identity()});
  }
  if (options.place_objects)
    for (size_t i = 0; i < samples.size(); ++i)
      samples[i].placement = placementPose(i, samples.size(), options.placement_distance * d);
  return samples;
}

}  // namespace duolod::render
