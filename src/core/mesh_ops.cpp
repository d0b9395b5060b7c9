// Mesh invariants and attribute generation: validation, bounds, angle-weighted normals
// (Thürmer & Wüthrich, "Computing vertex normals from polygonal facets", 1998), tangents in the
// MikkTSpace convention (Mikkelsen, "Simulation of wrinkled surfaces revisited", 2008), welding.
#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <numeric>

#include "duolod/core.hpp"

namespace duolod::core {
namespace {

float angleBetween(Vec3 u, Vec3 v) {
  float cosine = std::clamp(dot(normalize(u), normalize(v)), -1.0f, 1.0f);
  return std::acos(cosine);
}

// A triangle's edge vectors p1 - p0, p2 - p0 and p2 - p1, scaled by a power of two so that their
// largest component is in [0.5, 1). Cross products, lengths and unit vectors of them do not
// underflow for tiny triangles (edges below ~1e-11: float's squares vanish, and the triangle was
// taken for degenerate) nor overflow for huge ones; at ordinary scales the scaling is exact, so
// unit vectors and zero tests come out bit for bit as from the raw edges.
struct TriangleEdges {
  Vec3 e01, e02, e12;
};
TriangleEdges scaledEdges(Vec3 p0, Vec3 p1, Vec3 p2) {
  TriangleEdges e{p1 - p0, p2 - p0, p2 - p1};
  float largest = 0;
  for (Vec3 d : {e.e01, e.e02, e.e12})
    largest = std::max({largest, std::abs(d.x), std::abs(d.y), std::abs(d.z)});
  if (!(largest > 0) || !std::isfinite(largest)) return e;
  int exponent = 0;
  std::frexp(largest, &exponent);
  // (At most 2^125: the scale of a subnormal triangle must stay finite, or 0 * inf = NaN would
  // keep a degenerate one.)
  const float scale = std::ldexp(1.0f, -std::max(exponent, -125));
  return {e.e01 * scale, e.e02 * scale, e.e12 * scale};
}
// The triangle's angles at p0, p1 and p2.
std::array<float, 3> cornerAngles(const TriangleEdges& e) {
  return {angleBetween(e.e01, e.e02), angleBetween(e.e12, -e.e01), angleBetween(-e.e02, -e.e12)};
}

template <class T>
bool streamSizeOk(const std::vector<T>& stream, size_t vertex_count) {
  return stream.empty() || stream.size() == vertex_count;
}

bool finite4(Vec4 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w);
}

// What the mesh operations below index by: stream sizes, indices in range, submeshes tiling the
// index buffer (validateMesh without the finiteness checks). A mesh that fails it is left as it is:
// the operations index with these numbers, and out of range that was a crash.
bool indexable(const Mesh& mesh) {
  const size_t n = mesh.vertexCount();
  if (!streamSizeOk(mesh.normals, n) || !streamSizeOk(mesh.tangents, n) ||
      !streamSizeOk(mesh.uv0, n) || !streamSizeOk(mesh.uv1, n) || !streamSizeOk(mesh.colors, n) ||
      mesh.indices.size() % 3 != 0)
    return false;
  for (uint32_t index : mesh.indices)
    if (index >= n) return false;
  size_t covered = 0;
  for (const Submesh& sub : mesh.submeshes) {
    if (sub.first_index != covered || sub.index_count % 3 != 0) return false;
    covered += sub.index_count;
  }
  return mesh.submeshes.empty() || covered == mesh.indices.size();
}

}  // namespace

