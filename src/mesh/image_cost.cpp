// The image-driven collapse cost (Liang et al. §4.2, §5.1; Lindstrom & Turk 2000). See
// image_cost.hpp for the scheme; the comments here say why each step is as it is.
#include "mesh/image_cost.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "mesh/run_both.hpp"

namespace duolod::mesh {
namespace {

constexpr float kForbidden = std::numeric_limits<float>::infinity();

uint64_t edgeKey(uint32_t from, uint32_t to) { return uint64_t(from) << 32 | to; }

// Twice the signed area of a screen triangle in pixels². Rows run down, so OpenGL's counter-
// clockwise front faces have negative area here, back faces positive.
template <class Point>
float signedArea(const Point (&c)[3]) {
  return (c[1].x - c[0].x) * (c[2].y - c[0].y) - (c[2].x - c[0].x) * (c[1].y - c[0].y);
}

}  // namespace

ImageCostModel::ImageCostModel(ImageCostSetup setup)
    : setup_(std::move(setup)), quadric_(QuadricModelOptions{.endpoint_only = true}) {}

void ImageCostModel::begin(const EngineState& state) {
  quadric_.begin(state);
  const int R = setup_.resolution;
  view_count_ = int(setup_.samples.size()) / setup_.lights_per_view;
  position_count_ = state.positions.size();

  // Positions never move (endpoint placement), so each view's projection is computed once.
  projected_.resize(size_t(view_count_) * position_count_);
  for (int v = 0; v < view_count_; ++v) {
    const render::Sample& sample = setup_.samples[size_t(v) * setup_.lights_per_view];
    core::Mat4 view_projection = sample.projection * sample.view;
    for (size_t p = 0; p < position_count_; ++p) {
      core::Vec3 a = state.asset_positions[p];
      core::Vec4 clip = core::transform(view_projection, {a.x, a.y, a.z, 1});
      float w = clip.w > 1e-12f ? clip.w : 1e-12f;
      projected_[size_t(v) * position_count_ + p] = {(clip.x / w * 0.5f + 0.5f) * R,
                                                     (0.5f - clip.y / w * 0.5f) * R,
                                                     clip.z / w * 0.5f + 0.5f};
    }
  }

  // Cells of a few pixels: a collapse's region is a few pixels wide, and at small footprints many
  // triangles share each pixel.
  cell_pixels_ = std::max(2, R / 64);
  cells_per_side_ = (R + cell_pixels_ - 1) / cell_pixels_;
  bins_.assign(size_t(view_count_) * cells_per_side_ * cells_per_side_, {});
  for (TileScratch& scratch : scratch_) {
    scratch.triangle_mark.assign(state.triangle_alive.size(), 0);
    scratch.mark_round = 0;
  }
  for (uint32_t t = 0; t < state.triangle_alive.size(); ++t)
    if (state.triangle_alive[t]) binTriangle(state, t);

  const size_t samples = setup_.samples.size();
  sample_error_.assign(samples, 0);
  for (size_t s = 0; s < samples; ++s) {
    const uint8_t* image = setup_.current.tile(int(s));
    for (int y = 0; y < R; ++y)
      for (int x = 0; x < R; ++x)
        sample_error_[s] += pixelError(image + (size_t(y) * R + x) * 4, int(s), x, y);
  }
}

double ImageCostModel::pixelError(const uint8_t* rgba, int sample, int x, int y) const {
  const float* reference =
      setup_.reference->tile(sample) + (size_t(y) * setup_.resolution + x) * 4;
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    double d = rgba[c] * (1.0 / 255.0) - reference[c];
    sum += d * d;
  }
  return sum;
}

double ImageCostModel::currentError() const {
  double sum = 0;
  for (double e : sample_error_) sum += e;
  return sample_error_.empty() ? 0 : sum / double(sample_error_.size());
}

bool ImageCostModel::edgeTooLong(uint32_t from, uint32_t to) const {
  // §4.2: an edge longer than D pixels on screen changes the image visibly whatever it costs.
  const float limit = setup_.max_edge_pixels * setup_.max_edge_pixels;
  for (int v = 0; v < view_count_; ++v) {
    PixelPoint a = projected(v, from), b = projected(v, to);
    float dx = a.x - b.x, dy = a.y - b.y;
    if (dx * dx + dy * dy > limit) return true;
  }
  return false;
}

