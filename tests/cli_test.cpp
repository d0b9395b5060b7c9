// End-to-end tests of the duolod command line: each test runs the built binary (DUOLOD_CLI) with
// stdout and stderr redirected to scratch files, then checks the exit code, the text a user sees
// and the files written.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "duolod/core.hpp"
#include "duolod/io.hpp"
#include "duolod/render.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;


// Runs `duolod ARGS...` and captures its output.
using test::runCli;

// A small quad written as a .glb into `dir`: a cheap input for tests that do not need a real asset.
std::string writeQuad(const fs::path& dir) {
  core::Asset asset;
  asset.mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  asset.mesh.normals.assign(4, core::Vec3{0, 0, 1});
  asset.mesh.indices = {0, 1, 2, 0, 2, 3};
  asset.mesh.submeshes = {{0, 6, 0}};
  asset.materials = {core::Material{.name = "grey"}};
  std::string path = (dir / "quad.glb").string();
  EXPECT_TRUE(io::writeGltf(asset, path));
  return path;
}

// The value printed after `label` on its own line, e.g. "epsilon (eq. 6)      26.6".
double printedValue(const std::string& text, const std::string& label) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind(label, 0) == 0) return std::stod(line.substr(label.size()));
  ADD_FAILURE() << "no line starting with '" << label << "' in:\n" << text;
  return NAN;
}

TEST(Cli, VersionAndHelp) {
  test::CommandRun version = runCli({"--version"});
  EXPECT_EQ(version.exit_code, 0) << version.err;
  EXPECT_TRUE(test::contains(version.out, "duolod 0.1.0")) << version.out;
  test::CommandRun short_version = runCli({"-v"});  // was "A subcommand is required"
  EXPECT_EQ(short_version.exit_code, 0) << short_version.err;
  EXPECT_EQ(short_version.out, version.out);

  test::CommandRun help = runCli({"--help"});
  EXPECT_EQ(help.exit_code, 0) << help.err;
  for (const char* command : {"info", "render", "error"})
    EXPECT_TRUE(test::contains(help.out, command)) << "--help does not mention " << command;
}

TEST(Cli, NoSubcommandOrUnknownFlagFails) {
  test::CommandRun none = runCli({});
  EXPECT_NE(none.exit_code, 0);
  EXPECT_NE(none.exit_code, -1);
  test::CommandRun unknown = runCli({"info", "--no-such-flag", "x.gltf"});
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_NE(unknown.exit_code, -1);
}

TEST(Cli, InfoOnWaterBottle) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  test::CommandRun info = runCli({"info", path});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_TRUE(test::contains(info.out, "triangles   4510")) << info.out;
  EXPECT_TRUE(test::contains(info.out, "BottleMat")) << info.out;
  EXPECT_TRUE(test::contains(info.out,
                             "topology    6897 edges: 264 border, 0 non-manifold, 0 misoriented "
                             "(two triangles running the same way); Euler characteristic -2"))
      << info.out;
}

TEST(Cli, InfoOnMissingAndGarbageFiles) {
  fs::path dir = test::scratchDir("in");
  test::CommandRun missing = runCli({"info", (dir / "nowhere.gltf").string()});
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.exit_code, -1) << "crashed";
  EXPECT_TRUE(test::contains(missing.err, "nowhere.gltf")) << missing.err;

  std::string garbage_bytes;
  for (int i = 0; i < 512; ++i) garbage_bytes += char((i * 131 + 7) % 251);
  for (const char* name : {"garbage.gltf", "garbage.glb"}) {
    SCOPED_TRACE(name);
    std::string path = (dir / name).string();
    std::ofstream(path, std::ios::binary) << garbage_bytes;
    test::CommandRun garbage = runCli({"info", path});
    EXPECT_NE(garbage.exit_code, 0);
    EXPECT_NE(garbage.exit_code, -1) << "crashed";
    EXPECT_TRUE(test::contains(garbage.err, name)) << garbage.err;
  }
}

