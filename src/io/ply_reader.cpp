// PLY reader (ascii, binary_little_endian, binary_big_endian), after Greg Turk, "The PLY Polygon
// File Format" (1994) as documented by Paul Bourke: element vertex (x y z, nx ny nz, s t / u v /
// texture_u texture_v, red green blue alpha) and element face (list vertex_indices); every other
// element and property is skipped by its declared type. Elements may come in any order: faces
// read before the vertices are triangulated once the vertices are. Header counts are never
// trusted for allocation: each is checked against the bytes left in the file first.
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>

#include "duolod/io.hpp"
#include "io/text_parse.hpp"

namespace duolod::io {
namespace {

using core::Error;
using text::errorAt;
using text::errorIn;
using text::quote;

enum class ScalarType : uint8_t {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64
};

size_t scalarSize(ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
    case ScalarType::kUint8:
      return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16:
      return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32:
      return 4;
    case ScalarType::kFloat64:
      return 8;
  }
  return 1;
}

bool isInteger(ScalarType type) {
  return type != ScalarType::kFloat32 && type != ScalarType::kFloat64;
}

// Both the 1994 names and the sized names (int8, float32, ...) written by newer tools.
std::optional<ScalarType> parseScalarType(std::string_view name) {
  struct Named {
    std::string_view name;
    ScalarType type;
  };
  static constexpr Named kTypes[] = {
      {"char", ScalarType::kInt8},      {"int8", ScalarType::kInt8},
      {"uchar", ScalarType::kUint8},    {"uint8", ScalarType::kUint8},
      {"short", ScalarType::kInt16},    {"int16", ScalarType::kInt16},
      {"ushort", ScalarType::kUint16},  {"uint16", ScalarType::kUint16},
      {"int", ScalarType::kInt32},      {"int32", ScalarType::kInt32},
      {"uint", ScalarType::kUint32},    {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32},  {"float32", ScalarType::kFloat32},
      {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64},
  };
  for (const Named& named : kTypes) {
    if (named.name == name) return named.type;
  }
  return std::nullopt;
}

// What a vertex property means to us.
enum class Role : uint8_t { kNone, kX, kY, kZ, kNx, kNy, kNz, kU, kV, kRed, kGreen, kBlue, kAlpha };
constexpr int kRoleCount = 13;

Role roleOf(std::string_view name) {
  struct Named {
    std::string_view name;
    Role role;
  };
  static constexpr Named kRoles[] = {
      {"x", Role::kX},
      {"y", Role::kY},
      {"z", Role::kZ},
      {"nx", Role::kNx},
      {"ny", Role::kNy},
      {"nz", Role::kNz},
      {"s", Role::kU},
      {"t", Role::kV},
      {"u", Role::kU},
      {"v", Role::kV},
      {"texture_u", Role::kU},
      {"texture_v", Role::kV},
      {"texture_s", Role::kU},
      {"texture_t", Role::kV},
      {"red", Role::kRed},
      {"green", Role::kGreen},
      {"blue", Role::kBlue},
      {"alpha", Role::kAlpha},
      {"diffuse_red", Role::kRed},
      {"diffuse_green", Role::kGreen},
      {"diffuse_blue", Role::kBlue},
      {"diffuse_alpha", Role::kAlpha},
  };
  for (const Named& named : kRoles) {
    if (named.name == name) return named.role;
  }
  return Role::kNone;
}

struct Property {
  std::string name;
  ScalarType type = ScalarType::kFloat32;  // of the items, for a list
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;
  Role role = Role::kNone;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
  size_t line = 0;

  // Smallest encoding of one item: binary bytes (an empty list is just its count), or ascii
  // tokens (each at least one byte).
  size_t minimumBinarySize() const {
    size_t size = 0;
    for (const Property& p : properties) size += scalarSize(p.is_list ? p.count_type : p.type);
    return size;
  }
  bool hasList() const {
    for (const Property& p : properties) {
      if (p.is_list) return true;
    }
    return false;
  }
};

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  size_t body_offset = 0;
  size_t body_line = 0;  // line number where the body starts (ascii)
};

