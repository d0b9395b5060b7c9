// report.html: well-formed, self-contained (no external references), every section present and fed
// from the real search / path functions; and, where Debian's chromium is installed, a headless
// screenshot shows a rendered page.
#include <gtest/gtest.h>

#include <cctype>
#include <cstdlib>
#include <set>

#include "duolod/io.hpp"
#include "duolod/lod.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;

core::ImageRGBA8 gradient(int side) {
  core::ImageRGBA8 image{side, side, std::vector<uint8_t>(size_t(side) * side * 4)};
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      uint8_t* p = &image.pixels[(size_t(y) * side + x) * 4];
      p[0] = uint8_t(x * 255 / side), p[1] = uint8_t(y * 255 / side), p[2] = 128, p[3] = 255;
    }
  return image;
}

lod::ReportData sampleReport() {
  lod::ReportData data;
  data.title = "duolod report: <Test> & co";
  data.facts = {{"asset", "WaterBottle.gltf"}, {"display", "45 deg, 1080 px"}};
  for (int i = 0; i < 3; ++i)
    data.levels.push_back({.index = i,
                           .distance = 1.0 + 2 * i,
                           .screen_coverage = 0.3 / (1 + i * i),
                           .triangles = size_t(4000 >> i),
                           .shader_summary = i ? "Lambert per vertex" : "GGX, 4 textures",
                           .error = 0.1 * i,
                           .error_bound = 0.2 * i,
                           .transition_error = 0.05,
                           .predicted_cost = 3.0 - i,
                           .measured_cost = 3.1 - i,
                           .images = {{"level", gradient(16)}, {"reference", gradient(16)}}});
  data.plots.push_back(
      {.title = "error against distance",
       .x_label = "distance",
       .y_label = "error",
       .series = {{"bound", {1, 3, 5}, {0, 0.2, 0.4}}, {"measured", {1, 3, 5}, {0, 0.1, 0.2}}}});
  data.plots.push_back(
      {.title = "cost",
       .x_label = "distance",
       .y_label = "ms",
       .series = {{"no LOD", {1, 3, 5}, {3, 3, 3}}, {"joint", {1, 3, 5}, {3, 2, 1}}}});
  // A real Algorithm 2 walk on a 6 × 4 table (error m + 2s, bound 5).
  std::vector<int> order = {0, 1, 2, 3};
  lod::PairEvaluator table = [](int mesh, int shader) -> core::Result<lod::PairEvaluation> {
    return lod::PairEvaluation{mesh + 2.0 * shader, 50.0 - mesh - 3.0 * shader};
  };
  auto walk = lod::searchPairs(6, order, table, {.error_bound = 5.0});
  EXPECT_TRUE(walk.ok());
  data.searches.push_back(
      {.title = "level 1", .mesh_count = 6, .shader_count = 4, .result = *walk});
  // A real Algorithm 3 path over three small pair sets.
  lod::ReportTransitions transitions;
  transitions.level_pairs = {
      {walk->optimal[0]}, walk->visited, {walk->visited[0], walk->visited[1]}};
  lod::TransitionEvaluator transition = [](int, const lod::EvaluatedPair& a,
                                           const lod::EvaluatedPair& b) -> core::Result<double> {
    return std::abs(a.mesh - b.mesh) + 0.5 * std::abs(a.shader - b.shader);
  };
  auto path = lod::smoothestPath(transitions.level_pairs, transition);
  EXPECT_TRUE(path.ok());
  transitions.path = *path;
  data.transitions = transitions;
  return data;
}

// Every non-void element is closed in order; returns "" or the first problem. (A hand-written
// scan: <regex> draws false -Wmaybe-uninitialized warnings from GCC 12 under the sanitizers.)
std::string checkNesting(const std::string& html) {
  static const std::set<std::string> kVoid = {"meta", "img",   "br",      "hr",
                                              "link", "input", "!DOCTYPE"};
  std::vector<std::string> open;
  for (size_t at = html.find('<'); at != std::string::npos; at = html.find('<', at + 1)) {
    size_t end = html.find('>', at);
    if (end == std::string::npos) return "unterminated tag at " + std::to_string(at);
    bool closing = html[at + 1] == '/';
    size_t name_start = at + 1 + closing, name_end = name_start;
    while (name_end < end &&
           (std::isalnum(static_cast<unsigned char>(html[name_end])) || html[name_end] == '!'))
      ++name_end;
    std::string name = html.substr(name_start, name_end - name_start);
    if (name.empty()) return "a bare '<' at " + std::to_string(at);
    if (kVoid.count(name) || html[end - 1] == '/') continue;
    if (closing) {
      if (open.empty() || open.back() != name)
        return "</" + name + "> closes <" + (open.empty() ? "nothing" : open.back()) + ">";
      open.pop_back();
    } else {
      open.push_back(name);
    }
  }
  return open.empty() ? "" : "<" + open.back() + "> never closed";
}

