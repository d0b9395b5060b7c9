// duolod's own SPIR-V IR (private to src/shader). SPIRV-Tools' internal IR headers are not
// installed on Debian, so the simplification rules (paper §4.1) run on this one; SPIRV-Tools' public
// passes and validator clean up and check what the rules emit.
//
// Shape (after SPIRV-Cross's parsed IR, STYLE.md §6): a Module is plain values in vectors, cheap to
// copy for the search. Every instruction keeps its opcode, result type id, result id and the
// remaining operand words, plus which of those words are ids (from SPIRV-Tools' grammar through
// spvBinaryParse), so def-use chains and id replacement need no per-opcode tables here.
//
// Usage for a rule:
//   auto module = ir::parseModule(words);                 // Result<Module>
//   ir::DefUse uses(*module);                             // index; rebuild after mutating
//   for (const ir::InstructionRef& ref : uses.users(id)) ...
//   module->replaceAllUses(old_id, new_id); module->removeInstructions({old_id});
//   std::vector<uint32_t> out = ir::emitModule(*module);  // then shader::validateSpirv(out, ...)
#pragma once

#include <cstdint>
#include <functional>
#include <glslang/SPIRV/spirv.hpp>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::shader::ir {

// A SPIR-V <id>. 0 is never a valid id (kNoId marks "none").
using Id = uint32_t;
inline constexpr Id kNoId = 0;

struct Instruction {
  spv::Op opcode = spv::OpNop;
  Id type_id = kNoId;    // the result type, kNoId when the opcode has none
  Id result_id = kNoId;  // kNoId when the opcode has none
  // The words after the opcode word, result type and result id (literals, ids, enums).
  std::vector<uint32_t> operands;
  // is_id[i]: operands[i] is an <id> (a reference to another instruction's result).
  std::vector<bool> is_id;

  bool hasResult() const { return result_id != kNoId; }
  // The id operands, in order.
  std::vector<Id> idOperands() const;
  // Operands [first, end) read as a nul-terminated UTF-8 literal string (OpName, OpEntryPoint...).
  std::string literalString(size_t first) const;
  bool operator==(const Instruction& other) const = default;
};

// A position inside a function body: functions[function].blocks[block].instructions[index].
struct InstructionPosition {
  int function = 0;
  int block = 0;
  int index = 0;
};

// A basic block: its OpLabel, then every instruction up to and including the terminator (OpPhi
// first, OpLoopMerge/OpSelectionMerge just before the terminator, as SPIR-V requires).
struct Block {
  Instruction label;
  std::vector<Instruction> instructions;

  Id id() const { return label.result_id; }
  const Instruction& terminator() const { return instructions.back(); }
  // The OpLoopMerge / OpSelectionMerge of a header block, or nullptr.
  const Instruction* mergeInstruction() const;
  bool operator==(const Block& other) const = default;
};

struct Function {
  Instruction definition;                // OpFunction
  std::vector<Instruction> parameters;   // OpFunctionParameter
  std::vector<Block> blocks;             // the first is the entry block
  Instruction end;                       // OpFunctionEnd

  Id id() const { return definition.result_id; }
  bool operator==(const Function& other) const = default;
};

// A whole module, in the logical layout of SPIR-V §2.4.
struct Module {
  uint32_t version = 0x00010000;
  uint32_t generator = 0;
  uint32_t bound = 1;  // every id is < bound
  uint32_t schema = 0;

  std::vector<Instruction> capabilities;      // OpCapability
  std::vector<Instruction> extensions;        // OpExtension
  std::vector<Instruction> ext_inst_imports;  // OpExtInstImport
  std::vector<Instruction> memory_model;      // OpMemoryModel (exactly one in a valid module)
  std::vector<Instruction> entry_points;      // OpEntryPoint
  std::vector<Instruction> execution_modes;   // OpExecutionMode(Id)
  std::vector<Instruction> debug_sources;     // OpString, OpSource*, OpSourceContinued
  std::vector<Instruction> names;             // OpName, OpMemberName
  std::vector<Instruction> module_processed;  // OpModuleProcessed
  std::vector<Instruction> annotations;       // OpDecorate, OpMemberDecorate, groups
  // Types, constants, global OpVariables, OpUndef and OpLine/OpNoLine between them, in order.
  std::vector<Instruction> types_values;
  std::vector<Function> functions;

  bool operator==(const Module& other) const = default;

  // ---- mutation helpers for rules (ids stay unique; names are kept for readable output) ----

  // A fresh id (raises the bound).
  Id allocateId() { return bound++; }

