// report.html: one self-contained page (inline CSS and SVG, images as PNG data URIs, no script, no
// network) showing what the LOD generator decided, in the order of Liang et al., "Automatic Mesh
// and Shader Level of Detail": the levels (§3.1), error and cost against distance (eq. 3/4), the 2D
// search path of Algorithm 2 (the paper's Fig. 2) and the transition graph of Algorithm 3 with the
// chosen path (§6.1).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "duolod/io.hpp"
#include "duolod/lod.hpp"

namespace duolod::lod {
namespace {

std::string escaped(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out.push_back(c);
    }
  }
  return out;
}

// Fixed notation with a few significant digits, locale-independent (std::snprintf with "%g" uses
// the C locale's '.', which duolod never changes).
std::string number(double value, int digits = 4) {
  if (!std::isfinite(value)) return value > 0 ? "inf" : (value < 0 ? "-inf" : "n/a");
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}
std::string px(double value) {
  return number(value, 6);
}

std::string base64(std::span<const uint8_t> bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t chunk = uint32_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) chunk |= uint32_t(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) chunk |= bytes[i + 2];
    out.push_back(kAlphabet[(chunk >> 18) & 63]);
    out.push_back(kAlphabet[(chunk >> 12) & 63]);
    out.push_back(i + 1 < bytes.size() ? kAlphabet[(chunk >> 6) & 63] : '=');
    out.push_back(i + 2 < bytes.size() ? kAlphabet[chunk & 63] : '=');
  }
  return out;
}

// A qualitative palette (distinct under common colour-vision deficiencies).
constexpr const char* kSeriesColours[] = {"#0072b2", "#d55e00", "#009e73", "#cc79a7",
                                          "#e69f00", "#56b4e9", "#000000"};

