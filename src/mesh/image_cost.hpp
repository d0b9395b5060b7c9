// The image-driven collapse cost of Liang et al. §4.2 / §5.1 (after Lindstrom & Turk, "Image-driven
// simplification", ACM TOG 2000): the price of a collapse is the change it makes to the image error
// of eq. (6) against the supersampled reference of the original shader, summed over the training
// views × lights. The survivor stays at an endpoint (the engine evaluates both directions, so the
// endpoint with the lower image error wins), and an edge longer than D screen pixels in any view
// never collapses.
//
// Pricing every candidate by rendering would be far too slow, so the model is lazy: evaluate()
// gives estimates (a candidate's last rendered cost, or its quadric cost scaled to image units) and
// the engine asks refine() for rendered costs only for candidates that reach the top of its queue,
// in batches; one batch is one renderRegions() call that draws every candidate's neighbourhood,
// with the collapse applied, into a small tile per view and light.
#pragma once

#include <unordered_map>
#include <vector>

#include "duolod/render.hpp"
#include "mesh/collapse_engine.hpp"
#include "mesh/quadric.hpp"

namespace duolod::mesh {

struct ImageCostSetup {
  render::Renderer* renderer = nullptr;
  render::Renderer::AssetId asset = -1;            // supplies materials and textures
  render::Renderer::ProgramId region_program = -1;  // Renderer::compileRegionProgram
  render::Renderer::ProgramId program = -1;         // the same shader, for whole views
  std::vector<render::Sample> samples;             // view-major
  std::vector<uint32_t> group_material;            // material of each submesh (engine group)
  int lights_per_view = 5;
  int resolution = 64;  // the footprint s_d the samples are framed for
  int tile_size = 16;   // a neighbourhood wider than this in any view does not collapse
  float max_edge_pixels = 1.0f;  // D of §4.2
  size_t refine_batch = 32;      // candidates priced per renderRegions() call
  const render::ImageBatchF* reference = nullptr;  // f̄ of the original, per sample
  render::ImageBatch8 current;                     // f of the input mesh, per sample
};

struct ImageCostStats {
  size_t rendered_evaluations = 0;  // candidates priced by rendering
  size_t refine_batches = 0;
  size_t refreshed_regions = 0;  // regions re-rendered to keep `current` up to date
  size_t copied_regions = 0;     // regions updated from the tiles they were priced with
  size_t full_renders = 0;       // whole-domain re-renders of the current mesh
  size_t rejected_long_edges = 0;
  size_t rejected_wide_regions = 0;
  // (candidate, view) tiles skipped: the collapse shows nowhere there (its triangles face away,
  // or cover no pixel centre)
  size_t unseen_views = 0;
  double render_seconds = 0;
  double predicted_change = 0;  // sum of the rendered costs of the applied collapses
};

class ImageCostModel final : public CostModel {
 public:
  explicit ImageCostModel(ImageCostSetup setup);

  void begin(const EngineState& state) override;
  void evaluate(const EngineState& state, std::span<CandidateCollapse> batch) override;
  size_t refineBatchSize() const override { return setup_.refine_batch; }
  void refine(const EngineState& state, std::span<CandidateCollapse> batch) override;
  void beforeCollapse(const EngineState& state, const CandidateCollapse& chosen) override;
  void onCollapse(const EngineState& state, const AppliedCollapse& applied) override;
  void end(const EngineState& state) override { renderFully(state); }
  // The current images (of the mesh as simplified so far), one per sample.
  const render::ImageBatch8& currentImages() const { return setup_.current; }

  // eq. (6) of the current mesh: mean over samples of the summed squared RGB error.
  double currentError() const;
  const ImageCostStats& stats() const { return stats_; }
  // The rendering failure that stopped pricing, if any (then every cost is infinite).
  const std::string& failure() const { return failure_; }

 private:
  struct Region {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // pixel rectangle [x0, x1) × [y0, y1) in one view
  };
  struct PixelPoint {
    float x = 0, y = 0;  // pixel coordinates, rows top first
    float z = 0;         // window depth in [0, 1]
  };
  // A triangle considered for one tile: its wedges, submesh and screen corners.
  struct LocalTriangle {
    uint32_t wedges[3];
    uint32_t group;
    PixelPoint corners[3];
  };

