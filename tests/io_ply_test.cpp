// Tests for the PLY reader: one hand-written mesh in ascii, binary little-endian and binary
// big-endian must read identically; unknown elements/properties are skipped by their sizes.
#include <bit>
#include <cstring>

#include "duolod/io.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

using test::writeScratchFile;

core::Asset readPlyOk(const std::string& path) {
  return test::readOk(io::readPly, path);
}

// Builds binary PLY bodies value by value in either byte order.
class BinaryWriter {
 public:
  explicit BinaryWriter(bool big_endian) : big_endian_(big_endian) {}
  template <class T>
  BinaryWriter& put(T value) {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    bool swap = big_endian_ != (std::endian::native == std::endian::big);
    if (swap) {
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
    }
    bytes_.append(reinterpret_cast<const char*>(raw), sizeof(T));
    return *this;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  bool big_endian_;
  std::string bytes_;
};

// A quad (as one polygon) and a triangle over 5 vertices with normals, uvs and uchar colours, plus
// things a reader must skip: a float "confidence" and a list property on vertices, a "flags" byte
// before the indices on faces, and an "edge" element.
const char* kHeaderTail =
    "comment made by hand\n"
    "element vertex 5\n"
    "property float x\n"
    "property float y\n"
    "property float z\n"
    "property float confidence\n"
    "property float nx\n"
    "property float ny\n"
    "property float nz\n"
    "property float s\n"
    "property float t\n"
    "property uchar red\n"
    "property uchar green\n"
    "property uchar blue\n"
    "property list uchar int junk\n"
    "element face 2\n"
    "property uchar flags\n"
    "property list uchar int vertex_indices\n"
    "element edge 1\n"
    "property int vertex1\n"
    "property int vertex2\n"
    "end_header\n";

struct TestVertex {
  float x, y, z, confidence, nx, ny, nz, s, t;
  uint8_t r, g, b;
};
const TestVertex kVertices[5] = {
    {0, 0, 0, 0.5f, 0, 0, 1, 0, 0, 255, 0, 0},
    {1, 0, 0, 0.5f, 0, 0, 1, 1, 0, 0, 255, 0},
    {1, 1, 0, 0.5f, 0, 0, 1, 1, 1, 0, 0, 255},
    {0, 1, 0, 0.5f, 0, 0, 1, 0, 1, 51, 102, 153},
    {2, 0.5f, 0, 0.5f, 0, 0, 1, 0.25f, 0.75f, 0, 0, 0},
};

std::string asciiPly() {
  std::string text = std::string("ply\nformat ascii 1.0\n") + kHeaderTail;
  text +=
      "0 0 0 0.5 0 0 1 0 0 255 0 0 0\n"
      "1 0 0 0.5 0 0 1 1 0 0 255 0 2 7 8\n"
      "1 1 0 0.5 0 0 1 1 1 0 0 255 0\n"
      "0 1 0 0.5 0 0 1 0 1 51 102 153 1 -5\n"
      "2 0.5 0 0.5 0 0 1 0.25 0.75 0 0 0 0\n"
      "0 4 0 1 2 3\n"
      "1 3 1 4 2\n"
      "0 1\n";
  return text;
}

std::string binaryPly(bool big_endian) {
  std::string text = std::string("ply\nformat ") +
                     (big_endian ? "binary_big_endian" : "binary_little_endian") + " 1.0\n" +
                     kHeaderTail;
  BinaryWriter out(big_endian);
  for (int i = 0; i < 5; ++i) {
    const TestVertex& v = kVertices[i];
    out.put(v.x)
        .put(v.y)
        .put(v.z)
        .put(v.confidence)
        .put(v.nx)
        .put(v.ny)
        .put(v.nz)
        .put(v.s)
        .put(v.t);
    out.put(v.r).put(v.g).put(v.b);
    // The junk list: sizes 0, 2, 0, 1, 0 as in the ascii file.
    int junk[5] = {0, 2, 0, 1, 0};
    out.put(static_cast<uint8_t>(junk[i]));
    for (int k = 0; k < junk[i]; ++k) out.put(static_cast<int32_t>(7 + k));
  }
  out.put(static_cast<uint8_t>(0)).put(static_cast<uint8_t>(4));
  for (int32_t index : {0, 1, 2, 3}) out.put(index);
  out.put(static_cast<uint8_t>(1)).put(static_cast<uint8_t>(3));
  for (int32_t index : {1, 4, 2}) out.put(index);
  out.put(static_cast<int32_t>(0)).put(static_cast<int32_t>(1));
  return text + out.bytes();
}

void expectTestMesh(const core::Asset& asset) {
  const core::Mesh& mesh = asset.mesh;
  ASSERT_EQ(mesh.vertexCount(), 5u);
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 2}));
  ASSERT_EQ(mesh.normals.size(), 5u);
  ASSERT_EQ(mesh.uv0.size(), 5u);
  ASSERT_EQ(mesh.colors.size(), 5u);
  EXPECT_EQ(mesh.positions[4], (core::Vec3{2, 0.5f, 0}));
  EXPECT_EQ(mesh.normals[4], (core::Vec3{0, 0, 1}));
  // (s, t) = (0.25, 0.75) with t up becomes v = 0.25 with v down.
  EXPECT_EQ(mesh.uv0[4].x, 0.25f);
  EXPECT_EQ(mesh.uv0[4].y, 0.25f);
  EXPECT_EQ(mesh.colors[0].x, 1.0f);
  EXPECT_FLOAT_EQ(mesh.colors[3].x, 51 / 255.0f);
  EXPECT_FLOAT_EQ(mesh.colors[3].z, 153 / 255.0f);
  EXPECT_EQ(mesh.colors[3].w, 1.0f);
  EXPECT_TRUE(mesh.tangents.empty());
  ASSERT_EQ(asset.materials.size(), 1u);
  ASSERT_EQ(mesh.submeshes.size(), 1u);
  EXPECT_EQ(mesh.submeshes[0].index_count, 9u);
}