core::Result<Header> parseHeader(const std::string& path, std::string_view content,
                                 std::vector<std::string>& warnings) {
  text::LineReader lines(content);
  std::string_view line;
  if (!lines.next(line) || text::trim(line) != "ply") {
    return errorIn(path, "not a PLY file (it does not start with 'ply')");
  }
  Header header;
  bool have_format = false;
  size_t unknown_lines = 0;
  while (true) {
    if (!lines.next(line)) return errorIn(path, "header has no 'end_header' line");
    size_t line_number = lines.lineNumber();
    if (line.find('\0') != std::string_view::npos) {
      return errorAt(path, line_number, "binary data inside the header (no 'end_header'?)");
    }
    text::Tokens tokens(line);
    std::string_view keyword;
    if (!tokens.next(keyword)) continue;
    if (keyword == "end_header") break;
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      std::string_view format;
      tokens.next(format);
      if (format == "ascii") {
        header.format = Format::kAscii;
      } else if (format == "binary_little_endian") {
        header.format = Format::kBinaryLittleEndian;
      } else if (format == "binary_big_endian") {
        header.format = Format::kBinaryBigEndian;
      } else {
        return errorAt(path, line_number, "unknown format " + quote(format));
      }
      have_format = true;
    } else if (keyword == "element") {
      Element element;
      std::string_view name, count;
      if (!tokens.next(name) || !tokens.next(count) || !text::parseUint(count, element.count)) {
        return errorAt(path, line_number, "bad element line (expected 'element NAME COUNT')");
      }
      element.name = std::string(name);
      element.line = line_number;
      for (const Element& other : header.elements) {
        if (other.name == element.name && (name == "vertex" || name == "face")) {
          return errorAt(path, line_number, "second '" + element.name + "' element");
        }
      }
      header.elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header.elements.empty()) {
        return errorAt(path, line_number, "property before any element");
      }
      Property property;
      std::string_view type, name;
      if (!tokens.next(type)) return errorAt(path, line_number, "property without a type");
      if (type == "list") {
        std::string_view count_type, item_type;
        tokens.next(count_type);
        tokens.next(item_type);
        auto counted = parseScalarType(count_type);
        auto item = parseScalarType(item_type);
        if (!counted || !item) {
          return errorAt(path, line_number,
                         "bad list property types " + quote(count_type) + " " + quote(item_type));
        }
        if (!isInteger(*counted)) {
          return errorAt(path, line_number,
                         "list count type " + quote(count_type) + " is not an integer type");
        }
        property.is_list = true;
        property.count_type = *counted;
        property.type = *item;
      } else {
        auto scalar = parseScalarType(type);
        if (!scalar) return errorAt(path, line_number, "unknown property type " + quote(type));
        property.type = *scalar;
      }
      if (!tokens.next(name)) return errorAt(path, line_number, "property without a name");
      property.name = std::string(name);
      // (Which of two 'x' columns is the position is anyone's guess.)
      for (const Property& other : header.elements.back().properties)
        if (other.name == property.name)
          return errorAt(path, line_number,
                         "property '" + property.name + "' declared twice in element '" +
                             header.elements.back().name + "'");
      header.elements.back().properties.push_back(std::move(property));
    } else {
      for (char c : keyword) {
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) {
          return errorAt(path, line_number, "binary data inside the header (no 'end_header'?)");
        }
      }
      ++unknown_lines;  // e.g. Blender 2.4's "Created by Blender3D ..." without "comment"
    }
  }
  if (!have_format) return errorIn(path, "header has no 'format' line");
  if (unknown_lines > 0) {
    warnings.push_back(path + ": " + std::to_string(unknown_lines) +
                       " unknown header line(s) ignored");
  }
  header.body_offset = lines.offset();
  header.body_line = lines.lineNumber() + 1;
  return header;
}

