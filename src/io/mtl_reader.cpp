// Private: Wavefront MTL reader, after "MTL Material Format" (Wavefront Advanced Visualizer manual,
// Appendix B1) plus the PBR extension (Pr, Pm, Ke, map_Pr, map_Pm, norm) proposed by Exocortex for
// Clara.io (2015) and written by Blender and 3ds Max. Shininess is mapped to roughness after
// Walter, Marschner, Li, Torrance, "Microfacet Models for Refraction through Rough Surfaces"
// (2007).
#include "io/mtl_reader.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "io/text_parse.hpp"

namespace duolod::io::mtl {
namespace {

namespace fs = std::filesystem;
using core::Error;
using text::errorAt;
using text::quote;

// MTL files written on Windows use backslashes ("map_Kd .\textures\wood.jpg").
std::string portablePath(std::string_view written) {
  std::string path(written);
  std::replace(path.begin(), path.end(), '\\', '/');
  return path;
}

std::string resolvePath(const std::string& mtl_path, std::string_view written) {
  fs::path file(portablePath(written));
  if (file.is_absolute()) return file.lexically_normal().string();
  return (fs::path(mtl_path).parent_path() / file).lexically_normal().string();
}

class MtlParser {
 public:
  MtlParser(const std::string& path, std::vector<MtlMaterial>& materials,
            std::vector<std::string>& warnings)
      : path_(path), materials_(materials), warnings_(warnings) {}

  core::Status parse(std::string_view content) {
    if (content.find('\0') != std::string_view::npos) {
      return text::errorIn(path_, "not a text file (contains NUL bytes)");
    }
    text::LineReader lines(content);
    std::string_view line;
    while (lines.next(line)) {
      line_ = lines.lineNumber();
      text::Tokens tokens(line);
      std::string_view keyword;
      if (!tokens.next(keyword) || keyword[0] == '#') continue;
      if (auto status = parseStatement(keyword, tokens); !status) return status;
    }
    if (ignored_outside_material_ > 0) {
      warnings_.push_back(path_ + ": " + std::to_string(ignored_outside_material_) +
                          " statement(s) before the first newmtl were ignored");
    }
    if (transparency_ignored_) {
      warnings_.push_back(path_ + ": transparency (d / Tr) is not supported and was ignored");
    }
    return core::okStatus();
  }