Status validateMesh(const Mesh& mesh) {
  const size_t n = mesh.vertexCount();
  if (!streamSizeOk(mesh.normals, n)) return Error{"normal count differs from position count"};
  if (!streamSizeOk(mesh.tangents, n)) return Error{"tangent count differs from position count"};
  if (!streamSizeOk(mesh.uv0, n)) return Error{"uv0 count differs from position count"};
  if (!streamSizeOk(mesh.uv1, n)) return Error{"uv1 count differs from position count"};
  if (!streamSizeOk(mesh.colors, n)) return Error{"colour count differs from position count"};
  if (mesh.indices.size() % 3 != 0) return Error{"index count is not a multiple of 3"};
  for (size_t i = 0; i < n; ++i)
    if (!isFinite(mesh.positions[i]))
      return Error{"vertex " + std::to_string(i) + " has a non-finite position"};
  for (size_t i = 0; i < mesh.normals.size(); ++i)
    if (!isFinite(mesh.normals[i]))
      return Error{"vertex " + std::to_string(i) + " has a non-finite normal"};
  for (size_t i = 0; i < mesh.tangents.size(); ++i)
    if (!finite4(mesh.tangents[i]))
      return Error{"vertex " + std::to_string(i) + " has a non-finite tangent"};
  for (const auto* uv : {&mesh.uv0, &mesh.uv1})
    for (size_t i = 0; i < uv->size(); ++i)
      if (!std::isfinite((*uv)[i].x) || !std::isfinite((*uv)[i].y))
        return Error{"vertex " + std::to_string(i) + " has a non-finite texture coordinate"};
  for (size_t i = 0; i < mesh.colors.size(); ++i)
    if (!finite4(mesh.colors[i]))
      return Error{"vertex " + std::to_string(i) + " has a non-finite colour"};
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= n)
      return Error{"index " + std::to_string(i) + " = " + std::to_string(mesh.indices[i]) +
                   " is out of range (" + std::to_string(n) + " vertices)"};
  size_t covered = 0;
  for (size_t s = 0; s < mesh.submeshes.size(); ++s) {
    const Submesh& sub = mesh.submeshes[s];
    if (sub.first_index != covered || sub.index_count % 3 != 0)
      return Error{"submesh " + std::to_string(s) + " does not continue the index buffer"};
    covered += sub.index_count;
  }
  if (covered != mesh.indices.size())
    return Error{"submeshes cover " + std::to_string(covered) + " of " +
                 std::to_string(mesh.indices.size()) + " indices"};
  return okStatus();
}

Status validateImage(const ImageRGBA8& image) {
  if (image.width <= 0 || image.height <= 0)
    return Error{"image size " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                 " is empty"};
  const uint64_t expected = uint64_t(image.width) * uint64_t(image.height) * 4;
  if (image.pixels.size() != expected)
    return Error{"image of " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                 " pixels holds " + std::to_string(image.pixels.size()) + " bytes, not " +
                 std::to_string(expected)};
  return okStatus();
}

Status validateSubmeshMaterials(const Mesh& mesh, size_t material_count) {
  // With no materials at all, material 0 is the default one (glTF's; the renderer's zero block).
  for (size_t s = 0; s < mesh.submeshes.size(); ++s)
    if (mesh.submeshes[s].material >= std::max<size_t>(material_count, 1))
      return Error{"submesh " + std::to_string(s) + " uses material " +
                   std::to_string(mesh.submeshes[s].material) + " of " +
                   std::to_string(material_count)};
  return okStatus();
}

Status validateAssetReferences(const Asset& asset) {
  const size_t materials = asset.materials.size(), textures = asset.textures.size();
  if (auto valid = validateSubmeshMaterials(asset.mesh, materials); !valid) return valid;
  for (size_t m = 0; m < materials; ++m) {
    const Material& material = asset.materials[m];
    for (int texture :
         {material.base_color_texture, material.metallic_roughness_texture, material.normal_texture,
          material.occlusion_texture, material.emissive_texture})
      if (texture < -1 || (texture >= 0 && size_t(texture) >= textures))
        return Error{"material " + std::to_string(m) + " (" + material.name + ") uses texture " +
                     std::to_string(texture) + " of " + std::to_string(textures)};
  }
  for (size_t t = 0; t < textures; ++t) {
    const Texture& texture = asset.textures[t];
    if (texture.image.pixels.empty())
      continue;  // no pixels: undecoded (its `encoded` bytes) or a missing file's placeholder
    if (auto valid = validateImage(texture.image); !valid)
      return Error{"texture " + std::to_string(t) + " (" + texture.name +
                   "): " + valid.error().message};
  }
  return okStatus();
}

