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

TEST(OffReader, CountsSplitOverLinesAreReadWithAWarning) {
  // Geomview reads the counts as free-format numbers: "4" then "1 0" on the next line.
  core::Asset asset = readOffOk(writeScratchFile(
      "split_counts.off", "OFF\n4\n# faces next\n1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"));
  EXPECT_EQ(asset.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  ASSERT_EQ(asset.warnings.size(), 1u);
  EXPECT_NE(asset.warnings[0].find("split_counts.off:2: the counts are split over lines 2 and 4"),
            std::string::npos)
      << asset.warnings[0];
  // A vertex count alone at the end of the file is still an error that says so.
  auto truncated =
      io::readOff(writeScratchFile("only_vertex_count.off", "OFF\n4\n"), io::LoadOptions{});
  ASSERT_FALSE(truncated);
  EXPECT_NE(truncated.error().message.find("file ends after the vertex count"), std::string::npos)
      << truncated.error().message;
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

// OFF is whitespace-separated numbers: the cube of CubeOfQuads with its counts on the keyword
// line, a vertex split over two lines, several vertices and several faces on a line, a face split
// over lines, all on one line, one number a line after the counts must read the same. Such files
// were refused
// ("vertex 1 has 2 values (3 needed)").
const char* kCubeByLines =
    "OFF\n8 6 12\n"
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
    "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 3 7 6 2\n4 0 4 7 3\n4 1 2 6 5\n";

TEST(OffReader, FreeFormatLayoutsReadAsByLines) {
  const core::Asset by_lines = readOffOk(writeScratchFile("cube_lines.off", kCubeByLines));
  const struct {
    const char* name;
    const char* text;
  } layouts[] = {
      {"cube_free.off",
       "OFF 8 6 12\n"
       "0 0 0   1 0 0\n1 1 0 0\n1 0  # a vertex split over two lines\n0 0 1 1 0 1\n"
       "1 1 1 0 1 1\n"
       "4 0 3 2 1 4 4 5 6 7\n4 0 1 5 4  4 3 7 6 2\n4 0 4\n7 3\n4 1 2 6 5\n"},
      {"cube_one_line.off",
       "OFF 8 6 12 0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1 4 0 3 2 1 4 4 5 6 7 "
       "4 0 1 5 4 4 3 7 6 2 4 0 4 7 3 4 1 2 6 5"},
      {"cube_columns.off",
       "OFF\n8 6 12\n0\n0\n0\n1\n0\n0\n1\n1\n0\n0\n1\n0\n0\n0\n1\n1\n0\n1\n1\n1\n1\n"
       "0\n1\n1\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 3 7 6 2\n4 0 4 7 3\n4 1 2 6 5\n"},
  };
  for (const auto& layout : layouts) {
    SCOPED_TRACE(layout.name);
    const core::Asset asset = readOffOk(writeScratchFile(layout.name, layout.text));
    EXPECT_EQ(asset.mesh.positions, by_lines.mesh.positions);
    EXPECT_EQ(asset.mesh.indices, by_lines.mesh.indices);
    EXPECT_TRUE(test::hasWarningContaining(asset, "read as free-format OFF"));
  }
  // A file laid out by lines gets no such warning.
  EXPECT_TRUE(by_lines.warnings.empty());
}

// Free-format with the optional parts: a COFF vertex split over lines keeps its 3-number colour
// (the lines tell); vertices that do not start a line have RGBA colours (Geomview's 4 numbers);
// a face's colour is what follows its indices on its line, unless that is another face.
TEST(OffReader, FreeFormatKeepsVertexAndFaceColours) {
  const core::Asset coff = readOffOk(writeScratchFile(
      "free_colors.off",
      "COFF\n4 3 0\n"
      "0 0 0\n255 0 0\n"                        // split over two lines: RGB
      "1 0 0 0 255 0 255  1 1 0 0 0 255 128\n"  // two vertices on a line: RGBA each
      "0 1 0 0.5 0.5 0.5\n"                     // one line, RGB
      "3 0 1 2 255 255 255\n"                   // a face and its colour
      "3 0 2 3 3 0 1 3\n"                       // two faces on a line (no colour)
      ));
  ASSERT_EQ(coff.mesh.colors.size(), 4u);
  EXPECT_EQ(coff.mesh.colors[0].x, 1.0f);
  EXPECT_EQ(coff.mesh.colors[0].w, 1.0f);
  EXPECT_EQ(coff.mesh.colors[1].y, 1.0f);
  EXPECT_EQ(coff.mesh.colors[2].z, 1.0f);
  EXPECT_FLOAT_EQ(coff.mesh.colors[2].w, 128 / 255.0f);
  EXPECT_EQ(coff.mesh.colors[3].x, 0.5f);
  EXPECT_EQ(coff.mesh.positions[3], (core::Vec3{0, 1, 0}));
  EXPECT_EQ(coff.mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 1, 3}));

  // Normals and texture coordinates wrapped at four numbers a line.
  const core::Asset stnoff = readOffOk(writeScratchFile("free_stn.off",
                                                        "STNOFF 3 1 0\n"
                                                        "0 0 0 0\n0 1 0 0\n"
                                                        "1 0 0 0\n0 1 1 0\n"
                                                        "0 1 0 0\n0 1 0.25 0.75\n"
                                                        "3 0 1 2\n"));
  ASSERT_EQ(stnoff.mesh.normals.size(), 3u);
  EXPECT_EQ(stnoff.mesh.positions[2], (core::Vec3{0, 1, 0}));
  EXPECT_EQ(stnoff.mesh.normals[1], (core::Vec3{0, 0, 1}));
  EXPECT_EQ(stnoff.mesh.uv0[2].x, 0.25f);
  EXPECT_EQ(stnoff.mesh.uv0[2].y, 0.25f);  // t up becomes v down
}

// A free-format file with a real fault: the message gives the line reading's reason and where the
// free-format reading failed.
TEST(OffReader, FreeFormatErrorsSayWhere) {
  const std::string path =
      writeScratchFile("free_bad.off", "OFF 3 1 0\n0 0 0 1 0 0\n0 1 0 3 0 1 7\n");
  auto asset = io::readOff(path, io::LoadOptions{});
  ASSERT_FALSE(asset.ok());
  EXPECT_EQ(asset.error().message,
            path +
                ":3: file ends after 2 of 3 vertices; read as free-format OFF instead: line 3: "
                "face 0: vertex index 7 out of range (3 vertices)");
}

TEST(OffReader, NoFacesIsNotAnErrorHere) {
  core::Asset asset = readOffOk(writeScratchFile("cloud.off", "OFF\n2 0 0\n0 0 0\n1 1 1\n"));
  EXPECT_EQ(asset.mesh.vertexCount(), 2u);
  EXPECT_EQ(asset.mesh.triangleCount(), 0u);
  EXPECT_TRUE(asset.mesh.submeshes.empty());
}

}  // namespace
}  // namespace duolod
