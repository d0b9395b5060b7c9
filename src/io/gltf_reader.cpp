// glTF 2.0 reader (Khronos glTF 2.0 specification) through tinygltf (Debian libtinygltf-dev):
// all triangle primitives of the default scene, node transforms flattened, metallic-roughness
// materials and their textures. Every accessor read is bounds-checked here, because tinygltf
// leaves out-of-range views to the caller; a broken one is named with the mesh, primitive and
// attribute that use it.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE_WRITE
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "duolod/io.hpp"

namespace duolod::io {
namespace {
using core::Error;
using core::Mat4;
using core::Vec2;
using core::Vec3;
using core::Vec4;

struct ImageLoaderContext {
  bool load = true;    // LoadOptions::load_textures
  bool decode = true;  // LoadOptions::decode_textures: false keeps PNG and JPEG bytes undecoded
  const tinygltf::Model* model = nullptr;  // being filled; its buffers are parsed before images
  // Per image index: the encoded bytes (PNG, JPEG) for the writers to copy (core::EncodedImage).
  std::vector<std::shared_ptr<const core::EncodedImage>> encoded;
};

// tinygltf hands us the encoded bytes of each image (embedded or from a file it read).
bool loadImageThroughStb(tinygltf::Image* image, const int index, std::string* err, std::string*,
                         int, int, const unsigned char* bytes, int size, void* user) {
  auto* context = static_cast<ImageLoaderContext*>(user);
  if (!context->load) return true;
  std::string name = image->uri.empty() ? "image " + std::to_string(index) : image->uri;
  // tinygltf 2.7 passes an embedded image's bufferView without checking that it lies inside its
  // buffer; reading it would run past the buffer's end.
  if (image->bufferView >= 0 && context->model) {
    // tinygltf has checked both indices before calling.
    const tinygltf::Model& model = *context->model;
    const tinygltf::BufferView& view = model.bufferViews[image->bufferView];
    const size_t buffer_size = model.buffers[view.buffer].data.size();
    if (view.byteOffset > buffer_size || view.byteLength > buffer_size - view.byteOffset) {
      if (err)
        *err += name + ": bufferView " + std::to_string(image->bufferView) +
                " runs past the end of its buffer\n";
      return false;
    }
  }
  const std::span<const uint8_t> encoded(bytes, static_cast<size_t>(size));
  if (!context->decode && index >= 0) {
    auto kept = keepUndecoded(encoded, name);
    if (!kept) {
      if (err) *err += kept.error().message + "\n";
      return false;
    }
    if (*kept) {  // PNG or JPEG: the bytes stand for the texture (readMaterials)
      if (context->encoded.size() <= size_t(index)) context->encoded.resize(size_t(index) + 1);
      context->encoded[size_t(index)] = std::move(kept).value();
      return true;
    }
  }
  auto decoded = decodeImage(encoded, name);
  if (!decoded) {
    if (err) *err += decoded.error().message + "\n";
    return false;
  }
  if (index >= 0) {
    if (context->encoded.size() <= size_t(index)) context->encoded.resize(size_t(index) + 1);
    context->encoded[size_t(index)] = keepEncoded(encoded, *decoded);
  }
  image->width = decoded->width;
  image->height = decoded->height;
  image->component = 4;
  image->bits = 8;
  image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  image->image = std::move(decoded->pixels);
  return true;
}

// tinygltf's own FileExists opens the file to see whether it exists, and opening a pipe waits for
// a writer: a uri naming one hung the reader. Asked of the file system instead (readWholeFile
// then refuses anything but a regular file).
bool fileExists(const std::string& path, void*) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

// tinygltf's own ReadWholeFile sizes its buffer with tellg(), which on a folder is a huge value: a
// buffer or image uri naming a folder aborted with bad_alloc. Read through readFileBytes instead.
// `user`: the list of files read (Asset::source_files).
bool readWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                   void* user) {
  static_cast<std::vector<std::string>*>(user)->push_back(path);
  auto bytes = readFileBytes(path);
  if (bytes && bytes->empty()) bytes = Error{path + ": file is empty"};
  if (!bytes) {
    if (err) *err += bytes.error().message + "\n";
    return false;
  }
  *out = std::move(bytes.value());
  return true;
}

// The triangles of a strip or a fan, in the glTF specification's order (§3.7.2.1: strip
// triangle i is (v_i, v_{i+1+i%2}, v_{i+2-i%2}), so that every triangle turns as the first;
// fan triangle i is (v_{i+1}, v_{i+2}, v_0)). Fewer than three vertices make no triangle.
std::vector<uint32_t> triangleListOf(const std::vector<uint32_t>& vertices, int mode) {
  std::vector<uint32_t> triangles;
  if (vertices.size() < 3) return triangles;
  triangles.reserve((vertices.size() - 2) * 3);
  for (size_t i = 0; i + 2 < vertices.size(); ++i) {
    if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)
      triangles.insert(triangles.end(),
                       {vertices[i], vertices[i + 1 + i % 2], vertices[i + 2 - i % 2]});
    else
      triangles.insert(triangles.end(), {vertices[i + 1], vertices[i + 2], vertices[0]});
  }
  return triangles;
}

// How messages name a primitive: "mesh 2 'Body', primitive 0" (without a name when it has none),
// so that a broken accessor can be traced to what uses it.
std::string primitiveName(size_t mesh, const std::string& name, size_t primitive) {
  return "mesh " + std::to_string(mesh) + (name.empty() ? "" : " '" + name + "'") + ", primitive " +
         std::to_string(primitive);
}

constexpr const char* kNoBufferView =
    "has no bufferView (data from sparse accessors or compression extensions is not supported)";

// A validated view of an accessor's bytes: every element lies inside its buffer.
struct AccessorBytes {
  const unsigned char* first = nullptr;
  size_t stride = 0;
  size_t count = 0;
  int component_type = 0;
  int component_size = 0;
  bool normalized = false;
};

// `what` names the user ("path: mesh 2 'Body', primitive 0, attribute NORMAL"); the messages go
// on with the accessor and the numbers that do not fit ("accessor 5 reads bytes 0-4800 of
// bufferView 3 that holds 4000").
core::Result<AccessorBytes> viewAccessor(const tinygltf::Model& model, int index, int components,
                                         const std::string& what) {
  const std::string where = what + ": accessor " + std::to_string(index);
  if (index < 0 || index >= static_cast<int>(model.accessors.size()))
    return Error{where + " does not exist (" + std::to_string(model.accessors.size()) +
                 " accessors)"};
  const tinygltf::Accessor& accessor = model.accessors[index];
  if (accessor.sparse.isSparse) return Error{where + " is sparse, which is not supported"};
  int count_per_element = tinygltf::GetNumComponentsInType(accessor.type);
  if (count_per_element != components)
    return Error{where + " has " + std::to_string(count_per_element) + " components, " +
                 std::to_string(components) + " expected"};
  AccessorBytes bytes;
  bytes.component_type = accessor.componentType;
  bytes.component_size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
  bytes.count = accessor.count;
  bytes.normalized = accessor.normalized;
  if (bytes.component_size <= 0) return Error{where + " has an invalid componentType"};
  // Without a bufferView an accessor is all zeros unless sparse data or a compression extension
  // fills it, and neither is supported: zero positions or indices are only degenerate triangles,
  // and the count, bounded by no data in the file, could make a tiny file allocate any amount.
  if (accessor.bufferView < 0) return Error{where + " " + kNoBufferView};
  const std::string view_name = "bufferView " + std::to_string(accessor.bufferView);
  if (accessor.bufferView >= static_cast<int>(model.bufferViews.size()))
    return Error{where + "'s " + view_name + " does not exist (" +
                 std::to_string(model.bufferViews.size()) + " bufferViews)"};
  const tinygltf::BufferView& view = model.bufferViews[accessor.bufferView];
  if (view.buffer < 0 || view.buffer >= static_cast<int>(model.buffers.size()))
    return Error{where + ": " + view_name + "'s buffer " + std::to_string(view.buffer) +
                 " does not exist (" + std::to_string(model.buffers.size()) + " buffers)"};
  const std::vector<unsigned char>& data = model.buffers[view.buffer].data;
  size_t element_size = static_cast<size_t>(bytes.component_size) * components;
  bytes.stride = view.byteStride ? view.byteStride : element_size;
  if (bytes.stride < element_size)
    return Error{where + ": " + view_name + "'s byteStride " + std::to_string(bytes.stride) +
                 " is smaller than an element (" + std::to_string(element_size) + " bytes)"};
  // Offsets and lengths come from the file and may be near 2^64: compare by subtraction so that
  // no sum can wrap around.
  if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset)
    return Error{where + ": " + view_name + " runs past the end of buffer " +
                 std::to_string(view.buffer) + " (offset " + std::to_string(view.byteOffset) +
                 " + length " + std::to_string(view.byteLength) + " > " +
                 std::to_string(data.size()) + " bytes)"};
  const size_t available =
      accessor.byteOffset <= view.byteLength ? view.byteLength - accessor.byteOffset : 0;
  if (accessor.byteOffset > view.byteLength ||
      (accessor.count > 0 && ((accessor.count - 1) > available / bytes.stride ||
                              (accessor.count - 1) * bytes.stride + element_size > available))) {
    // The bytes it reads, from its byteOffset in the view to the end of its last element (past
    // 2^64 for a count or offset no file could back).
    const size_t kMax = std::numeric_limits<size_t>::max();
    const size_t last = accessor.count > 1 ? accessor.count - 1 : 0;
    const size_t span = accessor.count == 0 ? 0 : element_size;
    const bool wraps = last > (kMax - span) / bytes.stride ||
                       last * bytes.stride + span > kMax - accessor.byteOffset;
    const std::string first = std::to_string(accessor.byteOffset);
    const std::string range =
        wraps ? "from " + first + " to past 2^64"
              : first + "-" + std::to_string(accessor.byteOffset + last * bytes.stride + span);
    return Error{where + " reads bytes " + range + " of " + view_name + " that holds " +
                 std::to_string(view.byteLength) + ": its " + std::to_string(accessor.count) +
                 " elements do not fit"};
  }
  bytes.first = data.data() + view.byteOffset + accessor.byteOffset;
  return bytes;
}

