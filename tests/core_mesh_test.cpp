// Core mesh and math tests with hand-checkable answers: angle-weighted normals (independent of the
// triangulation), MikkTSpace-convention tangents and their handedness, welding, degenerate-triangle
// removal, validateMesh's messages, the 4x4 helpers (inverse, lookAt, perspective) and the
// bounding sphere.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <type_traits>
#include <vector>

#include "duolod/core.hpp"

namespace duolod {
namespace {
using core::Mat4;
using core::Mesh;
using core::Vec2;
using core::Vec3;
using core::Vec4;

void expectVecNear(Vec3 actual, Vec3 expected, float tolerance) {
  EXPECT_NEAR(actual.x, expected.x, tolerance);
  EXPECT_NEAR(actual.y, expected.y, tolerance);
  EXPECT_NEAR(actual.z, expected.z, tolerance);
}

// The unit square in z = 0, counter-clockwise seen from +z, as two triangles.
Mesh flatQuad() {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  mesh.submeshes = {{0, 6, 0}};
  return mesh;
}

// The README's library example dereferences a returned Result in place
// (`compileProgram(*render::loadShaderPair("pbr"))`): on a temporary the value is moved out, and
// a const Result reads.
TEST(CoreResult, DereferencesTemporariesAndConstResults) {
  auto make = [](int n) { return core::Result<std::vector<int>>(std::vector<int>(size_t(n), 7)); };
  std::vector<int> moved = *make(3);
  EXPECT_EQ(moved, (std::vector<int>{7, 7, 7}));
  static_assert(std::is_same_v<decltype(*make(1)), std::vector<int>>);
  const core::Result<std::vector<int>> kept = make(2);
  EXPECT_EQ((*kept).size(), 2u);
  static_assert(std::is_same_v<decltype(*kept), const std::vector<int>&>);
  const core::Result<int> failed = core::Error{"no"};
  EXPECT_FALSE(failed);
  EXPECT_EQ(failed.error().message, "no");
}

TEST(ComputeNormals, FlatQuadIsPlusZEverywhere) {
  Mesh mesh = flatQuad();
  core::computeNormals(mesh);
  ASSERT_EQ(mesh.normals.size(), 4u);
  for (Vec3 n : mesh.normals) expectVecNear(n, {0, 0, 1}, 1e-6f);
}

// Builds the three faces of the cube [-1,1]^3 around its corner C = (1,1,1), with C shared, each
// face triangulated differently:
//   +z: 2 triangles whose diagonal passes through C (C is in both, corner angles 45° + 45°);
//   +y: 2 triangles whose diagonal avoids C (C in one triangle, corner angle 90°);
//   +x: a fan of 4 triangles from C over the face with two edge midpoints added (angles sum 90°).
// Each face subtends 90° at C, so the angle-weighted normal at C is (1,1,1)/√3. Weighting by
// triangle count or by area would tilt it towards +x or +z.
TEST(ComputeNormals, CubeCornerIsAngleWeightedRegardlessOfTriangulation) {
  Mesh mesh;
  auto vertex = [&](Vec3 p) {
    mesh.positions.push_back(p);
    return static_cast<uint32_t>(mesh.positions.size() - 1);
  };
  // Adds triangle (a, b, c), flipped if needed so that its normal points along `outward`.
  auto triangle = [&](uint32_t a, uint32_t b, uint32_t c, Vec3 outward) {
    Vec3 n =
        core::cross(mesh.positions[b] - mesh.positions[a], mesh.positions[c] - mesh.positions[a]);
    if (core::dot(n, outward) < 0) std::swap(b, c);
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
  };
  uint32_t corner = vertex({1, 1, 1});
  // +z face: corners (-1,-1,1) (1,-1,1) C (-1,1,1); diagonal from C to (-1,-1,1).
  {
    uint32_t a = vertex({-1, -1, 1}), b = vertex({1, -1, 1}), d = vertex({-1, 1, 1});
    triangle(a, b, corner, {0, 0, 1});
    triangle(a, corner, d, {0, 0, 1});
  }
  // +y face: corners (-1,1,-1) (1,1,-1) C (-1,1,1); diagonal from (1,1,-1) to (-1,1,1).
  {
    uint32_t a = vertex({-1, 1, -1}), b = vertex({1, 1, -1}), d = vertex({-1, 1, 1});
    triangle(a, b, d, {0, 1, 0});
    triangle(b, corner, d, {0, 1, 0});
  }
  // +x face: polygon C, (1,-1,1), (1,-1,0), (1,-1,-1), (1,0,-1), (1,1,-1), fanned from C.
  {
    uint32_t ring[] = {vertex({1, -1, 1}), vertex({1, -1, 0}), vertex({1, -1, -1}),
                       vertex({1, 0, -1}), vertex({1, 1, -1})};
    for (int i = 0; i < 4; ++i) triangle(corner, ring[i], ring[i + 1], {1, 0, 0});
  }
  ASSERT_EQ(mesh.triangleCount(), 8u);
  core::computeNormals(mesh);
  float k = 1.0f / std::sqrt(3.0f);
  expectVecNear(mesh.normals[corner], {k, k, k}, 1e-5f);
}

// Positions = uv on a flat quad: +u is +x, +v is +y, so the tangent is (1,0,0) and the bitangent
// cross(n, t) = (0,1,0) already points along +v: w = +1.
TEST(ComputeTangents, QuadWithUvEqualXyHasTangentPlusX) {
  Mesh mesh = flatQuad();
  mesh.normals.assign(4, Vec3{0, 0, 1});
  for (Vec3 p : mesh.positions) mesh.uv0.push_back({p.x, p.y});
  core::computeTangents(mesh);
  ASSERT_EQ(mesh.tangents.size(), 4u);
  for (Vec4 t : mesh.tangents) {
    expectVecNear({t.x, t.y, t.z}, {1, 0, 0}, 1e-6f);
    EXPECT_EQ(t.w, 1.0f);
  }
}

// u = 1 - x mirrors the texture: +u is -x, so the tangent is (-1,0,0); +v is still +y, but
// cross(n, t) = (0,-1,0), so the handedness w must be -1.
TEST(ComputeTangents, MirroredUHasNegativeHandedness) {
  Mesh mesh = flatQuad();
  mesh.normals.assign(4, Vec3{0, 0, 1});
  for (Vec3 p : mesh.positions) mesh.uv0.push_back({1 - p.x, p.y});
  core::computeTangents(mesh);
  ASSERT_EQ(mesh.tangents.size(), 4u);
  for (Vec4 t : mesh.tangents) {
    expectVecNear({t.x, t.y, t.z}, {-1, 0, 0}, 1e-6f);
    EXPECT_EQ(t.w, -1.0f);
  }
}

// A mirrored UV layout: two quads side by side, u = x on the left and u = 2 - x on the right (the
// texture mirrored at x = 1), v = y. The two vertices on the mirror line are shared by both sides,
// whose tangents point opposite ways (+x, w = +1 on the left; -x, w = -1 on the right): they are
// split, one copy per side, as MikkTSpace does. Without the split their tangent sums cancel.
TEST(ComputeTangents, MirrorLineVerticesAreSplit) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}};
  mesh.indices = {0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4};
  mesh.submeshes = {{0, 12, 0}};
  mesh.normals.assign(6, Vec3{0, 0, 1});
  for (Vec3 p : mesh.positions) mesh.uv0.push_back({p.x <= 1 ? p.x : 2 - p.x, p.y});
  EXPECT_EQ(core::computeTangents(mesh), 2u);
  ASSERT_EQ(mesh.vertexCount(), 8u);
  ASSERT_EQ(mesh.normals.size(), 8u);
  ASSERT_EQ(mesh.uv0.size(), 8u);
  ASSERT_EQ(mesh.tangents.size(), 8u);
  ASSERT_TRUE(core::validateMesh(mesh));
  for (size_t t = 0; t < 4; ++t) {
    const bool left = t < 2;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[t * 3 + k];
      SCOPED_TRACE(testing::Message() << "triangle " << t << " vertex " << v);
      const Vec4 tangent = mesh.tangents[v];
      expectVecNear({tangent.x, tangent.y, tangent.z}, {left ? 1.0f : -1.0f, 0, 0}, 1e-6f);
      EXPECT_EQ(tangent.w, left ? 1.0f : -1.0f);
    }
  }
  // The copies sit where their originals do, with the same attributes.
  for (uint32_t copy : {6u, 7u}) {
    const Vec3 p = mesh.positions[copy];
    EXPECT_EQ(p.x, 1.0f);
    EXPECT_EQ(mesh.uv0[copy].x, 1.0f);
    EXPECT_EQ(mesh.uv0[copy].y, p.y);
  }
  // Again on the result: nothing left to split.
  EXPECT_EQ(core::computeTangents(mesh), 0u);
  EXPECT_EQ(mesh.vertexCount(), 8u);
}

