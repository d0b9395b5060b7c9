// duolod's SPIR-V IR: parse → emit round trip on the reference shaders (identical words), def-use,
// CFG, type/constant queries, interface/uniform/sampler discovery, the dependence slice, and the
// mutation helpers rules use (each mutated module must still validate).
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>

#include "duolod/shader.hpp"
#include "shader/ir.hpp"
#include "test_support.hpp"

namespace duolod::shader {
namespace {

using test::readShader;

std::vector<uint32_t> compileOrDie(const std::string& source, Stage stage, const std::string& name) {
  auto words = compileToSpirv(source, stage, name);
  EXPECT_TRUE(words.ok()) << (words.ok() ? "" : words.error().message);
  return words.ok() ? *words : std::vector<uint32_t>{};
}

ir::Module parseOrDie(const std::vector<uint32_t>& words) {
  auto module = ir::parseModule(words);
  EXPECT_TRUE(module.ok()) << (module.ok() ? "" : module.error().message);
  return module.ok() ? *module : ir::Module{};
}

class ReferenceShaders : public ::testing::TestWithParam<const char*> {};

TEST_P(ReferenceShaders, RoundTripIsWordIdenticalAndValid) {
  for (const char* extension : {".vert", ".frag"}) {
    std::string file = std::string(GetParam()) + extension;
    Stage stage = std::string(extension) == ".vert" ? Stage::kVertex : Stage::kFragment;
    std::vector<uint32_t> words = compileOrDie(readShader(file), stage, file);
    ASSERT_FALSE(words.empty());
    ir::Module module = parseOrDie(words);
    std::vector<uint32_t> emitted = ir::emitModule(module);
    EXPECT_EQ(emitted, words) << file;
    EXPECT_EQ(ir::wordsHash(words), ir::moduleHash(module));
    auto valid = validateSpirv(emitted, file);
    EXPECT_TRUE(valid.ok()) << (valid.ok() ? "" : valid.error().message);
    // Reparsing the emitted words gives the same IR.
    EXPECT_EQ(parseOrDie(emitted), module);
  }
}

INSTANTIATE_TEST_SUITE_P(Shaders, ReferenceShaders,
                         ::testing::Values("pbr", "noise_phong", "blend", "constant"));

// A small fragment shader with a branch, a loop with a constant trip count, a texture, a uniform
// block and a loose (non-block) uniform: predictable structure to check the analyses against.
const char* kSmallFragment = R"(#version 450 core
layout(std140, binding = 1) uniform Material {
  vec4 uBaseColorFactor;
  vec4 uEmissiveFactor;
};
layout(binding = 2) uniform sampler2D uNormalTexture;
layout(location = 0) in vec3 vNormal;
layout(location = 1) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  vec3 n = normalize(vNormal);
  float lit = max(n.z, 0.0) * 2.0;
  if (lit > 0.5) lit = lit * uEmissiveFactor.x;
  float sum = 0.0;
  for (int i = 0; i < 4; ++i) sum += float(i);
  vec4 texel = texture(uNormalTexture, vUV);
  outColor = vec4(uBaseColorFactor.rgb * lit, 1.0) + texel * sum;
}
)";

struct SmallShader {
  std::vector<uint32_t> words;
  ir::Module module;
};

SmallShader smallShader() {
  SmallShader shader;
  shader.words = compileOrDie(kSmallFragment, Stage::kFragment, "small.frag");
  shader.module = parseOrDie(shader.words);
  return shader;
}

// The id of the global (module-scope) variable named `name`.
ir::Id variableNamed(const ir::Module& module, const std::string& name) {
  for (const ir::Instruction& instruction : module.types_values)
    if (instruction.opcode == spv::OpVariable && module.name(instruction.result_id) == name)
      return instruction.result_id;
  return ir::kNoId;
}

// The result id of the last instruction with `opcode` in the fragment entry function.
ir::Id lastOfOpcode(const ir::Module& module, spv::Op opcode) {
  ir::Id found = ir::kNoId;
  for (const ir::Block& block : module.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions)
      if (instruction.opcode == opcode) found = instruction.result_id;
  return found;
}

