// Tests for the OBJ/MTL reader and writer: tiny hand-written files with exact expected results,
// and Keenan Crane's Spot (shared asset) for a real file with UV seams and a texture.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "duolod/io.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

using test::writeScratchFile;

using test::noTextures;

core::Asset readObjOk(const std::string& path, const io::LoadOptions& options = noTextures()) {
  return test::readOk(io::readObj, path, options);
}

using test::hasWarningContaining;

const char* kQuad =
    "# a unit quad in z = 0\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n"
    "f 1 2 3 4\n";

TEST(ObjReader, QuadIsFanTriangulated) {
  std::string path = writeScratchFile("quad.obj", kQuad);
  core::Asset asset = readObjOk(path);
  EXPECT_EQ(asset.source_path, path);
  ASSERT_EQ(asset.mesh.vertexCount(), 4u);
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_TRUE(asset.mesh.uv0.empty());
  EXPECT_TRUE(asset.mesh.normals.empty());  // loadAsset generates them
  EXPECT_TRUE(asset.mesh.tangents.empty());
  EXPECT_TRUE(asset.mesh.colors.empty());
  ASSERT_EQ(asset.materials.size(), 1u);
  EXPECT_EQ(asset.materials[0].name, "default");
  EXPECT_EQ(asset.materials[0].metallic_factor, 0.0f);  // OBJ materials are not metal by default
  ASSERT_EQ(asset.mesh.submeshes.size(), 1u);
  EXPECT_EQ(asset.mesh.submeshes[0].first_index, 0u);
  EXPECT_EQ(asset.mesh.submeshes[0].index_count, 6u);
  EXPECT_EQ(asset.mesh.positions[2], (core::Vec3{1, 1, 0}));
}

// A dart: corner 3 is a notch. The fan from corner 0 would fold its second triangle back over the
// notch's outside; ears give (3 0 1) and (1 2 3), both turning as the polygon does.
const char* kDart =
    "v 0 0 0\n"
    "v 2 1 0\n"
    "v 0 2 0\n"
    "v 0.5 1 0\n"
    "f 1 2 3 4\n";

TEST(ObjReader, ConcavePolygonIsCutIntoEars) {
  core::Asset asset = readObjOk(writeScratchFile("dart.obj", kDart));
  // The reader numbers vertices as the triangles first use them: the notch is vertex 0.
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 2, 3, 0}));
  EXPECT_EQ(asset.mesh.positions[0], (core::Vec3{0.5f, 1, 0}));
  EXPECT_TRUE(asset.warnings.empty());
}

// Twice the signed area (about +z) of each triangle, summed; and the smallest and largest.
double signedDoubleArea(const core::Mesh& mesh, double& smallest, double& largest) {
  double total = 0;
  smallest = INFINITY, largest = -INFINITY;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const core::Vec3 a = mesh.positions[mesh.indices[t * 3]],
                     b = mesh.positions[mesh.indices[t * 3 + 1]],
                     c = mesh.positions[mesh.indices[t * 3 + 2]];
    const double area =
        (double(b.x) - a.x) * (double(c.y) - a.y) - (double(b.y) - a.y) * (double(c.x) - a.x);
    total += area;
    smallest = std::min(smallest, area), largest = std::max(largest, area);
  }
  return total;
}

TEST(ObjReader, ConcavePolygonsWithCollinearCornersAndClockwiseTurns) {
  // An L of area 3 with a corner in the middle of its left side, counter-clockwise, and the same
  // L clockwise: every triangle turns as its polygon and together they cover it once.
  const std::string l_shape = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 1 0\n";
  for (bool clockwise : {false, true}) {
    SCOPED_TRACE(clockwise ? "clockwise" : "counter-clockwise");
    core::Asset asset = readObjOk(writeScratchFile(
        "l.obj", l_shape + (clockwise ? "f 7 6 5 4 3 2 1\n" : "f 1 2 3 4 5 6 7\n")));
    ASSERT_EQ(asset.mesh.triangleCount(), 5u);
    double smallest = 0, largest = 0;
    const double area = signedDoubleArea(asset.mesh, smallest, largest);
    EXPECT_DOUBLE_EQ(area, clockwise ? -6.0 : 6.0);
    EXPECT_LE(clockwise ? largest : -smallest, 0.0) << "a triangle turns the other way";
    EXPECT_TRUE(asset.warnings.empty());
  }
}

