// End-to-end tests of `duolod shader`: the built binary (DUOLOD_CLI) runs a small GP and a small
// greedy search on Spot with the noise + Phong shader at a far distance; the tests check the table
// the user reads, every file written (SPIR-V, GLSL, GLSL ES, HLSL per level and for the autoLOD
// shader), summary.json, and that existing output is never overwritten without --force.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;

using test::runCli;

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
  EXPECT_TRUE(test::contains(run.err, "duolod: generation 1 of 1: ")) << run.err;  // progress

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

// The workers that compile the coming variants (the GP's offspring, the greedy step's candidates)
// on other GL contexts only warm caches: the levels are the same with and without them, and they
// did compile some of them.
TEST(CliShaderTest, CompilingAheadChangesNoResult) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  for (std::string method : {"gp", "greedy"}) {
    SCOPED_TRACE(method);
    fs::path dir = test::scratchDir("cli_shader_ahead_" + method);
    std::vector<std::string> ahead = smallSearch(spot, (dir / "ahead").string(), method);
    std::vector<std::string> inline_only = smallSearch(spot, (dir / "inline").string(), method);
    inline_only.push_back("--no-compile-ahead");
    for (auto* args : {&ahead, &inline_only}) {
      if (method == "gp")  // two generations: the workers get two batches (greedy: two steps)
        (*args)[std::find(args->begin(), args->end(), "--generations") - args->begin() + 1] = "2";
      test::CommandRun run = runCli(*args);
      ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
    }
    nlohmann::json with = nlohmann::json::parse(test::readText(dir / "ahead" / "summary.json"));
    nlohmann::json without = nlohmann::json::parse(test::readText(dir / "inline" / "summary.json"));
    EXPECT_GT(with["timing_dependent"]["compiled_ahead"].get<int>(), 0);
    EXPECT_EQ(without["timing_dependent"]["compiled_ahead"].get<int>(), 0);
    EXPECT_EQ(with["counters"]["variants_predicted"], without["counters"]["variants_predicted"]);
    ASSERT_EQ(with["levels"].size(), without["levels"].size());
    for (size_t k = 0; k < with["levels"].size(); ++k)
      for (const char* field : {"rules", "predicted_cost", "predicted_error", "rendered_error"})
        EXPECT_EQ(with["levels"][k][field], without["levels"][k][field]) << k << " " << field;
  }
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
  // Each step is reported as it ends (a step scores many variants: tens of seconds on llvmpipe).
  EXPECT_TRUE(test::contains(run.err, "duolod: step 1 of at most 2: ")) << run.err;
  EXPECT_TRUE(test::contains(run.err, "duolod: step 2 of at most 2: ")) << run.err;
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

