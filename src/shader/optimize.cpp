// Clean-up of evaluation copies with SPIRV-Tools' public optimizer (the internal IR is not
// installed, so only the Create*Pass() factories are used). The readable output is emitted from the
// unoptimised module; this copy is what gets rendered and timed.
#include <spirv-tools/optimizer.hpp>

#include "duolod/shader.hpp"

namespace duolod::shader {

core::Result<std::vector<uint32_t>> optimizeForEvaluation(const std::vector<uint32_t>& words,
                                                          const std::string& what,
                                                          OptimizationLevel level) {
  if (auto valid = validateSpirv(words, what); !valid.ok()) return valid.error();
  spvtools::Optimizer optimizer(SPV_ENV_OPENGL_4_5);
  std::string messages;
  optimizer.SetMessageConsumer([&](spv_message_level_t severity, const char*, const spv_position_t&,
                                   const char* message) {
    if (severity <= SPV_MSG_ERROR) messages += std::string(message) + "\n";
  });
  if (level == OptimizationLevel::kPerformance) {
    optimizer.RegisterPerformancePasses();
  } else {
    optimizer.RegisterPass(spvtools::CreateDeadBranchElimPass())
        .RegisterPass(spvtools::CreateFoldSpecConstantOpAndCompositePass())
        .RegisterPass(spvtools::CreateUnifyConstantPass())
        .RegisterPass(spvtools::CreateAggressiveDCEPass())
        .RegisterPass(spvtools::CreateEliminateDeadConstantPass())
        .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass())
        .RegisterPass(spvtools::CreateCFGCleanupPass());
  }
  std::vector<uint32_t> optimized;
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);  // validated above and below, with our message
  if (!optimizer.Run(words.data(), words.size(), &optimized, options))
    return core::Error{what + ": SPIRV-Tools optimizer failed: " + messages};
  if (auto valid = validateSpirv(optimized, what + " (optimised)"); !valid.ok()) return valid.error();
  return optimized;
}

}  // namespace duolod::shader