bool ImageCostModel::collapseUnseen(const EngineState& state, uint32_t from, uint32_t to,
                                    int view) const {
  // The margin keeps nearly edge-on triangles, whose facing the rasterizer might judge
  // otherwise, counted as visible.
  constexpr float kMargin = 0.01f;
  auto facesAway = [&](const PixelPoint (&c)[3]) { return signedArea(c) > kMargin; };
  bool unseen = true;
  state.forEachCorner(from, [&](uint32_t corner) {
    if (!unseen) return;
    const uint32_t t = corner / 3;
    PixelPoint before[3], after[3];
    bool vanishes = false;
    for (int k = 0; k < 3; ++k) {
      uint32_t position = state.cornerPosition(t * 3 + k);
      before[k] = projected(view, position);
      vanishes |= position == to;
      after[k] = projected(view, position == from ? to : position);
    }
    if (!facesAway(before) || (!vanishes && !facesAway(after))) unseen = false;
  });
  return unseen;
}

void ImageCostModel::beforeCollapse(const EngineState& state, const CandidateCollapse& chosen) {
  applying_unseen_.assign(view_count_, 0);
  for (int v = 0; v < view_count_; ++v)
    applying_unseen_[v] = collapseUnseen(state, chosen.from, chosen.to, v);
}

void ImageCostModel::binTriangle(const EngineState& state, uint32_t triangle) {
  const int cells = cells_per_side_;
  for (int v = 0; v < view_count_; ++v) {
    float min_x = 1e30f, min_y = 1e30f, max_x = -1e30f, max_y = -1e30f;
    PixelPoint c[3];
    for (int k = 0; k < 3; ++k) {
      PixelPoint p = c[k] = projected(v, state.cornerPosition(triangle * 3 + k));
      min_x = std::min(min_x, p.x), max_x = std::max(max_x, p.x);
      min_y = std::min(min_y, p.y), max_y = std::max(max_y, p.y);
    }
    // Back-facing now: never drawn, so not listed (re-binned if a collapse turns it).
    if (!(signedArea(c) < 0))
      continue;
    int cx0 = std::clamp(int(std::floor(min_x)) / cell_pixels_, 0, cells - 1);
    int cx1 = std::clamp(int(std::floor(max_x)) / cell_pixels_, 0, cells - 1);
    int cy0 = std::clamp(int(std::floor(min_y)) / cell_pixels_, 0, cells - 1);
    int cy1 = std::clamp(int(std::floor(max_y)) / cell_pixels_, 0, cells - 1);
    if (max_x < 0 || max_y < 0 || min_x >= setup_.resolution || min_y >= setup_.resolution)
      continue;  // off screen in this view
    for (int cy = cy0; cy <= cy1; ++cy)
      for (int cx = cx0; cx <= cx1; ++cx)
        bins_[(size_t(v) * cells + cy) * cells + cx].push_back(triangle);
  }
}

bool ImageCostModel::collapseRegion(const EngineState& state, const CandidateCollapse& candidate,
                                    int view, Region& region) const {
  // Only triangles at `from` change (their `from` corner moves to `to`; those holding both
  // vanish), so the changed pixels lie in the box of from's one-ring, which contains `to`.
  PixelPoint p = projected(view, candidate.from);
  float min_x = p.x, max_x = p.x, min_y = p.y, max_y = p.y;
  state.forEachCorner(candidate.from, [&](uint32_t corner) {
    uint32_t t = corner / 3;
    for (int k = 0; k < 3; ++k) {
      PixelPoint q = projected(view, state.cornerPosition(t * 3 + k));
      min_x = std::min(min_x, q.x), max_x = std::max(max_x, q.x);
      min_y = std::min(min_y, q.y), max_y = std::max(max_y, q.y);
    }
  });
  region = pixelCentresWithin(min_x, min_y, max_x, max_y, setup_.resolution);
  return region.x1 - region.x0 <= setup_.tile_size && region.y1 - region.y0 <= setup_.tile_size;
}