TEST(ObjReader, PolygonsThatTouchThemselvesOrRepeatACorner) {
  // The dart with its notch corner repeated: the zero-length edge hid the notch, and the fan
  // folded a triangle over it. Ears again, the repeat left out.
  core::Asset repeated =
      readObjOk(writeScratchFile("dart_repeat.obj", std::string(kDart) + "f 1 2 3 4 4\n"));
  ASSERT_EQ(repeated.mesh.triangleCount(), 4u);  // the dart's own two, then these two
  core::Mesh second = repeated.mesh;
  second.indices.erase(second.indices.begin(), second.indices.begin() + 6);
  double smallest = 0, largest = 0;
  EXPECT_DOUBLE_EQ(signedDoubleArea(second, smallest, largest), 3.0);
  EXPECT_GE(smallest, 0.0);
  // Two squares meeting at a corner, as one polygon (and a pentagram, which turns the same way
  // at every corner): no triangulation by the polygon's corners turns every triangle its way, so
  // they are fanned with the warning, not cut into an ear outside the polygon silently.
  for (const char* polygon :
       {"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 2 1 0\nv 2 2 0\nv 1 2 0\nv 1 1 0\nv 0 1 0\n"
        "f 1 2 3 4 5 6 7 8\n",
        "v 1 0 0\nv -0.809 -0.588 0\nv 0.309 0.951 0\nv 0.309 -0.951 0\nv -0.809 0.588 0\n"
        "f 1 2 3 4 5\n"}) {
    core::Asset asset = readObjOk(writeScratchFile("touching.obj", polygon));
    EXPECT_TRUE(hasWarningContaining(asset, "could not be cut into ears")) << polygon;
  }
}

TEST(ObjReader, ConvexPolygonsWithCornersOnTheirEdgesAreFannedInAnyPlane) {
  // A square with its edges' midpoints, turned in space: rounding leaves the midpoints a turn of
  // about 1e-9 either way, which made some of them concave (cut into other triangles).
  const double square[8][2] = {{0, 0}, {0.5, 0}, {1, 0}, {1, 0.5},
                               {1, 1}, {0.5, 1}, {0, 1}, {0, 0.5}};
  for (int turn = 0; turn < 100; ++turn) {
    const double a = 0.37 * turn, b = 0.11 * turn;  // about z, then about x
    std::string text;
    for (const auto& p : square) {
      const double x = p[0] * std::cos(a) - p[1] * std::sin(a);
      const double y = p[0] * std::sin(a) + p[1] * std::cos(a);
      char line[96];
      std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", x, y * std::cos(b), y * std::sin(b));
      text += line;
    }
    core::Asset asset = readObjOk(writeScratchFile("tilted.obj", text + "f 1 2 3 4 5 6 7 8\n"));
    EXPECT_EQ(asset.mesh.indices,
              (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 7}))
        << "turn " << turn;
  }
}

TEST(ObjReader, PolygonCornersPastTheVerticesAreAnErrorNotACrash) {
  // Positive indices are checked after the file; a polygon's corners were read before.
  auto asset = io::readObj(
      writeScratchFile("far_corner.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3 2000000000\n"),
      noTextures());
  ASSERT_FALSE(asset);
  EXPECT_NE(asset.error().message.find("far_corner.obj:4: face index 2000000000 out of range"),
            std::string::npos)
      << asset.error().message;
  // A face before its vertices is valid OBJ.
  core::Asset late =
      readObjOk(writeScratchFile("late.obj", "f 1 2 3 4\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"));
  EXPECT_EQ(late.mesh.triangleCount(), 2u);
}

// A polygon before its vertices is cut up once they are read, as it would be after them: the dart
// gets its ears, not the fan that folds over its notch; and the triangles keep their place among
// the file's others (a triangle before and after it, a second dart in another material).
TEST(ObjReader, PolygonsBeforeTheirVerticesAreCutIntoEarsInPlace) {
  const std::string vertices = "v 0 0 0\nv 2 1 0\nv 0 2 0\nv 0.5 1 0\nv 3 0 0\n";
  const std::string faces = "f 1 2 3 4\nf 2 5 3\nusemtl other\nf 1 2 3 4\n";
  core::Asset after = readObjOk(writeScratchFile("dart_after.obj", vertices + faces));
  core::Asset before = readObjOk(writeScratchFile("dart_before.obj", faces + vertices));
  EXPECT_EQ(before.mesh.indices, after.mesh.indices);
  EXPECT_EQ(before.mesh.positions, after.mesh.positions);
  ASSERT_EQ(before.mesh.submeshes.size(), 2u);
  EXPECT_EQ(before.mesh.submeshes[1].index_count, 6u);
  EXPECT_EQ(before.warnings.size(), after.warnings.size());  // ("other" has no library)
  EXPECT_FALSE(hasWarningContaining(before, "could not be cut into ears"));
  // (The fan would be 0 1 2, 0 2 3 with the notch first.)
  EXPECT_EQ(std::vector<uint32_t>(before.mesh.indices.begin(), before.mesh.indices.begin() + 6),
            (std::vector<uint32_t>{0, 1, 2, 2, 3, 0}));
}