// A loader's warning names its file once: the OBJ and PLY readers' own warnings carry the path
// (and line), the others get it from the CLI (the path was printed twice before).
TEST(Cli, WarningsNameTheFileOnce) {
  fs::path dir = test::scratchDir("warn");
  const std::string path = (dir / "quad.obj").string();
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl missing\nf 1 2 3\nf 1 3 4\n"
                         "f 1 1 2\n";
  test::CommandRun info = runCli({"info", path});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_TRUE(test::contains(info.err, "duolod: warning: " + path + ":5: material 'missing'"))
      << info.err;  // the reader's own, with its line
  EXPECT_TRUE(test::contains(info.err, "duolod: warning: " + path + ": 1 degenerate")) << info.err;
  EXPECT_FALSE(test::contains(info.err, path + ": " + path)) << info.err;
}

TEST(Cli, RenderOneViewOfWaterBottle) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  fs::path dir = test::scratchDir("render");
  std::string out = (dir / "bottle.png").string();
  test::CommandRun render = runCli({"render", path, "--distance", "1", "--view", "0", "--out", out});
  ASSERT_EQ(render.exit_code, 0) << render.err;
  auto image = io::readImage(out);
  ASSERT_TRUE(image) << image.error().message;
  EXPECT_EQ(image->width, 369);
  EXPECT_EQ(image->height, 369);
  size_t covered = 0;
  for (size_t p = 0; p < image->pixels.size() / 4; ++p) covered += image->pixels[p * 4 + 3] > 0;
  EXPECT_GT(covered, 1000u) << "no object in the image";
  EXPECT_LT(covered, size_t(image->width) * image->height) << "the object fills every pixel";
  auto alpha = [&](int x, int y) { return image->pixels[(size_t(y) * image->width + x) * 4 + 3]; };
  int last = image->width - 1;
  EXPECT_EQ(alpha(0, 0), 0);
  EXPECT_EQ(alpha(last, 0), 0);
  EXPECT_EQ(alpha(0, last), 0);
  EXPECT_EQ(alpha(last, last), 0);

  // A second render to the same --out without --force fails and leaves the file as it was.
  std::string before = test::readText(out);
  test::CommandRun again =
      runCli({"render", path, "--distance", "1", "--view", "0", "--light", "2", "--out", out});
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.exit_code, -1);
  EXPECT_TRUE(test::contains(again.err, "already exists")) << again.err;
  EXPECT_EQ(test::readText(out), before);
}

// Works on a scratch file, so that a regression cannot overwrite a shared asset.
TEST(Cli, RenderRefusesToOverwriteItsInput) {
  fs::path dir = test::scratchDir("render");
  std::string quad = writeQuad(dir);
  std::string before = test::readText(quad);
  for (bool force : {false, true}) {
    std::vector<std::string> args = {"render", quad, "--distance", "5",
                                     "--view", "0",  "--out",      quad};
    if (force) args.push_back("--force");
    test::CommandRun run = runCli(args);
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.exit_code, -1);
    EXPECT_TRUE(test::contains(run.err, "input")) << run.err;
    EXPECT_EQ(test::readText(quad), before);
  }
}

// Nor any other file the run reads: a texture found beside the asset, the bindings, the shader;
// and a name that is not .png is refused (the render is PNG data whatever the name).
TEST(Cli, RenderRefusesToOverwriteAnyFileItReads) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  fs::path dir = test::scratchDir("render_inputs");
  for (const char* file : {"spot.obj", "spot_texture.png"})
    fs::copy_file(fs::path(spot).parent_path() / file, dir / file,
                  fs::copy_options::overwrite_existing);
  const std::string obj = (dir / "spot.obj").string();
  const std::string texture = (dir / "spot_texture.png").string();
  const std::string bindings = (dir / "bindings.json").string();
  std::ofstream(bindings) << "{\"attributes\": {\"normal\": 2, \"tangent\": -1}}";
  const std::string vert = (dir / "flat.vert").string(), frag = (dir / "flat.frag").string();
  fs::copy_file(test::sourcePath("shaders/constant.vert"), vert,
                fs::copy_options::overwrite_existing);
  fs::copy_file(test::sourcePath("shaders/constant.frag"), frag,
                fs::copy_options::overwrite_existing);
  const std::vector<std::string> base = {"render", obj,       "--pixels",   "16",    "--view",
                                         "0",      "--force", "--bindings", bindings};
  for (const std::string& victim : {texture, bindings, frag}) {
    const std::string before = test::readText(victim);
    std::vector<std::string> args = base;
    args.insert(args.end(), {"--vert", vert, "--frag", frag, "--out", victim});
    test::CommandRun run = runCli(args);
    EXPECT_EQ(run.exit_code, 1) << victim << ": " << run.err;
    EXPECT_TRUE(test::contains(run.err, "refusing")) << run.err;
    EXPECT_EQ(test::readText(victim), before) << victim << " was replaced";
  }
  const std::string jpg = (dir / "render.jpg").string();
  std::vector<std::string> args = base;
  args.insert(args.end(), {"--out", jpg});
  test::CommandRun run = runCli(args);
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_TRUE(test::contains(run.err, ".png")) << run.err;
  EXPECT_FALSE(fs::exists(jpg));
}

