// Private text-parsing helpers shared by the OBJ, MTL, PLY and OFF readers: a line reader and a
// token stream that count lines (for "file:line: reason" messages), strict number parsing
// (std::from_chars: locale-independent, whole token or nothing) and message formatting.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::io::text {

inline bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}
inline bool isLineBreak(char c) {
  return c == '\n' || c == '\r';
}

std::string_view trim(std::string_view text);
bool startsWith(std::string_view text, std::string_view prefix);
// ASCII case-insensitive comparison.
bool equalsIgnoreCase(std::string_view a, std::string_view b);

// Splits text into lines ending in LF, CRLF or CR; line numbers count from 1. A UTF-8 byte order
// mark at the start is skipped.
class LineReader {
 public:
  explicit LineReader(std::string_view text);
  // Sets `line` to the next line without its terminator; false at the end of the text.
  bool next(std::string_view& line);
  // Number of the line most recently returned by next() (0 before the first call).
  size_t lineNumber() const { return line_number_; }
  // Byte offset just past the line most recently returned, including its terminator.
  size_t offset() const { return offset_; }
  std::string_view text() const { return text_; }

 private:
  std::string_view text_;
  size_t offset_ = 0;
  size_t line_number_ = 0;
};

// Whitespace-separated tokens of one line.
class Tokens {
 public:
  explicit Tokens(std::string_view line) : rest_(line) {}
  // Sets `token` to the next token; false when the line has no more.
  bool next(std::string_view& token);
  // The unread part of the line, trimmed (e.g. a material name that may contain spaces).
  std::string_view rest() const { return trim(rest_); }
  bool atEnd() const { return trim(rest_).empty(); }

 private:
  std::string_view rest_;
};

// Whitespace-separated tokens of a whole text, across lines, with the line of each token.
class TokenStream {
 public:
  explicit TokenStream(std::string_view text, size_t first_line = 1)
      : text_(text), line_(first_line) {}
  bool next(std::string_view& token);
  // Line of the token most recently returned (or of the end of the text after next() failed).
  size_t lineNumber() const { return token_line_; }
  size_t bytesLeft() const { return text_.size() - offset_; }

 private:
  std::string_view text_;
  size_t offset_ = 0;
  size_t line_ = 1;
  size_t token_line_ = 1;
};

// Number parsing: the whole token must be a number. A leading '+' is accepted. parseFloat accepts
// "nan"/"inf" (callers check finiteness so they can name the problem); a value too small for a
// float becomes 0, one too large becomes infinity.
bool parseFloat(std::string_view token, float& value);
bool parseDouble(std::string_view token, double& value);
bool parseInt(std::string_view token, int64_t& value);
bool parseUint(std::string_view token, uint64_t& value);

// A token for an error message: quoted, at most ~40 characters, control/non-ASCII bytes escaped.
std::string quote(std::string_view token);

// "path:line: message".
core::Error errorAt(std::string_view path, size_t line, std::string_view message);
// "path: message".
core::Error errorIn(std::string_view path, std::string_view message);

// Reads a whole file (through io::readFileBytes); the error names the path.
core::Result<std::vector<uint8_t>> readInputFile(const std::string& path);
inline std::string_view asText(const std::vector<uint8_t>& bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

// Mesh assembly shared by the single-material readers (PLY, OFF).

// The triangles of a polygon whose corners are at `corners`, as triples of corner numbers
// (0..n-1) appended to `triangles`. A convex polygon is fanned from its first corner (v0 v1 v2,
// v0 v2 v3, ...: what exporters mean by it); a concave one is cut into ears, in the plane of its
// Newell normal, so that no triangle covers the outside of a notch. Returns false when the polygon
// is not simple (it crosses or touches itself, winds around twice, or is too long to clip: more
// than kMaxClippedCorners corners) or has no plane (all corners on a line): it is then fanned as
// before. Corners repeated one after the other count once.
// The fan of a polygon of n corners (0 1 2, 0 2 3, ...), as corner numbers.
void appendFanCorners(size_t n, std::vector<uint32_t>& triangles);
constexpr size_t kMaxClippedCorners = 1024;  // ear clipping is quadratic to cubic in them
// The readers' warning about the polygons triangulatePolygon returned false for.
inline const std::string kUnclippedPolygon =
    "could not be cut into ears (it crosses or touches itself, winds around twice, has no "
    "plane or has over " +
    std::to_string(kMaxClippedCorners) + " corners) and was fan-triangulated";
bool triangulatePolygon(std::span<const core::Vec3> corners, std::vector<uint32_t>& triangles);
// triangulatePolygon for a polygon of vertex ids into `indices`, its corners' positions read from
// `positions`, which must hold every corner (a reader that meets faces before their vertices
// keeps them until the vertices are read). Returns triangulatePolygon's answer.
bool appendPolygon(std::span<const uint32_t> polygon, std::span<const core::Vec3> positions,
                   std::vector<uint32_t>& indices);
// One default material and, when there are triangles, one submesh covering them all.
void finishSingleMaterialAsset(core::Asset& asset);

}  // namespace duolod::io::text
