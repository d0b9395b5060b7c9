// The rules API (rules.hpp): parsing and emitting a two-stage program, and the dispatch from a
// RuleKind to its find/apply pair (rules_internal.hpp). The rules themselves live in rule_*.cpp,
// one file per rule family (Liang et al. §4.1).
#include "shader/rules.hpp"

#include <charconv>
#include <glslang/SPIRV/GLSL.std.450.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <system_error>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <unordered_map>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {
namespace {

using core::Error;

// The emitted words of one stage, validated. With `optimize`, SPIRV-Tools' performance recipe
// (optimizeForEvaluation: inlining, dead code, folding) runs on the copy that is compiled and timed:
// a rule leaves dead code and foldable constants behind, and the driver should not be credited or
// blamed for them (§5.2's cost is the cost of what really runs).
core::Result<std::vector<uint32_t>> emitStage(const ir::Module& module, bool optimize,
                                              const std::string& what) {
  std::vector<uint32_t> words = ir::emitModule(module);
  if (optimize) return optimizeForEvaluation(words, what);  // validates before and after
  if (auto valid = validateSpirv(words, what); !valid.ok()) return valid.error();
  return words;
}

// Module order of every result id and block label, for enumerateSites' ordering.
std::unordered_map<ir::Id, size_t> moduleOrder(const ir::Module& module) {
  std::unordered_map<ir::Id, size_t> order;
  size_t next = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks) {
      order.emplace(block.id(), next++);
      for (const ir::Instruction& instruction : block.instructions)
        if (instruction.hasResult()) order.emplace(instruction.result_id, next++);
    }
  return order;
}

}  // namespace

std::string_view ruleName(RuleKind kind) {
  switch (kind) {
    case RuleKind::kOperationRemoval: return "operation removal";
    case RuleKind::kMoveToParameter: return "moving to parameter";
    case RuleKind::kPerVertex: return "per-vertex";
    case RuleKind::kTextureAverage: return "texture average";
    case RuleKind::kTextureMip: return "texture mip";
    case RuleKind::kLoopTruncation: return "loop truncation";
  }
  return "unknown rule";
}

const ir::Module& stageModule(const ShaderProgram& program, Stage stage) {
  return stage == Stage::kVertex ? program.vertex : program.fragment;
}
ir::Module& stageModule(ShaderProgram& program, Stage stage) {
  return stage == Stage::kVertex ? program.vertex : program.fragment;
}

std::string stageName(Stage stage) {
  switch (stage) {
    case Stage::kVertex: return "vertex";
    case Stage::kTessControl: return "tessellation control";
    case Stage::kTessEvaluation: return "tessellation evaluation";
    case Stage::kGeometry: return "geometry";
    case Stage::kFragment: return "fragment";
  }
  return "unknown stage";
}

core::Error siteError(const RuleSite& site, const std::string& reason) {
  return Error{std::string(ruleName(site.kind)) + " at " + stageName(site.stage) + " %" +
               std::to_string(site.target) + ": " + reason};
}

std::string valueName(const ir::Module& module, ir::Id id) {
  std::string name = module.name(id);
  return name.empty() ? "%" + std::to_string(id) : name;
}

