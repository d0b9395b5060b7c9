// LOD export: lod.json (written by io, read back by the header-only runtime) and the glTF LOD chain
// (MSFT_lod + MSFT_screencoverage) of a real asset, checked by the Khronos glTF-Validator; a
// corrupted chain must fail that validation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "duolod/io.hpp"
#include "duolod/mesh.hpp"
#include "duolod/runtime.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

io::LodJsonDocument threeLevelDocument() {
  io::LodJsonDocument document;
  document.asset_name = "WaterBottle";
  document.asset_source = "WaterBottle.gltf";
  document.bounds = {{0, 0.1f, 0}, 0.15f};
  document.d_near = 0.5;
  document.d_far = 5;
  document.q = 0.5;
  document.e_max = 0.1;
  document.time_tolerance = 0.05;
  document.merge_min_gain = 0.04;
  document.views = "upright";
  document.optimizer = "separate";
  document.cost_source = "measured";
  document.cost_unit = "ms";
  for (int i = 0; i < 3; ++i) {
    io::LodJsonLevel level;
    level.level = i;
    level.distance = 0.5 + 2 * i;
    level.switch_distance = i == 0 ? 0 : level.distance;
    level.screen_coverage = i == 0 ? 1.0 : 0.1 / (i * i);
    level.triangles = 4000 / (i + 1);
    level.vertices = 2100 / (i + 1);
    level.mesh_file = "lod" + std::to_string(i) + ".gltf";
    level.shader_summary = i == 0 ? "GGX with 4 textures" : "Lambert, base colour texture only";
    level.shader_files = {{"glsl450_frag", "lod" + std::to_string(i) + ".frag"}};
    level.error = 0.5 * i;
    level.error_bound = 1.0 * i;
    if (i < 2) level.transition_error = 0.25;
    level.measured_cost = 3.0 - i;
    document.levels.push_back(level);
  }
  return document;
}

TEST(LodJson, RuntimeReadsWhatIoWrites) {
  io::LodJsonDocument document = threeLevelDocument();
  fs::path dir = test::scratchDir("lod_json");
  std::string path = (dir / "lod.json").string();
  ASSERT_TRUE(io::writeLodJson(document, path).ok());

  runtime::Policy policy;
  std::string error;
  ASSERT_TRUE(runtime::loadPolicy(path, policy, &error)) << error;
  ASSERT_EQ(policy.levels.size(), 3u);
  EXPECT_EQ(policy.levels[1].switch_distance, 2.5);
  EXPECT_EQ(policy.levels[2].screen_coverage, 0.025);
  EXPECT_EQ(policy.levels[1].triangles, 2000u);
  EXPECT_EQ(policy.levels[2].mesh, "lod2.gltf");
  EXPECT_EQ(policy.levels[1].shader_summary, "Lambert, base colour texture only");
  EXPECT_EQ(policy.levels[0].shader_files.at("glsl450_frag"), "lod0.frag");
  runtime::LevelSelector selector(policy, {.hysteresis = 0});
  EXPECT_EQ(selector.selectByDistance(3.0).level, 1);

  // Everything else is there for tools: errors, absent values as null, the configuration.
  json root = json::parse(test::readText(path));
  EXPECT_EQ(root["levels"][2]["error"]["transition"], nullptr);
  EXPECT_EQ(root["levels"][0]["error"]["transition"], 0.25);
  EXPECT_EQ(root["levels"][0]["cost"]["predicted"], nullptr);
  EXPECT_EQ(root["levels"][0]["cost"]["measured"], 3.0);
  EXPECT_EQ(root["bound"]["merge_min_gain"], 0.04);
  EXPECT_EQ(root["bound"]["views"], "upright");
  EXPECT_EQ(root["display"]["height_px"], 1080);
  EXPECT_EQ(root["cost"]["source"], "measured");
  // Deterministic: the same document gives the same bytes.
  EXPECT_EQ(io::lodJsonText(document), test::readText(path));
}