  // Appends `instruction` to types_values unless an instruction with the same opcode, result type
  // and operands already exists there (then returns that one's id). The result id of the argument
  // is ignored: a fresh one is allocated. Types, constants and non-variable values only.
  Id addTypeOrConstant(spv::Op opcode, Id type_id, std::vector<uint32_t> operands);
  Id typeVoid();
  Id typeBool();
  Id typeFloat(uint32_t width = 32);
  Id typeInt(uint32_t width, bool is_signed);
  Id typeVector(Id component_type, uint32_t count);
  Id typePointer(spv::StorageClass storage, Id pointee_type);
  Id constantFloat(float value);  // 32-bit float constant
  Id constantInt(int32_t value);
  Id constantUint(uint32_t value);
  Id constantBool(bool value);
  // A composite constant (vector/matrix/array/struct) of `type_id` from constant ids.
  Id constantComposite(Id type_id, const std::vector<Id>& constituents);
  // A float vector constant (count = values.size(), 1 gives a scalar).
  Id constantFloatVector(std::span<const float> values);

  // A new non-block uniform (UniformConstant storage, explicit Location, as OpenGL SPIR-V allows
  // for default-block uniforms) of `value_type`, named `name`; de-duplicated by name. The CPU sets
  // it with glUniform* at `location` (He et al.'s "moving to parameter").
  Id addLooseUniform(Id value_type, const std::string& name, uint32_t location);

  // OpName for `id` (replacing an existing one), and the name of `id` or "".
  void setName(Id id, const std::string& name);
  std::string name(Id id) const;
  std::string memberName(Id struct_type, uint32_t member) const;

  // Rewrites every id operand equal to `from` into `to`, in types/values and function bodies (not
  // in names, decorations or entry-point interfaces, which describe `from` itself).
  void replaceAllUses(Id from, Id to);
  // Removes the instructions whose result id is in `ids`, together with their names and
  // decorations. Removing a function id removes the whole function; removing a block label id is a
  // precondition violation (change the CFG explicitly instead).
  void removeInstructions(const std::set<Id>& ids);
  // Removes instructions matching `predicate` from function bodies (not labels or terminators'
  // blocks: a removed terminator is the caller's responsibility). Returns how many.
  size_t removeInstructionsIf(const std::function<bool(const Instruction&)>& predicate);

  // Inserts `instructions` before the one at `position` (index == size appends; keep the
  // terminator last and OpVariables at the start of the entry block yourself).
  void insertBefore(const InstructionPosition& position, std::vector<Instruction> instructions);
  // Where the instruction with `result_id` sits in a function body, or nothing.
  std::optional<InstructionPosition> findPosition(Id result_id) const;

  Function* findFunction(Id function_id);
  const Function* findFunction(Id function_id) const;
  // The entry point's function for `model` (e.g. spv::ExecutionModelFragment), or nullptr.
  const Function* entryFunction(spv::ExecutionModel model) const;
  Function* entryFunction(spv::ExecutionModel model);
};

// Builds an instruction and classifies its operand words as ids or literals with SPIRV-Tools'
// grammar, using `module` for what the grammar needs (OpExtInst's import, OpConstant's and
// OpSwitch's literal widths). Use this for every instruction a rule creates.
Instruction makeInstruction(const Module& module, spv::Op opcode, Id type_id, Id result_id,
                            std::vector<uint32_t> operands);

// Parses a module from its words; errors name the word offset and the reason.
core::Result<Module> parseModule(std::span<const uint32_t> words);
// Emits the module's words in the logical layout (the same words parseModule read, when unchanged).
std::vector<uint32_t> emitModule(const Module& module);
// A hash of the emitted words (core::hashBytes): the key of program and error caches.
uint64_t moduleHash(const Module& module);
uint64_t wordsHash(std::span<const uint32_t> words);

// Literal string helpers for building OpName/OpMemberName/... operands.
std::vector<uint32_t> encodeString(const std::string& text);

// ---------------------------------------------------------------------------------------------
// Def-use. Pointers into the module: valid until the module is mutated (then rebuild).

// Where an instruction lives. function/block are -1 outside function bodies; index is the position
// in the containing vector (Block::instructions, or the module section).
struct InstructionRef {
  const Instruction* instruction = nullptr;
  int function = -1;
  int block = -1;
  int index = -1;
};