std::string operationName(const ir::Instruction& instruction) {
  // clang-format off
  static const std::map<uint32_t, const char*> kExtNames = {
      {GLSLstd450Round, "round"},   {GLSLstd450RoundEven, "roundEven"},
      {GLSLstd450Trunc, "trunc"},   {GLSLstd450FAbs, "abs"},      {GLSLstd450SAbs, "abs"},
      {GLSLstd450FSign, "sign"},    {GLSLstd450SSign, "sign"},    {GLSLstd450Floor, "floor"},
      {GLSLstd450Ceil, "ceil"},     {GLSLstd450Fract, "fract"},   {GLSLstd450Radians, "radians"},
      {GLSLstd450Degrees, "degrees"}, {GLSLstd450Sin, "sin"},     {GLSLstd450Cos, "cos"},
      {GLSLstd450Tan, "tan"},       {GLSLstd450Asin, "asin"},     {GLSLstd450Acos, "acos"},
      {GLSLstd450Atan, "atan"},     {GLSLstd450Exp, "exp"},       {GLSLstd450Log, "log"},
      {GLSLstd450Exp2, "exp2"},     {GLSLstd450Log2, "log2"},     {GLSLstd450Sqrt, "sqrt"},
      {GLSLstd450InverseSqrt, "inversesqrt"}, {GLSLstd450Determinant, "determinant"},
      {GLSLstd450MatrixInverse, "inverse"}, {GLSLstd450Length, "length"},
      {GLSLstd450Normalize, "normalize"},
      {GLSLstd450Pow, "pow"},       {GLSLstd450Atan2, "atan"},   {GLSLstd450FMin, "min"},
      {GLSLstd450FMax, "max"},      {GLSLstd450SMin, "min"},     {GLSLstd450SMax, "max"},
      {GLSLstd450UMin, "min"},      {GLSLstd450UMax, "max"},     {GLSLstd450FClamp, "clamp"},
      {GLSLstd450SClamp, "clamp"},  {GLSLstd450UClamp, "clamp"}, {GLSLstd450FMix, "mix"},
      {GLSLstd450Step, "step"},     {GLSLstd450SmoothStep, "smoothstep"},
      {GLSLstd450Fma, "fma"},       {GLSLstd450Cross, "cross"},  {GLSLstd450Reflect, "reflect"},
      {GLSLstd450Refract, "refract"}, {GLSLstd450Distance, "distance"},
      {GLSLstd450FaceForward, "faceforward"}, {GLSLstd450Ldexp, "ldexp"}};
  static const std::map<spv::Op, const char*> kOpNames = {
      {spv::OpFAdd, "add"}, {spv::OpIAdd, "add"}, {spv::OpFSub, "sub"}, {spv::OpISub, "sub"},
      {spv::OpFMul, "mul"}, {spv::OpIMul, "mul"}, {spv::OpVectorTimesScalar, "mul"},
      {spv::OpMatrixTimesScalar, "mul"}, {spv::OpVectorTimesMatrix, "mul"},
      {spv::OpMatrixTimesVector, "mul"}, {spv::OpMatrixTimesMatrix, "mul"},
      {spv::OpFDiv, "div"}, {spv::OpSDiv, "div"}, {spv::OpUDiv, "div"}, {spv::OpFMod, "mod"},
      {spv::OpSMod, "mod"}, {spv::OpUMod, "mod"}, {spv::OpFRem, "rem"}, {spv::OpSRem, "rem"},
      {spv::OpBitwiseAnd, "and"}, {spv::OpBitwiseOr, "or"}, {spv::OpBitwiseXor, "xor"},
      {spv::OpShiftLeftLogical, "shl"}, {spv::OpShiftRightLogical, "shr"},
      {spv::OpShiftRightArithmetic, "shr"}, {spv::OpSelect, "select"}, {spv::OpDot, "dot"},
      {spv::OpOuterProduct, "outerProduct"}, {spv::OpFNegate, "neg"}, {spv::OpSNegate, "neg"},
      {spv::OpTranspose, "transpose"}, {spv::OpConvertSToF, "float"},
      {spv::OpConvertUToF, "float"}, {spv::OpConvertFToS, "int"}, {spv::OpConvertFToU, "uint"},
      {spv::OpBitcast, "bitcast"}, {spv::OpFOrdLessThan, "lessThan"},
      {spv::OpFOrdGreaterThan, "greaterThan"}, {spv::OpFOrdLessThanEqual, "lessThanEqual"},
      {spv::OpFOrdGreaterThanEqual, "greaterThanEqual"}, {spv::OpFOrdEqual, "equal"},
      {spv::OpFOrdNotEqual, "notEqual"}, {spv::OpSLessThan, "lessThan"},
      {spv::OpSGreaterThan, "greaterThan"}, {spv::OpULessThan, "lessThan"},
      {spv::OpUGreaterThan, "greaterThan"}, {spv::OpIEqual, "equal"},
      {spv::OpINotEqual, "notEqual"}, {spv::OpLogicalAnd, "and"}, {spv::OpLogicalOr, "or"},
      {spv::OpLogicalNot, "not"}, {spv::OpAny, "any"}, {spv::OpAll, "all"},
      {spv::OpDPdx, "dFdx"}, {spv::OpDPdy, "dFdy"}, {spv::OpFwidth, "fwidth"},
      {spv::OpImageSampleImplicitLod, "texture"}, {spv::OpImageSampleExplicitLod, "textureLod"},
      {spv::OpImageSampleProjImplicitLod, "textureProj"},
      {spv::OpImageSampleDrefImplicitLod, "texture"}, {spv::OpImageFetch, "texelFetch"}};
  // clang-format on
  if (instruction.opcode == spv::OpExtInst) {
    auto found = kExtNames.find(instruction.operands[1]);
    return found != kExtNames.end() ? found->second
                                    : "GLSL.std.450 #" + std::to_string(instruction.operands[1]);
  }
  auto found = kOpNames.find(instruction.opcode);
  return found != kOpNames.end()
             ? found->second
             : "op " + std::to_string(static_cast<uint32_t>(instruction.opcode));
}