constexpr const char* kStyle = R"(
body { font-family: system-ui, sans-serif; margin: 24px; color: #222; max-width: 1200px; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 4px; margin-top: 2em; }
table { border-collapse: collapse; margin: 8px 0; }
td, th { border: 1px solid #ddd; padding: 3px 8px; text-align: right; }
th { background: #f4f4f4; } td.text, th.text { text-align: left; }
.level { border: 1px solid #ddd; border-radius: 6px; padding: 8px 12px; margin: 12px 0; }
figure { display: inline-block; margin: 4px 8px 4px 0; text-align: center; }
figure img { image-rendering: pixelated; border: 1px solid #ccc; max-width: 256px; }
figcaption { font-size: 0.85em; color: #555; }
svg { background: #fff; border: 1px solid #eee; margin: 6px 0; }
svg text { font-family: system-ui, sans-serif; font-size: 11px; }
.over { color: #b00020; font-weight: bold; }
)";

void appendFacts(std::string& html, const ReportData& data) {
  if (data.facts.empty()) return;
  html += "<section id=\"facts\"><h2>Configuration</h2><table>\n";
  for (const auto& [name, value] : data.facts)
    html += "<tr><th class=\"text\">" + escaped(name) + "</th><td class=\"text\">" +
            escaped(value) + "</td></tr>\n";
  html += "</table></section>\n";
}

void appendLevels(std::string& html, const ReportData& data) {
  if (data.levels.empty()) return;
  html +=
      "<section id=\"levels\"><h2>Levels</h2>\n<table><tr><th>level</th><th>distance</th>"
      // Coverage at the level's own distance d (lod.json's screen_coverage is at the distance
      // where the level takes over, 1 for level 0).
      "<th>screen coverage at d</th><th>triangles</th><th class=\"text\">shader</th>"
      "<th>error &#949;<sub>a</sub></th><th>bound e<sub>a</sub>&#183;s<sub>d</sub></th>"
      "<th>transition &#949;<sub>t</sub></th><th>predicted cost</th><th>measured cost</th></tr>\n";
  for (const ReportLevel& level : data.levels) {
    bool over = level.error >= level.error_bound && level.index > 0;
    const bool last =
        &level == &data.levels.back();  // no next level: no transition (null in lod.json)
    html += "<tr><td>" + std::to_string(level.index) + "</td><td>" + number(level.distance) +
            "</td><td>" + number(level.screen_coverage) + "</td><td>" +
            std::to_string(level.triangles) + "</td><td class=\"text\">" +
            escaped(level.shader_summary) + "</td><td" + (over ? " class=\"over\"" : "") + ">" +
            number(level.error) + "</td><td>" + number(level.error_bound) + "</td><td>" +
            (last ? std::string("&#8212;") : number(level.transition_error)) + "</td><td>" +
            number(level.predicted_cost) + "</td><td>" +
            (level.measured_cost > 0 ? number(level.measured_cost) : std::string("not measured")) +
            "</td></tr>\n";
  }
  html += "</table>\n";
  for (const ReportLevel& level : data.levels) {
    html += "<div class=\"level\" id=\"level-" + std::to_string(level.index) + "\"><h3>Level " +
            std::to_string(level.index) + " &#8212; d = " + number(level.distance) + ", " +
            std::to_string(level.triangles) +
            " triangles</h3>\n<p>Shader: " + escaped(level.shader_summary) + "</p>\n";
    for (const ReportImage& image : level.images) {
      if (image.image.pixels.empty()) continue;
      // Far levels render a few dozen pixels: shown magnified (pixelated, see the style) so
      // their error is visible; the caption keeps the true size.
      const int scale = std::max(1, 128 / std::max(1, image.image.width));
      html += "<figure><img alt=\"" + escaped(image.caption) + "\" width=\"" +
              std::to_string(image.image.width * scale) + "\" height=\"" +
              std::to_string(image.image.height * scale) + "\" src=\"data:image/png;base64," +
              base64(io::encodePng(image.image)) + "\"><figcaption>" + escaped(image.caption) +
              (scale > 1 ? " (" + std::to_string(image.image.width) + " px, ×" +
                               std::to_string(scale) + ")"
                         : std::string()) +
              "</figcaption></figure>\n";
    }
    html += "</div>\n";
  }
  html += "</section>\n";
}

struct Range {
  double low = std::numeric_limits<double>::infinity();
  double high = -std::numeric_limits<double>::infinity();
  void extend(double v) {
    if (!std::isfinite(v)) return;
    low = std::min(low, v);
    high = std::max(high, v);
  }
  void finish() {
    if (low > high) low = 0, high = 1;
    if (high - low < 1e-12) high = low + 1;
  }
};

// A line plot with axes, five ticks per axis and a legend.
void appendPlot(std::string& html, const ReportPlot& plot) {
  constexpr double kWidth = 640, kHeight = 360, kLeft = 70, kRight = 150, kTop = 30, kBottom = 45;
  Range x_range, y_range;
  for (const ReportSeries& series : plot.series) {
    for (double x : series.x) x_range.extend(x);
    for (double y : series.y) y_range.extend(y);
  }
  x_range.finish();
  y_range.low = std::min(y_range.low, 0.0);  // costs and errors read best from zero
  y_range.finish();
  const double plot_width = kWidth - kLeft - kRight, plot_height = kHeight - kTop - kBottom;
  auto sx = [&](double x) {
    return kLeft + (x - x_range.low) / (x_range.high - x_range.low) * plot_width;
  };
  auto sy = [&](double y) {
    return kTop + plot_height - (y - y_range.low) / (y_range.high - y_range.low) * plot_height;
  };
  html += "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" width=\"" + px(kWidth) +
          "\" height=\"" + px(kHeight) + "\" viewBox=\"0 0 " + px(kWidth) + " " + px(kHeight) +
          "\">\n<text x=\"" + px(kLeft) + "\" y=\"18\" font-weight=\"bold\">" +
          escaped(plot.title) + "</text>\n";
  html += "<rect x=\"" + px(kLeft) + "\" y=\"" + px(kTop) + "\" width=\"" + px(plot_width) +
          "\" height=\"" + px(plot_height) + "\" fill=\"none\" stroke=\"#999\"/>\n";
  for (int tick = 0; tick <= 4; ++tick) {
    double x = x_range.low + (x_range.high - x_range.low) * tick / 4;
    double y = y_range.low + (y_range.high - y_range.low) * tick / 4;
    html += "<line x1=\"" + px(sx(x)) + "\" y1=\"" + px(kTop) + "\" x2=\"" + px(sx(x)) +
            "\" y2=\"" + px(kTop + plot_height) + "\" stroke=\"#eee\"/>";
    html += "<text x=\"" + px(sx(x)) + "\" y=\"" + px(kTop + plot_height + 15) +
            "\" text-anchor=\"middle\">" + number(x, 3) + "</text>";
    html += "<line x1=\"" + px(kLeft) + "\" y1=\"" + px(sy(y)) + "\" x2=\"" +
            px(kLeft + plot_width) + "\" y2=\"" + px(sy(y)) + "\" stroke=\"#eee\"/>";
    html += "<text x=\"" + px(kLeft - 6) + "\" y=\"" + px(sy(y) + 4) + "\" text-anchor=\"end\">" +
            number(y, 3) + "</text>\n";
  }
  html += "<text x=\"" + px(kLeft + plot_width / 2) + "\" y=\"" + px(kHeight - 8) +
          "\" text-anchor=\"middle\">" + escaped(plot.x_label) + "</text>\n";
  html += "<text transform=\"translate(14," + px(kTop + plot_height / 2) +
          ") rotate(-90)\" text-anchor=\"middle\">" + escaped(plot.y_label) + "</text>\n";
  for (size_t s = 0; s < plot.series.size(); ++s) {
    const ReportSeries& series = plot.series[s];
    const char* colour = kSeriesColours[s % std::size(kSeriesColours)];
    std::string points;
    for (size_t i = 0; i < std::min(series.x.size(), series.y.size()); ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) continue;
      points += px(sx(series.x[i])) + "," + px(sy(series.y[i])) + " ";
      html += "<circle cx=\"" + px(sx(series.x[i])) + "\" cy=\"" + px(sy(series.y[i])) +
              "\" r=\"2.5\" fill=\"" + colour + "\"/>";
    }
    html += "<polyline class=\"series\" fill=\"none\" stroke-width=\"1.8\" stroke=\"" +
            std::string(colour) + "\" points=\"" + points + "\"/>\n";
    double legend_y = kTop + 10 + 18.0 * s;
    html += "<line x1=\"" + px(kWidth - kRight + 12) + "\" y1=\"" + px(legend_y) + "\" x2=\"" +
            px(kWidth - kRight + 32) + "\" y2=\"" + px(legend_y) + "\" stroke=\"" + colour +
            "\" stroke-width=\"3\"/><text x=\"" + px(kWidth - kRight + 36) + "\" y=\"" +
            px(legend_y + 4) + "\">" + escaped(series.name) + "</text>\n";
  }
  html += "</svg></figure>\n";
}

// Fig. 2 of the paper: meshes down (M_0 at the top), shaders across in SortByError order; visited
// pairs coloured by the bound, the optimal set outlined, the walk drawn through them.
void appendSearch(std::string& html, const ReportSearch& search) {
  const int rows = std::max(1, search.mesh_count), columns = std::max(1, search.shader_count);
  const double cell = std::clamp(std::min(480.0 / columns, 480.0 / rows), 1.0, 32.0);
  const double left = 60, top = 30;
  // Wide enough for the title and the axis caption even when the grid is small.
  const double width = std::max(420.0, left + cell * columns + 20), height = top + cell * rows + 40;
  html += "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" class=\"search\" width=\"" +
          px(width) + "\" height=\"" + px(height) + "\" viewBox=\"0 0 " + px(width) + " " +
          px(height) + "\">\n";
  html += "<text x=\"" + px(left) + "\" y=\"18\" font-weight=\"bold\">" + escaped(search.title) +
          " (" + std::to_string(search.result.evaluations) + " evaluations of " +
          std::to_string(rows * columns) + ")</text>\n";
  html += "<rect x=\"" + px(left) + "\" y=\"" + px(top) + "\" width=\"" + px(cell * columns) +
          "\" height=\"" + px(cell * rows) + "\" fill=\"#f7f7f7\" stroke=\"#999\"/>\n";
  auto centre = [&](const EvaluatedPair& p) {
    return std::pair{left + cell * (p.shader_rank + 0.5), top + cell * (p.mesh + 0.5)};
  };
  for (const EvaluatedPair& pair : search.result.visited)
    html += "<rect class=\"" + std::string(pair.within_bound ? "pair-in" : "pair-out") + "\" x=\"" +
            px(left + cell * pair.shader_rank) + "\" y=\"" + px(top + cell * pair.mesh) +
            "\" width=\"" + px(cell) + "\" height=\"" + px(cell) + "\" fill=\"" +
            (pair.within_bound ? "#8fd18f" : "#f2a0a0") + "\"><title>M" +
            std::to_string(pair.mesh) + " S" + std::to_string(pair.shader) + ": error " +
            number(pair.error) + ", cost " + number(pair.cost) + "</title></rect>\n";
  std::string points;
  for (const EvaluatedPair& pair : search.result.visited) {
    auto [x, y] = centre(pair);
    points += px(x) + "," + px(y) + " ";
  }
  html +=
      "<polyline fill=\"none\" stroke=\"#333\" stroke-width=\"1\" points=\"" + points + "\"/>\n";
  for (const EvaluatedPair& pair : search.result.optimal)
    html += "<rect class=\"pair-optimal\" x=\"" + px(left + cell * pair.shader_rank) + "\" y=\"" +
            px(top + cell * pair.mesh) + "\" width=\"" + px(cell) + "\" height=\"" + px(cell) +
            "\" fill=\"none\" stroke=\"#0072b2\" stroke-width=\"2\"/>\n";
  html += "<text x=\"" + px(left + cell * columns / 2) + "\" y=\"" + px(top + cell * rows + 18) +
          "\" text-anchor=\"middle\">shaders by error on M0 &#8594;</text>";
  html += "<text transform=\"translate(" + px(left - 10) + "," + px(top + cell * rows / 2) +
          ") rotate(-90)\" text-anchor=\"middle\">meshes, simpler &#8595;</text>\n";
  html +=
      "</svg><figcaption>green: within the bound, red: over it, blue outline: optimal set "
      "(within T of the cheapest)</figcaption></figure>\n";
}

// Algorithm 3's graph G: one column per level, one node per pair; edges grey with width by how
// smooth the transition is, the chosen path in blue.
void appendTransitions(std::string& html, const ReportTransitions& transitions) {
  const auto& levels = transitions.level_pairs;
  if (levels.empty()) return;
  size_t most = 1;
  for (const auto& level : levels) most = std::max(most, level.size());
  const double column = 110, row = 46, left = 50, top = 40;
  const double width = left * 2 + column * (levels.size() - 1) + 40, height = top + row * most + 30;
  auto node = [&](size_t level, size_t index) {
    return std::pair{left + column * level, top + row * (index + 0.5)};
  };
  double heaviest = 0;
  for (const TransitionEdge& edge : transitions.path.edges)
    heaviest = std::max(heaviest, edge.error);
  html += "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" class=\"transitions\" width=\"" +
          px(width) + "\" height=\"" + px(height) + "\" viewBox=\"0 0 " + px(width) + " " +
          px(height) + "\">\n";
  const std::vector<int>& choice = transitions.path.choice;
  for (const TransitionEdge& edge : transitions.path.edges) {
    if (size_t(edge.level + 1) >= levels.size()) continue;
    auto [x1, y1] = node(edge.level, edge.from);
    auto [x2, y2] = node(edge.level + 1, edge.to);
    bool chosen = size_t(edge.level + 1) < choice.size() && choice[edge.level] == edge.from &&
                  choice[edge.level + 1] == edge.to;
    double smooth = heaviest > 0 ? 1 - edge.error / heaviest : 1;
    html += "<line class=\"" + std::string(chosen ? "edge-chosen" : "edge") + "\" x1=\"" + px(x1) +
            "\" y1=\"" + px(y1) + "\" x2=\"" + px(x2) + "\" y2=\"" + px(y2) + "\" stroke=\"" +
            (chosen ? "#0072b2" : "#bbb") + "\" stroke-width=\"" +
            px(chosen ? 3.5 : 0.5 + 1.5 * smooth) + "\"><title>&#949;t = " + number(edge.error) +
            "</title></line>\n";
  }
  for (size_t level = 0; level < levels.size(); ++level) {
    html += "<text x=\"" + px(left + column * level) + "\" y=\"20\" text-anchor=\"middle\">level " +
            std::to_string(level) + "</text>\n";
    for (size_t index = 0; index < levels[level].size(); ++index) {
      const EvaluatedPair& pair = levels[level][index];
      auto [x, y] = node(level, index);
      bool chosen = level < choice.size() && size_t(choice[level]) == index;
      html += "<circle class=\"" + std::string(chosen ? "node-chosen" : "node") + "\" cx=\"" +
              px(x) + "\" cy=\"" + px(y) + "\" r=\"7\" fill=\"" + (chosen ? "#0072b2" : "#fff") +
              "\" stroke=\"#333\"/><text x=\"" + px(x + 10) + "\" y=\"" + px(y - 8) + "\">M" +
              std::to_string(pair.mesh) + " S" + std::to_string(pair.shader) + "</text>\n";
    }
  }
  html += "</svg><figcaption>total transition error along the chosen path: " +
          number(transitions.path.total_transition) + "</figcaption></figure>\n";
}

}  // namespace

std::string renderReportHtml(const ReportData& data) {
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
      escaped(data.title) + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n<h1>" +
      escaped(data.title) + "</h1>\n";
  appendFacts(html, data);
  appendLevels(html, data);
  if (!data.plots.empty()) {
    html += "<section id=\"plots\"><h2>Error and cost against distance</h2>\n";
    for (const ReportPlot& plot : data.plots) appendPlot(html, plot);
    html += "</section>\n";
  }
  if (!data.searches.empty()) {
    html += "<section id=\"search\"><h2>Pair search (Algorithm 2)</h2>\n";
    for (const ReportSearch& search : data.searches) appendSearch(html, search);
    html += "</section>\n";
  }
  if (data.transitions) {
    html +=
        "<section id=\"transitions\"><h2>Transition graph and smoothest path (Algorithm 3)</h2>\n";
    appendTransitions(html, *data.transitions);
    html += "</section>\n";
  }
  html += "</body>\n</html>\n";
  return html;
}

core::Status writeReport(const ReportData& data, const std::string& path) {
  return io::writeFileAtomic(path, renderReportHtml(data));
}

}  // namespace duolod::lod