TEST(ObjReader, SelfCrossingPolygonIsFannedWithAWarning) {
  // A bow tie: its two halves turn opposite ways, so its area vector is zero.
  core::Asset asset =
      readObjOk(writeScratchFile("bowtie.obj", "v 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\n"));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_TRUE(hasWarningContaining(asset, "bowtie.obj:5: a polygon could not be cut into ears"));
}

TEST(ObjReader, NegativeIndicesCountBackFromTheLastVertex) {
  // The same quad with relative indices; then a second quad defined after more vertices, where
  // -4 must mean the 5th vertex, not the 1st.
  std::string path = writeScratchFile("relative.obj",
                                      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                      "f -4 -3 -2 -1\n"
                                      "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                                      "f -4 -3 -2 -1\n");
  core::Asset asset = readObjOk(path);
  ASSERT_EQ(asset.mesh.vertexCount(), 8u);
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7}));
  EXPECT_EQ(asset.mesh.positions[4], (core::Vec3{0, 0, 1}));
}

TEST(ObjReader, CubeWithPerFaceNormalsHas24Corners) {
  // 8 positions x 6 face normals; each corner of each face is a distinct (v, vn) pair: 6 * 4 = 24.
  std::string path =
      writeScratchFile("cube.obj",
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                       "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                       "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n"
                       "f 1//1 4//1 3//1 2//1\n"
                       "f 5//2 6//2 7//2 8//2\n"
                       "f 1//3 2//3 6//3 5//3\n"
                       "f 4//4 8//4 7//4 3//4\n"
                       "f 1//5 5//5 8//5 4//5\n"
                       "f 2//6 3//6 7//6 6//6\n");
  core::Asset asset = readObjOk(path);
  EXPECT_EQ(asset.mesh.vertexCount(), 24u);
  EXPECT_EQ(asset.mesh.triangleCount(), 12u);
  ASSERT_EQ(asset.mesh.normals.size(), 24u);
  EXPECT_TRUE(asset.mesh.uv0.empty());
  // First face: all four corners carry normal 1.
  for (int i = 0; i < 4; ++i) EXPECT_EQ(asset.mesh.normals[i], (core::Vec3{0, 0, -1}));
  EXPECT_EQ(asset.mesh.normals[23], (core::Vec3{1, 0, 0}));
}

TEST(ObjReader, SharedCornersAreMergedAndVIsFlipped) {
  // Two triangles share the edge 1-3 with the same texcoords: 4 vertices, not 6.
  std::string path = writeScratchFile("uv.obj",
                                      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                      "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.25 0.75\n"
                                      "f 1/1 2/2 3/3\n"
                                      "f 1/1 3/3 4/4\n");
  core::Asset asset = readObjOk(path);
  ASSERT_EQ(asset.mesh.vertexCount(), 4u);
  ASSERT_EQ(asset.mesh.uv0.size(), 4u);
  // OBJ's v points up; ours down: (0.25, 0.75) becomes (0.25, 0.25).
  EXPECT_EQ(asset.mesh.uv0[3].x, 0.25f);
  EXPECT_EQ(asset.mesh.uv0[3].y, 0.25f);
  EXPECT_EQ(asset.mesh.uv0[0].y, 1.0f);
}

TEST(ObjReader, SameVertexWithTwoTexcoordsIsSplit) {
  // A UV seam: position 1 appears with vt 1 and vt 4 -> two vertices.
  std::string path = writeScratchFile("seam.obj",
                                      "v 0 0 0\nv 1 0 0\nv 1 1 0\n"
                                      "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.5\n"
                                      "f 1/1 2/2 3/3\n"
                                      "f 1/4 3/3 2/2\n");
  core::Asset asset = readObjOk(path);
  EXPECT_EQ(asset.mesh.vertexCount(), 4u);
  EXPECT_EQ(asset.mesh.positions[3], asset.mesh.positions[0]);
}

// A zero normal has no direction: the loaded mesh takes the surface's normal there (it drew
// black, and its error against the same triangle with a normal was 0.77 per pixel).
TEST(ObjReader, ZeroNormalsTakeTheSurfacesNormal) {
  const std::string path = writeScratchFile(
      "zero_normal.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 0 0 1\nf 1//1 2//1 3//2\n");
  auto asset = io::loadAsset(path, noTextures());
  ASSERT_TRUE(asset) << asset.error().message;
  ASSERT_EQ(asset->mesh.normals.size(), 3u);
  for (const core::Vec3& n : asset->mesh.normals) EXPECT_EQ(n, (core::Vec3{0, 0, 1}));
  EXPECT_TRUE(hasWarningContaining(*asset, "2 normals were zero"));
}

