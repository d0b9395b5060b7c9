// Writing a program's shader files (shader/shader_files.hpp).
#include "shader/shader_files.hpp"

#include <map>
#include <span>

#include "duolod/io.hpp"
#include "duolod/shader.hpp"

namespace duolod::shader {
namespace {

// The first line of a translation's check failure without the names glslang puts before it:
// "NAME (GLSL ES 300): ERROR: NAME (GLSL ES 300):42: 'bitCount' : ..." -> "line 42: 'bitCount' :
// ...".
std::string firstReason(const std::string& message, const std::string& name) {
  std::string line = message.substr(0, message.find('\n'));
  while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.pop_back();
  for (const std::string& prefix : {name + ": ", std::string("ERROR: ")})
    if (line.starts_with(prefix)) line.erase(0, prefix.size());
  if (line.starts_with(name + ":")) line = "line " + line.substr(name.size() + 1);
  return line;
}

}  // namespace

core::Result<std::vector<std::pair<std::string, std::string>>> writeShaderFiles(
    const std::vector<uint32_t>& vertex, const std::vector<uint32_t>& fragment,
    const std::filesystem::path& directory, const std::string& name,
    const render::Bindings& bindings) {
  std::vector<std::pair<std::string, std::string>> files;
  std::map<uint32_t, std::string> vertex_semantics;
  for (const auto& [semantic, location] : render::hlslVertexInputLocations(bindings))
    vertex_semantics[location] = semantic;
  struct StageWords {
    const char* suffix;
    Stage stage;
    const std::vector<uint32_t>* words;
  };
  struct Output {
    Target target;
    const char* extension;
    const char* kind;
  };
  for (const StageWords& stage : {StageWords{"vert", Stage::kVertex, &vertex},
                                  StageWords{"frag", Stage::kFragment, &fragment}}) {
    const std::string base = name + "." + stage.suffix;
    const auto* bytes = reinterpret_cast<const uint8_t*>(stage.words->data());
    if (auto ok = io::writeFileAtomic((directory / (base + ".spv")).string(),
                                      std::span<const uint8_t>(bytes, stage.words->size() * 4));
        !ok)
      return ok.error();
    files.push_back({std::string("spirv_") + stage.suffix, base + ".spv"});
    for (const Output& output : {Output{Target::kGlsl450, ".glsl", "glsl450_"},
                                 Output{Target::kGlslEs300, ".es.glsl", "glsles300_"},
                                 Output{Target::kHlsl50, ".hlsl", "hlsl50_"}}) {
      const std::string file = base + output.extension;
      auto text = crossCompile(
          *stage.words, output.target, base,
          stage.stage == Stage::kVertex ? vertex_semantics : std::map<uint32_t, std::string>{});
      core::Status check = text ? checkCrossCompiled(*text, output.target, stage.stage, file)
                                : core::Status(text.error());
      if (!check) {
        if (output.target == Target::kGlsl450) return check.error();
        // A language short of the shader's features (GLSL 450 has them all): the other files
        // are still the shader.
        const std::string name = file + " (" + targetName(output.target) + ")";
        core::log(core::LogLevel::kWarning, file + " not written: " + targetName(output.target) +
                                                " cannot express this shader (" +
                                                firstReason(check.error().message, name) + ")");
        continue;
      }
      if (auto ok = io::writeFileAtomic((directory / file).string(), *text); !ok) return ok.error();
      files.push_back({output.kind + std::string(stage.suffix), file});
    }
  }
  return files;
}

}  // namespace duolod::shader