// Per submesh: the same mirrored layout twice, the copy beside it (x + 3) as a second submesh,
// which also has a triangle on the first's mirror line (on vertices 4 and 5, mirrored like the
// right quad). Only the lines that a flagged submesh uses are split, and every mirrored triangle
// on them, whatever its submesh, moves to the copies.
TEST(ComputeTangents, OnlyTheFlaggedSubmeshesLinesAreSplit) {
  Mesh mesh;
  for (float dx : {0.0f, 3.0f})
    for (Vec3 p : {Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{2, 0, 0}, Vec3{0, 1, 0}, Vec3{1, 1, 0},
                   Vec3{2, 1, 0}})
      mesh.positions.push_back({p.x + dx, p.y, p.z});
  mesh.positions.push_back({1.5f, 2, 0});  // 12: the extra triangle's own corner
  mesh.indices = {0, 1, 4,  0, 4,  3, 1, 2, 5,  1, 5,  4,    // submesh 0
                  6, 7, 10, 6, 10, 9, 7, 8, 11, 7, 11, 10,   // submesh 1
                  4, 5, 12};                                 // submesh 1, on submesh 0's line
  mesh.submeshes = {{0, 12, 0}, {12, 15, 1}};
  mesh.normals.assign(13, Vec3{0, 0, 1});
  for (Vec3 p : mesh.positions) {
    const float x = p.x >= 3 ? p.x - 3 : p.x;
    mesh.uv0.push_back({x <= 1 ? x : 2 - x, p.y});
  }
  const Mesh input = mesh;
  EXPECT_EQ(core::computeTangentsPerSubmesh(mesh, {true, false}), 2u);
  ASSERT_EQ(mesh.vertexCount(), 15u);
  ASSERT_TRUE(core::validateMesh(mesh));
  // Submesh 0 as in MirrorLineVerticesAreSplit: its right quad moved to the copies 13 and 14, and
  // so did the other submesh's mirrored triangle on vertex 4.
  EXPECT_EQ(mesh.indices[6], 13u);
  EXPECT_EQ(mesh.indices[11], 14u);
  EXPECT_EQ(mesh.indices[24], 14u);
  for (size_t t = 0; t < 4; ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(mesh.tangents[mesh.indices[t * 3 + k]].x, t < 2 ? 1.0f : -1.0f, 1e-6f) << t;
  EXPECT_NEAR(mesh.tangents[14].x, -1.0f, 1e-6f);
  // Submesh 1's own line (vertices 7 and 10) is not split.
  for (size_t i = 12; i < 24; ++i) EXPECT_EQ(mesh.indices[i], input.indices[i]) << i;
  // Flagging every submesh splits the second line too; flagging none splits nothing.
  Mesh all = input;
  EXPECT_EQ(core::computeTangentsPerSubmesh(all, {true, true}), 4u);
  EXPECT_EQ(all.indices[24], all.indices[11]);
  Mesh none = input;
  EXPECT_EQ(core::computeTangentsPerSubmesh(none, {false, false}), 0u);
  EXPECT_EQ(none.vertexCount(), 13u);
  // Only the second submesh flagged: its own line (7 and 10) and, of the first's line, vertex 4,
  // which its extra triangle uses (both orientations meet there), not vertex 1.
  Mesh second = input;
  EXPECT_EQ(core::computeTangentsPerSubmesh(second, {false, true}), 3u);
  EXPECT_EQ(second.indices[9], 1u);
  EXPECT_EQ(second.indices[11], second.indices[24]);
  EXPECT_NE(second.indices[11], 4u);
}

// A mirror line that is also a material border: the left quad (kept orientation) is normal
// mapped, the right one (mirrored) is not. The line is split whichever side is flagged, so that
// the flagged side's frames do not cancel; the unflagged side takes the copies.
TEST(ComputeTangents, AMirrorLineOnAMaterialBorderIsSplit) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}};
  mesh.indices = {0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4};
  mesh.submeshes = {{0, 6, 0}, {6, 6, 1}};
  mesh.normals.assign(6, Vec3{0, 0, 1});
  for (Vec3 p : mesh.positions) mesh.uv0.push_back({p.x <= 1 ? p.x : 2 - p.x, p.y});
  for (const std::vector<bool>& flags : {std::vector<bool>{true, false},
                                         std::vector<bool>{false, true}}) {
    Mesh split = mesh;
    EXPECT_EQ(core::computeTangentsPerSubmesh(split, flags), 2u);
    for (size_t t = 0; t < 4; ++t)
      for (int k = 0; k < 3; ++k) {
        const Vec4 tangent = split.tangents[split.indices[t * 3 + k]];
        EXPECT_NEAR(tangent.x, t < 2 ? 1.0f : -1.0f, 1e-6f) << t;
        EXPECT_EQ(tangent.w, t < 2 ? 1.0f : -1.0f) << t;
      }
  }
  Mesh unflagged = mesh;
  EXPECT_EQ(core::computeTangentsPerSubmesh(unflagged, {false, false}), 0u);
}