 private:
  core::Status parseStatement(std::string_view keyword, text::Tokens& tokens) {
    using text::equalsIgnoreCase;
    if (equalsIgnoreCase(keyword, "newmtl")) {
      MtlMaterial material;
      material.name = std::string(tokens.rest());
      for (const MtlMaterial& earlier : materials_)
        if (earlier.name == material.name) {
          warnings_.push_back(errorAt(path_, line_,
                                      "material '" + material.name + "' is defined again (first " +
                                          "at line " + std::to_string(earlier.line) +
                                          "); the last definition is used")
                                  .message);
          break;
        }
      material.mtl_path = path_;
      material.line = line_;
      materials_.push_back(std::move(material));
      current_ = materials_.size() - 1;
      return core::okStatus();
    }
    if (current_ == kNone) {
      ++ignored_outside_material_;
      return core::okStatus();
    }
    MtlMaterial& m = materials_[current_];
    // Colours and factors within glTF's ranges (a base colour in [0, 1], emission not negative,
    // roughness and metallic in [0, 1]): clamped with a warning, so that what is written is
    // valid glTF and renders as the glTF reader would render it.
    if (equalsIgnoreCase(keyword, "Kd"))
      return clamped(keyword, parseColor(keyword, tokens, m.diffuse), m.diffuse, 1.0f);
    if (equalsIgnoreCase(keyword, "Ke"))
      return clamped(keyword, parseColor(keyword, tokens, m.emissive), m.emissive,
                     std::numeric_limits<float>::max());
    if (equalsIgnoreCase(keyword, "Ns")) return parseScalar(keyword, tokens, m.shininess);
    if (equalsIgnoreCase(keyword, "Pr"))
      return clamped(keyword, parseScalar(keyword, tokens, m.roughness), m.roughness, 1.0f);
    if (equalsIgnoreCase(keyword, "Pm"))
      return clamped(keyword, parseScalar(keyword, tokens, m.metallic), m.metallic, 1.0f);
    if (equalsIgnoreCase(keyword, "d") || equalsIgnoreCase(keyword, "Tr")) {
      std::optional<float> value;
      if (auto status = parseScalar(keyword, tokens, value); !status) return status;
      // d is opacity, Tr transparency; "d 1" / "Tr 0" (opaque) are what most exporters write.
      bool opaque = equalsIgnoreCase(keyword, "d") ? *value >= 1.0f : *value <= 0.0f;
      if (!opaque) transparency_ignored_ = true;
      return core::okStatus();
    }
    if (equalsIgnoreCase(keyword, "map_Kd")) return parseMap(keyword, tokens, m.diffuse_map);
    if (equalsIgnoreCase(keyword, "map_Ke")) return parseMap(keyword, tokens, m.emissive_map);
    if (equalsIgnoreCase(keyword, "map_Pr")) return parseMap(keyword, tokens, m.roughness_map);
    if (equalsIgnoreCase(keyword, "map_Pm")) return parseMap(keyword, tokens, m.metallic_map);
    if (equalsIgnoreCase(keyword, "map_Bump") || equalsIgnoreCase(keyword, "bump") ||
        equalsIgnoreCase(keyword, "norm")) {
      return parseMap(keyword, tokens, m.normal_map);
    }
    // Ka, Ks, Ni, illum, Tf, map_Ka, map_d, ... have no place in metallic-roughness.
    return core::okStatus();
  }

  // `value` (when parsed) clamped to [0, high] in each component, with a warning when it was not.
  template <class T>
  core::Status clamped(std::string_view keyword, core::Status parsed, std::optional<T>& value,
                       float high) {
    if (!parsed || !value) return parsed;
    float* components = reinterpret_cast<float*>(&*value);
    bool changed = false;
    for (size_t i = 0; i < sizeof(T) / sizeof(float); ++i) {
      const float kept = std::clamp(components[i], 0.0f, high);
      changed |= kept != components[i];
      components[i] = kept;
    }
    if (changed)
      warnings_.push_back(errorAt(path_, line_,
                                  "'" + std::string(keyword) + "' outside [0, " +
                                      (high == 1.0f ? "1" : "inf") + "]; clamped")
                              .message);
    return parsed;
  }

  Error numberError(std::string_view keyword, std::string_view token) const {
    return errorAt(path_, line_,
                   "expected a number after '" + std::string(keyword) + "', got " + quote(token));
  }

  core::Status parseScalar(std::string_view keyword, text::Tokens& tokens,
                           std::optional<float>& out) {
    std::string_view token;
    float value = 0;
    if (!tokens.next(token) || !text::parseFloat(token, value)) return numberError(keyword, token);
    if (!std::isfinite(value)) {
      return errorAt(path_, line_,
                     "non-finite value " + quote(token) + " for '" + std::string(keyword) + "'");
    }
    out = value;
    return core::okStatus();
  }

  // "Kd r [g b]"; the spectral/xyz forms are rare and are ignored with a warning.
  core::Status parseColor(std::string_view keyword, text::Tokens& tokens,
                          std::optional<core::Vec3>& out) {
    std::string_view token;
    if (!tokens.next(token)) return numberError(keyword, token);
    if (token == "spectral" || token == "xyz") {
      warnings_.push_back(text::errorAt(path_, line_,
                                        "'" + std::string(keyword) + " " + std::string(token) +
                                            "' is not supported; ignored")
                              .message);
      return core::okStatus();
    }
    core::Vec3 color;
    int count = 0;
    do {
      if (token[0] == '#') break;
      float value = 0;
      if (!text::parseFloat(token, value)) return numberError(keyword, token);
      if (!std::isfinite(value)) {
        return errorAt(path_, line_,
                       "non-finite value " + quote(token) + " for '" + std::string(keyword) + "'");
      }
      if (count < 3) color[count] = value;
      ++count;
    } while (tokens.next(token));
    if (count == 0) return numberError(keyword, "");
    if (count < 3) color.y = color.z = color.x;  // "Kd 0.5" means grey, as the spec allows
    out = color;
    return core::okStatus();
  }

