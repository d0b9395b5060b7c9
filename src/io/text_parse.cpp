// Private text-parsing helpers for the OBJ/MTL/PLY/OFF readers (see text_parse.hpp).
#include "io/text_parse.hpp"

#include <cassert>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "duolod/io.hpp"

namespace duolod::io::text {

std::string_view trim(std::string_view text) {
  size_t begin = 0;
  while (begin < text.size() && (isSpace(text[begin]) || isLineBreak(text[begin]))) ++begin;
  size_t end = text.size();
  while (end > begin && (isSpace(text[end - 1]) || isLineBreak(text[end - 1]))) --end;
  return text.substr(begin, end - begin);
}

bool startsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

bool equalsIgnoreCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i] >= 'A' && a[i] <= 'Z' ? static_cast<char>(a[i] - 'A' + 'a') : a[i];
    char y = b[i] >= 'A' && b[i] <= 'Z' ? static_cast<char>(b[i] - 'A' + 'a') : b[i];
    if (x != y) return false;
  }
  return true;
}

LineReader::LineReader(std::string_view text) : text_(text) {
  if (startsWith(text_, "\xEF\xBB\xBF")) offset_ = 3;
}

bool LineReader::next(std::string_view& line) {
  if (offset_ >= text_.size()) return false;
  size_t end = offset_;
  while (end < text_.size() && !isLineBreak(text_[end])) ++end;
  line = text_.substr(offset_, end - offset_);
  if (end < text_.size()) {
    // CRLF counts as one terminator; a lone CR (old Mac files) as one too.
    end += (text_[end] == '\r' && end + 1 < text_.size() && text_[end + 1] == '\n') ? 2 : 1;
  }
  offset_ = end;
  ++line_number_;
  return true;
}

bool Tokens::next(std::string_view& token) {
  size_t begin = 0;
  while (begin < rest_.size() && (isSpace(rest_[begin]) || isLineBreak(rest_[begin]))) ++begin;
  if (begin == rest_.size()) {
    rest_ = {};
    return false;
  }
  size_t end = begin;
  while (end < rest_.size() && !isSpace(rest_[end]) && !isLineBreak(rest_[end])) ++end;
  token = rest_.substr(begin, end - begin);
  rest_ = rest_.substr(end);
  return true;
}

bool TokenStream::next(std::string_view& token) {
  while (offset_ < text_.size()) {
    char c = text_[offset_];
    if (c == '\n') {
      ++line_;
    } else if (c == '\r') {
      // A CR followed by LF is counted once, at the LF.
      if (offset_ + 1 >= text_.size() || text_[offset_ + 1] != '\n') ++line_;
    } else if (!isSpace(c)) {
      break;
    }
    ++offset_;
  }
  token_line_ = line_;
  if (offset_ >= text_.size()) return false;
  size_t begin = offset_;
  while (offset_ < text_.size() && !isSpace(text_[offset_]) && !isLineBreak(text_[offset_])) {
    ++offset_;
  }
  token = text_.substr(begin, offset_ - begin);
  return true;
}

namespace {

// std::from_chars rejects a leading '+', which OBJ files written by some tools use.
std::string_view stripPlus(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') {
    return token.substr(1);
  }
  return token;
}

bool hasNegativeExponent(std::string_view token) {
  return token.find("e-") != std::string_view::npos || token.find("E-") != std::string_view::npos;
}

}  // namespace

bool parseDouble(std::string_view token, double& value) {
  token = stripPlus(token);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  auto [ptr, ec] = std::from_chars(token.data(), end, value);
  if (ptr != end) return false;
  if (ec == std::errc::result_out_of_range) {
    // from_chars reports both underflow and overflow this way and leaves value unspecified.
    bool negative = token[0] == '-';
    value = hasNegativeExponent(token) ? 0.0 : (negative ? -HUGE_VAL : HUGE_VAL);
    return true;
  }
  return ec == std::errc();
}

bool parseFloat(std::string_view token, float& value) {
  double wide = 0;
  if (!parseDouble(token, wide)) return false;
  // Values beyond float range become +-inf here, which callers reject as non-finite.
  value = static_cast<float>(wide);
  return true;
}

bool parseInt(std::string_view token, int64_t& value) {
  token = stripPlus(token);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  auto [ptr, ec] = std::from_chars(token.data(), end, value);
  return ec == std::errc() && ptr == end;
}

bool parseUint(std::string_view token, uint64_t& value) {
  token = stripPlus(token);
  if (token.empty() || token[0] == '-') return false;
  const char* end = token.data() + token.size();
  auto [ptr, ec] = std::from_chars(token.data(), end, value);
  return ec == std::errc() && ptr == end;
}