// A search pays each variant's compile, so when the original's first draw is slow the note about
// it says what the search will compile and which flags compile fewer. The slow compile: thirteen
// loops whose trip counts are not constants (the first draw takes about a second on llvmpipe here,
// with Mesa's shader cache off so that it is not skipped on a second run). Twelve took 0.5-0.7 s:
// too close to the 0.3 s notice, which the monitor checks every 0.25 s, and the test failed under
// load now and then.
TEST(CliShaderTest, ASlowCompileSaysWhatTheSearchWillCompile) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const fs::path dir = test::scratchDir("cli_shader_slow_compile");
  std::string frag = test::readText(test::sourcePath("shaders/constant.frag"));
  std::string loops = "  float c = uBaseColorFactor.r;\n";
  for (int k = 1; k <= 13; ++k) {
    const std::string n = std::to_string(k);
    loops += "  for (int i = 0; i < int(uMaterialParams.x * " + n +
             ".0 + 2.0); ++i) c = fract(c * 1." + n + " + 0." + n + ");\n";
  }
  const std::string body = "  outColor = vec4(uBaseColorFactor.rgb, 1.0);";
  ASSERT_NE(frag.find(body), std::string::npos);
  frag.replace(frag.find(body), body.size(),
               loops + "  outColor = vec4(uBaseColorFactor.rgb * c, 1.0);");
  const fs::path slow = dir / "slow.frag";
  std::ofstream(slow) << frag;
  test::CommandRun run = test::runCommand("env", {"MESA_SHADER_CACHE_DISABLE=true",
                                                  "DUOLOD_SLOW_NOTICE_SECONDS=0.3",
                                                  DUOLOD_CLI,
                                                  "shader",
                                                  spot,
                                                  "--vert",
                                                  test::sourcePath("shaders/constant.vert"),
                                                  "--frag",
                                                  slow.string(),
                                                  "--distance",
                                                  "30",
                                                  "--search",
                                                  "greedy",
                                                  "--steps",
                                                  "1",
                                                  "--candidates",
                                                  "1",
                                                  "--no-timing",
                                                  "--out",
                                                  (dir / "out").string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(test::contains(run.err, "It holds the program's first draw")) << run.err;
  EXPECT_TRUE(test::contains(run.err,
                             "The search compiles a program for each variant it "
                             "renders, most of them about as slowly: fewer --steps and "
                             "--candidates compile fewer."))
      << run.err;
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
  EXPECT_TRUE(test::contains(
      glsl_entry.err,
      "--vert-entry names the entry point of an HLSL (.hlsl) or SPIR-V (.spv) --vert"))
      << glsl_entry.err;
}

// A Lambert pair reading the normal at location 4 and uv0 at 1 (not INTERFACE.md's 1 and 3), and
// the bindings file that says so.
constexpr const char* kMovedVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 4) in vec3 inNormal;
layout(location = 1) in vec2 inUV0;
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) out vec3 vWorldPos;
layout(location = 1) out vec3 vNormal;
layout(location = 2) out vec2 vUV;
void main() {
  vec4 w = uModel * vec4(inPosition, 1.0);
  vWorldPos = w.xyz;
  vNormal = mat3(uNormalMatrix) * inNormal;
  vUV = inUV0;
  gl_Position = uProjection * (uView * w);
}
)";
constexpr const char* kLambertFragment = R"(#version 450 core
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(std140, binding = 1) uniform Material {
  vec4 uBaseColorFactor; vec4 uEmissiveFactor; vec4 uMaterialParams; vec4 uTextureFlags; vec4 uTextureFlags2;
};
layout(binding = 0) uniform sampler2D uBaseColorTexture;
layout(location = 0) in vec3 vWorldPos;
layout(location = 1) in vec3 vNormal;
layout(location = 2) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 n = normalize(vNormal);
  vec3 l = normalize(uLightPosition.xyz - vWorldPos);
  vec3 albedo = uBaseColorFactor.rgb * texture(uBaseColorTexture, vUV).rgb;
  vec3 lit = albedo * (uAmbientColor.rgb + uLightColor.rgb * max(dot(n, l), 0.0));
  outColor = vec4(pow(clamp(lit, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);
}
)";

double originalError(const fs::path& out) {
  nlohmann::json summary = nlohmann::json::parse(test::readText(out / "summary.json"));
  return summary["levels"][0]["rendered_error"].get<double>();
}

