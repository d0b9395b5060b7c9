// GLSL/HLSL → SPIR-V through glslang's public API (Debian glslang-dev 12), targeting OpenGL 4.5
// with ARB_gl_spirv; validation through SPIRV-Tools' public API.
// Debian's glslang is built with its HLSL front end (ENABLE_HLSL), but its header shows the
// HLSL-only setters (setEnvTargetHlslFunctionality1, an inline one) only to code that defines it
// too; nothing else in the header depends on it.
#ifndef ENABLE_HLSL
#define ENABLE_HLSL 1
#endif
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <glslang/SPIRV/spirv.hpp>
#include <spirv-tools/libspirv.hpp>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "duolod/shader.hpp"

namespace duolod::shader {
namespace {
using core::Error;

EShLanguage toGlslang(Stage stage) {
  switch (stage) {
    case Stage::kVertex: return EShLangVertex;
    case Stage::kTessControl: return EShLangTessControl;
    case Stage::kTessEvaluation: return EShLangTessEvaluation;
    case Stage::kGeometry: return EShLangGeometry;
    case Stage::kFragment: return EShLangFragment;
  }
  return EShLangVertex;
}

void ensureGlslangInitialized() {
  static std::once_flag once;
  std::call_once(once, [] { glslang::InitializeProcess(); });
}

// Resolves #include "file" relative to the including file's folder, then the include dirs.
class FileIncluder : public glslang::TShader::Includer {
 public:
  explicit FileIncluder(std::vector<std::string> dirs) : dirs_(std::move(dirs)) {}

  IncludeResult* includeLocal(const char* header, const char* includer, size_t depth) override {
    if (depth > kMaxIncludeDepth) return tooDeep(header);
    std::filesystem::path base = std::filesystem::path(includer ? includer : "").parent_path();
    if (auto* found = tryOpen(base / header)) return found;
    return includeSystem(header, includer, depth);
  }
  IncludeResult* includeSystem(const char* header, const char*, size_t depth) override {
    if (depth > kMaxIncludeDepth) return tooDeep(header);
    for (const std::string& dir : dirs_)
      if (auto* found = tryOpen(std::filesystem::path(dir) / header)) return found;
    return nullptr;
  }
  void releaseInclude(IncludeResult* result) override {
    if (!result) return;
    delete static_cast<std::string*>(result->userData);
    delete result;
  }

 private:
  // A file that includes itself, directly or around a cycle, would be expanded until memory ran
  // out (glslang does not stop it): nesting deeper than this is an error.
  static constexpr size_t kMaxIncludeDepth = 64;
  // glslang's convention: an empty header name, and the message as the contents.
  IncludeResult* tooDeep(const char* header) {
    auto* message =
        new std::string(std::string("#include \"") + header + "\" nested more than " +
                        std::to_string(kMaxIncludeDepth) + " deep: does it include itself?");
    return new IncludeResult("", message->data(), message->size(), message);
  }
  IncludeResult* tryOpen(const std::filesystem::path& path) {
    std::error_code ec;  // only a regular file: a device or pipe would be read for ever
    if (!std::filesystem::is_regular_file(path, ec)) return nullptr;
    std::ifstream in(path);
    if (!in) return nullptr;
    std::stringstream text;
    text << in.rdbuf();
    auto* contents = new std::string(core::withoutByteOrderMark(text.str()));
    return new IncludeResult(path.string(), contents->data(), contents->size(), contents);
  }
  std::vector<std::string> dirs_;
};

// glslang's log without its closing summary ("ERROR: 2 compilation errors.  No code generated.").
std::string trimLog(std::string log) {
  std::string kept;
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    if (line.find("compilation errors.") != std::string::npos) continue;
    if (line.find("compilation terminated") != std::string::npos) continue;
    while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.pop_back();
    if (line.empty()) continue;
    if (!kept.empty()) kept += "\n";
    kept += line;
  }
  return kept;
}

// glslang emits a module without OpEntryPoint when an HLSL entry point name matches nothing.
bool hasEntryPoint(const std::vector<uint32_t>& words) {
  for (size_t i = 5; i < words.size();) {
    uint32_t count = words[i] >> 16;
    if ((words[i] & 0xffffu) == static_cast<uint32_t>(spv::OpEntryPoint)) return true;
    if (count == 0) return false;
    i += count;
  }
  return false;
}

// Whether the module declares the Position built-in (gl_Position, HLSL's SV_Position output):
// glslang declares it only when the stage uses it, so a vertex stage without it draws nothing
// (a fragment or pixel shader given as the vertex stage compiles as one).
bool declaresPosition(const std::vector<uint32_t>& words) {
  constexpr uint32_t kBuiltIn = static_cast<uint32_t>(spv::DecorationBuiltIn);
  constexpr uint32_t kPosition = static_cast<uint32_t>(spv::BuiltInPosition);
  for (size_t i = 5; i < words.size();) {
    const uint32_t count = words[i] >> 16, opcode = words[i] & 0xffffu;
    if (count == 0 || i + count > words.size()) return false;
    if (opcode == static_cast<uint32_t>(spv::OpDecorate) && count >= 4 &&
        words[i + 2] == kBuiltIn && words[i + 3] == kPosition)
      return true;
    if (opcode == static_cast<uint32_t>(spv::OpMemberDecorate) && count >= 5 &&
        words[i + 3] == kBuiltIn && words[i + 4] == kPosition)
      return true;
    i += count;
  }
  return false;
}

}  // namespace

