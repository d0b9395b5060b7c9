// Bindings files: where a user's shader expects each asset input (see shaders/INTERFACE.md).
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string_view>
#include <vector>

#include "duolod/render.hpp"

namespace duolod::render {
using core::Error;

std::map<std::string, uint32_t> hlslVertexInputLocations(const Bindings& bindings) {
  std::map<std::string, uint32_t> locations;
  for (auto [semantic, location] : {std::pair{"POSITION0", bindings.position},
                                    {"NORMAL0", bindings.normal},
                                    {"TANGENT0", bindings.tangent},
                                    {"TEXCOORD0", bindings.uv0},
                                    {"TEXCOORD1", bindings.uv1},
                                    {"COLOR0", bindings.color}})
    if (location >= 0) locations[semantic] = uint32_t(location);
  return locations;
}

core::Result<Bindings> parseBindings(const std::string& json_text, const std::string& file_name) {
  nlohmann::json document;
  // A key given twice in one object: the parser keeps the last silently, which hides a mistake
  // ({"normal": 2, "normal": 1}). The keys of each open object, to name it.
  std::vector<std::vector<std::string>> open_keys;
  std::string duplicate;
  auto track = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (event == Event::object_start) open_keys.emplace_back();
    if (event == Event::object_end && !open_keys.empty()) open_keys.pop_back();
    if (event == Event::key && !open_keys.empty() && parsed.is_string()) {
      const std::string key = parsed.get<std::string>();
      std::vector<std::string>& keys = open_keys.back();
      if (duplicate.empty() && std::find(keys.begin(), keys.end(), key) != keys.end())
        duplicate = key;
      keys.push_back(key);
    }
    return true;
  };
  try {
    document = nlohmann::json::parse(json_text, track);
  } catch (const nlohmann::json::parse_error& e) {
    return Error{file_name + ": not valid JSON (" + e.what() + ")"};
  }
  if (!duplicate.empty())
    return Error{file_name + ": key '" + duplicate + "' is given twice in one object"};
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
  std::vector<const Field*> explicit_fields;
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
      // OpenGL guarantees 16 vertex attributes (GL_MAX_VERTEX_ATTRIBS); a location past them was
      // an "OpenGL error 1281" at the first draw.
      const int highest = section == "attributes" ? 15 : 31;
      if (!entry.is_number_integer() || entry.get<int>() < -1 || entry.get<int>() > highest)
        return Error{file_name + ": '" + section + "." + key +
                     "' must be an integer from -1 (unused) to " + std::to_string(highest)};
      *field->target = entry.get<int>();
      explicit_fields.push_back(field);
    }
  }
  // One location or binding per input of a kind. Two given at one are an error; a given one
  // takes it from an input left at its default, which becomes unused (-1): {"position": 2}
  // moves the position onto tangent's default location, and the tangent would otherwise be bound
  // there after it and be what the shader reads.
  auto isExplicit = [&](const Field& f) {
    return std::find(explicit_fields.begin(), explicit_fields.end(), &f) != explicit_fields.end();
  };
  for (const Field* given : explicit_fields) {
    if (*given->target < 0) continue;
    for (Field& other : fields) {
      if (&other == given || std::string_view(other.section) != given->section ||
          *other.target != *given->target)
        continue;
      if (isExplicit(other))
        return Error{file_name + ": '" + given->section + "." + given->key + "' and '" +
                     other.section + "." + other.key + "' are both " +
                     std::to_string(*given->target) + " (give one of them another, or -1)"};
      *other.target = -1;
    }
  }
  return bindings;
}

std::string shaderDirectory() {
  if (const char* overridden = std::getenv("DUOLOD_SHADER_DIR")) return overridden;
  // The source tree the library was built from, while it exists; else where `cmake --install`
  // put the shaders.
  namespace fs = std::filesystem;
  std::error_code ec;
  // An installed program uses the shaders installed with it (`cmake --install` with any
  // --prefix, or the tree moved since): share/duolod/shaders beside its bin/ folder. Programs in
  // the build tree have none there.
  const fs::path program = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path beside = program.parent_path().parent_path() / "share" / "duolod" / "shaders";
    if (fs::is_directory(beside, ec)) return beside.string();
  }
  if (fs::is_directory(DUOLOD_SHADER_DIR, ec)) return DUOLOD_SHADER_DIR;
  return DUOLOD_INSTALLED_SHADER_DIR;
}

core::Result<GlslSource> loadShaderPair(const std::string& name_or_prefix) {
  namespace fs = std::filesystem;
  // A bare name is duolod's shader first ("pbr" must not become a ./pbr.vert that happens to be
  // in the working folder), then one in the working folder; a path is taken as it is.
  fs::path prefix = name_or_prefix;
  if (!prefix.has_parent_path()) {
    const fs::path installed = fs::path(shaderDirectory()) / name_or_prefix;
    std::error_code ec;
    if (fs::exists(installed.string() + ".vert", ec) || !fs::exists(prefix.string() + ".vert", ec))
      prefix = installed;
  }
  GlslSource source;
  for (auto [extension, text, name] :
       {std::tuple{".vert", &source.vertex, &source.vertex_name},
        std::tuple{".frag", &source.fragment, &source.fragment_name}}) {
    std::string path = prefix.string() + extension;
    // Only a regular file: a device or pipe named like a shader would be read for ever.
    std::ifstream in;
    std::error_code status_error;
    if (fs::is_regular_file(path, status_error)) in.open(path);
    if (!in.is_open() || !in) {
      if (prefix.parent_path() == fs::path(shaderDirectory()))
        return Error{path +
                     ": shader file not found (duolod's own shaders are looked for in "
                     "$DUOLOD_SHADER_DIR, then share/duolod/shaders beside the program's "
                     "bin/, then the source tree the library was built from, then the "
                     "install prefix; set DUOLOD_SHADER_DIR to the folder that holds " +
                     name_or_prefix + ".vert)"};
      return Error{path + ": shader file not found"};
    }
    std::stringstream buffer;
    buffer << in.rdbuf();
    *text = std::string(core::withoutByteOrderMark(buffer.str()));
    *name = path;
  }
  return source;
}

}  // namespace duolod::render