// --bindings reaches the search's renderers: the original's error is the one `error` measures
// with the same bindings. Before, `shader` and `generate` checked the file and then drew with
// INTERFACE.md's locations (the normal read from the uv0 stream): 0.0038 instead of 0.0246.
// A bindings file inside --out (which this run would write over) is refused, --force or not.
TEST(CliShaderTest, BindingsReachTheSearch) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const fs::path dir = test::scratchDir("cli_shader_bindings");
  const std::string vert = (dir / "moved.vert").string(), frag = (dir / "lambert.frag").string();
  const std::string bindings = (dir / "moved.json").string();
  std::ofstream(vert) << kMovedVertex;
  std::ofstream(frag) << kLambertFragment;
  std::ofstream(bindings) << R"({"attributes": {"normal": 4, "uv0": 1}})";
  const std::vector<std::string> cheap = {
      "--pixels", "64", "--search", "greedy", "--steps", "2", "--candidates", "4", "--no-timing"};
  auto search = [&](const std::string& out, bool bound) {
    std::vector<std::string> args = {"shader", spot, "--vert", vert, "--frag", frag};
    args.insert(args.end(), cheap.begin(), cheap.end());
    if (bound) args.insert(args.end(), {"--bindings", bindings});
    args.insert(args.end(), {"--out", (dir / out).string()});
    return runCli(args);
  };
  test::CommandRun with = search("with", true), without = search("without", false);
  ASSERT_EQ(with.exit_code, 0) << with.err;
  ASSERT_EQ(without.exit_code, 0) << without.err;
  test::CommandRun measured = runCli({"error", spot, spot, "--vert", vert, "--frag", frag,
                                      "--pixels", "64", "--bindings", bindings});
  ASSERT_EQ(measured.exit_code, 0) << measured.err;
  const std::string label = "per-pixel error";
  const size_t at = measured.out.find(label);
  ASSERT_NE(at, std::string::npos) << measured.out;
  const double expected = std::stod(measured.out.substr(at + label.size()));
  EXPECT_NEAR(originalError(dir / "with"), expected, 1e-4 * expected);
  EXPECT_GT(std::abs(originalError(dir / "without") - expected), 0.1 * expected)
      << "the bindings change nothing here: the test shows nothing";
  // The HLSL files' vertex inputs carry the semantics of the streams the bindings put at their
  // locations (an engine binds by semantic); they were TEXCOORD<location> whatever the bindings.
  const std::string with_hlsl = test::readText(dir / "with" / "level00.vert.hlsl");
  EXPECT_TRUE(test::contains(with_hlsl, "inPosition : POSITION0;")) << with_hlsl;
  EXPECT_TRUE(test::contains(with_hlsl, "inNormal : NORMAL0;")) << with_hlsl;
  EXPECT_TRUE(test::contains(with_hlsl, "inUV0 : TEXCOORD0;")) << with_hlsl;
  const std::string without_hlsl = test::readText(dir / "without" / "level00.vert.hlsl");
  EXPECT_TRUE(test::contains(without_hlsl, "inNormal : TEXCOORD1;")) << without_hlsl;  // 4: uv1
  EXPECT_TRUE(test::contains(without_hlsl, "inUV0 : NORMAL0;")) << without_hlsl;       // 1: normal

  const fs::path out = dir / "into";
  fs::create_directories(out);
  const std::string inside = (out / "summary.json").string();
  std::ofstream(inside) << R"({"attributes": {"normal": 4, "uv0": 1}})";
  std::vector<std::string> args = {"shader", spot, "--vert", vert, "--frag", frag};
  args.insert(args.end(), cheap.begin(), cheap.end());
  args.insert(args.end(), {"--bindings", inside, "--force", "--out", out.string()});
  test::CommandRun refused = runCli(args);
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_TRUE(test::contains(refused.err, "is the folder of the input " + inside)) << refused.err;
  EXPECT_EQ(test::readText(inside), R"({"attributes": {"normal": 4, "uv0": 1}})");
}

