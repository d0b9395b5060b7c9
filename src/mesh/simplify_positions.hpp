// The position-only fast path of simplifyQuadric: the same pass ordering and rules as the
// collapse engine's kPasses (collapse_engine.hpp), on a data layout built for it. Private to
// src/mesh.
#pragma once

#include "duolod/mesh.hpp"
#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

// Whether simplifyPositions handles this prepared mesh: positions only (no attribute streams),
// one submesh, every position finite, optimal placement. Otherwise simplifyQuadric runs the
// general engine.
bool positionFastPathApplies(const PreparedMesh& prepared, const SimplifyOptions& options);

// Quadric simplification of a mesh positionFastPathApplies accepts: passes over compact
// per-pass adjacency down to the greedy tail, then the general engine's greedy queue for the
// tail (EngineOptions::greedy_tail_triangles), continuing with the same quadrics, frame and
// locked vertices. Same guarantees and result (record included) as runCollapseEngine.
SimplifyResult simplifyPositions(const PreparedMesh& prepared, const SimplifyOptions& options);

}  // namespace duolod::mesh