namespace {

// How deep describeOperand spells out unnamed operations: "mul(dot(N, L), max(…, 0.0))".
constexpr int kDescribedDepth = 2;

// The shortest text that reads back as the same float, spelled as a GLSL float literal ("2.0",
// "0.0625", "5.9604645e-08"): std::to_string's six decimals printed 1/16777216 as "0.0".
std::string constantText(float value) {
  char buffer[64];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, value);
  if (error != std::errc()) return std::to_string(value);
  std::string text(buffer, end);
  if (text.find_first_of(".einn") == std::string::npos) text += ".0";
  return text;
}

// GLSL's name for a vector of the scalar type `scalar_type`: vec, dvec, ivec, uvec or bvec.
std::string vectorPrefix(const ir::DefUse& uses, ir::Id scalar_type) {
  const ir::Instruction* scalar = uses.def(scalar_type);
  if (!scalar) return "vec";
  if (scalar->opcode == spv::OpTypeBool) return "bvec";
  if (scalar->opcode == spv::OpTypeInt)
    return scalar->operands.size() > 1 && scalar->operands[1] == 0 ? "uvec" : "ivec";
  if (scalar->opcode == spv::OpTypeFloat && !scalar->operands.empty() && scalar->operands[0] == 64)
    return "dvec";
  return "vec";
}

// ".x", ".xz": the components `indices` of a vector, or "[i]" for matrix columns and arrays.
std::string componentSuffix(const ir::DefUse& uses, ir::Id composite_type,
                            std::span<const uint32_t> indices) {
  const bool vector = ir::typeInfo(uses, composite_type).opcode == spv::OpTypeVector;
  std::string suffix = vector ? "." : "";
  for (uint32_t index : indices) {
    if (vector && index < 4)
      suffix += "xyzw"[index];
    else
      suffix += "[" + std::to_string(index) + "]";
  }
  return suffix;
}

std::string describeExpression(const ir::Module& module, const ir::DefUse& uses, ir::Id id,
                               int depth);

// What a pointer points at, as source code would name it: a variable or parameter ("vUV"), a
// member of a uniform block, named or not ("uMaterial.roughness", "roughness"), a component
// ("color.y") or an element ("uLights[2]", "weights[i]"); "" when it has no name to start from.
std::string describePlace(const ir::Module& module, const ir::DefUse& uses, ir::Id pointer_id) {
  const ir::Instruction* pointer = uses.def(pointer_id);
  if (!pointer) return "";
  if (pointer->opcode == spv::OpVariable || pointer->opcode == spv::OpFunctionParameter)
    return module.name(pointer->result_id);
  if (pointer->opcode != spv::OpAccessChain && pointer->opcode != spv::OpInBoundsAccessChain)
    return "";
  const ir::Instruction* base = uses.def(pointer->operands[0]);
  if (!base) return "";
  std::string text = describePlace(module, uses, base->result_id);
  ir::Id type = ir::pointeeType(uses, base->type_id);
  for (size_t i = 1; i < pointer->operands.size(); ++i) {
    const ir::Instruction* type_definition = uses.def(type);
    if (!type_definition) return "";
    const std::optional<int64_t> constant = ir::constantIntValue(uses, pointer->operands[i]);
    if (type_definition->opcode == spv::OpTypeStruct) {
      if (!constant || *constant < 0 || size_t(*constant) >= type_definition->operands.size())
        return "";
      std::string member = module.memberName(type, static_cast<uint32_t>(*constant));
      if (member.empty()) return "";
      text = text.empty() ? member : text + "." + member;  // an anonymous block's members
      type = type_definition->operands[size_t(*constant)];
      continue;
    }
    if (text.empty() || type_definition->operands.empty()) return "";
    if (type_definition->opcode == spv::OpTypeVector && constant && *constant >= 0 && *constant < 4)
      text += std::string(".") + "xyzw"[*constant];
    else
      text += "[" + describeExpression(module, uses, pointer->operands[i], 0) + "]";
    type = type_definition->operands[0];  // the component, column or element type
  }
  return text;
}