  PixelPoint projected(int view, uint32_t position) const {
    return projected_[size_t(view) * position_count_ + position];
  }
  // How far outside a triangle (in pixels) OpenGL may still cover a pixel centre: it snaps
  // vertices to 1/256 pixel, so 1/64 is ample.
  static constexpr float kPixelSlack = 1.0f / 64.0f;
  // The pixels whose centres lie in the box [min, max] (pixel coordinates, widened by
  // kPixelSlack), clamped to the view; empty when there are none.
  static Region pixelCentresWithin(float min_x, float min_y, float max_x, float max_y,
                                   int resolution);
  // The pixels the collapse may change in a view (centres in the box of the removed vertex's
  // one-ring, which holds the survivor; may be empty), or false when it is wider than a tile.
  bool collapseRegion(const EngineState& state, const CandidateCollapse& candidate, int view,
                      Region& region) const;
  bool edgeTooLong(uint32_t from, uint32_t to) const;
  // True when the collapse cannot change `view`'s image: every triangle at `from` faces away
  // from that camera now, and every one that survives the collapse (its `from` corner moved to
  // `to`) still faces away after it. Back faces are culled, so neither before nor after does one
  // of them cover a pixel, and the other triangles do not change.
  bool collapseUnseen(const EngineState& state, uint32_t from, uint32_t to, int view) const;
  void binTriangle(const EngineState& state, uint32_t triangle);
  // One thread's scratch for building tiles.
  struct TileScratch {
    std::vector<uint32_t> triangle_mark;  // per triangle: the last gather that took it
    uint32_t mark_round = 0;
    std::vector<float> depth;  // region depth buffer
  };
  // A tile of a soup: the region of a view, drawn with `collapse` applied (its `from` triangles
  // moved to `to`, those on the edge gone) or, without one, as the mesh is.
  struct TileJob {
    int view = 0;
    Region region;
    const CandidateCollapse* collapse = nullptr;
  };
  // The jobs' tiles and triangles appended to `soup`, tile i for job i.
  void buildSoup(const EngineState& state, std::span<const TileJob> jobs,
                 render::Renderer::RegionSoup& soup);
  // The triangles to draw for each job, in job order (so the soups do not depend on the number
  // of threads): on two threads when there are many jobs and two hardware threads.
  void buildTiles(const EngineState& state, std::span<const TileJob> jobs,
                  std::vector<std::vector<LocalTriangle>>& triangles);
  void buildTile(const EngineState& state, const TileJob& job, TileScratch& scratch,
                 std::vector<LocalTriangle>& out) const;
  // The live triangles that may cover a pixel centre of `region` in `view`, except those at
  // `skip_position` (kAbsent: none), appended to `out`.
  void gatherTriangles(const EngineState& state, int view, const Region& region,
                       uint32_t skip_position, TileScratch& scratch,
                       std::vector<LocalTriangle>& out) const;
  // Keeps only the triangles that are front-facing and nearest at some pixel centre of `region`
  // (a depth-buffered CPU rasterization with OpenGL's sampling rule): at small footprints a region
  // overlaps hundreds of triangles but shows a few dozen, and only those need shading on the GPU.
  static void keepVisible(const Region& region, TileScratch& scratch,
                          std::vector<LocalTriangle>& triangles);
  void appendToSoup(const EngineState& state, const std::vector<LocalTriangle>& triangles,
                    uint32_t tile, render::Renderer::RegionSoup& soup) const;
  void appendTriangle(const EngineState& state, const uint32_t wedges[3], uint32_t tile,
                      uint32_t group, render::Renderer::RegionSoup& soup) const;
  // Re-renders the regions touched by collapses since the last refine, so `current` and the
  // per-sample error sums describe the current mesh again.
  void refreshPendingRegions(const EngineState& state);
  // Renders every view of the current mesh anew: exact, and at small footprints cheaper than many
  // regions. Done when the pending regions cover much of the images, and every few batches so
  // that small differences between region and whole-view rasterization cannot accumulate.
  void renderFully(const EngineState& state);
  double pixelError(const uint8_t* rgba, int sample, int x, int y) const;
  // Writes a rendered tile's `region` pixels into the current image of `sample`, keeping the
  // sample's error sum in step.
  void writeTile(const uint8_t* tile, int sample, const Region& region);

  ImageCostSetup setup_;
  QuadricModel quadric_;
  ImageCostStats stats_;
  std::string failure_;
  int view_count_ = 0;
  size_t position_count_ = 0;
  std::vector<PixelPoint> projected_;  // per view, per position
  // Per view, a grid of small cells listing the front-facing triangles whose screen box touches
  // the cell. Entries go stale when triangles die or move; queries re-check.
  int cell_pixels_ = 2;
  int cells_per_side_ = 0;
  std::vector<std::vector<uint32_t>> bins_;  // [view * cells² + cell]
  TileScratch scratch_[2];  // one per thread of buildTiles
  std::vector<std::vector<LocalTriangle>> tile_triangles_;  // buildTiles' output, reused
  std::vector<double> sample_error_;  // per sample: Σ pixels |current − reference|²
  std::vector<std::pair<int, Region>> pending_;  // (view, region) to refresh
  // The last refine's tiles: a candidate applied before anything near it changed has its new
  // pixels there already, so they are copied instead of rendered again.
  struct PricedTile {
    int view;
    Region region;
    uint32_t tile;
  };
  render::ImageBatch8 last_tiles_;
  std::vector<PricedTile> last_placed_;
  std::unordered_map<uint64_t, std::pair<uint32_t, uint32_t>> last_refined_;  // → placed range
  std::vector<std::pair<int, Region>> changed_since_refine_;
  // Rendered cost of (from, to) when last priced: a far better estimate than the quadric once a
  // neighbour has changed it a little.
  std::unordered_map<uint64_t, float> last_cost_;
  std::vector<double> ratios_;  // rendered cost / quadric cost, to scale estimates
  double quadric_to_image_ = 0;
  size_t batches_since_full_ = 0;
  // beforeCollapse's verdict for the collapse being applied: per view, collapseUnseen().
  std::vector<uint8_t> applying_unseen_;
};

}  // namespace duolod::mesh
