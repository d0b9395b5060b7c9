// The header-only runtime: its JSON reader, lod.json policies (good and bad), level selection by
// distance and by screen coverage, hysteresis against flicker, and the cross-fade weight.
#include "duolod/runtime.hpp"  // first: it must compile on its own

#include <gtest/gtest.h>

#include <array>
#include <clocale>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "test_support.hpp"

namespace duolod {
namespace {
using runtime::JsonValue;

TEST(RuntimeJson, ParsesValuesEscapesAndNesting) {
  JsonValue root;
  std::string error;
  ASSERT_TRUE(JsonValue::parse(
      R"( {"a": [1, -2.5e1, true, false, null], "s": "x\"\\\/\n\u00e9\ud83d\ude00", "o": {}} )",
      root, &error))
      << error;
  ASSERT_TRUE(root.isObject());
  const JsonValue* a = root.find("a");
  ASSERT_TRUE(a && a->isArray());
  ASSERT_EQ(a->items().size(), 5u);
  EXPECT_EQ(a->items()[0].number(), 1.0);
  EXPECT_EQ(a->items()[1].number(), -25.0);
  EXPECT_TRUE(a->items()[2].boolean());
  EXPECT_FALSE(a->items()[3].boolean());
  EXPECT_EQ(a->items()[4].kind(), JsonValue::Kind::kNull);
  EXPECT_EQ(root.find("s")->string(), "x\"\\/\n\xC3\xA9\xF0\x9F\x98\x80");
  EXPECT_TRUE(root.find("o")->isObject());
  EXPECT_EQ(root.find("missing"), nullptr);
}

TEST(RuntimeJson, RejectsMalformedInputWithAnOffset) {
  for (const char* bad : {"", "{", "[1,]", "{\"a\" 1}", "01x", "\"open", "tru", "[1] 2",
                          "{\"a\":-}", "\"\\q\"", "\"\\u12\""}) {
    JsonValue root;
    std::string error;
    EXPECT_FALSE(JsonValue::parse(bad, root, &error)) << bad;
    EXPECT_NE(error.find("offset"), std::string::npos) << bad;
  }
  std::string deep(1000, '[');
  JsonValue root;
  std::string error;
  EXPECT_FALSE(JsonValue::parse(deep, root, &error));
  EXPECT_NE(error.find("deep"), std::string::npos);
}

constexpr const char* kThreeLevels = R"({
  "format": "duolod-lod", "version": 1,
  "asset": {"name": "test"},
  "levels": [
    {"level": 0, "switch_distance": 0, "screen_coverage": 1, "triangles": 1000, "mesh": "lod0.gltf",
     "shader": {"summary": "original", "files": {"glsl450_frag": "lod0.frag"}}},
    {"level": 1, "switch_distance": 10, "screen_coverage": 0.04, "triangles": 400, "mesh": "lod1.gltf",
     "shader": {"summary": "noise moved to parameter", "files": {},
                "parameters": [{"name": "n", "location": 40, "value": [0.5, 0.25, 0.125]}]}},
    {"level": 2, "switch_distance": 20, "screen_coverage": 0.01, "triangles": 50, "mesh": "lod2.gltf"}
  ]})";

runtime::Policy threeLevels() {
  runtime::Policy policy;
  std::string error;
  EXPECT_TRUE(runtime::parsePolicy(kThreeLevels, policy, &error)) << error;
  return policy;
}

TEST(RuntimePolicy, ParsesLevels) {
  runtime::Policy policy = threeLevels();
  ASSERT_EQ(policy.levels.size(), 3u);
  EXPECT_EQ(policy.levels[1].switch_distance, 10.0);
  EXPECT_EQ(policy.levels[2].screen_coverage, 0.01);
  EXPECT_EQ(policy.levels[0].triangles, 1000u);
  EXPECT_EQ(policy.levels[2].mesh, "lod2.gltf");
  EXPECT_EQ(policy.levels[0].shader_summary, "original");
  EXPECT_EQ(policy.levels[0].shader_files.at("glsl450_frag"), "lod0.frag");
  EXPECT_TRUE(policy.levels[0].shader_parameters.empty());
  ASSERT_EQ(policy.levels[1].shader_parameters.size(), 1u);
  const runtime::Level::Parameter& parameter = policy.levels[1].shader_parameters[0];
  EXPECT_EQ(parameter.name, "n");
  EXPECT_EQ(parameter.location, 40);
  EXPECT_EQ(parameter.value, (std::vector<float>{0.5f, 0.25f, 0.125f}));
}