std::string describeExpression(const ir::Module& module, const ir::DefUse& uses, ir::Id id,
                               int depth) {
  if (std::string name = module.name(id); !name.empty()) return name;
  const ir::Instruction* definition = uses.def(id);
  if (!definition) return valueName(module, id);
  if (definition->opcode == spv::OpConstant) {
    if (ir::isFloatType(uses, definition->type_id))
      if (std::optional<float> value = ir::constantFloatValue(uses, id))
        return constantText(*value);
    if (std::optional<int64_t> value = ir::constantIntValue(uses, id)) {
      const ir::Instruction* type = uses.def(definition->type_id);
      const bool is_unsigned = type && type->opcode == spv::OpTypeInt &&
                               type->operands.size() > 1 && type->operands[1] == 0;
      return std::to_string(*value) + (is_unsigned ? "u" : "");
    }
  }
  auto call = [&](const std::string& function, std::span<const ir::Id> arguments) {
    if (depth <= 0) return function + "(…)";
    std::string text = function + "(";
    for (size_t i = 0; i < arguments.size(); ++i)
      text += (i ? ", " : "") + describeExpression(module, uses, arguments[i], depth - 1);
    return text + ")";
  };
  const std::vector<ir::Id> ids = definition->idOperands();
  switch (definition->opcode) {
    case spv::OpLoad:
      if (std::string place = describePlace(module, uses, definition->operands[0]); !place.empty())
        return place;
      break;
    case spv::OpCompositeExtract: {
      const ir::Instruction* composite = uses.def(definition->operands[0]);
      if (!composite) break;
      // Each index by the type it selects from: a struct's member by name, a vector's component
      // by letter, a column or element by number ("light.color.x", "m[2].y").
      std::string text = describeExpression(module, uses, definition->operands[0], depth);
      ir::Id type = composite->type_id;
      for (size_t i = 1; i < definition->operands.size(); ++i) {
        const uint32_t index = definition->operands[i];
        const ir::Instruction* type_definition = uses.def(type);
        const std::string member = type_definition && type_definition->opcode == spv::OpTypeStruct
                                       ? module.memberName(type, index)
                                       : std::string();
        if (!member.empty())
          text += "." + member;
        else
          text += componentSuffix(uses, type, std::span<const uint32_t>(&index, 1));
        if (!type_definition || type_definition->operands.empty()) break;
        type = type_definition->opcode == spv::OpTypeStruct
                   ? (index < type_definition->operands.size() ? type_definition->operands[index]
                                                               : ir::kNoId)
                   : type_definition->operands[0];
      }
      return text;
    }
    case spv::OpVectorShuffle: {
      const ir::Instruction* first = uses.def(definition->operands[0]);
      if (!first) break;
      const uint32_t first_size = ir::componentCount(uses, first->type_id);
      std::vector<uint32_t> indices(definition->operands.begin() + 2, definition->operands.end());
      const bool from_first =
          definition->operands[0] == definition->operands[1] ||
          std::all_of(indices.begin(), indices.end(), [&](uint32_t i) { return i < first_size; });
      if (!from_first) break;
      return describeExpression(module, uses, definition->operands[0], depth) +
             componentSuffix(uses, first->type_id, indices);
    }
    case spv::OpCompositeConstruct:
    case spv::OpConstantComposite: {
      const ir::TypeInfo type = ir::typeInfo(uses, definition->type_id);
      std::string constructor =
          type.opcode == spv::OpTypeVector
              ? vectorPrefix(uses, type.scalar_type) + std::to_string(type.components)
          : type.opcode == spv::OpTypeMatrix ? "mat" + std::to_string(ids.size())
                                             : "struct";
      // A splat as GLSL writes it: vec3(0.5).
      const bool splat = type.opcode == spv::OpTypeVector && !ids.empty() &&
                         std::all_of(ids.begin(), ids.end(), [&](ir::Id c) { return c == ids[0]; });
      return call(constructor, splat ? std::span<const ir::Id>(ids).first(1) : ids);
    }
    case spv::OpCopyObject:
      return describeExpression(module, uses, ids.front(), depth);
    case spv::OpFunctionCall: {
      std::string callee = module.name(ids.front());
      if (callee.empty()) break;
      return call(callee.substr(0, callee.find('(')), std::span<const ir::Id>(ids).subspan(1));
    }
    case spv::OpExtInst:
      return call(operationName(*definition), std::span<const ir::Id>(ids).subspan(1));
    case spv::OpImageSampleImplicitLod:
    case spv::OpImageSampleExplicitLod:
    case spv::OpImageSampleProjImplicitLod:
    case spv::OpImageSampleDrefImplicitLod:
    case spv::OpImageFetch:
      // The sampler and the coordinate (image operands such as a bias or lod follow them).
      return call(operationName(*definition), std::span<const ir::Id>(ids).first(2));
    default: {
      std::string function = operationName(*definition);
      if (function.rfind("op ", 0) != 0) return call(function, ids);
      break;
    }
  }
  return valueName(module, id);
}

}  // namespace