// Compiled shaders (.spv, for OpenGL or Vulkan) are taken as their GLSL (SPIRV-Cross): the
// error is the GLSL pair's, `shader` simplifies them; a module of the other stage, a file that is
// not SPIR-V and a truncated one are errors naming the file.
TEST(CliShaderTest, SpirvFilesAreTakenAsTheirGlsl) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const fs::path dir = test::scratchDir("cli_shader_spirv");
  auto write = [&](const std::string& file, const std::vector<uint32_t>& words) {
    std::ofstream(dir / file, std::ios::binary)
        .write(reinterpret_cast<const char*>(words.data()),
               static_cast<std::streamsize>(words.size() * 4));
    return (dir / file).string();
  };
  auto source = render::loadShaderPair("noise_phong");
  ASSERT_TRUE(source.ok()) << source.error().message;
  auto vertex = shader::compileToSpirv(source->vertex, shader::Stage::kVertex, "np.vert");
  auto fragment = shader::compileToSpirv(source->fragment, shader::Stage::kFragment, "np.frag");
  ASSERT_TRUE(vertex.ok() && fragment.ok());
  const std::string vert = write("np.vert.spv", *vertex), frag = write("np.frag.spv", *fragment);

  auto errorOf = [&](const std::vector<std::string>& shading) {
    std::vector<std::string> args = {"error", spot, spot, "--pixels", "32"};
    args.insert(args.end(), shading.begin(), shading.end());
    test::CommandRun run = runCli(args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    const size_t at = run.out.find("per-pixel error");
    return at == std::string::npos ? -1.0 : std::stod(run.out.substr(at + 15));
  };
  const double glsl = errorOf({"--shader", "noise_phong"});
  EXPECT_GT(glsl, 0);
  EXPECT_EQ(errorOf({"--vert", vert, "--frag", frag}), glsl);
  EXPECT_EQ(errorOf({"--vert", vert, "--frag", frag, "--frag-entry", "main"}), glsl);

  test::CommandRun simplified = runCli({"shader", spot, "--vert", vert, "--frag", frag, "--pixels",
                                        "48", "--search", "greedy", "--steps", "1", "--candidates",
                                        "2", "--no-timing", "--out", (dir / "out").string()});
  EXPECT_EQ(simplified.exit_code, 0) << simplified.err;
  EXPECT_TRUE(fs::exists(dir / "out" / "level01.frag.spv"));

  const std::vector<std::pair<std::vector<std::string>, std::string>> refused = {
      {{"--vert", frag, "--frag", frag},
       "np.frag.spv: holds no vertex entry point (it holds fragment 'main')"},
      {{"--vert", vert, "--frag", frag, "--frag-entry", "shade"},
       "np.frag.spv: holds no fragment entry point 'shade' (it holds fragment 'main')"},
      {{"--vert", write("junk.spv", {0x6f6d2023u, 0x6c6f2075u, 0x0a21u, 1u, 2u}), "--frag", frag},
       "junk.spv: not a SPIR-V module"},
      {{"--vert", write("cut.spv", std::vector<uint32_t>(vertex->begin(), vertex->begin() + 100)),
        "--frag", frag},
       "cut.spv: invalid SPIR-V"}};
  for (const auto& [shading, message] : refused) {
    std::vector<std::string> args = {"error", spot, spot, "--pixels", "32"};
    args.insert(args.end(), shading.begin(), shading.end());
    test::CommandRun run = runCli(args);
    EXPECT_EQ(run.exit_code, 1) << message;
    EXPECT_TRUE(test::contains(run.err, message)) << run.err;
  }
  std::ofstream(dir / "odd.spv", std::ios::binary) << "abcdefg";
  test::CommandRun odd = runCli({"error", spot, spot, "--pixels", "32", "--vert",
                                 (dir / "odd.spv").string(), "--frag", frag});
  EXPECT_EQ(odd.exit_code, 1);
  EXPECT_TRUE(test::contains(odd.err, "odd.spv: not a SPIR-V module (7 bytes")) << odd.err;
}

// SPIR-V compiled for Vulkan by glslangValidator: separate textures and samplers become one
// sampler2D bound as the texture; a push-constant block becomes a uniform block at binding 32
// (reading zeros, with a warning); HLSL compiled to SPIR-V is legalized as the HLSL path is.
// They failed with "Cannot find mapping for combined sampler" and "non-opaque uniform variables
// need a layout(location=L)".
TEST(CliShaderTest, VulkanSpirvFilesAreTaken) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const std::string validator = "/usr/bin/glslangValidator";
  if (!fs::exists(validator))
    GTEST_SKIP() << "SKIPPED: " << validator
                 << " is missing (Debian glslang-tools; scripts/setup.sh installs it)";
  const fs::path dir = test::scratchDir("cli_shader_vulkan_spirv");
  std::ofstream(dir / "vk.vert") << R"(#version 450
