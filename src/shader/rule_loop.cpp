// Loop truncation (Pellacini 2005, "User-configurable automatic shader simplification", loop
// removal; Liang et al. §4.1): a loop with a constant trip count runs `choice` iterations instead,
// e.g. fewer fBm octaves.
//
// Only the counted-loop form is recognised, and only when its trip count is certain:
//   i = c0;  header: OpLoopMerge;  [cond block:] if (i <cmp> N) body else merge;
//   continue block: i = i ± step;
// where i is a Function variable written exactly twice (the constant initial store in the block
// entering the loop, the constant step in the continue block) and only loaded otherwise, and N is
// a 32-bit integer constant. The trip count is found by running the counter (≤ kMaxTripCount), so
// any comparison (<, <=, >, >=, !=, signed or unsigned, either side) and any step work; the
// truncated bound is checked the same way. Anything else is not offered.
#include <algorithm>
#include <optional>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {
namespace {

constexpr int64_t kMaxTripCount = 4096;

struct CountedLoop {
  int function = 0;
  int compare_block = 0;          // the block holding the comparison
  ir::Id compare = ir::kNoId;     // the comparison's result id
  size_t bound_operand = 1;       // operands[bound_operand] of the comparison is N
  ir::Id counter = ir::kNoId;     // the variable i
  int64_t initial = 0;
  int64_t step = 0;
  int64_t bound = 0;
  bool is_signed = true;
  bool continue_when_true = true;  // the loop continues while the comparison holds
  spv::Op compare_opcode = spv::OpSLessThan;
  int64_t trip_count = 0;
};

int64_t wrap32(int64_t value, bool is_signed) {
  auto bits = static_cast<uint32_t>(static_cast<uint64_t>(value));
  return is_signed ? static_cast<int64_t>(static_cast<int32_t>(bits)) : static_cast<int64_t>(bits);
}

// Evaluates `a <op> b` for an integer comparison opcode, or nothing for other opcodes.
std::optional<bool> compareIntegers(spv::Op opcode, int64_t a, int64_t b) {
  switch (opcode) {
    case spv::OpSLessThan: case spv::OpULessThan: return a < b;
    case spv::OpSLessThanEqual: case spv::OpULessThanEqual: return a <= b;
    case spv::OpSGreaterThan: case spv::OpUGreaterThan: return a > b;
    case spv::OpSGreaterThanEqual: case spv::OpUGreaterThanEqual: return a >= b;
    case spv::OpIEqual: return a == b;
    case spv::OpINotEqual: return a != b;
    default: return std::nullopt;
  }
}

bool isUnsignedCompare(spv::Op opcode) {
  return opcode == spv::OpULessThan || opcode == spv::OpULessThanEqual ||
         opcode == spv::OpUGreaterThan || opcode == spv::OpUGreaterThanEqual;
}

// Iterations the loop runs with `bound` in place of N, or nothing past kMaxTripCount.
std::optional<int64_t> tripCount(const CountedLoop& loop, int64_t bound) {
  int64_t value = loop.initial;
  for (int64_t count = 0; count <= kMaxTripCount; ++count) {
    int64_t left = loop.bound_operand == 1 ? value : bound;
    int64_t right = loop.bound_operand == 1 ? bound : value;
    if (*compareIntegers(loop.compare_opcode, left, right) != loop.continue_when_true) return count;
    value = wrap32(value + loop.step, loop.is_signed);
  }
  return std::nullopt;
}

// The bound that makes the loop run exactly `iterations` times, or nothing.
std::optional<int64_t> boundFor(const CountedLoop& loop, int64_t iterations) {
  // The counter's value after `iterations` steps (strict comparisons) or one step before (non-
  // strict); the check by tripCount decides.
  for (int64_t steps : {iterations, iterations - 1, iterations + 1}) {
    int64_t candidate = wrap32(loop.initial + steps * loop.step, loop.is_signed);
    if (tripCount(loop, candidate) == iterations) return candidate;
  }
  return std::nullopt;
}

const ir::Instruction* findInBlock(const ir::Block& block, ir::Id id) {
  for (const ir::Instruction& instruction : block.instructions)
    if (instruction.result_id == id) return &instruction;
  return nullptr;
}

// Recognises the counted loop headed by block `header` of function `function_index`.
std::optional<CountedLoop> recogniseLoop(const ir::Module& module, const ir::DefUse& uses,
                                         int function_index, const ir::Cfg& cfg, int header) {
  const ir::Function& function = module.functions[static_cast<size_t>(function_index)];
  const ir::Block& header_block = function.blocks[static_cast<size_t>(header)];
  const ir::Instruction* merge = header_block.mergeInstruction();
  if (!merge || merge->opcode != spv::OpLoopMerge) return std::nullopt;
  ir::Id merge_label = merge->operands[0];
  ir::Id continue_label = merge->operands[1];

  // The block with the exit test: the header itself, or the block it branches to.
  int compare_block = header;
  if (header_block.terminator().opcode == spv::OpBranch) {
    auto next = cfg.index_of.find(header_block.terminator().operands[0]);
    if (next == cfg.index_of.end()) return std::nullopt;
    compare_block = next->second;
  }
  const ir::Block& test_block = function.blocks[static_cast<size_t>(compare_block)];
  const ir::Instruction& branch = test_block.terminator();
  if (branch.opcode != spv::OpBranchConditional) return std::nullopt;
  CountedLoop loop{.function = function_index, .compare_block = compare_block};
  if (branch.operands[2] == merge_label) {
    loop.continue_when_true = true;
  } else if (branch.operands[1] == merge_label) {
    loop.continue_when_true = false;
  } else {
    return std::nullopt;
  }
  const ir::Instruction* compare = findInBlock(test_block, branch.operands[0]);
  if (!compare || !compareIntegers(compare->opcode, 0, 0)) return std::nullopt;
  loop.compare = compare->result_id;
  loop.compare_opcode = compare->opcode;
  loop.is_signed = !isUnsignedCompare(compare->opcode);

  // One side a load of the counter, the other a constant bound.
  const ir::Instruction* load = nullptr;
  for (size_t side = 0; side < 2; ++side) {
    const ir::Instruction* operand = uses.def(compare->operands[side]);
    const ir::Instruction* other = uses.def(compare->operands[1 - side]);
    if (!operand || !other || operand->opcode != spv::OpLoad || !ir::isConstant(uses, other->result_id))
      continue;
    std::optional<int64_t> bound = ir::constantIntValue(uses, other->result_id);
    ir::TypeInfo type = ir::typeInfo(uses, other->type_id);
    if (!bound || type.opcode != spv::OpTypeInt || type.width != 32) continue;
    load = operand;
    loop.bound_operand = 1 - side;
    loop.bound = wrap32(*bound, loop.is_signed);
  }
  if (!load) return std::nullopt;
  const ir::Instruction* counter = uses.def(load->operands[0]);
  if (!counter || counter->opcode != spv::OpVariable ||
      counter->operands[0] != spv::StorageClassFunction)
    return std::nullopt;
  loop.counter = counter->result_id;

  // Exactly two stores, everything else loads (or names): no pointer escapes.
  std::vector<bool> in_loop = loopConstructBlocks(cfg, header);
  std::optional<int64_t> initial, step;
  int stores = 0;
  for (const ir::InstructionRef& user : uses.users(loop.counter)) {
    const ir::Instruction& instruction = *user.instruction;
    if (instruction.opcode == spv::OpLoad || instruction.opcode == spv::OpName) continue;
    if (instruction.opcode != spv::OpStore || instruction.operands[0] != loop.counter ||
        user.function != function_index)
      return std::nullopt;
    ++stores;
    const ir::Instruction* value = uses.def(instruction.operands[1]);
    if (!value) return std::nullopt;
    if (!in_loop[static_cast<size_t>(user.block)]) {
      // The initial value, stored on the way into the header.
      const std::vector<int>& into_header = cfg.predecessors[static_cast<size_t>(header)];
      if (std::find(into_header.begin(), into_header.end(), user.block) == into_header.end())
        return std::nullopt;
      initial = ir::constantIntValue(uses, value->result_id);
    } else {
      // The step, in the continue block: i = i ± constant.
      if (function.blocks[static_cast<size_t>(user.block)].id() != continue_label) return std::nullopt;
      if (value->opcode != spv::OpIAdd && value->opcode != spv::OpISub) return std::nullopt;
      for (size_t side = 0; side < 2; ++side) {
        const ir::Instruction* operand = uses.def(value->operands[side]);
        std::optional<int64_t> constant = ir::constantIntValue(uses, value->operands[1 - side]);
        if (!operand || operand->opcode != spv::OpLoad || operand->operands[0] != loop.counter ||
            !constant || (value->opcode == spv::OpISub && side == 1))
          continue;
        step = value->opcode == spv::OpISub ? -*constant : *constant;
      }
    }
  }
  if (stores != 2 || !initial || !step || *step == 0) return std::nullopt;
  loop.initial = wrap32(*initial, loop.is_signed);
  loop.step = *step;
  std::optional<int64_t> trips = tripCount(loop, loop.bound);
  if (!trips || *trips < 2) return std::nullopt;
  loop.trip_count = *trips;
  return loop;
}

std::optional<CountedLoop> recogniseLoopAt(const ir::Module& module, const ir::DefUse& uses,
                                           ir::Id header_label) {
  for (size_t f = 0; f < module.functions.size(); ++f) {
    const ir::Function& function = module.functions[f];
    for (size_t b = 0; b < function.blocks.size(); ++b)
      if (function.blocks[b].id() == header_label) {
        ir::Cfg cfg = ir::buildCfg(function);
        return recogniseLoop(module, uses, static_cast<int>(f), cfg, static_cast<int>(b));
      }
  }
  return std::nullopt;
}

// Iteration counts offered for a loop of `trips` iterations: all of 1..trips-1 for short loops,
// powers of two and three quarters for long ones (so a 64-iteration loop is 8 sites, not 63).
std::vector<int64_t> iterationChoices(int64_t trips) {
  std::vector<int64_t> choices;
  if (trips <= 8) {
    for (int64_t k = 1; k < trips; ++k) choices.push_back(k);
    return choices;
  }
  for (int64_t k = 1; k < trips; k *= 2) choices.push_back(k);
  int64_t three_quarters = trips * 3 / 4;
  if (std::find(choices.begin(), choices.end(), three_quarters) == choices.end())
    choices.push_back(three_quarters);
  std::sort(choices.begin(), choices.end());
  return choices;
}

std::string loopLabel(const ir::Module& module, const CountedLoop& loop) {
  std::string function = functionName(module, static_cast<size_t>(loop.function));
  return "loop over " + valueName(module, loop.counter) +
         (function.empty() ? std::string() : " in " + function);
}

// Whether an instruction of the loop headed by block `header` has a result in `ids`.
bool loopFeedsAnyOf(const ir::Function& function, const ir::Cfg& cfg, int header,
                    const std::unordered_set<ir::Id>& ids) {
  const std::vector<bool> in_loop = loopConstructBlocks(cfg, header);
  for (size_t b = 0; b < in_loop.size() && b < function.blocks.size(); ++b) {
    if (!in_loop[b]) continue;
    for (const ir::Instruction& instruction : function.blocks[b].instructions)
      if (instruction.hasResult() && ids.count(instruction.result_id)) return true;
  }
  return false;
}

}  // namespace