TEST(LodJson, InconsistentLevelsAreRejected) {
  fs::path dir = test::scratchDir("lod_json_bad");
  io::LodJsonDocument document = threeLevelDocument();
  document.levels[2].switch_distance = 1.0;  // below level 1's
  auto written = io::writeLodJson(document, (dir / "lod.json").string());
  ASSERT_FALSE(written.ok());
  EXPECT_TRUE(test::contains(written.error().message, "levels[2].switch_distance"));
  EXPECT_FALSE(fs::exists(dir / "lod.json"));
  document = threeLevelDocument();
  document.levels[1].screen_coverage = 2;
  EXPECT_FALSE(io::writeLodJson(document, (dir / "lod.json").string()).ok());
  document.levels.clear();
  EXPECT_FALSE(io::writeLodJson(document, (dir / "lod.json").string()).ok());
  // Parameters the runtime would refuse on reading are refused on writing.
  for (const io::LodJsonLevel::Parameter& bad :
       {io::LodJsonLevel::Parameter{"none", 40, {}},
        io::LodJsonLevel::Parameter{"five", 40, {1, 2, 3, 4, 5}},
        io::LodJsonLevel::Parameter{"nan", 40, {std::nanf("")}},
        io::LodJsonLevel::Parameter{"far", 70000, {1}}}) {
    document = threeLevelDocument();
    document.levels[1].shader_parameters = {bad};
    auto refused = io::writeLodJson(document, (dir / "lod.json").string());
    ASSERT_FALSE(refused.ok()) << bad.name;
    EXPECT_TRUE(test::contains(refused.error().message, "levels[1].shader: parameter '" + bad.name))
        << refused.error().message;
  }
  EXPECT_FALSE(fs::exists(dir / "lod.json"));
}

// ---- glTF LOD chain ----

// Runs scripts/validate-gltf.js; skips the test loudly when node or the npm package is missing.
#define DUOLOD_REQUIRE_GLTF_VALIDATOR()                                                          \
  if (std::system("command -v node > /dev/null 2>&1") != 0)                                      \
    GTEST_SKIP() << "SKIPPED: `node` not found; the Khronos glTF-Validator needs Node.js";         \
  if (!validatorPackagePresent())                                                                \
    GTEST_SKIP() << "SKIPPED: npm package gltf-validator missing under " << DUOLOD_SOURCE_DIR     \
                 << "/.tools (run scripts/setup.sh)";

bool validatorPackagePresent() {
  if (const char* tools = std::getenv("DUOLOD_NODE_TOOLS"))
    if (fs::exists(fs::path(tools) / "node_modules/gltf-validator/package.json")) return true;
  return fs::exists(test::sourcePath(".tools/node_modules/gltf-validator/package.json"));
}

struct Validation {
  int exit_code = -1;
  json report;
};
Validation validate(const std::string& file) {
  test::CommandRun run = test::runCommand("node", {test::sourcePath("scripts/validate-gltf.js"), file});
  Validation result{run.exit_code, json::parse(run.out, nullptr, false)};
  return result;
}

core::ImageRGBA8 shrunk(const core::ImageRGBA8& image, int side) {
  if (image.width <= side && image.height <= side) return image;
  core::ImageRGBA8 small{side, side, std::vector<uint8_t>(size_t(side) * side * 4)};
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x)
      for (int c = 0; c < 4; ++c)
        small.pixels[(size_t(y) * side + x) * 4 + c] =
            image.pixels[(size_t(y * image.height / side) * image.width + x * image.width / side) * 4 + c];
  return small;
}

struct Chain {
  core::Asset asset;
  std::vector<core::Mesh> levels;
};
Chain waterBottleChain(const std::string& path) {
  Chain chain;
  auto asset = io::loadAsset(path);
  EXPECT_TRUE(asset.ok()) << asset.error().message;
  if (!asset.ok()) return chain;
  chain.asset = std::move(asset.value());
  // The bottle's four 2048² textures take seconds to re-encode as PNG and to validate; the chain is
  // about meshes and shared materials, so the test keeps them as 64² nearest-neighbour copies.
  for (core::Texture& texture : chain.asset.textures) texture.image = shrunk(texture.image, 64);
  chain.levels.push_back(chain.asset.mesh);
  for (double ratio : {0.5, 0.1}) {
    mesh::SimplifyOptions options;
    options.target_triangles = static_cast<size_t>(ratio * chain.asset.mesh.triangleCount());
    options.record = false;
    chain.levels.push_back(mesh::simplifyQuadric(chain.asset.mesh, options).mesh);
  }
  return chain;
}