TEST(ObjReader, MissingTexcoordsOrNormalsOnSomeCorners) {
  std::string path = writeScratchFile("partial.obj",
                                      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                      "vt 0.5 0.5\nvn 0 0 1\n"
                                      "f 1/1/1 2/1/1 3/1/1\n"
                                      "f 1 3 4\n");
  core::Asset asset = readObjOk(path);
  // UVs kept ((0, 0) where missing); normals dropped entirely, as an incomplete stream would be
  // wrong and loadAsset regenerates them.
  EXPECT_EQ(asset.mesh.uv0.size(), asset.mesh.vertexCount());
  EXPECT_TRUE(asset.mesh.normals.empty());
  EXPECT_TRUE(hasWarningContaining(asset, "no texture coordinate"));
  EXPECT_TRUE(hasWarningContaining(asset, "no normal"));
  // Corner 1 with uv and corner 1 without are different vertices: 1/1, 2/1, 3/1, 1, 3, 4.
  EXPECT_EQ(asset.mesh.vertexCount(), 6u);
  EXPECT_EQ(asset.mesh.uv0[3].x, 0.0f);
  EXPECT_EQ(asset.mesh.uv0[3].y, 0.0f);
}

TEST(ObjReader, VertexColorsAndTrailingComments) {
  std::string path = writeScratchFile("colors.obj",
                                      "v 0 0 0 1 0 0  # red\n"
                                      "v 1 0 0 0 1 0\n"
                                      "v 1 1 0 0 0 1\n"
                                      "f 1 2 3 # one triangle\n");
  core::Asset asset = readObjOk(path);
  ASSERT_EQ(asset.mesh.colors.size(), 3u);
  EXPECT_EQ(asset.mesh.colors[0].x, 1.0f);
  EXPECT_EQ(asset.mesh.colors[0].w, 1.0f);
  EXPECT_EQ(asset.mesh.colors[2].z, 1.0f);
  EXPECT_EQ(asset.mesh.triangleCount(), 1u);
}

TEST(ObjReader, CrlfLinesAndContinuations) {
  std::string path = writeScratchFile("crlf.obj",
                                      "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n"
                                      "f 1 2 \\\r\n 3 4\r\n");
  core::Asset asset = readObjOk(path);
  EXPECT_EQ(asset.mesh.triangleCount(), 2u);
}

// Values outside glTF's ranges are clamped with a warning naming the line (an OBJ's Kd 5 was
// written out as a baseColorFactor of 5, which is not glTF); a material defined twice is said so.
TEST(ObjReader, MaterialValuesOutsideGltfRangesAreClamped) {
  std::filesystem::path dir = test::scratchDir("clamped_materials");
  std::ofstream(dir / "odd.mtl") << "newmtl odd\n"
                                    "Kd 5 -3 0.5\n"
                                    "Ke -1 2 0\n"
                                    "Pr 1.5\n"
                                    "Pm -0.5\n"
                                    "newmtl odd\n"
                                    "Kd 5 -3 0.5\n";
  std::ofstream(dir / "odd.obj")
      << "mtllib odd.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl odd\nf 1 2 3\n";
  core::Asset asset = readObjOk((dir / "odd.obj").string());
  ASSERT_EQ(asset.materials.size(), 1u);
  const core::Vec4 base = asset.materials[0].base_color_factor;
  EXPECT_EQ(base.x, 1.0f);
  EXPECT_EQ(base.y, 0.0f);
  EXPECT_EQ(base.z, 0.5f);
  EXPECT_TRUE(hasWarningContaining(asset, "odd.mtl:2: 'Kd' outside [0, 1]; clamped"));
  EXPECT_TRUE(hasWarningContaining(asset, "odd.mtl:3: 'Ke' outside [0, inf]; clamped"));
  EXPECT_TRUE(hasWarningContaining(asset, "odd.mtl:4: 'Pr' outside [0, 1]; clamped"));
  EXPECT_TRUE(hasWarningContaining(asset, "odd.mtl:5: 'Pm' outside [0, 1]; clamped"));
  EXPECT_TRUE(hasWarningContaining(asset, "odd.mtl:6: material 'odd' is defined again"));
}