// Reads accessor `index` as `components` floats per element, normalizing integer types when the
// accessor says so.
core::Result<std::vector<float>> readFloats(const tinygltf::Model& model, int index,
                                            int components, const std::string& what) {
  auto view = viewAccessor(model, index, components, what);
  if (!view) return view.error();
  const AccessorBytes& a = *view;
  std::vector<float> out(a.count * components, 0.0f);
  for (size_t e = 0; e < a.count; ++e) {
    for (int c = 0; c < components; ++c) {
      const unsigned char* p = a.first + e * a.stride + c * a.component_size;
      float value = 0;
      switch (a.component_type) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: std::memcpy(&value, p, 4); break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: value = a.normalized ? *p / 255.0f : *p; break;
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
          auto v = static_cast<int8_t>(*p);
          value = a.normalized ? std::max(v / 127.0f, -1.0f) : v;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          uint16_t v;
          std::memcpy(&v, p, 2);
          value = a.normalized ? v / 65535.0f : v;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
          int16_t v;
          std::memcpy(&v, p, 2);
          value = a.normalized ? std::max(v / 32767.0f, -1.0f) : v;
          break;
        }
        // (glTF 2.0 allows no 32-bit integer vertex attribute: its raw values, 1e9 for a
        // float's bits, would be taken as coordinates.)
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
          return Error{what +
                       ": componentType 5125 (unsigned int) is not allowed for a vertex "
                       "attribute"};
        default: return Error{what + ": unsupported componentType"};
      }
      if (!std::isfinite(value))
        return Error{what + ": element " + std::to_string(e) + " is not a finite number"};
      out[e * components + c] = value;
    }
  }
  return out;
}

core::Result<std::vector<uint32_t>> readIndices(const tinygltf::Model& model, int index,
                                                const std::string& what) {
  auto view = viewAccessor(model, index, 1, what + ", indices");
  if (!view) return view.error();
  const AccessorBytes& a = *view;
  std::vector<uint32_t> out(a.count, 0);
  for (size_t e = 0; e < a.count; ++e) {
    const unsigned char* p = a.first + e * a.stride;
    switch (a.component_type) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: out[e] = *p; break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        out[e] = v;
        break;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: std::memcpy(&out[e], p, 4); break;
      default: return Error{what + ": indices must be unsigned integers"};
    }
  }
  return out;
}

// A node's local transform. `what` names the node in messages; a rotation that is not a unit
// quaternion is normalized (warned: the spec requires unit ones), a projective matrix's last row is
// ignored (warned).
core::Result<Mat4> nodeMatrix(const tinygltf::Node& node, const std::string& what,
                              std::vector<std::string>& warnings) {
  for (auto [values, size, name] : {std::tuple{&node.matrix, size_t(16), "matrix"},
                                    {&node.translation, size_t(3), "translation"},
                                    {&node.rotation, size_t(4), "rotation"},
                                    {&node.scale, size_t(3), "scale"}}) {
    if (!values->empty() && values->size() != size)
      return Error{what + ": " + name + " has " + std::to_string(values->size()) + " numbers (" +
                   std::to_string(size) + " needed)"};
    for (double value : *values)
      if (!std::isfinite(value) || !std::isfinite(float(value)))
        return Error{what + ": " + name + " holds a non-finite number"};
  }
  if (node.matrix.size() == 16) {
    Mat4 m;
    for (int i = 0; i < 16; ++i) m.m[i] = static_cast<float>(node.matrix[i]);
    if (node.matrix[3] != 0 || node.matrix[7] != 0 || node.matrix[11] != 0 || node.matrix[15] != 1)
      warnings.push_back(what +
                         ": matrix is not affine (its last row is not 0 0 0 1); the "
                         "projective part is ignored");
    return m;
  }
  Mat4 t = Mat4::identity(), r = Mat4::identity(), s = Mat4::identity();
  if (node.translation.size() == 3)
    for (int i = 0; i < 3; ++i) t.at(i, 3) = static_cast<float>(node.translation[i]);
  if (node.rotation.size() == 4) {
    double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
    const double length = std::sqrt(x * x + y * y + z * z + w * w);
    if (!(length > 0) || !std::isfinite(length))
      return Error{what + ": rotation (0, 0, 0, 0) is not a quaternion"};
    if (std::abs(length - 1) > 1e-3) {
      char text[32];
      std::snprintf(text, sizeof text, "%.6g", length);
      warnings.push_back(what + ": rotation has length " + text + ", not 1; normalized");
      x /= length, y /= length, z /= length, w /= length;
    }
    r.at(0, 0) = float(1 - 2 * (y * y + z * z)), r.at(0, 1) = float(2 * (x * y - z * w)),
    r.at(0, 2) = float(2 * (x * z + y * w));
    r.at(1, 0) = float(2 * (x * y + z * w)), r.at(1, 1) = float(1 - 2 * (x * x + z * z)),
    r.at(1, 2) = float(2 * (y * z - x * w));
    r.at(2, 0) = float(2 * (x * z - y * w)), r.at(2, 1) = float(2 * (y * z + x * w)),
    r.at(2, 2) = float(1 - 2 * (x * x + y * y));
  }
  if (node.scale.size() == 3)
    for (int i = 0; i < 3; ++i) s.at(i, i) = static_cast<float>(node.scale[i]);
  return Mat4(t * r * s);
}

float determinant3(const Mat4& m) {
  return m.at(0, 0) * (m.at(1, 1) * m.at(2, 2) - m.at(1, 2) * m.at(2, 1)) -
         m.at(0, 1) * (m.at(1, 0) * m.at(2, 2) - m.at(1, 2) * m.at(2, 0)) +
         m.at(0, 2) * (m.at(1, 0) * m.at(2, 1) - m.at(1, 1) * m.at(2, 0));
}

class GltfFlattener {
 public:
  GltfFlattener(const tinygltf::Model& model, const std::string& path, core::Asset& asset)
      : model_(model), path_(path), asset_(asset), visited_(model.nodes.size(), false) {}

