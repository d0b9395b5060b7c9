// duolod mesh: simplification by edge collapse (quadric error with attribute quadrics; the
// image-driven cost of the paper, §4.2/§5.1), vertex clustering, the progressive record that
// turns one run into K candidate meshes (§5.1), and geometric quality measures.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"

namespace duolod::mesh {

// ---------------------------------------------------------------------------------------------
// Edge collapse.

enum class Placement {
  kOptimal,   // quadric minimizer (Garland & Heckbert 1997), falling back to the best endpoint
  kEndpoint,  // one of the two endpoints (the paper's "place-to-endpoints", §4.2)
};

struct SimplifyOptions {
  // Stop when the mesh has at most this many triangles (0 = no triangle target).
  size_t target_triangles = 0;
  // Stop before a collapse whose error would exceed this (geometric: asset units of distance, the
  // square root of the quadric error; image-driven: eq. 6 units). Infinity = no error target.
  double target_error = std::numeric_limits<double>::infinity();
  Placement placement = Placement::kOptimal;
  bool lock_border = false;  // open-boundary vertices never move
  // Weight of the attribute quadrics (Hoppe 1999) relative to geometry, after the automatic
  // scale normalization (attributes are measured against the mesh's bounding-box diagonal).
  float attribute_weight = 1.0f;
  // Collapses across submesh (material) borders are refused unless this is set.
  bool allow_material_border_collapse = false;
  // Record every collapse (needed for candidates); costs memory proportional to the collapses.
  bool record = true;
  // Optional: called now and then with the live triangle count (after each pass, and after each
  // collapse of the greedy queue), so that a caller can show progress on a long run (a mesh of a
  // million triangles with normals takes seconds: a 977k-triangle grid to 10%, 2.5-2.8 s on 2
  // cores).
  std::function<void(size_t triangles)> progress = nullptr;
};

// One step of a progressive record: vertex `removed` merges into `kept`, whose attributes become
// `kept_vertex` (an index into ProgressiveRecord::vertex_values).
struct CollapseStep {
  uint32_t removed = 0;
  uint32_t kept = 0;
  uint32_t kept_value = 0;         // index into ProgressiveRecord's value streams
  uint32_t triangles_after = 0;    // triangle count once this collapse is applied
  float error = 0;                 // the cost that ordered this collapse
  float cumulative_error = 0;      // max error so far (monotone)
  // One edge collapse moves every wedge of a position together (attribute seams keep their
  // discontinuity), so it can take several steps; all but the last have `continues` set. A prefix
  // that ends on such a step would tear the seam open; chooseCandidates never picks one and
  // extractMesh rounds it up to the end of the collapse.
  bool continues = false;
};

// The collapse sequence of one run (§5.1: any intermediate mesh can be extracted cheaply). Vertex
// attribute values after a collapse are appended to `values`, which starts as the input mesh's
// vertices (so values.vertexCount() >= base vertex count).
struct ProgressiveRecord {
  core::Mesh base;                  // the input (welded) mesh
  core::Mesh values;                // attribute streams only: base vertices, then one per step
  std::vector<CollapseStep> steps;
};

struct SimplifyStats {
  size_t collapses = 0;
  size_t rejected_topology = 0;  // link condition / non-manifold
  size_t rejected_flip = 0;      // normal flip
  size_t rejected_border = 0;    // locked border, material border, seam rules
  size_t passes = 0;             // passes over all edges (quadric mode; 0 when greedy only)
  double seconds = 0;
};

struct SimplifyResult {
  core::Mesh mesh;
  double error = 0;  // largest collapse error applied (same units as target_error)
  SimplifyStats stats;
  ProgressiveRecord record;  // empty unless options.record
};

// Quadric error simplification with attribute quadrics. Attribute seams (vertices with equal
// positions but different normals/UVs/colours) are collapsed only along the seam; submesh borders
// are kept unless allowed. The result is compacted (no unreferenced vertices). Collapses never
// create non-manifold edges or vertices, never turn a triangle over, and never open a closed
// surface. Any input is accepted without crashing: vertices are welded first (equal position and
// attributes), unreferenced vertices and triangles with a repeated position, an out-of-range
// index or a duplicate of an earlier triangle are dropped (record.base is this cleaned mesh),
// vertices on non-manifold edges or fans and vertices with non-finite positions never move, and a
// submesh list that does not tile the index buffer becomes one submesh. The same mesh at any
// scale simplifies the same way (positions are normalized by the bounding-box diagonal). A mesh of
// positions only with 8192 vertices or more is simplified on two cores when the machine has them
// (a helper thread kept for the process, asleep between calls; one call at a time uses it), with
// the same result as on one.
SimplifyResult simplifyQuadric(const core::Mesh& mesh, const SimplifyOptions& options);

// The mesh after the first `step_count` collapses of `record`, compacted: collapsed and degenerate
// triangles dropped, triangles in their original order (submesh ranges recomputed, empty submeshes
// kept so material indices stay valid), referenced vertices in their original order. A count past
// the end is clamped; one inside a multi-step collapse is rounded up to its end (see `continues`).
core::Mesh extractMesh(const ProgressiveRecord& record, size_t step_count);
// Several prefixes at once by one incremental replay of the record (cost: one pass over the steps
// plus the size of the outputs), for the §5.1 candidates. `step_counts` must be ascending; the
// result has one mesh per count, each equal to extractMesh(record, count).
std::vector<core::Mesh> extractMeshes(const ProgressiveRecord& record,
                                      std::span<const size_t> step_counts);
// The triangle count of each of those meshes (extractMeshes(record, step_counts)[i]
// .triangleCount()), by one replay that builds no mesh.
std::vector<size_t> countTriangles(const ProgressiveRecord& record,
                                   std::span<const size_t> step_counts);

// K candidate step counts (§5.1): the record's prefix lengths where the error changes most,
// always including 0 (the input) and the last step; ascending, unique, never inside a multi-step
// collapse. A candidate is the prefix just before a jump of the cumulative error. Jumps are
// compared on a log scale (relative change), because absolute jumps grow with the error and would
// put every candidate at the coarse end; when fewer than k-2 prefixes have a jump, the rest are
// spread evenly by triangle count. Returns fewer than k when the record has fewer prefixes.
std::vector<size_t> chooseCandidates(const ProgressiveRecord& record, size_t k);

// ---------------------------------------------------------------------------------------------
// Image-driven simplification: the paper's mode (§4.2, §5.1; Lindstrom & Turk 2000). A collapse
// costs the change it makes to the image error of eq. (6) against the supersampled reference of
// the original asset and shader at one distance, over the 20 views × 5 lights; the survivor stays
// at the endpoint with the lower image error; edges longer than D pixels never collapse.

struct ImageSimplifyOptions {
  size_t target_triangles = 0;  // 0 = none
  // Stop before a collapse that would take ε (eq. 6) above this; infinity = no error target. A
  // start whose ε is already at or above it is returned unchanged, without pricing any edge.
  double target_error = std::numeric_limits<double>::infinity();
  float distance = 0;  // camera distance from the bounding-sphere centre, asset units
  render::Display display;
  render::DomainOptions domain = {};  // the views × lights the error is summed over
  int supersample = 4;           // k of the reference f̄
  float max_edge_pixels = 1.0f;  // D
  int tile_size = 8;  // pixels; a collapse whose neighbourhood is wider in some view is refused
  bool lock_border = false;
  bool allow_material_border_collapse = false;
  bool record = true;
  size_t refine_batch = 32;  // candidates priced by rendering per batch
  // Start from this simplification of asset.mesh instead of asset.mesh itself (the reference is
  // still the original asset): lets a farther level continue from a nearer level's result.
  const core::Mesh* start = nullptr;
  // f̄ already rendered for this distance (render::domainSamples of the original's bounding
  // sphere with `domain`, the footprint of `display`, `supersample`): saves rendering it again.
  const render::ImageBatchF* reference = nullptr;
  // Optional: called with the triangle count as the simplification proceeds (after each batch of
  // rendered prices and each applied collapse: often; throttle what it prints).
  std::function<void(size_t triangles)> progress = nullptr;
  // Optional: `asset` as already uploaded to `renderer` (Renderer::uploadAsset of this very
  // asset), whose materials and textures the meshes drawn here then share instead of uploading
  // the textures again (each upload holds them anew: on WaterBottle's four 2048² textures,
  // ~85 MB and their mipmaps' time). -1: `asset` is uploaded here, and released at the end.
  render::Renderer::AssetId uploaded = -1;
};

struct ImageSimplifyStats {
  int footprint_px = 0;
  double initial_error = 0;  // ε of the input against the reference
  double final_error = 0;    // ε of the result
  size_t rendered_evaluations = 0;
  size_t refine_batches = 0;
  size_t refreshed_regions = 0;  // re-rendered after collapses
  size_t copied_regions = 0;     // updated from the tiles the collapse was priced with
  size_t full_renders = 0;       // whole-domain re-renders of the current mesh
  size_t rejected_long_edges = 0;
  size_t rejected_wide_regions = 0;
  size_t unseen_views = 0;  // (candidate, view) tiles not rendered: the collapse shows nowhere there
  double reference_seconds = 0;  // rendering f̄ and the input's images
  double render_seconds = 0;     // pricing candidates by rendering
  double predicted_change = 0;   // Σ of the applied collapses' rendered costs (≈ final − initial)
  double total_seconds = 0;
};

// Errors: the shader does not compile, or rendering fails.
core::Result<SimplifyResult> simplifyImage(render::Renderer& renderer, const core::Asset& asset,
                                           const render::GlslSource& shader,
                                           const ImageSimplifyOptions& options,
                                           ImageSimplifyStats* stats = nullptr);

// ---------------------------------------------------------------------------------------------
// Vertex clustering (Rossignac & Borrel 1993, with Willmott 2011's attribute-aware
// representatives): the fast, coarse mode.

struct ClusterOptions {
  int grid_resolution = 32;  // cells along the bounding box's longest side (clamped to 1..65536)
  bool keep_attribute_seams = true;
};
// One vertex per occupied cell (per cell and attribute region with keep_attribute_seams), placed
// at the minimizer of the cell's quadric clamped into the cell; triangles whose corners share a
// cell, and repeats of a cell triple, are dropped. result.error is the largest distance from an
// input vertex to its representative (asset units); no record. Triangles touching non-finite
// positions are dropped.
SimplifyResult simplifyCluster(const core::Mesh& mesh, const ClusterOptions& options);

// ---------------------------------------------------------------------------------------------
// Geometric quality (Metro-style, Cignoni et al. 1998): surface sampling both ways.

struct SurfaceDistance {
  double hausdorff = 0;  // max of the two one-sided maxima
  double mean = 0;       // mean of the two one-sided means
  double rms = 0;        // root of the mean of the two one-sided mean squares
  // The one-sided maxima (hausdorff is the larger): how far a point of `a` can be from `b`
  // (with a the original, detail the simplification lost) and a point of `b` from `a` (the
  // simplification left the surface).
  double max_a_to_b = 0, max_b_to_a = 0;
  // Where they were measured: the point of `a` farthest from `b`, and of `b` from `a`.
  core::Vec3 farthest_a_to_b{}, farthest_b_to_a{};
};
// `samples_per_mesh` points are sampled (area-weighted, deterministic for a seed) on each mesh.
// For the maximum only, every vertex is measured too, and so is a dense grid (325 points) on each
// of the 64 triangles with the largest distances measured, where the maximum most likely is.
// Distances are to the other surface (closest point on any triangle, via a BVH). Two empty meshes
// are at distance 0; one empty mesh is at infinity. The mean and rms are over the area samples:
// NaN (not measured) when there are none (samples_per_mesh 0, or a mesh of zero area). The two
// sides run on two cores when the machine has them (simplifyQuadric's helper thread when no call
// holds it, else a thread of their own); the results do not depend on it.
SurfaceDistance surfaceDistance(const core::Mesh& a, const core::Mesh& b,
                                size_t samples_per_mesh = 100000, uint64_t seed = 1);

// ---------------------------------------------------------------------------------------------
// Topology: what decides which vertices the quadric mode may move.

// The surface with its vertices welded by position as the simplifier welds them (equal bits, +0
// and -0 alike) and its triangles with a repeated welded corner or an index out of range left
// out. simplifyQuadric never moves a vertex of a non-manifold or misoriented edge, and keeps
// border edges on the border (or fixed, with lock_border).
struct SurfaceTopology {
  size_t vertices = 0;  // welded, used by a triangle
  size_t edges = 0;
  size_t triangles = 0;           // not degenerate after welding
  size_t border_edges = 0;        // on one triangle
  size_t non_manifold_edges = 0;  // on three triangles or more
  size_t misoriented_edges = 0;   // on two triangles that run along it the same way
  // V - E + F (2 for a closed surface of genus 0).
  long long eulerCharacteristic() const {
    return (long long)vertices - (long long)edges + (long long)triangles;
  }
  bool operator==(const SurfaceTopology&) const = default;
};
SurfaceTopology surfaceTopology(const core::Mesh& mesh);

// What orientConsistently changed.
struct OrientationRepair {
  size_t turned_triangles = 0;      // triangles whose corner order was reversed
  size_t parts = 0;                 // parts joined through edges on exactly two triangles
  size_t non_orientable_parts = 0;  // left as they were (a Moebius strip has no orientation)
  bool operator==(const OrientationRepair&) const = default;
};
// Turns triangles round (reverses their corner order) so that every edge on exactly two
// triangles runs opposite ways in them, as on an oriented surface: afterwards surfaceTopology
// counts no misoriented edges but in non-orientable parts. Triangles are joined by position
// (welded as surfaceTopology welds) across such edges into parts; a closed part (no border or
// non-manifold edge) ends up facing outwards (positive enclosed volume), an open one keeps the
// way most of its triangle area faced. Degenerate triangles and those with an index out of range
// are left alone; vertex attributes (normals, tangents) are not changed.
OrientationRepair orientConsistently(core::Mesh& mesh);

}  // namespace duolod::mesh