// Flag values out of range are usage errors naming the flag, before any file is read.
TEST(Cli, OutOfRangeFlagsNameTheFlag) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"render", "missing.obj", "--pixels", "32", "--fov", "-10", "--out", "x.png"}, "--fov"},
      {{"render", "missing.obj", "--pixels", "32", "--fov", "nan", "--out", "x.png"}, "--fov"},
      {{"render", "missing.obj", "--pixels", "32", "--screen-height", "0", "--out", "x.png"},
       "--screen-height"},
      {{"render", "missing.obj", "--pixels", "0", "--out", "x.png"}, "--pixels"},
      {{"render", "missing.obj", "--distance", "-1", "--out", "x.png"}, "--distance"},
      {{"render", "missing.obj", "--pixels", "32", "--view", "-1", "--out", "x.png"}, "--view"},
      {{"error", "a.obj", "b.obj", "--pixels", "32", "--q", "nan"}, "--q"},
      {{"error", "a.obj", "b.obj", "--pixels", "32", "--e-max", "-1"}, "--e-max"},
      {{"simplify", "a.obj", "b.glb", "--ratio", "0.5", "--pixels", "0"}, "--pixels"},
      {{"generate", "a.obj", "--candidates", "0", "--out", "g"}, "--candidates"},
      {{"generate", "a.obj", "--candidates", "-1", "--out", "g"}, "--candidates"},
      {{"generate", "a.obj", "--seed", "-5", "--out", "g"}, "--seed"},
      {{"generate", "a.obj", "--merge-gain", "nan", "--out", "g"}, "--merge-gain"},
      {{"generate", "a.obj", "--shader-levels", "-1", "--out", "g"}, "--shader-levels"},
      {{"shader", "a.obj", "--pixels", "32", "--population", "1", "--out", "s"}, "--population"},
      {{"render", "missing.obj", "--pixels", "32", "--fov", "abc", "--out", "x.png"}, "--fov"},
  };
  for (const auto& [args, flag] : cases) {
    test::CommandRun run = runCli(args);
    EXPECT_EQ(run.exit_code, 2) << args[1] << " " << flag << ": " << run.err;
    EXPECT_TRUE(test::contains(run.err, "duolod: error: " + flag + ":")) << run.err;
  }
  // In range: shader's --candidates 0 means every site (the parser passes it; the missing asset
  // is what fails).
  test::CommandRun every_site = runCli({"shader", "missing.obj", "--pixels", "32", "--search",
                                        "greedy", "--candidates", "0", "--out", "s"});
  EXPECT_EQ(every_site.exit_code, 1) << every_site.err;
  EXPECT_TRUE(test::contains(every_site.err, "missing.obj")) << every_site.err;
  // Contradictory generate flags, and an unknown command, are named too.
  test::CommandRun both =
      runCli({"generate", "missing.obj", "--d-near", "0.5", "--near-pixels", "100", "--out", "g"});
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_TRUE(test::contains(both.err, "--d-near or --near-pixels")) << both.err;
  test::CommandRun unknown = runCli({"bogus"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_TRUE(test::contains(unknown.err, "unknown command 'bogus'")) << unknown.err;
  // A folder where a file is expected, and two ways of naming the shader at once.
  const std::string folder = test::scratchDir("a_folder").string();
  test::CommandRun info = runCli({"info", folder});
  EXPECT_EQ(info.exit_code, 1);
  EXPECT_TRUE(test::contains(info.err, "is a folder")) << info.err;
  test::CommandRun two_shaders =
      runCli({"render", writeQuad(test::scratchDir("two_shaders")), "--pixels", "16", "--shader",
              "constant", "--vert", folder, "--frag", folder, "--out", folder + "/x.png"});
  EXPECT_EQ(two_shaders.exit_code, 1);
  EXPECT_TRUE(test::contains(two_shaders.err, "--shader or --vert")) << two_shaders.err;
  test::CommandRun empty_out = runCli({"shader", "missing.obj", "--pixels", "32", "--out", ""});
  EXPECT_EQ(empty_out.exit_code, 1) << empty_out.err;
  EXPECT_TRUE(test::contains(empty_out.err, "--out: empty path")) << empty_out.err;
}

TEST(Cli, RenderWithAShaderThatFailsToCompile) {
  fs::path dir = test::scratchDir("shader");
  std::string quad = writeQuad(dir);
  std::string frag = (dir / "broken.frag").string();
  std::ofstream(frag) << "#version 450 core\n"
                         "layout(location = 0) out vec4 outColor;\n"
                         "void main() { outColor = no_such_variable; }\n";
  std::string out = (dir / "never.png").string();
  test::CommandRun run = runCli({"render", quad, "--distance", "5", "--view", "0", "--vert",
                       test::sourcePath("shaders/constant.vert"), "--frag", frag, "--out", out});
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.exit_code, -1) << "crashed";
  EXPECT_TRUE(test::contains(run.err, "broken.frag")) << run.err;
  EXPECT_TRUE(test::contains(run.err, "no_such_variable")) << "no compile log in: " << run.err;
  EXPECT_FALSE(fs::exists(out));
}