  core::Status visit(int node_index, const Mat4& parent, int depth) {
    if (node_index < 0 || node_index >= static_cast<int>(model_.nodes.size()))
      return Error{path_ + ": node " + std::to_string(node_index) + " does not exist"};
    if (depth > 256) return Error{path_ + ": node hierarchy deeper than 256 (a cycle?)"};
    // glTF 2.0 (Nodes and Hierarchy): the node hierarchy is a set of disjoint trees. A node
    // reached twice (a cycle, or two parents) would otherwise be flattened once per path, which
    // is exponentially many times in a chain of nodes that list their child twice.
    if (visited_[node_index])
      return Error{path_ + ": node " + std::to_string(node_index) +
                   " is reached twice (a cycle, or a node with two parents)"};
    visited_[node_index] = true;
    const tinygltf::Node& node = model_.nodes[node_index];
    auto local = nodeMatrix(node, path_ + ": node " + std::to_string(node_index), asset_.warnings);
    if (!local) return local.error();
    Mat4 world = parent * *local;
    if (node.mesh >= 0) {
      if (node.mesh >= static_cast<int>(model_.meshes.size()))
        return Error{path_ + ": node " + std::to_string(node_index) + " refers to missing mesh " +
                     std::to_string(node.mesh)};
      if (auto added = addMesh(node.mesh, world); !added) return added;
    }
    for (int child : node.children)
      if (auto visited = visit(child, world, depth + 1); !visited) return visited;
    return core::okStatus();
  }

  core::Status addMesh(int mesh_index, const Mat4& world) {
    const tinygltf::Mesh& gmesh = model_.meshes[mesh_index];
    ++instance_;  // the vertices appended for this placement of the mesh are shared below
    for (size_t p = 0; p < gmesh.primitives.size(); ++p) {
      const tinygltf::Primitive& prim = gmesh.primitives[p];
      const std::string what = path_ + ": " + primitiveName(mesh_index, gmesh.name, p);
      // Triangles, strips and fans are read (strips and fans as triangles); points and lines
      // have no surface to simplify or shade.
      if (prim.mode < -1 || prim.mode > TINYGLTF_MODE_TRIANGLE_FAN)
        return Error{what + ": mode " + std::to_string(prim.mode) +
                     " is not a glTF primitive mode (0-6)"};
      if (prim.mode >= TINYGLTF_MODE_POINTS && prim.mode < TINYGLTF_MODE_TRIANGLES) {
        static const char* const kNames[] = {"points", "lines", "a line loop", "a line strip"};
        asset_.warnings.push_back(what + ": mode " + std::to_string(prim.mode) + " (" +
                                  kNames[prim.mode] + ") has no triangles; skipped");
        continue;
      }
      if (auto added = addPrimitive(prim, world, what); !added) return added;
    }
    return core::okStatus();
  }

  // Groups triangles per material; the final index buffer is built by finish().
  core::Status addPrimitive(const tinygltf::Primitive& prim, const Mat4& world,
                            const std::string& what) {
    auto position_it = prim.attributes.find("POSITION");
    if (position_it == prim.attributes.end()) return Error{what + ": has no POSITION attribute"};
    // Primitives of one mesh often share their vertex accessors and differ only in indices and
    // material (duolod's own writer does so): append those vertices once per placement, not once
    // per primitive, which would cost primitives x vertices in time and memory.
    VertexSourceKey key{instance_, {}};
    for (size_t s = 0; s < kVertexAttributes.size(); ++s) {
      auto it = prim.attributes.find(kVertexAttributes[s]);
      key.accessors[s] = it == prim.attributes.end() ? -1 : it->second;
    }
    if (auto shared = appended_.find(key); shared != appended_.end())
      return addTriangles(prim, world, what, shared->second.base, shared->second.count);
    auto positions = readFloats(model_, position_it->second, 3, what + ", attribute POSITION");
    if (!positions) return positions.error();
    size_t count = positions->size() / 3;
    auto optional = [&](const char* name, int components) -> core::Result<std::vector<float>> {
      auto it = prim.attributes.find(name);
      if (it == prim.attributes.end()) return std::vector<float>{};
      auto values = readFloats(model_, it->second, components, what + ", attribute " + name);
      if (values && values->size() != count * components)
        return Error{what + ", attribute " + name + ": accessor " + std::to_string(it->second) +
                     " has " + std::to_string(values->size() / components) +
                     " elements, POSITION's " + std::to_string(count)};
      return values;
    };
    auto normals = optional("NORMAL", 3);
    if (!normals) return normals.error();
    auto tangents = optional("TANGENT", 4);
    if (!tangents) return tangents.error();
    auto uv0 = optional("TEXCOORD_0", 2);
    if (!uv0) return uv0.error();
    auto uv1 = optional("TEXCOORD_1", 2);
    if (!uv1) return uv1.error();
    std::vector<float> colors;
    if (auto it = prim.attributes.find("COLOR_0"); it != prim.attributes.end()) {
      int components = 4;
      if (it->second >= 0 && it->second < static_cast<int>(model_.accessors.size()))
        components = model_.accessors[it->second].type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
      auto read = optional("COLOR_0", components);
      if (!read) return read.error();
      colors.resize(count * 4, 1.0f);
      for (size_t v = 0; v < count; ++v)
        for (int c = 0; c < components; ++c) colors[v * 4 + c] = (*read)[v * components + c];
    }
    // Streams present anywhere must be present everywhere; fill absent ones with defaults.
    core::Mesh& mesh = asset_.mesh;
    uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    Mat4 normal_matrix = core::transpose(core::inverse(world));
    bool mirrored = determinant3(world) < 0;
    for (size_t v = 0; v < count; ++v) {
      Vec3 p{(*positions)[v * 3], (*positions)[v * 3 + 1], (*positions)[v * 3 + 2]};
      mesh.positions.push_back(core::transformPoint(world, p));
    }
    appendStream(mesh.normals, has_normals_, !normals->empty(), base, count, Vec3{0, 0, 1},
                 [&](size_t v) {
                   Vec3 n{(*normals)[v * 3], (*normals)[v * 3 + 1], (*normals)[v * 3 + 2]};
                   return core::normalize(core::transformVector(normal_matrix, n));
                 });
    appendStream(mesh.tangents, has_tangents_, !tangents->empty(), base, count, Vec4{1, 0, 0, 1},
                 [&](size_t v) {
                   const float* t = &(*tangents)[v * 4];
                   Vec3 d = core::normalize(core::transformVector(world, Vec3{t[0], t[1], t[2]}));
                   return Vec4{d.x, d.y, d.z, mirrored ? -t[3] : t[3]};
                 });
    appendStream(mesh.uv0, has_uv0_, !uv0->empty(), base, count, Vec2{0, 0},
                 [&](size_t v) { return Vec2{(*uv0)[v * 2], (*uv0)[v * 2 + 1]}; });
    appendStream(mesh.uv1, has_uv1_, !uv1->empty(), base, count, Vec2{0, 0},
                 [&](size_t v) { return Vec2{(*uv1)[v * 2], (*uv1)[v * 2 + 1]}; });
    appendStream(mesh.colors, has_colors_, !colors.empty(), base, count, Vec4{1, 1, 1, 1},
                 [&](size_t v) {
                   return Vec4{colors[v * 4], colors[v * 4 + 1], colors[v * 4 + 2],
                               colors[v * 4 + 3]};
                 });
    appended_[key] = {base, count};
    return addTriangles(prim, world, what, base, count);
  }