// The quad as two triangles with their own three vertices each (6 vertices, 2 shared positions).
Mesh unsharedQuad() {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2, 3, 4, 5};
  mesh.submeshes = {{0, 6, 0}};
  return mesh;
}

// Normals, tangents and the degenerate test do not depend on the scale: a folded, uneven patch
// scaled by 2^-40 (edges ~1e-13) or 2^40 (~1e12) gets the same normals and tangents bit for bit
// and loses no triangle. (In float, the cross products' squares underflowed below edges of ~1e-11:
// triangles were dropped as degenerate and normals were (0,0,1); above ~4e9 they overflowed.)
TEST(ComputeNormals, ScaleByPowersOfTwoChangesNothing) {
  Mesh unit;
  unit.positions = {{0, 0, 0}, {1, 0, 0.2f}, {0.1f, 1, 0.3f}, {1.2f, 1.1f, -0.4f}, {0.5f, 2, 0.9f}};
  unit.indices = {0, 1, 2, 1, 3, 2, 2, 3, 4};
  unit.submeshes = {{0, 9, 0}};
  for (Vec3 p : unit.positions) unit.uv0.push_back({p.x * 0.7f, p.y + 0.1f * p.z});
  auto prepared = [](Mesh mesh) {
    EXPECT_EQ(core::removeDegenerateTriangles(mesh), 0u);
    core::computeNormals(mesh);
    core::computeTangents(mesh);
    return mesh;
  };
  const Mesh reference = prepared(unit);
  for (float scale : {std::ldexp(1.0f, -40), std::ldexp(1.0f, 40)}) {
    SCOPED_TRACE(scale);
    Mesh scaled = unit;
    for (Vec3& p : scaled.positions) p = p * scale;
    const Mesh result = prepared(scaled);
    ASSERT_EQ(result.indices, reference.indices);
    for (size_t v = 0; v < unit.vertexCount(); ++v) {
      EXPECT_EQ(result.normals[v].x, reference.normals[v].x) << v;
      EXPECT_EQ(result.normals[v].y, reference.normals[v].y) << v;
      EXPECT_EQ(result.normals[v].z, reference.normals[v].z) << v;
      EXPECT_EQ(result.tangents[v].x, reference.tangents[v].x) << v;
      EXPECT_EQ(result.tangents[v].y, reference.tangents[v].y) << v;
      EXPECT_EQ(result.tangents[v].z, reference.tangents[v].z) << v;
      EXPECT_EQ(result.tangents[v].w, reference.tangents[v].w) << v;
    }
  }
}

