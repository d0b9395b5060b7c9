// OFF reader, after the Geomview "OFF" file format description (geomview.org, "Object File
// Formats"): the [ST][C][N]OFF header keyword (optional), "nv nf ne" counts, the vertices
// (x y z [nx ny nz] [r g b [a]] [s t]), then the polygons ("n i0 .. in-1 [colour]"), fanned when
// convex and cut into ears when concave (text::triangulatePolygon). '#' starts a comment. The
// 4-D, n-D and binary variants are rejected.
//
// Layout. OFF is whitespace-separated numbers, but nearly every file has one vertex and one face
// per line, and two things only the lines tell: whether a vertex colour has 3 or 4 numbers, and
// where a face's colour ends (Geomview: "colorspec continues past v[Nv-1] to end-of-line").
// So a file is read by lines first, and as free-format numbers only when that fails:
//  1. By lines: each vertex is one line (values past its fields are ignored: some writers put a
//     colour on a plain OFF's vertices), each face is one line (what follows its indices is its
//     colour).
//  2. Free-format: the counts are still one line (the keyword's or the next), where the edge
//     count and then data may follow them.
//     A vertex that starts a line, when that line (or it and the next ones, for a vertex split
//     over lines) holds one whole vertex and nothing more, is those lines, its colour 3 or 4
//     numbers as written; any other vertex is exactly its fields wherever the lines break, its
//     colour RGBA (Geomview reads 4 numbers). A face is its count and that many indices across
//     line breaks. After its last index, the rest of that line is its colour when it holds at
//     most four tokens that are not a triangle of this mesh ("3 i j k"); otherwise a next face
//     starts there (several faces on a line). So a line may end inside a face, but not within
//     the first four tokens of a face that does not start its line: those would read as the
//     previous face's colour.
// A file read the second way gets a warning naming where its lines stopped making sense. When
// both readings fail, the error is the line reading's, followed by the free-format reading's
// when that differs.
#include <algorithm>
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

// The tokens of an OFF body with their line numbers; '#' starts a comment that runs to the end of
// its line. A value: copied to look ahead.
class OffTokens {
 public:
  // `offset` in `text`, on line `line`, after some token of it (so not at a line's start).
  OffTokens(std::string_view text, size_t offset, size_t line)
      : text_(text), offset_(offset), line_(line) {}

  // The next token on the current line; false at its end, where the cursor then stays.
  bool nextOnLine(std::string_view& token) {
    if (!skipToToken()) return false;
    const size_t begin = offset_;
    while (offset_ < text_.size() && !isSeparator(text_[offset_])) ++offset_;
    token = text_.substr(begin, offset_ - begin);
    at_line_start_ = false;
    return true;
  }
  // Moves to the next line that holds a token; false at the end of the text.
  bool nextLine() {
    while (true) {
      while (offset_ < text_.size() && !text::isLineBreak(text_[offset_])) ++offset_;
      if (offset_ >= text_.size()) return false;
      // CRLF is one line break; a lone CR (old Mac files) one too. A break at the very end of
      // the text starts no line (as text::LineReader counts them).
      const bool crlf =
          text_[offset_] == '\r' && offset_ + 1 < text_.size() && text_[offset_ + 1] == '\n';
      offset_ += crlf ? 2 : 1;
      if (offset_ >= text_.size()) return false;
      ++line_;
      at_line_start_ = true;
      if (skipToToken()) return true;
    }
  }
  // The next token, on this line or a later one.
  bool next(std::string_view& token) {
    return nextOnLine(token) || (nextLine() && nextOnLine(token));
  }

  bool hasTokenOnLine() const {
    OffTokens probe = *this;
    return probe.skipToToken();
  }
  // How many tokens the current line has left, counting up to `cap` (a long line is not scanned
  // to its end for each record on it).
  size_t countOnLine(size_t cap) const {
    OffTokens probe = *this;
    size_t count = 0;
    for (std::string_view token; count < cap && probe.nextOnLine(token);) ++count;
    return count;
  }
  // Whether the next token is the first of its line.
  bool nextStartsALine() const { return at_line_start_ || !hasTokenOnLine(); }
  // Line of the token last read (or of the line moved to).
  size_t line() const { return line_; }