class DefUse {
 public:
  explicit DefUse(const Module& module);
  // The defining instruction of `id`, or nullptr.
  const Instruction* def(Id id) const;
  const InstructionRef* defRef(Id id) const;
  // Every instruction with `id` among its id operands (names/decorations included), in module order.
  const std::vector<InstructionRef>& users(Id id) const;
  // OpDecorate / OpMemberDecorate instructions targeting `id`.
  std::vector<const Instruction*> decorations(Id id) const;
  // The literal of decoration `decoration` on `id` (e.g. Location, Binding, BuiltIn), if present.
  std::optional<uint32_t> decoration(Id id, spv::Decoration decoration) const;
  std::optional<uint32_t> memberDecoration(Id struct_type, uint32_t member,
                                           spv::Decoration decoration) const;
  bool hasDecoration(Id id, spv::Decoration decoration) const;

 private:
  const Module* module_;
  std::unordered_map<Id, InstructionRef> defs_;
  std::unordered_map<Id, std::vector<InstructionRef>> users_;
  std::vector<InstructionRef> no_users_;
};

// ---------------------------------------------------------------------------------------------
// Types and constants (queries through a DefUse).

struct TypeInfo {
  spv::Op opcode = spv::OpNop;  // OpTypeFloat, OpTypeVector, ...
  Id scalar_type = kNoId;       // the component scalar type (itself for a scalar)
  uint32_t components = 0;      // 1 scalar, n vector, columns×rows matrix; 0 otherwise
  uint32_t columns = 0;         // matrices
  uint32_t width = 0;           // bits of the scalar (0 for bool)
};
TypeInfo typeInfo(const DefUse& uses, Id type_id);
bool isFloatType(const DefUse& uses, Id type_id);          // scalar float
bool isFloatVectorType(const DefUse& uses, Id type_id);    // vector of float
bool isFloatScalarOrVector(const DefUse& uses, Id type_id);
bool isMatrixType(const DefUse& uses, Id type_id);
bool isBoolType(const DefUse& uses, Id type_id);
uint32_t componentCount(const DefUse& uses, Id type_id);  // 1 for scalars, n for vectors
Id scalarType(const DefUse& uses, Id type_id);
std::optional<spv::StorageClass> pointerStorageClass(const DefUse& uses, Id pointer_type);
Id pointeeType(const DefUse& uses, Id pointer_type);
bool isSampledImageType(const DefUse& uses, Id type_id);  // OpTypeSampledImage (sampler2D...)

bool isConstant(const DefUse& uses, Id id);  // OpConstant*, OpSpecConstant*, OpUndef excluded
// The value of a 32-bit scalar float/int/bool constant, or nothing.
std::optional<float> constantFloatValue(const DefUse& uses, Id id);
std::optional<int64_t> constantIntValue(const DefUse& uses, Id id);
// Scalar components of a (composite) constant, flattened, as floats (ints converted); empty if not
// a constant of numbers.
std::vector<float> constantAsFloats(const DefUse& uses, Id id);

// ---------------------------------------------------------------------------------------------
// Interface, uniforms, samplers.

struct InterfaceVariable {
  Id variable = kNoId;
  Id value_type = kNoId;  // the pointee type
  spv::StorageClass storage = spv::StorageClassInput;
  std::string name;
  std::optional<uint32_t> location;
  std::optional<spv::BuiltIn> builtin;  // on the variable, or on a member of its block (gl_PerVertex)
  bool flat = false;
};
// Input and Output variables of the module.
std::vector<InterfaceVariable> interfaceVariables(const Module& module, const DefUse& uses);

struct UniformMember {
  uint32_t index = 0;
  std::string name;
  Id type = kNoId;
  std::optional<uint32_t> offset;
};
struct UniformBlock {
  Id variable = kNoId;
  Id block_type = kNoId;  // the struct
  std::string name;       // the block type's name (e.g. "Frame")
  std::string instance_name;
  std::optional<uint32_t> binding;
  std::vector<UniformMember> members;
};
std::vector<UniformBlock> uniformBlocks(const Module& module, const DefUse& uses);

struct StorageBlock {  // a shader storage block (or an array of them)
  Id variable = kNoId;
  std::string name;  // the block type's name, else the instance's
  std::optional<uint32_t> binding;
  uint32_t count = 1;  // array elements: bindings binding .. binding + count - 1
};
std::vector<StorageBlock> storageBlocks(const Module& module, const DefUse& uses);

struct LooseUniform {  // a non-opaque UniformConstant with a Location
  Id variable = kNoId;
  Id value_type = kNoId;
  std::string name;
  std::optional<uint32_t> location;
};
std::vector<LooseUniform> looseUniforms(const Module& module, const DefUse& uses);

