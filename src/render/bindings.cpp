// Bindings files: where a user's shader expects each asset input (see shaders/INTERFACE.md).
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>

#include "duolod/render.hpp"

namespace duolod::render {
using core::Error;

core::Result<Bindings> parseBindings(const std::string& json_text, const std::string& file_name) {
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::parse_error& e) {
    return Error{file_name + ": not valid JSON (" + e.what() + ")"};
  }
  if (!document.is_object()) return Error{file_name + ": expected a JSON object"};
  Bindings bindings;
  struct Field {
    const char* section;
    const char* key;
    int* target;
  } fields[] = {
      {"attributes", "position", &bindings.position}, {"attributes", "normal", &bindings.normal},
      {"attributes", "tangent", &bindings.tangent},   {"attributes", "uv0", &bindings.uv0},
      {"attributes", "uv1", &bindings.uv1},           {"attributes", "color", &bindings.color},
      {"blocks", "frame", &bindings.frame_block},     {"blocks", "material", &bindings.material_block},
      {"textures", "baseColor", &bindings.base_color},
      {"textures", "metallicRoughness", &bindings.metallic_roughness},
      {"textures", "normal", &bindings.normal_map},   {"textures", "occlusion", &bindings.occlusion},
      {"textures", "emissive", &bindings.emissive},
  };
  for (auto& [section, value] : document.items()) {
    if (section != "attributes" && section != "blocks" && section != "textures")
      return Error{file_name + ": unknown section '" + section +
                   "' (expected attributes, blocks, textures)"};
    if (!value.is_object()) return Error{file_name + ": '" + section + "' must be an object"};
    for (auto& [key, entry] : value.items()) {
      Field* field = nullptr;
      for (Field& f : fields)
        if (section == f.section && key == f.key) field = &f;
      if (!field) return Error{file_name + ": unknown key '" + section + "." + key + "'"};
      if (!entry.is_number_integer() || entry.get<int>() < -1 || entry.get<int>() > 31)
        return Error{file_name + ": '" + section + "." + key +
                     "' must be an integer from -1 (unused) to 31"};
      *field->target = entry.get<int>();
    }
  }
  // Two inputs of one kind at one location or binding would read the same data (defaults
  // included: the interface's locations for what the file leaves out).
  for (const Field& a : fields)
    for (const Field& b : fields)
      if (&a < &b && std::string_view(a.section) == b.section && *a.target >= 0 &&
          *a.target == *b.target)
        return Error{file_name + ": '" + a.section + "." + a.key + "' and '" + b.section + "." +
                     b.key + "' are both " + std::to_string(*a.target) +
                     " (give one of them another, or -1 for unused)"};
  return bindings;
}

std::string shaderDirectory() {
  if (const char* overridden = std::getenv("DUOLOD_SHADER_DIR")) return overridden;
  return DUOLOD_SHADER_DIR;
}

core::Result<GlslSource> loadShaderPair(const std::string& name_or_prefix) {
  namespace fs = std::filesystem;
  fs::path prefix = name_or_prefix;
  if (!fs::exists(prefix.string() + ".vert")) prefix = fs::path(shaderDirectory()) / name_or_prefix;
  GlslSource source;
  for (auto [extension, text, name] :
       {std::tuple{".vert", &source.vertex, &source.vertex_name},
        std::tuple{".frag", &source.fragment, &source.fragment_name}}) {
    std::string path = prefix.string() + extension;
    std::ifstream in(path);
    if (!in) return Error{path + ": shader file not found"};
    std::stringstream buffer;
    buffer << in.rdbuf();
    *text = buffer.str();
    *name = path;
  }
  return source;
}

}  // namespace duolod::render