TEST(ObjReader, MaterialsGroupTrianglesIntoContiguousSubmeshes) {
  std::filesystem::path dir = test::scratchDir("materials");
  std::ofstream(dir / "two.mtl") << "# two materials\n"
                                    "newmtl red\n"
                                    "Kd 1 0 0\n"
                                    "Ke 0.5 0.25 0\n"
                                    "Pr 0.3\n"
                                    "Pm 0.7\n"
                                    "d 1\n"
                                    "\n"
                                    "newmtl shiny blue\n"
                                    "Kd 0 0 1\n"
                                    "Ns 98\n";
  std::ofstream(dir / "mats.obj") << "mtllib two.mtl\n"
                                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                     "usemtl red\n"
                                     "f 1 2 3\n"
                                     "usemtl shiny blue\n"
                                     "f 1 3 4\n"
                                     "usemtl red\n"
                                     "f 2 3 4\n"
                                     "usemtl unknown\n"
                                     "f 1 2 4\n";
  core::Asset asset = readObjOk((dir / "mats.obj").string());
  ASSERT_EQ(asset.materials.size(), 3u);
  EXPECT_EQ(asset.materials[0].name, "red");
  EXPECT_EQ(asset.materials[1].name, "shiny blue");
  EXPECT_EQ(asset.materials[2].name, "unknown");
  ASSERT_EQ(asset.mesh.submeshes.size(), 3u);
  // red: faces 1 and 3 together, first.
  EXPECT_EQ(asset.mesh.submeshes[0].first_index, 0u);
  EXPECT_EQ(asset.mesh.submeshes[0].index_count, 6u);
  EXPECT_EQ(asset.mesh.submeshes[0].material, 0u);
  EXPECT_EQ(asset.mesh.submeshes[1].first_index, 6u);
  EXPECT_EQ(asset.mesh.submeshes[1].index_count, 3u);
  EXPECT_EQ(asset.mesh.submeshes[1].material, 1u);
  EXPECT_EQ(asset.mesh.submeshes[2].first_index, 9u);
  EXPECT_EQ(asset.mesh.submeshes[2].material, 2u);

  const core::Material& red = asset.materials[0];
  EXPECT_EQ(red.base_color_factor.x, 1.0f);
  EXPECT_EQ(red.base_color_factor.y, 0.0f);
  EXPECT_EQ(red.base_color_factor.w, 1.0f);
  EXPECT_EQ(red.emissive_factor, (core::Vec3{0.5f, 0.25f, 0}));
  EXPECT_FLOAT_EQ(red.roughness_factor, 0.3f);
  EXPECT_FLOAT_EQ(red.metallic_factor, 0.7f);
  // Ns 98: alpha = sqrt(2 / 100), roughness = sqrt(alpha) = 0.37606.
  EXPECT_NEAR(asset.materials[1].roughness_factor, 0.37606f, 1e-4f);
  EXPECT_EQ(asset.materials[1].metallic_factor, 0.0f);
  EXPECT_TRUE(hasWarningContaining(asset, "'unknown' is not defined"));
  EXPECT_FALSE(hasWarningContaining(asset, "transparency"));  // "d 1" is opaque
}

TEST(ObjReader, MtlTexturesWithoutDecoding) {
  std::filesystem::path dir = test::scratchDir("textures");
  std::ofstream(dir / "tex.mtl") << "newmtl a\n"
                                    "map_Kd -s 1 1 1 -o 0 0 textures\\wood grain.png\n"
                                    "norm -bm 0.5 normal.png\n"
                                    "map_Ke glow.png\n"
                                    "map_Pr rough.png\n"
                                    "newmtl b\n"
                                    "map_Kd textures/wood grain.png\n"
                                    "bump normal.png\n";
  std::ofstream(dir / "tex.obj") << "mtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\n"
                                    "usemtl a\nf 1 2 3\nusemtl b\nf 3 2 1\n";
  core::Asset asset = readObjOk((dir / "tex.obj").string());
  ASSERT_EQ(asset.materials.size(), 2u);
  const core::Material& a = asset.materials[0];
  const core::Material& b = asset.materials[1];
  ASSERT_GE(a.base_color_texture, 0);
  // Same file and colour space: one texture shared; backslashes read as folder separators.
  EXPECT_EQ(a.base_color_texture, b.base_color_texture);
  EXPECT_EQ(a.normal_texture, b.normal_texture);
  const core::Texture& wood = asset.textures[a.base_color_texture];
  EXPECT_TRUE(wood.srgb);
  EXPECT_TRUE(wood.image.pixels.empty());
  EXPECT_EQ(std::filesystem::path(wood.name).filename().string(), "wood grain.png");
  EXPECT_FALSE(asset.textures[a.normal_texture].srgb);
  EXPECT_EQ(a.normal_scale, 0.5f);
  ASSERT_GE(a.emissive_texture, 0);
  EXPECT_TRUE(asset.textures[a.emissive_texture].srgb);
  EXPECT_EQ(a.emissive_factor, (core::Vec3{1, 1, 1}));  // a map without Ke must still show
  ASSERT_GE(a.metallic_roughness_texture, 0);
  EXPECT_FALSE(asset.textures[a.metallic_roughness_texture].srgb);
  EXPECT_EQ(a.roughness_factor, 1.0f);
  EXPECT_EQ(asset.textures.size(), 4u);
}

