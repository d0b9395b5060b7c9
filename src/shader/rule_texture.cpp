// Texture rules (Olano, Kuehne & Simmons 2003, "Automatic shader level of detail"):
//   kTextureAverage  a texture sample → the texture's average colour, a constant vec4;
//   kTextureMip      a texture sample → the same sample `choice` mip levels coarser, Olano's
//                    texture collapse in its cheap form: a LOD bias (implicit-LOD samples) or a
//                    larger explicit LOD.
// The average is baked as a constant rather than a CPU-set uniform: a shader LOD is made for one
// asset (the averages come from its images, RuleContext::texture_averages), and a constant lets
// SPIRV-Tools fold away everything computed from the sample, which is where Olano's saving is
// (the cost model then sees it). A material swap regenerates the levels anyway.
#include <array>
#include <optional>

#include "shader/rules_internal.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {
namespace {

constexpr uint32_t kMipChoices[] = {1, 2, 3};  // 2×, 4×, 8× coarser per axis

struct SampleShape {
  size_t fixed_operands = 2;  // sampled image, coordinate (and dref) before the operand mask
  bool implicit_lod = true;
  bool depth_compare = false;
};

std::optional<SampleShape> sampleShape(spv::Op opcode) {
  switch (opcode) {
    case spv::OpImageSampleImplicitLod: case spv::OpImageSampleProjImplicitLod:
      return SampleShape{2, true, false};
    case spv::OpImageSampleExplicitLod: case spv::OpImageSampleProjExplicitLod:
      return SampleShape{2, false, false};
    case spv::OpImageSampleDrefImplicitLod: case spv::OpImageSampleProjDrefImplicitLod:
      return SampleShape{3, true, true};
    case spv::OpImageSampleDrefExplicitLod: case spv::OpImageSampleProjDrefExplicitLod:
      return SampleShape{3, false, true};
    default:
      return std::nullopt;
  }
}

// The sampler variable a sample reads (through OpLoad, and OpSampledImage for separate images),
// or kNoId when it comes from somewhere the rule cannot follow (a function parameter...).
ir::Id samplerVariable(const ir::DefUse& uses, ir::Id sampled_image) {
  const ir::Instruction* definition = uses.def(sampled_image);
  if (definition && definition->opcode == spv::OpSampledImage)
    definition = uses.def(definition->operands[0]);
  if (!definition || definition->opcode != spv::OpLoad) return ir::kNoId;
  const ir::Instruction* variable = uses.def(definition->operands[0]);
  if (!variable || variable->opcode != spv::OpVariable ||
      variable->operands[0] != spv::StorageClassUniformConstant)
    return ir::kNoId;
  return variable->result_id;
}

struct TextureSample {
  const ir::Instruction* instruction = nullptr;
  ir::InstructionPosition position;
  SampleShape shape;
  ir::Id sampler = ir::kNoId;
  std::optional<uint32_t> binding;
};

std::optional<TextureSample> findSample(const ir::Module& module, const ir::DefUse& uses,
                                        ir::Id result_id) {
  std::optional<ir::InstructionPosition> position = module.findPosition(result_id);
  if (!position) return std::nullopt;
  const ir::Instruction& instruction = module.functions[static_cast<size_t>(position->function)]
                                           .blocks[static_cast<size_t>(position->block)]
                                           .instructions[static_cast<size_t>(position->index)];
  std::optional<SampleShape> shape = sampleShape(instruction.opcode);
  if (!shape) return std::nullopt;
  TextureSample sample;
  sample.instruction = &instruction;
  sample.position = *position;
  sample.shape = *shape;
  sample.sampler = samplerVariable(uses, instruction.operands[0]);
  if (sample.sampler != ir::kNoId)
    sample.binding = uses.decoration(sample.sampler, spv::DecorationBinding);
  return sample;
}

// Every sample instruction of both stages, in module order.
template <class Visit>
void forEachSample(const ShaderProgram& program, Visit visit) {
  for (Stage stage : {Stage::kVertex, Stage::kFragment}) {
    const ir::Module& module = stageModule(program, stage);
    ir::DefUse uses(module);
    // A vertex-stage sample the position depends on (a displacement map) is left alone.
    const std::unordered_set<ir::Id> position = stage == Stage::kVertex
                                                    ? vertexPositionSources(module, uses)
                                                    : std::unordered_set<ir::Id>{};
    for (const ir::Function& function : module.functions)
      for (const ir::Block& block : function.blocks)
        for (const ir::Instruction& instruction : block.instructions)
          if (sampleShape(instruction.opcode) && !position.count(instruction.result_id))
            if (std::optional<TextureSample> sample = findSample(module, uses, instruction.result_id))
              visit(stage, module, uses, *sample);
  }
}

std::string samplerLabel(const ir::Module& module, const TextureSample& sample) {
  return sample.sampler != ir::kNoId ? valueName(module, sample.sampler) : "a texture";
}

// The average colour to substitute, when the rule applies: a colour (not depth) sample of a float
// vector type, from a sampler whose binding has an average.
std::optional<std::array<float, 4>> averageFor(const ir::DefUse& uses,
                                               const TextureSample& sample,
                                               const RuleContext& context) {
  if (sample.shape.depth_compare || !sample.binding) return std::nullopt;
  if (!ir::isFloatScalarOrVector(uses, sample.instruction->type_id)) return std::nullopt;
  auto found = context.texture_averages.find(*sample.binding);
  if (found == context.texture_averages.end()) return std::nullopt;
  return found->second;
}

// The image-operand mask word index and value (0 when absent), and whether the LOD can be coarsened
// (implicit: always, by a bias; explicit: when it has a Lod operand, not gradients).
bool canCoarsen(const TextureSample& sample) {
  const ir::Instruction& instruction = *sample.instruction;
  size_t mask_index = sample.shape.fixed_operands;
  uint32_t mask = mask_index < instruction.operands.size() ? instruction.operands[mask_index] : 0;
  if (sample.shape.implicit_lod) return true;
  return (mask & spv::ImageOperandsLodMask) != 0;
}

}  // namespace

