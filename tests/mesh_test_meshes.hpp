// Small procedural meshes for the mesh-simplification tests, each simple enough that the expected
// result can be worked out by hand: grids (flat, or a height field), a cube, icospheres (smooth or
// bumpy), and a grid with a UV seam down the middle.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::test {

// An n x n grid of quads over [0, size]², two triangles each, counter-clockwise seen from +z,
// vertices row-major ((n+1)² of them); z = height(x, y).
inline core::Mesh gridMesh(int n, float size = 1.0f,
                           const std::function<float(float, float)>& height = nullptr) {
  core::Mesh mesh;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      float x = size * float(i) / float(n), y = size * float(j) / float(n);
      mesh.positions.push_back({x, y, height ? height(x, y) : 0.0f});
    }
  auto at = [&](int i, int j) { return uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  mesh.submeshes = {{0, uint32_t(mesh.indices.size()), 0}};
  return mesh;
}

// The cube [-1, 1]³: 8 shared corners, 12 outward-facing triangles.
inline core::Mesh cubeMesh() {
  core::Mesh mesh;
  for (int i = 0; i < 8; ++i)
    mesh.positions.push_back({i & 1 ? 1.0f : -1.0f, i & 2 ? 1.0f : -1.0f, i & 4 ? 1.0f : -1.0f});
  // Each face as a quad (a, b, c, d) counter-clockwise from outside.
  const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.indices.insert(mesh.indices.end(), {f[0], f[1], f[2]});
    mesh.indices.insert(mesh.indices.end(), {f[0], f[2], f[3]});
  }
  mesh.submeshes = {{0, 36, 0}};
  return mesh;
}

// Icosahedron subdivided `subdivisions` times (20 * 4^s triangles), vertices on the sphere of
// `radius` displaced by radius * bump(direction); welded; outward-facing.
inline core::Mesh icosphere(int subdivisions, float radius = 1.0f,
                            const std::function<float(core::Vec3)>& bump = nullptr) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<core::Vec3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : p) v = core::normalize(v);
  std::vector<uint32_t> tris = {0, 11, 5, 0, 5,  1,  0, 1, 7, 0, 7,  10, 0, 10, 11,
                                1, 5,  9, 5, 11, 4,  11, 10, 2, 10, 7, 6, 7,  1,  8,
                                3, 9,  4, 3, 4,  2,  3, 2, 6, 3, 6,  8,  3, 8,  9,
                                4, 9,  5, 2, 4,  11, 6, 2, 10, 8, 6, 7, 9,  8,  1};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      p.push_back(core::normalize((p[a] + p[b]) * 0.5f));
      return midpoints[key] = uint32_t(p.size() - 1);
    };
    std::vector<uint32_t> next;
    for (size_t i = 0; i < tris.size(); i += 3) {
      uint32_t a = tris[i], b = tris[i + 1], c = tris[i + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    tris = std::move(next);
  }
  core::Mesh mesh;
  for (core::Vec3 v : p) mesh.positions.push_back(v * (radius * (1.0f + (bump ? bump(v) : 0.0f))));
  mesh.indices = std::move(tris);
  mesh.submeshes = {{0, uint32_t(mesh.indices.size()), 0}};
  return mesh;
}

// A closed horn along +z: `rings` rings of `sides` vertices (every other ring turned by half a
// side), radius `radius` (1 - z / length) at z = length * i / rings, so the sides are a straight
// cone ending in a tip vertex at (0, 0, length); a fan closes the base at z = 0. The tip is the
// vertex before last, the base centre the last.
inline core::Mesh hornMesh(int rings, int sides, float radius, float length) {
  core::Mesh m;
  for (int i = 0; i < rings; ++i) {
    const float z = length * float(i) / float(rings), r = radius * (1 - z / length);
    for (int j = 0; j < sides; ++j) {
      const float a = 2 * float(M_PI) * (float(j) + 0.5f * float(i % 2)) / float(sides);
      m.positions.push_back({r * std::cos(a), r * std::sin(a), z});
    }
  }
  const uint32_t tip = uint32_t(m.positions.size());
  m.positions.push_back({0, 0, length});
  const uint32_t base = uint32_t(m.positions.size());
  m.positions.push_back({0, 0, 0});
  auto id = [&](int i, int j) { return uint32_t(i * sides + (j + sides) % sides); };
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < sides; ++j) {
      if (i % 2 == 0)
        m.indices.insert(m.indices.end(), {id(i, j), id(i, j + 1), id(i + 1, j), id(i, j + 1),
                                           id(i + 1, j + 1), id(i + 1, j)});
      else
        m.indices.insert(m.indices.end(), {id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i, j),
                                           id(i + 1, j + 1), id(i + 1, j)});
    }
  for (int j = 0; j < sides; ++j)
    m.indices.insert(m.indices.end(),
                     {id(rings - 1, j), id(rings - 1, j + 1), tip, id(0, j + 1), id(0, j), base});
  m.submeshes = {{0, uint32_t(m.indices.size()), 0}};
  return m;
}

