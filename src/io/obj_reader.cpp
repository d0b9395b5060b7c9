// Wavefront OBJ reader, after "Object Files (.obj)" (Wavefront Advanced Visualizer manual,
// Appendix B1): v (with the common "v x y z r g b" colour extension), vt, vn, polygonal f with
// absolute and relative indices, usemtl and mtllib (see mtl_reader.cpp). Free-form geometry, points
// and lines are skipped with a warning.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <unordered_map>

#include "duolod/io.hpp"
#include "io/mtl_reader.hpp"
#include "io/text_parse.hpp"

namespace duolod::io {
namespace {

namespace fs = std::filesystem;
using core::Error;
using text::errorAt;
using text::quote;

constexpr int32_t kAbsent = -1;

// One polygon corner: 0-based indices into the v / vt / vn lists, kAbsent when not given.
struct Corner {
  int32_t position = kAbsent;
  int32_t texcoord = kAbsent;
  int32_t normal = kAbsent;
  bool operator==(const Corner&) const = default;
};

struct CornerHash {
  size_t operator()(const Corner& c) const {
    uint64_t h = static_cast<uint32_t>(c.position);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(c.texcoord);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(c.normal);
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

struct Triangle {
  Corner corners[3];
  size_t line = 0;  // of the face it came from, for range errors found after parsing
};

// Triangles that share a material, in file order. Submeshes must be contiguous in the index
// buffer, so faces are collected per material and concatenated at the end.
struct MaterialGroup {
  std::string name;
  bool from_usemtl = false;  // false: faces before any usemtl
  size_t first_line = 0;
  std::vector<Triangle> triangles;
};

// Statements that are valid OBJ but carry nothing a triangle mesh can use.
bool isIgnoredStatement(std::string_view keyword) {
  static constexpr std::string_view kIgnored[] = {
      "o",        "g",          "s",         "mg",    "vp",    "cstype", "deg",
      "bmat",     "step",       "curv",      "curv2", "surf",  "parm",   "trim",
      "hole",     "scrv",       "sp",        "end",   "con",   "lod",    "maplib",
      "usemap",   "shadow_obj", "trace_obj", "ctech", "stech", "bevel",  "c_interp",
      "d_interp", "call",       "scmp",      "csh",   "res"};
  for (std::string_view ignored : kIgnored) {
    if (keyword == ignored) return true;
  }
  return false;
}

bool isPrintableKeyword(std::string_view keyword) {
  for (char c : keyword) {
    if (c < 0x21 || c > 0x7E) return false;
  }
  return true;
}

class ObjParser {
 public:
  ObjParser(const std::string& path, const LoadOptions& options, core::Asset& asset)
      : path_(path), options_(options), asset_(asset) {}

  core::Status parse(std::string_view content) {
    if (content.find('\0') != std::string_view::npos) {
      return text::errorIn(path_, "not a text file (contains NUL bytes; binary or UTF-16?)");
    }
    text::LineReader lines(content);
    std::string_view line;
    std::string joined;  // a statement continued over lines with a trailing backslash
    while (lines.next(line)) {
      line_ = lines.lineNumber();
      if (!line.empty() && line.back() == '\\') {
        joined.assign(line.substr(0, line.size() - 1));
        std::string_view more;
        while (!joined.empty() && lines.next(more)) {
          bool continues = !more.empty() && more.back() == '\\';
          joined += ' ';
          joined.append(more.substr(0, more.size() - (continues ? 1 : 0)));
          if (!continues) break;
        }
        line = joined;
      }
      text::Tokens tokens(line);
      std::string_view keyword;
      if (!tokens.next(keyword) || keyword[0] == '#') continue;
      if (auto status = parseStatement(keyword, tokens); !status) return status;
    }
    return finish();
  }

 private:
  core::Status parseStatement(std::string_view keyword, text::Tokens& tokens) {
    if (keyword == "v") return parseVertex(tokens);
    if (keyword == "vt") return parseTexcoord(tokens);
    if (keyword == "vn") return parseNormal(tokens);
    if (keyword == "f" || keyword == "fo") return parseFace(tokens);
    if (keyword == "usemtl") {
      useMaterial(tokens.rest());
      return core::okStatus();
    }
    if (keyword == "mtllib") return loadMaterialLibraries(tokens.rest());
    if (keyword == "l" || keyword == "p") {
      ++ignored_points_and_lines_;
      return core::okStatus();
    }
    if (isIgnoredStatement(keyword)) return core::okStatus();
    if (!isPrintableKeyword(keyword)) {
      return errorAt(path_, line_, "not an OBJ statement: " + quote(keyword) + " (binary data?)");
    }
    ++unknown_statements_;
    if (first_unknown_.empty()) first_unknown_ = std::string(keyword);
    return core::okStatus();
  }

  // Reads up to `capacity` numbers; a '#' token starts a trailing comment.
  core::Result<int> parseNumbers(std::string_view keyword, text::Tokens& tokens, float* values,
                                 int capacity) {
    int count = 0;
    std::string_view token;
    while (tokens.next(token)) {
      if (token[0] == '#') break;
      float value = 0;
      if (!text::parseFloat(token, value)) {
        return errorAt(
            path_, line_,
            "expected a number in '" + std::string(keyword) + "' statement, got " + quote(token));
      }
      if (!std::isfinite(value)) {
        return errorAt(
            path_, line_,
            "non-finite value " + quote(token) + " in '" + std::string(keyword) + "' statement");
      }
      if (count < capacity) values[count] = value;
      ++count;
    }
    return std::min(count, capacity);
  }

  core::Status parseVertex(text::Tokens& tokens) {
    float values[7] = {};
    auto count = parseNumbers("v", tokens, values, 7);
    if (!count) return count.error();
    if (*count < 3) {
      return errorAt(path_, line_,
                     "vertex " + std::to_string(positions_.size() + 1) + " has " +
                         std::to_string(*count) + " coordinates (3 needed)");
    }
    positions_.push_back({values[0], values[1], values[2]});
    // "v x y z w" has a weight we ignore; "v x y z r g b" is the common colour extension.
    if (*count >= 6) {
      if (colors_.empty()) colors_.assign(positions_.size() - 1, core::Vec4{1, 1, 1, 1});
      colors_.push_back({values[3], values[4], values[5], 1.0f});
    } else if (!colors_.empty()) {
      colors_.push_back({1, 1, 1, 1});
    }
    return core::okStatus();
  }

  core::Status parseTexcoord(text::Tokens& tokens) {
    float values[3] = {};
    auto count = parseNumbers("vt", tokens, values, 3);
    if (!count) return count.error();
    if (*count < 1) return errorAt(path_, line_, "texture coordinate without values");
    // OBJ's v points up (origin bottom-left); ours points down (origin top-left), as in glTF.
    texcoords_.push_back({values[0], 1.0f - values[1]});
    return core::okStatus();
  }

  core::Status parseNormal(text::Tokens& tokens) {
    float values[3] = {};
    auto count = parseNumbers("vn", tokens, values, 3);
    if (!count) return count.error();
    if (*count < 3) {
      return errorAt(path_, line_,
                     "normal " + std::to_string(normals_.size() + 1) + " has " +
                         std::to_string(*count) + " components (3 needed)");
    }
    normals_.push_back({values[0], values[1], values[2]});
    return core::okStatus();
  }

  // One index of a corner ("7", "-1", or "" when omitted as in "7//3"). Relative (negative)
  // indices count back from the elements defined so far; positive ones are range-checked after
  // the whole file is read, since nothing forbids a face from preceding its vertices.
  core::Result<int32_t> parseIndex(std::string_view token, std::string_view part, size_t defined,
                                   const char* what) {
    if (part.empty()) return kAbsent;
    int64_t index = 0;
    if (!text::parseInt(part, index)) {
      return errorAt(path_, line_,
                     "bad face vertex " + quote(token) + " (" + what + " index is not an integer)");
    }
    if (index == 0) {
      return errorAt(path_, line_,
                     "face vertex " + quote(token) + " uses index 0 (OBJ indices start at 1)");
    }
    if (index < 0) {
      index += static_cast<int64_t>(defined);
      if (index < 0) {
        return errorAt(path_, line_,
                       "relative " + std::string(what) + " index in " + quote(token) +
                           " points before the first (" + std::to_string(defined) +
                           " defined so far)");
      }
      return static_cast<int32_t>(index);
    }
    if (index > INT32_MAX) {
      return errorAt(path_, line_, "face index " + std::to_string(index) + " out of range");
    }
    return static_cast<int32_t>(index - 1);
  }

  core::Status parseFace(text::Tokens& tokens) {
    polygon_.clear();
    std::string_view token;
    while (tokens.next(token)) {
      if (token[0] == '#') break;
      std::string_view parts[3];
      int part_count = 0;
      size_t start = 0;
      while (true) {
        size_t slash = token.find('/', start);
        if (part_count == 3) {
          return errorAt(path_, line_, "bad face vertex " + quote(token) + " (too many '/')");
        }
        parts[part_count++] = token.substr(
            start, slash == std::string_view::npos ? std::string_view::npos : slash - start);
        if (slash == std::string_view::npos) break;
        start = slash + 1;
      }
      if (parts[0].empty()) {
        return errorAt(path_, line_, "bad face vertex " + quote(token) + " (no position index)");
      }
      auto position = parseIndex(token, parts[0], positions_.size(), "position");
      if (!position) return position.error();
      auto texcoord = parseIndex(token, parts[1], texcoords_.size(), "texture coordinate");
      if (!texcoord) return texcoord.error();
      auto normal = parseIndex(token, parts[2], normals_.size(), "normal");
      if (!normal) return normal.error();
      polygon_.push_back({*position, *texcoord, *normal});
    }
    if (polygon_.size() < 3) {
      return errorAt(
          path_, line_,
          "face has " + std::to_string(polygon_.size()) + " vertices (at least 3 needed)");
    }
    MaterialGroup& group = currentGroup();
    // A fan for convex polygons (what exporters write), ears for concave ones
    // (text::triangulatePolygon).
    if (polygon_.size() == 3) {
      group.triangles.push_back({{polygon_[0], polygon_[1], polygon_[2]}, line_});
      return core::okStatus();
    }
    // Positive indices are range-checked after the file (a face may come before its vertices):
    // such a polygon is fanned for now and cut up in finish(), when its corners are known.
    bool placed = true;
    for (size_t k = 0; k < polygon_.size() && placed; ++k)
      placed = static_cast<size_t>(polygon_[k].position) < positions_.size();
    if (!placed) {
      deferred_.push_back({current_group_, group.triangles.size(), line_, polygon_});
      polygon_triangles_.clear();
      text::appendFanCorners(polygon_.size(), polygon_triangles_);
      appendTriangles(polygon_, polygon_triangles_, line_, group.triangles);
      return core::okStatus();
    }
    if (!triangulate(polygon_) && !first_unclipped_line_) first_unclipped_line_ = line_;
    appendTriangles(polygon_, polygon_triangles_, line_, group.triangles);
    return core::okStatus();
  }

  // Cuts `polygon` (every corner placed) into polygon_triangles_; triangulatePolygon's answer.
  bool triangulate(const std::vector<Corner>& polygon) {
    polygon_points_.resize(polygon.size());
    for (size_t k = 0; k < polygon.size(); ++k)
      polygon_points_[k] = positions_[polygon[k].position];
    polygon_triangles_.clear();
    return text::triangulatePolygon(polygon_points_, polygon_triangles_);
  }

  static void appendTriangles(const std::vector<Corner>& polygon,
                              const std::vector<uint32_t>& triangles, size_t line,
                              std::vector<Triangle>& out) {
    for (size_t i = 0; i < triangles.size(); i += 3)
      out.push_back(
          {{polygon[triangles[i]], polygon[triangles[i + 1]], polygon[triangles[i + 2]]}, line});
  }

  // The polygons that came before their vertices, now that every vertex is read: their fans are
  // replaced by what triangulatePolygon makes of them, in place (last first, so that the earlier
  // ones' places in their group do not move). One whose corners are still out of range stays
  // fanned: the range check then refuses it.
  void triangulateDeferred() {
    for (auto it = deferred_.rbegin(); it != deferred_.rend(); ++it) {
      bool placed = true;
      for (const Corner& corner : it->polygon)
        placed &= static_cast<size_t>(corner.position) < positions_.size();
      if (!placed) continue;
      if (!triangulate(it->polygon) && (!first_unclipped_line_ || it->line < first_unclipped_line_))
        first_unclipped_line_ = it->line;
      std::vector<Triangle> cut;
      appendTriangles(it->polygon, polygon_triangles_, it->line, cut);
      std::vector<Triangle>& triangles = groups_[it->group].triangles;
      const auto first = triangles.begin() + static_cast<std::ptrdiff_t>(it->first_triangle);
      const auto fanned = static_cast<std::ptrdiff_t>(it->polygon.size() - 2);
      triangles.insert(triangles.erase(first, first + fanned), cut.begin(), cut.end());
    }
    deferred_.clear();
  }

  MaterialGroup& currentGroup() {
    if (current_group_ == kNoGroup) {
      groups_.push_back(
          {.name = "default", .from_usemtl = false, .first_line = line_, .triangles = {}});
      current_group_ = groups_.size() - 1;
    }
    return groups_[current_group_];
  }

  void useMaterial(std::string_view name) {
    auto [found, inserted] = group_by_name_.try_emplace(std::string(name), groups_.size());
    if (inserted) {
      groups_.push_back(
          {.name = std::string(name), .from_usemtl = true, .first_line = line_, .triangles = {}});
    }
    current_group_ = found->second;
  }

  // "mtllib a.mtl b.mtl"; names with spaces are common too, so the whole rest of the line is tried
  // first as one file name.
  core::Status loadMaterialLibraries(std::string_view rest) {
    if (rest.empty()) return errorAt(path_, line_, "mtllib without a file name");
    fs::path folder = fs::path(path_).parent_path();
    auto resolve = [&](std::string_view written) {
      std::string portable(written);
      for (char& c : portable) {
        if (c == '\\') c = '/';
      }
      return (folder / portable).lexically_normal().string();
    };
    std::vector<std::string_view> names;
    std::error_code ec;
    if (fs::is_regular_file(resolve(rest), ec)) {
      names.push_back(rest);
    } else {
      text::Tokens tokens(rest);
      std::string_view token;
      while (tokens.next(token)) names.push_back(token);
    }
    for (std::string_view written : names) {
      std::string mtl_path = resolve(written);
      if (!fs::is_regular_file(mtl_path, ec)) {
        asset_.warnings.push_back(errorAt(path_, line_,
                                          "material library " + quote(written) +
                                              " not found (looked for " + mtl_path +
                                              "); default materials used")
                                      .message);
        continue;
      }
      auto bytes = text::readInputFile(mtl_path);
      if (!bytes) return bytes.error();
      asset_.source_files.push_back(mtl_path);
      if (auto status =
              mtl::parseMtl(mtl_path, text::asText(*bytes), mtl_materials_, asset_.warnings);
          !status) {
        return status;
      }
    }
    return core::okStatus();
  }

  core::Status checkCorner(const Corner& corner, size_t line) const {
    auto outOfRange = [&](int32_t index, size_t count, const char* what, const char* plural) {
      return errorAt(path_, line,
                     std::string(what) + " index " + std::to_string(index + 1LL) +
                         " out of range (" + std::to_string(count) + " " + plural + ")");
    };
    if (static_cast<size_t>(corner.position) >= positions_.size()) {
      return outOfRange(corner.position, positions_.size(), "face", "positions");
    }
    if (corner.texcoord != kAbsent && static_cast<size_t>(corner.texcoord) >= texcoords_.size()) {
      return outOfRange(corner.texcoord, texcoords_.size(), "texture coordinate", "texcoords");
    }
    if (corner.normal != kAbsent && static_cast<size_t>(corner.normal) >= normals_.size()) {
      return outOfRange(corner.normal, normals_.size(), "normal", "normals");
    }
    return core::okStatus();
  }

  core::Status finish() {
    triangulateDeferred();
    // Range checks, and which attribute streams the mesh gets.
    size_t corners = 0, corners_with_uv = 0, corners_with_normal = 0;
    for (const MaterialGroup& group : groups_) {
      for (const Triangle& triangle : group.triangles) {
        for (const Corner& corner : triangle.corners) {
          if (auto status = checkCorner(corner, triangle.line); !status) return status;
          corners_with_uv += corner.texcoord != kAbsent;
          corners_with_normal += corner.normal != kAbsent;
        }
        corners += 3;
      }
    }
    if (corners > UINT32_MAX) return text::errorIn(path_, "too many triangles (over 2^32 corners)");
    bool use_uv = corners_with_uv > 0;
    // A normal stream must be complete; with some corners lacking one, loadAsset recomputes all.
    bool use_normals = corners_with_normal > 0 && corners_with_normal == corners;
    if (use_uv && corners_with_uv < corners) {
      asset_.warnings.push_back(path_ + ": " + std::to_string(corners - corners_with_uv) +
                                " face corners have no texture coordinate; (0, 0) used");
    }
    if (corners_with_normal > 0 && !use_normals) {
      asset_.warnings.push_back(path_ + ": " + std::to_string(corners - corners_with_normal) +
                                " face corners have no normal; file normals dropped");
    }
    if (first_unclipped_line_ > 0) {
      asset_.warnings.push_back(
          errorAt(path_, first_unclipped_line_,
                  "a polygon " + text::kUnclippedPolygon + " (the first of them)")
              .message);
    }
    if (ignored_points_and_lines_ > 0) {
      asset_.warnings.push_back(path_ + ": " + std::to_string(ignored_points_and_lines_) +
                                " point/line statements (p, l) ignored");
    }
    if (unknown_statements_ > 0) {
      asset_.warnings.push_back(path_ + ": " + std::to_string(unknown_statements_) +
                                " unknown statements ignored (first: " + quote(first_unknown_) +
                                ")");
    }

    // Materials, in order of first use, for the groups that have faces.
    std::map<std::string, size_t> mtl_by_name;
    for (size_t i = 0; i < mtl_materials_.size(); ++i) mtl_by_name[mtl_materials_[i].name] = i;
    std::map<std::string, int> texture_by_key;
    std::vector<const MaterialGroup*> used;
    for (const MaterialGroup& group : groups_) {
      if (group.triangles.empty()) continue;
      used.push_back(&group);
      auto found = group.from_usemtl ? mtl_by_name.find(group.name) : mtl_by_name.end();
      if (found == mtl_by_name.end()) {
        if (group.from_usemtl) {
          asset_.warnings.push_back(errorAt(path_, group.first_line,
                                            "material " + quote(group.name) +
                                                " is not defined in any material library; "
                                                "default material used")
                                        .message);
        }
        asset_.materials.push_back(mtl::defaultMaterial(group.name));
        continue;
      }
      auto material =
          mtl::buildMaterial(mtl_materials_[found->second], options_, asset_, texture_by_key);
      if (!material) return material.error();
      asset_.materials.push_back(std::move(material).value());
    }
    if (asset_.materials.empty()) asset_.materials.push_back(mtl::defaultMaterial("default"));

    // One vertex per distinct (v, vt, vn) corner, in order of first use.
    core::Mesh& mesh = asset_.mesh;
    std::unordered_map<Corner, uint32_t, CornerHash> vertex_by_corner;
    vertex_by_corner.reserve(std::min(corners, positions_.size() * 2));
    mesh.indices.reserve(corners);
    for (size_t m = 0; m < used.size(); ++m) {
      core::Submesh submesh{.first_index = static_cast<uint32_t>(mesh.indices.size()),
                            .index_count = 0,
                            .material = static_cast<uint32_t>(m)};
      for (const Triangle& triangle : used[m]->triangles) {
        for (Corner corner : triangle.corners) {
          if (!use_uv) corner.texcoord = kAbsent;
          if (!use_normals) corner.normal = kAbsent;
          auto [found, inserted] =
              vertex_by_corner.try_emplace(corner, static_cast<uint32_t>(mesh.positions.size()));
          if (inserted) {
            mesh.positions.push_back(positions_[corner.position]);
            if (use_uv) {
              mesh.uv0.push_back(corner.texcoord == kAbsent ? core::Vec2{0, 0}
                                                            : texcoords_[corner.texcoord]);
            }
            if (use_normals) mesh.normals.push_back(normals_[corner.normal]);
            if (!colors_.empty()) mesh.colors.push_back(colors_[corner.position]);
          }
          mesh.indices.push_back(found->second);
        }
      }
      submesh.index_count = static_cast<uint32_t>(mesh.indices.size()) - submesh.first_index;
      mesh.submeshes.push_back(submesh);
    }
    return core::okStatus();
  }

  static constexpr size_t kNoGroup = SIZE_MAX;

  const std::string& path_;
  const LoadOptions& options_;
  core::Asset& asset_;
  size_t line_ = 0;

  std::vector<core::Vec3> positions_;
  std::vector<core::Vec4> colors_;  // empty, or one per position
  std::vector<core::Vec2> texcoords_;
  std::vector<core::Vec3> normals_;
  std::vector<Corner> polygon_;  // scratch for the face being read
  std::vector<core::Vec3> polygon_points_;   // its corners' positions
  // Polygons of more than three corners read before some of their vertices (triangulateDeferred):
  // their group, where their fan starts in it, their line and their corners.
  struct DeferredPolygon {
    size_t group = 0, first_triangle = 0, line = 0;
    std::vector<Corner> polygon;
  };
  std::vector<DeferredPolygon> deferred_;
  std::vector<uint32_t> polygon_triangles_;  // its triangles, as corner numbers
  size_t first_unclipped_line_ = 0;  // the first polygon not cut into ears (triangulatePolygon)

  std::vector<MaterialGroup> groups_;
  std::map<std::string, size_t> group_by_name_;
  size_t current_group_ = kNoGroup;
  std::vector<mtl::MtlMaterial> mtl_materials_;

  size_t ignored_points_and_lines_ = 0;
  size_t unknown_statements_ = 0;
  std::string first_unknown_;
};

}  // namespace

core::Result<core::Asset> readObj(const std::string& path, const LoadOptions& options) {
  auto bytes = text::readInputFile(path);
  if (!bytes) return bytes.error();
  core::Asset asset;
  asset.source_path = path;
  ObjParser parser(path, options, asset);
  if (auto status = parser.parse(text::asText(*bytes)); !status) return status.error();
  return asset;
}

}  // namespace duolod::io