ImageCostModel::Region ImageCostModel::pixelCentresWithin(float min_x, float min_y, float max_x,
                                                          float max_y, int resolution) {
  // A triangle covers only pixel centres inside its box, up to OpenGL's snapping (kPixelSlack).
  // (The region had a whole pixel of margin on each side: at small footprints, where a one-ring
  // spans two or three pixels, most of its pixels, and the triangles seen there, were ones no
  // collapse could change.)
  auto first = [&](float low) {
    return std::clamp(int(std::ceil(low - 0.5f - kPixelSlack)), 0, resolution);
  };
  auto end = [&](float high) {
    return std::clamp(int(std::floor(high - 0.5f + kPixelSlack)) + 1, 0, resolution);
  };
  Region region{first(min_x), first(min_y), end(max_x), end(max_y)};
  if (region.x1 < region.x0) region.x1 = region.x0;
  if (region.y1 < region.y0) region.y1 = region.y0;
  return region;
}

void ImageCostModel::appendTriangle(const EngineState& state, const uint32_t wedges[3],
                                    uint32_t tile, uint32_t group,
                                    render::Renderer::RegionSoup& soup) const {
  const AttributeLayout& layout = state.layout;
  core::Mesh& m = soup.triangles;
  for (int k = 0; k < 3; ++k) {
    const float* a = state.wedgeAttributes(wedges[k]);
    m.positions.push_back(state.asset_positions[state.wedge_position[wedges[k]]]);
    if (layout.normal != kAbsent)
      m.normals.push_back({a[layout.normal], a[layout.normal + 1], a[layout.normal + 2]});
    if (layout.tangent != kAbsent)
      m.tangents.push_back({a[layout.tangent], a[layout.tangent + 1], a[layout.tangent + 2],
                            a[layout.tangent + 3]});
    if (layout.uv0 != kAbsent) m.uv0.push_back({a[layout.uv0], a[layout.uv0 + 1]});
    if (layout.uv1 != kAbsent) m.uv1.push_back({a[layout.uv1], a[layout.uv1 + 1]});
    if (layout.color != kAbsent)
      m.colors.push_back({a[layout.color], a[layout.color + 1], a[layout.color + 2],
                          a[layout.color + 3]});
  }
  soup.triangle_tile.push_back(tile);
  soup.triangle_material.push_back(group < setup_.group_material.size()
                                       ? setup_.group_material[group]
                                       : 0);
}

void ImageCostModel::buildSoup(const EngineState& state, std::span<const TileJob> jobs,
                               render::Renderer::RegionSoup& soup) {
  buildTiles(state, jobs, tile_triangles_);
  for (uint32_t tile = 0; tile < jobs.size(); ++tile) {
    const Region& r = jobs[tile].region;
    soup.tiles.push_back({jobs[tile].view, r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0});
    appendToSoup(state, tile_triangles_[tile], tile, soup);
  }
}

void ImageCostModel::buildTiles(const EngineState& state, std::span<const TileJob> jobs,
                                std::vector<std::vector<LocalTriangle>>& triangles) {
  if (triangles.size() < jobs.size()) triangles.resize(jobs.size());
  auto build = [&](TileScratch& scratch, size_t first, size_t step) {
    for (size_t i = first; i < jobs.size(); i += step)
      buildTile(state, jobs[i], scratch, triangles[i]);
  };
  // Between two renders the GPU's threads are idle: this is the one stretch of the image-driven
  // mode's work that ran on one core (bench/RESULTS.md, issue 3, session 29). Jobs alternate
  // between the threads, which share only what they read.
  constexpr size_t kTwoThreadJobs = 16;
  if (jobs.size() < kTwoThreadJobs) {
    build(scratch_[0], 0, 1);
    return;
  }
  runBoth([&] { build(scratch_[0], 0, 2); }, [&] { build(scratch_[1], 1, 2); });
}

