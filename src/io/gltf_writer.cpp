// glTF 2.0 writer (Khronos glTF 2.0 specification §5 for the JSON schema, §4.4 for GLB): one mesh
// with a primitive per submesh, metallic-roughness materials, PNG textures, written as .gltf with a
// .bin and PNG files beside it, or as a single .glb. Every file goes through writeFileAtomic.
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "duolod/io.hpp"

namespace duolod::io {
namespace {
namespace fs = std::filesystem;
using core::Error;
using nlohmann::json;

constexpr int kFloat = 5126;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

class GltfBuilder {
 public:
  // Appends bytes to the binary buffer (4-byte aligned) and returns the bufferView index.
  int addView(const void* data, size_t size, int target) {
    while (bin_.size() % 4) bin_.push_back(0);
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target) view["target"] = target;
    const auto* bytes = static_cast<const uint8_t*>(data);
    bin_.insert(bin_.end(), bytes, bytes + size);
    views_.push_back(view);
    return static_cast<int>(views_.size()) - 1;
  }

  template <class T>
  int addFloatAccessor(const std::vector<T>& stream, const char* type, bool with_bounds) {
    int components = static_cast<int>(sizeof(T) / sizeof(float));
    int view = addView(stream.data(), stream.size() * sizeof(T), kArrayBuffer);
    json accessor = {
        {"bufferView", view}, {"componentType", kFloat}, {"count", stream.size()}, {"type", type}};
    if (with_bounds) {  // required for POSITION (glTF §5.1.1)
      std::vector<float> lo(components, INFINITY), hi(components, -INFINITY);
      for (const T& v : stream)
        for (int c = 0; c < components; ++c) {
          float x = reinterpret_cast<const float*>(&v)[c];
          lo[c] = std::min(lo[c], x);
          hi[c] = std::max(hi[c], x);
        }
      accessor["min"] = lo;
      accessor["max"] = hi;
    }
    accessors_.push_back(accessor);
    return static_cast<int>(accessors_.size()) - 1;
  }

  int addIndexAccessor(const uint32_t* indices, size_t count) {
    int view = addView(indices, count * 4, kElementArrayBuffer);
    accessors_.push_back({{"bufferView", view},
                          {"componentType", kUnsignedInt},
                          {"count", count},
                          {"type", "SCALAR"}});
    return static_cast<int>(accessors_.size()) - 1;
  }

  json views_ = json::array();
  json accessors_ = json::array();
  std::vector<uint8_t> bin_;
};

json materialJson(const core::Material& m) {
  json pbr = {{"baseColorFactor",
               {m.base_color_factor.x, m.base_color_factor.y, m.base_color_factor.z,
                m.base_color_factor.w}},
              {"metallicFactor", m.metallic_factor},
              {"roughnessFactor", m.roughness_factor}};
  if (m.base_color_texture >= 0) pbr["baseColorTexture"] = {{"index", m.base_color_texture}};
  if (m.metallic_roughness_texture >= 0)
    pbr["metallicRoughnessTexture"] = {{"index", m.metallic_roughness_texture}};
  json out = {{"name", m.name}, {"pbrMetallicRoughness", pbr}};
  if (m.normal_texture >= 0)
    out["normalTexture"] = {{"index", m.normal_texture}, {"scale", m.normal_scale}};
  if (m.occlusion_texture >= 0)
    out["occlusionTexture"] = {{"index", m.occlusion_texture}, {"strength", m.occlusion_strength}};
  if (m.emissive_texture >= 0) out["emissiveTexture"] = {{"index", m.emissive_texture}};
  if (m.emissive_factor.x != 0 || m.emissive_factor.y != 0 || m.emissive_factor.z != 0)
    out["emissiveFactor"] = {m.emissive_factor.x, m.emissive_factor.y, m.emissive_factor.z};
  if (m.alpha_mode == core::AlphaMode::kMask) {
    out["alphaMode"] = "MASK";
    out["alphaCutoff"] = m.alpha_cutoff;
  } else if (m.alpha_mode == core::AlphaMode::kBlend) {
    out["alphaMode"] = "BLEND";
  }
  if (m.double_sided) out["doubleSided"] = true;
  return out;
}

// A file name as a glTF URI reference (RFC 3986): every byte but the unreserved characters
// percent-encoded, UTF-8 bytes one by one. Readers decode %XX, so "a%20b.bin" written raw was
// read back as "a b.bin".
std::string uriOfFileName(const std::string& name) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string uri;
  for (char c : name) {
    const unsigned char byte = static_cast<unsigned char>(c);
    if (std::isalnum(byte) || c == '-' || c == '.' || c == '_' || c == '~') {
      uri += c;
    } else {
      uri += '%';
      uri += kHex[byte >> 4];
      uri += kHex[byte & 15];
    }
  }
  return uri;
}