// A degenerate triangle stays degenerate when it is subnormally small (its scale to unit size
// would overflow a float, and 0 * inf is NaN, which no zero test catches), and a proper one that
// small is kept.
TEST(RemoveDegenerateTriangles, SubnormalTriangles) {
  const float tiny = std::numeric_limits<float>::denorm_min() * 64;
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {tiny, 0, 0}, {2 * tiny, 0, 0}, {0, tiny, 0}};
  mesh.indices = {0, 1, 2, 0, 1, 3};  // collinear, then proper
  mesh.submeshes = {{0, 6, 0}};
  EXPECT_EQ(core::removeDegenerateTriangles(mesh), 1u);
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 3}));
}

TEST(WeldVertices, MergesExactDuplicatesAndRemapsIndices) {
  Mesh mesh = unsharedQuad();
  EXPECT_EQ(core::weldVertices(mesh), 2u);
  ASSERT_EQ(mesh.vertexCount(), 4u);
  // First occurrences keep their order: v3 -> v0, v4 -> v2, v5 becomes vertex 3.
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(mesh.positions[3], (Vec3{0, 1, 0}));
  EXPECT_TRUE(core::validateMesh(mesh));
}

TEST(WeldVertices, KeepsVerticesThatDifferOnlyInUv) {
  Mesh mesh = unsharedQuad();
  // v0 and v3 agree in uv too (weld); v2 and v4 share a position but not a uv (a UV seam).
  mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 0}, {0.5f, 0.5f}, {0, 1}};
  EXPECT_EQ(core::weldVertices(mesh), 1u);
  ASSERT_EQ(mesh.vertexCount(), 5u);
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 3, 4}));
  ASSERT_EQ(mesh.uv0.size(), 5u);
  EXPECT_EQ(mesh.uv0[2].x, 1.0f);
  EXPECT_EQ(mesh.uv0[3].x, 0.5f);
}

// Thousands of vertices, each position used three times in a scrambled order and some told
// apart only by a uv or by -0: the weld's table (open addressing, probed past collisions) gives
// what a plain ordered map of first occurrences gives.
TEST(WeldVertices, ManyDuplicatesMatchAPlainMap) {
  Mesh mesh;
  uint64_t state = 12345;
  auto next = [&] {
    return uint32_t((state = state * 6364136223846793005ull + 1442695040888963407ull) >> 33);
  };
  for (int i = 0; i < 9000; ++i) {
    const uint32_t id = next() % 3000;
    const float x = id % 2 == 0 && next() % 2 ? -0.0f : 0.0f;  // -0 and +0 weld
    mesh.positions.push_back({x, float(id % 50), float(id / 50)});
    mesh.uv0.push_back({id % 7 == 0 ? float(next() % 2) : 0.0f, 0});  // a seam on some
  }
  for (uint32_t i = 0; i + 2 < 9000; i += 3)
    mesh.indices.insert(mesh.indices.end(), {i, i + 1, i + 2});
  mesh.submeshes = {{0, uint32_t(mesh.indices.size()), 0}};
  const Mesh before = mesh;
  std::map<std::array<float, 4>, uint32_t> first;  // key -> new id, in order of first use
  std::vector<uint32_t> expected_remap(before.vertexCount());
  for (uint32_t v = 0; v < before.vertexCount(); ++v) {
    const Vec3 p = before.positions[v];
    const std::array<float, 4> key = {p.x == 0 ? 0.0f : p.x, p.y, p.z, before.uv0[v].x};
    expected_remap[v] = first.try_emplace(key, uint32_t(first.size())).first->second;
  }
  EXPECT_EQ(core::weldVertices(mesh), before.vertexCount() - first.size());
  ASSERT_EQ(mesh.vertexCount(), first.size());
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    ASSERT_EQ(mesh.indices[i], expected_remap[before.indices[i]]) << i;
    EXPECT_EQ(mesh.uv0[mesh.indices[i]].x, before.uv0[before.indices[i]].x);
    EXPECT_EQ(mesh.positions[mesh.indices[i]].y, before.positions[before.indices[i]].y);
  }
}