  // The primitive's triangles, over `count` vertices already appended from `base` on, into its
  // material's bucket.
  core::Status addTriangles(const tinygltf::Primitive& prim, const Mat4& world,
                            const std::string& what, uint32_t base, size_t count) {
    std::vector<uint32_t> indices;
    if (prim.indices >= 0) {
      auto read = readIndices(model_, prim.indices, what);
      if (!read) return read.error();
      indices = std::move(read.value());
    } else {
      indices.resize(count);
      for (size_t i = 0; i < count; ++i) indices[i] = static_cast<uint32_t>(i);
    }
    const bool strip_or_fan =
        prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP || prim.mode == TINYGLTF_MODE_TRIANGLE_FAN;
    if (!strip_or_fan && indices.size() % 3 != 0)
      return Error{what + ": " + std::to_string(indices.size()) +
                   (prim.indices >= 0 ? " indices" : " vertices (it has no indices)") +
                   " is not a whole number of triangles"};
    for (size_t i = 0; i < indices.size(); ++i)
      if (indices[i] >= count)
        return Error{what + ": index " + std::to_string(i) + " = " + std::to_string(indices[i]) +
                     " is out of range (" + std::to_string(count) + " vertices)"};
    if (strip_or_fan) indices = triangleListOf(indices, prim.mode);
    const bool mirrored = determinant3(world) < 0;
    int material = prim.material;
    if (material < -1 || material >= static_cast<int>(model_.materials.size()))
      return Error{what + ": refers to missing material " + std::to_string(material)};
    std::vector<uint32_t>& bucket = triangles_by_material_[material];
    for (size_t i = 0; i < indices.size(); i += 3) {
      uint32_t a = base + indices[i], b = base + indices[i + 1], c = base + indices[i + 2];
      if (mirrored) std::swap(b, c);  // keep counter-clockwise front faces after a mirror
      bucket.insert(bucket.end(), {a, b, c});
    }
    return core::okStatus();
  }

  // Materials in file order; -1 (no material) maps to a default material appended at the end.
  void finish() {
    core::Mesh& mesh = asset_.mesh;
    mesh.indices.clear();
    mesh.submeshes.clear();
    for (auto& [material, triangles] : triangles_by_material_) {
      uint32_t id = material >= 0 ? static_cast<uint32_t>(material)
                                  : static_cast<uint32_t>(model_.materials.size());
      mesh.submeshes.push_back({static_cast<uint32_t>(mesh.indices.size()),
                                static_cast<uint32_t>(triangles.size()), id});
      mesh.indices.insert(mesh.indices.end(), triangles.begin(), triangles.end());
    }
  }

  bool usesDefaultMaterial() const { return triangles_by_material_.count(-1) > 0; }

 private:
  template <class T, class Get>
  void appendStream(std::vector<T>& stream, bool& present, bool here, uint32_t base, size_t count,
                    T fallback, Get get) {
    if (here && !present) {  // first primitive with this stream: back-fill earlier vertices
      stream.assign(base, fallback);
      present = true;
    }
    if (!present) return;
    for (size_t v = 0; v < count; ++v) stream.push_back(here ? get(v) : fallback);
  }

  static constexpr std::array<const char*, 6> kVertexAttributes = {
      "POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "TEXCOORD_1", "COLOR_0"};
  struct VertexSourceKey {
    int instance;                                         // which addMesh call (placement)
    std::array<int, kVertexAttributes.size()> accessors;  // -1: attribute absent
    auto operator<=>(const VertexSourceKey&) const = default;
  };
  struct AppendedVertices {
    uint32_t base;
    size_t count;
  };

  const tinygltf::Model& model_;
  const std::string& path_;
  core::Asset& asset_;
  std::map<int, std::vector<uint32_t>> triangles_by_material_;
  std::vector<bool> visited_;  // nodes already flattened
  int instance_ = 0;
  std::map<VertexSourceKey, AppendedVertices> appended_;
  bool has_normals_ = false, has_tangents_ = false, has_uv0_ = false, has_uv1_ = false,
       has_colors_ = false;
};

// `encoded`: per image, the bytes it was decoded from (ImageLoaderContext), for the textures.
core::Status readMaterials(const tinygltf::Model& model, const std::string& path,
                           std::span<const std::shared_ptr<const core::EncodedImage>> encoded,
                           core::Asset& asset) {
  std::vector<int> srgb_use(model.textures.size(), 0), linear_use(model.textures.size(), 0);
  auto textureRef = [&](int texture, int tex_coord, const std::string& what, bool srgb,
                        const tinygltf::ExtensionMap& extensions) -> core::Result<int> {
    if (texture < 0) return -1;
    if (texture >= static_cast<int>(model.textures.size()))
      return Error{path + ": " + what + " refers to missing texture " + std::to_string(texture)};
    if (tex_coord != 0)
      asset.warnings.push_back(what + " uses TEXCOORD_" + std::to_string(tex_coord) +
                               "; duolod's shaders sample TEXCOORD_0");
    if (extensions.count("KHR_texture_transform"))
      asset.warnings.push_back(what + ": KHR_texture_transform is ignored");
    (srgb ? srgb_use : linear_use)[texture]++;
    return texture;
  };
  for (size_t m = 0; m < model.materials.size(); ++m) {
    const tinygltf::Material& gm = model.materials[m];
    core::Material mat;
    std::string what = "material " + std::to_string(m) + (gm.name.empty() ? "" : " '" + gm.name + "'");
    mat.name = gm.name.empty() ? "material" + std::to_string(m) : gm.name;
    const auto& pbr = gm.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() == 4)
      mat.base_color_factor = {float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]),
                               float(pbr.baseColorFactor[2]), float(pbr.baseColorFactor[3])};
    mat.metallic_factor = float(pbr.metallicFactor);
    mat.roughness_factor = float(pbr.roughnessFactor);
    if (gm.emissiveFactor.size() == 3)
      mat.emissive_factor = {float(gm.emissiveFactor[0]), float(gm.emissiveFactor[1]),
                             float(gm.emissiveFactor[2])};
    mat.normal_scale = float(gm.normalTexture.scale);
    mat.occlusion_strength = float(gm.occlusionTexture.strength);
    mat.alpha_cutoff = float(gm.alphaCutoff);
    mat.alpha_mode = gm.alphaMode == "MASK"    ? core::AlphaMode::kMask
                     : gm.alphaMode == "BLEND" ? core::AlphaMode::kBlend
                                               : core::AlphaMode::kOpaque;
    mat.double_sided = gm.doubleSided;
    // Factors: finite (an infinite one was written out as `inf`, which nothing reads back), and
    // within the spec's ranges (clamped, with a warning).
    struct Factor {
      float* value;
      const char* name;
      float low, high;
    };
    const float kUnbounded = std::numeric_limits<float>::max();
    const std::vector<Factor> factors = {
        {&mat.base_color_factor.x, "baseColorFactor", 0, 1},
        {&mat.base_color_factor.y, "baseColorFactor", 0, 1},
        {&mat.base_color_factor.z, "baseColorFactor", 0, 1},
        {&mat.base_color_factor.w, "baseColorFactor", 0, 1},
        {&mat.metallic_factor, "metallicFactor", 0, 1},
        {&mat.roughness_factor, "roughnessFactor", 0, 1},
        {&mat.emissive_factor.x, "emissiveFactor", 0, kUnbounded},
        {&mat.emissive_factor.y, "emissiveFactor", 0, kUnbounded},
        {&mat.emissive_factor.z, "emissiveFactor", 0, kUnbounded},
        {&mat.normal_scale, "normalTexture.scale", -kUnbounded, kUnbounded},
        {&mat.occlusion_strength, "occlusionTexture.strength", 0, 1},
        {&mat.alpha_cutoff, "alphaCutoff", 0, kUnbounded}};
    std::string clamped;
    for (const Factor& factor : factors) {
      if (!std::isfinite(*factor.value))
        return Error{path + ": " + what + ": " + factor.name + " is not a finite number"};
      if (*factor.value < factor.low || *factor.value > factor.high) {
        *factor.value = std::clamp(*factor.value, factor.low, factor.high);
        if (clamped.find(factor.name) == std::string::npos)
          clamped += (clamped.empty() ? "" : ", ") + std::string(factor.name);
      }
    }
    if (!clamped.empty())
      asset.warnings.push_back(path + ": " + what + ": " + clamped +
                               " out of the glTF range, clamped");
    struct Slot {
      int* target;
      int texture, tex_coord;
      const char* name;
      bool srgb;
      const tinygltf::ExtensionMap* extensions;
    } slots[] = {
        {&mat.base_color_texture, pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
         "baseColorTexture", true, &pbr.baseColorTexture.extensions},
        {&mat.metallic_roughness_texture, pbr.metallicRoughnessTexture.index,
         pbr.metallicRoughnessTexture.texCoord, "metallicRoughnessTexture", false,
         &pbr.metallicRoughnessTexture.extensions},
        {&mat.normal_texture, gm.normalTexture.index, gm.normalTexture.texCoord, "normalTexture",
         false, &gm.normalTexture.extensions},
        {&mat.occlusion_texture, gm.occlusionTexture.index, gm.occlusionTexture.texCoord,
         "occlusionTexture", false, &gm.occlusionTexture.extensions},
        {&mat.emissive_texture, gm.emissiveTexture.index, gm.emissiveTexture.texCoord,
         "emissiveTexture", true, &gm.emissiveTexture.extensions},
    };
    for (const Slot& slot : slots) {
      auto ref = textureRef(slot.texture, slot.tex_coord, what + " " + slot.name, slot.srgb,
                            *slot.extensions);
      if (!ref) return ref.error();
      *slot.target = *ref;
    }
    asset.materials.push_back(mat);
  }
  for (size_t t = 0; t < model.textures.size(); ++t) {
    const tinygltf::Texture& gt = model.textures[t];
    core::Texture texture;
    if (gt.source < 0 || gt.source >= static_cast<int>(model.images.size())) {
      if (srgb_use[t] + linear_use[t] > 0)
        return Error{path + ": texture " + std::to_string(t) + " has no valid image source"};
      asset.textures.push_back(texture);
      continue;
    }
    const tinygltf::Image& image = model.images[gt.source];
    texture.name = !image.uri.empty() ? image.uri : !image.name.empty() ? image.name
                                                   : "image" + std::to_string(gt.source);
    if (srgb_use[t] && linear_use[t])
      asset.warnings.push_back("texture " + texture.name +
                               " is used both as colour and as data; treated as colour");
    texture.srgb = srgb_use[t] > 0;
    if (image.width > 0 && image.height > 0 && image.component == 4 && image.bits == 8 &&
        image.image.size() == static_cast<size_t>(image.width) * image.height * 4) {
      texture.image.width = image.width;
      texture.image.height = image.height;
      texture.image.pixels = image.image;
    }
    if (size_t(gt.source) < encoded.size()) texture.encoded = encoded[size_t(gt.source)];
    asset.textures.push_back(std::move(texture));
  }
  return core::okStatus();
}

