// Distance levels and their error bounds: Liang et al., "Automatic Mesh and Shader Level of
// Detail", §3.1 (eq. 3, 4), §3.3 (N initial levels) and Table 1 (per-asset e_max and Q).
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>

#include "duolod/lod.hpp"

namespace duolod::lod {
namespace {
constexpr double kPi = 3.14159265358979323846;

// Table 1 of the paper, LOD config columns.
constexpr std::array<AssetBoundRow, 5> kTableOne = {{
    {"dragon", 0.14f, 0.5f},
    {"imrod", 0.24f, 0.5f},
    {"couch", 0.1f, 0.5f},
    {"rocket", 0.1f, 0.6f},
    {"statue", 0.1f, 0.5f},
}};

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

double discPixels(int footprint_px) {
  return kPi / 4.0 * double(footprint_px) * footprint_px;
}
}  // namespace

std::span<const AssetBoundRow> tableOneBounds() {
  return kTableOne;
}

std::optional<AssetBoundRow> tableOneBound(std::string_view asset) {
  for (const AssetBoundRow& row : kTableOne)
    if (equalsIgnoringCase(row.asset, asset)) return row;
  return std::nullopt;
}

double screenCoverage(const core::Sphere& bounds, double distance, const render::Display& display,
                      float screen_aspect) {
  // The unrounded diameter: the rendered footprint rounds up to whole pixels, up to 8% more
  // area, and a coverage from it switched up to 4% nearer than switch_distance.
  const double diameter =
      render::projectedDiameterPixels(bounds, static_cast<float>(distance), display);
  const double screen = double(display.height_px) * display.height_px * screen_aspect;
  return std::clamp(kPi / 4.0 * diameter * diameter / screen, 0.0, 1.0);
}

core::Result<std::vector<DistanceLevel>> distanceLevels(const core::Sphere& bounds,
                                                        const LevelOptions& options) {
  const metric::BoundConfig& bound = options.bound;
  // (Each level renders its own supersampled references: a thousand is far beyond any use, and
  // a count near INT_MAX would fail to allocate.)
  if (options.level_count < 1 || options.level_count > kMaxLevelCount)
    return core::Error{"LOD levels: level_count must be in [1, " + std::to_string(kMaxLevelCount) +
                       "], got " + std::to_string(options.level_count)};
  if (!(bound.d_near > 0) || !(bound.d_far > bound.d_near))
    return core::Error{"LOD levels: need 0 < d_near < d_far, got d_near = " +
                       std::to_string(bound.d_near) + ", d_far = " + std::to_string(bound.d_far)};
  if (!(bound.q >= 0 && bound.q <= 1) || !(bound.e_max >= 0))
    return core::Error{"LOD levels: need Q in [0, 1] and e_max >= 0 (eq. 4), got Q = " +
                       std::to_string(bound.q) + ", e_max = " + std::to_string(bound.e_max)};
  if (options.display.height_px < 1 || !(options.display.fov_y_deg > 0) ||
      !(options.display.fov_y_deg < 180) || !(options.screen_aspect > 0))
    return core::Error{
        "LOD levels: the display needs height >= 1 px, 0 < fov < 180 degrees and a "
        "positive aspect"};

  std::vector<DistanceLevel> levels(options.level_count);
  const int last = options.level_count - 1;
  for (int i = 0; i < options.level_count; ++i) {
    double t = last == 0 ? 0.0 : double(i) / last;
    double distance = options.spacing == LevelSpacing::kLinear
                          ? bound.d_near + t * (bound.d_far - bound.d_near)
                          : bound.d_near * std::pow(double(bound.d_far) / bound.d_near, t);
    DistanceLevel& level = levels[i];
    level.index = i;
    level.distance = distance;
    level.footprint_px =
        render::footprintPixels(bounds, static_cast<float>(distance), options.display);
    level.per_pixel_bound = metric::perPixelBound(bound, distance);  // eq. (4)
    level.disc_coverage_px = discPixels(level.footprint_px);
    level.screen_coverage =
        screenCoverage(bounds, distance, options.display, options.screen_aspect);
  }
  return levels;
}

}  // namespace duolod::lod