// Tangents generated at load split the mirror line of a mirrored UV layout (two quads, u = x on
// the left and 2 - x on the right) only where a normal map will shade with them: without one the
// copies would be seams for nothing.
TEST(ObjReader, GeneratedTangentsSplitMirrorLinesOnlyUnderANormalMap) {
  std::filesystem::path dir = test::scratchDir("mirrored");
  const std::string geometry =
      "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n"
      "vt 0 0\nvt 1 0\nvt 0 0\nvt 0 1\nvt 1 1\nvt 0 1\n"
      "f 1/1 2/2 5/5 4/4\nf 2/2 3/3 6/6 5/5\n";
  std::ofstream(dir / "plain.mtl") << "newmtl a\nmap_Kd colour.png\n";
  std::ofstream(dir / "bumpy.mtl") << "newmtl a\nmap_Kd colour.png\nnorm normal.png\n";
  for (const char* name : {"plain", "bumpy"}) {
    std::ofstream(dir / (std::string(name) + ".obj"))
        << "mtllib " << name << ".mtl\nusemtl a\n" << geometry;
  }
  io::LoadOptions options;
  options.load_textures = false;
  auto plain = io::loadAsset((dir / "plain.obj").string(), options);
  auto bumpy = io::loadAsset((dir / "bumpy.obj").string(), options);
  ASSERT_TRUE(plain) << plain.error().message;
  ASSERT_TRUE(bumpy) << bumpy.error().message;
  EXPECT_EQ(core::normalMappedSubmeshes(*plain), std::vector<bool>{false});
  EXPECT_EQ(core::normalMappedSubmeshes(*bumpy), std::vector<bool>{true});
  EXPECT_EQ(plain->mesh.vertexCount(), 6u);
  ASSERT_EQ(bumpy->mesh.vertexCount(), 8u);
  ASSERT_EQ(bumpy->mesh.tangents.size(), 8u);
  for (size_t t = 0; t < 4; ++t) {  // the left quad's two triangles first
    const float side = t < 2 ? 1.0f : -1.0f;
    for (int k = 0; k < 3; ++k) {
      const core::Vec4 tangent = bumpy->mesh.tangents[bumpy->mesh.indices[t * 3 + k]];
      EXPECT_NEAR(tangent.x, side, 1e-5f) << t;
      EXPECT_EQ(tangent.w, -side) << t;  // OBJ's v runs up, glTF's (ours) down: v flipped
    }
  }
  // Per submesh: the same layout twice in one file, the second copy (x + 3) under a material
  // without a normal map, splits the first copy's line only.
  std::ofstream(dir / "mixed.mtl") << "newmtl bumpy\nmap_Kd colour.png\nnorm normal.png\n"
                                   << "newmtl plain\nmap_Kd colour.png\n";
  std::ofstream(dir / "mixed.obj")
      << "mtllib mixed.mtl\n"
      << "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n"
      << "vt 0 0\nvt 1 0\nvt 0 0\nvt 0 1\nvt 1 1\nvt 0 1\n"
      << "v 3 0 0\nv 4 0 0\nv 5 0 0\nv 3 1 0\nv 4 1 0\nv 5 1 0\n"
      << "usemtl bumpy\nf 1/1 2/2 5/5 4/4\nf 2/2 3/3 6/6 5/5\n"
      << "usemtl plain\nf 7/1 8/2 11/5 10/4\nf 8/2 9/3 12/6 11/5\n";
  auto mixed = io::loadAsset((dir / "mixed.obj").string(), options);
  ASSERT_TRUE(mixed) << mixed.error().message;
  EXPECT_EQ(core::normalMappedSubmeshes(*mixed), (std::vector<bool>{true, false}));
  EXPECT_EQ(mixed->mesh.vertexCount(), 14u);
}