// GLB layout (glTF 2.0 §4.4): 12-byte header, JSON chunk, optional BIN chunk, each chunk with an
// 8-byte header. tinygltf 2.7 checks the BIN chunk's length without its header, so a crafted
// length makes it copy up to 8 bytes past the end of the file; check the layout here first.
core::Status checkGlbLayout(const std::vector<uint8_t>& bytes, const std::string& path) {
  auto read32 = [&](size_t offset) {
    uint32_t v;
    std::memcpy(&v, bytes.data() + offset, 4);
    return uint64_t(v);
  };
  if (bytes.size() < 20) return Error{path + ": GLB file too short for its header"};
  // (Version 1 is glTF 1.0's binary extension, another layout; it was read as if it were 2.)
  if (read32(4) != 2)
    return Error{path + ": GLB version " + std::to_string(read32(4)) +
                 " is not supported (glTF 2.0's GLB is version 2)"};
  const uint64_t length = read32(8);
  if (length > bytes.size())
    return Error{path + ": GLB header claims " + std::to_string(length) + " bytes, the file has " +
                 std::to_string(bytes.size())};
  const uint64_t json_end = 20 + read32(12);
  if (json_end > length) return Error{path + ": GLB JSON chunk runs past the end of the file"};
  if (json_end < length) {
    if (json_end + 8 > length || json_end + 8 + read32(json_end) > length)
      return Error{path + ": GLB BIN chunk runs past the end of the file"};
  }
  return core::okStatus();
}

// How deeply a JSON text nests arrays and objects (strings skipped, escapes included).
size_t jsonNestingDepth(const uint8_t* text, size_t size) {
  size_t depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < size; ++i) {
    const uint8_t c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}
// tinygltf copies `extras` and extensions into its Value one recursive call per level: a
// document nested 20,000 deep overflowed the stack (a crash, not an error). Real documents nest a
// dozen levels.
constexpr size_t kMaxJsonNesting = 256;

// Whether a URI's '%' signs each start an escape of two hex digits (RFC 3986).
bool wellEscaped(const std::string& uri) {
  for (size_t i = 0; i < uri.size(); ++i)
    if (uri[i] == '%' &&
        (i + 2 >= uri.size() || !std::isxdigit(static_cast<unsigned char>(uri[i + 1])) ||
         !std::isxdigit(static_cast<unsigned char>(uri[i + 2]))))
      return false;
  return true;
}

// Keys whose numbers glTF 2.0 defines as integers (indices, enums, sizes), below the document's
// top level (where "nodes" and "samplers" are arrays of objects): everything under them is an
// integer too (a primitive's attributes and targets, a scene's nodes, a sparse accessor's indices).
bool holdsIntegers(const std::string& key) {
  // clang-format off
  static const std::set<std::string> kIntegerKeys = {
      "attributes", "buffer", "bufferView", "byteLength", "byteOffset", "byteStride", "camera",
      "children", "componentType", "count", "index", "indices", "input", "inverseBindMatrices",
      "joints", "magFilter", "material", "mesh", "minFilter", "mode", "node", "nodes", "output",
      "sampler", "scene", "skeleton", "skin", "source", "target", "targets", "texCoord", "wrapS",
      "wrapT"};
  // clang-format on
  return kIntegerKeys.count(key) > 0;
}

// Integer fields written as whole floats (36.0, 3.6e1: integers by the schema) rewritten as
// integer literals: tinygltf reads only integer literals there, and took such a byteOffset as
// absent (0), so the data came from the wrong bytes without a word. Extensions and extras are
// left as written. Returns how many values were rewritten.
size_t wholeNumbersAsIntegers(nlohmann::json& value, bool integers, bool top_level) {
  size_t rewritten = 0;
  if (value.is_object()) {
    for (auto& [key, member] : value.items())
      if (key != "extensions" && key != "extras")
        rewritten += wholeNumbersAsIntegers(
            member, integers || (top_level ? key == "scene" : holdsIntegers(key)), false);
  } else if (value.is_array()) {
    for (nlohmann::json& element : value)
      rewritten += wholeNumbersAsIntegers(element, integers, false);
  } else if (integers && value.is_number_float()) {
    const double number = value.get<double>();
    constexpr double kExactIntegers = 9007199254740992.0;  // 2^53
    if (std::floor(number) == number && std::fabs(number) <= kExactIntegers) {
      if (number >= 0)
        value = static_cast<uint64_t>(number);
      else
        value = static_cast<int64_t>(number);
      ++rewritten;
    }
  }
  return rewritten;
}

// The JSON text with the contents of its long data: URI strings left out (each string kept as
// "data:"), or an empty string when it has none. Those strings are most of an embedded file
// (a 23 MB grid's buffer) and normalizedDocument looks no further than their "data:": parsing
// them here as well as in tinygltf cost an eighth of `duolod info` on that grid (bench/RESULTS.md,
// session 46). A '"' not escaped by a backslash and followed by "data:" opens a string in valid
// JSON (a closing quote is followed by , : ] } or space); the string ends at the next '"' that
// no backslash escapes (base64 has neither, but a writer may escape a '/' as "\/").
std::string withoutLongDataUris(const uint8_t* text, size_t size) {
  constexpr size_t kLong = 4096;
  const std::string_view all(reinterpret_cast<const char*>(text), size);
  std::string out;
  size_t copied = 0;  // text before this is in `out`
  for (size_t at = all.find("\"data:"); at != std::string_view::npos;
       at = all.find("\"data:", at + 1)) {
    size_t backslashes = 0;
    while (backslashes < at && all[at - 1 - backslashes] == '\\') ++backslashes;
    if (backslashes % 2 != 0) continue;  // an escaped quote inside another string
    size_t end = all.find('"', at + 6);  // a quote preceded by an odd run of '\\' is escaped
    for (;;) {
      if (end == std::string_view::npos) break;
      size_t run = 0;
      while (all[end - 1 - run] == '\\') ++run;
      if (run % 2 == 0) break;
      end = all.find('"', end + 1);
    }
    if (end == std::string_view::npos) break;  // unterminated: left for the parsers to report
    if (end - at - 1 < kLong) {  // its characters, as written (escapes counted as written)
      at = end;
      continue;
    }
    if (out.empty()) out.reserve(size / 16);
    out.append(all.substr(copied, at + 6 - copied));  // up to and including "data:
    copied = end;                                     // from the closing quote on
    at = end;
  }
  if (copied == 0) return std::string();
  out.append(all.substr(copied));
  return out;
}