TEST(GltfLodChain, WaterBottleThreeLevelsValidateWithZeroErrors) {
  DUOLOD_REQUIRE_ASSET(source, "gltf/WaterBottle/WaterBottle.gltf");
  DUOLOD_REQUIRE_GLTF_VALIDATOR();
  Chain chain = waterBottleChain(source);
  ASSERT_EQ(chain.levels.size(), 3u);
  EXPECT_LT(chain.levels[2].triangleCount(), chain.levels[1].triangleCount());
  const std::vector<double> coverage = {0.2, 0.05, 0.0};
  fs::path dir = test::scratchDir("gltf_lod_chain");

  for (const char* name : {"bottle_lod.gltf", "bottle_lod.glb"}) {
    std::string out = (dir / name).string();
    auto written = io::writeGltfLodChain(chain.asset, chain.levels, coverage, out);
    ASSERT_TRUE(written.ok()) << written.error().message;
    Validation validation = validate(out);
    ASSERT_FALSE(validation.report.is_discarded()) << name << ": validator printed no JSON";
    EXPECT_EQ(validation.report["issues"]["numErrors"], 0) << validation.report.dump(1);
    EXPECT_EQ(validation.exit_code, 0) << name;
    // The validator saw all three levels, drawing with the asset's materials and textures.
    size_t triangles = 0;
    for (const core::Mesh& level : chain.levels) triangles += level.triangleCount();
    EXPECT_EQ(validation.report["info"]["drawCallCount"], 3) << name;
    EXPECT_EQ(validation.report["info"]["totalTriangleCount"], triangles) << name;
    EXPECT_EQ(validation.report["info"]["materialCount"], chain.asset.materials.size()) << name;
    EXPECT_EQ(validation.report["info"]["resources"].size(), 1 + chain.asset.textures.size())
        << name;
  }

  // The chain's structure (MSFT_lod spec): node 0 lists levels 1, 2; coverage per level; only
  // node 0 in the scene; textures written once.
  json document = json::parse(test::readText(dir / "bottle_lod.gltf"));
  EXPECT_EQ(document["extensionsUsed"], json({"MSFT_lod"}));
  EXPECT_EQ(document["nodes"][0]["extensions"]["MSFT_lod"]["ids"], json({1, 2}));
  EXPECT_EQ(document["nodes"][0]["extras"]["MSFT_screencoverage"], json(coverage));
  EXPECT_EQ(document["scenes"][0]["nodes"], json({0}));
  EXPECT_EQ(document["meshes"].size(), 3u);
  EXPECT_EQ(document["images"].size(), chain.asset.textures.size());
  EXPECT_EQ(document["meshes"][0]["primitives"][0]["material"],
            document["meshes"][2]["primitives"][0]["material"]);
}