TEST(ObjReader, MissingMtlFileIsAWarning) {
  std::string path = writeScratchFile("nomtl.obj",
                                      "mtllib does_not_exist.mtl\n"
                                      "v 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl stone\nf 1 2 3\n");
  core::Asset asset = readObjOk(path);
  EXPECT_TRUE(hasWarningContaining(asset, "does_not_exist.mtl"));
  EXPECT_TRUE(hasWarningContaining(asset, "nomtl.obj:1:"));
  ASSERT_EQ(asset.materials.size(), 1u);
  EXPECT_EQ(asset.materials[0].name, "stone");
  EXPECT_EQ(asset.mesh.triangleCount(), 1u);
}

TEST(ObjReader, PointsLinesAndFreeFormAreSkipped) {
  std::string path = writeScratchFile("mixed.obj",
                                      "o thing\ng part\ns 1\n"
                                      "v 0 0 0\nv 1 0 0\nv 1 1 0\n"
                                      "l 1 2\np 3\nf 1 2 3\n");
  core::Asset asset = readObjOk(path);
  EXPECT_EQ(asset.mesh.triangleCount(), 1u);
  EXPECT_TRUE(hasWarningContaining(asset, "(p, l) ignored"));
}

TEST(ObjReader, NoFacesIsNotAnErrorHere) {
  // Zero triangles is loadAsset's call to reject, not the reader's.
  auto asset = io::readObj(writeScratchFile("points.obj", "v 0 0 0\nv 1 0 0\n"), noTextures());
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  EXPECT_EQ(asset->mesh.triangleCount(), 0u);
  EXPECT_TRUE(asset->mesh.submeshes.empty());
  EXPECT_EQ(asset->materials.size(), 1u);
}

TEST(ObjReader, SpotHasExactCounts) {
  DUOLOD_REQUIRE_ASSET(path, "obj/spot/spot.obj");
  core::Asset asset = readObjOk(path);
  EXPECT_EQ(asset.mesh.triangleCount(), 5856u);
  // Every vertex is a distinct (position, texcoord) pair: at least the 3,225 texcoords and the
  // 2,930 positions are all used.
  EXPECT_GE(asset.mesh.vertexCount(), 3225u);
  EXPECT_EQ(asset.mesh.uv0.size(), asset.mesh.vertexCount());
  EXPECT_TRUE(asset.mesh.normals.empty());
  EXPECT_TRUE(asset.warnings.empty());
  // The first face is "f 739/1 735/2 736/3": vertex 0 is v 739 with vt 1 = (0.800375, 0.667457).
  EXPECT_EQ(asset.mesh.positions[0], (core::Vec3{0.317288f, -0.397295f, 0.364448f}));
  EXPECT_EQ(asset.mesh.uv0[0].x, 0.800375f);
  EXPECT_EQ(asset.mesh.uv0[0].y, 1.0f - 0.667457f);
}

TEST(ObjReader, SpotTextureLoadsThroughAnMtl) {
  // spot.obj has no mtllib; give it one in a scratch folder that points at the real texture.
  DUOLOD_REQUIRE_ASSET(obj_path, "obj/spot/spot.obj");
  DUOLOD_REQUIRE_ASSET(png_path, "obj/spot/spot_texture.png");
  std::filesystem::path dir = test::scratchDir("spot");
  std::ofstream(dir / "spot.mtl") << "newmtl spot\nKd 1 1 1\nmap_Kd "
                                  << std::filesystem::absolute(png_path).string() << "\n";
  std::ifstream original(obj_path);
  std::stringstream contents;
  contents << original.rdbuf();
  std::ofstream(dir / "spot.obj") << "mtllib spot.mtl\nusemtl spot\n" << contents.str();

  auto asset = io::readObj((dir / "spot.obj").string(), io::LoadOptions{});
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  EXPECT_EQ(asset->mesh.triangleCount(), 5856u);
  ASSERT_EQ(asset->materials.size(), 1u);
  ASSERT_EQ(asset->textures.size(), 1u);
  EXPECT_EQ(asset->materials[0].base_color_texture, 0);
  const core::Texture& texture = asset->textures[0];
  EXPECT_TRUE(texture.srgb);
  EXPECT_EQ(texture.image.width, 1024);
  EXPECT_EQ(texture.image.height, 1024);
  EXPECT_EQ(texture.image.pixels.size(), 1024u * 1024u * 4u);
}

