// Writing a program's shader files: per stage the SPIR-V module and its GLSL 450, GLSL ES 300 and
// HLSL 5.0 translations (SPIRV-Cross), each translation re-compiled by glslang before it is
// written. Used by `duolod shader` (shader/lod_search.hpp) and `duolod generate`
// (lod/export.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"

namespace duolod::shader {

// Writes NAME.{vert,frag}.spv, .glsl, .es.glsl and .hlsl into `directory` atomically. Returns the
// files written as (kind, file name): kinds spirv_vert, glsl450_vert, glsles300_vert,
// hlsl50_vert and likewise _frag. The SPIR-V and GLSL 450 files are the shader itself and must be
// written; a GLSL ES 300 or HLSL 5.0 translation that cannot express it (an SSBO or bitCount in
// ES 3.0) is left out, with a warning through core::log naming the file and the reason. The HLSL
// vertex stage's inputs carry the semantics of the streams `bindings` puts at their locations
// (POSITION0, NORMAL0, TANGENT0, TEXCOORD0, TEXCOORD1, COLOR0: render::hlslVertexInputLocations,
// what an HLSL input shader is read with).
core::Result<std::vector<std::pair<std::string, std::string>>> writeShaderFiles(
    const std::vector<uint32_t>& vertex, const std::vector<uint32_t>& fragment,
    const std::filesystem::path& directory, const std::string& name,
    const render::Bindings& bindings = {});

}  // namespace duolod::shader
