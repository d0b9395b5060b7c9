// End-to-end tests of `duolod shader`: the built binary (DUOLOD_CLI) runs a small GP and a small
// greedy search on Spot with the noise + Phong shader at a far distance; the tests check the table
// the user reads, every file written (SPIR-V, GLSL, GLSL ES, HLSL per level and for the autoLOD
// shader), summary.json, and that existing output is never overwritten without --force.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;

test::CommandRun runCli(const std::vector<std::string>& args) {
  return test::runCommand(DUOLOD_CLI, args);
}

// Spot is ~2 units across: at distance 30 it spans ~50 px on a 1080 px display, so a variant's
// renders are cheap.
std::vector<std::string> smallSearch(const std::string& asset, const std::string& out,
                                     const std::string& method) {
  std::vector<std::string> args = {"shader",   asset, "--shader", "noise_phong",
                                   "--distance", "30",  "--search", method};
  // Each search's own flags only (the other's are refused).
  const std::vector<std::string> own =
      method == "gp" ? std::vector<std::string>{"--seed", "5", "--generations", "1",
                                                "--population", "4"}
                     : std::vector<std::string>{"--steps", "2", "--candidates", "4"};
  args.insert(args.end(), own.begin(), own.end());
  args.insert(args.end(), {"--no-timing", "--out", out});
  return args;
}

void expectLevelFiles(const fs::path& dir, const std::string& name) {
  for (const char* stage : {"vert", "frag"})
    for (const char* extension : {".spv", ".glsl", ".es.glsl", ".hlsl"}) {
      fs::path file = dir / (name + "." + stage + extension);
      EXPECT_TRUE(fs::exists(file)) << file;
      EXPECT_GT(fs::file_size(file), 0u) << file;
    }
}

TEST(CliShaderTest, GeneticSearchWritesLevelsAutoLodAndSummary) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  fs::path out = test::scratchDir("cli_shader_gp") / "out";
  test::CommandRun run = runCli(smallSearch(spot, out.string(), "gp"));
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_TRUE(test::contains(run.out, "rules applied")) << run.out;
  EXPECT_TRUE(test::contains(run.out, "original")) << run.out;
  EXPECT_TRUE(test::contains(run.out, "autoLOD")) << run.out;

  nlohmann::json summary = nlohmann::json::parse(test::readText(out / "summary.json"));
  const nlohmann::json& levels = summary["levels"];
  ASSERT_GE(levels.size(), 2u);
  EXPECT_TRUE(levels[0]["rules"].empty());  // the original comes first
  for (size_t k = 0; k < levels.size(); ++k) {
    expectLevelFiles(out, levels[k]["files"].get<std::string>());
    EXPECT_GE(levels[k]["rendered_error"].get<double>(), 0.0);
    // After the original, by decreasing predicted cost (a variant on the front can cost more than
    // the original when its error is lower).
    if (k > 1) {
      EXPECT_LE(levels[k]["predicted_cost"].get<double>(), levels[k - 1]["predicted_cost"].get<double>());
    }
  }
  // The original differs from its supersampled reference by its aliasing only.
  EXPECT_LT(levels[0]["rendered_error"].get<double>(), 0.05);
  expectLevelFiles(out, "autolod");
  EXPECT_TRUE(test::contains(test::readText(out / "autolod.frag.glsl"), "autoLOD"));
  // --no-timing: no time was measured, so none is reported (0 would read as free).
  for (size_t k = 0; k < levels.size(); ++k) {
    EXPECT_TRUE(levels[k]["measured_seconds"].is_null()) << k;
    EXPECT_TRUE(levels[k]["time_ratio"].is_null()) << k;
  }
  // Every parameter the summary lists is declared under that name in each cross-compiled form:
  // GLSL ES and HLSL have no locations, so the name is how a program finds it (the autoLOD
  // shader's carry their level's suffix; SPIRV-Cross rewrites names with "__").
  size_t parameters_checked = 0;
  auto expectDeclared = [&](const nlohmann::json& parameters, const std::string& files) {
    for (const nlohmann::json& parameter : parameters) {
      const std::string name = parameter["name"].get<std::string>();
      for (const char* form : {".frag.glsl", ".frag.es.glsl", ".frag.hlsl"})
        EXPECT_TRUE(test::contains(test::readText(out / (files + form)), " " + name + ";"))
            << files << form << " does not declare " << name;
      ++parameters_checked;
    }
  };
  for (const nlohmann::json& level : levels)
    expectDeclared(level["parameters"], level["files"].get<std::string>());
  expectDeclared(summary["autolod"]["parameters"], "autolod");
  EXPECT_GE(parameters_checked, 2u) << "the search kept no level with a parameter";
  // The table's rule column is whole UTF-8 (a cut "→" was two bytes of three) and names each
  // rule once.
  EXPECT_FALSE(test::contains(run.out, "moving to parameter: moving to parameter")) << run.out;
  for (size_t i = 0; i < run.out.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(run.out[i]);
    if (c < 0x80) continue;
    const size_t length = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC0 ? 2 : 0;
    ASSERT_GT(length, 0u) << "stray continuation byte at " << i << ":\n" << run.out;
    ASSERT_LE(i + length, run.out.size()) << run.out;
    for (size_t j = 1; j < length; ++j)
      ASSERT_EQ(static_cast<unsigned char>(run.out[i + j]) & 0xC0, 0x80) << "cut at " << i;
    i += length - 1;
  }
  EXPECT_EQ(summary["autolod"]["thresholds"].size(), levels.size());
  const nlohmann::json& counters = summary["counters"];
  EXPECT_GT(counters["variants_predicted"].get<int>(), 1);
  EXPECT_EQ(counters["variants_rendered"].get<size_t>(), levels.size());

  // The same folder again: refused without --force, nothing touched; accepted with it.
  auto before = fs::last_write_time(out / "summary.json");
  test::CommandRun again = runCli(smallSearch(spot, out.string(), "gp"));
  EXPECT_NE(again.exit_code, 0);
  EXPECT_TRUE(test::contains(again.err, "--force")) << again.err;
  EXPECT_EQ(fs::last_write_time(out / "summary.json"), before);
}