TEST(RuntimePolicy, BadPoliciesNameTheField) {
  struct Case {
    const char* json;
    const char* expected;
  };
  for (const Case& c : std::vector<Case>{
           {R"({"version": 1, "levels": []})", "format"},
           {R"({"format": "duolod-lod", "version": 2, "levels": []})", "version"},
           {R"({"format": "duolod-lod", "version": 1, "levels": []})", "levels"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"screen_coverage": 1}]})",
            "levels[0].switch_distance"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 2}]})",
            "levels[0].screen_coverage"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [
               {"switch_distance": 5, "screen_coverage": 1},
               {"switch_distance": 5, "screen_coverage": 0.5}]})",
            "levels[1].switch_distance"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [
               {"switch_distance": 0, "screen_coverage": 0.1},
               {"switch_distance": 5, "screen_coverage": 0.5}]})",
            "levels[1].screen_coverage"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 1, "shader": {"parameters": [{"location": 3, "value": []}]}}]})",
            "levels[0].shader.parameters"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 1, "shader": {"parameters": [{"location": 1e12, "value": [1]}]}}]})",
            "location must be a whole number"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 1, "shader": {"parameters": [{"location": 3, "value": [null]}]}}]})",
            "finite numbers"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 1, "shader": {"parameters": [{"location": 3, "value": [1e39]}]}}]})",
            "finite numbers"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 1, "triangles": 1e30}]})",
            "levels[0].triangles"},
           {R"({"format": "duolod-lod", "version": 1, "levels": [{"switch_distance": 0,
               "screen_coverage": 1, "mesh": 3}]})",
            "levels[0].mesh"},
           {R"({"format": "duolod-lod", "version": 1e999, "levels": []})", "out of range"},
           {R"({"format": )", "offset"},
       }) {
    runtime::Policy policy;
    std::string error;
    EXPECT_FALSE(runtime::parsePolicy(c.json, policy, &error)) << c.json;
    EXPECT_NE(error.find(c.expected), std::string::npos) << error;
  }
  runtime::Policy policy;
  std::string error;
  EXPECT_FALSE(runtime::loadPolicy("/nonexistent/lod.json", policy, &error));
  EXPECT_NE(error.find("/nonexistent/lod.json"), std::string::npos);
}

TEST(RuntimeJson, ParsingIntoAUsedValueReplacesIt) {
  JsonValue value;
  std::string error;
  ASSERT_TRUE(JsonValue::parse("[1, 2, 3]", value, &error)) << error;
  ASSERT_TRUE(JsonValue::parse("[4]", value, &error)) << error;
  ASSERT_EQ(value.items().size(), 1u);  // not 4: the earlier items were kept
  EXPECT_EQ(value.items()[0].number(), 4.0);
}

TEST(RuntimePolicy, MeshNamesAFileAndANode) {
  runtime::Level level;
  level.mesh = "lod.gltf#node2";  // what `duolod generate` writes
  EXPECT_EQ(level.meshFile(), "lod.gltf");
  EXPECT_EQ(level.meshNode(), 2);
  level.mesh = "lod1.gltf";
  EXPECT_EQ(level.meshFile(), "lod1.gltf");
  EXPECT_EQ(level.meshNode(), -1);
  level.mesh = "odd#nodex";
  EXPECT_EQ(level.meshNode(), -1);
  EXPECT_EQ(level.meshFile(), "odd#nodex");  // no node: the name is a file alone
}

// Numbers are read the same in any C locale: an engine that calls setlocale(LC_ALL, "") in a
// comma-decimal locale must not read "2.5" as 2 (strtod would). The locale is made with
// localedef (Debian's `locales`, which scripts/setup.sh installs) into a scratch folder.
TEST(RuntimePolicy, NumbersDoNotDependOnTheLocale) {
  const std::filesystem::path locales = test::scratchDir("runtime_locale");
  const std::string make =
      "localedef -i de_DE -f UTF-8 " + (locales / "de_DE.UTF-8").string() + " >/dev/null 2>&1";
  if (std::system(make.c_str()) != 0)
    GTEST_SKIP() << "SKIPPED: cannot make the de_DE.UTF-8 locale with localedef (Debian package "
                    "`locales`, installed by scripts/setup.sh)";
  const char* old_path = std::getenv("LOCPATH");
  const std::string kept_path = old_path ? old_path : "";
  setenv("LOCPATH", locales.c_str(), 1);
  const bool switched = std::setlocale(LC_NUMERIC, "de_DE.UTF-8") != nullptr;
  if (old_path)
    setenv("LOCPATH", kept_path.c_str(), 1);
  else
    unsetenv("LOCPATH");
  if (!switched) GTEST_SKIP() << "SKIPPED: setlocale(LC_NUMERIC, \"de_DE.UTF-8\") failed";
  // The locale is in force: the C library reads a comma there.
  const double c_library = std::strtod("2.5", nullptr);
  runtime::Policy policy;
  std::string error;
  const bool parsed = runtime::parsePolicy(kThreeLevels, policy, &error);
  JsonValue value;
  const bool number = JsonValue::parse("[0.0625, 2.5e-1]", value, &error);
  std::setlocale(LC_NUMERIC, "C");
  EXPECT_EQ(c_library, 2.0);
  ASSERT_TRUE(parsed) << error;
  EXPECT_EQ(policy.levels[1].shader_parameters[0].value[1], 0.25f);
  ASSERT_TRUE(number) << error;
  EXPECT_EQ(value.items()[0].number(), 0.0625);
  EXPECT_EQ(value.items()[1].number(), 0.25);
}