// Reads the body one scalar at a time, from ascii tokens or binary bytes, and knows where it is
// (element, item, property) for messages.
class BodyReader {
 public:
  BodyReader(const std::string& path, const Header& header, std::string_view content)
      : path_(path),
        format_(header.format),
        bytes_(reinterpret_cast<const uint8_t*>(content.data())),
        size_(content.size()),
        offset_(header.body_offset),
        tokens_(content.substr(header.body_offset), header.body_line) {}

  size_t bytesLeft() const {
    return format_ == Format::kAscii ? tokens_.bytesLeft() : size_ - offset_;
  }
  bool ascii() const { return format_ == Format::kAscii; }

  void at(const Element* element, uint64_t item, const Property* property) {
    element_ = element;
    item_ = item;
    property_ = property;
  }

  // "path:LINE: element 'face' item 3, property 'vertex_indices': reason" (ascii) or
  // "path: element 'face' item 3, property 'vertex_indices' (byte 1234): reason" (binary).
  Error error(std::string_view reason) const {
    std::string where = "element '" + element_->name + "' item " + std::to_string(item_);
    if (property_) where += ", property '" + property_->name + "'";
    if (ascii()) return errorAt(path_, tokens_.lineNumber(), where + ": " + std::string(reason));
    return errorIn(path_,
                   where + " (byte " + std::to_string(offset_) + "): " + std::string(reason));
  }

  core::Status read(ScalarType type, double& value) {
    if (ascii()) {
      std::string_view token;
      if (!tokens_.next(token)) return error("file ends early (truncated?)");
      if (!isInteger(type)) {
        if (!text::parseDouble(token, value))
          return error("expected a number, got " + quote(token));
        return core::okStatus();
      }
      int64_t integer = 0;
      if (!text::parseInt(token, integer)) return error("expected an integer, got " + quote(token));
      if (!fitsInteger(type, integer)) {
        return error("value " + std::to_string(integer) + " does not fit the declared type");
      }
      value = static_cast<double>(integer);
      return core::okStatus();
    }
    size_t size = scalarSize(type);
    if (size_ - offset_ < size) return error("file ends early (truncated?)");
    uint8_t raw[8];
    std::memcpy(raw, bytes_ + offset_, size);
    offset_ += size;
    bool swap = (format_ == Format::kBinaryBigEndian) != (std::endian::native == std::endian::big);
    if (swap) {
      for (size_t i = 0; i < size / 2; ++i) std::swap(raw[i], raw[size - 1 - i]);
    }
    value = decode(type, raw);
    return core::okStatus();
  }

  // Skips n scalars of one type (unknown list properties).
  core::Status skip(ScalarType type, uint64_t n) {
    if (ascii()) {
      std::string_view token;
      for (uint64_t i = 0; i < n; ++i) {
        if (!tokens_.next(token)) return error("file ends early (truncated?)");
      }
      return core::okStatus();
    }
    if (n > (size_ - offset_) / scalarSize(type)) return error("file ends early (truncated?)");
    offset_ += n * scalarSize(type);
    return core::okStatus();
  }

  // Skips n items of a binary element without lists in one step.
  core::Status skipFixed(uint64_t n, size_t item_size) {
    if (item_size > 0 && n > (size_ - offset_) / item_size) {
      return error("file ends early (truncated?)");
    }
    offset_ += n * item_size;
    return core::okStatus();
  }

 private:
  static bool fitsInteger(ScalarType type, int64_t v) {
    switch (type) {
      case ScalarType::kInt8:
        return v >= INT8_MIN && v <= INT8_MAX;
      case ScalarType::kUint8:
        return v >= 0 && v <= UINT8_MAX;
      case ScalarType::kInt16:
        return v >= INT16_MIN && v <= INT16_MAX;
      case ScalarType::kUint16:
        return v >= 0 && v <= UINT16_MAX;
      case ScalarType::kInt32:
        return v >= INT32_MIN && v <= INT32_MAX;
      case ScalarType::kUint32:
        return v >= 0 && v <= UINT32_MAX;
      default:
        return true;
    }
  }

