// Shared helpers for duolod tests: where the real assets are, scratch folders, loud skips.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "duolod/io.hpp"
#include "duolod/render.hpp"

namespace duolod::test {

// Path of an asset under ../shared/assets, or "" when it is missing.
std::string sharedAsset(const std::string& relative_path);
// Path of a file in the source tree (e.g. "shaders/pbr.frag").
std::string sourcePath(const std::string& relative_path);
// A fresh, empty folder for this test (under the build tree), removed at the start of each run.
std::filesystem::path scratchDir(const std::string& name);
// Writes text/bytes into a scratch file and returns its path.
std::string writeScratchFile(const std::string& name, const std::string& contents);

// Runs `binary ARGS...` with stdout and stderr captured through scratch files.
struct CommandRun {
  int exit_code = -1;  // -1: did not exit normally (e.g. killed by a signal)
  std::string out, err;
};
CommandRun runCommand(const std::string& binary, const std::vector<std::string>& args);
// Runs the built `duolod` binary (DUOLOD_CLI) with ARGS.
CommandRun runCli(const std::vector<std::string>& args);
std::string readText(const std::filesystem::path& path);
std::vector<uint8_t> readBytes(const std::filesystem::path& path);
void writeBytes(const std::filesystem::path& path, const std::vector<uint8_t>& bytes);
// The source of a reference shader (shaders/FILE).
std::string readShader(const std::string& file);
// Load options that leave textures unread, for tests of geometry.
io::LoadOptions noTextures();
// Reads PATH with one of io's readers (io::readObj, readPly, readOff: no post-processing),
// expecting success and a valid mesh; an empty asset after a failed expectation.
using AssetReader = core::Result<core::Asset> (*)(const std::string&, const io::LoadOptions&);
core::Asset readOk(AssetReader reader, const std::string& path,
                   const io::LoadOptions& options = {});
bool hasWarningContaining(const core::Asset& asset, const std::string& fragment);

// The renderer's per-frame block (shaders/INTERFACE.md), for hand-written test shaders.
inline constexpr const char* kFrameBlock = R"(
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
)";
// A renderer for a test suite's SetUpTestSuite (the caller owns it), or nullptr with the reason in
// `failure` when there is no OpenGL 4.5 context.
render::Renderer* createRenderer(std::string& failure);

inline bool contains(const std::string& text, const std::string& fragment) {
  return text.find(fragment) != std::string::npos;
}

}  // namespace duolod::test

// Skips the current test loudly when a shared asset is absent. CI installs/keeps them, so a skip is
// visible in the ctest output rather than a silent pass.
#define DUOLOD_REQUIRE_ASSET(var, relative)                                                    \
  std::string var = ::duolod::test::sharedAsset(relative);                                    \
  if (var.empty()) {                                                                          \
    GTEST_SKIP() << "SKIPPED: shared asset '" << (relative) << "' not found under "           \
                 << DUOLOD_ASSET_DIR << " (the test needs the ../shared/assets checkout)";    \
  }