// Calls `visit(who, primitive)` for each primitive object of the document's meshes, `who` naming
// it as messages do (primitiveName: "mesh 2 'Body', primitive 0"); stops at the first error.
template <typename Visit>
core::Status forEachPrimitive(const nlohmann::json& doc, Visit&& visit) {
  const auto meshes = doc.find("meshes");
  if (meshes == doc.end() || !meshes->is_array()) return core::okStatus();
  for (size_t m = 0; m < meshes->size(); ++m) {
    const nlohmann::json& mesh = (*meshes)[m];
    const auto primitives = mesh.is_object() ? mesh.find("primitives") : mesh.end();
    if (!mesh.is_object() || primitives == mesh.end() || !primitives->is_array()) continue;
    const auto name = mesh.find("name");
    const std::string mesh_name =
        name != mesh.end() && name->is_string() ? name->get<std::string>() : "";
    for (size_t p = 0; p < primitives->size(); ++p)
      if ((*primitives)[p].is_object())
        if (auto visited = visit(primitiveName(m, mesh_name, p), (*primitives)[p]); !visited)
          return visited;
  }
  return core::okStatus();
}

// tinygltf refuses a primitive whose indices accessor does not exist or has no bufferView, but
// with a message that names neither the mesh nor the primitive ("primitive indices accessor out
// of bounds", "accessor[5] invalid bufferView"): checked here first, saying which. (Its
// attributes' accessors are checked where they are read, viewAccessor, with the same words.)
core::Status checkIndexAccessors(const nlohmann::json& doc, const std::string& path) {
  auto arrayOf = [&](const char* key) -> const nlohmann::json* {
    const auto found = doc.find(key);
    return found != doc.end() && found->is_array() ? &*found : nullptr;
  };
  const nlohmann::json* accessors = arrayOf("accessors");
  const nlohmann::json* views = arrayOf("bufferViews");
  const size_t accessor_count = accessors ? accessors->size() : 0;
  const size_t view_count = views ? views->size() : 0;
  return forEachPrimitive(
      doc, [&](const std::string& who, const nlohmann::json& primitive) -> core::Status {
        const auto indices = primitive.find("indices");
        // (A negative or non-integer one is refused by checkAccessorsAndStrides, naming it.)
        if (indices == primitive.end() || !indices->is_number_unsigned()) return core::okStatus();
        const uint64_t index = indices->get<uint64_t>();
        const std::string where =
            path + ": " + who + ", indices: accessor " + std::to_string(index);
        if (index >= accessor_count)
          return Error{where + " does not exist (" + std::to_string(accessor_count) +
                       " accessors)"};
        const nlohmann::json& accessor = (*accessors)[index];
        if (!accessor.is_object()) return core::okStatus();
        const auto view = accessor.find("bufferView");
        if (view == accessor.end()) return Error{where + " " + kNoBufferView};
        if (view->is_number_integer() &&
            (!view->is_number_unsigned() || view->get<uint64_t>() >= view_count))
          return Error{where + "'s bufferView " + view->dump() + " does not exist (" +
                       std::to_string(view_count) + " bufferViews)"};
        // glTF 2.0 indices are unsigned bytes, shorts or ints (another type read as one would only
        // fail later, with a size that does not fit).
        const auto type = accessor.find("componentType");
        if (type != accessor.end() && type->is_number_integer()) {
          const int64_t component = type->get<int64_t>();
          if (component != 5121 && component != 5123 && component != 5125)
            return Error{where + "'s componentType " + std::to_string(component) +
                         " is not one of indices' 5121, 5123 or 5125 (unsigned byte, short, int)"};
        }
        return core::okStatus();
      });
}

// The first user of each accessor, as messages name it ("mesh 2 'Body', primitive 0, attribute
// NORMAL"), or empty when no primitive reads it; and the first primitive reference that is not an
// accessor index at all (tinygltf dropped such an attribute without a word: "no triangles").
struct AccessorUsers {
  std::vector<std::string> users;
  std::string bad_reference;  // its message, or empty
};
AccessorUsers accessorUsers(const nlohmann::json& doc, size_t accessor_count) {
  AccessorUsers result;
  result.users.resize(accessor_count);
  auto use = [&](const nlohmann::json& index, const std::string& who) {
    if (!index.is_number_unsigned()) {
      if (result.bad_reference.empty())
        result.bad_reference = who + ": " + index.dump() + " is not an accessor index";
      return;
    }
    const uint64_t i = index.get<uint64_t>();
    if (i < accessor_count && result.users[i].empty()) result.users[i] = who;
  };
  // (This visitor never fails.)
  static_cast<void>(
      forEachPrimitive(doc, [&](const std::string& who, const nlohmann::json& primitive) {
        if (const auto indices = primitive.find("indices"); indices != primitive.end())
          use(*indices, who + ", indices");
        if (const auto attributes = primitive.find("attributes");
            attributes != primitive.end() && attributes->is_object())
          for (const auto& [attribute, index] : attributes->items())
            use(index, who + ", attribute " + attribute);
        return core::okStatus();
      }));
  return result;
}

// tinygltf refuses an accessor's unknown componentType or type, and a bufferView's byteStride
// outside glTF's 4-252 bytes in steps of 4, but its messages name neither the object nor what
// uses it ("Invalid `componentType` in accessor. Got 9999"): checked here first, saying which.
core::Status checkAccessorsAndStrides(const nlohmann::json& doc, const std::string& path) {
  // Required properties, which tinygltf reports without saying which object lacks them
  // ("'byteLength' property is missing in Buffer.").
  auto lacking = [&](const nlohmann::json& object, std::initializer_list<const char*> required) {
    for (const char* field : required)
      if (!object.contains(field)) return field;
    return static_cast<const char*>(nullptr);
  };
  if (const auto buffers = doc.find("buffers"); buffers != doc.end() && buffers->is_array())
    for (size_t b = 0; b < buffers->size(); ++b)
      if ((*buffers)[b].is_object())
        if (const char* field = lacking((*buffers)[b], {"byteLength"}))
          return Error{path + ": buffer " + std::to_string(b) + " has no " + field + " (required)"};
  const auto accessors = doc.find("accessors");
  const auto views = doc.find("bufferViews");
  const bool have_accessors = accessors != doc.end() && accessors->is_array();
  const bool have_views = views != doc.end() && views->is_array();
  const size_t accessor_count = have_accessors ? accessors->size() : 0;
  const AccessorUsers found = accessorUsers(doc, accessor_count);
  if (!found.bad_reference.empty()) return Error{path + ": " + found.bad_reference};
  const std::vector<std::string>& users = found.users;
  auto accessorName = [&](size_t i) {
    return users[i].empty() ? "accessor " + std::to_string(i)
                            : users[i] + ": accessor " + std::to_string(i);
  };
  for (size_t i = 0; i < accessor_count; ++i) {
    const nlohmann::json& accessor = (*accessors)[i];
    if (!accessor.is_object()) continue;
    if (const char* field = lacking(accessor, {"componentType", "count", "type"}))
      return Error{path + ": " + accessorName(i) + " has no " + field + " (required)"};
    if (const auto type = accessor.find("componentType"); type != accessor.end()) {
      static const std::set<int64_t> kComponentTypes = {5120, 5121, 5122, 5123, 5125, 5126};
      if (!type->is_number_integer() || !kComponentTypes.count(type->get<int64_t>()))
        return Error{path + ": " + accessorName(i) + ": componentType " + type->dump() +
                     " is not a glTF component type (5120-5123, 5125 or 5126)"};
    }
    if (const auto type = accessor.find("type"); type != accessor.end()) {
      static const std::set<std::string> kTypes = {"SCALAR", "VEC2", "VEC3", "VEC4",
                                                   "MAT2",   "MAT3", "MAT4"};
      if (!type->is_string() || !kTypes.count(type->get<std::string>()))
        return Error{path + ": " + accessorName(i) + ": type " + type->dump() +
                     " is not a glTF accessor type (SCALAR, VEC2-4 or MAT2-4)"};
    }
  }
  if (!have_views) return core::okStatus();
  for (size_t v = 0; v < views->size(); ++v) {
    const nlohmann::json& view = (*views)[v];
    if (!view.is_object()) continue;
    if (const char* field = lacking(view, {"buffer", "byteLength"}))
      return Error{path + ": bufferView " + std::to_string(v) + " has no " + field + " (required)"};
    const auto stride = view.find("byteStride");
    if (stride == view.end() || !stride->is_number_unsigned()) continue;  // (normalize's check)
    const uint64_t bytes = stride->get<uint64_t>();
    if (bytes >= 4 && bytes <= 252 && bytes % 4 == 0) continue;
    std::string reader;  // the first accessor on this view, and what uses it
    for (size_t i = 0; i < accessor_count && reader.empty(); ++i) {
      const nlohmann::json& accessor = (*accessors)[i];
      if (!accessor.is_object()) continue;
      const auto on = accessor.find("bufferView");
      if (on != accessor.end() && on->is_number_unsigned() && on->get<uint64_t>() == v)
        reader = " (read by " + accessorName(i) + ")";
    }
    return Error{path + ": bufferView " + std::to_string(v) + reader + ": byteStride " +
                 std::to_string(bytes) + " is not a multiple of 4 from 4 to 252 (glTF 2.0)"};
  }
  return core::okStatus();
}