struct Sampler {
  Id variable = kNoId;
  Id type = kNoId;  // OpTypeSampledImage / OpTypeImage / OpTypeSampler
  std::string name;
  std::optional<uint32_t> binding;
};
std::vector<Sampler> samplers(const Module& module, const DefUse& uses);

// ---------------------------------------------------------------------------------------------
// Per-function control-flow graph.

struct Cfg {
  std::vector<Id> blocks;  // in function order; blocks[0] is the entry
  std::unordered_map<Id, int> index_of;
  std::vector<std::vector<int>> successors, predecessors;
  std::vector<int> merge_block;     // per block: index of its merge block, or -1
  std::vector<int> continue_block;  // per loop header: index of its continue target, or -1
  // Reverse post-order over structured successors (merge and continue targets first), so every
  // construct's blocks come before its merge block: the order to walk a structured program.
  std::vector<int> structured_order;
};
Cfg buildCfg(const Function& function);

// ---------------------------------------------------------------------------------------------
// Program dependence (per stage): what a value is computed from. Loads through Function-storage
// variables are followed to every store into that variable (flow-insensitive, so conservative),
// calls to their arguments and to what the callee reads.

struct ValueSources {
  std::set<Id> instructions;    // result ids in the backward slice (the value itself included)
  std::set<Id> global_reads;    // global variables loaded (Input, Uniform, UniformConstant, ...)
  bool reads_input = false;
  bool reads_uniform = false;   // Uniform / UniformConstant / PushConstant (non-opaque)
  bool reads_texture = false;   // an image/sampler variable
  bool reads_other = false;     // Output, Private, Workgroup, StorageBuffer... or unknown memory
  bool uses_derivatives = false;  // OpDPdx..., implicit-LOD sampling (fragment-only meaning)
  bool has_side_effects = false;  // OpKill, atomics, image writes in the slice
  // True when the value is a function of Input variables, uniforms and constants only: it can be
  // computed per vertex and interpolated (Wang et al. 2014), provided it is also smooth enough.
  bool onlyInputsUniformsConstants() const {
    return !reads_other && !reads_texture && !uses_derivatives && !has_side_effects;
  }
};
ValueSources backwardSlice(const Module& module, const DefUse& uses, Id value);
// The union of the values' slices, in one walk: each instruction is visited once however many
// slices share it (many loop conditions reading one variable).
ValueSources backwardSlice(const Module& module, const DefUse& uses, std::span<const Id> values);

// The flags of backwardSlice(value), for many values of one module. A value's slice is the
// closure of a fixed dependence graph (what one instruction depends on does not depend on which
// slice reaches it), so the flags are ORed once per strongly connected component (Tarjan) and
// shared: all of a module's values cost O(module) instead of O(module) each (the rules'
// site enumeration sliced every candidate, quadratic in the shader's length).
struct SliceFlags {
  bool reads_input = false;
  bool reads_uniform = false;
  bool reads_texture = false;
  bool reads_other = false;
  bool uses_derivatives = false;
  bool has_side_effects = false;
  bool reaches_marked = false;  // the slice holds an instruction `marked` accepts
  bool onlyInputsUniformsConstants() const {
    return !reads_other && !reads_texture && !uses_derivatives && !has_side_effects;
  }
};
class SliceSummaries {
 public:
  // `module` and `uses` must outlive this and stay unchanged. `marked` is asked about each
  // function-body instruction a slice holds (ValueSources::instructions).
  SliceSummaries(const Module& module, const DefUse& uses,
                 std::function<bool(const Instruction&)> marked);
  ~SliceSummaries();
  SliceSummaries(SliceSummaries&&) noexcept;
  SliceSummaries& operator=(SliceSummaries&&) noexcept;
  // Computed on first demand, for the value and everything its slice reaches.
  SliceFlags of(Id value);
  // The dependence edges of the values computed so far: the work of() did (tests count it).
  size_t dependenceCount() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// While it lives, Module::name on `module` (this very object, on this thread) looks names up in an
// index made at construction instead of scanning `names`: for read-only passes that name ids by
// the hundred (enumerateSites' descriptions). The module must not change meanwhile.
class NameIndexScope {
 public:
  explicit NameIndexScope(const Module& module);
  ~NameIndexScope();
  NameIndexScope(const NameIndexScope&) = delete;
  NameIndexScope& operator=(const NameIndexScope&) = delete;

 private:
  const void* index_;
};

}  // namespace duolod::shader::ir