  // "map_Kd [-option args...] file name"; the file name is the rest of the line, spaces included.
  core::Status parseMap(std::string_view keyword, text::Tokens& tokens,
                        std::optional<TextureRef>& out) {
    TextureRef ref;
    ref.line = line_;
    text::Tokens lookahead = tokens;
    std::string_view token;
    while (true) {
      text::Tokens before = lookahead;
      if (!lookahead.next(token) || token.size() < 2 || token[0] != '-') {
        lookahead = before;
        break;
      }
      std::string_view option = token.substr(1);
      int arguments = 0;    // fixed argument count
      int max_numbers = 0;  // for -o -s -t: 1 to 3 numbers
      if (option == "o" || option == "s" || option == "t") {
        max_numbers = 3;
      } else if (option == "mm") {
        arguments = 2;
      } else if (option == "blendu" || option == "blendv" || option == "boost" ||
                 option == "texres" || option == "clamp" || option == "bm" || option == "imfchan" ||
                 option == "type" || option == "cc") {
        arguments = 1;
      } else {
        warnings_.push_back(
            errorAt(path_, line_, "unknown texture option " + quote(token) + " ignored").message);
        continue;
      }
      for (int i = 0; i < arguments; ++i) {
        std::string_view argument;
        if (!lookahead.next(argument)) {
          return errorAt(path_, line_, "texture option " + quote(token) + " needs an argument");
        }
        if (option == "bm") {
          float scale = 1;
          if (!text::parseFloat(argument, scale) || !std::isfinite(scale)) {
            return numberError(token, argument);
          }
          ref.bump_scale = scale;
        } else if (option == "imfchan") {
          if (argument == "g")
            ref.channel = 1;
          else if (argument == "b")
            ref.channel = 2;
          else if (argument == "m")
            ref.channel = 3;
          else
            ref.channel = 0;  // r, l (luminance) and z read the first channel
        }
      }
      for (int i = 0; i < max_numbers; ++i) {
        text::Tokens before_number = lookahead;
        std::string_view number;
        float value = 0;
        if (!lookahead.next(number) || !text::parseFloat(number, value)) {
          lookahead = before_number;
          break;
        }
      }
    }
    std::string_view file = lookahead.rest();
    if (file.empty()) {
      warnings_.push_back(
          errorAt(path_, line_, "'" + std::string(keyword) + "' without a file name ignored")
              .message);
      return core::okStatus();
    }
    ref.written = std::string(file);
    ref.resolved = resolvePath(path_, file);
    if (out) {
      warnings_.push_back(errorAt(path_, line_,
                                  "second '" + std::string(keyword) + "' for material '" +
                                      materials_[current_].name + "' replaces the first")
                              .message);
    }
    out = std::move(ref);
    return core::okStatus();
  }

  const std::string& path_;
  std::vector<MtlMaterial>& materials_;
  std::vector<std::string>& warnings_;
  static constexpr size_t kNone = SIZE_MAX;
  size_t current_ = kNone;  // index of the material being filled
  size_t line_ = 0;
  size_t ignored_outside_material_ = 0;
  bool transparency_ignored_ = false;
};

// §5.2 of Walter et al. 2007: a Phong exponent n matches a Beckmann width alpha = sqrt(2 / (n +
// 2)). glTF's roughness is the square root of alpha (alpha = roughness^2).
float roughnessFromShininess(float shininess) {
  float alpha = std::sqrt(2.0f / (std::max(shininess, 0.0f) + 2.0f));
  return std::clamp(std::sqrt(alpha), 0.0f, 1.0f);
}

class TextureLoader {
 public:
  TextureLoader(const MtlMaterial& source, const LoadOptions& options, core::Asset& asset,
                std::map<std::string, int>& texture_by_key)
      : source_(source), options_(options), asset_(asset), texture_by_key_(texture_by_key) {}

