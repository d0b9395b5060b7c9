// duolod's SPIR-V IR: parsing (through SPIRV-Tools' public spvBinaryParse, which knows the grammar),
// emission, mutation helpers and def-use. Analyses (types, interface, CFG, dependence) are in
// ir_analysis.cpp.
#include "shader/ir.hpp"

#include <spirv-tools/libspirv.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <unordered_map>

namespace duolod::shader::ir {
namespace {
using core::Error;

constexpr uint32_t kMagic = 0x07230203u;
constexpr size_t kHeaderWords = 5;

spv_const_context parserContext() {
  // The grammar is the same for every environment; 1.6 knows every opcode OpenGL modules use.
  static const spv_context context = spvContextCreate(SPV_ENV_UNIVERSAL_1_6);
  return context;
}

bool isIdOperandType(spv_operand_type_t type) {
  return type == SPV_OPERAND_TYPE_ID || type == SPV_OPERAND_TYPE_TYPE_ID ||
         type == SPV_OPERAND_TYPE_MEMORY_SEMANTICS_ID || type == SPV_OPERAND_TYPE_SCOPE_ID;
}

// Copies one parsed instruction into our form.
Instruction fromParsed(const spv_parsed_instruction_t& parsed) {
  Instruction instruction;
  instruction.opcode = static_cast<spv::Op>(parsed.opcode);
  instruction.type_id = parsed.type_id;
  instruction.result_id = parsed.result_id;
  size_t first = 1 + (parsed.type_id ? 1 : 0) + (parsed.result_id ? 1 : 0);
  instruction.operands.assign(parsed.words + first, parsed.words + parsed.num_words);
  instruction.is_id.assign(instruction.operands.size(), false);
  for (uint16_t i = 0; i < parsed.num_operands; ++i) {
    const spv_parsed_operand_t& operand = parsed.operands[i];
    if (operand.offset < first || !isIdOperandType(operand.type)) continue;
    for (uint16_t w = 0; w < operand.num_words; ++w) instruction.is_id[operand.offset - first + w] = true;
  }
  return instruction;
}

void appendWords(const Instruction& instruction, std::vector<uint32_t>& out) {
  uint32_t count = 1 + (instruction.type_id ? 1 : 0) + (instruction.result_id ? 1 : 0) +
                   static_cast<uint32_t>(instruction.operands.size());
  out.push_back((count << 16) | static_cast<uint32_t>(instruction.opcode));
  if (instruction.type_id) out.push_back(instruction.type_id);
  if (instruction.result_id) out.push_back(instruction.result_id);
  out.insert(out.end(), instruction.operands.begin(), instruction.operands.end());
}

bool isAnnotation(spv::Op op) {
  switch (op) {
    case spv::OpDecorate:
    case spv::OpMemberDecorate:
    case spv::OpDecorationGroup:
    case spv::OpGroupDecorate:
    case spv::OpGroupMemberDecorate:
    case spv::OpDecorateId:
    case spv::OpDecorateString:
    case spv::OpMemberDecorateString: return true;
    default: return false;
  }
}

// Places parsed instructions into the module's sections and functions.
struct ModuleBuilder {
  Module module;
  Function* function = nullptr;  // open function
  Block* block = nullptr;        // open block
  std::string error;
  size_t word_offset = kHeaderWords;

  void fail(const std::string& message) {
    if (error.empty()) error = "word " + std::to_string(word_offset) + ": " + message;
  }