Bounds computeBounds(const Mesh& mesh) {
  Bounds b;
  for (Vec3 p : mesh.positions) b.extend(p);
  return b;
}

namespace {

// Ritter (1990): start from a far pair, grow to include outliers; then a second pass shrinks the
// slack a little by re-centering on the box centre when that is tighter. In scalar T: float, or
// double where float's squared distances overflow (coordinates beyond ~1e19). The operations are
// those of Vec3's, in the same order, so the float sphere is what it always was.
template <class T>
Sphere ritterSphere(const std::vector<Vec3>& points, const Bounds& box) {
  struct P {
    T x, y, z;
    P operator+(P b) const { return {x + b.x, y + b.y, z + b.z}; }
    P operator-(P b) const { return {x - b.x, y - b.y, z - b.z}; }
    P operator*(T s) const { return {x * s, y * s, z * s}; }
    T length() const { return std::sqrt(x * x + y * y + z * z); }
  };
  auto at = [&](size_t i) { return P{T(points[i].x), T(points[i].y), T(points[i].z)}; };
  auto farthest = [&](P from) {
    size_t best = 0;
    T best_d = -1;
    for (size_t i = 0; i < points.size(); ++i) {
      const P d = at(i) - from;
      const T d2 = d.x * d.x + d.y * d.y + d.z * d.z;
      if (d2 > best_d) best_d = d2, best = i;
    }
    return at(best);
  };
  const P a = farthest(at(0));
  const P b = farthest(a);
  P center = (a + b) * T(0.5);
  T radius = (b - a).length() * T(0.5);
  for (size_t i = 0; i < points.size(); ++i) {
    const P q = at(i);
    const T d = (q - center).length();
    if (d > radius) {
      const T new_radius = (radius + d) * T(0.5);
      center = center + (q - center) * ((new_radius - radius) / d);
      radius = new_radius;
    }
  }
  const P box_center = (P{T(box.min.x), T(box.min.y), T(box.min.z)} +
                        P{T(box.max.x), T(box.max.y), T(box.max.z)}) *
                       T(0.5);
  T box_radius = 0;
  for (size_t i = 0; i < points.size(); ++i)
    box_radius = std::max(box_radius, (at(i) - box_center).length());
  if (box_radius < radius) center = box_center, radius = box_radius;
  return {{float(center.x), float(center.y), float(center.z)}, float(radius)};
}

}  // namespace

Sphere computeBoundingSphere(const Mesh& mesh) {
  if (mesh.positions.empty()) return {};
  const Bounds box = computeBounds(mesh);
  const Sphere sphere = ritterSphere<float>(mesh.positions, box);
  // A bounding sphere is at least as wide as the box's longest side; one that is not lost its
  // squared distances to underflow (coordinates below ~1e-19: a mesh 1e-30 wide had radius 0).
  const Vec3 size = box.max - box.min;
  const float longest = std::max({size.x, size.y, size.z});
  if (std::isfinite(sphere.radius) && isFinite(sphere.center) &&
      2 * sphere.radius >= longest * (1 - 1e-5f))
    return sphere;
  // (Found by fuzzing: a mesh 1e20 wide had an infinite radius, which every camera is placed by.)
  return ritterSphere<double>(mesh.positions, box);
}

size_t normalizeNormals(Mesh& mesh) {
  size_t off = 0;
  for (Vec3& n : mesh.normals) {
    const float length_squared = dot(n, n), from_unit = std::abs(length_squared - 1.0f);
    if (from_unit <= 1e-5f) continue;  // unit up to float rounding: left bit for bit as it is
    if (from_unit > 0.02f && length_squared != 0.0f) ++off;
    n = normalize(n);
  }
  return off;
}