std::string quote(std::string_view token) {
  constexpr size_t kMaxShown = 40;  // long enough to recognise a token, short enough for one line
  std::string out = "'";
  for (size_t i = 0; i < token.size() && i < kMaxShown; ++i) {
    unsigned char c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7F) {
      out += static_cast<char>(c);
    } else {
      char buffer[8];
      std::snprintf(buffer, sizeof(buffer), "\\x%02X", c);
      out += buffer;
    }
  }
  if (token.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

core::Error errorAt(std::string_view path, size_t line, std::string_view message) {
  std::string text(path);
  text += ':';
  text += std::to_string(line);
  text += ": ";
  text += message;
  return core::Error{std::move(text)};
}

core::Error errorIn(std::string_view path, std::string_view message) {
  std::string text(path);
  text += ": ";
  text += message;
  return core::Error{std::move(text)};
}

core::Result<std::vector<uint8_t>> readInputFile(const std::string& path) {
  auto bytes = readFileBytes(path);
  if (!bytes && bytes.error().message.find(path) == std::string::npos) {
    return errorIn(path, bytes.error().message);
  }
  return bytes;
}

void appendFanCorners(size_t n, std::vector<uint32_t>& triangles) {
  for (uint32_t i = 1; i + 1 < n; ++i) triangles.insert(triangles.end(), {0, i, i + 1});
}

bool triangulatePolygon(std::span<const core::Vec3> corners, std::vector<uint32_t>& triangles) {
  const size_t count = corners.size();
  if (count <= 3) {
    appendFanCorners(count, triangles);
    return true;
  }
  auto fanned = [&](bool simple) {
    appendFanCorners(count, triangles);
    return simple;
  };
  // The distinct corners: a corner repeated right after itself adds a zero-length edge, whose
  // zero turn would hide a notch from the convexity test.
  std::vector<uint32_t> kept;
  kept.reserve(count);
  for (uint32_t k = 0; k < count; ++k)
    if (kept.empty() || !(corners[k] == corners[kept.back()])) kept.push_back(k);
  while (kept.size() > 1 && corners[kept.back()] == corners[kept.front()]) kept.pop_back();
  const size_t n = kept.size();
  if (n < 3) return fanned(false);
  // The Newell normal (the polygon's area vector, whatever its shape), in double.
  double normal[3] = {0, 0, 0};
  for (size_t i = 0; i < n; ++i) {
    const core::Vec3 a = corners[kept[i]], b = corners[kept[(i + 1) % n]];
    normal[0] += (double(a.y) - b.y) * (double(a.z) + b.z);
    normal[1] += (double(a.z) - b.z) * (double(a.x) + b.x);
    normal[2] += (double(a.x) - b.x) * (double(a.y) + b.y);
  }
  // Projected along the normal's largest axis, the polygon turns counter-clockwise in (u, v)
  // when that component is positive.
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(normal[k]) > std::abs(normal[axis])) axis = k;
  if (!(std::abs(normal[axis]) > 0) || !std::isfinite(normal[axis])) return fanned(false);
  const int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
  const double turn = normal[axis] > 0 ? 1.0 : -1.0;
  std::vector<double> u(n), v(n);
  for (size_t i = 0; i < n; ++i) {
    const float* p = &corners[kept[i]].x;
    u[i] = p[u_axis], v[i] = p[v_axis];
  }
  // Twice the signed area of (a, b, c), positive when it turns as the polygon does; and what
  // counts as straight (a turn below 1e-5 radians): rounding leaves a corner on an edge (a
  // T-junction) of a tilted polygon a small turn either way, which must not make a convex
  // polygon concave (a file's 6 decimals: ~1e-6 of an edge).
  auto area = [&](size_t a, size_t b, size_t c) {
    return turn * ((u[b] - u[a]) * (v[c] - v[a]) - (v[b] - v[a]) * (u[c] - u[a]));
  };
  auto straight = [&](size_t a, size_t b, size_t c) {
    return 1e-5 * std::hypot(u[b] - u[a], v[b] - v[a]) * std::hypot(u[c] - u[b], v[c] - v[b]);
  };
  bool convex = true;
  for (size_t i = 0; i < n && convex; ++i) {
    const size_t a = (i + n - 1) % n, c = (i + 1) % n;
    convex = area(a, i, c) >= -straight(a, i, c);
  }
  if (convex && n >= 5) {
    // Every turn the same way, but around twice or more (a pentagram): the turns must add up to
    // one full turn.
    double total = 0;
    for (size_t i = 0; i < n; ++i) {
      const size_t a = (i + n - 1) % n, c = (i + 1) % n;
      const double du0 = u[i] - u[a], dv0 = v[i] - v[a], du1 = u[c] - u[i], dv1 = v[c] - v[i];
      total += std::atan2(turn * (du0 * dv1 - dv0 * du1), du0 * du1 + dv0 * dv1);
    }
    if (total > 3 * M_PI) return fanned(false);
  }
  if (convex) return fanned(true);  // as every reader wrote before (exact here)
  if (n > kMaxClippedCorners) return fanned(false);
  // Ear clipping: a corner whose triangle with its two neighbours turns the polygon's way and
  // holds no other remaining corner is cut off; n - 2 cuts leave the triangles. A polygon
  // that crosses itself can run out of ears, or cut one outside itself (it touches itself at a
  // corner): it is then fanned, as before, and said so.
  std::vector<uint32_t> next(n), previous(n), cut;
  cut.reserve((n - 2) * 3);
  for (size_t i = 0; i < n; ++i)
    next[i] = uint32_t((i + 1) % n), previous[i] = uint32_t((i + n - 1) % n);
  auto inside = [&](size_t p, size_t a, size_t b, size_t c) {  // closed triangle
    return area(a, b, p) >= 0 && area(b, c, p) >= 0 && area(c, a, p) >= 0;
  };
  // relaxed: after a round without an ear, a corner on the line of its neighbours may go too
  // (a degenerate triangle, which the loader drops), so that collinear corners do not stop it.
  bool relaxed = false;
  auto is_ear = [&](uint32_t i) {
    const uint32_t a = previous[i], c = next[i];
    const double turned = area(a, i, c), tolerance = straight(a, i, c);
    if (!(turned > tolerance || (relaxed && turned >= -tolerance))) return false;
    for (uint32_t p = next[c]; p != a; p = next[p]) {
      // A corner at the same place as one of the ear's (a polygon touching itself) does not
      // block it.
      const bool shared = (u[p] == u[a] && v[p] == v[a]) || (u[p] == u[i] && v[p] == v[i]) ||
                          (u[p] == u[c] && v[p] == v[c]);
      if (!shared && inside(p, a, i, c)) return false;
    }
    return true;
  };
  size_t left = n;
  uint32_t i = 0;
  for (size_t misses = 0; left > 3;) {
    if (misses == left) {
      if (relaxed) break;
      relaxed = true, misses = 0;
    }
    if (is_ear(i)) {
      const uint32_t a = previous[i], c = next[i];
      cut.insert(cut.end(), {a, i, c});
      next[a] = c, previous[c] = a;
      --left;
      misses = 0, relaxed = false;
      i = c;
    } else {
      ++misses;
      i = next[i];
    }
  }
  if (left != 3) return fanned(false);
  cut.insert(cut.end(), {i, next[i], next[next[i]]});
  // Every triangle must turn the polygon's way (the ears do; the last one, left over, may not).
  for (size_t t = 0; t < cut.size(); t += 3)
    if (area(cut[t], cut[t + 1], cut[t + 2]) < -straight(cut[t], cut[t + 1], cut[t + 2]))
      return fanned(false);
  for (uint32_t corner : cut) triangles.push_back(kept[corner]);
  return true;
}

bool appendPolygon(std::span<const uint32_t> polygon, std::span<const core::Vec3> positions,
                   std::vector<uint32_t>& indices) {
  if (polygon.size() == 3) {
    indices.insert(indices.end(), polygon.begin(), polygon.end());
    return true;
  }
  std::vector<core::Vec3> corners(polygon.size());
  for (size_t k = 0; k < polygon.size(); ++k) {
    assert(polygon[k] < positions.size());
    corners[k] = positions[polygon[k]];
  }
  std::vector<uint32_t> triangles;
  const bool simple = triangulatePolygon(corners, triangles);
  for (uint32_t corner : triangles) indices.push_back(polygon[corner]);
  return simple;
}

void finishSingleMaterialAsset(core::Asset& asset) {
  core::Material material;
  material.name = "default";
  material.metallic_factor = 0.0f;  // glTF's default of 1 would make plain scans look metallic
  asset.materials.push_back(material);
  if (!asset.mesh.indices.empty()) {
    asset.mesh.submeshes.push_back({.first_index = 0,
                                    .index_count = static_cast<uint32_t>(asset.mesh.indices.size()),
                                    .material = 0});
  }
}

}  // namespace duolod::io::text