TEST(WeldVertices, NothingToWeldLeavesMeshAlone) {
  Mesh mesh = flatQuad();
  Mesh before = mesh;
  EXPECT_EQ(core::weldVertices(mesh), 0u);
  EXPECT_EQ(mesh.indices, before.indices);
  EXPECT_EQ(mesh.vertexCount(), before.vertexCount());
}

// Two submeshes; each loses one triangle: (0,0,1) repeats an index, (0,1,4) has three collinear
// corners (zero area), and the third submesh has only a degenerate triangle and becomes empty.
TEST(RemoveDegenerateTriangles, DropsRepeatedIndexAndZeroAreaAndKeepsSubmeshesConsistent) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0}};
  mesh.indices = {0, 1, 2, 0, 0, 1,  // submesh 0: good, repeated index
                  0, 1, 4, 0, 2, 3,  // submesh 1: collinear, good
                  1, 1, 1};          // submesh 2: repeated index only
  mesh.submeshes = {{0, 6, 0}, {6, 6, 1}, {12, 3, 2}};
  ASSERT_TRUE(core::validateMesh(mesh));
  EXPECT_EQ(core::removeDegenerateTriangles(mesh), 3u);
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  ASSERT_EQ(mesh.submeshes.size(), 3u);
  EXPECT_EQ(mesh.submeshes[0].first_index, 0u);
  EXPECT_EQ(mesh.submeshes[0].index_count, 3u);
  EXPECT_EQ(mesh.submeshes[0].material, 0u);
  EXPECT_EQ(mesh.submeshes[1].first_index, 3u);
  EXPECT_EQ(mesh.submeshes[1].index_count, 3u);
  EXPECT_EQ(mesh.submeshes[1].material, 1u);
  EXPECT_EQ(mesh.submeshes[2].first_index, 6u);
  EXPECT_EQ(mesh.submeshes[2].index_count, 0u);
  auto valid = core::validateMesh(mesh);
  EXPECT_TRUE(valid) << valid.error().message;
}

TEST(RemoveDegenerateTriangles, MeshWithoutSubmeshesStaysWithout) {
  Mesh mesh = flatQuad();
  mesh.submeshes.clear();
  mesh.indices.insert(mesh.indices.end(), {3, 3, 0});
  EXPECT_EQ(core::removeDegenerateTriangles(mesh), 1u);
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_TRUE(mesh.submeshes.empty());
}

// validateMesh must name each broken invariant.
void expectInvalid(const Mesh& mesh, const std::string& fragment) {
  auto valid = core::validateMesh(mesh);
  ASSERT_FALSE(valid) << "expected an error containing '" << fragment << "'";
  EXPECT_NE(valid.error().message.find(fragment), std::string::npos) << valid.error().message;
}

TEST(ValidateMesh, AcceptsAGoodMesh) {
  EXPECT_TRUE(core::validateMesh(flatQuad()));
}

TEST(ValidateMesh, CatchesNanPosition) {
  Mesh mesh = flatQuad();
  mesh.positions[2].y = std::nanf("");
  expectInvalid(mesh, "vertex 2 has a non-finite position");
}

TEST(ValidateMesh, CatchesInfiniteNormal) {
  Mesh mesh = flatQuad();
  mesh.normals.assign(4, Vec3{0, 0, 1});
  mesh.normals[1].z = INFINITY;
  expectInvalid(mesh, "vertex 1 has a non-finite normal");
}

TEST(ValidateMesh, CatchesIndexOutOfRange) {
  Mesh mesh = flatQuad();
  mesh.indices[4] = 4;
  expectInvalid(mesh, "index 4 = 4 is out of range (4 vertices)");
}

// The mesh operations index with the mesh's numbers: on an index out of range (or a submesh past
// the index buffer) they crashed; now they leave the mesh as it is.
TEST(MeshOperations, InconsistentMeshesAreLeftAsTheyAre) {
  for (int broken = 0; broken < 2; ++broken) {
    Mesh mesh = flatQuad();
    mesh.normals.assign(4, Vec3{0, 0, 1});
    mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    if (broken == 0)
      mesh.indices[4] = 4000000;
    else
      mesh.submeshes = {{0, 600, 0}};
    const Mesh before = mesh;
    core::computeNormals(mesh);
    EXPECT_EQ(core::computeTangents(mesh), 0u);
    EXPECT_EQ(core::weldVertices(mesh), 0u);
    EXPECT_EQ(core::removeDegenerateTriangles(mesh), 0u);
    size_t before_runs = 7;
    EXPECT_EQ(core::optimizeVertexReuse(mesh, 16, &before_runs), 0u);
    EXPECT_EQ(before_runs, 0u);
    EXPECT_EQ(mesh.indices, before.indices) << broken;
    EXPECT_EQ(mesh.positions.size(), before.positions.size());
    EXPECT_TRUE(mesh.tangents.empty());
  }
  const std::vector<uint32_t> out_of_range = {0, 1, 99};
  EXPECT_EQ(core::countVertexRuns(out_of_range, 3, 16), 3u);
}