  void add(Instruction instruction) {
    spv::Op op = instruction.opcode;
    if (function) {
      addToFunction(std::move(instruction));
      return;
    }
    switch (op) {
      case spv::OpCapability: module.capabilities.push_back(std::move(instruction)); return;
      case spv::OpExtension: module.extensions.push_back(std::move(instruction)); return;
      case spv::OpExtInstImport: module.ext_inst_imports.push_back(std::move(instruction)); return;
      case spv::OpMemoryModel: module.memory_model.push_back(std::move(instruction)); return;
      case spv::OpEntryPoint: module.entry_points.push_back(std::move(instruction)); return;
      case spv::OpExecutionMode:
      case spv::OpExecutionModeId: module.execution_modes.push_back(std::move(instruction)); return;
      case spv::OpString:
      case spv::OpSource:
      case spv::OpSourceExtension:
      case spv::OpSourceContinued: module.debug_sources.push_back(std::move(instruction)); return;
      case spv::OpName:
      case spv::OpMemberName: module.names.push_back(std::move(instruction)); return;
      case spv::OpModuleProcessed: module.module_processed.push_back(std::move(instruction)); return;
      case spv::OpFunction: {
        module.functions.emplace_back();
        function = &module.functions.back();
        function->definition = std::move(instruction);
        return;
      }
      case spv::OpFunctionParameter:
      case spv::OpLabel:
      case spv::OpFunctionEnd: fail("instruction outside a function"); return;
      default:
        if (isAnnotation(op)) {
          module.annotations.push_back(std::move(instruction));
        } else {
          module.types_values.push_back(std::move(instruction));
        }
    }
  }

  void addToFunction(Instruction instruction) {
    switch (instruction.opcode) {
      case spv::OpFunctionParameter:
        if (block) return fail("OpFunctionParameter after the first block");
        function->parameters.push_back(std::move(instruction));
        return;
      case spv::OpLabel:
        if (block && (block->instructions.empty() || !isTerminator(block->instructions.back().opcode)))
          return fail("block " + std::to_string(block->id()) + " has no terminator");
        function->blocks.emplace_back();
        block = &function->blocks.back();
        block->label = std::move(instruction);
        return;
      case spv::OpFunctionEnd:
        if (block && (block->instructions.empty() || !isTerminator(block->instructions.back().opcode)))
          return fail("last block of function " + std::to_string(function->id()) +
                      " has no terminator");
        function->end = std::move(instruction);
        function = nullptr;
        block = nullptr;
        return;
      case spv::OpFunction: return fail("nested OpFunction");
      default:
        if (!block) return fail("instruction before the first OpLabel of a function");
        if (!block->instructions.empty() && isTerminator(block->instructions.back().opcode))
          return fail("instruction after the terminator of block " + std::to_string(block->id()));
        block->instructions.push_back(std::move(instruction));
    }
  }