TEST(RuntimePolicy, LoadsFromAFile) {
  std::string path = test::writeScratchFile("lod.json", kThreeLevels);
  runtime::Policy policy;
  std::string error;
  ASSERT_TRUE(runtime::loadPolicy(path, policy, &error)) << error;
  EXPECT_EQ(policy.levels.size(), 3u);
}

TEST(RuntimeSelect, ByDistanceWithoutHysteresis) {
  runtime::LevelSelector selector(threeLevels(), {.hysteresis = 0, .fade_band = 0});
  EXPECT_EQ(selector.selectByDistance(0).level, 0);
  EXPECT_EQ(selector.selectByDistance(9.99).level, 0);
  EXPECT_EQ(selector.selectByDistance(10).level, 1);
  EXPECT_EQ(selector.selectByDistance(25).level, 2);  // several levels at once
  EXPECT_EQ(selector.selectByDistance(5).level, 0);   // and back
  EXPECT_EQ(selector.selectByDistance(1e9).level, 2);
  EXPECT_EQ(selector.selectByDistance(15).fade_level, -1);
}

TEST(RuntimeSelect, HysteresisStopsFlickerAtASwitchDistance) {
  runtime::LevelSelector selector(threeLevels(), {.hysteresis = 0.1});
  // Hovering around 10 (inside [9, 11]) never switches, whichever side it started on.
  int switches = 0, last = 0;
  for (int frame = 0; frame < 100; ++frame) {
    int level = selector.selectByDistance(frame % 2 ? 9.5 : 10.5).level;
    switches += level != last;
    last = level;
  }
  EXPECT_EQ(switches, 0);
  EXPECT_EQ(selector.selectByDistance(11.01).level, 1);  // past the band: switch
  EXPECT_EQ(selector.selectByDistance(9.5).level, 1);    // back inside the band: stay
  EXPECT_EQ(selector.selectByDistance(8.99).level, 0);   // below it: switch back
}

TEST(RuntimeSelect, ByScreenCoverageMatchesDistanceThresholds) {
  runtime::LevelSelector selector(threeLevels(), {.hysteresis = 0});
  EXPECT_EQ(selector.selectByScreenCoverage(0.5).level, 0);
  EXPECT_EQ(selector.selectByScreenCoverage(0.04).level, 1);
  EXPECT_EQ(selector.selectByScreenCoverage(0.02).level, 1);
  EXPECT_EQ(selector.selectByScreenCoverage(0.009).level, 2);
  EXPECT_EQ(selector.selectByScreenCoverage(0).level, 2);
  EXPECT_EQ(selector.selectByScreenCoverage(1).level, 0);
  // Hysteresis in coverage: 10% in distance is (1/1.1)^2 ≈ 0.826 in coverage.
  runtime::LevelSelector sticky(threeLevels(), {.hysteresis = 0.1});
  EXPECT_EQ(sticky.selectByScreenCoverage(0.035).level, 0);  // 0.035 > 0.04/1.21: not yet
  EXPECT_EQ(sticky.selectByScreenCoverage(0.032).level, 1);
}