std::vector<RuleSite> findLoopTruncationSites(const ShaderProgram& program, const RuleContext&) {
  std::vector<RuleSite> sites;
  for (Stage stage : {Stage::kVertex, Stage::kFragment}) {
    const ir::Module& module = stageModule(program, stage);
    ir::DefUse uses(module);
    // A vertex-stage loop the position depends on (skinning over bones) is left alone.
    const std::unordered_set<ir::Id> position = stage == Stage::kVertex
                                                    ? vertexPositionSources(module, uses)
                                                    : std::unordered_set<ir::Id>{};
    for (size_t f = 0; f < module.functions.size(); ++f) {
      ir::Cfg cfg = ir::buildCfg(module.functions[f]);
      for (size_t b = 0; b < cfg.blocks.size(); ++b) {
        std::optional<CountedLoop> loop =
            recogniseLoop(module, uses, static_cast<int>(f), cfg, static_cast<int>(b));
        if (!loop) continue;
        if (!position.empty() &&
            loopFeedsAnyOf(module.functions[f], cfg, static_cast<int>(b), position))
          continue;
        for (int64_t iterations : iterationChoices(loop->trip_count)) {
          if (!boundFor(*loop, iterations)) continue;
          sites.push_back({.kind = RuleKind::kLoopTruncation,
                           .stage = stage,
                           .target = cfg.blocks[b],
                           .choice = static_cast<uint32_t>(iterations),
                           .description = stageName(stage) + ": " + loopLabel(module, *loop) +
                                          ": " + std::to_string(loop->trip_count) + " → " +
                                          std::to_string(iterations) + " iterations"});
        }
      }
    }
  }
  return sites;
}