  // The file as a texture, its bytes kept for the writers (readTextureFile); not decoded when
  // `decode` is false and it is a PNG or JPEG.
  core::Result<core::Texture> loadTexture(const TextureRef& ref, bool srgb, bool decode) {
    if (auto found = checkExists(ref); !found) return found.error();
    auto texture = readTextureFile(ref.resolved, srgb, decode);
    if (!texture) return cannotLoad(ref, texture.error());
    return texture;
  }

  // The decoded image alone (for the metallic-roughness composition, which is a new image: no
  // file bytes to keep).
  core::Result<core::ImageRGBA8> loadImage(const TextureRef& ref) {
    if (auto found = checkExists(ref); !found) return found.error();
    auto image = readImage(ref.resolved);
    if (!image) return cannotLoad(ref, image.error());
    return image;
  }

  // A plain texture (base colour, normal, emissive), shared by path and colour space.
  core::Result<int> single(const TextureRef& ref, bool srgb) {
    asset_.source_files.push_back(ref.resolved);  // read or not: never to be replaced
    std::string key = ref.resolved + (srgb ? "|srgb" : "|linear");
    if (auto found = texture_by_key_.find(key); found != texture_by_key_.end()) {
      return found->second;
    }
    core::Texture texture{.name = ref.resolved, .image = {}, .srgb = srgb};
    if (options_.load_textures) {
      auto loaded = loadTexture(ref, srgb, options_.decode_textures);
      if (!loaded) return loaded.error();
      texture = std::move(loaded).value();
    }
    return add(key, std::move(texture));
  }

  // glTF packs roughness (G) and metallic (B) into one texture; OBJ has a map for each.
  core::Result<int> metallicRoughness(const TextureRef* roughness, const TextureRef* metallic) {
    auto describe = [](const TextureRef* ref) {
      return ref ? ref->resolved + "#" + std::to_string(ref->channel) : std::string("-");
    };
    std::string key = "mr|" + describe(roughness) + "|" + describe(metallic);
    if (auto found = texture_by_key_.find(key); found != texture_by_key_.end()) {
      return found->second;
    }
    for (const TextureRef* ref : {roughness, metallic})
      if (ref) asset_.source_files.push_back(ref->resolved);  // read or not: never to be replaced
    std::string name = roughness ? roughness->resolved : std::string();
    if (metallic && (!roughness || metallic->resolved != roughness->resolved)) {
      name += (name.empty() ? "" : "+") + metallic->resolved;
    }
    core::Texture texture{.name = name, .image = {}, .srgb = false};
    if (options_.load_textures) {
      core::ImageRGBA8 roughness_image, metallic_image;
      if (roughness) {
        auto image = loadImage(*roughness);
        if (!image) return image.error();
        roughness_image = std::move(image).value();
      }
      if (metallic) {
        if (roughness && metallic->resolved == roughness->resolved) {
          metallic_image = roughness_image;
        } else {
          auto image = loadImage(*metallic);
          if (!image) return image.error();
          metallic_image = std::move(image).value();
        }
      }
      if (roughness && metallic &&
          (roughness_image.width != metallic_image.width ||
           roughness_image.height != metallic_image.height)) {
        asset_.warnings.push_back(
            errorAt(source_.mtl_path, metallic->line,
                    "map_Pm size differs from map_Pr's; the metallic map is ignored")
                .message);
        metallic = nullptr;
      }
      // Start from one of the images so an R channel (often occlusion) survives; then G and B.
      texture.image = roughness ? roughness_image : metallic_image;
      size_t pixels = texture.image.pixels.size() / 4;
      for (size_t i = 0; i < pixels; ++i) {
        texture.image.pixels[4 * i + 1] =
            roughness ? roughness_image.pixels[4 * i + roughness->channel] : 255;
        texture.image.pixels[4 * i + 2] =
            metallic ? metallic_image.pixels[4 * i + metallic->channel] : 255;
      }
    }
    return add(key, std::move(texture));
  }