void computeNormals(Mesh& mesh) {
  if (!indexable(mesh)) return;
  mesh.normals.assign(mesh.vertexCount(), Vec3{});
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    uint32_t i[3] = {mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
    const TriangleEdges e =
        scaledEdges(mesh.positions[i[0]], mesh.positions[i[1]], mesh.positions[i[2]]);
    Vec3 face = normalize(cross(e.e01, e.e02));
    if (length(face) == 0) continue;
    const std::array<float, 3> angle = cornerAngles(e);
    for (int k = 0; k < 3; ++k) mesh.normals[i[k]] += face * angle[k];
  }
  // Vertices that share a position (split only by a UV or colour seam) share one normal: a
  // texture seam must not become a shading crease.
  // Grouped by a sort of (position hash, id) rather than a hash map of lists (a list allocated
  // per vertex: 0.77 s of a 490k-vertex mesh's load); each group keeps its ids in increasing
  // order, so the sums are made in the same order as before.
  const uint32_t n = uint32_t(mesh.vertexCount());
  std::vector<std::pair<uint64_t, uint32_t>> by_position(n);
  for (uint32_t v = 0; v < n; ++v) {
    Vec3 p = mesh.positions[v];
    if (p.x == 0) p.x = 0;  // -0 and +0 are one position
    if (p.y == 0) p.y = 0;
    if (p.z == 0) p.z = 0;
    by_position[v] = {hashBytes(&p, sizeof p), v};
  }
  std::sort(by_position.begin(), by_position.end());
  std::vector<uint32_t> vertices, group;
  for (size_t begin = 0, end = 0; begin < n; begin = end) {
    for (end = begin + 1; end < n && by_position[end].first == by_position[begin].first; ++end) {
    }
    if (end - begin < 2) continue;
    vertices.clear();
    for (size_t i = begin; i < end; ++i) vertices.push_back(by_position[i].second);
    // Same hash: group by exact position (collisions are possible, so compare).
    for (size_t i = 0; i < vertices.size(); ++i) {
      if (vertices[i] == UINT32_MAX) continue;
      Vec3 sum = mesh.normals[vertices[i]];
      group.assign(1, vertices[i]);
      for (size_t j = i + 1; j < vertices.size(); ++j)
        if (vertices[j] != UINT32_MAX && mesh.positions[vertices[j]] == mesh.positions[vertices[i]]) {
          sum += mesh.normals[vertices[j]];
          group.push_back(vertices[j]);
          vertices[j] = UINT32_MAX;
        }
      for (uint32_t v : group) mesh.normals[v] = sum;
    }
  }
  for (Vec3& n : mesh.normals) {
    n = normalize(n);
    if (length(n) == 0) n = {0, 0, 1};  // isolated or degenerate-only vertex
  }
}

namespace {
// The UV mapping's orientation on a triangle: +1 where it keeps the triangle's turning sense,
// -1 where it mirrors it (MikkTSpace's sign of the signed UV area), 0 where it is degenerate.
int uvOrientation(const Mesh& mesh, size_t t) {
  const Vec2 a = mesh.uv0[mesh.indices[t]], b = mesh.uv0[mesh.indices[t + 1]],
             c = mesh.uv0[mesh.indices[t + 2]];
  const float det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
  return std::fabs(det) < 1e-20f ? 0 : det > 0 ? 1 : -1;
}

// A vertex that triangles of both UV orientations share (the mirror line of a mirrored UV
// layout) has no one tangent frame: its tangents from either side point opposite ways and cancel.
// MikkTSpace gives each side its own vertex; so does this: the mirrored triangles' corners move
// to a copy of the vertex (every stream copied). Only vertices that a triangle flagged in
// `in_scope` uses are split (elsewhere no tangent shades, and a copy would only be a seam), but
// every triangle's orientation counts, and every mirrored triangle moves to the copy: a mirror
// line on a material border is split, and its triangles on either side see one frame. Returns
// the number of copies.
size_t splitMirroredVertices(Mesh& mesh, const std::vector<uint8_t>& in_scope) {
  const size_t n = mesh.vertexCount();
  const size_t triangles = mesh.indices.size() / 3;
  // bit 0: a kept-orientation triangle, bit 1: a mirrored one, bit 2: a triangle in scope
  std::vector<uint8_t> seen(n, 0);
  std::vector<uint8_t> mirrored(triangles, 0);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint8_t scope = in_scope[t / 3] ? 4 : 0;
    const int orientation = uvOrientation(mesh, t);
    mirrored[t / 3] = orientation < 0;
    const uint8_t side = orientation > 0 ? 1 : orientation < 0 ? 2 : 0;
    for (int k = 0; k < 3; ++k) seen[mesh.indices[t + k]] |= side | scope;
  }
  std::vector<uint32_t> copy_of(n, UINT32_MAX);
  size_t copies = 0;
  for (size_t v = 0; v < n; ++v)
    if (seen[v] == 7) copy_of[v] = uint32_t(n + copies++);
  if (copies == 0) return 0;
  auto extend = [&](auto& stream) {
    if (stream.size() != n) return;
    stream.resize(n + copies);
    for (size_t v = 0; v < n; ++v)
      if (copy_of[v] != UINT32_MAX) stream[copy_of[v]] = stream[v];
  };
  extend(mesh.positions), extend(mesh.normals), extend(mesh.tangents), extend(mesh.uv0),
      extend(mesh.uv1), extend(mesh.colors);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    if (!mirrored[t / 3]) continue;
    for (int k = 0; k < 3; ++k) {
      uint32_t& index = mesh.indices[t + k];
      if (index < n && copy_of[index] != UINT32_MAX) index = copy_of[index];
    }
  }
  return copies;
}

