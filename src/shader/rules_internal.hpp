// Private to the rule implementations (src/shader/rule_*.cpp): one find/apply pair per rule, which
// rules.cpp's enumerateSites / applyRule dispatch to, and the few helpers every rule shares.
//
// Contract of every pair:
//   find*  returns the sites of that rule in `program` (any order: enumerateSites sorts them), each
//          with kind, stage, target, choice and a description in words;
//   apply* returns the rewritten program, or an Error when the site no longer applies (its target
//          was removed by an earlier rule, or changed shape). It does not validate and does not
//          touch `history` (applyRule does both).
#pragma once

#include <set>
#include <string>
#include <unordered_set>
#include <vector>

#include "shader/ir.hpp"
#include "shader/rules.hpp"

namespace duolod::shader {

// ---- the rules (files: rule_operation_removal.cpp, rule_move_to_parameter.cpp,
// rule_per_vertex.cpp, rule_texture.cpp, rule_loop.cpp) ----
std::vector<RuleSite> findOperationRemovalSites(const ShaderProgram& program,
                                                const RuleContext& context);
core::Result<ShaderProgram> applyOperationRemoval(const ShaderProgram& program,
                                                  const RuleSite& site, const RuleContext& context);

std::vector<RuleSite> findMoveToParameterSites(const ShaderProgram& program,
                                               const RuleContext& context);
core::Result<ShaderProgram> applyMoveToParameter(const ShaderProgram& program,
                                                 const RuleSite& site, const RuleContext& context);

std::vector<RuleSite> findPerVertexSites(const ShaderProgram& program, const RuleContext& context);
core::Result<ShaderProgram> applyPerVertex(const ShaderProgram& program, const RuleSite& site,
                                           const RuleContext& context);

std::vector<RuleSite> findTextureAverageSites(const ShaderProgram& program,
                                              const RuleContext& context);
core::Result<ShaderProgram> applyTextureAverage(const ShaderProgram& program,
                                                const RuleSite& site, const RuleContext& context);

std::vector<RuleSite> findTextureMipSites(const ShaderProgram& program, const RuleContext& context);
core::Result<ShaderProgram> applyTextureMip(const ShaderProgram& program, const RuleSite& site,
                                            const RuleContext& context);

std::vector<RuleSite> findLoopTruncationSites(const ShaderProgram& program,
                                              const RuleContext& context);
core::Result<ShaderProgram> applyLoopTruncation(const ShaderProgram& program, const RuleSite& site,
                                                const RuleContext& context);

// ---- shared helpers (rules.cpp) ----

// The module a site rewrites: the vertex or the fragment stage (other stages are not simplified).
const ir::Module& stageModule(const ShaderProgram& program, Stage stage);
ir::Module& stageModule(ShaderProgram& program, Stage stage);
// "vertex" / "fragment".
std::string stageName(Stage stage);

// The error for a site that does not apply to `program` (any more): names the rule, stage,
// target id and the reason.
core::Error siteError(const RuleSite& site, const std::string& reason);

// A readable name for a value in descriptions: its OpName, else "%<id>".
std::string valueName(const ir::Module& module, ir::Id id);
// A readable name of an operation for descriptions, as its GLSL function ("mix", "normalize",
// "texture") or a word for an operator ("mul", "add", "lessThan"); "op <number>" when unnamed.
std::string operationName(const ir::Instruction& instruction);
// The same for an operand, in the shader's own words: looking through a load to the variable,
// uniform-block member or element it reads, scalar constants by value, swizzles as ".xy", and an
// unnamed result as the operation that computes it, two calls deep ("vUV", "uBaseColorFactor",
// "0.5", "mul(dot(N, L), max(…, 0.0))", "texture(uBaseColor, vUV).rgb"); "%<id>" only for what it
// cannot spell.
std::string describeOperand(const ir::Module& module, const ir::DefUse& uses, ir::Id id);
// The source-level name of function `function_index` ("fbm" for glslang's "fbm(vf3;").
std::string functionName(const ir::Module& module, size_t function_index);
// `text` with every run of characters that are not letters or digits replaced by one '_', none at
// either end ("value" if nothing is left): the middle of the names of the uniforms and varyings
// rules add ("uAverage_" + it + "_40"). GLSL reserves names with "__", which SPIRV-Cross
// therefore rewrites, so a name with one would not be the name in the cross-compiled source that
// the summary and lod.json list ("%316" gave "uAverage__316_40", declared as uAverage_316_40).
std::string identifierFrom(const std::string& text);

// What the vertex stage's position (gl_Position, a Position builtin) is computed from: the result
// ids of its backward slice, and every result of a function that slice calls and of what that
// calls. No rule changes them: moving the geometry is the mesh simplifier's business, not the
// shader's.
std::unordered_set<ir::Id> vertexPositionSources(const ir::Module& module, const ir::DefUse& uses);

// Why fragment `value` cannot be the target of a value rule (moving to parameter, per-vertex) by
// its definition alone: not a result of the fragment entry point, not a 32-bit float scalar or
// vector, or a plain load or phi. "" when it can; each rule then checks its own dependences.
std::string valueTargetUnsuitability(const ir::Module& fragment, const ir::DefUse& uses,
                                     ir::Id value);

}  // namespace duolod::shader
