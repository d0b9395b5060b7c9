// `cmake --install` and find_package(duolod): an engine's own CMake project, configured against
// the installed prefix alone, builds and runs a program that loads, simplifies and writes a mesh
// through the public headers, and finds the installed shaders.
#include <gtest/gtest.h>

#include <fstream>

#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;

const char* kConsumerCMake = R"(cmake_minimum_required(VERSION 3.25)
project(engine LANGUAGES CXX)
set(CMAKE_CXX_STANDARD 20)
find_package(duolod 0.1 CONFIG REQUIRED)
add_executable(engine engine.cpp)
target_link_libraries(engine PRIVATE duolod::duolod)
target_compile_definitions(engine PRIVATE INSTALLED_SHADERS="${DUOLOD_SHADER_DIR}")
)";

const char* kConsumerSource = R"(#include <cstdio>
#include <filesystem>
#include <duolod/io.hpp>
#include <duolod/mesh.hpp>
#include <duolod/runtime.hpp>
int main(int argc, char** argv) {
  if (argc != 3) return 2;
  auto asset = duolod::io::loadAsset(argv[1]);
  if (!asset) { std::fprintf(stderr, "%s\n", asset.error().message.c_str()); return 1; }
  duolod::mesh::SimplifyOptions options;
  options.target_triangles = asset->mesh.triangleCount() / 4;
  duolod::core::Asset simplified = *asset;
  simplified.mesh = duolod::mesh::simplifyQuadric(asset->mesh, options).mesh;
  if (auto written = duolod::io::writeObj(simplified, argv[2]); !written) {
    std::fprintf(stderr, "%s\n", written.error().message.c_str());
    return 1;
  }
  const bool shaders = std::filesystem::exists(std::filesystem::path(INSTALLED_SHADERS) / "pbr.frag");
  std::printf("triangles %zu -> %zu, installed shaders %s\n", asset->mesh.triangleCount(),
              simplified.mesh.triangleCount(), shaders ? "found" : "missing");
  return 0;
}
)";

// A 16 × 16 grid of quads, bent so that it is not planar.
std::string gridObj() {
  std::string text;
  for (int y = 0; y <= 16; ++y)
    for (int x = 0; x <= 16; ++x)
      text += "v " + std::to_string(x) + " " + std::to_string(y) + " " +
              std::to_string((x - 8) * (x - 8) * 0.05) + "\n";
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const int a = y * 17 + x + 1, b = a + 1, c = a + 17, d = c + 1;
      text += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + "\n";
      text += "f " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + "\n";
    }
  return text;
}

TEST(Install, FindPackageBuildsAnEngineProgram) {
  const fs::path dir = test::scratchDir("install");
  const fs::path prefix = dir / "prefix";
  test::CommandRun install = test::runCommand(
      CMAKE_COMMAND, {"--install", DUOLOD_BINARY_DIR, "--prefix", prefix.string()});
  ASSERT_EQ(install.exit_code, 0) << install.out << install.err;
  EXPECT_TRUE(fs::exists(prefix / "include/duolod/runtime.hpp"));
  EXPECT_TRUE(fs::exists(prefix / "lib/cmake/duolod/duolodConfig.cmake"));
  EXPECT_TRUE(fs::exists(prefix / "share/duolod/shaders/pbr.vert"));
  EXPECT_TRUE(fs::exists(prefix / "bin/duolod"));

  const fs::path source = dir / "engine";
  fs::create_directories(source);
  std::ofstream(source / "CMakeLists.txt") << kConsumerCMake;
  std::ofstream(source / "engine.cpp") << kConsumerSource;
  // Only the installed prefix: not the build tree, which the library's own targets live in.
  std::vector<std::string> configure = {"-S",
                                        source.string(),
                                        "-B",
                                        (source / "build").string(),
                                        "-DCMAKE_PREFIX_PATH=" + prefix.string(),
                                        "-DCMAKE_BUILD_TYPE=Release"};
#ifdef DUOLOD_TEST_SANITIZE  // the installed library is instrumented: so must the program be
  configure.push_back("-DCMAKE_CXX_FLAGS=-fsanitize=address,undefined");
#endif
  test::CommandRun configured = test::runCommand(CMAKE_COMMAND, configure);
  ASSERT_EQ(configured.exit_code, 0) << configured.out << configured.err;
  test::CommandRun built =
      test::runCommand(CMAKE_COMMAND, {"--build", (source / "build").string()});
  ASSERT_EQ(built.exit_code, 0) << built.out << built.err;

  std::ofstream(dir / "grid.obj") << gridObj();
  test::CommandRun run =
      test::runCommand((source / "build" / "engine").string(),
                       {(dir / "grid.obj").string(), (dir / "out.obj").string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // A quarter of the triangles, or one fewer (a collapse inside the grid removes two).
  EXPECT_TRUE(run.out == "triangles 512 -> 128, installed shaders found\n" ||
              run.out == "triangles 512 -> 127, installed shaders found\n")
      << run.out;
  EXPECT_TRUE(fs::exists(dir / "out.obj"));

  // The installed tool reads the shaders installed beside it, not the source tree's (which exists
  // here): with its copy of pbr.frag gone, --shader pbr fails naming the prefix's path.
  fs::remove(prefix / "share/duolod/shaders/pbr.frag");
  test::CommandRun rendered = test::runCommand(
      (prefix / "bin/duolod").string(), {"render", (dir / "grid.obj").string(), "--shader", "pbr",
                                         "--pixels", "8", "--out", (dir / "grid.png").string()});
  EXPECT_NE(rendered.exit_code, 0);
  EXPECT_TRUE(test::contains(rendered.err, (prefix / "share/duolod/shaders/pbr.frag").string() +
                                               ": shader file not found"))
      << rendered.err;
  EXPECT_TRUE(test::contains(rendered.err, "DUOLOD_SHADER_DIR")) << rendered.err;
  EXPECT_FALSE(fs::exists(dir / "grid.png"));
}

}  // namespace
}  // namespace duolod