// A deterministic lumpy displacement (sum of a few sines), for meshes without symmetric ties.
inline float lumps(core::Vec3 d) {
  return 0.08f * std::sin(3.1f * d.x + 0.7f) * std::cos(2.3f * d.y - 0.4f) +
         0.05f * std::sin(5.3f * d.z + 1.9f * d.x) + 0.03f * std::cos(7.7f * d.y + 2.9f * d.z);
}

// An n x n grid over [0,1]² (n even) on the height field `height`, with a UV seam along x = 0.5:
// the seam's positions have two wedges, the left chart maps x in [0, 0.5] to u in [0, 0.2], the
// right chart maps [0.5, 1] to u in [0.8, 1.0]; v = y. Normals are the height field's.
inline core::Mesh seamGrid(int n, const std::function<float(float, float)>& height) {
  core::Mesh mesh;
  std::vector<uint32_t> left(size_t(n + 1) * (n + 1)), right(left.size());
  auto add = [&](float x, float y, float u) {
    mesh.positions.push_back({x, y, height(x, y)});
    mesh.uv0.push_back({u, y});
    return uint32_t(mesh.positions.size() - 1);
  };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      float x = float(i) / float(n), y = float(j) / float(n);
      size_t k = size_t(j) * (n + 1) + i;
      if (2 * i <= n) left[k] = add(x, y, 0.4f * x);
      if (2 * i >= n) right[k] = add(x, y, 0.8f + 0.4f * (x - 0.5f));
    }
  auto at = [&](int i, int j, bool on_left) {
    size_t k = size_t(j) * (n + 1) + i;
    return on_left ? left[k] : right[k];
  };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      bool l = 2 * i < n;
      mesh.indices.insert(mesh.indices.end(), {at(i, j, l), at(i + 1, j, l), at(i + 1, j + 1, l)});
      mesh.indices.insert(mesh.indices.end(), {at(i, j, l), at(i + 1, j + 1, l), at(i, j + 1, l)});
    }
  mesh.submeshes = {{0, uint32_t(mesh.indices.size()), 0}};
  core::computeNormals(mesh);
  return mesh;
}

inline core::Mesh scaledMesh(core::Mesh mesh, float scale) {
  for (core::Vec3& p : mesh.positions) p = p * scale;
  return mesh;
}

// Number of triangles on each undirected edge, keyed by position (bitwise), not by vertex index,
// so that seams do not look like borders.
inline std::map<std::pair<std::array<float, 3>, std::array<float, 3>>, int> edgeTriangleCounts(
    const core::Mesh& mesh) {
  std::map<std::pair<std::array<float, 3>, std::array<float, 3>>, int> counts;
  auto key = [&](uint32_t i) {
    core::Vec3 p = mesh.positions[i];
    return std::array<float, 3>{p.x, p.y, p.z};
  };
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      auto a = key(mesh.indices[t + k]), b = key(mesh.indices[t + (k + 1) % 3]);
      ++counts[std::minmax(a, b)];
    }
  return counts;
}

inline core::Vec3 triangleNormal(const core::Mesh& mesh, size_t t) {
  core::Vec3 a = mesh.positions[mesh.indices[t * 3]], b = mesh.positions[mesh.indices[t * 3 + 1]],
             c = mesh.positions[mesh.indices[t * 3 + 2]];
  return core::cross(b - a, c - a);
}

// Writes icosphere(subdivisions) as an OBJ of positions with every third triangle (1, 4, 7, ...)
// turned round: a surface whose edges are half misoriented, for --reorient.
inline void writeIcosphereWithTurnedTriangles(const std::string& path, int subdivisions) {
  const core::Mesh sphere = icosphere(subdivisions);
  std::ofstream obj(path);
  for (const core::Vec3& p : sphere.positions)
    obj << "v " << p.x << " " << p.y << " " << p.z << "\n";
  for (size_t t = 0; t < sphere.triangleCount(); ++t) {
    const uint32_t* v = &sphere.indices[t * 3];
    const bool turned = t % 3 == 1;
    obj << "f " << v[0] + 1 << " " << v[turned ? 2 : 1] + 1 << " " << v[turned ? 1 : 2] + 1 << "\n";
  }
}

}  // namespace duolod::test