 private:
  static bool isSeparator(char c) { return text::isSpace(c) || text::isLineBreak(c) || c == '#'; }
  // Skips blanks and a comment; true when a token of this line follows.
  bool skipToToken() {
    while (offset_ < text_.size() && text::isSpace(text_[offset_])) ++offset_;
    if (offset_ < text_.size() && text_[offset_] == '#')
      while (offset_ < text_.size() && !text::isLineBreak(text_[offset_])) ++offset_;
    return offset_ < text_.size() && !text::isLineBreak(text_[offset_]);
  }

  std::string_view text_;
  size_t offset_;
  size_t line_;
  bool at_line_start_ = false;  // no token read on the current line yet
};

enum class Reading { kByLines, kFreeFormat };

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
    bool counts_read = tokens.next(token) && text::parseUint(token, vertex_count);
    if (counts_read && tokens.atEnd()) {
      // Geomview reads the counts as free-format numbers: the face count may start the next
      // line ("OFF\n8\n6 12\n"). Read so, with a warning (most readers want them on one line).
      const size_t vertex_count_line = line_;
      if (!nextDataLine(lines, line)) return errorIn(path_, "file ends after the vertex count");
      tokens = text::Tokens(line);
      asset_.warnings.push_back(located(vertex_count_line, "the counts are split over lines " +
                                                               std::to_string(vertex_count_line) +
                                                               " and " + std::to_string(line_) +
                                                               "; read as one line")
                                    .message);
    }
    if (!counts_read || !tokens.next(token) || !text::parseUint(token, face_count)) {
      return errorAt(path_, line_,
                     "expected 'vertex_count face_count [edge_count]', got " + quote(line));
    }
    // The body starts right after the face count (a free-format file may go on on its line).
    const size_t body = static_cast<size_t>(token.data() + token.size() - content.data());
    // The shortest vertex is "0 0 0" (5 bytes), the shortest face "3 0 1 2" (more than 6 with
    // what separates it); a header asking for more than the file can hold is corrupt.
    size_t left = content.size() - body;
    if (vertex_count > left / 5 || face_count > left / 6 ||
        vertex_count * 5 + face_count * 6 > left + 1) {
      return errorAt(path_, line_,
                     "header declares " + std::to_string(vertex_count) + " vertices and " +
                         std::to_string(face_count) + " faces, more than the " +
                         std::to_string(left) + " bytes left in the file can hold");
    }
    if (vertex_count > UINT32_MAX) return errorAt(path_, line_, "more than 2^32 vertices");
    vertex_count_ = vertex_count;
    face_count_ = face_count;

    const OffTokens start(content, body, line_);
    const size_t warnings_before = asset_.warnings.size();
    auto by_lines = readBody(start, Reading::kByLines);
    if (by_lines) return finish();
    const Failure line_failure = failure_;
    asset_.mesh = core::Mesh{};
    asset_.warnings.resize(warnings_before);
    first_unclipped_line_ = 0;
    if (readBody(start, Reading::kFreeFormat)) {
      asset_.warnings.push_back(
          located(line_failure.line, "not one vertex and one face per line (" +
                                         line_failure.reason + "); read as free-format OFF")
              .message);
      return finish();
    }
    if (failure_.line == line_failure.line && failure_.reason == line_failure.reason)
      return by_lines;
    return Error{by_lines.error().message + "; read as free-format OFF instead: " +
                 (failure_.line > 0 ? "line " + std::to_string(failure_.line) + ": " : "") +
                 failure_.reason};
  }

 private:
  struct Failure {
    size_t line = 0;  // 0: not at a line
    std::string reason;
  };

  core::Status fail(size_t line, std::string reason) {
    failure_ = {line, std::move(reason)};
    return located(line, failure_.reason);
  }
  Error located(size_t line, std::string_view message) const {
    return line > 0 ? errorAt(path_, line, message) : errorIn(path_, message);
  }

  core::Status finish() {
    text::finishSingleMaterialAsset(asset_);
    return core::okStatus();
  }

  // Next line that is not blank or a comment, with any trailing comment removed (the header).
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

  // The vertices and faces, from just after the face count.
  core::Status readBody(OffTokens tokens, Reading reading) {
    if (reading == Reading::kFreeFormat) {
      std::string_view edge_count;
      tokens.nextOnLine(edge_count);  // on the counts' line, if anywhere (never used)
    }
    if (auto status = readVertices(tokens, reading); !status) return status;
    if (auto status = readFaces(tokens, reading); !status) return status;
    // Data past the declared faces is not read: said so (a count one short drops a face).
    size_t extra = 0, first_extra = 0;
    if (reading == Reading::kFreeFormat && tokens.hasTokenOnLine()) {
      extra = 1;
      first_extra = tokens.line();
    }
    while (tokens.nextLine())
      if (extra++ == 0) first_extra = tokens.line();
    if (extra > 0)
      asset_.warnings.push_back(path_ + ":" + std::to_string(first_extra) + ": " +
                                std::to_string(extra) + " data line" + (extra > 1 ? "s" : "") +
                                " after the " + std::to_string(face_count_) +
                                " declared faces, not read");
    return core::okStatus();
  }

  // Values of a vertex: x y z, normal, colour (3 or 4), texture coordinates.
  static constexpr size_t kMaxValues = 12;
  size_t fixedValues() const { return 3 + (layout_.normals ? 3 : 0) + (layout_.texcoords ? 2 : 0); }

  core::Status readVertices(OffTokens& tokens, Reading reading) {
    core::Mesh& mesh = asset_.mesh;
    const uint64_t count = vertex_count_;
    mesh.positions.reserve(count);
    if (layout_.normals) mesh.normals.reserve(count);
    if (layout_.colors) mesh.colors.reserve(count);
    if (layout_.texcoords) mesh.uv0.reserve(count);
    const size_t fixed = fixedValues();
    const size_t fewest = fixed + (layout_.colors ? 3 : 0), most = fixed + (layout_.colors ? 4 : 0);
    float values[kMaxValues];
    std::string_view seen[kMaxValues];
    for (uint64_t v = 0; v < count; ++v) {
      auto ended = [&] {
        return fail(tokens.line(), "file ends after " + std::to_string(v) + " of " +
                                       std::to_string(count) + " vertices");
      };
      size_t n = 0;
      std::string_view token;
      if (reading == Reading::kByLines) {
        if (!tokens.nextLine()) return ended();
        // Extra values (e.g. a colour on a plain OFF) are ignored.
        while (n < kMaxValues && tokens.nextOnLine(token)) {
          if (auto status = parseValue(token, v, tokens.line(), values[n]); !status) return status;
          seen[n++] = token;
        }
      } else {
        const size_t take = freeFormatVertexSize(tokens, fewest, most);
        while (n < take) {
          if (!tokens.next(token)) return ended();
          if (auto status = parseValue(token, v, tokens.line(), values[n]); !status) return status;
          seen[n++] = token;
        }
      }
      if (auto status = storeVertex(values, seen, n, v, tokens.line()); !status) return status;
    }
    return core::okStatus();
  }

  // How many values the free-format vertex at `tokens` has (the layout rules at the top).
  size_t freeFormatVertexSize(const OffTokens& tokens, size_t fewest, size_t most) const {
    OffTokens probe = tokens;
    if (probe.nextStartsALine()) {
      size_t held = 0;
      if (!probe.hasTokenOnLine()) probe.nextLine();
      do {
        held += probe.countOnLine(most + 1);
      } while (held < fewest && probe.nextLine());
      if (held >= fewest && held <= most) return held;
    }
    return most;
  }

  core::Status parseValue(std::string_view token, uint64_t v, size_t line, float& value) {
    if (!text::parseFloat(token, value))
      return fail(line, "vertex " + std::to_string(v) + ": expected a number, got " + quote(token));
    if (!std::isfinite(value))
      return fail(line, "vertex " + std::to_string(v) + " has a non-finite value " + quote(token));
    return core::okStatus();
  }

  // Vertex v from its n values (`seen`: as written), in the layout's order.
  core::Status storeVertex(const float* values, const std::string_view* seen, size_t n, uint64_t v,
                           size_t line) {
    core::Mesh& mesh = asset_.mesh;
    const size_t fixed = fixedValues();
    size_t color_values = layout_.colors ? (n > fixed ? n - fixed : 0) : 0;
    if (n < fixed || (layout_.colors && color_values < 3)) {
      return fail(line, "vertex " + std::to_string(v) + " has " + std::to_string(n) + " values (" +
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
    return core::okStatus();
  }

  core::Status readFaces(OffTokens& tokens, Reading reading) {
    const uint64_t count = face_count_;
    std::vector<uint32_t> polygon;
    for (uint64_t f = 0; f < count; ++f) {
      std::string_view token;
      const bool started = reading == Reading::kByLines
                               ? tokens.nextLine() && tokens.nextOnLine(token)
                               : tokens.next(token);
      if (!started) {
        return fail(tokens.line(), "file ends after " + std::to_string(f) + " of " +
                                       std::to_string(count) + " faces");
      }
      uint64_t n = 0;
      if (!text::parseUint(token, n)) {
        return fail(tokens.line(),
                    "face " + std::to_string(f) + ": expected a vertex count, got " + quote(token));
      }
      if (n < 3) {
        return fail(tokens.line(), "face " + std::to_string(f) + " has " + std::to_string(n) +
                                       " vertices (at least 3 needed)");
      }
      const size_t face_line = tokens.line();
      polygon.clear();
      for (uint64_t i = 0; i < n; ++i) {
        const bool more =
            reading == Reading::kByLines ? tokens.nextOnLine(token) : tokens.next(token);
        if (!more) {
          return fail(face_line, "face " + std::to_string(f) + " lists " + std::to_string(n) +
                                     " vertices but has " + std::to_string(i) + " indices");
        }
        uint64_t index = 0;
        if (!text::parseUint(token, index)) {
          return fail(tokens.line(),
                      "face " + std::to_string(f) + ": bad vertex index " + quote(token));
        }
        if (index >= vertex_count_) {
          return fail(tokens.line(), "face " + std::to_string(f) + ": vertex index " +
                                         std::to_string(index) + " out of range (" +
                                         std::to_string(vertex_count_) + " vertices)");
        }
        polygon.push_back(static_cast<uint32_t>(index));
      }
      // Anything after the indices is a face colour, which has no place in our mesh: by lines,
      // the next face starts on the next line; free-format, see the rules at the top.
      if (reading == Reading::kFreeFormat) skipFaceColour(tokens);
      if (!text::appendPolygon(polygon, asset_.mesh.positions, asset_.mesh.indices) &&
          !first_unclipped_line_)
        first_unclipped_line_ = face_line;
      if (asset_.mesh.indices.size() > UINT32_MAX) return fail(0, "too many triangles");
    }
    if (first_unclipped_line_ > 0)
      asset_.warnings.push_back(
          errorAt(path_, first_unclipped_line_,
                  "a polygon " + text::kUnclippedPolygon + " (the first of them)")
              .message);
    return core::okStatus();
  }

  // Free-format: skips what follows a face's last index on its line when it is a colour (at most
  // four tokens, not a triangle "3 i j k" of this mesh); leaves it as the next face otherwise.
  void skipFaceColour(OffTokens& tokens) const {
    const size_t rest = tokens.countOnLine(5);
    if (rest == 0 || rest > 4) return;
    OffTokens probe = tokens;
    std::string_view token;
    uint64_t value = 0;
    bool triangle =
        rest == 4 && probe.nextOnLine(token) && text::parseUint(token, value) && value == 3;
    for (int i = 0; i < 3 && triangle; ++i)
      triangle = probe.nextOnLine(token) && text::parseUint(token, value) && value < vertex_count_;
    if (triangle) return;
    while (tokens.nextOnLine(token)) {
    }
  }

  const std::string& path_;
  core::Asset& asset_;
  OffLayout layout_;
  size_t line_ = 0;  // of the header's line last read
  uint64_t vertex_count_ = 0, face_count_ = 0;
  size_t first_unclipped_line_ = 0;  // the first polygon not cut into ears (triangulatePolygon)
  Failure failure_;                  // of the last fail() (the reading that failed)
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
