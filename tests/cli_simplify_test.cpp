// End-to-end tests of `duolod simplify`: the built binary (DUOLOD_CLI) runs with stdout and stderr
// redirected to scratch files; the tests check the exit code, what the user reads, and the files
// written (reloaded with io::loadAsset).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "duolod/io.hpp"
#include "duolod/mesh.hpp"
#include "mesh_test_meshes.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;

using test::runCli;

// The line of `text` starting with `prefix` ("" when there is none).
std::string lineStarting(const std::string& text, const std::string& prefix) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind(prefix, 0) == 0) return line;
  return {};
}

// A UV sphere (`rings` × `segments` quads, poles fanned) with normals, as a .glb in `dir`: a cheap
// closed input (352 triangles by default).
std::string writeSphere(const fs::path& dir, int rings = 12, int segments = 16,
                        const std::string& name = "sphere.glb") {
  core::Asset asset;
  core::Mesh& m = asset.mesh;
  const float pi = 3.14159265f;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      float theta = pi * float(r) / float(rings), phi = 2 * pi * float(s) / float(segments);
      core::Vec3 p{std::sin(theta) * std::cos(phi), std::cos(theta),
                   std::sin(theta) * std::sin(phi)};
      m.positions.push_back(p);
      m.normals.push_back(p);
      if (r == 0 || r == rings) break;  // one vertex per pole
    }
  auto index = [&](int r, int s) -> uint32_t {
    if (r == 0) return 0;
    if (r == rings) return uint32_t(m.positions.size() - 1);
    return uint32_t(1 + (r - 1) * segments + (s % segments));
  };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      uint32_t a = index(r, s), b = index(r, s + 1), c = index(r + 1, s), d = index(r + 1, s + 1);
      if (r != 0) m.indices.insert(m.indices.end(), {a, b, c});
      if (r != rings - 1) m.indices.insert(m.indices.end(), {b, d, c});
    }
  m.submeshes = {{0, uint32_t(m.indices.size()), 0}};
  asset.materials = {core::Material{.name = "grey"}};
  std::string path = (dir / name).string();
  EXPECT_TRUE(io::writeGltf(asset, path));
  return path;
}

// The same triangles, corner by corner, up to what a text file's decimals keep of a position.
void expectSameCorners(const core::Mesh& written, const core::Mesh& expected) {
  ASSERT_EQ(written.indices.size(), expected.indices.size());
  for (size_t i = 0; i < expected.indices.size(); ++i) {
    const core::Vec3 a = written.positions[written.indices[i]];
    const core::Vec3 b = expected.positions[expected.indices[i]];
    ASSERT_NEAR(a.x, b.x, 1e-6f) << "index " << i;
    ASSERT_NEAR(a.y, b.y, 1e-6f) << "index " << i;
    ASSERT_NEAR(a.z, b.z, 1e-6f) << "index " << i;
  }
}