// A level that changes only the shader repeats the previous level's mesh: its node shares that
// glTF mesh, whose buffers are stored once, and reading the node gives the same triangles.
TEST(GltfLodChain, LevelsWithEqualMeshesShareOneGltfMesh) {
  DUOLOD_REQUIRE_ASSET(source, "gltf/WaterBottle/WaterBottle.gltf");
  DUOLOD_REQUIRE_GLTF_VALIDATOR();
  Chain chain = waterBottleChain(source);
  ASSERT_EQ(chain.levels.size(), 3u);
  const std::vector<core::Mesh> distinct = chain.levels;
  const std::vector<core::Mesh> repeated = {chain.levels[0], chain.levels[1], chain.levels[1],
                                            chain.levels[2]};
  fs::path dir = test::scratchDir("gltf_lod_chain_shared");
  const std::string distinct_path = (dir / "distinct.glb").string();
  const std::string repeated_path = (dir / "repeated.glb").string();
  ASSERT_TRUE(io::writeGltfLodChain(chain.asset, distinct, {{0.2, 0.05, 0.0}}, distinct_path).ok());
  auto written =
      io::writeGltfLodChain(chain.asset, repeated, {{0.2, 0.1, 0.05, 0.0}}, repeated_path);
  ASSERT_TRUE(written.ok()) << written.error().message;
  // One more node costs a few bytes of JSON, not a second copy of level 1's buffers.
  EXPECT_LT(fs::file_size(repeated_path), fs::file_size(distinct_path) + 200);

  Validation validation = validate(repeated_path);
  ASSERT_FALSE(validation.report.is_discarded());
  EXPECT_EQ(validation.report["issues"]["numErrors"], 0) << validation.report.dump(1);

  const std::string gltf_path = (dir / "repeated.gltf").string();
  ASSERT_TRUE(
      io::writeGltfLodChain(chain.asset, repeated, {{0.2, 0.1, 0.05, 0.0}}, gltf_path).ok());
  json document = json::parse(test::readText(gltf_path));
  EXPECT_EQ(document["meshes"].size(), 3u);
  EXPECT_EQ(document["nodes"].size(), 4u);
  EXPECT_EQ(document["nodes"][1]["mesh"], 1);
  EXPECT_EQ(document["nodes"][2]["mesh"], 1);
  EXPECT_EQ(document["nodes"][3]["mesh"], 2);
  EXPECT_EQ(document["nodes"][0]["extensions"]["MSFT_lod"]["ids"], json({1, 2, 3}));
  for (int node = 1; node <= 3; ++node) {
    io::LoadOptions options;
    options.gltf_node = node;
    options.weld = false;
    options.generate_normals = options.generate_tangents = false;
    auto level = io::loadAsset(gltf_path, options);
    ASSERT_TRUE(level.ok()) << level.error().message;
    EXPECT_EQ(level.value().mesh.triangleCount(), repeated[size_t(node)].triangleCount()) << node;
    EXPECT_EQ(level.value().mesh.vertexCount(), repeated[size_t(node)].vertexCount()) << node;
  }
}

TEST(GltfLodChain, CorruptedChainFailsValidation) {
  DUOLOD_REQUIRE_ASSET(source, "gltf/WaterBottle/WaterBottle.gltf");
  DUOLOD_REQUIRE_GLTF_VALIDATOR();
  Chain chain = waterBottleChain(source);
  fs::path dir = test::scratchDir("gltf_lod_chain_corrupt");
  std::string out = (dir / "bottle_lod.gltf").string();
  ASSERT_TRUE(io::writeGltfLodChain(chain.asset, chain.levels, {{0.2, 0.05, 0.0}}, out).ok());
  // Level 2's index accessor now claims more indices than its buffer view holds, and level 1's
  // node points at a mesh that does not exist.
  json document = json::parse(test::readText(out));
  int indices = document["meshes"][2]["primitives"][0]["indices"];
  document["accessors"][indices]["count"] = document["accessors"][indices]["count"].get<int>() * 4;
  document["nodes"][1]["mesh"] = 7;
  ASSERT_TRUE(io::writeFileAtomic(out, document.dump(2)).ok());
  Validation validation = validate(out);
  ASSERT_FALSE(validation.report.is_discarded());
  EXPECT_GE(validation.report["issues"]["numErrors"].get<int>(), 2);
  EXPECT_EQ(validation.exit_code, 1);
}

TEST(GltfLodChain, BadCoverageIsRejected) {
  core::Asset asset;
  asset.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  asset.mesh.indices = {0, 1, 2};
  asset.mesh.submeshes = {{0, 3, 0}};
  std::vector<core::Mesh> levels = {asset.mesh, asset.mesh};
  fs::path dir = test::scratchDir("gltf_lod_chain_bad");
  std::string out = (dir / "chain.gltf").string();
  auto count = io::writeGltfLodChain(asset, levels, {{0.5}}, out);
  ASSERT_FALSE(count.ok());
  EXPECT_TRUE(test::contains(count.error().message, "2 levels need as many"));
  EXPECT_FALSE(io::writeGltfLodChain(asset, levels, {{0.1, 0.5}}, out).ok());  // increasing
  EXPECT_FALSE(io::writeGltfLodChain(asset, levels, {{1.5, 0.5}}, out).ok());  // not a fraction
  EXPECT_TRUE(io::writeGltfLodChain(asset, levels, {{0.5, 0.0}}, out).ok());
}

}  // namespace
}  // namespace duolod