TEST(ValidateMesh, CatchesStreamSizeMismatch) {
  Mesh mesh = flatQuad();
  mesh.normals.assign(3, Vec3{0, 0, 1});
  expectInvalid(mesh, "normal count differs from position count");
  mesh = flatQuad();
  mesh.uv0.assign(5, Vec2{});
  expectInvalid(mesh, "uv0 count differs from position count");
}

TEST(ValidateMesh, CatchesIndexCountNotMultipleOfThree) {
  Mesh mesh = flatQuad();
  mesh.indices.push_back(0);
  expectInvalid(mesh, "not a multiple of 3");
}

TEST(ValidateMesh, CatchesSubmeshGapAndShortCoverage) {
  Mesh mesh = flatQuad();
  mesh.submeshes = {{0, 3, 0}, {6, 0, 1}};  // indices 3..5 belong to no submesh
  expectInvalid(mesh, "submesh 1 does not continue the index buffer");
  mesh.submeshes = {{0, 3, 0}};
  expectInvalid(mesh, "submeshes cover 3 of 6 indices");
}

// A translation-rotation-scale matrix from a seeded generator.
Mat4 randomTrs(std::mt19937& random) {
  std::uniform_real_distribution<float> unit(-1, 1), scale(0.25f, 4.0f);
  Mat4 t = Mat4::identity(), r = Mat4::identity(), s = Mat4::identity();
  for (int i = 0; i < 3; ++i) t.at(i, 3) = 10 * unit(random);
  float x = unit(random), y = unit(random), z = unit(random), w = unit(random);
  float norm = std::sqrt(x * x + y * y + z * z + w * w);
  x /= norm;
  y /= norm;
  z /= norm;
  w /= norm;
  const float rotation[3][3] = {
      {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  for (int row = 0; row < 3; ++row)
    for (int column = 0; column < 3; ++column) r.at(row, column) = rotation[row][column];
  for (int i = 0; i < 3; ++i) s.at(i, i) = scale(random);
  return t * r * s;
}

TEST(Math, InverseTimesMatrixIsIdentity) {
  std::mt19937 random(1234);
  for (int trial = 0; trial < 50; ++trial) {
    Mat4 m = randomTrs(random);
    Mat4 product = core::inverse(m) * m;
    for (int row = 0; row < 4; ++row)
      for (int column = 0; column < 4; ++column)
        EXPECT_NEAR(product.at(row, column), row == column ? 1.0f : 0.0f, 1e-5f)
            << "trial " << trial << " at (" << row << ", " << column << ")";
  }
}

TEST(Math, InverseOfSingularMatrixIsIdentity) {
  Mat4 zero;
  Mat4 inv = core::inverse(zero);
  EXPECT_EQ(inv.m, Mat4::identity().m);
}

TEST(Math, LookAtMapsEyeToOriginAndTargetOntoMinusZ) {
  Vec3 eye{3, 4, 5}, target{1, -2, 0.5f};
  Mat4 view = core::lookAt(eye, target, {0, 1, 0});
  expectVecNear(core::transformPoint(view, eye), {0, 0, 0}, 1e-5f);
  float distance = core::length(target - eye);
  expectVecNear(core::transformPoint(view, target), {0, 0, -distance}, 1e-5f);
  // The up vector stays in the upper half of the image.
  EXPECT_GT(core::transformPoint(view, eye + Vec3{0, 1, 0}).y, 0.0f);
}

TEST(Math, LookAtAlongUpStillWorks) {
  Vec3 eye{0, 5, 0}, target{0, 0, 0};
  Mat4 view = core::lookAt(eye, target, {0, 1, 0});
  expectVecNear(core::transformPoint(view, target), {0, 0, -5}, 1e-5f);
}

TEST(Math, PerspectiveMapsNearAndFarToMinusOneAndOne) {
  float z_near = 0.5f, z_far = 20.0f;
  Mat4 projection = core::perspective(1.0f, 1.5f, z_near, z_far);
  auto ndc_depth = [&](float eye_z) {
    Vec4 clip = core::transform(projection, {0.3f, -0.2f, eye_z, 1});
    return clip.z / clip.w;
  };
  EXPECT_NEAR(ndc_depth(-z_near), -1.0f, 1e-5f);
  EXPECT_NEAR(ndc_depth(-z_far), 1.0f, 1e-5f);
  // tan(fov/2) * near is the top edge of the near plane: y_ndc = 1 there.
  Vec4 top = core::transform(projection, {0, z_near * std::tan(0.5f), -z_near, 1});
  EXPECT_NEAR(top.y / top.w, 1.0f, 1e-5f);
}

TEST(BoundingSphere, UnitCubeCornersHaveRadiusHalfRootThree) {
  Mesh mesh;
  for (int i = 0; i < 8; ++i)
    mesh.positions.push_back({float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  core::Sphere sphere = core::computeBoundingSphere(mesh);
  float expected = std::sqrt(3.0f) / 2;
  EXPECT_NEAR(sphere.radius, expected, 0.01f * expected);
  for (Vec3 p : mesh.positions)
    EXPECT_LE(core::length(p - sphere.center), sphere.radius * (1 + 1e-6f));
}

TEST(BoundingSphere, ContainsEveryPointOfARandomCloud) {
  std::mt19937 random(99);
  std::normal_distribution<float> gauss(0, 1);
  Mesh mesh;
  for (int i = 0; i < 1000; ++i)
    mesh.positions.push_back({gauss(random) * 3 + 1, gauss(random), gauss(random) * 0.5f - 2});
  core::Sphere sphere = core::computeBoundingSphere(mesh);
  for (Vec3 p : mesh.positions)
    EXPECT_LE(core::length(p - sphere.center), sphere.radius * (1 + 1e-6f));
}

// Float's squared distances overflow beyond ~1e19: the unit cube's corners scaled by 1e20 and by
// 1e38 still get the cube's sphere, scaled (the radius was infinite: found by fuzzing). Below that
// the sphere is computed in float, as before.
TEST(BoundingSphere, HugeCoordinates) {
  for (float scale : {1e20f, 1e38f}) {
    Mesh mesh;
    for (int i = 0; i < 8; ++i)
      mesh.positions.push_back(
          Vec3{float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)} * scale);
    core::Sphere sphere = core::computeBoundingSphere(mesh);
    ASSERT_TRUE(std::isfinite(sphere.radius)) << scale;
    EXPECT_NEAR(sphere.radius / scale, std::sqrt(3.0f) / 2, 0.01f) << scale;
    EXPECT_NEAR(sphere.center.x / scale, 0.5f, 0.01f) << scale;
  }
}

// Float squared distances underflow below ~1e-19: a mesh 1e-30 wide had radius 0 (found by
// fuzzing), and every camera is placed by the radius.
TEST(BoundingSphere, TinyCoordinates) {
  for (float scale : {1e-20f, 1e-30f, 1e-40f}) {
    Mesh mesh;
    for (int i = 0; i < 8; ++i)
      mesh.positions.push_back(Vec3{float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)} *
                               scale);
    core::Sphere sphere = core::computeBoundingSphere(mesh);
    EXPECT_NEAR(sphere.radius / scale, std::sqrt(3.0f) / 2, 0.01f) << scale;
    EXPECT_NEAR(sphere.center.x / scale, 0.5f, 0.01f) << scale;
  }
}

// normalize() keeps the direction of a vector whose squared length overflows or underflows a
// float (a normal of 1e20 in an OBJ became NaN tangents and a failed write, found by fuzzing);
// normalizeNormals makes every normal unit and counts those that were far from it.
TEST(Math, NormalizeBeyondFloatSquares) {
  for (float scale : {1e20f, 5e37f, 1e-25f, 1e-40f}) {
    const Vec3 n = core::normalize(Vec3{3, 0, -4} * scale);
    EXPECT_NEAR(n.x, 0.6f, 1e-6f) << scale;
    EXPECT_NEAR(n.z, -0.8f, 1e-6f) << scale;
  }
  EXPECT_EQ(core::normalize(Vec3{0, 0, 0}), (Vec3{0, 0, 0}));
  Mesh mesh;
  mesh.normals = {{0, 0, 1}, {0, 0, 1.001f}, {1e20f, 0, 0}, {0, 2, 0}, {0, 0, 0}};
  EXPECT_EQ(core::normalizeNormals(mesh), 2u);  // 1e20 and 2; 1.001 is within 1%
  for (size_t i = 0; i < 4; ++i) EXPECT_NEAR(core::length(mesh.normals[i]), 1.0f, 1e-6f) << i;
  EXPECT_EQ(mesh.normals[4], (Vec3{0, 0, 0}));
}

TEST(BoundingSphere, EmptyMeshHasZeroRadius) {
  EXPECT_EQ(core::computeBoundingSphere(Mesh{}).radius, 0.0f);
}

}  // namespace
}  // namespace duolod