TEST(ShaderIr, SectionsNamesAndEntryPoint) {
  SmallShader shader = smallShader();
  const ir::Module& module = shader.module;
  EXPECT_EQ(module.memory_model.size(), 1u);
  ASSERT_EQ(module.entry_points.size(), 1u);
  EXPECT_EQ(module.entry_points[0].literalString(2), "main");
  ASSERT_NE(module.entryFunction(spv::ExecutionModelFragment), nullptr);
  EXPECT_EQ(module.entryFunction(spv::ExecutionModelVertex), nullptr);
  EXPECT_EQ(module.ext_inst_imports.size(), 1u);  // GLSL.std.450
  EXPECT_NE(variableNamed(module, "vNormal"), ir::kNoId);
  EXPECT_NE(variableNamed(module, "uNormalTexture"), ir::kNoId);
}

TEST(ShaderIr, InterfaceUniformsAndSamplers) {
  SmallShader shader = smallShader();
  ir::DefUse uses(shader.module);
  std::vector<ir::InterfaceVariable> interface = ir::interfaceVariables(shader.module, uses);
  ASSERT_EQ(interface.size(), 3u);
  std::map<std::string, ir::InterfaceVariable> by_name;
  for (const auto& variable : interface) by_name[variable.name] = variable;
  EXPECT_EQ(by_name["vNormal"].location, 0u);
  EXPECT_EQ(by_name["vUV"].location, 1u);
  EXPECT_EQ(by_name["vUV"].storage, spv::StorageClassInput);
  EXPECT_EQ(by_name["outColor"].storage, spv::StorageClassOutput);
  EXPECT_EQ(ir::componentCount(uses, by_name["vNormal"].value_type), 3u);
  EXPECT_TRUE(ir::isFloatVectorType(uses, by_name["vUV"].value_type));

  std::vector<ir::UniformBlock> blocks = ir::uniformBlocks(shader.module, uses);
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].name, "Material");
  EXPECT_EQ(blocks[0].binding, 1u);
  ASSERT_EQ(blocks[0].members.size(), 2u);
  EXPECT_EQ(blocks[0].members[1].name, "uEmissiveFactor");
  EXPECT_EQ(blocks[0].members[1].offset, 16u);  // std140: vec4 after vec4

  std::vector<ir::Sampler> textures = ir::samplers(shader.module, uses);
  ASSERT_EQ(textures.size(), 1u);
  EXPECT_EQ(textures[0].name, "uNormalTexture");
  EXPECT_EQ(textures[0].binding, 2u);
  EXPECT_TRUE(ir::isSampledImageType(uses, textures[0].type));
  EXPECT_TRUE(ir::looseUniforms(shader.module, uses).empty());
}

TEST(ShaderIr, DefUseAndConstants) {
  SmallShader shader = smallShader();
  ir::DefUse uses(shader.module);
  ir::Id normal = variableNamed(shader.module, "vNormal");
  // vNormal: one OpLoad, one OpName, one OpDecorate (Location) and the entry-point interface.
  int loads = 0, names = 0;
  for (const ir::InstructionRef& user : uses.users(normal)) {
    loads += user.instruction->opcode == spv::OpLoad;
    names += user.instruction->opcode == spv::OpName;
  }
  EXPECT_EQ(loads, 1);
  EXPECT_EQ(names, 1);
  EXPECT_EQ(uses.decoration(normal, spv::DecorationLocation), 0u);
  ASSERT_NE(uses.def(normal), nullptr);
  EXPECT_EQ(uses.def(normal)->opcode, spv::OpVariable);
  EXPECT_EQ(ir::pointerStorageClass(uses, uses.def(normal)->type_id), spv::StorageClassInput);

  // The constant 2.0 of `max(n.z, 0.0) * 2.0` exists and reads back.
  bool found_two = false;
  for (const ir::Instruction& instruction : shader.module.types_values)
    if (instruction.opcode == spv::OpConstant && ir::constantFloatValue(uses, instruction.result_id) == 2.0f)
      found_two = true;
  EXPECT_TRUE(found_two);
}

