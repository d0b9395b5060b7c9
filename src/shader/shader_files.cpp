// Writing a program's shader files (shader/shader_files.hpp).
#include "shader/shader_files.hpp"

#include <span>

#include "duolod/io.hpp"
#include "duolod/shader.hpp"

namespace duolod::shader {

core::Result<std::vector<std::pair<std::string, std::string>>> writeShaderFiles(
    const std::vector<uint32_t>& vertex, const std::vector<uint32_t>& fragment,
    const std::filesystem::path& directory, const std::string& name) {
  std::vector<std::pair<std::string, std::string>> files;
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
      auto text = crossCompile(*stage.words, output.target, base);
      if (!text) return text.error();
      if (auto check = checkCrossCompiled(*text, output.target, stage.stage, base + output.extension);
          !check)
        return check.error();
      if (auto ok = io::writeFileAtomic((directory / (base + output.extension)).string(), *text); !ok)
        return ok.error();
      files.push_back({output.kind + std::string(stage.suffix), base + output.extension});
    }
  }
  return files;
}

}  // namespace duolod::shader