  static double decode(ScalarType type, const uint8_t* raw) {
    switch (type) {
      case ScalarType::kInt8:
        return static_cast<int8_t>(raw[0]);
      case ScalarType::kUint8:
        return raw[0];
      case ScalarType::kInt16:
        return loadAs<int16_t>(raw);
      case ScalarType::kUint16:
        return loadAs<uint16_t>(raw);
      case ScalarType::kInt32:
        return loadAs<int32_t>(raw);
      case ScalarType::kUint32:
        return loadAs<uint32_t>(raw);
      case ScalarType::kFloat32:
        return loadAs<float>(raw);
      case ScalarType::kFloat64:
        return loadAs<double>(raw);
    }
    return 0;
  }

  template <class T>
  static T loadAs(const uint8_t* raw) {
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return value;
  }

  const std::string& path_;
  Format format_;
  const uint8_t* bytes_;
  size_t size_;
  size_t offset_;
  text::TokenStream tokens_;
  const Element* element_ = nullptr;
  uint64_t item_ = 0;
  const Property* property_ = nullptr;
};

class PlyParser {
 public:
  PlyParser(const std::string& path, core::Asset& asset) : path_(path), asset_(asset) {}

  core::Status parse(std::string_view content) {
    auto header = parseHeader(path_, content, asset_.warnings);
    if (!header) return header.error();
    bool faces = false;
    for (const Element& element : header->elements) {
      if (element.name == "vertex") vertex_count_ = element.count;
      faces |= element.name == "face" && element.count > 0;
    }
    // Triangle strips (an element some scanners' tools write) are not read: said so, rather than
    // "the file contains no triangles".
    if (!faces)
      for (const Element& element : header->elements)
        if (element.name == "tristrips" && element.count > 0)
          return Error{path_ +
                       ": its triangles are in a 'tristrips' element, which is not read "
                       "(only 'face' lists are); convert the strips to faces"};
    BodyReader body(path_, *header, content);
    for (Element& element : header->elements) {
      if (auto status = readElement(element, body); !status) return status;
    }
    if (auto status = triangulateDeferredFaces(); !status) return status;
    if (body.bytesLeft() > 0 && !body.ascii()) {
      asset_.warnings.push_back(path_ + ": " + std::to_string(body.bytesLeft()) +
                                " bytes after the last element ignored");
    }
    finish();
    return core::okStatus();
  }

 private:
  core::Status readElement(Element& element, BodyReader& body) {
    body.at(&element, 0, nullptr);
    if (element.name == "vertex") {
      auto status = readVertices(element, body);
      vertices_read_ = true;
      return status;
    }
    if (element.name == "face") return readFaces(element, body);
    if (element.count == 0 || element.properties.empty()) return core::okStatus();
    if (auto status = checkCount(element, body); !status) return status;
    skipped_elements_.push_back(element.name);
    if (!body.ascii() && !element.hasList()) {
      return body.skipFixed(element.count, element.minimumBinarySize());
    }
    for (uint64_t item = 0; item < element.count; ++item) {
      for (const Property& property : element.properties) {
        body.at(&element, item, &property);
        if (auto status = skipProperty(property, body); !status) return status;
      }
    }
    return core::okStatus();
  }

  // Never trust a count for allocation or looping: it must fit in what the file has left.
  core::Status checkCount(const Element& element, BodyReader& body) {
    size_t minimum = body.ascii() ? element.properties.size() : element.minimumBinarySize();
    if (minimum > 0 && element.count > body.bytesLeft() / minimum) {
      // At the header's element line (the body's position is not where the count was given).
      return errorAt(path_, element.line,
                     "header declares " + std::to_string(element.count) + " '" + element.name +
                         "' items, more than the " + std::to_string(body.bytesLeft()) +
                         " bytes left in the file can hold");
    }
    return core::okStatus();
  }