// The tangent frames themselves, once the mirror lines in `split_scope` (per triangle) are split.
size_t computeTangentsSplitting(Mesh& mesh, const std::vector<uint8_t>& split_scope) {
  if (!indexable(mesh)) return 0;
  if (mesh.normals.size() != mesh.vertexCount() || mesh.uv0.size() != mesh.vertexCount()) return 0;
  const size_t split = splitMirroredVertices(mesh, split_scope);
  const size_t n = mesh.vertexCount();
  std::vector<Vec3> tangent_sum(n), bitangent_sum(n);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    uint32_t i[3] = {mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
    Vec2 w[3] = {mesh.uv0[i[0]], mesh.uv0[i[1]], mesh.uv0[i[2]]};
    const TriangleEdges e =
        scaledEdges(mesh.positions[i[0]], mesh.positions[i[1]], mesh.positions[i[2]]);
    const Vec3 e1 = e.e01, e2 = e.e02;
    float du1 = w[1].x - w[0].x, dv1 = w[1].y - w[0].y;
    float du2 = w[2].x - w[0].x, dv2 = w[2].y - w[0].y;
    float det = du1 * dv2 - du2 * dv1;
    if (std::fabs(det) < 1e-20f) continue;  // degenerate UV mapping: contributes nothing
    float r = 1.0f / det;
    Vec3 tangent = (e1 * dv2 - e2 * dv1) * r;
    Vec3 bitangent = (e2 * du1 - e1 * du2) * r;
    // Normalize per face before angle weighting, so that large UV scale differences between faces
    // do not dominate (as MikkTSpace does).
    tangent = normalize(tangent);
    bitangent = normalize(bitangent);
    const std::array<float, 3> angle = cornerAngles(e);
    for (int k = 0; k < 3; ++k) {
      tangent_sum[i[k]] += tangent * angle[k];
      bitangent_sum[i[k]] += bitangent * angle[k];
    }
  }
  mesh.tangents.resize(n);
  for (size_t v = 0; v < n; ++v) {
    Vec3 normal = mesh.normals[v];
    Vec3 t = normalize(tangent_sum[v] - normal * dot(normal, tangent_sum[v]));
    if (length(t) == 0) {  // no UV gradient here: any vector orthogonal to the normal
      Vec3 axis = std::fabs(normal.x) < 0.9f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      t = normalize(cross(axis, normal));
    }
    // glTF: bitangent = cross(normal, tangent.xyz) * tangent.w
    float handedness = dot(cross(normal, t), bitangent_sum[v]) < 0 ? -1.0f : 1.0f;
    mesh.tangents[v] = {t.x, t.y, t.z, handedness};
  }
  return split;
}
}  // namespace

