// Tests for the OFF reader (OFF, COFF, NOFF, CNOFF, STOFF): tiny hand-written files with exact
// expected counts and values.
#include "duolod/io.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

using test::writeScratchFile;

core::Asset readOffOk(const std::string& path) {
  return test::readOk(io::readOff, path);
}

TEST(OffReader, CubeOfQuads) {
  std::string path = writeScratchFile("cube.off",
                                      "OFF\n"
                                      "# a unit cube\n"
                                      "8 6 12\n"
                                      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                                      "0 0 1\n1 0 1\n1 1 1\n0 1 1  # last vertex\n"
                                      "\n"
                                      "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n"
                                      "4 3 7 6 2\n4 0 4 7 3\n4 1 2 6 5\n");
  core::Asset asset = readOffOk(path);
  EXPECT_EQ(asset.source_path, path);
  EXPECT_EQ(asset.mesh.vertexCount(), 8u);
  EXPECT_EQ(asset.mesh.triangleCount(), 12u);
  EXPECT_EQ(asset.mesh.positions[6], (core::Vec3{1, 1, 1}));
  // Fan of the first quad: (0 3 2), (0 2 1).
  EXPECT_EQ((std::vector<uint32_t>(asset.mesh.indices.begin(), asset.mesh.indices.begin() + 6)),
            (std::vector<uint32_t>{0, 3, 2, 0, 2, 1}));
  EXPECT_TRUE(asset.mesh.normals.empty());
  EXPECT_TRUE(asset.mesh.colors.empty());
  ASSERT_EQ(asset.materials.size(), 1u);
  ASSERT_EQ(asset.mesh.submeshes.size(), 1u);
  EXPECT_EQ(asset.mesh.submeshes[0].index_count, 36u);
}

TEST(OffReader, PentagonAndCountsOnTheKeywordLine) {
  core::Asset asset = readOffOk(writeScratchFile(
      "pentagon.off", "OFF 5 1 0\n0 0 0\n2 0 0\n3 1 0\n1 2 0\n-1 1 0\n5 0 1 2 3 4 0.5 0.5 0.5\n"));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
}

TEST(OffReader, ConcavePolygonIsCutIntoEars) {  // the dart of io_obj_test.cpp
  core::Asset asset = readOffOk(
      writeScratchFile("dart.off", "OFF\n4 1 0\n0 0 0\n2 1 0\n0 2 0\n0.5 1 0\n4 0 1 2 3\n"));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{3, 0, 1, 1, 2, 3}));
}

TEST(OffReader, MissingKeywordIsAccepted) {
  core::Asset asset =
      readOffOk(writeScratchFile("bare.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_EQ(asset.mesh.triangleCount(), 1u);
}

TEST(OffReader, CoffIntegerAndFloatColors) {
  core::Asset asset = readOffOk(writeScratchFile("colors.off",
                                                 "COFF\n4 2 0\n"
                                                 "0 0 0 255 0 0 255\n"
                                                 "1 0 0 0 128 0 255\n"
                                                 "1 1 0 0 0 1 1\n"      // floats 0..1 (none > 1)
                                                 "0 1 0 0.5 0.5 0.5\n"  // no alpha
                                                 "3 0 1 2\n3 0 2 3\n"));
  ASSERT_EQ(asset.mesh.colors.size(), 4u);
  EXPECT_EQ(asset.mesh.colors[0].x, 1.0f);
  EXPECT_EQ(asset.mesh.colors[0].w, 1.0f);
  EXPECT_FLOAT_EQ(asset.mesh.colors[1].y, 128 / 255.0f);
  EXPECT_EQ(asset.mesh.colors[2].z, 1.0f);
  EXPECT_EQ(asset.mesh.colors[3].x, 0.5f);
  EXPECT_EQ(asset.mesh.colors[3].w, 1.0f);
}

TEST(OffReader, NoffNormals) {
  core::Asset asset = readOffOk(writeScratchFile("normals.off",
                                                 "NOFF\n3 1 0\n"
                                                 "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0.6 0 0.8\n"
                                                 "3 0 1 2\n"));
  ASSERT_EQ(asset.mesh.normals.size(), 3u);
  EXPECT_EQ(asset.mesh.normals[2], (core::Vec3{0.6f, 0, 0.8f}));
  EXPECT_TRUE(asset.mesh.colors.empty());
}

TEST(OffReader, CnoffAndStoff) {
  core::Asset colored = readOffOk(writeScratchFile("cn.off",
                                                   "CNOFF\n3 1 0\n"
                                                   "0 0 0 0 0 1 1 0 0 1\n"
                                                   "1 0 0 0 0 1 0 1 0 1\n"
                                                   "0 1 0 0 0 1 0 0 1 1\n"
                                                   "3 0 1 2\n"));
  ASSERT_EQ(colored.mesh.normals.size(), 3u);
  ASSERT_EQ(colored.mesh.colors.size(), 3u);
  EXPECT_EQ(colored.mesh.colors[1].y, 1.0f);

  core::Asset textured = readOffOk(writeScratchFile("st.off",
                                                    "STOFF\n3 1 0\n"
                                                    "0 0 0 0 0\n1 0 0 1 0\n0 1 0 0.25 0.75\n"
                                                    "3 0 1 2\n"));
  ASSERT_EQ(textured.mesh.uv0.size(), 3u);
  EXPECT_EQ(textured.mesh.uv0[2].x, 0.25f);
  EXPECT_EQ(textured.mesh.uv0[2].y, 0.25f);  // t up becomes v down

  // Integer colours next to fractional texture coordinates: only the colour tokens decide.
  core::Asset both = readOffOk(writeScratchFile("stc.off",
                                                "STCOFF\n3 1 0\n"
                                                "0 0 0 255 0 0 0.5 0.5\n"
                                                "1 0 0 0 255 0 255 1 0\n"
                                                "0 1 0 0 0 255 0.25 0.75\n"
                                                "3 0 1 2\n"));
  ASSERT_EQ(both.mesh.colors.size(), 3u);
  EXPECT_EQ(both.mesh.colors[0].x, 1.0f);
  EXPECT_EQ(both.mesh.colors[1].w, 1.0f);
  EXPECT_EQ(both.mesh.colors[2].z, 1.0f);
  EXPECT_EQ(both.mesh.uv0[0].x, 0.5f);
  EXPECT_EQ(both.mesh.uv0[1].x, 1.0f);
  EXPECT_EQ(both.mesh.uv0[2].y, 0.25f);
}

TEST(OffReader, NoFacesIsNotAnErrorHere) {
  core::Asset asset = readOffOk(writeScratchFile("cloud.off", "OFF\n2 0 0\n0 0 0\n1 1 1\n"));
  EXPECT_EQ(asset.mesh.vertexCount(), 2u);
  EXPECT_EQ(asset.mesh.triangleCount(), 0u);
  EXPECT_TRUE(asset.mesh.submeshes.empty());
}

}  // namespace
}  // namespace duolod