  core::Result<uint64_t> readListCount(const Property& property, BodyReader& body) {
    double count = 0;
    if (auto status = body.read(property.count_type, count); !status) return status.error();
    if (count < 0) {
      return body.error("negative list size " + std::to_string(static_cast<int64_t>(count)));
    }
    uint64_t n = static_cast<uint64_t>(count);
    // Each item takes at least one byte (ascii) or its size (binary).
    size_t item_size = body.ascii() ? 1 : scalarSize(property.type);
    if (n > body.bytesLeft() / item_size) {
      return body.error("list of " + std::to_string(n) + " items runs past the end of the file");
    }
    return n;
  }

  core::Status skipProperty(const Property& property, BodyReader& body) {
    if (!property.is_list) {
      double ignored = 0;
      return body.read(property.type, ignored);
    }
    auto n = readListCount(property, body);
    if (!n) return n.error();
    return body.skip(property.type, *n);
  }

  core::Status readVertices(Element& element, BodyReader& body) {
    if (element.count > UINT32_MAX) return body.error("more than 2^32 vertices");
    bool present[kRoleCount] = {};
    for (Property& property : element.properties) {
      property.role = property.is_list ? Role::kNone : roleOf(property.name);
      present[static_cast<int>(property.role)] = true;
    }
    auto has = [&](Role role) { return present[static_cast<int>(role)]; };
    if (!has(Role::kX) || !has(Role::kY) || !has(Role::kZ)) {
      return errorAt(path_, element.line, "element 'vertex' lacks an x, y or z property");
    }
    if (auto status = checkCount(element, body); !status) return status;
    bool normals = has(Role::kNx) && has(Role::kNy) && has(Role::kNz);
    bool uvs = has(Role::kU) && has(Role::kV);
    bool colors = has(Role::kRed) && has(Role::kGreen) && has(Role::kBlue);
    core::Mesh& mesh = asset_.mesh;
    size_t count = static_cast<size_t>(element.count);  // checked against the file size above
    mesh.positions.reserve(count);
    if (normals) mesh.normals.reserve(count);
    if (uvs) mesh.uv0.reserve(count);
    if (colors) mesh.colors.reserve(count);

    float values[kRoleCount];
    for (uint64_t item = 0; item < element.count; ++item) {
      values[static_cast<int>(Role::kAlpha)] = 1.0f;
      for (const Property& property : element.properties) {
        body.at(&element, item, &property);
        if (property.is_list) {
          if (auto status = skipProperty(property, body); !status) return status;
          continue;
        }
        double value = 0;
        if (auto status = body.read(property.type, value); !status) return status;
        if (property.role == Role::kNone) continue;
        if (property.role >= Role::kRed && isInteger(property.type)) {
          // Integer colours are fractions of their type's range (uchar 0..255 usually).
          value /= property.type == ScalarType::kUint16 || property.type == ScalarType::kInt16
                       ? 65535.0
                       : 255.0;
        }
        float narrowed = static_cast<float>(value);
        if (!std::isfinite(narrowed)) return body.error("non-finite value");
        values[static_cast<int>(property.role)] = narrowed;
      }
      auto at = [&](Role role) { return values[static_cast<int>(role)]; };
      mesh.positions.push_back({at(Role::kX), at(Role::kY), at(Role::kZ)});
      if (normals) mesh.normals.push_back({at(Role::kNx), at(Role::kNy), at(Role::kNz)});
      // PLY writers (Blender, MeshLab) store OpenGL-style v up; ours points down.
      if (uvs) mesh.uv0.push_back({at(Role::kU), 1.0f - at(Role::kV)});
      if (colors) {
        mesh.colors.push_back(
            {at(Role::kRed), at(Role::kGreen), at(Role::kBlue), at(Role::kAlpha)});
      }
    }
    return core::okStatus();
  }