TEST(ObjWriter, RoundTripKeepsGeometryAndMaterials) {
  std::filesystem::path dir = test::scratchDir("roundtrip");
  std::ofstream(dir / "in.mtl") << "newmtl red\nKd 1 0 0\nPr 0.25\nPm 0.5\nKe 0 0.5 0\n"
                                   "newmtl blue\nKd 0 0 1\n";
  std::ofstream(dir / "in.obj") << "mtllib in.mtl\n"
                                   "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\n"
                                   "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.1 0.7\n"
                                   "vn 0 0 1\n"
                                   "usemtl red\nf 1/1/1 2/2/1 3/3/1\n"
                                   "usemtl blue\nf 1/1/1 3/3/1 4/4/1\n";
  core::Asset in = readObjOk((dir / "in.obj").string());
  std::string out_path = (dir / "out.obj").string();
  auto written = io::writeObj(in, out_path);
  ASSERT_TRUE(written.ok()) << written.error().message;
  EXPECT_TRUE(std::filesystem::exists(dir / "out.mtl"));
  core::Asset out = readObjOk(out_path);

  EXPECT_EQ(out.mesh.positions.size(), in.mesh.positions.size());
  for (size_t i = 0; i < in.mesh.positions.size(); ++i) {
    EXPECT_EQ(out.mesh.positions[i], in.mesh.positions[i]);
    EXPECT_EQ(out.mesh.normals[i], in.mesh.normals[i]);
    EXPECT_NEAR(out.mesh.uv0[i].x, in.mesh.uv0[i].x, 1e-6f);
    EXPECT_NEAR(out.mesh.uv0[i].y, in.mesh.uv0[i].y, 1e-6f);  // v is flipped twice
    EXPECT_EQ(out.mesh.colors[i].x, in.mesh.colors[i].x);
  }
  EXPECT_EQ(out.mesh.indices, in.mesh.indices);
  ASSERT_EQ(out.mesh.submeshes.size(), 2u);
  ASSERT_EQ(out.materials.size(), 2u);
  EXPECT_EQ(out.materials[0].name, "red");
  EXPECT_EQ(out.materials[1].name, "blue");
  EXPECT_EQ(out.materials[0].roughness_factor, 0.25f);
  EXPECT_EQ(out.materials[0].metallic_factor, 0.5f);
  EXPECT_EQ(out.materials[0].emissive_factor, (core::Vec3{0, 0.5f, 0}));
  EXPECT_EQ(out.materials[1].base_color_factor.z, 1.0f);
}

TEST(ObjWriter, TexturesAreWrittenAsPngAndReadBack) {
  std::filesystem::path dir = test::scratchDir("texture_out");
  core::Asset asset;
  asset.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}};
  asset.mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}};
  asset.mesh.indices = {0, 1, 2};
  asset.mesh.submeshes = {{.first_index = 0, .index_count = 3, .material = 0}};
  core::Material material;
  material.name = "checker";
  material.base_color_texture = 0;
  material.metallic_roughness_texture = 1;
  asset.materials = {material};
  core::Texture color{.name = "c", .image = {2, 1, {255, 0, 0, 255, 0, 255, 0, 255}}, .srgb = true};
  core::Texture mr{.name = "mr", .image = {1, 1, {0, 64, 200, 255}}, .srgb = false};
  asset.textures = {color, mr};
  std::string path = (dir / "tex.obj").string();
  auto written = io::writeObj(asset, path);
  ASSERT_TRUE(written.ok()) << written.error().message;

  auto back = io::readObj(path, io::LoadOptions{});
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->materials.size(), 1u);
  const core::Material& read = back->materials[0];
  ASSERT_GE(read.base_color_texture, 0);
  const core::ImageRGBA8& image = back->textures[read.base_color_texture].image;
  EXPECT_EQ(image.width, 2);
  EXPECT_EQ(image.pixels, color.image.pixels);
  // map_Pr -imfchan g / map_Pm -imfchan b put the packed texture back together.
  ASSERT_GE(read.metallic_roughness_texture, 0);
  const core::ImageRGBA8& packed = back->textures[read.metallic_roughness_texture].image;
  ASSERT_EQ(packed.pixels.size(), 4u);
  EXPECT_EQ(packed.pixels[1], 64);
  EXPECT_EQ(packed.pixels[2], 200);
  EXPECT_EQ(read.metallic_factor, 1.0f);
  EXPECT_EQ(read.roughness_factor, 1.0f);
}

TEST(ObjWriter, RefusesToOverwriteItsSource) {
  std::string path = writeScratchFile("source.obj", kQuad);
  core::Asset asset = readObjOk(path);
  auto written = io::writeObj(asset, path);
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.error().message.find("source.obj"), std::string::npos);
  // The original is untouched.
  std::ifstream in(path);
  std::stringstream contents;
  contents << in.rdbuf();
  EXPECT_EQ(contents.str(), kQuad);
}

}  // namespace
}  // namespace duolod