TEST(ShaderIr, CfgOfBranchAndLoop) {
  SmallShader shader = smallShader();
  const ir::Function& main_function = *shader.module.entryFunction(spv::ExecutionModelFragment);
  ir::Cfg cfg = ir::buildCfg(main_function);
  ASSERT_EQ(cfg.blocks.size(), main_function.blocks.size());
  int loop_headers = 0, selection_headers = 0;
  for (size_t b = 0; b < main_function.blocks.size(); ++b) {
    const ir::Instruction* merge = main_function.blocks[b].mergeInstruction();
    if (!merge) continue;
    if (merge->opcode == spv::OpLoopMerge) {
      ++loop_headers;
      EXPECT_GE(cfg.continue_block[b], 0);
    } else {
      ++selection_headers;
    }
    EXPECT_GE(cfg.merge_block[b], 0);
  }
  EXPECT_EQ(loop_headers, 1);
  EXPECT_EQ(selection_headers, 1);
  // Predecessors mirror successors.
  for (size_t b = 0; b < cfg.successors.size(); ++b)
    for (int s : cfg.successors[b]) {
      const auto& predecessors = cfg.predecessors[static_cast<size_t>(s)];
      EXPECT_NE(std::find(predecessors.begin(), predecessors.end(), static_cast<int>(b)), predecessors.end());
    }
  // The structured order visits every block once, entry first, each header before its merge.
  ASSERT_EQ(cfg.structured_order.size(), cfg.blocks.size());
  EXPECT_EQ(cfg.structured_order[0], 0);
  std::vector<int> position(cfg.blocks.size());
  for (size_t i = 0; i < cfg.structured_order.size(); ++i)
    position[static_cast<size_t>(cfg.structured_order[i])] = static_cast<int>(i);
  for (size_t b = 0; b < cfg.blocks.size(); ++b) {
    if (cfg.merge_block[b] < 0) continue;
    EXPECT_LT(position[b], position[static_cast<size_t>(cfg.merge_block[b])]);
    // Every block of the construct (reached from the header without the merge) precedes the merge.
    for (int s : cfg.successors[b]) {
      if (s == cfg.merge_block[b]) continue;
      EXPECT_LT(position[static_cast<size_t>(s)], position[static_cast<size_t>(cfg.merge_block[b])]);
    }
  }
}

TEST(ShaderIr, BackwardSliceSeparatesInterpolatedFromTextured) {
  SmallShader shader = smallShader();
  ir::DefUse uses(shader.module);
  // normalize(vNormal): only an input.
  ir::Id normalized = ir::kNoId;
  for (const ir::Block& block : shader.module.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions)
      if (instruction.opcode == spv::OpExtInst && normalized == ir::kNoId) normalized = instruction.result_id;
  ASSERT_NE(normalized, ir::kNoId);
  ir::ValueSources normal_sources = ir::backwardSlice(shader.module, uses, normalized);
  EXPECT_TRUE(normal_sources.reads_input);
  EXPECT_FALSE(normal_sources.reads_uniform);
  EXPECT_TRUE(normal_sources.onlyInputsUniformsConstants());
  EXPECT_TRUE(normal_sources.global_reads.count(variableNamed(shader.module, "vNormal")));

  // The texture sample: depends on a texture and on derivatives (implicit LOD).
  ir::Id sample = lastOfOpcode(shader.module, spv::OpImageSampleImplicitLod);
  ASSERT_NE(sample, ir::kNoId);
  ir::ValueSources sample_sources = ir::backwardSlice(shader.module, uses, sample);
  EXPECT_TRUE(sample_sources.reads_texture);
  EXPECT_TRUE(sample_sources.uses_derivatives);
  EXPECT_FALSE(sample_sources.onlyInputsUniformsConstants());

  // The value stored to outColor: through locals `lit` (conditionally assigned: its condition
  // joins the slice) and `sum` (a loop), plus the texture.
  ir::Id out_value = ir::kNoId;
  ir::Id out_color = variableNamed(shader.module, "outColor");
  for (const ir::Block& block : shader.module.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions)
      if (instruction.opcode == spv::OpStore && instruction.operands[0] == out_color)
        out_value = instruction.operands[1];
  ir::ValueSources out_sources = ir::backwardSlice(shader.module, uses, out_value);
  EXPECT_TRUE(out_sources.reads_uniform);
  EXPECT_TRUE(out_sources.reads_input);
  EXPECT_TRUE(out_sources.reads_texture);
  EXPECT_GT(out_sources.instructions.size(), sample_sources.instructions.size());
  // The comparison `lit > 0.5` decides a store into `lit`, so it is in the slice.
  ir::Id comparison = lastOfOpcode(shader.module, spv::OpFOrdGreaterThan);
  ASSERT_NE(comparison, ir::kNoId);
  EXPECT_TRUE(out_sources.instructions.count(comparison));
}

