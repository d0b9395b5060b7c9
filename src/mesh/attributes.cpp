// Packed vertex attributes (see attributes.hpp).
#include "mesh/attributes.hpp"

#include <cmath>
#include <cstring>

namespace duolod::mesh {

AttributeLayout attributeLayout(const core::Mesh& mesh) {
  AttributeLayout layout;
  const size_t n = mesh.vertexCount();
  auto take = [&](uint32_t& offset, size_t stream_size, uint32_t floats) {
    if (n == 0 || stream_size != n) return;
    offset = layout.stride;
    layout.stride += floats;
  };
  take(layout.normal, mesh.normals.size(), 3);
  take(layout.tangent, mesh.tangents.size(), 4);
  take(layout.uv0, mesh.uv0.size(), 2);
  take(layout.uv1, mesh.uv1.size(), 2);
  take(layout.color, mesh.colors.size(), 4);
  return layout;
}

std::vector<float> packAttributes(const core::Mesh& mesh, const AttributeLayout& layout) {
  const size_t n = mesh.vertexCount();
  std::vector<float> packed(n * layout.stride);
  for (size_t v = 0; v < n; ++v) {
    float* out = packed.data() + v * layout.stride;
    if (layout.normal != kAbsent) std::memcpy(out + layout.normal, &mesh.normals[v], 12);
    if (layout.tangent != kAbsent) std::memcpy(out + layout.tangent, &mesh.tangents[v], 16);
    if (layout.uv0 != kAbsent) std::memcpy(out + layout.uv0, &mesh.uv0[v], 8);
    if (layout.uv1 != kAbsent) std::memcpy(out + layout.uv1, &mesh.uv1[v], 8);
    if (layout.color != kAbsent) std::memcpy(out + layout.color, &mesh.colors[v], 16);
  }
  return packed;
}

void appendVertex(core::Mesh& mesh, const AttributeLayout& layout, core::Vec3 position,
                  const float* a) {
  mesh.positions.push_back(position);
  if (layout.normal != kAbsent) {
    const float* v = a + layout.normal;
    mesh.normals.push_back({v[0], v[1], v[2]});
  }
  if (layout.tangent != kAbsent) {
    const float* v = a + layout.tangent;
    mesh.tangents.push_back({v[0], v[1], v[2], v[3]});
  }
  if (layout.uv0 != kAbsent) mesh.uv0.push_back({a[layout.uv0], a[layout.uv0 + 1]});
  if (layout.uv1 != kAbsent) mesh.uv1.push_back({a[layout.uv1], a[layout.uv1 + 1]});
  if (layout.color != kAbsent) {
    const float* v = a + layout.color;
    mesh.colors.push_back({v[0], v[1], v[2], v[3]});
  }
}

void renormalizeAttributes(const AttributeLayout& layout, float* a) {
  core::Vec3 n{0, 0, 0};
  if (layout.normal != kAbsent) {
    float* v = a + layout.normal;
    n = core::normalize({v[0], v[1], v[2]});
    if (core::length(n) > 0) v[0] = n.x, v[1] = n.y, v[2] = n.z;
  }
  if (layout.tangent != kAbsent) {
    float* v = a + layout.tangent;
    core::Vec3 t{v[0], v[1], v[2]};
    t = t - n * core::dot(n, t);  // Gram-Schmidt against the (possibly new) normal
    t = core::normalize(t);
    if (core::length(t) > 0) v[0] = t.x, v[1] = t.y, v[2] = t.z;
    v[3] = v[3] < 0 ? -1.0f : 1.0f;
  }
}

}  // namespace duolod::mesh
