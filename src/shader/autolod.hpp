// Olano's single LOD shader (Olano, Kuehne, Simmons 2003, "Automatic Shader Level of Detail",
// §2.2): a sequence of simplified variants of one program combined into ONE program that picks a
// level from `uniform float autoLOD`, with monotonically increasing thresholds. The application
// sets autoLOD (here: at an explicit location, as ARB_gl_spirv programs have no names); left unset
// it is 0 and the original runs, so the LOD shader drops in for the original.
//
// Built on duolod's SPIR-V IR, per stage: each variant's entry function (and every function it
// calls) is imported into one module with its ids remapped; types and constants are shared when
// they are structurally equal (decorations included); interface variables are shared by BuiltIn or
// Location, uniform blocks and samplers by Binding. A new `main` computes the level
//   level = #{k ≥ 1 : thresholds[k] ≤ autoLOD}
// and switches to the level's entry function, so variant k runs when
// thresholds[k] ≤ autoLOD < thresholds[k+1] (level 0 also below thresholds[1], NaN included).
//
// Varyings and parameters: the variants were simplified independently, so two of them may put
// different varyings (Wang et al.'s per-vertex moves) or different parameter values (He et al.'s
// moving to parameter) at the same location. A varying is shared when its type and interpolation
// match (only one level runs in a draw, and both stages switch on the same autoLOD); otherwise it
// is moved to a free location in both stages of its variant. A parameter is shared when its value
// matches, otherwise moved the same way. Vertex stages: variants whose vertex stages are
// word-identical (after the moves) share one; when all do, the vertex stage is that one module,
// otherwise it switches on autoLOD like the fragment stage.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "duolod/core.hpp"
#include "shader/rules.hpp"

namespace duolod::shader {

struct AutoLodOptions {
  uint32_t autolod_location = 39;  // INTERFACE.md reserves it; rules' parameters start at 40
  std::string uniform_name = "autoLOD";
};

struct AutoLodShader {
  // Both stages; `parameters` holds every level's parameters at their final locations (autoLOD is
  // not among them: the caller sets it per draw).
  ShaderProgram program;
  std::vector<float> thresholds;  // as given: thresholds[k] starts level k
  uint32_t autolod_location = 39;
  // Per level: the distinct vertex stage it runs (0 when all levels share one).
  std::vector<int> vertex_stage_of_level;
  int distinct_vertex_stages = 1;
  int moved_varyings = 0;    // varyings given a new location to avoid a clash
  int moved_parameters = 0;  // parameters given a new location to avoid a clash
};

// Checked before a search, whose levels end in an autoLOD shader: the original may not have a
// loose uniform at the switch's location or with its name (buildAutoLodShader would refuse every
// level then, after the whole search). The error names the stage's file and the uniform.
core::Status checkRoomForAutoLod(const ShaderProgram& original, const std::string& vertex_name,
                                 const std::string& fragment_name,
                                 const AutoLodOptions& options = {});

// Combines `levels` (the original first, the cheapest last) with `thresholds` (one per level,
// finite, strictly increasing; thresholds[0] is where level 0 nominally starts, usually 0).
// Errors: mismatched counts, thresholds not increasing, a level already using autoLOD's location
// or name, variants that disagree on a uniform block's or sampler's type at one binding, or a
// module that fails validation after merging.
core::Result<AutoLodShader> buildAutoLodShader(std::span<const ShaderProgram> levels,
                                               std::span<const float> thresholds,
                                               const AutoLodOptions& options = {});

// The level the LOD shader runs for `autolod` (the same rule as its switch).
int autoLodLevel(std::span<const float> thresholds, float autolod);

// Olano's frozen snapshot (§3.3): `program` with the loose uniforms named by `values` (autoLOD,
// parameters; by location) replaced by those constants, so it needs no CPU-set uniform. Frozen at
// an autoLOD value, an LOD shader runs that level unconditionally (SPIRV-Tools' folding can then
// drop the other levels). Values for locations the program does not have are ignored.
core::Result<ShaderProgram> freezeUniforms(const ShaderProgram& program,
                                           std::span<const ParameterValue> values);

}  // namespace duolod::shader