std::vector<bool> normalMappedSubmeshes(const Asset& asset) {
  std::vector<bool> mapped;
  mapped.reserve(asset.mesh.submeshes.size());
  for (const Submesh& submesh : asset.mesh.submeshes)
    mapped.push_back(submesh.material < asset.materials.size() &&
                     asset.materials[submesh.material].normal_texture >= 0);
  return mapped;
}

size_t computeTangents(Mesh& mesh, bool split_mirrored) {
  return computeTangentsSplitting(mesh, std::vector<uint8_t>(mesh.triangleCount(), split_mirrored));
}

size_t computeTangentsPerSubmesh(Mesh& mesh, const std::vector<bool>& split_submeshes) {
  const size_t triangles = mesh.triangleCount();
  std::vector<uint8_t> in_scope(triangles, 0);
  if (mesh.submeshes.empty() && !split_submeshes.empty() && split_submeshes[0])
    in_scope.assign(triangles, 1);
  for (size_t s = 0; s < mesh.submeshes.size() && s < split_submeshes.size(); ++s) {
    if (!split_submeshes[s]) continue;
    const size_t first = std::min<size_t>(triangles, mesh.submeshes[s].first_index / 3);
    const size_t end = std::min(triangles, first + mesh.submeshes[s].index_count / 3);
    std::fill(in_scope.begin() + first, in_scope.begin() + end, 1);
  }
  return computeTangentsSplitting(mesh, in_scope);
}

size_t weldVertices(Mesh& mesh) {
  if (!indexable(mesh)) return 0;
  const size_t n = mesh.vertexCount();
  if (n == 0) return 0;
  // Pack each vertex's attributes into one byte string; equal strings are equal vertices.
  size_t stride = sizeof(Vec3) + (mesh.normals.empty() ? 0 : sizeof(Vec3)) +
                  (mesh.tangents.empty() ? 0 : sizeof(Vec4)) +
                  (mesh.uv0.empty() ? 0 : sizeof(Vec2)) + (mesh.uv1.empty() ? 0 : sizeof(Vec2)) +
                  (mesh.colors.empty() ? 0 : sizeof(Vec4));
  std::vector<uint8_t> keys(n * stride);
  for (size_t v = 0; v < n; ++v) {
    uint8_t* out = keys.data() + v * stride;
    auto put = [&](const auto& value) {
      std::memcpy(out, &value, sizeof(value));
      out += sizeof(value);
    };
    Vec3 pos = mesh.positions[v];
    if (pos.x == 0) pos.x = 0;  // fold -0 into +0 so they weld
    if (pos.y == 0) pos.y = 0;
    if (pos.z == 0) pos.z = 0;
    put(pos);
    if (!mesh.normals.empty()) put(mesh.normals[v]);
    if (!mesh.tangents.empty()) put(mesh.tangents[v]);
    if (!mesh.uv0.empty()) put(mesh.uv0[v]);
    if (!mesh.uv1.empty()) put(mesh.uv1[v]);
    if (!mesh.colors.empty()) put(mesh.colors[v]);
  }
  // Equal keys found in an open-addressing table of first ids (linear probing, at most half
  // full), not a node-based hash map (a node allocated per vertex: 0.18 s for 490k distinct
  // vertices). A vertex maps to the first (lowest id) of its equals, and the kept vertices are
  // numbered in id order.
  auto key = [&](uint32_t v) { return keys.data() + size_t(v) * stride; };
  size_t slots = 16;
  while (slots < 2 * n) slots *= 2;
  const size_t mask = slots - 1;
  std::vector<uint32_t> first_of(slots, UINT32_MAX);  // a kept vertex's id, or empty
  std::vector<uint32_t> remap(n);
  uint32_t next = 0;
  for (uint32_t v = 0; v < n; ++v) {
    size_t slot = hashBytes(key(v), stride) & mask;
    while (first_of[slot] != UINT32_MAX && std::memcmp(key(first_of[slot]), key(v), stride) != 0)
      slot = (slot + 1) & mask;
    if (first_of[slot] == UINT32_MAX) {
      first_of[slot] = v;
      remap[v] = next++;
    } else {
      remap[v] = remap[first_of[slot]];
    }
  }
  if (next == n) return 0;
  auto compact = [&](auto& stream) {
    if (stream.empty()) return;
    std::remove_reference_t<decltype(stream)> out(next);
    for (size_t v = 0; v < n; ++v) out[remap[v]] = stream[v];
    stream = std::move(out);
  };
  compact(mesh.positions);
  compact(mesh.normals);
  compact(mesh.tangents);
  compact(mesh.uv0);
  compact(mesh.uv1);
  compact(mesh.colors);
  for (uint32_t& i : mesh.indices) i = remap[i];
  return n - next;
}

