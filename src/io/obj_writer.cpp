// Wavefront OBJ + MTL writer, after "Object Files (.obj)" and "MTL Material Format" (Wavefront
// Advanced Visualizer manual, Appendix B1) with the Exocortex PBR extension (Pr, Pm, Ke, map_Pr,
// map_Pm, norm), so that readObj reads back what is written here. Textures with decoded images
// are written as PNG beside the .obj.
#include <algorithm>
#include <charconv>
#include <filesystem>
#include <set>

#include "duolod/io.hpp"

namespace duolod::io {
namespace {

namespace fs = std::filesystem;
using core::Error;

// Shortest text that reads back to the same float.
void appendFloat(std::string& out, float value) {
  char buffer[32];
  auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, ec == std::errc() ? end : buffer);
}

void appendFloats(std::string& out, std::string_view keyword, std::initializer_list<float> values) {
  out += keyword;
  for (float value : values) {
    out += ' ';
    appendFloat(out, value);
  }
  out += '\n';
}

// usemtl/newmtl take the rest of the line, so names may hold spaces, but not line breaks, and an
// empty or repeated name would merge materials on reading back.
std::vector<std::string> uniqueMaterialNames(const std::vector<core::Material>& materials) {
  std::vector<std::string> names;
  std::set<std::string> taken;
  for (size_t i = 0; i < materials.size(); ++i) {
    std::string name = materials[i].name;
    for (char& c : name) {
      if (c == '\n' || c == '\r' || c == '\t') c = ' ';
    }
    while (!name.empty() && name.back() == ' ') name.pop_back();
    while (!name.empty() && name.front() == ' ') name.erase(name.begin());
    if (name.empty()) name = "material_" + std::to_string(i);
    std::string unique = name;
    for (int suffix = 1; taken.count(unique); ++suffix)
      unique = name + "_" + std::to_string(suffix);
    taken.insert(unique);
    names.push_back(unique);
  }
  return names;
}

class ObjWriter {
 public:
  ObjWriter(const core::Asset& asset, const std::string& path, const WriteOptions& options)
      : asset_(asset), path_(path), files_(options.replace_existing) {}

  core::Status write() {
    const core::Mesh& mesh = asset_.mesh;
    if (auto status = core::validateMesh(mesh); !status) {
      return Error{path_ + ": cannot write an invalid mesh: " + status.error().message};
    }
    if (auto status = core::validateAssetReferences(asset_); !status)
      return Error{path_ + ": cannot write the asset: " + status.error().message};
    fs::path obj_path(path_);
    fs::path mtl_path = fs::path(obj_path).replace_extension(".mtl");
    if (auto status = refuseSource(obj_path); !status) return status;
    if (!asset_.materials.empty()) {
      if (auto status = refuseSource(mtl_path); !status) return status;
    }
    std::string stem = obj_path.stem().string();

    // Textures first, so the MTL can name their files.
    // Textures whose files would be equal byte for byte share one file, written once.
    std::vector<std::string> texture_files(asset_.textures.size());
    std::vector<std::pair<TextureFile, std::string>> written;
    for (size_t i = 0; i < asset_.textures.size(); ++i) {
      const core::Texture& texture = asset_.textures[i];
      if (texture.image.pixels.empty() && !texture.encoded) {
        // Not decoded: point at the original file, if it is one, relative to the output folder.
        std::error_code ec;
        if (!texture.name.empty() && fs::is_regular_file(texture.name, ec)) {
          fs::path original = fs::absolute(texture.name, ec);
          fs::path relative = original.lexically_relative(fs::absolute(obj_path, ec).parent_path());
          texture_files[i] = relative.empty() ? original.string() : relative.string();
        }
        continue;
      }
      // The bytes it was read from while unchanged (textureFile), else PNG.
      TextureFile encoded = textureFile(texture);
      auto same = std::find_if(written.begin(), written.end(), [&](const auto& w) {
        return w.first.mime_type == encoded.mime_type && w.first.bytes == encoded.bytes;
      });
      if (same != written.end()) {
        texture_files[i] = same->second;
        continue;
      }
      // Numbered by the files written, so that shared and unwritten textures leave no gaps.
      std::string file = stem + "_texture" + std::to_string(written.size()) + encoded.extension;
      fs::path image_path = obj_path.parent_path() / file;
      if (auto status = refuseSource(image_path); !status) return status;
      if (encoded.bytes.empty())
        return Error{image_path.string() + ": cannot encode texture as PNG"};
      if (auto status = files_.add(image_path.string(), std::span<const uint8_t>(encoded.bytes));
          !status) {
        return status;
      }
      texture_files[i] = file;
      written.emplace_back(std::move(encoded), file);
    }

    std::vector<std::string> names = uniqueMaterialNames(asset_.materials);
    std::string obj = "# written by duolod\n";
    if (!asset_.materials.empty()) obj += "mtllib " + mtl_path.filename().string() + "\n";
    bool colors = !mesh.colors.empty();
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const core::Vec3& p = mesh.positions[i];
      if (colors) {
        const core::Vec4& c = mesh.colors[i];
        appendFloats(obj, "v", {p.x, p.y, p.z, c.x, c.y, c.z});
      } else {
        appendFloats(obj, "v", {p.x, p.y, p.z});
      }
    }
    // Ours is v down (glTF); OBJ's is v up.
    for (const core::Vec2& uv : mesh.uv0) appendFloats(obj, "vt", {uv.x, 1.0f - uv.y});
    for (const core::Vec3& n : mesh.normals) appendFloats(obj, "vn", {n.x, n.y, n.z});