void expectSameVertexAttributes(const core::Mesh& a, const core::Mesh& b) {
  ASSERT_EQ(a.vertexCount(), b.vertexCount());
  for (size_t i = 0; i < a.vertexCount(); ++i) {
    EXPECT_EQ(a.positions[i], b.positions[i]);
    EXPECT_EQ(a.normals[i], b.normals[i]);
    EXPECT_EQ(a.uv0[i].x, b.uv0[i].x);
    EXPECT_EQ(a.uv0[i].y, b.uv0[i].y);
    EXPECT_EQ(a.colors[i].x, b.colors[i].x);
    EXPECT_EQ(a.colors[i].y, b.colors[i].y);
    EXPECT_EQ(a.colors[i].z, b.colors[i].z);
    EXPECT_EQ(a.colors[i].w, b.colors[i].w);
  }
  EXPECT_EQ(a.indices, b.indices);
}

TEST(PlyReader, Ascii) {
  std::string path = writeScratchFile("mesh_ascii.ply", asciiPly());
  core::Asset asset = readPlyOk(path);
  EXPECT_EQ(asset.source_path, path);
  expectTestMesh(asset);
}

TEST(PlyReader, ConcavePolygonIsCutIntoEars) {  // the dart of io_obj_test.cpp
  core::Asset asset = readPlyOk(writeScratchFile(
      "dart.ply",
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n2 1 0\n0 2 0\n0.5 1 0\n4 0 1 2 3\n"));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{3, 0, 1, 1, 2, 3}));
}

// The header may put the face element first: its polygons must still be cut into ears (they were
// fanned, as their corners had no positions yet: the dart's fan 0 1 2, 0 2 3 covers its notch),
// in file order, with nothing to warn about.
TEST(PlyReader, FacesBeforeVerticesAreCutIntoEars) {
  const std::string faces_first =
      "ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int vertex_indices\n"
      "element vertex 5\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
      "4 0 1 2 3\n3 1 4 2\n"
      "0 0 0\n2 1 0\n0 2 0\n0.5 1 0\n3 1 0\n";
  core::Asset asset = readPlyOk(writeScratchFile("faces_first.ply", faces_first));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{3, 0, 1, 1, 2, 3, 1, 4, 2}));
  EXPECT_TRUE(asset.warnings.empty()) << asset.warnings.front();
  ASSERT_EQ(asset.mesh.submeshes.size(), 1u);
  EXPECT_EQ(asset.mesh.submeshes[0].index_count, 9u);

  // Binary, the same way.
  BinaryWriter out(false);
  for (int32_t value : {4, 0, 1, 2, 3, 3, 1, 4, 2}) out.put(static_cast<uint8_t>(value));
  for (float value : {0.f, 0.f, 0.f, 2.f, 1.f, 0.f, 0.f, 2.f, 0.f, 0.5f, 1.f, 0.f, 3.f, 1.f, 0.f})
    out.put(value);
  core::Asset binary = readPlyOk(writeScratchFile(
      "faces_first_binary.ply",
      "ply\nformat binary_little_endian 1.0\nelement face 2\n"
      "property list uchar uchar vertex_indices\nelement vertex 5\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n" +
          out.bytes()));
  EXPECT_EQ(binary.mesh.indices, asset.mesh.indices);
  EXPECT_EQ(binary.mesh.positions, asset.mesh.positions);
}