// normalizedDocument's checks and rewrites of a parsed document (an object); how many values
// were rewritten.
core::Result<size_t> normalize(nlohmann::json& doc, const std::string& path) {
  size_t rewritten = wholeNumbersAsIntegers(doc, false, true);
  auto each = [&](const char* array, auto&& visit) -> core::Status {
    const auto found = doc.find(array);
    if (found == doc.end() || !found->is_array()) return core::okStatus();
    for (size_t i = 0; i < found->size(); ++i)
      if ((*found)[i].is_object())
        if (auto visited = visit(i, (*found)[i]); !visited) return visited;
    return core::okStatus();
  };
  struct Sizes {
    const char* array;
    const char* object;
    std::initializer_list<const char*> fields;
  };
  for (const Sizes& sizes :
       {Sizes{"accessors", "accessor", {"byteOffset", "count"}},
        Sizes{"bufferViews", "bufferView", {"byteOffset", "byteLength", "byteStride"}},
        Sizes{"buffers", "buffer", {"byteLength"}}}) {
    auto status = each(sizes.array, [&](size_t i, const nlohmann::json& object) -> core::Status {
      for (const char* field : sizes.fields) {
        const auto value = object.find(field);
        if (value == object.end()) continue;
        const bool whole = value->is_number_unsigned() ||
                           (value->is_number_integer() && value->get<int64_t>() >= 0);
        if (!whole)
          return Error{path + ": " + sizes.object + " " + std::to_string(i) + ": " + field +
                       " is " + value->dump() + ", not a non-negative integer"};
      }
      return core::okStatus();
    });
    if (!status) return status.error();
  }
  for (const auto& [array, object] : {std::pair{"buffers", "buffer"}, {"images", "image"}}) {
    auto status = each(array, [&](size_t i, nlohmann::json& element) -> core::Status {
      const auto uri = element.find("uri");
      if (uri == element.end() || !uri->is_string()) return core::okStatus();
      std::string& text = uri->get_ref<std::string&>();
      if (text.starts_with("data:")) return core::okStatus();
      if (!wellEscaped(text))
        return Error{path + ": " + object + " " + std::to_string(i) + ": uri '" + text +
                     "' has a '%' not followed by two hex digits (a file name's '%' is written "
                     "%25)"};
      for (size_t at = text.find('+'); at != std::string::npos; at = text.find('+', at + 3)) {
        text.replace(at, 1, "%2B");
        ++rewritten;
      }
      return core::okStatus();
    });
    if (!status) return status.error();
  }
  if (auto checked = checkIndexAccessors(doc, path); !checked) return checked.error();
  if (auto checked = checkAccessorsAndStrides(doc, path); !checked) return checked.error();
  return rewritten;
}

// The document as tinygltf is to read it, parsed here first for what tinygltf lets through and
// then reads wrongly:
//   - integer fields written as whole floats are rewritten as integers (wholeNumbersAsIntegers);
//   - a '+' in a buffer's or image's uri is a plus sign (RFC 3986), which tinygltf decoded as a
//     space (a+b.bin was looked for as "a b.bin"): it is rewritten as %2B;
//   - offsets, lengths, strides and counts are non-negative integers (glTF 2.0's schema): a
//     negative or fractional byteOffset was read as 0; refused, naming the object and field;
//   - a '%' in a uri escapes two hex digits: a bad escape cut the file name short ("File not
//     found : m"); refused, naming the uri;
//   - a primitive's indices accessor exists and has a bufferView: tinygltf refuses it otherwise
//     without saying which mesh (checkIndexAccessors); refused naming the mesh and primitive.
// Returns the rewritten JSON text, or an empty string when nothing needed rewriting. A document
// that does not parse is left to tinygltf, whose message says where. Long data: URIs are parsed
// only when the document is rewritten (withoutLongDataUris).
core::Result<std::string> normalizedDocument(const uint8_t* text, size_t size,
                                             const std::string& path) {
  const std::string shortened = withoutLongDataUris(text, size);
  nlohmann::json doc =
      shortened.empty() ? nlohmann::json::parse(text, text + size, nullptr, false)
                        : nlohmann::json::parse(shortened.begin(), shortened.end(), nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return std::string();
  auto rewritten = normalize(doc, path);
  if (rewritten && *rewritten == 0) return std::string();
  // A refusal, or a rewritten text (which goes to tinygltf, so it needs the data: URIs parsed
  // without above), from the whole document (rare with long data: URIs): a document whose only
  // fault is inside a data: URI (a raw line break in MIME-wrapped base64) gets the parser's
  // message, not a check's, and two long "data:..." keys of one object are not one.
  if (!shortened.empty()) {
    doc = nlohmann::json::parse(text, text + size, nullptr, false);
    if (doc.is_discarded() || !doc.is_object()) return std::string();
    rewritten = normalize(doc, path);
  }
  if (!rewritten) return rewritten.error();
  if (*rewritten == 0) return std::string();
  return doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// A GLB file with its JSON chunk replaced by `json` (padded with spaces to 4 bytes, as the
// specification asks); the chunks after it are kept as they are. `glb` passed checkGlbLayout.
std::vector<uint8_t> glbWithJson(const std::vector<uint8_t>& glb, uint32_t json_size,
                                 const std::string& json) {
  std::string padded = json;
  while (padded.size() % 4) padded += ' ';
  std::vector<uint8_t> out(glb.begin(), glb.begin() + 20);  // header and JSON chunk header
  out.insert(out.end(), padded.begin(), padded.end());
  out.insert(out.end(), glb.begin() + 20 + json_size, glb.end());
  const uint32_t total = static_cast<uint32_t>(out.size());
  const uint32_t chunk = static_cast<uint32_t>(padded.size());
  std::memcpy(out.data() + 8, &total, 4);
  std::memcpy(out.data() + 12, &chunk, 4);
  return out;
}

}  // namespace

namespace {

// A URI reference's file name: %XX decoded (the writer encodes spaces and UTF-8, so an image
// named "my texture.png" is "my%20texture.png" in the document).
std::string fileNameOfUri(const std::string& uri) {
  auto hex = [](char c) {
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
  };
  std::string name;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) >= 0 && hex(uri[i + 2]) >= 0) {
      name += static_cast<char>(hex(uri[i + 1]) * 16 + hex(uri[i + 2]));
      i += 2;
    } else {
      name += uri[i];
    }
  }
  return name;
}

}  // namespace

