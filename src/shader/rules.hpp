// Shader simplification rules (Liang et al. §4.1) on duolod's SPIR-V IR, private to src/shader.
// A search (GP or greedy, §5.2) works on ShaderPrograms: it asks where rules apply
// (enumerateSites), applies one (applyRule) to get a new variant, and composes them; a genome is
// the ordered list of RuleSites applied to the original. Ids stay stable across applications (rules
// only add fresh ids and remove dead ones), so a site found on a program still names the same
// instruction in the programs derived from it, unless a previous rule removed it (then applyRule
// fails cleanly and the search drops the genome).
//
// The rules, with the papers they come from:
//   kOperationRemoval  op(a, b) → a | b, type-compatible (Sitthi-Amorn et al. 2011; §4.1)
//   kMoveToParameter   n → average(n) over the training domain, a uniform set by the CPU
//                      (He et al. 2015 "moving to parameter"; Pellacini 2005 average substitution)
//   kPerVertex         a fragment value depending only on interpolated inputs, uniforms and
//                      constants is computed in the vertex stage behind a new varying (Wang et al.
//                      2014 code transformation)
//   kTextureAverage    a texture sample → the texture's average colour (Olano et al. 2003)
//   kTextureMip        a texture sample → the same sample `choice` mip levels coarser (Olano's
//                      texture collapse, in its cheap form: a LOD bias)
//   kLoopTruncation    a loop with a constant trip count runs `choice` iterations instead
//                      (Pellacini 2005 loop removal)
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/shader.hpp"
#include "shader/ir.hpp"

namespace duolod::shader {

// A value the CPU sets for a simplified program: a loose uniform at an explicit location (SPIR-V
// programs have no uniform names to look up). Mirrors render::UniformValue; shader does not
// depend on render.
struct ParameterValue {
  std::string name;
  uint32_t location = 0;
  int components = 1;  // float, vec2, vec3 or vec4
  std::array<float, 4> value{};
  bool operator==(const ParameterValue& other) const = default;
};

// The program being simplified: both stages, plus what the CPU must set for it.
struct ShaderProgram {
  ir::Module vertex;
  ir::Module fragment;
  std::vector<ParameterValue> parameters;
  // Descriptions of the rules applied to the original, in order (the summary of a level says
  // them in words).
  std::vector<std::string> history;
};

enum class RuleKind {
  kOperationRemoval,
  kMoveToParameter,
  kPerVertex,
  kTextureAverage,
  kTextureMip,
  kLoopTruncation,
};
inline constexpr int kRuleKindCount = 6;
std::string_view ruleName(RuleKind kind);  // "operation removal", ...

// One place where one rule applies in a given program.
struct RuleSite {
  RuleKind kind = RuleKind::kOperationRemoval;
  Stage stage = Stage::kFragment;  // the module rewritten (kPerVertex: the fragment value moved)
  ir::Id target = ir::kNoId;       // the instruction's result id (the sample, the operation, the
                                   // value moved; for loops the header block's label id)
  uint32_t choice = 0;  // kOperationRemoval: index of the kept operand among the id operands
                        // (for OpExtInst: after the instruction-set id);
                        // kLoopTruncation: iterations kept; kTextureMip: levels coarser; else 0
  std::string description;  // in words, with source names: "fbm loop: 4 → 2 iterations"
  bool operator==(const RuleSite& other) const {
    return kind == other.kind && stage == other.stage && target == other.target &&
           choice == other.choice;
  }
};

// What rules need from outside the program.
struct RuleContext {
  // Average linear RGBA of the texture at each sampler binding (from the asset's images; Olano).
  std::map<uint32_t, std::array<float, 4>> texture_averages;
  // The average of value `value` of `program`'s stage over the training domain's covered pixels,
  // by an instrumented render (supplied by the evaluator; components as the value's type). Unset:
  // kMoveToParameter is not offered.
  std::function<core::Result<std::vector<float>>(const ShaderProgram& program, Stage stage,
                                                 ir::Id value)>
      average_value;
  // Where new loose uniforms go (clear of the interface in shaders/INTERFACE.md), and the lowest location a new varying may take: the first
  // one neither stage uses from there on. Low, as OpenGL 4.5 guarantees only 15 varying vectors
  // (locations 0-14; llvmpipe has 32, a minimal driver would not link locations above 14).
  uint32_t first_parameter_location = 40;
  uint32_t first_varying_location = 0;
  // Which rules enumerateSites offers (all by default).
  std::array<bool, kRuleKindCount> enabled{true, true, true, true, true, true};
};

// Parses both stages (already-compiled SPIR-V, e.g. from compileToSpirv).
core::Result<ShaderProgram> parseProgram(std::span<const uint32_t> vertex_words,
                                         std::span<const uint32_t> fragment_words);

struct ProgramWords {
  std::vector<uint32_t> vertex;
  std::vector<uint32_t> fragment;
};
// Emits both stages and validates them (SPV_ENV_OPENGL_4_5). With `optimize`, SPIRV-Tools'
// public clean-up passes run on the emitted copy (dead code, folding): the form that is compiled
// and timed; without, the readable form that is cross-compiled for export.
core::Result<ProgramWords> emitProgram(const ShaderProgram& program, bool optimize);

// Every site where an enabled rule applies, in a deterministic order (stage, then module order).
std::vector<RuleSite> enumerateSites(const ShaderProgram& program, const RuleContext& context);

// The program with the rule applied (its description appended to history). Fails, without
// touching `program`, when the site no longer applies.
core::Result<ShaderProgram> applyRule(const ShaderProgram& program, const RuleSite& site,
                                      const RuleContext& context);

}  // namespace duolod::shader