TEST(PlyReader, BinaryLittleAndBigEndianMatchAscii) {
  core::Asset ascii = readPlyOk(writeScratchFile("mesh_ascii.ply", asciiPly()));
  core::Asset little = readPlyOk(writeScratchFile("mesh_le.ply", binaryPly(false)));
  core::Asset big = readPlyOk(writeScratchFile("mesh_be.ply", binaryPly(true)));
  expectTestMesh(little);
  expectTestMesh(big);
  expectSameVertexAttributes(ascii.mesh, little.mesh);
  expectSameVertexAttributes(ascii.mesh, big.mesh);
  // Nothing left over: every skipped property had the right size.
  for (const std::string& warning : little.warnings) {
    EXPECT_EQ(warning.find("bytes after"), std::string::npos) << warning;
  }
}

TEST(PlyReader, SizedTypeNamesFloatColorsAndVertexIndex) {
  // The names of newer writers (float32, uint8, int32), "vertex_index", float colours with alpha,
  // u/v texture coordinates, CRLF line ends.
  std::string path = writeScratchFile("sized.ply",
                                      "ply\r\nformat ascii 1.0\r\n"
                                      "element vertex 3\r\n"
                                      "property float32 x\r\nproperty float32 y\r\n"
                                      "property float64 z\r\n"
                                      "property float u\r\nproperty float v\r\n"
                                      "property float red\r\nproperty float green\r\n"
                                      "property float blue\r\nproperty float alpha\r\n"
                                      "element face 1\r\n"
                                      "property list uint8 uint32 vertex_index\r\n"
                                      "end_header\r\n"
                                      "0 0 0 0 0 0 0 1 0.5\r\n"
                                      "1 0 0 1 0 0 1 0 1\r\n"
                                      "0 1 0 0 1 1 0 0 1\r\n"
                                      "3 0 1 2\r\n");
  core::Asset asset = readPlyOk(path);
  ASSERT_EQ(asset.mesh.triangleCount(), 1u);
  ASSERT_EQ(asset.mesh.colors.size(), 3u);
  EXPECT_EQ(asset.mesh.colors[0].z, 1.0f);
  EXPECT_EQ(asset.mesh.colors[0].w, 0.5f);
  ASSERT_EQ(asset.mesh.uv0.size(), 3u);
  EXPECT_EQ(asset.mesh.uv0[2].y, 0.0f);
  EXPECT_TRUE(asset.mesh.normals.empty());
}

TEST(PlyReader, PointCloudHasNoTriangles) {
  core::Asset asset = readPlyOk(writeScratchFile(
      "points.ply",
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n0 0 0\n1 1 1\n"));
  EXPECT_EQ(asset.mesh.vertexCount(), 2u);
  EXPECT_EQ(asset.mesh.triangleCount(), 0u);
  EXPECT_TRUE(asset.mesh.submeshes.empty());
}

TEST(PlyReader, UnknownBinaryElementWithListIsSkipped) {
  // An element before "vertex" with a list, in binary: its size must be computed per item.
  std::string header =
      "ply\nformat binary_little_endian 1.0\n"
      "element material 2\nproperty list ushort double weights\nproperty short id\n"
      "element vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
      "element face 1\nproperty list int uint vertex_indices\nend_header\n";
  BinaryWriter out(false);
  out.put(static_cast<uint16_t>(2)).put(1.0).put(2.0).put(static_cast<int16_t>(5));
  out.put(static_cast<uint16_t>(0)).put(static_cast<int16_t>(6));
  for (double v : {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0}) out.put(v);
  out.put(static_cast<int32_t>(3));
  for (uint32_t i : {0u, 1u, 2u}) out.put(i);
  core::Asset asset = readPlyOk(writeScratchFile("skip.ply", header + out.bytes()));
  ASSERT_EQ(asset.mesh.vertexCount(), 3u);
  EXPECT_EQ(asset.mesh.positions[1], (core::Vec3{1, 0, 0}));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
}

}  // namespace
}  // namespace duolod
