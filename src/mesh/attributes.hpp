// Vertex attributes other than position as one flat float array (a fixed number of floats per
// vertex), so the simplifiers can move, merge and copy them without caring which streams a mesh
// has. Shared by the collapse engine, the progressive record and vertex clustering.
#pragma once

#include <cstdint>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::mesh {

inline constexpr uint32_t kAbsent = 0xffffffffu;

// Which streams a mesh has and where each lives in a packed vertex. Offsets are kAbsent for
// absent streams.
struct AttributeLayout {
  uint32_t normal = kAbsent;   // 3 floats
  uint32_t tangent = kAbsent;  // 4 floats
  uint32_t uv0 = kAbsent;      // 2 floats
  uint32_t uv1 = kAbsent;      // 2 floats
  uint32_t color = kAbsent;    // 4 floats
  uint32_t stride = 0;         // floats per vertex
};

AttributeLayout attributeLayout(const core::Mesh& mesh);

// All vertices' attributes, `layout.stride` floats each.
std::vector<float> packAttributes(const core::Mesh& mesh, const AttributeLayout& layout);

// Appends one vertex (position + packed attributes) to every present stream of `mesh`.
void appendVertex(core::Mesh& mesh, const AttributeLayout& layout, core::Vec3 position,
                  const float* attributes);

// Re-normalizes the unit-length streams (normal, tangent xyz) of one packed vertex after
// averaging or interpolation, keeping the tangent orthogonal to the normal and w = ±1.
void renormalizeAttributes(const AttributeLayout& layout, float* attributes);

}  // namespace duolod::mesh