void ImageCostModel::buildTile(const EngineState& state, const TileJob& job,
                               TileScratch& scratch, std::vector<LocalTriangle>& out) const {
  out.clear();
  const CandidateCollapse* c = job.collapse;
  gatherTriangles(state, job.view, job.region, c ? c->from : kAbsent, scratch, out);
  if (c) {
    // The moved triangles: from's corner takes the wedge (and position) it merges into.
    state.forEachCorner(c->from, [&](uint32_t corner) {
      uint32_t t = corner / 3;
      LocalTriangle moved;
      moved.group = state.groups[t];
      bool vanishes = false;
      for (int k = 0; k < 3; ++k) {
        uint32_t w = state.corners[t * 3 + k];
        uint32_t position = state.wedge_position[w];
        vanishes |= position == c->to;
        if (position == c->from) {
          for (int m = 0; m < c->wedge_count; ++m)
            if (c->from_wedges[m] == w) w = c->to_wedges[m];
          position = c->to;
        }
        moved.wedges[k] = w;
        moved.corners[k] = projected(job.view, position);
      }
      if (!vanishes) out.push_back(moved);
    });
  }
  keepVisible(job.region, scratch, out);
}

void ImageCostModel::gatherTriangles(const EngineState& state, int view, const Region& region,
                                     uint32_t skip_position, TileScratch& scratch,
                                     std::vector<LocalTriangle>& out) const {
  if (++scratch.mark_round == 0) {
    std::fill(scratch.triangle_mark.begin(), scratch.triangle_mark.end(), 0);
    scratch.mark_round = 1;
  }
  const int cells = cells_per_side_;
  int cx0 = std::clamp(region.x0 / cell_pixels_, 0, cells - 1);
  int cx1 = std::clamp((region.x1 - 1) / cell_pixels_, 0, cells - 1);
  int cy0 = std::clamp(region.y0 / cell_pixels_, 0, cells - 1);
  int cy1 = std::clamp((region.y1 - 1) / cell_pixels_, 0, cells - 1);
  // Pixel centres of the region lie in [x0 + 0.5, x1 − 0.5]: a triangle whose box misses that
  // range (by more than OpenGL's snapping) covers none of them.
  const float min_cx = region.x0 + 0.5f - kPixelSlack, max_cx = region.x1 - 0.5f + kPixelSlack;
  const float min_cy = region.y0 + 0.5f - kPixelSlack, max_cy = region.y1 - 0.5f + kPixelSlack;
  for (int cy = cy0; cy <= cy1; ++cy)
    for (int cx = cx0; cx <= cx1; ++cx)
      for (uint32_t t : bins_[(size_t(view) * cells + cy) * cells + cx]) {
        if (!state.triangle_alive[t] || scratch.triangle_mark[t] == scratch.mark_round) continue;
        scratch.triangle_mark[t] = scratch.mark_round;
        LocalTriangle local;
        local.group = state.groups[t];
        bool skip = false;
        float min_x = 1e30f, min_y = 1e30f, max_x = -1e30f, max_y = -1e30f;
        for (int k = 0; k < 3; ++k) {
          uint32_t position = state.cornerPosition(t * 3 + k);
          skip |= position == skip_position;
          local.wedges[k] = state.corners[t * 3 + k];
          local.corners[k] = projected(view, position);
          min_x = std::min(min_x, local.corners[k].x), max_x = std::max(max_x, local.corners[k].x);
          min_y = std::min(min_y, local.corners[k].y), max_y = std::max(max_y, local.corners[k].y);
        }
        if (skip || max_x < min_cx || min_x > max_cx || max_y < min_cy || min_y > max_cy) continue;
        out.push_back(local);
      }
}

