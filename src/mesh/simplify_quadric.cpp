// simplifyQuadric: the collapse engine driven by the quadric cost (quadric.hpp). The fast mode and
// the geometric baseline of the paper's mesh simplification (§4.2 uses the same engine with an
// image-driven cost). Pass ordering, then the greedy queue for the last collapses
// (collapse_engine.hpp). Position-only meshes price at fixed points (the optimal placement solved
// only for the collapses applied) and run in the position-only fast path (simplify_positions.hpp)
// when it applies; meshes with attributes price every candidate at its optimal placement.
#include <chrono>

#include "duolod/mesh.hpp"
#include "mesh/collapse_engine.hpp"
#include "mesh/quadric.hpp"
#include "mesh/simplify_positions.hpp"

namespace duolod::mesh {

SimplifyResult simplifyQuadric(const core::Mesh& mesh, const SimplifyOptions& options) {
  auto start = std::chrono::steady_clock::now();
  auto fast = [&](const core::Mesh& m) {
    SimplifyResult result = simplifyPositions(m, options);
    result.stats.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  if (positionFastPathApplies(mesh, options)) return fast(mesh);
  PreparedMesh prepared = prepareMeshWithPositions(mesh);
  if (positionFastPathApplies(prepared.mesh, options)) return fast(prepared.mesh);
  // With attributes the passes price every candidate at its optimal placement, as the greedy
  // queue does: ordered by the best of the fixed points, the attribute quadrics' prices misjudged
  // curved regions, whose collapses are cheap only off the edge (WaterBottle at 50%: the knurled
  // cap lost its highlights, the pbr render 0.00065 -> 0.0022 per pixel even with passes only
  // down to 75%; exactly priced 0.00064). bench/RESULTS.md, issue 3, session 43.
  const bool has_attributes = attributeLayout(prepared.mesh).stride != 0;
  QuadricModel model({.endpoint_only = options.placement == Placement::kEndpoint,
                      .price_at_fixed_points = !has_attributes,
                      .attribute_weight = options.attribute_weight});
  EngineOptions engine_options{
      .target_triangles = options.target_triangles,
      .target_error = options.target_error,
      .endpoint_only = options.placement == Placement::kEndpoint,
      .lock_border = options.lock_border,
      .allow_material_border_collapse = options.allow_material_border_collapse,
      .record = options.record,
      // Passes, then the greedy queue at the coarse end, with or without attributes. The
      // attribute-aware meshes took the greedy queue throughout until session 43: each collapse
      // re-priced the survivor's edges (~7 evaluations, each a Hoppe reduction and a solve) and
      // most queue pops were stale entries. Exactly priced passes: bunny with normals to 10%
      // 464 -> 278 ms; the pbr and UV renders of tests/mesh_attributes_render_test.cpp as good or
      // better (spot 10% 0.0370 -> 0.0361 per pixel); on 7 meshes with attributes at 50/10/1%,
      // Hausdorff ratios to meshopt over 5 orders geomean 0.745 -> 0.749, mean 0.622 -> 0.616.
      // With attributes and only an error to stop at, the greedy queue throughout, as before:
      // with no triangle target there is no greedy tail at the coarse end, and on spot at
      // --error 0.02 the passes' Hausdorff distance was 1.7x the queue's (0.079 against 0.046).
      .ordering = has_attributes && options.target_triangles == 0 ? CollapseOrdering::kGreedy
                                                                  : CollapseOrdering::kPasses,
      // Exactly priced passes cost what the queue does per candidate: hand over to it once a
      // pass applies fewer than 1 in 100 (fandisk with normals at 50%: 169M -> 150M
      // instructions, the greedy queue's 152M; bunny, armadillo and the shared assets unchanged).
      .min_pass_yield = has_attributes ? 0.01 : 0.0,
      .progress = options.progress,
  };
  SimplifyResult result = runCollapseEngine(prepared, model, engine_options);
  result.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace duolod::mesh