// The worker that compiles the GP's coming variants on a second GL context only warms caches:
// the levels are the same with and without it, and it did compile some of them.
TEST(CliShaderTest, CompilingAheadChangesNoResult) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  fs::path dir = test::scratchDir("cli_shader_ahead");
  std::vector<std::string> ahead = smallSearch(spot, (dir / "ahead").string(), "gp");
  std::vector<std::string> inline_only = smallSearch(spot, (dir / "inline").string(), "gp");
  inline_only.push_back("--no-compile-ahead");
  for (auto* args : {&ahead, &inline_only}) {  // two generations: the worker gets two batches
    (*args)[std::find(args->begin(), args->end(), "--generations") - args->begin() + 1] = "2";
    test::CommandRun run = runCli(*args);
    ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  }
  nlohmann::json with = nlohmann::json::parse(test::readText(dir / "ahead" / "summary.json"));
  nlohmann::json without = nlohmann::json::parse(test::readText(dir / "inline" / "summary.json"));
  EXPECT_GT(with["counters"]["compiled_ahead"].get<int>(), 0);
  EXPECT_EQ(without["counters"]["compiled_ahead"].get<int>(), 0);
  EXPECT_EQ(with["counters"]["variants_predicted"], without["counters"]["variants_predicted"]);
  ASSERT_EQ(with["levels"].size(), without["levels"].size());
  for (size_t k = 0; k < with["levels"].size(); ++k)
    for (const char* field : {"rules", "predicted_cost", "predicted_error", "rendered_error"})
      EXPECT_EQ(with["levels"][k][field], without["levels"][k][field]) << k << " " << field;
}

TEST(CliShaderTest, GreedySearchRecordsItsSteps) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  fs::path out = test::scratchDir("cli_shader_greedy") / "out";
  std::vector<std::string> args = smallSearch(spot, out.string(), "greedy");
  test::CommandRun run = runCli(args);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  nlohmann::json summary = nlohmann::json::parse(test::readText(out / "summary.json"));
  const nlohmann::json& levels = summary["levels"];
  ASSERT_EQ(levels.size(), 3u);  // the original + 2 steps
  for (size_t k = 0; k < levels.size(); ++k) EXPECT_EQ(levels[k]["rules"].size(), k);
  // Again into the same folder with one step: level02's files of the first run are removed, so
  // the folder holds this result only.
  EXPECT_TRUE(fs::exists(out / "level02.frag.glsl"));
  args[std::find(args.begin(), args.end(), "--steps") - args.begin() + 1] = "1";
  args.push_back("--force");
  EXPECT_EQ(runCli(args).exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(test::readText(out / "summary.json"))["levels"].size(), 2u);
  EXPECT_TRUE(fs::exists(out / "level01.frag.glsl"));
  for (const char* extension :
       {".frag.spv", ".frag.glsl", ".frag.es.glsl", ".frag.hlsl", ".vert.spv"})
    EXPECT_FALSE(fs::exists(out / ("level02" + std::string(extension)))) << extension;
}