size_t count(const std::string& text, const std::string& fragment) {
  size_t n = 0;
  for (size_t at = text.find(fragment); at != std::string::npos; at = text.find(fragment, at + 1))
    ++n;
  return n;
}

TEST(LodReport, WellFormedSelfContainedWithEverySection) {
  lod::ReportData data = sampleReport();
  std::string html = lod::renderReportHtml(data);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(checkNesting(html), "");
  for (const char* section : {"id=\"facts\"", "id=\"levels\"", "id=\"level-0\"", "id=\"level-2\"",
                              "id=\"plots\"", "id=\"search\"", "id=\"transitions\""})
    EXPECT_TRUE(test::contains(html, section)) << section;
  // Text is escaped (the title has markup characters).
  EXPECT_TRUE(test::contains(html, "duolod report: &lt;Test&gt; &amp; co"));
  EXPECT_FALSE(test::contains(html, "<Test>"));
  // Self-contained: images are data URIs, nothing is fetched.
  EXPECT_EQ(count(html, "src=\"data:image/png;base64,iVBORw0KGgo"), 6u);  // PNG signature
  EXPECT_FALSE(test::contains(html, "http://") &&
               !test::contains(html, "xmlns=\"http://www.w3.org/2000/svg\""));
  for (const char* external : {"src=\"http", "src=\"//", "src=\"file:", "href=", "url("})
    EXPECT_FALSE(test::contains(html, external)) << external;
  EXPECT_FALSE(test::contains(html, "<script"));
  // Plots: one polyline per series; the search grid: a cell per evaluation and the optimal set.
  EXPECT_EQ(count(html, "class=\"series\""), 4u);
  const lod::PairSearchResult& walk = data.searches[0].result;
  EXPECT_EQ(count(html, "class=\"pair-in\"") + count(html, "class=\"pair-out\""),
            walk.visited.size());
  EXPECT_EQ(count(html, "class=\"pair-optimal\""), walk.optimal.size());
  EXPECT_TRUE(test::contains(html, std::to_string(walk.evaluations) + " evaluations of 24"));
  // The graph: every edge drawn, exactly the path's edges highlighted, one chosen node per level.
  const lod::SmoothPath& path = data.transitions->path;
  EXPECT_EQ(count(html, "class=\"edge\"") + count(html, "class=\"edge-chosen\""),
            path.edges.size());
  EXPECT_EQ(count(html, "class=\"edge-chosen\""), 2u);
  EXPECT_EQ(count(html, "class=\"node-chosen\""), 3u);
  // Deterministic.
  EXPECT_EQ(html, lod::renderReportHtml(data));
}

TEST(LodReport, EmptyPartsAreLeftOut) {
  lod::ReportData data;
  data.title = "empty";
  std::string html = lod::renderReportHtml(data);
  EXPECT_EQ(checkNesting(html), "");
  EXPECT_FALSE(test::contains(html, "id=\"levels\""));
  EXPECT_FALSE(test::contains(html, "<svg"));
}

TEST(LodReport, HeadlessChromiumRendersIt) {
  const char* browser = nullptr;
  for (const char* candidate : {"chromium", "chromium-browser", "google-chrome"})
    if (std::system(("command -v " + std::string(candidate) + " > /dev/null 2>&1").c_str()) == 0) {
      browser = candidate;
      break;
    }
  if (!browser) GTEST_SKIP() << "SKIPPED: no chromium (apt-get install chromium; scripts/setup.sh)";
  fs::path dir = test::scratchDir("report_chromium");
  std::string report = (dir / "report.html").string(), shot = (dir / "shot.png").string();
  ASSERT_TRUE(lod::writeReport(sampleReport(), report).ok());
  test::CommandRun run = test::runCommand(
      browser, {"--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                "--user-data-dir=" + (dir / "profile").string(), "--window-size=1000,1400",
                "--screenshot=" + shot, "file://" + report});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto image = io::readImage(shot);
  ASSERT_TRUE(image.ok()) << "no screenshot: " << run.err;
  EXPECT_EQ(image->width, 1000);
  EXPECT_EQ(image->height, 1400);
  // Something was drawn: the page has dark text and coloured plot/graph pixels, not just white.
  size_t dark = 0, coloured = 0;
  for (size_t i = 0; i < image->pixels.size(); i += 4) {
    int r = image->pixels[i], g = image->pixels[i + 1], b = image->pixels[i + 2];
    dark += r + g + b < 200;
    coloured += std::max({r, g, b}) - std::min({r, g, b}) > 60;
  }
  EXPECT_GT(dark, 2000u);
  EXPECT_GT(coloured, 500u);
}

}  // namespace
}  // namespace duolod