void ImageCostModel::keepVisible(const Region& region, TileScratch& scratch,
                                 std::vector<LocalTriangle>& triangles) {
  const int width = region.x1 - region.x0, height = region.y1 - region.y0;
  std::vector<float>& depth = scratch.depth;
  depth.assign(size_t(width) * height, 2.0f);
  // Two passes over the front faces: the nearest depth at every pixel centre, then every triangle
  // that reaches within a tolerance of it. The tolerances keep what OpenGL might draw where our
  // rasterization and its (fixed-point, top-left-rule) one can disagree: on shared edges, and
  // within 1/64 pixel of an edge.
  constexpr float kDepthTolerance = 1e-5f;
  auto rasterize = [&](const LocalTriangle& t, float slack, auto&& visit) {
    const PixelPoint* c = t.corners;
    // Rows top first flip the winding: OpenGL's counter-clockwise front faces have negative area.
    float area = signedArea(t.corners);
    if (!(area < 0)) return;  // back-facing or degenerate: culled like glCullFace(GL_BACK)
    float min_x = std::min({c[0].x, c[1].x, c[2].x}), max_x = std::max({c[0].x, c[1].x, c[2].x});
    float min_y = std::min({c[0].y, c[1].y, c[2].y}), max_y = std::max({c[0].y, c[1].y, c[2].y});
    int px0 = std::max(region.x0, int(std::ceil(min_x - 0.5f - slack)));
    int px1 = std::min(region.x1 - 1, int(std::floor(max_x - 0.5f + slack)));
    int py0 = std::max(region.y0, int(std::ceil(min_y - 0.5f - slack)));
    int py1 = std::min(region.y1 - 1, int(std::floor(max_y - 0.5f + slack)));
    float inverse_area = 1.0f / area;
    // Slack along each edge's normal: the edge function grows with the edge's length.
    auto length = [](PixelPoint a, PixelPoint b) {
      return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y));
    };
    float e0 = slack * length(c[2], c[1]);
    float e1 = slack * length(c[0], c[2]);
    float e2 = slack * length(c[1], c[0]);
    for (int py = py0; py <= py1; ++py)
      for (int px = px0; px <= px1; ++px) {
        float x = px + 0.5f, y = py + 0.5f;
        // Edge functions; all ≤ 0 inside for this (negative-area) winding.
        float w0 = (c[2].x - c[1].x) * (y - c[1].y) - (c[2].y - c[1].y) * (x - c[1].x);
        float w1 = (c[0].x - c[2].x) * (y - c[2].y) - (c[0].y - c[2].y) * (x - c[2].x);
        float w2 = (c[1].x - c[0].x) * (y - c[0].y) - (c[1].y - c[0].y) * (x - c[0].x);
        if (w0 > e0 || w1 > e1 || w2 > e2) continue;
        float z = (w0 * c[0].z + w1 * c[1].z + w2 * c[2].z) * inverse_area;
        visit(size_t(py - region.y0) * width + (px - region.x0), z);
      }
  };
  // Occluders only where they surely cover the pixel centre (slack inwards): a triangle whose
  // edge passes within the slack of a centre may not be drawn there by OpenGL, and then what lies
  // behind it shows (at silhouettes: the background or a farther fold).
  for (const LocalTriangle& t : triangles)
    rasterize(t, -kPixelSlack,
              [&](size_t at, float z) { depth[at] = std::min(depth[at], z); });
  size_t kept = 0;
  for (size_t i = 0; i < triangles.size(); ++i) {
    bool visible = false;
    rasterize(triangles[i], kPixelSlack, [&](size_t at, float z) {
      visible |= z <= depth[at] + kDepthTolerance;
    });
    if (visible) triangles[kept++] = triangles[i];  // original order: deterministic soups
  }
  triangles.resize(kept);
}

void ImageCostModel::appendToSoup(const EngineState& state,
                                  const std::vector<LocalTriangle>& triangles, uint32_t tile,
                                  render::Renderer::RegionSoup& soup) const {
  for (const LocalTriangle& t : triangles) appendTriangle(state, t.wedges, tile, t.group, soup);
}

void ImageCostModel::evaluate(const EngineState& state, std::span<CandidateCollapse> batch) {
  quadric_.evaluate(state, batch);  // cost = quadric error: the estimate before rendering
  for (CandidateCollapse& c : batch) {
    c.position = state.positions[c.to];
    if (edgeTooLong(c.from, c.to)) {
      ++stats_.rejected_long_edges;
      c.cost = c.error = kForbidden;
      c.exact = true;
      continue;
    }
    auto known = last_cost_.find(edgeKey(c.from, c.to));
    if (known != last_cost_.end())
      c.cost = known->second;
    else if (quadric_to_image_ > 0)
      c.cost *= quadric_to_image_;
    c.error = 0;  // unknown until rendered; never a reason to skip
    c.exact = false;
  }
}