core::Result<ShaderProgram> applyLoopTruncation(const ShaderProgram& program, const RuleSite& site,
                                                const RuleContext&) {
  const ir::Module& original = stageModule(program, site.stage);
  ir::DefUse uses(original);
  std::optional<CountedLoop> loop = recogniseLoopAt(original, uses, site.target);
  if (!loop) return siteError(site, "no longer a loop with a constant trip count");
  if (site.choice < 1 || site.choice >= loop->trip_count)
    return siteError(site, "the loop runs " + std::to_string(loop->trip_count) +
                               " iterations; cannot truncate to " + std::to_string(site.choice));
  std::optional<int64_t> bound = boundFor(*loop, site.choice);
  if (!bound) return siteError(site, "no bound gives " + std::to_string(site.choice) + " iterations");

  ShaderProgram rewritten = program;
  ir::Module& module = stageModule(rewritten, site.stage);
  ir::Id constant = loop->is_signed ? module.constantInt(static_cast<int32_t>(*bound))
                                    : module.constantUint(static_cast<uint32_t>(*bound));
  // The bound's type must stay the comparison operand's type (int vs uint as declared).
  ir::DefUse new_uses(module);
  ir::Block& block = module.functions[static_cast<size_t>(loop->function)]
                         .blocks[static_cast<size_t>(loop->compare_block)];
  for (ir::Instruction& instruction : block.instructions) {
    if (instruction.result_id != loop->compare) continue;
    const ir::Instruction* old_bound = new_uses.def(instruction.operands[loop->bound_operand]);
    const ir::Instruction* new_bound = new_uses.def(constant);
    if (!old_bound || !new_bound || old_bound->type_id != new_bound->type_id)
      return siteError(site, "the bound's integer type is neither the module's int nor uint");
    instruction.operands[loop->bound_operand] = constant;
  }
  return rewritten;
}

}  // namespace duolod::shader
