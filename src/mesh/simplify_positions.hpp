// The position-only fast path of simplifyQuadric: the same pass ordering and rules as the
// collapse engine's kPasses (collapse_engine.hpp), on a data layout built for it. Private to
// src/mesh.
#pragma once

#include "duolod/mesh.hpp"
#include "mesh/collapse_engine.hpp"

namespace duolod::mesh {

// Whether simplifyPositions handles this mesh: positions only (no attribute streams), one
// submesh (or submeshes that prepareMesh would make one), every position finite, optimal
// placement. Otherwise simplifyQuadric prepares the mesh (prepareMeshWithPositions, which drops
// unused vertices, non-finite ones among them) and asks again, else runs the general engine.
bool positionFastPathApplies(const core::Mesh& mesh, const SimplifyOptions& options);

// Quadric simplification of a mesh positionFastPathApplies accepts, straight from the input (it
// welds and cleans as prepareMeshWithPositions does, id for id): passes over compact per-pass
// adjacency down to the greedy tail, then a greedy queue for the tail
// (EngineOptions::greedy_tail_triangles). Same guarantees as runCollapseEngine; the record's base
// is the prepared mesh.
SimplifyResult simplifyPositions(const core::Mesh& mesh, const SimplifyOptions& options);

}  // namespace duolod::mesh