// `error A A` compares A's 4×4-supersampled reference with a plain render of A: the difference is
// the aliasing of the plain render, finite and positive. With --supersample 1 the reference is the
// same plain render, so ε is exactly 0.
TEST(Cli, ErrorOfAnAssetAgainstItself) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  // --check: exit code 3 when outside the bound, which below d_near is 0. d_near defaults to
  // where the bottle (radius 0.14) spans 256 px, as `generate` places it: ~1.43.
  test::CommandRun run = runCli({"error", path, path, "--distance", "1", "--check"});
  ASSERT_EQ(run.exit_code, 3) << run.err;
  double epsilon = printedValue(run.out, "epsilon (eq. 6)");
  EXPECT_TRUE(std::isfinite(epsilon));
  EXPECT_GT(epsilon, 0.0);
  bool verdict = false;
  std::istringstream lines(run.out);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("within bound", 0) == 0)
      verdict = test::contains(line, " yes") || test::contains(line, " no");
  EXPECT_TRUE(verdict) << "no 'within bound yes|no' line in:\n" << run.out;
  EXPECT_TRUE(test::contains(run.out, "within bound         no")) << run.out;

  // ε = 0 is within any bound above 0 (d_near below the distance): --check exits 0.
  test::CommandRun plain = runCli(
      {"error", path, path, "--distance", "1", "--supersample", "1", "--d-near", "0.5", "--check"});
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_TRUE(test::contains(plain.out, "within bound         yes")) << plain.out;
  EXPECT_EQ(printedValue(plain.out, "epsilon (eq. 6)"), 0.0) << plain.out;
}

// A request larger than memory ends as an error (exit 1), not an abort ("terminate called ...
// std::bad_alloc", exit 134, as `error --pixels 4095` did): with the address space limited to
// 4 GB, 100 float images of 2001² pixels (6.4 GB) cannot be allocated.
TEST(Cli, OutOfMemoryIsAnError) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: no ulimit -v under it";
#else
  const std::string quad = writeQuad(test::scratchDir("cli_memory"));
  test::CommandRun run =
      test::runCommand("sh", {"-c", "ulimit -v 4000000 && exec \"$0\" \"$@\"", DUOLOD_CLI, "error",
                              quad, quad, "--pixels", "2000", "--supersample", "1"});
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_TRUE(test::contains(run.err, "duolod: error: out of memory")) << run.err;
#endif
}