// SliceSummaries (every value's slice flags from one pass over the dependence graph) must say
// exactly what slicing each value on its own says, on shaders with calls, loops, branches and
// textures: every function-body value of the reference shaders' stages and the small shader.
void expectSummariesMatchSlices(const ir::Module& module, const std::string& what) {
  ir::DefUse uses(module);
  auto computes = [](const ir::Instruction& instruction) {
    return instruction.opcode != spv::OpLoad && instruction.opcode != spv::OpCompositeExtract;
  };
  ir::SliceSummaries summaries(module, uses, computes);
  int values = 0;
  std::set<int> combinations;  // of the flags: the comparison is not of constant answers
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks)
      for (const ir::Instruction& instruction : block.instructions) {
        if (!instruction.hasResult()) continue;
        ++values;
        ir::ValueSources slice = ir::backwardSlice(module, uses, instruction.result_id);
        bool marked = false;
        for (ir::Id id : slice.instructions) marked |= computes(*uses.def(id));
        ir::SliceFlags summary = summaries.of(instruction.result_id);
        EXPECT_EQ(summary.reads_input, slice.reads_input) << what << " %" << instruction.result_id;
        EXPECT_EQ(summary.reads_uniform, slice.reads_uniform)
            << what << " %" << instruction.result_id;
        EXPECT_EQ(summary.reads_texture, slice.reads_texture)
            << what << " %" << instruction.result_id;
        EXPECT_EQ(summary.reads_other, slice.reads_other) << what << " %" << instruction.result_id;
        EXPECT_EQ(summary.uses_derivatives, slice.uses_derivatives)
            << what << " %" << instruction.result_id;
        EXPECT_EQ(summary.has_side_effects, slice.has_side_effects)
            << what << " %" << instruction.result_id;
        EXPECT_EQ(summary.reaches_marked, marked) << what << " %" << instruction.result_id;
        combinations.insert(summary.reads_input | summary.reads_uniform << 1 |
                            summary.reads_texture << 2 | summary.reads_other << 3 |
                            summary.uses_derivatives << 4 | summary.reaches_marked << 5);
      }
  EXPECT_GT(values, 20) << what;
  EXPECT_GE(combinations.size(), 3u) << what;
  std::printf("[ summaries ] %s: %d values agree\n", what.c_str(), values);
}

TEST(ShaderIr, SliceSummariesAgreeWithSlicingEachValue) {
  for (const char* name : {"pbr", "noise_phong", "blend"})
    for (const char* extension : {".vert", ".frag"}) {
      std::string file = std::string(name) + extension;
      Stage stage = std::string(extension) == ".vert" ? Stage::kVertex : Stage::kFragment;
      expectSummariesMatchSlices(parseOrDie(compileOrDie(readShader(file), stage, file)), file);
    }
  expectSummariesMatchSlices(smallShader().module, "small.frag");
}