layout(location = 0) in vec3 inPosition;
layout(location = 3) in vec2 inUV0;
layout(set = 0, binding = 0, std140) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) out vec2 vUV;
void main() {
  vUV = inUV0;
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";
  std::ofstream(dir / "vk.frag") << R"(#version 450
layout(location = 0) in vec2 vUV;
layout(set = 1, binding = 0) uniform texture2D uBaseColorTexture;
layout(set = 1, binding = 5) uniform sampler uLinear;
layout(push_constant) uniform Tint { vec4 tint; } pc;
layout(location = 0) out vec4 outColor;
void main() {
  outColor = vec4(texture(sampler2D(uBaseColorTexture, uLinear), vUV).rgb + pc.tint.rgb, 1.0);
}
)";
  for (const char* stage : {"vert", "frag"}) {
    test::CommandRun compiled = test::runCommand(
        validator, {"-V", "-o", (dir / (std::string("vk.") + stage + ".spv")).string(),
                    (dir / (std::string("vk.") + stage)).string()});
    ASSERT_EQ(compiled.exit_code, 0) << compiled.out << compiled.err;
  }
  test::CommandRun run =
      runCli({"error", spot, spot, "--pixels", "32", "--vert", (dir / "vk.vert.spv").string(),
              "--frag", (dir / "vk.frag.spv").string()});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(
      test::contains(run.err, "uniform block 'Tint' at binding 32 is neither Frame nor Material"))
      << run.err;
  EXPECT_FALSE(test::contains(run.err, "uBaseColorTexture")) << run.err;  // bound: no warning

  for (const char* stage : {"vert", "frag"}) {
    const std::string source =
        test::sourcePath(std::string("shaders/hlsl/lambert.") + stage + ".hlsl");
    test::CommandRun compiled = test::runCommand(
        validator, {"-D", "-V", "-e", "main", "-S", stage, "-o",
                    (dir / (std::string("lambert.") + stage + ".spv")).string(), source});
    ASSERT_EQ(compiled.exit_code, 0) << compiled.out << compiled.err;
  }
  test::CommandRun hlsl =
      runCli({"error", spot, spot, "--pixels", "32", "--vert", (dir / "lambert.vert.spv").string(),
              "--frag", (dir / "lambert.frag.spv").string()});
  EXPECT_EQ(hlsl.exit_code, 0) << hlsl.err;
}

// Vulkan's usual layout, set 0 per frame and set 1 per material both from binding 0, cannot be
// taken as it is: OpenGL has no sets, so Material would read Frame's data. Refused with both
// blocks named, within one module and across the vertex and fragment modules; distinct bindings
// across the sets are taken. It was taken silently, and rendered with the wrong data.
TEST(CliShaderTest, SpirvDescriptorSetsThatMeetInOneOpenGlBindingAreRefused) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const std::string validator = "/usr/bin/glslangValidator";
  if (!fs::exists(validator))
    GTEST_SKIP() << "SKIPPED: " << validator
                 << " is missing (Debian glslang-tools; scripts/setup.sh installs it)";
  const fs::path dir = test::scratchDir("cli_shader_descriptor_sets");
  const std::string frame = R"(uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
)";
  const std::string material = R"(uniform Material {
  vec4 uBaseColorFactor; vec4 uEmissiveFactor; vec4 uMaterialParams; vec4 uTextureFlags;
  vec4 uTextureFlags2;
};
)";
  std::ofstream(dir / "frame.vert") << "#version 450\nlayout(location = 0) in vec3 inPosition;\n"
                                    << "layout(set = 0, binding = 0, std140) " << frame << R"(