// A file without normals (OFF, or an OBJ of positions only) is simplified as what it holds,
// positions: the loader's generated normals are not simplified as attributes (that took the slow
// general path, 7x the time on CGAL's bunny) but derived again from the result. The written mesh
// is the library's position-only result, with one normal per vertex.
TEST(CliSimplify, NormalsTheFileLacksAreDerivedAfterNotSimplified) {
  DUOLOD_REQUIRE_ASSET(path, "obj/spot/spot.obj");
  fs::path dir = test::scratchDir("positions_only");
  auto spot = io::loadAsset(path, {.load_textures = false});
  ASSERT_TRUE(spot) << spot.error().message;
  core::Asset bare;
  bare.mesh.positions = spot->mesh.positions;
  bare.mesh.indices = spot->mesh.indices;
  bare.mesh.submeshes = {{0, uint32_t(bare.mesh.indices.size()), 0}};
  bare.materials = {core::Material{.name = "grey"}};
  const std::string in = (dir / "spot_positions.obj").string();
  ASSERT_TRUE(io::writeObj(bare, in));

  const std::string out = (dir / "spot_positions_10.obj").string();
  test::CommandRun run = runCli({"simplify", in, out, "--ratio", "0.1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto written = io::loadAsset(out, {.generate_normals = false});
  ASSERT_TRUE(written) << written.error().message;
  EXPECT_EQ(written->mesh.normals.size(), written->mesh.vertexCount()) << "normals derived again";

  auto reloaded = io::loadAsset(in, {.generate_normals = false, .generate_tangents = false});
  ASSERT_TRUE(reloaded) << reloaded.error().message;
  ASSERT_TRUE(reloaded->mesh.normals.empty());
  const size_t target = size_t(std::lround(0.1 * double(reloaded->mesh.triangleCount())));
  const mesh::SimplifyResult expected =
      mesh::simplifyQuadric(reloaded->mesh, {.target_triangles = target, .record = false});
  ASSERT_EQ(written->mesh.vertexCount(), expected.mesh.vertexCount());
  expectSameCorners(written->mesh, expected.mesh);

  // --simplify-generated-normals: the loader's normals, simplified as attributes.
  const std::string kept = (dir / "spot_positions_10_normals.obj").string();
  run = runCli({"simplify", in, kept, "--ratio", "0.1", "--simplify-generated-normals"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto with_normals = io::loadAsset(in);  // generated normals
  ASSERT_TRUE(with_normals) << with_normals.error().message;
  const mesh::SimplifyResult engine =
      mesh::simplifyQuadric(with_normals->mesh, {.target_triangles = target, .record = false});
  auto written_kept = io::loadAsset(kept, {.generate_normals = false});
  ASSERT_TRUE(written_kept) << written_kept.error().message;
  expectSameCorners(written_kept->mesh, engine.mesh);
}

// The headline case: Spot to 10% with the quadric mode writes a .glb that reloads with about 10%
// of the triangles, Spot's texture and material, and the attribute streams; the report has one line
// per stage with the counts and the geometric error.
TEST(CliSimplify, QuadricSpotToTenPercentWritesAValidGlb) {
  DUOLOD_REQUIRE_ASSET(path, "obj/spot/spot.obj");
  fs::path dir = test::scratchDir("spot");
  std::string out = (dir / "spot_10.glb").string();
  test::CommandRun run = runCli({"simplify", path, out, "--ratio", "0.1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;

  auto input = io::loadAsset(path);
  ASSERT_TRUE(input) << input.error().message;
  auto output = io::loadAsset(out);
  ASSERT_TRUE(output) << output.error().message;
  const double expected = 0.1 * double(input->mesh.triangleCount());  // 585.6
  EXPECT_NEAR(double(output->mesh.triangleCount()), expected, 0.02 * expected);
  EXPECT_EQ(output->mesh.uv0.size(), output->mesh.vertexCount());
  EXPECT_EQ(output->mesh.normals.size(), output->mesh.vertexCount());
  ASSERT_EQ(output->materials.size(), input->materials.size());
  EXPECT_GE(output->materials[0].base_color_texture, 0) << "the texture was dropped";
  ASSERT_EQ(output->textures.size(), input->textures.size());
  EXPECT_EQ(output->textures[0].image.width, input->textures[0].image.width);

  const std::string simplify = lineStarting(run.out, "simplify");
  EXPECT_TRUE(test::contains(simplify, "quadric")) << run.out;
  EXPECT_TRUE(test::contains(simplify, std::to_string(input->mesh.triangleCount()) + " -> " +
                                     std::to_string(output->mesh.triangleCount())))
      << run.out;
  const std::string geometry = lineStarting(run.out, "geometry");
  EXPECT_TRUE(test::contains(geometry, "Hausdorff")) << run.out;
  EXPECT_TRUE(test::contains(geometry, "mean")) << run.out;
  EXPECT_TRUE(test::contains(geometry, "% of the bounding-box diagonal")) << run.out;
  EXPECT_FALSE(lineStarting(run.out, "load").empty()) << run.out;
  EXPECT_FALSE(lineStarting(run.out, "write").empty()) << run.out;
  EXPECT_TRUE(lineStarting(run.out, "image").empty()) << "no distance, no image error: " << run.out;

  // An existing OUT needs --force, and is left alone without it.
  std::string before = test::readText(out);
  test::CommandRun again = runCli({"simplify", path, out, "--ratio", "0.5"});
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.exit_code, -1);
  EXPECT_TRUE(test::contains(again.err, "already exists")) << again.err;
  EXPECT_EQ(test::readText(out), before);
  test::CommandRun forced = runCli({"simplify", path, out, "--ratio", "0.5", "--force"});
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  auto replaced = io::loadAsset(out);
  ASSERT_TRUE(replaced) << replaced.error().message;
  EXPECT_NEAR(double(replaced->mesh.triangleCount()), 5 * expected, 0.02 * 5 * expected);
}

// `--no-geometry` leaves out only the geometry line (its surface sampling is most of the command's
// time on large meshes): the other lines are printed and the file written is the same, byte for
// byte, as without the flag.
TEST(CliSimplify, NoGeometryLeavesOutOnlyTheGeometryLine) {
  fs::path dir = test::scratchDir("no_geometry");
  const std::string sphere = writeSphere(dir);
  // One file name in two folders: a .glb names its mesh and node after the file.
  fs::create_directories(dir / "measured");
  fs::create_directories(dir / "unmeasured");
  const std::string measured = (dir / "measured" / "sphere_50.glb").string();
  const std::string unmeasured = (dir / "unmeasured" / "sphere_50.glb").string();
  test::CommandRun with = runCli({"simplify", sphere, measured, "--ratio", "0.5"});
  ASSERT_EQ(with.exit_code, 0) << with.err;
  EXPECT_FALSE(lineStarting(with.out, "geometry").empty()) << with.out;
  test::CommandRun without =
      runCli({"simplify", sphere, unmeasured, "--ratio", "0.5", "--no-geometry"});
  ASSERT_EQ(without.exit_code, 0) << without.err;
  EXPECT_TRUE(lineStarting(without.out, "geometry").empty()) << without.out;
  for (const char* stage : {"load", "simplify", "write"})
    EXPECT_FALSE(lineStarting(without.out, stage).empty()) << stage << ": " << without.out;
  const std::string written = test::readText(unmeasured);
  EXPECT_FALSE(written.empty());
  EXPECT_TRUE(written == test::readText(measured)) << "the files differ";
}

// Works on a scratch copy, so that a regression cannot overwrite a shared asset.
// A target below what the rules allow is reported with the reason: here a square of two
// triangles whose every vertex is on its locked border has no candidate edge at all, so no
// collapse was refused either.
TEST(CliSimplify, UnreachableTargetSaysWhy) {
  fs::path dir = test::scratchDir("unreachable");
  const std::string square = (dir / "square.obj").string();
  std::ofstream(square) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const std::string out = (dir / "out.glb").string();
  test::CommandRun run = runCli({"simplify", square, out, "--triangles", "1", "--lock-border"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(test::contains(lineStarting(run.out, "simplify"),
                             "target 1 not reached (no edge may collapse"))
      << run.out;
  EXPECT_TRUE(
      test::contains(run.err, "warning: " + square + ": the target of 1 triangles was not reached"))
      << run.err;
  auto output = io::loadAsset(out);
  ASSERT_TRUE(output) << output.error().message;
  EXPECT_EQ(output->mesh.triangleCount(), 2u);
  EXPECT_FALSE(test::contains(run.out, "misoriented")) << run.out;

  // The same square with its second triangle turned round: the diagonal is run the same way by
  // both triangles, and the line names that as what holds its vertices.
  const std::string turned = (dir / "turned.obj").string();
  std::ofstream(turned) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 4 3\n";
  test::CommandRun misoriented =
      runCli({"simplify", turned, (dir / "turned_out.glb").string(), "--triangles", "1"});
  ASSERT_EQ(misoriented.exit_code, 0) << misoriented.err;
  EXPECT_TRUE(
      test::contains(lineStarting(misoriented.out, "simplify"),
                     "; the input has 1 misoriented and 0 non-manifold edges (duolod info), "
                     "whose vertices never move"))
      << misoriented.out;
}

// --reorient turns triangles round before simplifying: an icosphere (320 outward triangles)
// with every third triangle turned holds nearly every vertex still without it (and the line says
// so, naming the flag); with it, 107 triangles are turned back and the target is reached.
TEST(CliSimplify, ReorientTurnsTrianglesFirst) {
  fs::path dir = test::scratchDir("reorient");
  const std::string turned = (dir / "turned.obj").string();
  test::writeIcosphereWithTurnedTriangles(turned, 2);  // 320 triangles
  test::CommandRun held =
      runCli({"simplify", turned, (dir / "held.obj").string(), "--triangles", "32"});
  ASSERT_EQ(held.exit_code, 0) << held.err;
  EXPECT_TRUE(test::contains(lineStarting(held.out, "simplify"),
                             "whose vertices never move (--reorient turns triangles round"))
      << held.out;
  EXPECT_EQ(lineStarting(held.out, "reorient"), "");

  const std::string out = (dir / "reoriented.obj").string();
  test::CommandRun run = runCli({"simplify", turned, out, "--triangles", "32", "--reorient"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(lineStarting(run.out, "reorient"),
            "reorient  107 triangles turned round, 1 parts (0 cannot be oriented: left as they "
            "were)")
      << run.out;
  EXPECT_TRUE(test::contains(lineStarting(run.out, "simplify"), "320 -> 32 triangles")) << run.out;
  auto output = io::loadAsset(out);
  ASSERT_TRUE(output) << output.error().message;
  EXPECT_EQ(output->mesh.triangleCount(), 32u);
  EXPECT_EQ(mesh::surfaceTopology(output->mesh).misoriented_edges, 0u);
}

TEST(CliSimplify, RefusesToOverwriteItsInput) {
  fs::path dir = test::scratchDir("input");
  std::string sphere = writeSphere(dir);
  std::string before = test::readText(sphere);
  for (bool force : {false, true}) {
    std::vector<std::string> args = {"simplify", sphere, sphere, "--ratio", "0.5"};
    if (force) args.push_back("--force");
    test::CommandRun run = runCli(args);
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.exit_code, -1) << "crashed";
    EXPECT_TRUE(test::contains(run.err, "input")) << run.err;
    EXPECT_EQ(test::readText(sphere), before);
  }
  // The same file by another name.
  std::string alias = (dir / "." / "sphere.glb").string();
  test::CommandRun run = runCli({"simplify", sphere, alias, "--ratio", "0.5", "--force"});
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(test::readText(sphere), before);
}

// A file the output would write beside it (.bin, .mtl) that exists is not replaced without
// --force, and nothing is written; an output folder that does not exist, or is a file, is refused
// before the input is even loaded.
TEST(CliSimplify, FilesBesideTheOutputAndItsFolderAreChecked) {
  fs::path dir = test::scratchDir("beside");
  std::string sphere = writeSphere(dir);
  for (const char* kept : {"out.bin", "out.mtl"}) {
    std::ofstream(dir / kept) << "precious";
    const std::string out =
        (dir / (std::string(kept) == "out.bin" ? "out.gltf" : "out.obj")).string();
    test::CommandRun run = runCli({"simplify", sphere, out, "--ratio", "0.5"});
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_TRUE(test::contains(run.err, std::string(kept) + ": already exists, written beside"))
        << run.err;
    EXPECT_TRUE(test::contains(run.err, "(use --force to replace it)")) << run.err;
    // Found before the work (it was found by the writer, after an image-mode run's minutes).
    EXPECT_FALSE(test::contains(run.out, "simplify")) << run.out;
    EXPECT_EQ(test::readText(dir / kept), "precious");
    EXPECT_FALSE(fs::exists(out));
    test::CommandRun forced = runCli({"simplify", sphere, out, "--ratio", "0.5", "--force"});
    EXPECT_EQ(forced.exit_code, 0) << forced.err;
    EXPECT_NE(test::readText(dir / kept), "precious");
  }
  for (const std::string& out : {(dir / "nowhere" / "out.glb").string(), sphere + "/out.glb"}) {
    test::CommandRun run = runCli({"simplify", sphere, out, "--ratio", "0.5"});
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_TRUE(test::contains(
        run.err, out.find("nowhere") != std::string::npos ? "does not exist" : "is not a folder"))
        << run.err;
    EXPECT_FALSE(test::contains(run.out, "load")) << "loaded before checking: " << run.out;
  }
}

// Each bad combination fails with a message naming the problem (before any work, but for a
// result with no triangles), and writes nothing.
TEST(CliSimplify, BadFlagsFailWithAMessage) {
  fs::path dir = test::scratchDir("flags");
  std::string sphere = writeSphere(dir);
  std::string out = (dir / "out.glb").string();
  struct Case {
    std::vector<std::string> flags;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{}, "exactly one of --ratio"},
      {{"--ratio", "0.5", "--triangles", "10"}, "exactly one of --ratio"},
      {{"--ratio", "0.5", "--error", "0.1"}, "exactly one of --ratio"},
      {{"--ratio", "0"}, "(0, 1]"},
      {{"--ratio", "1.5"}, "(0, 1]"},
      {{"--ratio", "-0.2"}, "(0, 1]"},
      {{"--triangles", "0"}, "must be >= 1"},
      {{"--triangles", "-5"}, "must be >= 1"},
      {{"--error", "-1"}, "--error"},
      {{"--mode", "image", "--ratio", "0.5"}, "--distance D or --pixels N"},
      {{"--ratio", "0.5", "--distance", "3", "--pixels", "64"}, "at most one of --distance"},
      {{"--ratio", "0.5", "--grid", "8"}, "--grid applies to --mode cluster"},
      {{"--mode", "cluster", "--ratio", "0.5", "--grid", "8"}, "cluster mode: give exactly one"},
      {{"--mode", "cluster", "--grid", "8", "--lock-border"}, "--lock-border"},
      {{"--mode", "cluster", "--grid", "0"}, "must be >= 1, got 0"},
      // One cell holds the whole sphere: no triangle is left, and no empty file is written.
      {{"--mode", "cluster", "--grid", "1"}, "the result has no triangles (grid 1"},
      {{"--mode", "image", "--pixels", "32", "--ratio", "0.5", "--placement", "optimal"},
       "--placement applies to --mode quadric only (image mode"},
      {{"--mode", "cluster", "--grid", "4", "--placement", "endpoint"},
       "--placement applies to --mode quadric only (cluster mode"},
      {{"--ratio", "0.5", "--max-edge-pixels", "4"},
       "--max-edge-pixels applies to --mode image only"},
      {{"--mode", "fancy", "--ratio", "0.5"}, "fancy"},
      {{"--placement", "middle", "--ratio", "0.5"}, "middle"},
      {{"--ratio", "half"}, "--ratio"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"simplify", sphere, out};
    args.insert(args.end(), c.flags.begin(), c.flags.end());
    std::string shown;
    for (const std::string& a : c.flags) shown += a + " ";
    SCOPED_TRACE(shown);
    test::CommandRun run = runCli(args);
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.exit_code, -1) << "crashed";
    EXPECT_TRUE(test::contains(run.err, c.message)) << run.err;
    EXPECT_FALSE(fs::exists(out)) << "a failed run wrote its output";
  }
  // A value out of a flag's range is the parser's error (exit code 2, as the README says), with
  // the flag's name; the ranges show in --help.
  for (const std::vector<std::string>& flags :
       std::vector<std::vector<std::string>>{{"--ratio", "1.5"},
                                             {"--ratio", "nan"},
                                             {"--triangles", "0"},
                                             {"--error", "-1"},
                                             {"--mode", "cluster", "--grid", "0"},
                                             {"--max-edge-pixels", "0", "--ratio", "0.5"}}) {
    std::vector<std::string> args = {"simplify", sphere, out};
    args.insert(args.end(), flags.begin(), flags.end());
    test::CommandRun run = runCli(args);
    EXPECT_EQ(run.exit_code, 2) << flags[0] << " " << flags[1] << ": " << run.err;
  }
  test::CommandRun help = runCli({"simplify", "--help"});
  EXPECT_TRUE(test::contains(help.out, "in (0, 1]")) << help.out;

  test::CommandRun extension = runCli({"simplify", sphere, (dir / "out.png").string(), "--ratio", "0.5"});
  EXPECT_NE(extension.exit_code, 0);
  EXPECT_TRUE(test::contains(extension.err, ".gltf, .glb or .obj")) << extension.err;

  test::CommandRun missing = runCli({"simplify", (dir / "nowhere.obj").string(), out, "--ratio", "0.5"});
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.exit_code, -1) << "crashed";
  EXPECT_TRUE(test::contains(missing.err, "nowhere.obj")) << missing.err;
  EXPECT_FALSE(fs::exists(out));
}

// A cluster triangle target that only an empty mesh meets (every grid that keeps a triangle keeps
// more): the coarsest grid that keeps any is written, above the target, with the warning; it
// failed with "the result has no triangles (grid 1 ...)" although grid 2 keeps some.
TEST(CliSimplify, ClusterTargetBelowEveryGridThatKeepsATriangle) {
  fs::path dir = test::scratchDir("cluster_tiny_target");
  const std::string sphere = writeSphere(dir);
  const std::string out = (dir / "tiny.glb").string();
  test::CommandRun run = runCli({"simplify", sphere, out, "--mode", "cluster", "--triangles", "1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto output = io::loadAsset(out);
  ASSERT_TRUE(output) << output.error().message;
  EXPECT_GT(output->mesh.triangleCount(), 1u);
  EXPECT_TRUE(test::contains(run.err, "the target of 1 triangles was not reached")) << run.err;
  // A coarser grid keeps nothing.
  const std::string grid = lineStarting(run.out, "simplify");
  const size_t at = grid.find("grid ");
  ASSERT_NE(at, std::string::npos) << run.out;
  const int used = std::stoi(grid.substr(at + 5));
  test::CommandRun coarser = runCli({"simplify", sphere, (dir / "coarser.glb").string(), "--mode",
                                     "cluster", "--grid", std::to_string(used - 1)});
  EXPECT_EQ(coarser.exit_code, 1);
  EXPECT_TRUE(test::contains(coarser.err, "the result has no triangles")) << coarser.err;
}

// The other modes and targets on small spheres, each reloading with the count it reports; with
// --pixels the image error at that distance is reported too. Image mode never collapses an edge
// longer than 1 pixel, so its sphere is finer (1,920 triangles, 64 segments: edges under 1 px at a
// 20 px footprint) and drawn with the constant shader to keep the run to a couple of seconds.
TEST(CliSimplify, OtherModesAndTargets) {
  fs::path dir = test::scratchDir("modes");
  const std::string coarse = writeSphere(dir);
  const std::string fine = writeSphere(dir, 16, 64, "fine_sphere.glb");
  auto coarse_asset = io::loadAsset(coarse);
  ASSERT_TRUE(coarse_asset) << coarse_asset.error().message;
  const size_t coarse_triangles = coarse_asset->mesh.triangleCount();
  ASSERT_EQ(coarse_triangles, 352u);

  struct Case {
    std::string out;
    std::string input;
    std::vector<std::string> flags;
    size_t at_most;    // triangles
    int footprint_px;  // 0: no distance given, no image line
  };
  const std::vector<Case> cases = {
      {"triangles.obj", coarse, {"--triangles", "100"}, 100, 0},
      {"error.gltf",
       coarse,
       {"--error", "0.05", "--placement", "endpoint", "--lock-border"},
       coarse_triangles - 1,
       0},
      {"grid.glb", coarse, {"--mode", "cluster", "--grid", "4"}, coarse_triangles / 2, 0},
      {"cluster_ratio.glb",
       coarse,
       {"--mode", "cluster", "--ratio", "0.25"},
       coarse_triangles / 4,
       0},
      {"quadric_pixels.glb",
       coarse,
       {"--ratio", "0.5", "--pixels", "48"},
       coarse_triangles / 2,
       48},
      {"image.glb",
       fine,
       {"--mode", "image", "--pixels", "20", "--ratio", "0.8", "--shader", "constant"},
       1536,
       20},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.out);
    std::string out = (dir / c.out).string();
    std::vector<std::string> args = {"simplify", c.input, out};
    args.insert(args.end(), c.flags.begin(), c.flags.end());
    test::CommandRun run = runCli(args);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    auto output = io::loadAsset(out);
    ASSERT_TRUE(output) << output.error().message;
    EXPECT_GT(output->mesh.triangleCount(), 0u);
    EXPECT_LE(output->mesh.triangleCount(), c.at_most) << run.out;
    EXPECT_TRUE(test::contains(lineStarting(run.out, "simplify"),
                         "-> " + std::to_string(output->mesh.triangleCount()) + " triangles"))
        << run.out;
    const std::string image = lineStarting(run.out, "image");
    EXPECT_EQ(image.empty(), c.footprint_px == 0) << run.out;
    if (c.footprint_px > 0) {
      EXPECT_TRUE(test::contains(image, "footprint " + std::to_string(c.footprint_px) + " px"))
          << run.out;
      EXPECT_TRUE(test::contains(image, "epsilon")) << run.out;
    }
  }
}

}  // namespace
}  // namespace duolod