// A fragment shader of `branches` sequential if/else blocks, each updating the colour `c`.
std::string manyBranchesShader(int branches) {
  std::string source = R"(#version 450 core
layout(std140, binding = 1) uniform Material { vec4 uBaseColorFactor; vec4 uMaterialParams; };
layout(location = 0) out vec4 outColor;
void main() {
  vec3 c = uBaseColorFactor.rgb;
  float a = uMaterialParams.x;
)";
  for (int i = 0; i < branches; ++i)
    source +=
        "  if (c.x > " + std::to_string(i) + ".0 * a) c = c * 1.5 + vec3(a); else c = c.zxy;\n";
  return source + "  outColor = vec4(c, 1.0);\n}\n";
}

ir::Id valueStoredTo(const ir::Module& module, const std::string& variable) {
  ir::Id target = variableNamed(module, variable.c_str()), value = ir::kNoId;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks)
      for (const ir::Instruction& instruction : block.instructions)
        if (instruction.opcode == spv::OpStore && instruction.operands[0] == target)
          value = instruction.operands[1];
  return value;
}

TEST(ShaderIr, SliceSummariesOfManyBranchesAgreeAndGrowLinearly) {
  expectSummariesMatchSlices(
      parseOrDie(compileOrDie(manyBranchesShader(12), Stage::kFragment, "branches.frag")),
      "12 branches");
  // A local stored in N branches and loaded in N: each load depends on the variable, not on its
  // N stores, so the graph has O(N) edges (it had N² before, and 400 branches took a minute).
  std::vector<size_t> edges;
  for (int branches : {100, 300}) {
    ir::Module module =
        parseOrDie(compileOrDie(manyBranchesShader(branches), Stage::kFragment, "branches.frag"));
    ir::DefUse uses(module);
    ir::SliceSummaries summaries(module, uses, [](const ir::Instruction&) { return false; });
    ir::Id out = valueStoredTo(module, "outColor");
    ASSERT_NE(out, ir::kNoId);
    ir::SliceFlags flags = summaries.of(out);
    ir::ValueSources slice = ir::backwardSlice(module, uses, out);
    EXPECT_TRUE(flags.reads_uniform && slice.reads_uniform);
    EXPECT_EQ(flags.reads_input, slice.reads_input);
    EXPECT_EQ(flags.reads_other, slice.reads_other);
    edges.push_back(summaries.dependenceCount());
    std::printf("[ branches ] %d: %zu dependence edges\n", branches, edges.back());
    EXPECT_LT(edges.back(), size_t(branches) * 40) << branches << " branches";
  }
  EXPECT_LT(double(edges[1]) / double(edges[0]), 3.5) << "300 branches against 100";
}

// backwardSlice of several values in one walk is the union of their slices.
TEST(ShaderIr, BackwardSliceOfManyValuesIsTheUnionOfTheirSlices) {
  ir::Module module =
      parseOrDie(compileOrDie(readShader("pbr.frag"), Stage::kFragment, "pbr.frag"));
  ir::DefUse uses(module);
  std::vector<ir::Id> values;
  int seen = 0;
  for (const ir::Function& function : module.functions)
    for (const ir::Block& block : function.blocks)
      for (const ir::Instruction& instruction : block.instructions)
        if (instruction.hasResult() && ++seen % 11 == 0) values.push_back(instruction.result_id);
  ASSERT_GT(values.size(), 5u);
  ir::ValueSources together = ir::backwardSlice(module, uses, values);
  std::set<ir::Id> instructions, globals;
  bool reads_texture = false, reads_input = false, uses_derivatives = false;
  for (ir::Id value : values) {
    ir::ValueSources one = ir::backwardSlice(module, uses, value);
    instructions.insert(one.instructions.begin(), one.instructions.end());
    globals.insert(one.global_reads.begin(), one.global_reads.end());
    reads_texture |= one.reads_texture;
    reads_input |= one.reads_input;
    uses_derivatives |= one.uses_derivatives;
  }
  EXPECT_EQ(together.instructions, instructions);
  EXPECT_EQ(together.global_reads, globals);
  EXPECT_EQ(together.reads_texture, reads_texture);
  EXPECT_EQ(together.reads_input, reads_input);
  EXPECT_EQ(together.uses_derivatives, uses_derivatives);
  EXPECT_TRUE(ir::backwardSlice(module, uses, std::span<const ir::Id>{}).instructions.empty());
}