namespace duolod {
namespace {

// A UV seam splits vertices but must not split their normal: a fold along the seam keeps one
// smooth normal on both sides.
TEST(ComputeNormals, SeamVerticesShareOneNormal) {
  core::Mesh mesh;
  // Two triangles meeting at the edge (0,0,0)-(0,1,0) with a 90° fold; the edge's vertices are
  // duplicated (different UVs on each side).
  mesh.positions = {{0, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, 0, 0}, {0, 1, 0}, {0, 0, -1}};
  mesh.uv0 = {{0, 0}, {0, 1}, {1, 0}, {0.5f, 0}, {0.5f, 1}, {1, 1}};
  mesh.indices = {0, 1, 2, 3, 4, 5};  // faces +z and -x
  mesh.submeshes = {{0, 6, 0}};
  core::computeNormals(mesh);
  EXPECT_EQ(mesh.normals[0], mesh.normals[3]);
  EXPECT_EQ(mesh.normals[1], mesh.normals[4]);
  // Both faces' normals, (0,0,1) and (-1,0,0), weighted alike: the bisector.
  float h = std::sqrt(0.5f);
  EXPECT_NEAR(mesh.normals[0].x, -h, 1e-5f);
  EXPECT_NEAR(mesh.normals[0].z, h, 1e-5f);
  // Unshared vertices keep their face's normal.
  EXPECT_NEAR(mesh.normals[2].z, 1.0f, 1e-5f);
}

// A FIFO post-transform cache of 3 by hand: 0 1 2 miss; 2 and 1 hit; 3 misses and evicts 0; 0
// misses and evicts 1; 3 hits; 1 misses.
TEST(VertexReuse, CountsRunsOfAFifoCacheByHand) {
  const std::vector<uint32_t> indices = {0, 1, 2, 2, 1, 3, 0, 3, 1};
  EXPECT_EQ(core::countVertexRuns(indices, 4, 3), 6u);
  EXPECT_EQ(core::countVertexRuns(indices, 4, 4), 4u);  // everything fits
  EXPECT_EQ(core::countVertexRuns(indices, 4, 1), 8u);  // only a repeat of the last one hits
}

// Reordering keeps every triangle (with its winding) inside its own submesh and every vertex's
// attributes together, and it brings a shuffled grid close to one shader run per vertex.
TEST(VertexReuse, ShuffledGridKeepsItsTrianglesAndNeedsFarFewerRuns) {
  const int n = 32;
  Mesh mesh;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      mesh.positions.push_back({float(i), float(j), 0.0f});
      mesh.uv0.push_back({float(i) / n, float(j) / n});
    }
  std::vector<std::array<uint32_t, 3>> triangles;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
      triangles.push_back({a, b, c});
      triangles.push_back({a, c, d});
    }
  // Two materials: the lower and the upper half of the grid, each half's triangles shuffled.
  const size_t half_triangles = triangles.size() / 2;
  std::mt19937 random(5);
  std::shuffle(triangles.begin(), triangles.begin() + long(half_triangles), random);
  std::shuffle(triangles.begin() + long(half_triangles), triangles.end(), random);
  for (const auto& t : triangles) mesh.indices.insert(mesh.indices.end(), t.begin(), t.end());
  const uint32_t half = uint32_t(3 * half_triangles);
  mesh.submeshes = {{0, half, 0}, {half, half, 1}};

