#include "test_support.hpp"

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iterator>

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

std::string readText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<uint8_t> readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const std::filesystem::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::string readShader(const std::string& file) {
  return readText(sourcePath("shaders/" + file));
}

io::LoadOptions noTextures() {
  io::LoadOptions options;
  options.load_textures = false;
  return options;
}

core::Asset readOk(AssetReader reader, const std::string& path, const io::LoadOptions& options) {
  auto asset = reader(path, options);
  EXPECT_TRUE(asset.ok()) << (asset.ok() ? "" : asset.error().message);
  if (!asset.ok()) return {};
  EXPECT_TRUE(core::validateMesh(asset->mesh).ok());
  return std::move(asset).value();
}

bool hasWarningContaining(const core::Asset& asset, const std::string& fragment) {
  for (const std::string& warning : asset.warnings)
    if (warning.find(fragment) != std::string::npos) return true;
  return false;
}

namespace {
std::string shellQuoted(const std::string& argument) {
  std::string out = "'";
  for (char c : argument) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}
}  // namespace

CommandRun runCommand(const std::string& binary, const std::vector<std::string>& args) {
  std::filesystem::path dir = scratchDir("command_run");
  std::string command = shellQuoted(binary);
  for (const std::string& arg : args) command += " " + shellQuoted(arg);
  command += " > " + shellQuoted((dir / "stdout").string()) + " 2> " +
             shellQuoted((dir / "stderr").string());
  int status = std::system(command.c_str());
  CommandRun run;
  if (status != -1 && WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
  run.out = readText(dir / "stdout");
  run.err = readText(dir / "stderr");
  return run;
}

CommandRun runCli(const std::vector<std::string>& args) {
  return runCommand(DUOLOD_CLI, args);
}

render::Renderer* createRenderer(std::string& failure) {
  auto created = render::Renderer::create();
  if (!created) {
    failure = created.error().message;
    return nullptr;
  }
  return std::move(created.value()).release();
}

}  // namespace duolod::test
