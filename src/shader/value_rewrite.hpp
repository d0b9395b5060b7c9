// Helpers shared by the rules (operation removal, texture, loops: dead code and loop constructs;
// "moving to parameter", He et al. 2015, and per-pixel → per-vertex, Wang et al. 2014: values
// replaced by something computed elsewhere) and by the instrumented render that averages a value
// (value_average.cpp). Private to src/shader.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "duolod/core.hpp"
#include "shader/ir.hpp"

namespace duolod::shader {

// Index into Module::functions of the entry point for `model`, or -1.
int entryFunctionIndex(const ir::Module& module, spv::ExecutionModel model);

// The id of the module's GLSL.std.450 extended instruction import (added when missing).
ir::Id glslStd450Import(ir::Module& module);

// Appends `variable` to the interface list of the entry point for `model` (Input/Output variables
// must be listed there in SPIR-V 1.0-1.3; every global from 1.4).
void addToEntryInterface(ir::Module& module, spv::ExecutionModel model, ir::Id variable);

// Where a replacement for `value` can be inserted so that it dominates every use of `value`: just
// before it, or after the last OpPhi of its block when `value` is a phi.
std::optional<ir::InstructionPosition> insertionPointFor(const ir::Module& module, ir::Id value);

// Replaces every use of `value` by a load of the global `variable` (whose pointee type must be the
// value's type), inserted where `value` is defined, then removes what became dead
// (removeDeadCode). Returns the id of the load.
core::Result<ir::Id> replaceValueByLoad(ir::Module& module, ir::Id value, ir::Id variable);

// Repeatedly removes what nothing uses any more: pure instructions with unused results, Function
// variables that are only stored to, calls of side-effect-free functions whose result and pointer
// arguments are unused, and functions nobody calls. Returns the number of instructions removed.
size_t removeDeadCode(ir::Module& module);

// The lowest varying location at or above `first` that neither the vertex stage's outputs nor the
// fragment stage's inputs use (vertex attributes and fragment outputs are other namespaces; a
// location taken by an array or matrix counts all the locations it spans).
uint32_t freeVaryingLocation(const ir::Module& vertex, const ir::Module& fragment, uint32_t first);
// The lowest location >= `first` that no loose uniform of `modules` uses and that is not in
// `taken`.
uint32_t freeUniformLocation(const std::vector<const ir::Module*>& modules, uint32_t first,
                             const std::vector<uint32_t>& taken);

// The blocks of the loop whose header is block `header` of `cfg`: every block reachable from the
// header without passing through its merge block (flags indexed like cfg.blocks).
std::vector<bool> loopConstructBlocks(const ir::Cfg& cfg, int header);

// Label ids of the blocks of `function` that lie inside a loop construct (from a loop header up to,
// not including, its merge block): a value there has one instance per iteration, so "its value at
// a pixel" is not one number.
std::set<ir::Id> blocksInLoops(const ir::Function& function);

// Fragment-entry values a value rule can target: results of the entry function of `model` whose
// type is a float scalar or vector, excluding loads, pointers, phis and constants; in module order.
std::vector<ir::Id> candidateValues(const ir::Module& module, const ir::DefUse& uses,
                                    spv::ExecutionModel model);

// Whether an instruction computes something (not a load, access chain, variable or composite
// shuffle): a value whose slice holds none is a plain copy of an input or a uniform.
bool isComputingInstruction(const ir::Instruction& instruction);

// Slice flags of `module`'s values, with reaches_marked meaning "computes something"
// (isComputingInstruction): what the value rules ask of each candidate.
ir::SliceSummaries computingSliceSummaries(const ir::Module& module, const ir::DefUse& uses);

// A readable name for a computed `value` in descriptions: its OpName, else the GLSL variable it is
// stored into (glslang names variables, not the results stored into them), else describeOperand (rules.cpp).
std::string describeComputedValue(const ir::Module& module, const ir::DefUse& uses, ir::Id value);

}  // namespace duolod::shader