  core::Status readFaces(Element& element, BodyReader& body) {
    const Property* indices = nullptr;
    for (const Property& property : element.properties) {
      if (property.is_list &&
          (property.name == "vertex_indices" || property.name == "vertex_index")) {
        indices = &property;
      }
    }
    if (!indices) {
      asset_.warnings.push_back(
          errorAt(path_, element.line, "element 'face' has no vertex_indices list; no faces read")
              .message);
    } else if (!isInteger(indices->type)) {
      return errorAt(path_, element.line, "vertex_indices has a non-integer item type");
    }
    if (auto status = checkCount(element, body); !status) return status;
    face_line_ = element.line;
    std::vector<uint32_t> polygon;
    size_t unclipped = 0;  // polygons not cut into ears (triangulatePolygon): fanned
    for (uint64_t item = 0; item < element.count; ++item) {
      for (const Property& property : element.properties) {
        body.at(&element, item, &property);
        if (&property != indices) {
          if (auto status = skipProperty(property, body); !status) return status;
          continue;
        }
        auto n = readListCount(property, body);
        if (!n) return n.error();
        if (*n < 3)
          return body.error("face has " + std::to_string(*n) + " vertices (at least 3 needed)");
        polygon.clear();
        for (uint64_t i = 0; i < *n; ++i) {
          double index = 0;
          if (auto status = body.read(property.type, index); !status) return status;
          if (index < 0 || index >= static_cast<double>(vertex_count_)) {
            return body.error("vertex index " + std::to_string(static_cast<int64_t>(index)) +
                              " out of range (" + std::to_string(vertex_count_) + " vertices)");
          }
          polygon.push_back(static_cast<uint32_t>(index));
        }
        if (!vertices_read_) {
          // Faces before vertices (the header may order elements any way): a polygon's shape is
          // not known yet, so it is kept and cut up once the vertices are read.
          deferred_sizes_.push_back(static_cast<uint32_t>(polygon.size()));
          deferred_corners_.insert(deferred_corners_.end(), polygon.begin(), polygon.end());
          continue;
        }
        if (!text::appendPolygon(polygon, asset_.mesh.positions, asset_.mesh.indices)) ++unclipped;
        if (asset_.mesh.indices.size() > UINT32_MAX) return body.error("too many triangles");
      }
    }
    warnUnclipped(unclipped);
    return core::okStatus();
  }

  // The faces readFaces kept because they came before the vertices, triangulated as they would
  // have been after them (in file order, ears for concave polygons).
  core::Status triangulateDeferredFaces() {
    size_t unclipped = 0, first = 0;
    for (uint32_t size : deferred_sizes_) {
      const std::span<const uint32_t> polygon(deferred_corners_.data() + first, size);
      first += size;
      if (!text::appendPolygon(polygon, asset_.mesh.positions, asset_.mesh.indices)) ++unclipped;
      if (asset_.mesh.indices.size() > UINT32_MAX)
        return errorAt(path_, face_line_, "element 'face': too many triangles");
    }
    warnUnclipped(unclipped);
    deferred_sizes_.clear();
    deferred_corners_.clear();
    return core::okStatus();
  }

  void warnUnclipped(size_t unclipped) {
    if (unclipped > 0)
      asset_.warnings.push_back(path_ + ": " + std::to_string(unclipped) + " polygon(s): each " +
                                text::kUnclippedPolygon);
  }

  void finish() {
    if (!skipped_elements_.empty()) {
      std::string names;
      for (const std::string& name : skipped_elements_) names += (names.empty() ? "" : ", ") + name;
      asset_.warnings.push_back(path_ + ": elements not used: " + names);
    }
    text::finishSingleMaterialAsset(asset_);
  }

  const std::string& path_;
  core::Asset& asset_;
  uint64_t vertex_count_ = 0;
  bool vertices_read_ = false;
  // Faces read before the vertices (triangulateDeferredFaces): each polygon's corner count, and
  // all their corners one after another. face_line_: the header line of the face element.
  std::vector<uint32_t> deferred_sizes_, deferred_corners_;
  size_t face_line_ = 0;
  std::vector<std::string> skipped_elements_;
};

}  // namespace

core::Result<core::Asset> readPly(const std::string& path, const LoadOptions& /*options*/) {
  auto bytes = text::readInputFile(path);
  if (!bytes) return bytes.error();
  core::Asset asset;
  asset.source_path = path;
  PlyParser parser(path, asset);
  if (auto status = parser.parse(text::asText(*bytes)); !status) return status.error();
  return asset;
}

}  // namespace duolod::io