    bool uvs = !mesh.uv0.empty();
    bool normals = !mesh.normals.empty();
    auto appendCorner = [&](uint32_t index) {
      // Every stream has one entry per vertex, so one index serves v, vt and vn.
      std::string number = std::to_string(index + 1ull);
      obj += ' ';
      obj += number;
      if (uvs || normals) obj += '/';
      if (uvs) obj += number;
      if (normals) {
        obj += '/';
        obj += number;
      }
    };
    for (const core::Submesh& submesh : mesh.submeshes) {
      if (submesh.material < names.size()) obj += "usemtl " + names[submesh.material] + "\n";
      for (uint32_t i = 0; i + 2 < submesh.index_count; i += 3) {
        obj += 'f';
        for (uint32_t k = 0; k < 3; ++k) appendCorner(mesh.indices[submesh.first_index + i + k]);
        obj += '\n';
      }
    }

    if (!asset_.materials.empty()) {
      std::string mtl = "# written by duolod\n";
      for (size_t i = 0; i < asset_.materials.size(); ++i) {
        appendMaterial(mtl, asset_.materials[i], names[i], texture_files);
      }
      if (auto status = files_.add(mtl_path.string(), std::string_view(mtl)); !status) {
        return status;
      }
    }
    if (auto status = files_.add(path_, std::string_view(obj)); !status) return status;
    // All or nothing: a failure before here (a full disk, a folder in the way) left none of the
    // textures, the .mtl or the .obj.
    return files_.commit();
  }

 private:
  // No file written may replace one the asset was read from (the .obj, its .mtl or textures,
  // which may carry the names this output's files get).
  core::Status refuseSource(const fs::path& output) const {
    return refuseSourceFile(asset_, output.string());
  }

  void appendMaterial(std::string& mtl, const core::Material& material, const std::string& name,
                      const std::vector<std::string>& texture_files) const {
    auto file = [&](int texture) -> const std::string* {
      if (texture < 0 || static_cast<size_t>(texture) >= texture_files.size()) return nullptr;
      return texture_files[texture].empty() ? nullptr : &texture_files[texture];
    };
    mtl += "\nnewmtl " + name + "\n";
    const core::Vec4& base = material.base_color_factor;
    appendFloats(mtl, "Kd", {base.x, base.y, base.z});
    if (base.w < 1.0f) appendFloats(mtl, "d", {base.w});
    const core::Vec3& emissive = material.emissive_factor;
    if (emissive.x != 0 || emissive.y != 0 || emissive.z != 0 || material.emissive_texture >= 0) {
      appendFloats(mtl, "Ke", {emissive.x, emissive.y, emissive.z});
    }
    appendFloats(mtl, "Pr", {material.roughness_factor});
    appendFloats(mtl, "Pm", {material.metallic_factor});
    if (const std::string* f = file(material.base_color_texture)) mtl += "map_Kd " + *f + "\n";
    if (const std::string* f = file(material.emissive_texture)) mtl += "map_Ke " + *f + "\n";
    if (const std::string* f = file(material.normal_texture)) {
      mtl += "norm";
      if (material.normal_scale != 1.0f) {
        mtl += " -bm ";
        appendFloat(mtl, material.normal_scale);
      }
      mtl += " " + *f + "\n";
    }
    // glTF packs roughness in G and metallic in B of one texture; point both maps at it.
    if (const std::string* f = file(material.metallic_roughness_texture)) {
      mtl += "map_Pr -imfchan g " + *f + "\n";
      mtl += "map_Pm -imfchan b " + *f + "\n";
    }
  }

  const core::Asset& asset_;
  const std::string& path_;
  FileSet files_;
};

}  // namespace

core::Status writeObj(const core::Asset& asset, const std::string& path,
                      const WriteOptions& options) {
  return ObjWriter(asset, path, options).write();
}

}  // namespace duolod::io