  static bool isTerminator(spv::Op op) {
    switch (op) {
      case spv::OpBranch:
      case spv::OpBranchConditional:
      case spv::OpSwitch:
      case spv::OpReturn:
      case spv::OpReturnValue:
      case spv::OpKill:
      case spv::OpUnreachable:
      case spv::OpTerminateInvocation: return true;
      default: return false;
    }
  }
};

spv_result_t onHeader(void* user, spv_endianness_t, uint32_t, uint32_t version, uint32_t generator,
                      uint32_t bound, uint32_t schema) {
  auto* builder = static_cast<ModuleBuilder*>(user);
  builder->module.version = version;
  builder->module.generator = generator;
  builder->module.bound = bound;
  builder->module.schema = schema;
  return SPV_SUCCESS;
}

spv_result_t onInstruction(void* user, const spv_parsed_instruction_t* parsed) {
  auto* builder = static_cast<ModuleBuilder*>(user);
  builder->add(fromParsed(*parsed));
  builder->word_offset += parsed->num_words;
  return builder->error.empty() ? SPV_SUCCESS : SPV_ERROR_INVALID_BINARY;
}

std::string takeDiagnostic(spv_diagnostic diagnostic) {
  if (!diagnostic) return "unknown error";
  std::string text = diagnostic->error ? diagnostic->error : "unknown error";
  if (!diagnostic->isTextSource) text = "word " + std::to_string(diagnostic->position.index) + ": " + text;
  spvDiagnosticDestroy(diagnostic);
  return text;
}

const Instruction* findInVector(const std::vector<Instruction>& list, Id id) {
  for (const Instruction& instruction : list)
    if (instruction.result_id == id) return &instruction;
  return nullptr;
}

void replaceIn(Instruction& instruction, Id from, Id to) {
  if (instruction.type_id == from) instruction.type_id = to;
  for (size_t i = 0; i < instruction.operands.size(); ++i)
    if (instruction.is_id[i] && instruction.operands[i] == from) instruction.operands[i] = to;
}

template <class Predicate>
void eraseIf(std::vector<Instruction>& list, Predicate predicate) {
  list.erase(std::remove_if(list.begin(), list.end(), predicate), list.end());
}

}  // namespace

// ---------------------------------------------------------------------------------------------

std::vector<Id> Instruction::idOperands() const {
  std::vector<Id> ids;
  for (size_t i = 0; i < operands.size(); ++i)
    if (is_id[i]) ids.push_back(operands[i]);
  return ids;
}

std::string Instruction::literalString(size_t first) const {
  std::string text;
  for (size_t i = first; i < operands.size(); ++i) {
    for (int byte = 0; byte < 4; ++byte) {
      char c = static_cast<char>((operands[i] >> (8 * byte)) & 0xffu);
      if (c == '\0') return text;
      text.push_back(c);
    }
  }
  return text;
}

std::vector<uint32_t> encodeString(const std::string& text) {
  std::vector<uint32_t> words(text.size() / 4 + 1, 0u);
  for (size_t i = 0; i < text.size(); ++i)
    words[i / 4] |= static_cast<uint32_t>(static_cast<unsigned char>(text[i])) << (8 * (i % 4));
  return words;
}

const Instruction* Block::mergeInstruction() const {
  if (instructions.size() < 2) return nullptr;
  const Instruction& candidate = instructions[instructions.size() - 2];
  if (candidate.opcode == spv::OpLoopMerge || candidate.opcode == spv::OpSelectionMerge)
    return &candidate;
  return nullptr;
}

core::Result<Module> parseModule(std::span<const uint32_t> words) {
  if (words.size() < kHeaderWords) return Error{"SPIR-V module: shorter than its 5-word header"};
  if (words[0] != kMagic) return Error{"SPIR-V module: bad magic number (not SPIR-V, or byte-swapped)"};
  ModuleBuilder builder;
  spv_diagnostic diagnostic = nullptr;
  spv_result_t result = spvBinaryParse(parserContext(), &builder, words.data(), words.size(), onHeader,
                                       onInstruction, &diagnostic);
  if (!builder.error.empty()) {
    if (diagnostic) spvDiagnosticDestroy(diagnostic);
    return Error{"SPIR-V module: " + builder.error};
  }
  if (result != SPV_SUCCESS) return Error{"SPIR-V module: " + takeDiagnostic(diagnostic)};
  if (builder.function) return Error{"SPIR-V module: function without OpFunctionEnd"};
  if (builder.module.memory_model.size() != 1)
    return Error{"SPIR-V module: expected one OpMemoryModel, found " +
                 std::to_string(builder.module.memory_model.size())};
  return std::move(builder.module);
}

std::vector<uint32_t> emitModule(const Module& module) {
  std::vector<uint32_t> out = {kMagic, module.version, module.generator, module.bound, module.schema};
  auto emitAll = [&](const std::vector<Instruction>& list) {
    for (const Instruction& instruction : list) appendWords(instruction, out);
  };
  emitAll(module.capabilities);
  emitAll(module.extensions);
  emitAll(module.ext_inst_imports);
  emitAll(module.memory_model);
  emitAll(module.entry_points);
  emitAll(module.execution_modes);
  emitAll(module.debug_sources);
  emitAll(module.names);
  emitAll(module.module_processed);
  emitAll(module.annotations);
  emitAll(module.types_values);
  for (const Function& function : module.functions) {
    appendWords(function.definition, out);
    emitAll(function.parameters);
    for (const Block& block : function.blocks) {
      appendWords(block.label, out);
      emitAll(block.instructions);
    }
    appendWords(function.end, out);
  }
  return out;
}

uint64_t wordsHash(std::span<const uint32_t> words) {
  return core::hashBytes(words.data(), words.size_bytes());
}

uint64_t moduleHash(const Module& module) { return wordsHash(emitModule(module)); }

Instruction makeInstruction(const Module& module, spv::Op opcode, Id type_id, Id result_id,
                            std::vector<uint32_t> operands) {
  // Parse a tiny module holding what the grammar needs and the instruction itself.
  std::vector<uint32_t> words = {kMagic, module.version, 0, std::max<uint32_t>(module.bound, result_id + 1) + 4, 0};
  auto typeOf = [&](Id id) -> Id {
    for (const Instruction& instruction : module.types_values)
      if (instruction.result_id == id) return instruction.type_id;
    for (const Function& function : module.functions) {
      for (const Instruction& parameter : function.parameters)
        if (parameter.result_id == id) return parameter.type_id;
      for (const Block& block : function.blocks)
        for (const Instruction& instruction : block.instructions)
          if (instruction.result_id == id) return instruction.type_id;
    }
    return kNoId;
  };
  auto addTypeDefinition = [&](Id type) {
    if (const Instruction* definition = findInVector(module.types_values, type))
      appendWords(*definition, words);
  };
  if (opcode == spv::OpExtInst)
    for (const Instruction& import : module.ext_inst_imports) appendWords(import, words);
  if (opcode == spv::OpConstant || opcode == spv::OpSpecConstant) addTypeDefinition(type_id);
  if (opcode == spv::OpSwitch && !operands.empty()) {
    Id selector_type = typeOf(operands[0]);
    addTypeDefinition(selector_type);
    Instruction undef{spv::OpUndef, selector_type, operands[0], {}, {}};
    appendWords(undef, words);
  }
  size_t instruction_start = words.size();
  Instruction instruction{opcode, type_id, result_id, std::move(operands), {}};
  appendWords(instruction, words);

  struct Capture {
    size_t start = 0, offset = kHeaderWords;
    Instruction parsed;
    bool found = false;
  } capture;
  capture.start = instruction_start;
  auto onParsed = [](void* user, const spv_parsed_instruction_t* parsed) -> spv_result_t {
    auto* state = static_cast<Capture*>(user);
    if (state->offset == state->start) {
      state->parsed = fromParsed(*parsed);
      state->found = true;
    }
    state->offset += parsed->num_words;
    return SPV_SUCCESS;
  };
  spv_diagnostic diagnostic = nullptr;
  spvBinaryParse(parserContext(), &capture, words.data(), words.size(), nullptr, onParsed, &diagnostic);
  if (diagnostic) spvDiagnosticDestroy(diagnostic);
  if (capture.found) return capture.parsed;
  // The grammar rejected it (a programmer error in a rule); keep the words, classify nothing,
  // and let the validator report the module.
  instruction.is_id.assign(instruction.operands.size(), false);
  return instruction;
}

// ---------------------------------------------------------------------------------------------
// Mutation helpers.

Id Module::addTypeOrConstant(spv::Op opcode, Id type_id, std::vector<uint32_t> operands) {
  for (const Instruction& existing : types_values)
    if (existing.opcode == opcode && existing.type_id == type_id && existing.operands == operands &&
        existing.result_id != kNoId)
      return existing.result_id;
  Id id = allocateId();
  types_values.push_back(makeInstruction(*this, opcode, type_id, id, std::move(operands)));
  return id;
}

Id Module::typeVoid() { return addTypeOrConstant(spv::OpTypeVoid, kNoId, {}); }
Id Module::typeBool() { return addTypeOrConstant(spv::OpTypeBool, kNoId, {}); }
Id Module::typeFloat(uint32_t width) { return addTypeOrConstant(spv::OpTypeFloat, kNoId, {width}); }
Id Module::typeInt(uint32_t width, bool is_signed) {
  return addTypeOrConstant(spv::OpTypeInt, kNoId, {width, is_signed ? 1u : 0u});
}
Id Module::typeVector(Id component_type, uint32_t count) {
  return addTypeOrConstant(spv::OpTypeVector, kNoId, {component_type, count});
}
Id Module::typePointer(spv::StorageClass storage, Id pointee_type) {
  return addTypeOrConstant(spv::OpTypePointer, kNoId, {static_cast<uint32_t>(storage), pointee_type});
}
Id Module::constantFloat(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  return addTypeOrConstant(spv::OpConstant, typeFloat(), {bits});
}
Id Module::constantInt(int32_t value) {
  return addTypeOrConstant(spv::OpConstant, typeInt(32, true), {static_cast<uint32_t>(value)});
}
Id Module::constantUint(uint32_t value) {
  return addTypeOrConstant(spv::OpConstant, typeInt(32, false), {value});
}
Id Module::constantBool(bool value) {
  return addTypeOrConstant(value ? spv::OpConstantTrue : spv::OpConstantFalse, typeBool(), {});
}
Id Module::constantComposite(Id type_id, const std::vector<Id>& constituents) {
  return addTypeOrConstant(spv::OpConstantComposite, type_id,
                           std::vector<uint32_t>(constituents.begin(), constituents.end()));
}
Id Module::constantFloatVector(std::span<const float> values) {
  if (values.size() == 1) return constantFloat(values[0]);
  std::vector<Id> components;
  for (float value : values) components.push_back(constantFloat(value));
  return constantComposite(typeVector(typeFloat(), static_cast<uint32_t>(values.size())), components);
}

Id Module::addLooseUniform(Id value_type, const std::string& uniform_name, uint32_t location) {
  for (const Instruction& instruction : names)
    if (instruction.opcode == spv::OpName && instruction.literalString(1) == uniform_name)
      if (const Instruction* variable = findInVector(types_values, instruction.operands[0]))
        if (variable->opcode == spv::OpVariable &&
            variable->operands[0] == spv::StorageClassUniformConstant)
          return variable->result_id;
  Id pointer = typePointer(spv::StorageClassUniformConstant, value_type);
  Id variable = allocateId();
  types_values.push_back(makeInstruction(*this, spv::OpVariable, pointer, variable,
                                         {static_cast<uint32_t>(spv::StorageClassUniformConstant)}));
  annotations.push_back(makeInstruction(*this, spv::OpDecorate, kNoId, kNoId,
                                        {variable, static_cast<uint32_t>(spv::DecorationLocation), location}));
  setName(variable, uniform_name);
  return variable;
}

void Module::setName(Id id, const std::string& text) {
  std::vector<uint32_t> operands = {id};
  std::vector<uint32_t> encoded = encodeString(text);
  operands.insert(operands.end(), encoded.begin(), encoded.end());
  Instruction instruction = makeInstruction(*this, spv::OpName, kNoId, kNoId, std::move(operands));
  for (Instruction& existing : names)
    if (existing.opcode == spv::OpName && existing.operands[0] == id) {
      existing = std::move(instruction);
      return;
    }
  names.push_back(std::move(instruction));
}

namespace {
// The scoped name indexes of NameIndexScope on this thread (nested scopes stack).
struct NameIndex {
  const Module* module;
  std::unordered_map<Id, size_t> first;  // OpName's target -> its first entry in names
  const NameIndex* outer;
};
thread_local const NameIndex* t_name_index = nullptr;
}  // namespace

NameIndexScope::NameIndexScope(const Module& module) {
  auto index = std::make_unique<NameIndex>(NameIndex{&module, {}, t_name_index});
  for (size_t i = 0; i < module.names.size(); ++i) {
    const Instruction& instruction = module.names[i];
    if (instruction.opcode == spv::OpName && !instruction.operands.empty())
      index->first.emplace(instruction.operands[0], i);
  }
  t_name_index = index.get();
  index_ = index.release();
}

NameIndexScope::~NameIndexScope() {
  auto* index = static_cast<const NameIndex*>(index_);
  t_name_index = index->outer;
  delete index;
}

std::string Module::name(Id id) const {
  for (const NameIndex* index = t_name_index; index; index = index->outer)
    if (index->module == this) {
      auto found = index->first.find(id);
      return found == index->first.end() ? std::string() : names[found->second].literalString(1);
    }
  for (const Instruction& instruction : names)
    if (instruction.opcode == spv::OpName && instruction.operands[0] == id)
      return instruction.literalString(1);
  return {};
}

std::string Module::memberName(Id struct_type, uint32_t member) const {
  for (const Instruction& instruction : names)
    if (instruction.opcode == spv::OpMemberName && instruction.operands[0] == struct_type &&
        instruction.operands[1] == member)
      return instruction.literalString(2);
  return {};
}

void Module::replaceAllUses(Id from, Id to) {
  for (Instruction& instruction : types_values) replaceIn(instruction, from, to);
  for (Function& function : functions) {
    replaceIn(function.definition, from, to);
    for (Instruction& parameter : function.parameters) replaceIn(parameter, from, to);
    for (Block& block : function.blocks)
      for (Instruction& instruction : block.instructions) replaceIn(instruction, from, to);
  }
}

void Module::removeInstructions(const std::set<Id>& ids) {
  if (ids.empty()) return;
  auto removed = [&](const Instruction& instruction) { return ids.count(instruction.result_id) > 0; };
  auto targetsRemoved = [&](const Instruction& instruction) {
    return !instruction.operands.empty() && ids.count(instruction.operands[0]) > 0;
  };
  eraseIf(types_values, removed);
  eraseIf(names, targetsRemoved);
  eraseIf(annotations, targetsRemoved);
  eraseIf(execution_modes, targetsRemoved);
  for (Instruction& entry : entry_points) {
    // Interface ids follow the name; drop removed variables from the list.
    for (size_t i = entry.operands.size(); i-- > 2;)
      if (entry.is_id[i] && ids.count(entry.operands[i])) {
        entry.operands.erase(entry.operands.begin() + static_cast<std::ptrdiff_t>(i));
        entry.is_id.erase(entry.is_id.begin() + static_cast<std::ptrdiff_t>(i));
      }
  }
  functions.erase(std::remove_if(functions.begin(), functions.end(),
                                 [&](const Function& function) { return ids.count(function.id()) > 0; }),
                  functions.end());
  for (Function& function : functions)
    for (Block& block : function.blocks) eraseIf(block.instructions, removed);
}

size_t Module::removeInstructionsIf(const std::function<bool(const Instruction&)>& predicate) {
  size_t count = 0;
  for (Function& function : functions)
    for (Block& block : function.blocks) {
      size_t before = block.instructions.size();
      eraseIf(block.instructions, predicate);
      count += before - block.instructions.size();
    }
  return count;
}

void Module::insertBefore(const InstructionPosition& position, std::vector<Instruction> instructions) {
  std::vector<Instruction>& list =
      functions.at(static_cast<size_t>(position.function)).blocks.at(static_cast<size_t>(position.block)).instructions;
  list.insert(list.begin() + position.index, std::make_move_iterator(instructions.begin()),
              std::make_move_iterator(instructions.end()));
}

std::optional<InstructionPosition> Module::findPosition(Id result_id) const {
  for (size_t f = 0; f < functions.size(); ++f)
    for (size_t b = 0; b < functions[f].blocks.size(); ++b) {
      const std::vector<Instruction>& list = functions[f].blocks[b].instructions;
      for (size_t i = 0; i < list.size(); ++i)
        if (list[i].result_id == result_id)
          return InstructionPosition{static_cast<int>(f), static_cast<int>(b), static_cast<int>(i)};
    }
  return std::nullopt;
}

Function* Module::findFunction(Id function_id) {
  for (Function& function : functions)
    if (function.id() == function_id) return &function;
  return nullptr;
}
const Function* Module::findFunction(Id function_id) const {
  return const_cast<Module*>(this)->findFunction(function_id);
}

Function* Module::entryFunction(spv::ExecutionModel model) {
  for (const Instruction& entry : entry_points)
    if (entry.operands[0] == static_cast<uint32_t>(model)) return findFunction(entry.operands[1]);
  return nullptr;
}
const Function* Module::entryFunction(spv::ExecutionModel model) const {
  return const_cast<Module*>(this)->entryFunction(model);
}

// ---------------------------------------------------------------------------------------------
// Def-use.

DefUse::DefUse(const Module& module) : module_(&module) {
  auto visit = [&](const Instruction& instruction, int function, int block, int index) {
    InstructionRef ref{&instruction, function, block, index};
    if (instruction.result_id) defs_[instruction.result_id] = ref;
    Id last = kNoId;
    auto addUser = [&](Id id) {
      if (id == last) return;  // one entry per instruction for `op %a %a`
      std::vector<InstructionRef>& list = users_[id];
      if (!list.empty() && list.back().instruction == &instruction) return;
      list.push_back(ref);
      last = id;
    };
    if (instruction.type_id) addUser(instruction.type_id);
    for (size_t i = 0; i < instruction.operands.size(); ++i)
      if (instruction.is_id[i]) addUser(instruction.operands[i]);
  };
  auto visitAll = [&](const std::vector<Instruction>& list) {
    for (size_t i = 0; i < list.size(); ++i) visit(list[i], -1, -1, static_cast<int>(i));
  };
  visitAll(module.ext_inst_imports);
  visitAll(module.entry_points);
  visitAll(module.execution_modes);
  visitAll(module.debug_sources);
  visitAll(module.names);
  visitAll(module.annotations);
  visitAll(module.types_values);
  for (size_t f = 0; f < module.functions.size(); ++f) {
    const Function& function = module.functions[f];
    int fi = static_cast<int>(f);
    visit(function.definition, fi, -1, -1);
    for (size_t p = 0; p < function.parameters.size(); ++p)
      visit(function.parameters[p], fi, -1, static_cast<int>(p));
    for (size_t b = 0; b < function.blocks.size(); ++b) {
      const Block& block = function.blocks[b];
      visit(block.label, fi, static_cast<int>(b), -1);
      for (size_t i = 0; i < block.instructions.size(); ++i)
        visit(block.instructions[i], fi, static_cast<int>(b), static_cast<int>(i));
    }
  }
}

const Instruction* DefUse::def(Id id) const {
  auto found = defs_.find(id);
  return found == defs_.end() ? nullptr : found->second.instruction;
}

const InstructionRef* DefUse::defRef(Id id) const {
  auto found = defs_.find(id);
  return found == defs_.end() ? nullptr : &found->second;
}

const std::vector<InstructionRef>& DefUse::users(Id id) const {
  auto found = users_.find(id);
  return found == users_.end() ? no_users_ : found->second;
}

std::vector<const Instruction*> DefUse::decorations(Id id) const {
  std::vector<const Instruction*> result;
  for (const Instruction& instruction : module_->annotations)
    if ((instruction.opcode == spv::OpDecorate || instruction.opcode == spv::OpMemberDecorate ||
         instruction.opcode == spv::OpDecorateId || instruction.opcode == spv::OpDecorateString ||
         instruction.opcode == spv::OpMemberDecorateString) &&
        instruction.operands[0] == id)
      result.push_back(&instruction);
  return result;
}

std::optional<uint32_t> DefUse::decoration(Id id, spv::Decoration decoration) const {
  for (const Instruction* instruction : decorations(id))
    if (instruction->opcode == spv::OpDecorate && instruction->operands.size() >= 2 &&
        instruction->operands[1] == static_cast<uint32_t>(decoration))
      return instruction->operands.size() >= 3 ? instruction->operands[2] : 0u;
  return std::nullopt;
}

std::optional<uint32_t> DefUse::memberDecoration(Id struct_type, uint32_t member,
                                                 spv::Decoration decoration) const {
  for (const Instruction* instruction : decorations(struct_type))
    if (instruction->opcode == spv::OpMemberDecorate && instruction->operands.size() >= 3 &&
        instruction->operands[1] == member &&
        instruction->operands[2] == static_cast<uint32_t>(decoration))
      return instruction->operands.size() >= 4 ? instruction->operands[3] : 0u;
  return std::nullopt;
}

bool DefUse::hasDecoration(Id id, spv::Decoration decoration) const {
  return this->decoration(id, decoration).has_value();
}

}  // namespace duolod::shader::ir