 private:
  int add(const std::string& key, core::Texture texture) {
    int index = static_cast<int>(asset_.textures.size());
    asset_.textures.push_back(std::move(texture));
    texture_by_key_[key] = index;
    return index;
  }

  core::Status checkExists(const TextureRef& ref) const {
    std::error_code ec;
    if (!fs::is_regular_file(ref.resolved, ec)) {
      return errorAt(
          source_.mtl_path, ref.line,
          "texture " + quote(ref.written) + " not found (looked for " + ref.resolved + ")");
    }
    return core::okStatus();
  }

  core::Error cannotLoad(const TextureRef& ref, const core::Error& error) const {
    return errorAt(source_.mtl_path, ref.line,
                   "cannot load texture " + quote(ref.written) + ": " + error.message);
  }

  const MtlMaterial& source_;
  const LoadOptions& options_;
  core::Asset& asset_;
  std::map<std::string, int>& texture_by_key_;
};

}  // namespace

core::Status parseMtl(const std::string& mtl_path, std::string_view text,
                      std::vector<MtlMaterial>& materials, std::vector<std::string>& warnings) {
  MtlParser parser(mtl_path, materials, warnings);
  return parser.parse(text);
}

core::Material defaultMaterial(std::string name) {
  core::Material material;
  material.name = std::move(name);
  material.metallic_factor = 0.0f;
  material.roughness_factor = 1.0f;
  return material;
}

core::Result<core::Material> buildMaterial(const MtlMaterial& source, const LoadOptions& options,
                                           core::Asset& asset,
                                           std::map<std::string, int>& texture_by_key) {
  core::Material material = defaultMaterial(source.name);
  if (source.diffuse) {
    material.base_color_factor = {source.diffuse->x, source.diffuse->y, source.diffuse->z, 1.0f};
  }
  if (source.emissive) {
    material.emissive_factor = *source.emissive;
  } else if (source.emissive_map) {
    material.emissive_factor = {1, 1, 1};  // the map alone should show
  }
  if (source.roughness) {
    material.roughness_factor = *source.roughness;  // in [0, 1] since parsing
  } else if (!source.roughness_map && source.shininess) {
    material.roughness_factor = roughnessFromShininess(*source.shininess);
  }
  if (source.metallic) {
    material.metallic_factor = *source.metallic;  // in [0, 1] since parsing
  } else if (source.metallic_map) {
    material.metallic_factor = 1.0f;  // the map alone should show
  }

  TextureLoader loader(source, options, asset, texture_by_key);
  if (source.diffuse_map) {
    auto index = loader.single(*source.diffuse_map, true);
    if (!index) return index.error();
    material.base_color_texture = *index;
  }
  if (source.emissive_map) {
    auto index = loader.single(*source.emissive_map, true);
    if (!index) return index.error();
    material.emissive_texture = *index;
  }
  if (source.normal_map) {
    auto index = loader.single(*source.normal_map, false);
    if (!index) return index.error();
    material.normal_texture = *index;
    material.normal_scale = source.normal_map->bump_scale;
  }
  if (source.roughness_map || source.metallic_map) {
    auto index = loader.metallicRoughness(source.roughness_map ? &*source.roughness_map : nullptr,
                                          source.metallic_map ? &*source.metallic_map : nullptr);
    if (!index) return index.error();
    material.metallic_roughness_texture = *index;
  }
  return material;
}

}  // namespace duolod::io::mtl