size_t removeDegenerateTriangles(Mesh& mesh) {
  if (!indexable(mesh)) return 0;
  std::vector<uint32_t> kept;
  kept.reserve(mesh.indices.size());
  size_t removed = 0;
  std::vector<Submesh> submeshes = mesh.submeshes;
  if (submeshes.empty() && !mesh.indices.empty())
    submeshes.push_back({0, static_cast<uint32_t>(mesh.indices.size()), 0});
  for (Submesh& sub : submeshes) {
    uint32_t first = static_cast<uint32_t>(kept.size());
    for (uint32_t t = sub.first_index; t + 2 < sub.first_index + sub.index_count; t += 3) {
      uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
      const TriangleEdges e = scaledEdges(mesh.positions[a], mesh.positions[b], mesh.positions[c]);
      if (a == b || b == c || a == c || length(cross(e.e01, e.e02)) == 0) {
        ++removed;
        continue;
      }
      kept.insert(kept.end(), {a, b, c});
    }
    sub.first_index = first;
    sub.index_count = static_cast<uint32_t>(kept.size()) - first;
  }
  mesh.indices = std::move(kept);
  if (!mesh.submeshes.empty()) mesh.submeshes = std::move(submeshes);
  return removed;
}

namespace {

// Tipsify (Sander, Nehab & Barczak 2007, Algorithm 1) on one range of triangles: fan around a
// vertex, emitting all its remaining triangles, then continue from a vertex those triangles
// brought into the cache that will still be there after its own fan (the oldest such), else
// from the dead-end stack of recently used vertices, else from the next vertex in id order.
void tipsifyRange(std::span<uint32_t> indices, size_t vertex_count, int cache_size) {
  const size_t triangle_count = indices.size() / 3;
  if (triangle_count < 2) return;
  std::vector<uint32_t> offsets(vertex_count + 1, 0);  // vertex -> its triangles, compressed rows
  for (uint32_t v : indices) ++offsets[v + 1];
  for (size_t v = 0; v < vertex_count; ++v) offsets[v + 1] += offsets[v];
  std::vector<uint32_t> triangles_of(indices.size());
  std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (size_t t = 0; t < triangle_count; ++t)
    for (int c = 0; c < 3; ++c) triangles_of[fill[indices[3 * t + c]]++] = static_cast<uint32_t>(t);
  std::vector<int> live(vertex_count);  // triangles not yet emitted, per vertex
  for (size_t v = 0; v < vertex_count; ++v) live[v] = static_cast<int>(offsets[v + 1] - offsets[v]);

  // stamp[v]: the time v entered the cache; v is cached while time - stamp[v] <= cache_size.
  std::vector<int64_t> stamp(vertex_count, -int64_t(cache_size) - 1);
  int64_t time = cache_size + 1;
  std::vector<char> emitted(triangle_count, 0);
  std::vector<uint32_t> order, dead_end, candidates;
  order.reserve(indices.size());
  size_t cursor = 0;
  int64_t fanning = indices[0];
  while (fanning >= 0) {
    candidates.clear();
    for (uint32_t a = offsets[fanning]; a < offsets[fanning + 1]; ++a) {
      uint32_t t = triangles_of[a];
      if (emitted[t]) continue;
      emitted[t] = 1;
      for (int c = 0; c < 3; ++c) {
        uint32_t v = indices[3 * t + c];
        order.push_back(v);
        dead_end.push_back(v);
        candidates.push_back(v);
        --live[v];
        if (time - stamp[v] > cache_size) stamp[v] = time++;
      }
    }
    int64_t next = -1, best_priority = -1;
    for (uint32_t v : candidates) {
      if (live[v] <= 0) continue;
      int64_t priority = 0;  // a vertex that will have left the cache by the end of its fan
      if (time - stamp[v] + 2 * live[v] <= cache_size) priority = time - stamp[v];
      if (priority > best_priority) best_priority = priority, next = v;
    }
    while (next < 0 && !dead_end.empty()) {
      uint32_t v = dead_end.back();
      dead_end.pop_back();
      if (live[v] > 0) next = v;
    }
    while (next < 0 && cursor < vertex_count) {
      if (live[cursor] > 0) next = static_cast<int64_t>(cursor);
      ++cursor;
    }
    fanning = next;
  }
  std::copy(order.begin(), order.end(), indices.begin());
}

template <class T>
void permuteStream(std::vector<T>& stream, const std::vector<uint32_t>& old_of_new) {
  if (stream.empty()) return;
  std::vector<T> permuted(stream.size());
  for (size_t n = 0; n < old_of_new.size(); ++n) permuted[n] = stream[old_of_new[n]];
  stream = std::move(permuted);
}

}  // namespace