TEST(ShaderIr, MutationsKeepTheModuleValid) {
  SmallShader shader = smallShader();
  ir::Module& module = shader.module;
  uint32_t bound = module.bound;
  ir::Id two = module.constantFloat(2.0f);
  EXPECT_EQ(module.bound, bound) << "2.0 exists already: de-duplicated";
  ir::Id seven = module.constantFloat(7.0f);
  EXPECT_EQ(seven, bound);
  EXPECT_EQ(module.bound, bound + 1);
  EXPECT_EQ(module.constantFloat(7.0f), seven);

  // Operation removal by hand: replace `max(n.z,0)*2.0` (the OpFMul by 2.0) with its left operand.
  ir::DefUse uses(module);
  ir::Id product = ir::kNoId, left = ir::kNoId;
  for (const ir::Block& block : module.entryFunction(spv::ExecutionModelFragment)->blocks)
    for (const ir::Instruction& instruction : block.instructions)
      if (instruction.opcode == spv::OpFMul && instruction.operands[1] == two) {
        product = instruction.result_id;
        left = instruction.operands[0];
      }
  ASSERT_NE(product, ir::kNoId);
  EXPECT_FALSE(uses.users(product).empty());
  module.replaceAllUses(product, left);
  module.removeInstructions({product});
  ir::DefUse after(module);
  EXPECT_EQ(after.def(product), nullptr);
  EXPECT_TRUE(after.users(product).empty());
  std::vector<uint32_t> words = ir::emitModule(module);
  auto valid = validateSpirv(words, "mutated");
  EXPECT_TRUE(valid.ok()) << (valid.ok() ? "" : valid.error().message);
  EXPECT_NE(ir::wordsHash(words), ir::wordsHash(shader.words));

  // A new loose uniform and an instruction inserted before the store to outColor that scales the
  // stored colour by it.
  ir::Id vec4_type = module.typeVector(module.typeFloat(), 4);
  ir::Id scale = module.addLooseUniform(vec4_type, "uAverageScale", 7);
  EXPECT_EQ(module.addLooseUniform(vec4_type, "uAverageScale", 7), scale);
  ir::Id out_color = variableNamed(module, "outColor");
  ir::Function& main_function = *module.entryFunction(spv::ExecutionModelFragment);
  bool inserted = false;
  for (size_t b = 0; b < main_function.blocks.size() && !inserted; ++b) {
    auto& list = main_function.blocks[b].instructions;
    for (size_t i = 0; i < list.size(); ++i) {
      if (list[i].opcode != spv::OpStore || list[i].operands[0] != out_color) continue;
      ir::Id original = list[i].operands[1];
      ir::Id loaded = module.allocateId(), scaled = module.allocateId();
      std::vector<ir::Instruction> code = {
          ir::makeInstruction(module, spv::OpLoad, vec4_type, loaded, {scale}),
          ir::makeInstruction(module, spv::OpFMul, vec4_type, scaled, {original, loaded})};
      EXPECT_EQ(code[1].is_id, (std::vector<bool>{true, true}));
      list[i].operands[1] = scaled;
      module.insertBefore({0, static_cast<int>(b), static_cast<int>(i)}, std::move(code));
      inserted = true;
      break;
    }
  }
  ASSERT_TRUE(inserted);
  words = ir::emitModule(module);
  valid = validateSpirv(words, "with uniform");
  EXPECT_TRUE(valid.ok()) << (valid.ok() ? "" : valid.error().message);
  ir::DefUse final_uses(module);
  std::vector<ir::LooseUniform> loose = ir::looseUniforms(module, final_uses);
  ASSERT_EQ(loose.size(), 1u);
  EXPECT_EQ(loose[0].name, "uAverageScale");
  EXPECT_EQ(loose[0].location, 7u);
}