  // A triangle as its corner positions, rotated to start at the smallest (winding kept).
  auto corners = [](const Mesh& m, size_t first, size_t count) {
    std::vector<std::array<float, 6>> result;
    for (size_t k = first; k < first + count; k += 3) {
      std::array<Vec3, 3> p = {m.positions[m.indices[k]], m.positions[m.indices[k + 1]],
                               m.positions[m.indices[k + 2]]};
      auto key = [](Vec3 v) { return std::pair(v.x, v.y); };
      int start = 0;
      for (int c = 1; c < 3; ++c)
        if (key(p[c]) < key(p[start])) start = c;
      std::array<float, 6> t{};
      for (int c = 0; c < 3; ++c) t[2 * c] = p[(start + c) % 3].x, t[2 * c + 1] = p[(start + c) % 3].y;
      result.push_back(t);
    }
    std::sort(result.begin(), result.end());
    return result;
  };
  auto first_half = corners(mesh, 0, half), second_half = corners(mesh, half, half);
  size_t before = 0;
  size_t after = core::optimizeVertexReuse(mesh, 16, &before);
  ASSERT_TRUE(core::validateMesh(mesh).ok());
  EXPECT_EQ(corners(mesh, 0, half), first_half);
  EXPECT_EQ(corners(mesh, half, half), second_half);
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {  // the streams moved together
    EXPECT_FLOAT_EQ(mesh.uv0[v].x * n, mesh.positions[v].x);
    EXPECT_FLOAT_EQ(mesh.uv0[v].y * n, mesh.positions[v].y);
  }
  EXPECT_EQ(after, core::countVertexRuns(mesh.indices, mesh.vertexCount(), 16));
  // Shuffled, nearly every corner misses (~3 runs per vertex over 2n² triangles); reordered,
  // each submesh's ~(n+1)²/2 vertices run about once, plus its border rows.
  EXPECT_GT(before, 5 * mesh.vertexCount() / 2);
  EXPECT_LT(after, 3 * mesh.vertexCount() / 2);
  // Vertices are numbered by first use.
  uint32_t next = 0;
  for (uint32_t v : mesh.indices) {
    EXPECT_LE(v, next);
    if (v == next) ++next;
  }
}

}  // namespace
}  // namespace duolod