size_t countVertexRuns(std::span<const uint32_t> indices, size_t vertex_count, int cache_size) {
  // FIFO: v is cached while fewer than cache_size misses happened since it entered.
  std::vector<int64_t> entered(vertex_count, std::numeric_limits<int64_t>::min() / 2);
  int64_t misses = 0;
  for (uint32_t v : indices) {
    if (v >= vertex_count) {  // out of range: a run, not a read past the table
      ++misses;
      continue;
    }
    if (misses - entered[v] > cache_size) entered[v] = misses++;
  }
  return static_cast<size_t>(misses);
}

size_t optimizeVertexReuse(Mesh& mesh, int cache_size, size_t* before_runs) {
  if (!indexable(mesh)) {
    if (before_runs) *before_runs = 0;
    return 0;
  }
  const size_t vertex_count = mesh.vertexCount();
  if (before_runs) *before_runs = countVertexRuns(mesh.indices, vertex_count, cache_size);
  std::vector<Submesh> ranges = mesh.submeshes;
  if (ranges.empty()) ranges.push_back({0, static_cast<uint32_t>(mesh.indices.size()), 0});
  for (const Submesh& range : ranges)
    tipsifyRange(std::span<uint32_t>(mesh.indices).subspan(range.first_index, range.index_count),
                 vertex_count, cache_size);

  // Vertices by first use; any vertex no triangle uses keeps its relative order at the end.
  constexpr uint32_t kUnset = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> new_of_old(vertex_count, kUnset), old_of_new;
  old_of_new.reserve(vertex_count);
  for (uint32_t v : mesh.indices)
    if (new_of_old[v] == kUnset) {
      new_of_old[v] = static_cast<uint32_t>(old_of_new.size());
      old_of_new.push_back(v);
    }
  for (uint32_t v = 0; v < vertex_count; ++v)
    if (new_of_old[v] == kUnset) {
      new_of_old[v] = static_cast<uint32_t>(old_of_new.size());
      old_of_new.push_back(v);
    }
  for (uint32_t& v : mesh.indices) v = new_of_old[v];
  permuteStream(mesh.positions, old_of_new);
  permuteStream(mesh.normals, old_of_new);
  permuteStream(mesh.tangents, old_of_new);
  permuteStream(mesh.uv0, old_of_new);
  permuteStream(mesh.uv1, old_of_new);
  permuteStream(mesh.colors, old_of_new);
  return countVertexRuns(mesh.indices, vertex_count, cache_size);
}

}  // namespace duolod::core
