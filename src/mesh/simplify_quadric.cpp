// simplifyQuadric: the collapse engine driven by the quadric cost (quadric.hpp). The fast mode and
// the geometric baseline of the paper's mesh simplification (§4.2 uses the same engine with an
// image-driven cost). Position-only meshes: pass ordering with fixed-point pricing (optimal
// placement solved only for the collapses applied), then the greedy queue for the last collapses
// (collapse_engine.hpp), run by the position-only fast path (simplify_positions.hpp) when it
// applies; meshes with attributes: the greedy queue throughout.
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
  QuadricModel model({.endpoint_only = options.placement == Placement::kEndpoint,
                      .price_at_fixed_points = true,
                      .attribute_weight = options.attribute_weight});
  EngineOptions engine_options{
      .target_triangles = options.target_triangles,
      .target_error = options.target_error,
      .endpoint_only = options.placement == Placement::kEndpoint,
      .lock_border = options.lock_border,
      .allow_material_border_collapse = options.allow_material_border_collapse,
      .record = options.record,
      // Passes for position-only meshes; the greedy queue when there are attributes: on
      // WaterBottle at 50% the passes made the pbr render 3.5x worse per pixel (0.00064 ->
      // 0.00223, tests/mesh_attributes_render_test.cpp), mostly around the cap, while the
      // positions-only row is where meshopt_simplify 0.18 (position-only) is the comparison.
      .ordering = attributeLayout(prepared.mesh).stride == 0 ? CollapseOrdering::kPasses
                                                             : CollapseOrdering::kGreedy,
      .progress = options.progress,
  };
  SimplifyResult result = runCollapseEngine(prepared, model, engine_options);
  result.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace duolod::mesh