std::string describeOperand(const ir::Module& module, const ir::DefUse& uses, ir::Id id) {
  return describeExpression(module, uses, id, kDescribedDepth);
}

std::string functionName(const ir::Module& module, size_t function_index) {
  std::string name = module.name(module.functions[function_index].id());
  return name.substr(0, name.find('('));
}

std::string identifierFrom(const std::string& text) {
  constexpr size_t kIdentifierLength = 32;
  std::string result;
  for (char c : text) {
    const bool letter_or_digit = std::isalnum(static_cast<unsigned char>(c)) != 0;
    if (letter_or_digit)
      result += c;
    else if (!result.empty() && result.back() != '_')
      result += '_';
    if (result.size() >= kIdentifierLength) break;  // a whole expression would make a long name
  }
  while (!result.empty() && result.back() == '_') result.pop_back();
  return result.empty() ? "value" : result;
}

namespace {

// Every result of function `function_id` and of the functions it calls.
void addFunctionResults(const ir::Module& module, ir::Id function_id,
                        std::unordered_set<ir::Id>& ids, std::set<ir::Id>& done) {
  if (!done.insert(function_id).second) return;
  const ir::Function* function = module.findFunction(function_id);
  if (!function) return;
  for (const ir::Block& block : function->blocks)
    for (const ir::Instruction& instruction : block.instructions) {
      if (instruction.hasResult()) ids.insert(instruction.result_id);
      if (instruction.opcode == spv::OpFunctionCall)
        addFunctionResults(module, instruction.operands[0], ids, done);
    }
}

}  // namespace

std::unordered_set<ir::Id> vertexPositionSources(const ir::Module& module, const ir::DefUse& uses) {
  std::unordered_set<ir::Id> sources;
  std::set<ir::Id> position_variables, whole_functions;
  for (const ir::InterfaceVariable& variable : ir::interfaceVariables(module, uses))
    if (variable.storage == spv::StorageClassOutput && variable.builtin)
      position_variables.insert(variable.variable);
  auto basePointer = [&](ir::Id pointer) {
    const ir::Instruction* definition = uses.def(pointer);
    while (definition && (definition->opcode == spv::OpAccessChain ||
                          definition->opcode == spv::OpInBoundsAccessChain))
      definition = uses.def(definition->operands[0]);
    return definition ? definition->result_id : ir::kNoId;
  };
  std::vector<ir::Id> stored;  // values stored into the position, sliced together
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks)
      for (const ir::Instruction& instruction : block.instructions)
        if (instruction.opcode == spv::OpStore &&
            position_variables.count(basePointer(instruction.operands[0])))
          stored.push_back(instruction.operands[1]);
  if (stored.empty()) return sources;
  ir::ValueSources slice = ir::backwardSlice(module, uses, stored);
  sources.insert(slice.instructions.begin(), slice.instructions.end());
  // The slice stops at calls (it summarises callees): a position computed in a function (HLSL's
  // entry point returns it in a struct that main copies out) keeps that whole function, and what
  // it calls, as it is.
  for (ir::Id id : slice.instructions)
    if (const ir::Instruction* call = uses.def(id); call && call->opcode == spv::OpFunctionCall)
      addFunctionResults(module, call->operands[0], sources, whole_functions);
  return sources;
}

std::string valueTargetUnsuitability(const ir::Module& fragment, const ir::DefUse& uses,
                                     ir::Id value) {
  const ir::InstructionRef* ref = uses.defRef(value);
  int entry = entryFunctionIndex(fragment, spv::ExecutionModelFragment);
  if (!ref || ref->function != entry || ref->block < 0)
    return "not a value of the fragment entry point";
  const ir::Instruction& definition = *ref->instruction;
  if (!definition.type_id || !ir::isFloatScalarOrVector(uses, definition.type_id) ||
      ir::typeInfo(uses, definition.type_id).width != 32)
    return "not a 32-bit float scalar or vector";
  if (definition.opcode == spv::OpLoad || definition.opcode == spv::OpPhi)
    return "a plain load or a phi";
  return "";
}