void main() { gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0))); }
)";
  auto fragment = [&](const std::string& name, const std::string& blocks) {
    std::ofstream(dir / name) << "#version 450\n"
                              << blocks << R"(layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(uBaseColorFactor.rgb, 1.0); }
)";
  };
  fragment("both.frag", "layout(set = 0, binding = 0, std140) " + frame +
                            "layout(set = 1, binding = 0, std140) " + material);
  fragment("material.frag", "layout(set = 1, binding = 0, std140) " + material);
  fragment("distinct.frag", "layout(set = 1, binding = 1, std140) " + material);
  for (const char* name : {"frame.vert", "both.frag", "material.frag", "distinct.frag"}) {
    test::CommandRun compiled = test::runCommand(
        validator,
        {"-V", "-o", (dir / (std::string(name) + ".spv")).string(), (dir / name).string()});
    ASSERT_EQ(compiled.exit_code, 0) << name << compiled.out << compiled.err;
  }
  auto run = [&](const char* fragment_name) {
    return runCli({"error", spot, spot, "--pixels", "16", "--supersample", "1", "--vert",
                   (dir / "frame.vert.spv").string(), "--frag",
                   (dir / (std::string(fragment_name) + ".spv")).string()});
  };
  test::CommandRun both = run("both.frag");
  EXPECT_EQ(both.exit_code, 1) << both.err;
  EXPECT_TRUE(test::contains(both.err,
                             "both.frag.spv: uniform blocks 'Material' (set 1) and "
                             "'Frame' (set 0) both take binding 0"))
      << both.err;
  test::CommandRun across = run("material.frag");
  EXPECT_EQ(across.exit_code, 1) << across.err;
  EXPECT_TRUE(test::contains(across.err, "frame.vert.spv: uniform blocks 'Frame' (set 0) and " +
                                             (dir / "material.frag.spv").string() +
                                             "'s 'Material' (set 1) both take binding 0"))
      << across.err;
  test::CommandRun distinct = run("distinct.frag");
  EXPECT_EQ(distinct.exit_code, 0) << distinct.err;
}

// A UTF-8 byte-order mark (Visual Studio saves HLSL with one) is not a token: the files compile
// as without it. It was "'<bad token>' : unexpected token" at line 1.
TEST(CliShaderTest, AByteOrderMarkIsNotAToken) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const fs::path dir = test::scratchDir("cli_shader_bom");
  const std::string vert = test::sourcePath("shaders/hlsl/lambert.vert.hlsl");
  const std::string frag = (dir / "lambert.frag.hlsl").string();
  const std::string glsl = (dir / "lambert.frag").string();
  std::ofstream(frag) << "\xEF\xBB\xBF"
                      << test::readText(test::sourcePath("shaders/hlsl/lambert.frag.hlsl"));
  std::ofstream(glsl) << "\xEF\xBB\xBF" << kLambertFragment;
  test::CommandRun hlsl = runCli({"error", spot, spot, "--vert", vert, "--frag", frag, "--pixels",
                                  "32", "--supersample", "1"});
  EXPECT_EQ(hlsl.exit_code, 0) << hlsl.err;
  const std::string moved_vert = (dir / "moved.vert").string();
  std::ofstream(moved_vert) << "\xEF\xBB\xBF" << kMovedVertex;
  std::ofstream(dir / "moved.json") << R"({"attributes": {"normal": 4, "uv0": 1}})";
  test::CommandRun run = runCli({"render", spot, "--vert", moved_vert, "--frag", glsl, "--bindings",
                                 (dir / "moved.json").string(), "--pixels", "32", "--view", "0",
                                 "--force", "--out", (dir / "r.png").string()});
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