std::vector<RuleSite> findTextureAverageSites(const ShaderProgram& program,
                                              const RuleContext& context) {
  std::vector<RuleSite> sites;
  forEachSample(program, [&](Stage stage, const ir::Module& module, const ir::DefUse& uses,
                             const TextureSample& sample) {
    if (!averageFor(uses, sample, context)) return;
    sites.push_back({.kind = RuleKind::kTextureAverage,
                     .stage = stage,
                     .target = sample.instruction->result_id,
                     .choice = 0,
                     .description = stageName(stage) + ": " + samplerLabel(module, sample) +
                                    " sample → its average colour"});
  });
  return sites;
}

core::Result<ShaderProgram> applyTextureAverage(const ShaderProgram& program,
                                                const RuleSite& site, const RuleContext& context) {
  const ir::Module& original = stageModule(program, site.stage);
  ir::DefUse uses(original);
  std::optional<TextureSample> sample = findSample(original, uses, site.target);
  if (!sample) return siteError(site, "the texture sample is no longer in the module");
  std::optional<std::array<float, 4>> average = averageFor(uses, *sample, context);
  if (!average) return siteError(site, "no average colour for this texture's binding");
  uint32_t components = ir::componentCount(uses, sample->instruction->type_id);
  if (components == 0 || components > 4) return siteError(site, "unexpected sample type");

  ShaderProgram rewritten = program;
  ir::Module& module = stageModule(rewritten, site.stage);
  ir::Id constant = module.constantFloatVector(std::span(average->data(), components));
  module.replaceAllUses(site.target, constant);
  module.removeInstructions({site.target});
  removeDeadCode(module);
  return rewritten;
}

std::vector<RuleSite> findTextureMipSites(const ShaderProgram& program, const RuleContext&) {
  std::vector<RuleSite> sites;
  forEachSample(program, [&](Stage stage, const ir::Module& module, const ir::DefUse&,
                             const TextureSample& sample) {
    if (!canCoarsen(sample)) return;
    for (uint32_t levels : kMipChoices)
      sites.push_back({.kind = RuleKind::kTextureMip,
                       .stage = stage,
                       .target = sample.instruction->result_id,
                       .choice = levels,
                       .description = stageName(stage) + ": " + samplerLabel(module, sample) +
                                      " sample → " + std::to_string(levels) +
                                      " mip level(s) coarser"});
  });
  return sites;
}

core::Result<ShaderProgram> applyTextureMip(const ShaderProgram& program, const RuleSite& site,
                                            const RuleContext&) {
  if (site.choice == 0 || site.choice > 16)
    return siteError(site, "levels coarser must be 1..16, not " + std::to_string(site.choice));
  const ir::Module& original = stageModule(program, site.stage);
  ir::DefUse uses(original);
  std::optional<TextureSample> found = findSample(original, uses, site.target);
  if (!found) return siteError(site, "the texture sample is no longer in the module");
  if (!canCoarsen(*found)) return siteError(site, "the sample uses explicit gradients");
  const TextureSample sample = *found;

  ShaderProgram rewritten = program;
  ir::Module& module = stageModule(rewritten, site.stage);
  ir::Instruction instruction = *sample.instruction;  // a copy: rebuilt below
  ir::Id float_type = module.typeFloat();
  ir::Id levels = module.constantFloat(static_cast<float>(site.choice));
  size_t mask_index = sample.shape.fixed_operands;
  std::vector<uint32_t> operands = instruction.operands;
  if (mask_index >= operands.size()) operands.push_back(0);
  uint32_t mask = operands[mask_index];
  // Bias (implicit LOD) or Lod (explicit) is the first operand after the mask: both are the
  // lowest bits of the mask and operands follow in bit order (SPIR-V §3.14).
  uint32_t lod_bit = sample.shape.implicit_lod ? spv::ImageOperandsBiasMask
                                               : spv::ImageOperandsLodMask;
  size_t lod_index = mask_index + 1;
  if (!sample.shape.implicit_lod && (mask & spv::ImageOperandsBiasMask)) ++lod_index;
  std::vector<ir::Instruction> inserted;
  if (mask & lod_bit) {
    ir::Id sum = module.allocateId();
    inserted.push_back(ir::makeInstruction(module, spv::OpFAdd, float_type, sum,
                                           {operands[lod_index], levels}));
    operands[lod_index] = sum;
  } else {
    operands[mask_index] = mask | lod_bit;
    operands.insert(operands.begin() + static_cast<std::ptrdiff_t>(lod_index), levels);
  }
  ir::Instruction replacement = ir::makeInstruction(module, instruction.opcode, instruction.type_id,
                                                    instruction.result_id, std::move(operands));
  ir::Block& block = module.functions[static_cast<size_t>(sample.position.function)]
                         .blocks[static_cast<size_t>(sample.position.block)];
  block.instructions[static_cast<size_t>(sample.position.index)] = std::move(replacement);
  if (!inserted.empty()) module.insertBefore(sample.position, std::move(inserted));
  return rewritten;
}

}  // namespace duolod::shader