core::Result<core::Asset> readGltf(const std::string& path, const LoadOptions& options) {
  tinygltf::TinyGLTF loader;
  ImageLoaderContext context;
  context.load = options.load_textures;
  context.decode = options.decode_textures;
  loader.SetImageLoader(loadImageThroughStb, &context);
  std::vector<std::string> files_read;
  loader.SetFsCallbacks({&fileExists, &tinygltf::ExpandFilePath, &readWholeFile,
                         &tinygltf::WriteWholeFile, &files_read});
  tinygltf::Model model;
  std::string error, warning;
  bool binary = false;
  std::vector<uint8_t> document;  // the file, or the file with its JSON rewritten
  {
    auto head = readFileBytes(path);
    if (!head) return head.error();
    binary = head->size() >= 4 && std::memcmp(head->data(), "glTF", 4) == 0;
    if (binary) {
      if (auto layout = checkGlbLayout(*head, path); !layout) return layout.error();
    }
    if (head->empty()) return Error{path + ": file is empty"};
    // A .glb that is not one: said so, rather than a JSON parser's complaint about a binary byte.
    std::string extension = std::filesystem::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (!binary && extension == ".glb" && (*head)[0] != '{' && !std::isspace((*head)[0]))
      return Error{path + ": not a GLB file (it does not start with the magic 'glTF')"};
    uint32_t json_size = 0;
    if (binary) std::memcpy(&json_size, head->data() + 12, 4);  // checkGlbLayout: in the file
    const size_t depth = binary ? jsonNestingDepth(head->data() + 20, json_size)
                                : jsonNestingDepth(head->data(), head->size());
    if (depth > kMaxJsonNesting)
      return Error{path + ": the JSON nests " + std::to_string(depth) + " levels deep (at most " +
                   std::to_string(kMaxJsonNesting) + " are read)"};
    auto rewritten = binary ? normalizedDocument(head->data() + 20, json_size, path)
                            : normalizedDocument(head->data(), head->size(), path);
    if (!rewritten) return rewritten.error();
    if (!rewritten->empty())
      document = binary ? glbWithJson(*head, json_size, *rewritten)
                        : std::vector<uint8_t>(rewritten->begin(), rewritten->end());
    else
      document = std::move(*head);
  }
  if (document.size() > std::numeric_limits<unsigned>::max())
    return Error{path + ": " + std::to_string(document.size()) +
                 " bytes: larger than the 4 GiB a glTF file may hold"};
  context.model = &model;
  // From the bytes read above (tinygltf's *FromFile read the file again), with the base folder
  // tinygltf's *FromFile would take.
  files_read.push_back(path);
  const std::string base_dir = tinygltf::GetBaseDir(path);
  const unsigned size = static_cast<unsigned>(document.size());
  bool ok = binary ? loader.LoadBinaryFromMemory(&model, &error, &warning, document.data(), size,
                                                 base_dir)
                   : loader.LoadASCIIFromString(&model, &error, &warning,
                                                reinterpret_cast<const char*>(document.data()),
                                                size, base_dir);
  if (!ok) {
    while (!error.empty() && (error.back() == '\n' || error.back() == ' ')) error.pop_back();
    if (error.empty()) error = "not a valid glTF file";
    std::replace(error.begin(), error.end(), '\n', ';');
    // tinygltf quotes a data uri whole ("Failed to decode 'uri' : data:...;base64,<megabytes>"):
    // its payload is cut to its start.
    for (size_t at = error.find("data:"); at != std::string::npos;
         at = error.find("data:", at + 1)) {
      const size_t comma = error.find(',', at);
      if (comma == std::string::npos) break;
      const size_t end = std::min(error.find_first_of(" ';\"", comma), error.size());
      if (end - comma > 48)
        error.replace(comma + 33, end - comma - 33,
                      "... (" + std::to_string(end - comma - 1) + " characters)");
    }
    return Error{path + ": " + error};
  }
  // glTF 2 only (1.0's materials and techniques are another format), and no extension the file
  // declares required that is not read here: the spec's rule, for what it needs cannot be drawn
  // right without it (Draco-compressed geometry, say, reads as broken accessors).
  if (!model.asset.version.starts_with("2."))
    return Error{path + ": glTF version '" + model.asset.version +
                 "' is not supported (glTF 2.0 only)"};
  for (const std::string& extension : model.extensionsRequired)
    if (extension != "KHR_mesh_quantization")  // any accessor component type is read
      return Error{path + ": requires the glTF extension " + extension +
                   ", which duolod does not read (extensionsRequired)"};
  core::Asset asset;
  asset.source_path = path;
  // The files read (the document, its buffers, its images when textures are loaded) and the
  // image files it names in any case: the writers never replace them.
  asset.source_files = std::move(files_read);
  for (const tinygltf::Image& image : model.images)
    if (!image.uri.empty() && !image.uri.starts_with("data:"))
      asset.source_files.push_back(
          (std::filesystem::path(path).parent_path() / fileNameOfUri(image.uri))
              .lexically_normal()
              .string());
  if (!warning.empty()) asset.warnings.push_back(warning);
  // A uri that leaves the asset's folder (absolute, or up through ..) is read as the spec allows,
  // but said: a pipeline converting files it did not make would otherwise copy whatever such a
  // uri names into its outputs unawares.
  {
    auto outside = [&](const std::string& uri) {
      if (uri.empty() || uri.starts_with("data:")) return false;
      const std::filesystem::path relative =
          std::filesystem::path(fileNameOfUri(uri)).lexically_normal();
      return relative.is_absolute() || (!relative.empty() && *relative.begin() == "..");
    };
    for (size_t i = 0; i < model.buffers.size(); ++i)
      if (outside(model.buffers[i].uri))
        asset.warnings.push_back(path + ": buffer " + std::to_string(i) + "'s uri '" +
                                 model.buffers[i].uri + "' is outside the asset's folder");
    for (size_t i = 0; i < model.images.size(); ++i)
      if (outside(model.images[i].uri))
        asset.warnings.push_back(path + ": image " + std::to_string(i) + "'s uri '" +
                                 model.images[i].uri + "' is outside the asset's folder");
  }
  if (auto materials = readMaterials(model, path, context.encoded, asset); !materials)
    return materials.error();
  GltfFlattener flattener(model, path, asset);
  std::vector<int> roots;
  int scene = model.defaultScene >= 0 ? model.defaultScene : (model.scenes.empty() ? -1 : 0);
  if (scene >= static_cast<int>(model.scenes.size()))
    return Error{path + ": default scene " + std::to_string(scene) + " does not exist"};
  if (options.gltf_node >= 0) {
    if (options.gltf_node >= static_cast<int>(model.nodes.size()))
      return Error{path + ": node " + std::to_string(options.gltf_node) + " does not exist (" +
                   std::to_string(model.nodes.size()) + " nodes)"};
    roots = {options.gltf_node};
  } else if (scene >= 0) {
    roots = model.scenes[scene].nodes;
  } else {
    // No scene: take every mesh once, untransformed.
    for (size_t m = 0; m < model.meshes.size(); ++m)
      if (auto added = flattener.addMesh(static_cast<int>(m), core::Mat4::identity()); !added)
        return added.error();
  }
  for (int root : roots)
    if (auto visited = flattener.visit(root, core::Mat4::identity(), 0); !visited)
      return visited.error();
  flattener.finish();
  if (flattener.usesDefaultMaterial()) asset.materials.push_back(core::Material{.name = "default"});
  if (options.load_textures)
    for (const core::Texture& texture : asset.textures)
      if (texture.image.pixels.empty() && !texture.encoded && !texture.name.empty())
      {
        // Say whether the file is there at all (the common case: a texture not copied along).
        std::error_code ec;
        const std::filesystem::path beside =
            std::filesystem::path(path).parent_path() / texture.name;
        const bool missing = texture.name.find('/') == std::string::npos &&
                             texture.name.find('.') != std::string::npos &&
                             !std::filesystem::exists(beside, ec);
        return Error{path + ": texture image '" + texture.name + "' could not be loaded" +
                     (missing ? " (" + beside.string() + " does not exist)"
                              : " (not a readable PNG or JPEG)")};
      }
  return asset;
}

}  // namespace duolod::io