// A fragment stage whose alpha is 0 (here an `out vec3`: alpha undefined, 0 on llvmpipe) gave a
// covered pixel count of 0, every variant an error of 0, and black levels with exit code 0. It is
// refused before anything is drawn, saying why (so is one that writes no colour at all).
TEST(CliShaderTest, AShaderWithoutAlphaIsRefused) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const fs::path dir = test::scratchDir("cli_shader_alpha");
  std::string fragment = kLambertFragment;
  const std::string vec4_out = "out vec4 outColor;";
  fragment.replace(fragment.find(vec4_out), vec4_out.size(), "out vec3 outColor;");
  const std::string write = "outColor = vec4(pow(clamp(lit, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);";
  fragment.replace(fragment.find(write), write.size(),
                   "outColor = pow(clamp(lit, 0.0, 1.0), vec3(1.0 / 2.2));");
  const std::string frag = (dir / "vec3.frag").string(), vert = (dir / "plain.vert").string();
  std::ofstream(frag) << fragment;
  std::string vertex = kMovedVertex;  // at INTERFACE.md's locations
  vertex.replace(vertex.find("location = 4) in vec3 inNormal"), 13, "location = 1)");
  vertex.replace(vertex.find("location = 1) in vec2 inUV0"), 13, "location = 3)");
  std::ofstream(vert) << vertex;
  test::CommandRun run = runCli({"shader", spot, "--vert", vert, "--frag", frag, "--pixels", "64",
                                 "--search", "greedy", "--steps", "2", "--candidates", "4",
                                 "--no-timing", "--out", (dir / "out").string()});
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_TRUE(test::contains(run.err,
                             "vec3.frag: its colour output 'outColor' at location 0 is "
                             "a vec3, which leaves alpha undefined"))
      << run.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  const std::string silent = (dir / "silent.frag").string();
  std::ofstream(silent) << "#version 450\nvoid main() {}\n";
  // The same refusal from the commands that draw one shader pair (here with no colour at all).
  run = runCli({"error", spot, spot, "--vert", vert, "--frag", silent, "--pixels", "32"});
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_TRUE(test::contains(run.err, "silent.frag: writes no colour output at location 0"))
      << run.err;
  run = runCli({"render", spot, "--vert", vert, "--frag", silent, "--pixels", "32", "--out",
                (dir / "silent.png").string()});
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_TRUE(test::contains(run.err, "silent.frag: writes no colour output at location 0"))
      << run.err;
  EXPECT_FALSE(fs::exists(dir / "silent.png"));
}

// GLSL 450 that GLSL ES 3.0 cannot express (bitCount) is simplified as any other: its levels are
// written without the .es.glsl translation, with a warning naming the file and the reason. The
// run failed after the whole search, naming a file it had generated.
TEST(CliShaderTest, ATranslationTheShaderIsBeyondIsLeftOutWithAWarning) {
  DUOLOD_REQUIRE_ASSET(spot, "obj/spot/spot.obj");
  const fs::path dir = test::scratchDir("cli_shader_es");
  std::string fragment = kLambertFragment;
  const std::string lit = "  outColor = vec4(";
  fragment.insert(fragment.find(lit),
                  "  lit *= 1.0 + 0.001 * float(bitCount(uint(gl_FragCoord.x)));\n");
  std::string vertex = kMovedVertex;  // at INTERFACE.md's locations
  vertex.replace(vertex.find("location = 4) in vec3 inNormal"), 13, "location = 1)");
  vertex.replace(vertex.find("location = 1) in vec2 inUV0"), 13, "location = 3)");
  const std::string frag = (dir / "bits.frag").string(), vert = (dir / "plain.vert").string();
  std::ofstream(frag) << fragment;
  std::ofstream(vert) << vertex;
  const fs::path out = dir / "out";
  test::CommandRun run =
      runCli({"shader", spot, "--vert", vert, "--frag", frag, "--pixels", "64", "--search",
              "greedy", "--steps", "2", "--candidates", "4", "--no-timing", "--out", out.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(test::contains(run.err,
                             "duolod: warning: level00.frag.es.glsl not written: GLSL ES 300 "
                             "cannot express this shader (line "))
      << run.err;
  EXPECT_TRUE(test::contains(run.err, "'bitCount'")) << run.err;
  EXPECT_FALSE(fs::exists(out / "level00.frag.es.glsl"));
  for (const char* file : {"level00.frag.glsl", "level00.frag.hlsl", "level00.frag.spv",
                           "level00.vert.es.glsl", "autolod.frag.glsl"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
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
