// The instrumented render behind "moving to parameter" (see value_average.hpp).
#include "shader/value_average.hpp"

#include <glslang/SPIRV/GLSL.std.450.h>

#include <cmath>
#include <set>

#include "duolod/shader.hpp"
#include "shader/value_rewrite.hpp"

namespace duolod::shader {

using ir::Id;
using ir::Instruction;

core::Status bakeParameters(ir::Module& module, const std::vector<ParameterValue>& parameters) {
  for (const ParameterValue& parameter : parameters) {
    ir::DefUse uses(module);
    Id variable = ir::kNoId;
    for (const ir::LooseUniform& uniform : ir::looseUniforms(module, uses))
      if (uniform.location == parameter.location) variable = uniform.variable;
    if (variable == ir::kNoId) continue;  // the parameter belongs to the other stage
    Id constant = module.constantFloatVector(
        std::span<const float>(parameter.value.data(), static_cast<size_t>(parameter.components)));
    std::set<Id> loads;
    for (const ir::InstructionRef& user : uses.users(variable)) {
      spv::Op op = user.instruction->opcode;
      if (op == spv::OpLoad) {
        loads.insert(user.instruction->result_id);
      } else if (op != spv::OpName && op != spv::OpDecorate && op != spv::OpEntryPoint) {
        return core::Error{"parameter '" + parameter.name + "' is read other than by a load"};
      }
    }
    for (Id load : loads) module.replaceAllUses(load, constant);
    module.removeInstructions(loads);
  }
  return core::okStatus();
}

core::Result<ir::Module> instrumentFragmentValue(const ShaderProgram& program, Id value,
                                                 uint32_t component) {
  ir::Module module = program.fragment;
  if (auto baked = bakeParameters(module, program.parameters); !baked) return baked.error();

  ir::DefUse uses(module);
  int entry = entryFunctionIndex(module, spv::ExecutionModelFragment);
  const ir::InstructionRef* ref = uses.defRef(value);
  if (entry < 0 || !ref || ref->function != entry || ref->block < 0)
    return core::Error{"%" + std::to_string(value) + " is not a value of the fragment entry point"};
  Id value_type = ref->instruction->type_id;
  if (!value_type || !ir::isFloatScalarOrVector(uses, value_type) ||
      ir::typeInfo(uses, value_type).width != 32)
    return core::Error{"%" + std::to_string(value) + " is not a 32-bit float scalar or vector"};
  uint32_t components = ir::componentCount(uses, value_type);
  if (component >= components)
    return core::Error{"component " + std::to_string(component) + " of a " +
                       std::to_string(components) + "-component value"};
  if (blocksInLoops(module.functions[entry]).count(module.functions[entry].blocks[ref->block].id()))
    return core::Error{"%" + std::to_string(value) + " is inside a loop (one value per iteration)"};
  bool is_phi = ref->instruction->opcode == spv::OpPhi;

  Id float_type = module.typeFloat();
  Id vec4_type = module.typeVector(float_type, 4);
  Id color_output = ir::kNoId;
  for (const ir::InterfaceVariable& variable : ir::interfaceVariables(module, uses))
    if (variable.storage == spv::StorageClassOutput && variable.location == 0u &&
        variable.value_type == vec4_type)
      color_output = variable.variable;
  if (color_output == ir::kNoId)
    return core::Error{"the fragment stage has no vec4 colour output at location 0"};

  // Every pointer into the colour output: its stores are the colour, which the value replaces.
  std::set<Id> output_pointers = {color_output};
  std::vector<Id> work = {color_output};
  while (!work.empty()) {
    Id pointer = work.back();
    work.pop_back();
    for (const ir::InstructionRef& user : uses.users(pointer))
      if ((user.instruction->opcode == spv::OpAccessChain ||
           user.instruction->opcode == spv::OpInBoundsAccessChain) &&
          user.instruction->operands[0] == pointer &&
          output_pointers.insert(user.instruction->result_id).second)
        work.push_back(user.instruction->result_id);
  }

  // After the value: squash, split into bytes, store with alpha 1.
  Id glsl = glslStd450Import(module);
  auto constant = [&](float x) { return module.constantFloat(x); };
  std::vector<Instruction> code;
  auto emit = [&](spv::Op op, Id type, std::vector<uint32_t> operands) {
    Id id = module.allocateId();
    code.push_back(ir::makeInstruction(module, op, type, id, std::move(operands)));
    return id;
  };
  auto extended = [&](GLSLstd450 function, std::vector<uint32_t> arguments) {
    std::vector<uint32_t> operands = {glsl, static_cast<uint32_t>(function)};
    operands.insert(operands.end(), arguments.begin(), arguments.end());
    return emit(spv::OpExtInst, float_type, operands);
  };
  Id x = components == 1 ? value : emit(spv::OpCompositeExtract, float_type, {value, component});
  Id magnitude = extended(GLSLstd450FAbs, {x});
  Id squashed =
      emit(spv::OpFDiv, float_type, {x, emit(spv::OpFAdd, float_type, {magnitude, constant(1)})});
  Id y = emit(spv::OpFAdd, float_type,
              {emit(spv::OpFMul, float_type, {squashed, constant(0.5f)}), constant(0.5f)});
  // Largest float below 1, so the top byte never overflows.
  y = extended(GLSLstd450FClamp, {y, constant(0), constant(std::nextafter(1.0f, 0.0f))});
  Id scaled = emit(spv::OpFMul, float_type, {y, constant(255)});
  Id top = extended(GLSLstd450Floor, {scaled});
  Id rest =
      emit(spv::OpFMul, float_type, {emit(spv::OpFSub, float_type, {scaled, top}), constant(255)});
  Id middle = extended(GLSLstd450Floor, {rest});
  Id low = emit(spv::OpFSub, float_type, {rest, middle});
  Id color = emit(spv::OpCompositeConstruct, vec4_type,
                  {emit(spv::OpFDiv, float_type, {top, constant(255)}),
                   emit(spv::OpFDiv, float_type, {middle, constant(255)}), low, constant(1)});
  code.push_back(
      ir::makeInstruction(module, spv::OpStore, ir::kNoId, ir::kNoId, {color_output, color}));

  module.removeInstructionsIf([&](const Instruction& instruction) {
    return instruction.opcode == spv::OpStore && output_pointers.count(instruction.operands[0]);
  });
  ir::InstructionPosition after = *module.findPosition(value);
  if (is_phi) {
    after = *insertionPointFor(module, value);
  } else {
    ++after.index;
  }
  module.insertBefore(after, std::move(code));
  // Pixels where the value is not computed (a branch not taken) stay uncovered: alpha 0.
  std::vector<float> zero = {0, 0, 0, 0};
  Id transparent = module.constantFloatVector(zero);
  ir::Block& entry_block = module.functions[entry].blocks[0];
  int first = 0;
  while (first < static_cast<int>(entry_block.instructions.size()) &&
         entry_block.instructions[first].opcode == spv::OpVariable)
    ++first;
  module.insertBefore({entry, 0, first},
                      {ir::makeInstruction(module, spv::OpStore, ir::kNoId, ir::kNoId,
                                           {color_output, transparent})});
  removeDeadCode(module);
  return module;
}

float decodeAveragedPixel(uint8_t red, uint8_t green, uint8_t blue) {
  double y = (red + (green + blue / 255.0) / 255.0) / 255.0;
  double s = 2 * y - 1;  // x / (1 + |x|)
  return static_cast<float>(s / (1 - std::abs(s)));
}

ValueAverager::ValueAverager(render::Renderer& renderer, render::Renderer::AssetId asset,
                             std::vector<render::Sample> samples, AverageOptions options)
    : renderer_(renderer), asset_(asset), samples_(std::move(samples)), options_(options) {}

std::function<core::Result<std::vector<float>>(const ShaderProgram&, Stage, ir::Id)>
ValueAverager::function() {
  return [this](const ShaderProgram& program, Stage stage, ir::Id value) {
    return average(program, stage, value);
  };
}

core::Result<std::vector<float>> ValueAverager::average(const ShaderProgram& program, Stage stage,
                                                        Id value) {
  if (stage != Stage::kFragment)
    return core::Error{"averaging is implemented for fragment values only"};
  ir::DefUse uses(program.fragment);
  const Instruction* definition = uses.def(value);
  if (!definition || !definition->type_id)
    return core::Error{"%" + std::to_string(value) + " is not a value of the fragment stage"};
  uint32_t components = ir::componentCount(uses, definition->type_id);
  std::vector<float> result;
  for (uint32_t component = 0; component < components; ++component) {
    core::Result<float> mean = averageComponent(program, value, component);
    if (!mean) return mean.error();
    result.push_back(*mean);
  }
  return result;
}

core::Result<float> ValueAverager::averageComponent(const ShaderProgram& program, Id value,
                                                    uint32_t component) {
  core::Result<ir::Module> instrumented = instrumentFragmentValue(program, value, component);
  if (!instrumented) return instrumented.error();
  render::SpirvBinary binary{ir::emitModule(program.vertex), ir::emitModule(*instrumented)};
  uint64_t key =
      ir::wordsHash(binary.fragment) ^ (ir::wordsHash(binary.vertex) * 0x9e3779b97f4a7c15ull);
  if (auto found = cache_.find(key); found != cache_.end()) {
    ++counters_.cache_hits;
    return found->second;
  }
  if (auto valid = validateSpirv(binary.fragment, "instrumented fragment stage"); !valid)
    return valid.error();
  core::Result<render::Renderer::ProgramId> compiled = renderer_.compileProgram(binary);
  if (!compiled) return core::Error{"instrumented program: " + compiled.error().message};
  render::RenderOptions options;
  options.resolution = options_.resolution;
  core::Result<render::ImageBatch8> images = renderer_.render(asset_, *compiled, samples_, options);
  renderer_.releaseProgram(*compiled);
  if (!images) return images.error();
  ++counters_.renders;
  double sum = 0;
  int64_t covered = 0;
  const std::vector<uint8_t>& pixels = images->pixels;
  for (size_t i = 0; i + 3 < pixels.size(); i += 4) {
    if (pixels[i + 3] < 128) continue;  // background, or the value is not computed there
    sum += decodeAveragedPixel(pixels[i], pixels[i + 1], pixels[i + 2]);
    ++covered;
  }
  if (covered == 0) return core::Error{"the value is computed at no pixel of the domain"};
  counters_.pixels += covered;
  float mean = static_cast<float>(sum / static_cast<double>(covered));
  cache_[key] = mean;
  return mean;
}

}  // namespace duolod::shader
