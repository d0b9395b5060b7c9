// Private: Wavefront MTL material libraries for the OBJ reader — parsing, and turning a parsed
// material into a glTF-style core::Material with its textures.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/io.hpp"

namespace duolod::io::mtl {

// A texture statement (map_Kd, norm, ...) as found in the file.
struct TextureRef {
  std::string written;      // file name as written (for messages)
  std::string resolved;     // path relative to the working folder (MTL folder + written name)
  int channel = 0;          // -imfchan for scalar maps (0 = r, 1 = g, 2 = b, 3 = alpha)
  float bump_scale = 1.0f;  // -bm for bump/normal maps
  size_t line = 0;
};

struct MtlMaterial {
  std::string name;
  std::string mtl_path;                // the library it came from, for messages
  size_t line = 0;                     // of its newmtl statement
  std::optional<core::Vec3> diffuse;   // Kd
  std::optional<core::Vec3> emissive;  // Ke
  std::optional<float> shininess;      // Ns (Phong exponent)
  std::optional<float> roughness;      // Pr, in [0, 1] (clamped when parsed)
  std::optional<float> metallic;       // Pm, in [0, 1] (clamped when parsed)
  std::optional<TextureRef> diffuse_map, emissive_map, normal_map, roughness_map, metallic_map;
};

// Parses MTL text read from mtl_path; appends materials in file order and non-fatal problems to
// warnings. Texture paths are resolved relative to the folder of mtl_path.
core::Status parseMtl(const std::string& mtl_path, std::string_view text,
                      std::vector<MtlMaterial>& materials, std::vector<std::string>& warnings);

// A material with OBJ's defaults (non-metallic, rough), since glTF's defaults (metallic = 1) would
// turn every plain OBJ material into metal.
core::Material defaultMaterial(std::string name);

// Converts a parsed material, adding its textures to asset.textures (shared between materials by
// path and colour space). Images are decoded only when options.load_textures (and, for PNG and
// JPEG files, options.decode_textures: otherwise their bytes alone, Texture::encoded); without
// load_textures the Texture entries carry the path in `name` and an empty image. A missing or
// undecodable texture file is an Error naming the MTL file and line.
core::Result<core::Material> buildMaterial(const MtlMaterial& source, const LoadOptions& options,
                                           core::Asset& asset,
                                           std::map<std::string, int>& texture_by_key);

}  // namespace duolod::io::mtl
