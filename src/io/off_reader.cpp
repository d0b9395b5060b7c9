// OFF reader, after the Geomview "OFF" file format description (geomview.org, "Object File
// Formats"): the [ST][C][N]OFF header keyword (optional), "nv nf ne" counts, one vertex per line
// (x y z [nx ny nz] [r g b [a]] [s t]), then one polygon per line ("n i0 .. in-1 [colour]"),
// fan-triangulated. '#' starts a comment. The 4-D, n-D and binary variants are rejected.
#include <cmath>

#include "duolod/io.hpp"
#include "io/text_parse.hpp"

namespace duolod::io {
namespace {

using core::Error;
using text::errorAt;
using text::errorIn;
using text::quote;

struct OffLayout {
  bool texcoords = false;  // ST
  bool colors = false;     // C
  bool normals = false;    // N
};

class OffParser {
 public:
  OffParser(const std::string& path, core::Asset& asset) : path_(path), asset_(asset) {}

  core::Status parse(std::string_view content) {
    if (content.find('\0') != std::string_view::npos) {
      return errorIn(path_, "not a text OFF file (contains NUL bytes)");
    }
    text::LineReader lines(content);
    std::string_view line;
    if (!nextDataLine(lines, line)) return errorIn(path_, "empty file (no OFF header)");

    // Header keyword, optionally followed by the counts on the same line.
    text::Tokens tokens(line);
    std::string_view first;
    tokens.next(first);
    uint64_t probe = 0;
    if (!text::parseUint(first, probe)) {
      if (auto status = parseKeyword(first); !status) return status;
      if (tokens.atEnd()) {
        if (!nextDataLine(lines, line)) return errorIn(path_, "file ends before the counts line");
        tokens = text::Tokens(line);
      } else if (tokens.rest().substr(0, 6) == "BINARY") {
        return errorAt(path_, line_, "binary OFF is not supported");
      }
    } else {
      tokens = text::Tokens(line);  // no keyword: this line holds the counts
    }

    uint64_t vertex_count = 0, face_count = 0;
    std::string_view token;
    if (!tokens.next(token) || !text::parseUint(token, vertex_count) || !tokens.next(token) ||
        !text::parseUint(token, face_count)) {
      return errorAt(path_, line_,
                     "expected 'vertex_count face_count [edge_count]', got " + quote(line));
    }
    // The shortest vertex line is "0 0 0" (5 bytes), the shortest face line "3 0 1 2" (more than
    // 6 with its line break); a header asking for more than the file can hold is corrupt.
    size_t left = content.size() - lines.offset();
    if (vertex_count > left / 5 || face_count > left / 6 ||
        vertex_count * 5 + face_count * 6 > left + 1) {
      return errorAt(path_, line_,
                     "header declares " + std::to_string(vertex_count) + " vertices and " +
                         std::to_string(face_count) + " faces, more than the " +
                         std::to_string(left) + " bytes left in the file can hold");
    }
    if (vertex_count > UINT32_MAX) return errorAt(path_, line_, "more than 2^32 vertices");

    if (auto status = readVertices(lines, vertex_count); !status) return status;
    if (auto status = readFaces(lines, face_count, vertex_count); !status) return status;
    // Data past the declared faces is not read: said so (a count one short drops a face).
    size_t extra = 0, first_extra = 0;
    for (std::string_view rest; nextDataLine(lines, rest);)
      if (extra++ == 0) first_extra = line_;
    if (extra > 0)
      asset_.warnings.push_back(path_ + ":" + std::to_string(first_extra) + ": " +
                                std::to_string(extra) + " data line" + (extra > 1 ? "s" : "") +
                                " after the " + std::to_string(face_count) +
                                " declared faces, not read");
    text::finishSingleMaterialAsset(asset_);
    return core::okStatus();
  }

 private:
  // Next line that is not blank or a comment, with any trailing comment removed.
  bool nextDataLine(text::LineReader& lines, std::string_view& line) {
    while (lines.next(line)) {
      line_ = lines.lineNumber();
      line = line.substr(0, line.find('#'));
      if (!text::trim(line).empty()) return true;
    }
    line_ = lines.lineNumber();
    return false;
  }

  core::Status parseKeyword(std::string_view keyword) {
    std::string_view rest = keyword;
    if (text::startsWith(rest, "ST")) {
      layout_.texcoords = true;
      rest.remove_prefix(2);
    }
    if (text::startsWith(rest, "C")) {
      layout_.colors = true;
      rest.remove_prefix(1);
    }
    if (text::startsWith(rest, "N")) {
      layout_.normals = true;
      rest.remove_prefix(1);
    }
    if (text::startsWith(rest, "4") || text::startsWith(rest, "n")) {
      return errorAt(path_, line_, "4-D / n-D OFF (" + quote(keyword) + ") is not supported");
    }
    if (rest != "OFF") return errorAt(path_, line_, "not an OFF file: header " + quote(keyword));
    return core::okStatus();
  }