// An HLSL shader pair goes through the whole search and comes out as every kind of file, HLSL
// included; an entry point the file lacks is an error naming it.
TEST(CliShaderTest, HlslShadersAreSimplifiedToo) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const std::string vert = test::sourcePath("shaders/hlsl/lambert.vert.hlsl");
  const std::string frag = test::sourcePath("shaders/hlsl/lambert.frag.hlsl");
  fs::path out = test::scratchDir("cli_shader_hlsl") / "out";
  test::CommandRun run =
      runCli({"shader", spot, "--vert", vert, "--frag", frag, "--distance", "30", "--seed", "5",
              "--generations", "1", "--population", "4", "--no-timing", "--out", out.string()});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  nlohmann::json summary = nlohmann::json::parse(test::readText(out / "summary.json"));
  ASSERT_GE(summary["levels"].size(), 2u) << run.out;
  for (const nlohmann::json& level : summary["levels"])
    expectLevelFiles(out, level["files"].get<std::string>());
  // Rules describe the shader in its own names, not HLSL's plumbing or SPIR-V ids.
  EXPECT_FALSE(test::contains(run.out, "%")) << run.out;
  EXPECT_FALSE(test::contains(run.out, "entryPointOutput")) << run.out;

  test::CommandRun missing =
      runCli({"shader", spot, "--vert", vert, "--frag", frag, "--frag-entry", "PSMain",
              "--distance", "30", "--out", (out.parent_path() / "other").string()});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_TRUE(test::contains(missing.err, "lambert.frag.hlsl")) << missing.err;
  EXPECT_TRUE(test::contains(missing.err, "PSMain")) << missing.err;
  EXPECT_TRUE(test::contains(missing.err, "--frag-entry")) << missing.err;
}

TEST(CliShaderTest, BadFlagsAreClearErrors) {
  test::CommandRun no_distance = runCli({"shader", "missing.obj", "--out", "x"});
  EXPECT_NE(no_distance.exit_code, 0);
  EXPECT_TRUE(test::contains(no_distance.err, "--distance")) << no_distance.err;
  test::CommandRun bad_method =
      runCli({"shader", "missing.obj", "--distance", "3", "--search", "annealing", "--out", "x"});
  EXPECT_NE(bad_method.exit_code, 0);
  test::CommandRun missing = runCli({"shader", "missing.obj", "--distance", "3", "--out",
                                     (test::scratchDir("cli_shader_bad") / "out").string()});
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_TRUE(test::contains(missing.err, "missing.obj")) << missing.err;
  // A flag of the other search was ignored; now it is an error.
  test::CommandRun other_search = runCli({"shader", "missing.obj", "--distance", "3", "--steps",
                                          "5", "--out",
                                          (test::scratchDir("cli_shader_bad") / "out").string()});
  EXPECT_NE(other_search.exit_code, 0);
  EXPECT_TRUE(test::contains(other_search.err, "--steps applies to --search greedy only"))
      << other_search.err;
  // An entry point for a GLSL pair (always main()) was ignored; now it is an error.
  test::CommandRun glsl_entry =
      runCli({"shader", "missing.obj", "--distance", "3", "--shader", "pbr", "--vert-entry", "VS",
              "--out", (test::scratchDir("cli_shader_bad") / "out").string()});
  EXPECT_NE(glsl_entry.exit_code, 0);
  EXPECT_TRUE(
      test::contains(glsl_entry.err, "--vert-entry names the entry point of an HLSL --vert"))
      << glsl_entry.err;
}

TEST(CliShaderTest, RefusesToWriteIntoTheAssetsFolderEvenWithForce) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  fs::path asset_dir = fs::path(spot).parent_path();
  auto files_before = std::distance(fs::directory_iterator(asset_dir), fs::directory_iterator());
  test::CommandRun run = runCli({"shader", spot, "--shader", "noise_phong", "--distance", "30",
                                 "--force", "--out", asset_dir.string()});
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(test::contains(run.err, "folder of the input")) << run.err;
  EXPECT_EQ(std::distance(fs::directory_iterator(asset_dir), fs::directory_iterator()), files_before);
}

}  // namespace
}  // namespace duolod