void ImageCostModel::refine(const EngineState& state, std::span<CandidateCollapse> batch) {
  if (!failure_.empty()) {
    for (CandidateCollapse& c : batch) c.cost = c.error = kForbidden, c.exact = true;
    return;
  }
  auto start = std::chrono::steady_clock::now();
  auto since = [](auto t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  size_t refreshed_before = stats_.refreshed_regions;
  size_t pending_pixels = 0;
  for (const auto& [view, region] : pending_)
    pending_pixels += size_t(region.x1 - region.x0) * (region.y1 - region.y0);
  const size_t view_pixels = size_t(setup_.resolution) * setup_.resolution * view_count_;
  if (pending_pixels * 4 > view_pixels || ++batches_since_full_ >= 32)
    renderFully(state);
  else
    refreshPendingRegions(state);
  double refresh_s = since(start);
  auto build_start = std::chrono::steady_clock::now();

  // One tile per (candidate, view): the candidate's neighbourhood with the collapse applied.
  struct Placed {
    uint32_t candidate;
    int view;
    Region region;
  };
  std::vector<Placed> placed;
  std::vector<TileJob> jobs;
  render::Renderer::RegionSoup soup;
  std::vector<uint8_t> usable(batch.size(), 1);
  for (uint32_t i = 0; i < batch.size(); ++i) {
    const CandidateCollapse& c = batch[i];
    std::vector<Placed> mine;
    for (int v = 0; v < view_count_ && usable[i]; ++v) {
      Region region;
      if (!collapseRegion(state, c, v, region)) usable[i] = 0;
      mine.push_back({i, v, region});
    }
    if (!usable[i]) {
      ++stats_.rejected_wide_regions;
      continue;
    }
    for (const Placed& p : mine) {
      // Nothing to render where the collapse shows nowhere: its change of eq. (6) there is 0.
      const bool no_pixel = p.region.x1 == p.region.x0 || p.region.y1 == p.region.y0;
      if (no_pixel || collapseUnseen(state, c.from, c.to, p.view)) {
        ++stats_.unseen_views;
        continue;
      }
      jobs.push_back({p.view, p.region, &c});
      placed.push_back(p);
    }
  }
  buildSoup(state, jobs, soup);

  const int R = setup_.resolution, T = setup_.tile_size, L = setup_.lights_per_view;
  double build_s = since(build_start);
  auto render_start = std::chrono::steady_clock::now();
  auto tiles = setup_.renderer->renderRegions(setup_.asset, setup_.region_program, soup,
                                              setup_.samples, L, R, T);
  double render_s = since(render_start);
  if (!tiles) {
    failure_ = tiles.error().message;
    for (CandidateCollapse& c : batch) c.cost = c.error = kForbidden, c.exact = true;
    return;
  }
  if (std::getenv("DUOLOD_DEBUG"))
    std::fprintf(stderr,
                 "refine %zu: %zu candidates, %zu tiles, %zu soup triangles; refresh %zu regions "
                 "%.0f ms, build %.0f ms, render %.0f ms\n",
                 stats_.refine_batches, batch.size(), soup.tiles.size(), soup.triangle_tile.size(),
                 stats_.refreshed_regions - refreshed_before, refresh_s * 1e3, build_s * 1e3,
                 render_s * 1e3);
  std::vector<double> delta(batch.size(), 0);
  for (size_t tile = 0; tile < placed.size(); ++tile) {
    const Placed& p = placed[tile];
    for (int light = 0; light < L; ++light) {
      int sample = p.view * L + light;
      const uint8_t* rendered = tiles->tile(int(tile) * L + light);
      const uint8_t* current = setup_.current.tile(sample);
      for (int y = p.region.y0; y < p.region.y1; ++y)
        for (int x = p.region.x0; x < p.region.x1; ++x) {
          const uint8_t* now = rendered + (size_t(y - p.region.y0) * T + (x - p.region.x0)) * 4;
          delta[p.candidate] += pixelError(now, sample, x, y) -
                                pixelError(current + (size_t(y) * R + x) * 4, sample, x, y);
        }
    }
  }
  // Keep the tiles: an applied candidate's new pixels are in them (see onCollapse).
  last_refined_.clear();
  last_placed_.clear();
  changed_since_refine_.clear();
  for (size_t first = 0; first < placed.size();) {
    size_t end = first;
    while (end < placed.size() && placed[end].candidate == placed[first].candidate) ++end;
    const CandidateCollapse& c = batch[placed[first].candidate];
    last_refined_[edgeKey(c.from, c.to)] = {uint32_t(first), uint32_t(end)};
    first = end;
  }
  for (size_t i = 0; i < placed.size(); ++i)
    last_placed_.push_back({placed[i].view, placed[i].region, uint32_t(i)});

  // The quadric cost of each, to learn how image costs scale against it for the estimates.
  std::vector<CandidateCollapse> quadric_priced(batch.begin(), batch.end());
  quadric_.evaluate(state, quadric_priced);
  const double error_now = currentError();
  const double samples = double(setup_.samples.size());
  for (uint32_t i = 0; i < batch.size(); ++i) {
    CandidateCollapse& c = batch[i];
    c.exact = true;
    if (!usable[i]) {
      c.cost = c.error = kForbidden;
      continue;
    }
    double quadric_cost = quadric_priced[i].cost;
    c.cost = delta[i] / samples;  // the change of eq. (6), averaged over views × lights
    c.error = error_now + c.cost;
    last_cost_[edgeKey(c.from, c.to)] = float(c.cost);
    if (quadric_cost > 0 && c.cost > 0) ratios_.push_back(c.cost / quadric_cost);
  }
  // Estimates for unpriced candidates: quadric × the median ratio seen so far.
  if (ratios_.size() > 4096) ratios_.erase(ratios_.begin(), ratios_.end() - 2048);
  if (!ratios_.empty()) {
    std::vector<double> sorted = ratios_;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    quadric_to_image_ = sorted[sorted.size() / 2];
  }
  last_tiles_ = std::move(tiles.value());
  stats_.rendered_evaluations += batch.size();
  ++stats_.refine_batches;
  stats_.render_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void ImageCostModel::onCollapse(const EngineState& state, const AppliedCollapse& applied) {
  quadric_.onCollapse(state, applied);
  // The queue clamps negative costs to 0; the rendered value is the one to add up.
  auto known = last_cost_.find(edgeKey(applied.candidate.from, applied.candidate.to));
  stats_.predicted_change += known != last_cost_.end() ? known->second : applied.candidate.cost;
  const uint32_t survivor = applied.candidate.to, removed = applied.candidate.from;
  const int R = setup_.resolution, L = setup_.lights_per_view;
  auto overlaps = [](const Region& a, const Region& b) {
    return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
  };
  auto priced = last_refined_.find(edgeKey(removed, survivor));
  for (int v = 0; v < view_count_; ++v) {
    if (size_t(v) < applying_unseen_.size() && applying_unseen_[v]) continue;  // no pixel changed
    // Priced in the last batch, with nothing applied near it since: copy its rendered pixels.
    if (priced != last_refined_.end()) {
      const PricedTile* tile = nullptr;
      for (uint32_t i = priced->second.first; i < priced->second.second; ++i)
        if (last_placed_[i].view == v) tile = &last_placed_[i];
      bool untouched = tile != nullptr;
      for (const auto& [view, region] : changed_since_refine_)
        if (untouched && view == v && overlaps(region, tile->region)) untouched = false;
      if (untouched) {
        const Region& region = tile->region;
        for (int light = 0; light < L; ++light)
          writeTile(last_tiles_.tile(int(tile->tile) * L + light), v * L + light, region);
        changed_since_refine_.push_back({v, region});
        ++stats_.copied_regions;
        continue;
      }
    }
    // Otherwise re-render the changed pixels before the next pricing: the box of the survivor's
    // new one-ring and the removed vertex.
    PixelPoint p = projected(v, removed);
    float min_x = p.x, max_x = p.x, min_y = p.y, max_y = p.y;
    state.forEachCorner(survivor, [&](uint32_t corner) {
      for (int k = 0; k < 3; ++k) {
        PixelPoint q = projected(v, state.cornerPosition(corner / 3 * 3 + k));
        min_x = std::min(min_x, q.x), max_x = std::max(max_x, q.x);
        min_y = std::min(min_y, q.y), max_y = std::max(max_y, q.y);
      }
    });
    const Region region = pixelCentresWithin(min_x, min_y, max_x, max_y, R);
    if (region.x1 > region.x0 && region.y1 > region.y0) {
      pending_.push_back({v, region});
      changed_since_refine_.push_back({v, region});
    }
  }
  // The survivor's triangles changed shape: list them in the cells they reach now.
  state.forEachCorner(survivor, [&](uint32_t corner) { binTriangle(state, corner / 3); });
}

void ImageCostModel::writeTile(const uint8_t* tile, int sample, const Region& region) {
  const int R = setup_.resolution, T = setup_.tile_size;
  uint8_t* current = setup_.current.tile(sample);
  for (int y = region.y0; y < region.y1; ++y)
    for (int x = region.x0; x < region.x1; ++x) {
      const uint8_t* now = tile + (size_t(y - region.y0) * T + (x - region.x0)) * 4;
      uint8_t* old = current + (size_t(y) * R + x) * 4;
      sample_error_[sample] += pixelError(now, sample, x, y) - pixelError(old, sample, x, y);
      std::copy_n(now, 4, old);
    }
}

void ImageCostModel::renderFully(const EngineState& state) {
  batches_since_full_ = 0;
  pending_.clear();
  if (!failure_.empty()) return;
  // The current mesh: every wedge (unreferenced ones are harmless), live triangles by submesh.
  const AttributeLayout& layout = state.layout;
  core::Mesh mesh;
  for (uint32_t w = 0; w < state.wedge_position.size(); ++w)
    appendVertex(mesh, layout, state.asset_positions[state.wedge_position[w]],
                 state.wedgeAttributes(w));
  const uint32_t groups = uint32_t(setup_.group_material.size());
  for (uint32_t g = 0; g < std::max(groups, 1u); ++g) {
    uint32_t first = uint32_t(mesh.indices.size());
    for (uint32_t t = 0; t < state.triangle_alive.size(); ++t)
      if (state.triangle_alive[t] && (groups == 0 || state.groups[t] == g))
        for (int k = 0; k < 3; ++k) mesh.indices.push_back(state.corners[t * 3 + k]);
    uint32_t material = groups ? setup_.group_material[g] : 0;
    mesh.submeshes.push_back({first, uint32_t(mesh.indices.size()) - first, material});
  }
  auto id = setup_.renderer->uploadMesh(setup_.asset, mesh);
  if (!id) {
    failure_ = id.error().message;
    return;
  }
  auto images = setup_.renderer->render(*id, setup_.program, setup_.samples,
                                        {.resolution = setup_.resolution});
  setup_.renderer->releaseAsset(*id);
  if (!images) {
    failure_ = images.error().message;
    return;
  }
  setup_.current = std::move(images.value());
  const int R = setup_.resolution;
  for (size_t s = 0; s < sample_error_.size(); ++s) {
    sample_error_[s] = 0;
    const uint8_t* image = setup_.current.tile(int(s));
    for (int y = 0; y < R; ++y)
      for (int x = 0; x < R; ++x)
        sample_error_[s] += pixelError(image + (size_t(y) * R + x) * 4, int(s), x, y);
  }
  ++stats_.full_renders;
}

void ImageCostModel::refreshPendingRegions(const EngineState& state) {
  if (pending_.empty()) return;
  const int T = setup_.tile_size, R = setup_.resolution, L = setup_.lights_per_view;
  // Regions larger than a tile are cut into tiles.
  std::vector<std::pair<int, Region>> pieces;
  for (const auto& [view, region] : pending_)
    for (int y = region.y0; y < region.y1; y += T)
      for (int x = region.x0; x < region.x1; x += T)
        pieces.push_back({view, Region{x, y, std::min(x + T, region.x1), std::min(y + T, region.y1)}});
  pending_.clear();
  render::Renderer::RegionSoup soup;
  std::vector<TileJob> jobs;
  for (const auto& [view, piece] : pieces) jobs.push_back({view, piece, nullptr});
  buildSoup(state, jobs, soup);
  auto tiles = setup_.renderer->renderRegions(setup_.asset, setup_.region_program, soup,
                                              setup_.samples, L, R, T);
  if (!tiles) {
    failure_ = tiles.error().message;
    return;
  }
  for (uint32_t tile = 0; tile < pieces.size(); ++tile) {
    const auto& [view, region] = pieces[tile];
    for (int light = 0; light < L; ++light)
      writeTile(tiles->tile(int(tile) * L + light), view * L + light, region);
  }
  stats_.refreshed_regions += pieces.size();
}

}  // namespace duolod::mesh