  core::Status readVertices(text::LineReader& lines, uint64_t count) {
    core::Mesh& mesh = asset_.mesh;
    mesh.positions.reserve(count);
    if (layout_.normals) mesh.normals.reserve(count);
    if (layout_.colors) mesh.colors.reserve(count);
    if (layout_.texcoords) mesh.uv0.reserve(count);
    size_t fixed = 3 + (layout_.normals ? 3 : 0) + (layout_.texcoords ? 2 : 0);
    constexpr size_t kMaxValues = 12;  // x y z nx ny nz r g b a s t
    float values[kMaxValues];
    std::string_view line;
    for (uint64_t v = 0; v < count; ++v) {
      if (!nextDataLine(lines, line)) {
        return errorAt(
            path_, line_,
            "file ends after " + std::to_string(v) + " of " + std::to_string(count) + " vertices");
      }
      text::Tokens tokens(line);
      std::string_view token;
      size_t n = 0;
      std::string_view seen[kMaxValues];
      while (tokens.next(token)) {
        if (n == kMaxValues) break;  // extra values (e.g. a colour on a plain OFF) are ignored
        if (!text::parseFloat(token, values[n])) {
          return errorAt(
              path_, line_,
              "vertex " + std::to_string(v) + ": expected a number, got " + quote(token));
        }
        if (!std::isfinite(values[n])) {
          return errorAt(path_, line_,
                         "vertex " + std::to_string(v) + " has a non-finite value " + quote(token));
        }
        seen[n++] = token;
      }
      size_t color_values = layout_.colors ? (n > fixed ? n - fixed : 0) : 0;
      if (n < fixed || (layout_.colors && color_values < 3)) {
        return errorAt(path_, line_,
                       "vertex " + std::to_string(v) + " has " + std::to_string(n) + " values (" +
                           std::to_string(fixed + (layout_.colors ? 3 : 0)) + " needed)");
      }
      color_values = std::min<size_t>(color_values, 4);
      mesh.positions.push_back({values[0], values[1], values[2]});
      size_t next = 3;
      if (layout_.normals) {
        mesh.normals.push_back({values[3], values[4], values[5]});
        next = 6;
      }
      if (layout_.colors) {
        bool integer_colors = true;
        for (size_t i = next; i < next + color_values; ++i) {
          int64_t ignored = 0;
          if (!text::parseInt(seen[i], ignored)) integer_colors = false;
        }
        core::Vec4 color{values[next], values[next + 1], values[next + 2],
                         color_values == 4 ? values[next + 3] : 1.0f};
        // Geomview: colours are floats in 0..1 or integers in 0..255.
        if (integer_colors &&
            (color.x > 1 || color.y > 1 || color.z > 1 || (color_values == 4 && color.w > 1))) {
          color = {color.x / 255, color.y / 255, color.z / 255,
                   color_values == 4 ? color.w / 255 : 1.0f};
        }
        mesh.colors.push_back(color);
        next += color_values;
      }
      if (layout_.texcoords) {
        // Texture coordinates follow OpenGL (v up); ours point down.
        mesh.uv0.push_back({values[next], 1.0f - values[next + 1]});
      }
    }
    return core::okStatus();
  }

  core::Status readFaces(text::LineReader& lines, uint64_t count, uint64_t vertex_count) {
    std::vector<uint32_t> polygon;
    std::string_view line;
    for (uint64_t f = 0; f < count; ++f) {
      if (!nextDataLine(lines, line)) {
        return errorAt(
            path_, line_,
            "file ends after " + std::to_string(f) + " of " + std::to_string(count) + " faces");
      }
      text::Tokens tokens(line);
      std::string_view token;
      uint64_t n = 0;
      tokens.next(token);
      if (!text::parseUint(token, n)) {
        return errorAt(
            path_, line_,
            "face " + std::to_string(f) + ": expected a vertex count, got " + quote(token));
      }
      if (n < 3) {
        return errorAt(path_, line_,
                       "face " + std::to_string(f) + " has " + std::to_string(n) +
                           " vertices (at least 3 needed)");
      }
      polygon.clear();
      for (uint64_t i = 0; i < n; ++i) {
        uint64_t index = 0;
        if (!tokens.next(token)) {
          return errorAt(path_, line_,
                         "face " + std::to_string(f) + " lists " + std::to_string(n) +
                             " vertices but has " + std::to_string(i) + " indices");
        }
        if (!text::parseUint(token, index)) {
          return errorAt(path_, line_,
                         "face " + std::to_string(f) + ": bad vertex index " + quote(token));
        }
        if (index >= vertex_count) {
          return errorAt(path_, line_,
                         "face " + std::to_string(f) + ": vertex index " + std::to_string(index) +
                             " out of range (" + std::to_string(vertex_count) + " vertices)");
        }
        polygon.push_back(static_cast<uint32_t>(index));
      }
      // Anything after the indices is a face colour, which has no place in our mesh.
      if (!text::appendPolygon(polygon, asset_.mesh.positions, asset_.mesh.indices) &&
          !first_unclipped_line_)
        first_unclipped_line_ = line_;
    }
    if (first_unclipped_line_ > 0)
      asset_.warnings.push_back(
          errorAt(path_, first_unclipped_line_,
                  "a polygon " + text::kUnclippedPolygon + " (the first of them)")
              .message);
    if (asset_.mesh.indices.size() > UINT32_MAX) return errorIn(path_, "too many triangles");
    return core::okStatus();
  }

  const std::string& path_;
  core::Asset& asset_;
  OffLayout layout_;
  size_t line_ = 0;
  size_t first_unclipped_line_ = 0;  // the first polygon not cut into ears (triangulatePolygon)
};

}  // namespace

core::Result<core::Asset> readOff(const std::string& path, const LoadOptions& /*options*/) {
  auto bytes = text::readInputFile(path);
  if (!bytes) return bytes.error();
  core::Asset asset;
  asset.source_path = path;
  OffParser parser(path, asset);
  if (auto status = parser.parse(text::asText(*bytes)); !status) return status.error();
  return asset;
}

}  // namespace duolod::io