// A long GPU request is explained on stderr (DUOLOD_SLOW_NOTICE_SECONDS, here 0.2 s: the 100
// references of 192 px at 4x4 take longer than that, ~1 s here); a bad value is warned about and
// the default (30 s) kept, so the same run says nothing.
TEST(Cli, LongGpuRequestsAreExplained) {
  const std::string quad = writeQuad(test::scratchDir("cli_slow_notice"));
  const std::vector<std::string> error_run = {DUOLOD_CLI, "error", quad, quad, "--pixels", "192"};
  auto withNotice = [&](const std::string& setting) {
    std::vector<std::string> args = {"DUOLOD_SLOW_NOTICE_SECONDS=" + setting};
    args.insert(args.end(), error_run.begin(), error_run.end());
    return test::runCommand("env", args);
  };
  test::CommandRun noted = withNotice("0.2");
  EXPECT_EQ(noted.exit_code, 0) << noted.err;
  EXPECT_TRUE(test::contains(noted.err, "duolod: note: one GPU request has taken")) << noted.err;
  EXPECT_TRUE(test::contains(noted.err,
                             "so far: rendering 100 references of 192 px (4x4 supersampled) with "))
      << noted.err;
  EXPECT_TRUE(test::contains(noted.err, "Still waiting (Ctrl-C stops")) << noted.err;

  test::CommandRun bad = withNotice("soon");
  EXPECT_EQ(bad.exit_code, 0) << bad.err;
  EXPECT_TRUE(test::contains(bad.err, "DUOLOD_SLOW_NOTICE_SECONDS='soon' is not a number"))
      << bad.err;
  EXPECT_FALSE(test::contains(bad.err, "duolod: note:")) << bad.err;
}

// The bound's distances default to generate's (where the object spans --near-pixels 256 and
// --far-pixels 16), not to 1 and 10 asset units, which gave a bound of 0 at every distance for
// an asset larger than a few units; --d-near and --near-pixels together are refused as generate
// refuses them.
TEST(Cli, ErrorBoundDistancesFollowGenerate) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;
  const core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  const render::Display display;
  const float d_near = render::distanceForFootprint(sphere, 256, display);
  const float d_far = render::distanceForFootprint(sphere, 16, display);
  EXPECT_EQ(render::footprintPixels(sphere, d_near, display), 256);
  EXPECT_EQ(render::footprintPixels(sphere, d_far, display), 16);
  char range[64];
  std::snprintf(range, sizeof range, "d %g..%g)", d_near, d_far);
  test::CommandRun run =
      runCli({"error", path, path, "--pixels", "24", "--supersample", "1", "--check"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(test::contains(run.out, range)) << "expected '" << range << "' in:\n" << run.out;
  EXPECT_GT(printedValue(run.out, "bound e_a(d)*s_d"), 0.0) << run.out;

  test::CommandRun custom = runCli({"error", path, path, "--pixels", "24", "--supersample", "1",
                                    "--near-pixels", "100", "--far-pixels", "10"});
  ASSERT_EQ(custom.exit_code, 0) << custom.err;
  std::snprintf(range, sizeof range, "d %g..%g)",
                render::distanceForFootprint(sphere, 100, display),
                render::distanceForFootprint(sphere, 10, display));
  EXPECT_TRUE(test::contains(custom.out, range)) << "expected '" << range << "' in:\n"
                                                 << custom.out;

  test::CommandRun both =
      runCli({"error", path, path, "--pixels", "24", "--d-near", "2", "--near-pixels", "100"});
  EXPECT_EQ(both.exit_code, 1) << both.err;
  EXPECT_TRUE(test::contains(both.err, "give --d-near or --near-pixels, not both")) << both.err;
  test::CommandRun crossed = runCli({"error", path, path, "--pixels", "24", "--d-near", "50"});
  EXPECT_EQ(crossed.exit_code, 1) << crossed.err;
  EXPECT_TRUE(test::contains(crossed.err, "from --far-pixels 16")) << crossed.err;
}

}  // namespace
}  // namespace duolod
