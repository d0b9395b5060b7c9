// duolod shader: the GLSL/HLSL front end (glslang → SPIR-V for OpenGL). The SPIR-V IR, rules,
// cost model and searches build on this.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::shader {

enum class Stage { kVertex, kTessControl, kTessEvaluation, kGeometry, kFragment };
enum class Language { kGlsl, kHlsl };

struct CompileOptions {
  Language language = Language::kGlsl;
  std::string entry_point = "main";
  std::vector<std::string> include_dirs;  // for #include "..."
  std::vector<std::pair<std::string, std::string>> defines;
};

// Compiles one stage to SPIR-V for OpenGL 4.5 (ARB_gl_spirv), with debug names kept and no
// optimisation, so later passes and emitters see the program as written. Errors carry the file
// name and line from glslang's log.
core::Result<std::vector<uint32_t>> compileToSpirv(const std::string& source, Stage stage,
                                                   const std::string& file_name,
                                                   const CompileOptions& options = {});

// Validates a module with SPIRV-Tools for SPV_ENV_OPENGL_4_5; the error names what is wrong.
core::Status validateSpirv(const std::vector<uint32_t>& words, const std::string& what);

}  // namespace duolod::shader