TEST(RuntimeSelect, CrossFadeWeightRisesAcrossTheBand) {
  runtime::LevelSelector selector(threeLevels(), {.hysteresis = 0, .fade_band = 0.1});
  runtime::Selection at_low = selector.selectByDistance(9.0);  // band is (9, 11)
  EXPECT_EQ(at_low.fade_level, -1);
  runtime::Selection quarter = selector.selectByDistance(9.5);
  EXPECT_EQ(quarter.level, 0);
  EXPECT_EQ(quarter.fade_level, 1);
  EXPECT_NEAR(quarter.fade, 0.25f, 1e-6);
  runtime::Selection three_quarters = selector.selectByDistance(10.5);
  EXPECT_EQ(three_quarters.level, 1);
  EXPECT_EQ(three_quarters.fade_level, 0);
  EXPECT_NEAR(three_quarters.fade, 0.25f, 1e-6);  // level 0 keeps a quarter
  // The drawn level's weight and the faded one's always sum to 1, and the blend is continuous
  // across the switch (level 1's share just before 10 equals its share just after).
  runtime::Selection before = selector.selectByDistance(9.999),
                     after = selector.selectByDistance(10.001);
  EXPECT_NEAR(before.fade, 1.0f - after.fade, 3e-3);
  EXPECT_EQ(selector.selectByDistance(15).fade_level, -1);
}

// What is seen (each level's share) changes continuously with the distance, also with a
// hysteresis wider than the fade band (the header's own example), moving away and back.
TEST(RuntimeSelect, CrossFadeIsContinuousWithAWiderHysteresis) {
  for (runtime::SelectorOptions options :
       {runtime::SelectorOptions{.hysteresis = 0.1, .fade_band = 0.05},
        runtime::SelectorOptions{.hysteresis = 0.02, .fade_band = 0.1},
        runtime::SelectorOptions{.hysteresis = 0.3, .fade_band = 0.02},
        // bands that would overlap (10 · 1.5 > 20 · 0.5) and a hysteresis past the next switch
        runtime::SelectorOptions{.hysteresis = 0.3, .fade_band = 0.5},
        runtime::SelectorOptions{.hysteresis = 0.9, .fade_band = 0.05}}) {
    runtime::LevelSelector selector(threeLevels(), options);
    std::vector<double> path;
    for (int i = 0; i <= 30000; ++i) path.push_back(5 + i * 0.001);  // 5 → 35
    for (int i = 30000; i >= 0; --i) path.push_back(5 + i * 0.001);  // and back
    std::array<float, 3> previous{1, 0, 0};
    float largest_step = 0;
    for (double d : path) {
      const runtime::Selection pick = selector.selectByDistance(d);
      std::array<float, 3> seen{0, 0, 0};
      seen[size_t(pick.level)] += 1 - pick.fade;
      if (pick.fade_level >= 0) seen[size_t(pick.fade_level)] += pick.fade;
      for (size_t k = 0; k < 3; ++k)
        largest_step = std::max(largest_step, std::abs(seen[k] - previous[k]));
      previous = seen;
    }
    // A step of 0.001 moves a weight by at most 0.001 / (2 · fade_band · 10) (0.01 at 0.05).
    EXPECT_LT(largest_step, 0.03f)
        << "hysteresis " << options.hysteresis << ", fade band " << options.fade_band;
  }
}

TEST(RuntimeSelect, NanKeepsTheLevelAndOptionsAreClamped) {
  runtime::LevelSelector selector(threeLevels(), {.hysteresis = 0, .fade_band = 0});
  EXPECT_EQ(selector.selectByDistance(25).level, 2);
  EXPECT_EQ(selector.selectByDistance(NAN).level, 2);
  EXPECT_EQ(selector.selectByScreenCoverage(NAN).level, 2);
  EXPECT_EQ(selector.selectByDistance(1).level, 0);
  EXPECT_EQ(selector.selectByScreenCoverage(NAN).level, 0);
  EXPECT_EQ(selector.selectByDistance(NAN).fade_level, -1);
  // Out-of-range options (a negative band made std::clamp's bounds cross: undefined).
  runtime::LevelSelector odd(threeLevels(), {.hysteresis = -0.5, .fade_band = NAN});
  EXPECT_EQ(odd.options().hysteresis, 0.0);
  EXPECT_EQ(odd.options().fade_band, 0.0);
  EXPECT_EQ(odd.selectByDistance(15).level, 1);
  runtime::LevelSelector wide(threeLevels(), {.hysteresis = 7, .fade_band = 2});
  EXPECT_EQ(wide.options().hysteresis, 0.99);
  EXPECT_EQ(wide.options().fade_band, 0.99);
}

}  // namespace
}  // namespace duolod

namespace duolod {
namespace {
// An engine links only runtime.hpp: it must not pull in any other duolod header.
TEST(RuntimeHeader, DependsOnTheStandardLibraryOnly) {
  std::string header = test::readText(test::sourcePath("include/duolod/runtime.hpp"));
  ASSERT_FALSE(header.empty());
  EXPECT_FALSE(test::contains(header, "#include \"")) << "runtime.hpp includes a project header";
}
}  // namespace
}  // namespace duolod
