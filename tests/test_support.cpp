#include "test_support.hpp"

#include <fstream>

namespace duolod::test {

std::string sharedAsset(const std::string& relative_path) {
  std::filesystem::path path = std::filesystem::path(DUOLOD_ASSET_DIR) / relative_path;
  return std::filesystem::exists(path) ? path.lexically_normal().string() : std::string();
}

std::string sourcePath(const std::string& relative_path) {
  return (std::filesystem::path(DUOLOD_SOURCE_DIR) / relative_path).string();
}

std::filesystem::path scratchDir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string test_name = info ? std::string(info->test_suite_name()) + "." + info->name() : "none";
  std::filesystem::path dir = std::filesystem::current_path() / "scratch" / test_name / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string writeScratchFile(const std::string& name, const std::string& contents) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string test_name = info ? std::string(info->test_suite_name()) + "." + info->name() : "none";
  std::filesystem::path dir = std::filesystem::current_path() / "scratch" / test_name / "files";
  std::filesystem::create_directories(dir);
  std::filesystem::path path = dir / name;
  std::ofstream(path, std::ios::binary) << contents;
  return path.string();
}

}  // namespace duolod::test