core::Result<ShaderProgram> parseProgram(std::span<const uint32_t> vertex_words,
                                         std::span<const uint32_t> fragment_words) {
  ShaderProgram program;
  auto vertex = ir::parseModule(vertex_words);
  if (!vertex.ok()) return Error{"vertex stage: " + vertex.error().message};
  auto fragment = ir::parseModule(fragment_words);
  if (!fragment.ok()) return Error{"fragment stage: " + fragment.error().message};
  if (!vertex->entryFunction(spv::ExecutionModelVertex))
    return Error{"vertex stage: the module has no vertex entry point"};
  if (!fragment->entryFunction(spv::ExecutionModelFragment))
    return Error{"fragment stage: the module has no fragment entry point"};
  program.vertex = std::move(*vertex);
  program.fragment = std::move(*fragment);
  return program;
}

core::Result<ProgramWords> emitProgram(const ShaderProgram& program, bool optimize) {
  ProgramWords words;
  auto vertex = emitStage(program.vertex, optimize, "vertex stage");
  if (!vertex.ok()) return vertex.error();
  auto fragment = emitStage(program.fragment, optimize, "fragment stage");
  if (!fragment.ok()) return fragment.error();
  words.vertex = std::move(*vertex);
  words.fragment = std::move(*fragment);
  return words;
}

std::vector<RuleSite> enumerateSites(const ShaderProgram& program, const RuleContext& context) {
  using Finder = std::vector<RuleSite> (*)(const ShaderProgram&, const RuleContext&);
  // Indexed by RuleKind; nullptr: not implemented in this build.
  const std::array<Finder, kRuleKindCount> finders = {
      &findOperationRemovalSites, &findMoveToParameterSites, &findPerVertexSites,
      &findTextureAverageSites,   &findTextureMipSites,      &findLoopTruncationSites};
  // The program is read-only here, and the sites' descriptions name ids by the hundred.
  const ir::NameIndexScope vertex_names(program.vertex), fragment_names(program.fragment);
  std::vector<RuleSite> sites;
  for (int kind = 0; kind < kRuleKindCount; ++kind) {
    if (!context.enabled[static_cast<size_t>(kind)] || !finders[static_cast<size_t>(kind)])
      continue;
    std::vector<RuleSite> found = finders[static_cast<size_t>(kind)](program, context);
    sites.insert(sites.end(), found.begin(), found.end());
  }
  // Stage, then module order of the target, then rule and choice: independent of the order the
  // finders walk in.
  const std::unordered_map<ir::Id, size_t> vertex_order = moduleOrder(program.vertex);
  const std::unordered_map<ir::Id, size_t> fragment_order = moduleOrder(program.fragment);
  auto position = [&](const RuleSite& site) {
    const auto& order = site.stage == Stage::kVertex ? vertex_order : fragment_order;
    auto found = order.find(site.target);
    return found == order.end() ? static_cast<size_t>(-1) : found->second;
  };
  std::stable_sort(sites.begin(), sites.end(), [&](const RuleSite& a, const RuleSite& b) {
    auto key = [&](const RuleSite& site) {
      return std::make_tuple(static_cast<int>(site.stage), position(site),
                             static_cast<int>(site.kind), site.choice);
    };
    return key(a) < key(b);
  });
  return sites;
}

core::Result<ShaderProgram> applyRule(const ShaderProgram& program, const RuleSite& site,
                                      const RuleContext& context) {
  if (site.stage != Stage::kVertex && site.stage != Stage::kFragment)
    return siteError(site, "only the vertex and fragment stages are simplified");
  core::Result<ShaderProgram> result = siteError(site, "this rule is not implemented yet");
  switch (site.kind) {
    case RuleKind::kOperationRemoval: result = applyOperationRemoval(program, site, context); break;
    case RuleKind::kMoveToParameter: result = applyMoveToParameter(program, site, context); break;
    case RuleKind::kPerVertex: result = applyPerVertex(program, site, context); break;
    case RuleKind::kTextureAverage: result = applyTextureAverage(program, site, context); break;
    case RuleKind::kTextureMip: result = applyTextureMip(program, site, context); break;
    case RuleKind::kLoopTruncation: result = applyLoopTruncation(program, site, context); break;
  }
  if (!result.ok()) return result;
  result->history.push_back(site.description.empty() ? std::string(ruleName(site.kind))
                                                     : site.description);
  return result;
}

}  // namespace duolod::shader