core::Result<std::vector<uint32_t>> compileToSpirv(const std::string& source, Stage stage,
                                                   const std::string& file_name,
                                                   const CompileOptions& options) {
  ensureGlslangInitialized();
  EShLanguage language = toGlslang(stage);
  glslang::TShader shader(language);
  const std::string_view body = core::withoutByteOrderMark(source);
  const char* text = body.data();
  const int length = static_cast<int>(body.size());
  const char* name = file_name.c_str();
  shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
  shader.setEntryPoint(options.entry_point.c_str());
  std::string preamble;
  // `#include` works as in C without the user naming the extension glslang requires for it.
  if (options.language == Language::kGlsl) preamble += "#extension GL_GOOGLE_include_directive : enable\n";
  for (const auto& [key, value] : options.defines) preamble += "#define " + key + " " + value + "\n";
  shader.setPreamble(preamble.c_str());
  bool hlsl = options.language == Language::kHlsl;
  shader.setEnvInput(hlsl ? glslang::EShSourceHlsl : glslang::EShSourceGlsl, language,
                     glslang::EShClientOpenGL, 450);
  shader.setEnvClient(glslang::EShClientOpenGL, glslang::EShTargetOpenGL_450);
  shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_0);
  // HLSL's semantics as decorations (SPV_GOOGLE_hlsl_functionality1), so that a pair's varyings
  // can be matched by semantic as Direct3D matches them (hlslPairToGlsl).
  if (hlsl) shader.setEnvTargetHlslFunctionality1();
  if (hlsl || options.auto_map_locations) {
    // HLSL (and WebGL-style GLSL) has no explicit locations; let glslang assign them.
    shader.setAutoMapLocations(true);
    shader.setAutoMapBindings(options.auto_map_locations);
  }
  FileIncluder includer(options.include_dirs);
  EShMessages messages = static_cast<EShMessages>(
      EShMsgSpvRules | (hlsl ? static_cast<int>(EShMsgReadHlsl) : 0));
  if (!shader.parse(GetDefaultResources(), 450, ENoProfile, false, false, messages, includer))
    return Error{file_name + ": " + trimLog(shader.getInfoLog())};
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(messages)) return Error{file_name + ": link: " + trimLog(program.getInfoLog())};
  // glslang only warns, and emits an empty function, when the entry point matches nothing.
  if (std::string(program.getInfoLog()).find("Entry point not found") != std::string::npos)
    return Error{file_name + ": entry point '" + options.entry_point +
                 "' not found (CompileOptions::entry_point)"};
  if (hlsl && !options.auto_map_locations) {
    // duolod's interface binds by number (INTERFACE.md): a resource without a register() would
    // get binding 0 (glslang's default) beside whatever else is there and draw with the wrong
    // data, so it is named instead. Globals outside a cbuffer form the block "$Global".
    program.buildReflection();
    for (int i = 0; i < program.getNumLiveUniformBlocks(); ++i) {
      const glslang::TObjectReflection& block = program.getUniformBlock(i);
      if (block.name == "$Global")
        return Error{file_name +
                     ": global variables outside a cbuffer are not supported (the "
                     "interface binds blocks by number): put them in a cbuffer with "
                     "a register(bN)"};
      if (block.getBinding() < 0)
        return Error{file_name + ": cbuffer '" + block.name +
                     "' has no register(); duolod's interface binds resources by number "
                     "(shaders/INTERFACE.md), so give it one"};
    }
    for (int i = 0; i < program.getNumLiveUniformVariables(); ++i) {
      const glslang::TObjectReflection& uniform = program.getUniform(i);
      if (uniform.index < 0 && uniform.getBinding() < 0)  // not a block member: a texture, sampler
        return Error{file_name + ": '" + uniform.name +
                     "' has no register(); duolod's interface binds resources by number "
                     "(shaders/INTERFACE.md), so give it one"};
    }
  }
  std::vector<uint32_t> words;
  glslang::SpvOptions spv_options;
  spv_options.generateDebugInfo = false;
  spv_options.disableOptimizer = true;
  spv_options.optimizeSize = false;
  spv::SpvBuildLogger logger;
  glslang::GlslangToSpv(*program.getIntermediate(language), words, &logger, &spv_options);
  std::string log = logger.getAllMessages();
  if (words.empty()) return Error{file_name + ": SPIR-V generation failed: " + log};
  if (!hasEntryPoint(words)) return Error{file_name + ": the module has no entry point"};
  if (stage == Stage::kVertex && !declaresPosition(words))
    return Error{
        file_name + ": the vertex stage never writes " + (hlsl ? "SV_Position" : "gl_Position") +
        ", so nothing would be drawn (is it the " + (hlsl ? "pixel" : "fragment") + " stage?)"};
  return words;
}

core::Status validateSpirv(const std::vector<uint32_t>& words, const std::string& what) {
  spvtools::SpirvTools tools(SPV_ENV_OPENGL_4_5);
  std::string messages;
  tools.SetMessageConsumer([&](spv_message_level_t, const char*, const spv_position_t& position,
                               const char* message) {
    messages += "word " + std::to_string(position.index) + ": " + message + "\n";
  });
  if (!tools.Validate(words)) return Error{what + ": invalid SPIR-V: " + trimLog(messages)};
  return core::okStatus();
}

}  // namespace duolod::shader