TEST(ShaderIr, ExtInstOperandsAreClassified) {
  SmallShader shader = smallShader();
  ir::Id import = shader.module.ext_inst_imports[0].result_id;
  ir::Id float_type = shader.module.typeFloat();
  ir::Instruction call = ir::makeInstruction(shader.module, spv::OpExtInst, float_type,
                                             shader.module.allocateId(), {import, 4 /* FAbs */, 12});
  EXPECT_EQ(call.is_id, (std::vector<bool>{true, false, true}));
}

TEST(ShaderIr, MalformedWordsGiveErrorsNotCrashes) {
  SmallShader shader = smallShader();
  EXPECT_FALSE(ir::parseModule(std::vector<uint32_t>{}).ok());
  EXPECT_FALSE(ir::parseModule(std::vector<uint32_t>{1, 2, 3, 4, 5}).ok());
  // Truncations at every length must fail cleanly (or parse a shorter valid prefix).
  for (size_t length = 5; length < shader.words.size(); length += 7) {
    std::vector<uint32_t> prefix(shader.words.begin(), shader.words.begin() + static_cast<std::ptrdiff_t>(length));
    auto module = ir::parseModule(prefix);
    if (module.ok()) {
      EXPECT_EQ(ir::emitModule(*module), prefix);
    }
  }
  // The second instruction's word count set to zero.
  std::vector<uint32_t> broken = shader.words;
  size_t second = 5 + (broken[5] >> 16);
  broken[second] &= 0xffffu;
  auto module = ir::parseModule(broken);
  EXPECT_FALSE(module.ok());
  if (!module.ok()) {
    EXPECT_NE(module.error().message.find("word"), std::string::npos) << module.error().message;
  }
}

// Corrupted modules (deterministic word flips of a real one) never crash the parser or any
// analysis: the parser either rejects them or hands over a module every query survives.
TEST(ShaderIr, CorruptedModulesNeverCrashTheAnalyses) {
  std::vector<uint32_t> original = compileOrDie(readShader("noise_phong.frag"), Stage::kFragment, "noise_phong.frag");
  ASSERT_FALSE(original.empty());
  uint64_t state = 0x9e3779b97f4a7c15ull;  // fixed seed: the same corruptions every run
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<uint32_t>(state >> 33);
  };
  int parsed = 0, rejected = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<uint32_t> words = original;
    int flips = 1 + static_cast<int>(next() % 3);
    for (int f = 0; f < flips; ++f) {
      size_t at = 5 + next() % (words.size() - 5);
      // Small values hit ids, opcodes and counts; random ones anything.
      words[at] = (next() % 2) ? next() % 64 : next();
    }
    auto module = ir::parseModule(words);
    if (!module.ok()) {
      ++rejected;
      continue;
    }
    ++parsed;
    ir::DefUse uses(*module);
    ir::interfaceVariables(*module, uses);
    ir::uniformBlocks(*module, uses);
    ir::looseUniforms(*module, uses);
    ir::samplers(*module, uses);
    for (const ir::Instruction& instruction : module->types_values) {
      ir::typeInfo(uses, instruction.result_id);
      ir::constantAsFloats(uses, instruction.result_id);
    }
    for (const ir::Function& function : module->functions) {
      ir::buildCfg(function);
      for (const ir::Block& block : function.blocks)
        for (const ir::Instruction& instruction : block.instructions)
          if (instruction.hasResult() && next() % 64 == 0) ir::backwardSlice(*module, uses, instruction.result_id);
    }
    ir::SliceSummaries summaries(*module, uses, [](const ir::Instruction&) { return true; });
    for (const ir::Function& function : module->functions)
      for (const ir::Block& block : function.blocks)
        for (const ir::Instruction& instruction : block.instructions)
          if (instruction.hasResult()) summaries.of(instruction.result_id);
    EXPECT_TRUE(ir::parseModule(ir::emitModule(*module)).ok()) << "trial " << trial;
  }
  EXPECT_GT(parsed, 0);
  EXPECT_GT(rejected, 0);
  std::printf("[ corrupted ] %d parsed, %d rejected\n", parsed, rejected);
}

}  // namespace
}  // namespace duolod::shader