template <class T>
bool sameElements(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Equal bit for bit, so that a level whose mesh another level already has (a level that changes
// only the shader) can share that glTF mesh instead of storing its buffers again.
bool sameMesh(const core::Mesh& a, const core::Mesh& b) {
  if (a.submeshes.size() != b.submeshes.size()) return false;
  for (size_t i = 0; i < a.submeshes.size(); ++i)
    if (a.submeshes[i].first_index != b.submeshes[i].first_index ||
        a.submeshes[i].index_count != b.submeshes[i].index_count ||
        a.submeshes[i].material != b.submeshes[i].material)
      return false;
  return sameElements(a.indices, b.indices) && sameElements(a.positions, b.positions) &&
         sameElements(a.normals, b.normals) && sameElements(a.tangents, b.tangents) &&
         sameElements(a.uv0, b.uv0) && sameElements(a.uv1, b.uv1) &&
         sameElements(a.colors, b.colors);
}

// Writes `meshes` (one node each) with the asset's materials and textures. With `screen_coverage`
// non-empty, node 0 chains the others through MSFT_lod and only node 0 is in the scene.
core::Status writeGltfDocument(const core::Asset& asset, std::span<const core::Mesh> meshes,
                               std::span<const double> screen_coverage, const std::string& path,
                               const WriteOptions& options) {
  if (auto refused = refuseSourceFile(asset, path); !refused) return refused;
  if (auto consistent = core::validateAssetReferences(asset); !consistent)
    return Error{path + ": cannot write the asset: " + consistent.error().message};
  for (size_t i = 0; i < meshes.size(); ++i)
    if (auto valid = core::validateSubmeshMaterials(meshes[i], asset.materials.size()); !valid)
      return Error{path + ": cannot write the asset: " +
                   (meshes.size() > 1 ? "level " + std::to_string(i) + ": " : std::string()) +
                   valid.error().message};
  for (size_t i = 0; i < meshes.size(); ++i)
    if (meshes[i].indices.empty())  // a mesh with no primitive is not valid glTF
      return Error{path + ": cannot write a mesh with no triangles" +
                   (meshes.size() > 1 ? " (level " + std::to_string(i) + ")" : std::string())};
  for (size_t i = 0; i < meshes.size(); ++i)
    if (auto valid = core::validateMesh(meshes[i]); !valid)
      return Error{path + ": cannot write an invalid mesh" +
                   (meshes.size() > 1 ? " (level " + std::to_string(i) + ")" : std::string()) +
                   ": " + valid.error().message};
  fs::path target(path);
  std::string extension = target.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
  bool binary = extension == ".glb";
  if (!binary && extension != ".gltf")
    return Error{path + ": glTF output needs a .gltf or .glb extension"};

  GltfBuilder builder;
  json gltf_meshes = json::array(), nodes = json::array();
  for (size_t level = 0; level < meshes.size(); ++level) {
    const core::Mesh& mesh = meshes[level];
    std::string name = target.stem().string();
    if (meshes.size() > 1) name += "_LOD" + std::to_string(level);
    // Levels that differ only in their shader have the same mesh: one glTF mesh, several nodes.
    auto earlier = std::find_if(meshes.begin(), meshes.begin() + level,
                                [&](const core::Mesh& other) { return sameMesh(other, mesh); });
    if (earlier != meshes.begin() + level) {
      nodes.push_back({{"mesh", nodes[size_t(earlier - meshes.begin())]["mesh"]}, {"name", name}});
      continue;
    }
    json attributes = {{"POSITION", builder.addFloatAccessor(mesh.positions, "VEC3", true)}};
    if (!mesh.normals.empty())
      attributes["NORMAL"] = builder.addFloatAccessor(mesh.normals, "VEC3", false);
    if (!mesh.tangents.empty())
      attributes["TANGENT"] = builder.addFloatAccessor(mesh.tangents, "VEC4", false);
    if (!mesh.uv0.empty())
      attributes["TEXCOORD_0"] = builder.addFloatAccessor(mesh.uv0, "VEC2", false);
    if (!mesh.uv1.empty())
      attributes["TEXCOORD_1"] = builder.addFloatAccessor(mesh.uv1, "VEC2", false);
    if (!mesh.colors.empty())
      attributes["COLOR_0"] = builder.addFloatAccessor(mesh.colors, "VEC4", false);

    json primitives = json::array();
    for (const core::Submesh& sub : mesh.submeshes) {
      if (sub.index_count == 0) continue;
      json primitive = {{"attributes", attributes},
                        {"indices", builder.addIndexAccessor(mesh.indices.data() + sub.first_index,
                                                             sub.index_count)},
                        {"mode", 4}};
      if (sub.material < asset.materials.size()) primitive["material"] = sub.material;
      primitives.push_back(primitive);
    }
    nodes.push_back({{"mesh", gltf_meshes.size()}, {"name", name}});
    gltf_meshes.push_back({{"primitives", primitives}, {"name", name}});
  }
  const bool lod_chain = !screen_coverage.empty();
  if (lod_chain && meshes.size() > 1) {
    // MSFT_lod: the finest node lists the coarser ones in order of decreasing detail.
    json ids = json::array();
    for (size_t level = 1; level < meshes.size(); ++level) ids.push_back(level);
    nodes[0]["extensions"] = {{"MSFT_lod", {{"ids", ids}}}};
    nodes[0]["extras"] = {{"MSFT_screencoverage", screen_coverage}};
  }

  json materials = json::array();
  for (const core::Material& m : asset.materials) materials.push_back(materialJson(m));

  // Textures: files beside a .gltf, or embedded bufferViews in a .glb; the bytes they were read
  // from while unchanged (textureFile), else PNG. Textures whose files would be equal byte for
  // byte (one source image used as colour and as emission, say) share one image, written once.
  json images = json::array(), textures = json::array();
  std::vector<std::pair<std::string, std::vector<uint8_t>>> side_files;
  std::vector<TextureFile> image_files;
  for (size_t t = 0; t < asset.textures.size(); ++t) {
    core::Texture blank;
    const core::Texture* texture = &asset.textures[t];
    if (texture->image.pixels.empty() && !texture->encoded) {  // keep indices stable
      blank.image = {1, 1, {255, 255, 255, 255}};
      texture = &blank;
    }
    TextureFile file = textureFile(*texture);
    auto same = std::find_if(image_files.begin(), image_files.end(), [&](const TextureFile& f) {
      return f.mime_type == file.mime_type && f.bytes == file.bytes;
    });
    const size_t image = size_t(same - image_files.begin());
    if (same == image_files.end()) {
      if (binary) {
        images.push_back({{"bufferView", builder.addView(file.bytes.data(), file.bytes.size(), 0)},
                          {"mimeType", file.mime_type}});
      } else {
        std::string name =
            target.stem().string() + "_texture" + std::to_string(image) + file.extension;
        images.push_back({{"uri", uriOfFileName(name)}});
        side_files.emplace_back((target.parent_path() / name).string(), std::vector<uint8_t>{});
      }
      image_files.push_back(std::move(file));
    }
    textures.push_back({{"source", image}, {"sampler", 0}});
  }
  for (size_t i = 0; i < side_files.size(); ++i)  // moved, once no more textures compare
    side_files[i].second = std::move(image_files[i].bytes);

  json document = {
      {"asset", {{"version", "2.0"}, {"generator", "duolod " DUOLOD_VERSION}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", nodes},
      {"meshes", gltf_meshes},
      {"accessors", builder.accessors_},
      {"bufferViews", builder.views_},
  };
  if (lod_chain && meshes.size() > 1) document["extensionsUsed"] = {"MSFT_lod"};
  if (!materials.empty()) document["materials"] = materials;
  if (!textures.empty()) {
    document["textures"] = textures;
    document["images"] = images;
    // Trilinear, repeat: what duolod renders with.
    document["samplers"] = {
        {{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}};
  }
  while (builder.bin_.size() % 4) builder.bin_.push_back(0);

  if (binary) {
    document["buffers"] = {{{"byteLength", builder.bin_.size()}}};
    std::string text = document.dump(-1, ' ', false, json::error_handler_t::replace);
    while (text.size() % 4) text.push_back(' ');
    std::vector<uint8_t> glb;
    auto put32 = [&](uint32_t v) {
      for (int i = 0; i < 4; ++i) glb.push_back(static_cast<uint8_t>(v >> (8 * i)));
    };
    uint32_t total = 12 + 8 + static_cast<uint32_t>(text.size()) + 8 +
                     static_cast<uint32_t>(builder.bin_.size());
    put32(0x46546C67);  // "glTF"
    put32(2);
    put32(total);
    put32(static_cast<uint32_t>(text.size()));
    put32(0x4E4F534A);  // "JSON"
    glb.insert(glb.end(), text.begin(), text.end());
    put32(static_cast<uint32_t>(builder.bin_.size()));
    put32(0x004E4942);  // "BIN\0"
    glb.insert(glb.end(), builder.bin_.begin(), builder.bin_.end());
    FileSet file(options.replace_existing);
    if (auto added = file.add(path, glb); !added) return added;
    return file.commit();
  }
  std::string bin_name = target.stem().string() + ".bin";
  document["buffers"] = {{{"byteLength", builder.bin_.size()}, {"uri", uriOfFileName(bin_name)}}};
  // Side files must not replace any file the asset was read from (its own .bin or textures,
  // which may carry these names); an earlier output's are replaced.
  side_files.emplace_back((target.parent_path() / bin_name).string(), std::move(builder.bin_));
  for (const auto& [file, bytes] : side_files)
    if (auto refused = refuseSourceFile(asset, file); !refused) return refused;
  // All or nothing: a failure (a full disk, a folder in the way) leaves none of the files.
  FileSet files(options.replace_existing);
  for (const auto& [file, bytes] : side_files)
    if (auto added = files.add(file, bytes); !added) return added;
  if (auto added = files.add(path, document.dump(2, ' ', false, json::error_handler_t::replace));
      !added)
    return added;
  return files.commit();
}

}  // namespace

core::Status writeGltf(const core::Asset& asset, const std::string& path,
                       const WriteOptions& options) {
  return writeGltfDocument(asset, std::span<const core::Mesh>(&asset.mesh, 1), {}, path, options);
}

core::Status writeGltfLodChain(const core::Asset& asset, std::span<const core::Mesh> level_meshes,
                               std::span<const double> screen_coverage, const std::string& path) {
  if (level_meshes.empty()) return Error{path + ": a LOD chain needs at least one level"};
  if (screen_coverage.size() != level_meshes.size())
    return Error{path + ": " + std::to_string(level_meshes.size()) +
                 " levels need as many screen " + "coverage values, got " +
                 std::to_string(screen_coverage.size())};
  for (size_t i = 0; i < screen_coverage.size(); ++i) {
    if (!(screen_coverage[i] >= 0 && screen_coverage[i] <= 1))
      return Error{path + ": screen coverage " + std::to_string(i) + " is not in [0, 1]"};
    if (i > 0 && screen_coverage[i] > screen_coverage[i - 1])
      return Error{path + ": screen coverage must decrease from level to level (level " +
                   std::to_string(i) + ")"};
  }
  return writeGltfDocument(asset, level_meshes, screen_coverage, path, {});
}

}  // namespace duolod::io
