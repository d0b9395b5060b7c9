// Clean-up of evaluation copies with SPIRV-Tools' public optimizer (the internal IR is not
// installed, so only the Create*Pass() factories are used). The readable output is emitted from the
// unoptimised module; this copy is what gets rendered and timed.
#include <mutex>
#include <optional>
#include <spirv-tools/optimizer.hpp>
#include <unordered_map>

#include "duolod/shader.hpp"

namespace duolod::shader {
namespace {

// Successful optimisations by input, shared by every thread of the process: the optimizer is a
// pure function of the words and the level, and a GP search optimises the same stage again and
// again (a rule changes one stage, so the other is its parent's; configurations meet the same
// variants; generate re-makes its candidates' evaluation forms after the searches). Failures are
// not kept (their message names the caller's `what`). Bounded: cleared when it passes kMemoWords,
// and kept only while an OptimizationMemoScope lives (a library embedded in a long-running host
// gets its memory back after each generateLod / runShaderLod).
class OptimizationMemo {
 public:
  static OptimizationMemo& instance() {
    static OptimizationMemo memo;
    return memo;
  }
  void open() {
    std::lock_guard lock(mutex_);
    ++scopes_;
  }
  void close() {
    std::lock_guard lock(mutex_);
    if (--scopes_ == 0) {
      entries_ = {};
      stored_words_ = 0;
    }
  }
  std::optional<std::vector<uint32_t>> find(const std::vector<uint32_t>& words,
                                            OptimizationLevel level) {
    const uint64_t key = keyOf(words, level);
    std::lock_guard lock(mutex_);
    if (scopes_ == 0) return std::nullopt;
    auto [first, last] = entries_.equal_range(key);
    for (auto entry = first; entry != last; ++entry)
      if (entry->second.level == level && entry->second.input == words) return entry->second.output;
    return std::nullopt;
  }
  void store(const std::vector<uint32_t>& words, OptimizationLevel level,
             const std::vector<uint32_t>& optimized) {
    const uint64_t key = keyOf(words, level);
    std::lock_guard lock(mutex_);
    if (scopes_ == 0) return;
    if (stored_words_ + words.size() + optimized.size() > kMemoWords) {
      entries_.clear();
      stored_words_ = 0;
    }
    auto [first, last] = entries_.equal_range(key);
    for (auto entry = first; entry != last; ++entry)
      if (entry->second.level == level && entry->second.input == words) return;
    entries_.emplace(key, Entry{level, words, optimized});
    stored_words_ += words.size() + optimized.size();
  }

 private:
  static constexpr size_t kMemoWords = size_t(16) << 20;  // 64 MB of input and output words
  struct Entry {
    OptimizationLevel level;
    std::vector<uint32_t> input, output;
  };
  static uint64_t keyOf(const std::vector<uint32_t>& words, OptimizationLevel level) {
    return core::hashBytes(words.data(), words.size() * sizeof(uint32_t)) ^
           (static_cast<uint64_t>(level) + 1) * 0x9e3779b97f4a7c15ull;
  }
  std::mutex mutex_;
  std::unordered_multimap<uint64_t, Entry> entries_;
  size_t stored_words_ = 0;
  int scopes_ = 0;  // OptimizationMemoScope objects alive
};

}  // namespace

OptimizationMemoScope::OptimizationMemoScope() {
  OptimizationMemo::instance().open();
}
OptimizationMemoScope::~OptimizationMemoScope() {
  OptimizationMemo::instance().close();
}

core::Result<std::vector<uint32_t>> optimizeForEvaluation(const std::vector<uint32_t>& words,
                                                          const std::string& what,
                                                          OptimizationLevel level) {
  // Validated before and after when it was made.
  if (auto known = OptimizationMemo::instance().find(words, level)) return std::move(*known);
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
  OptimizationMemo::instance().store(words, level, optimized);
  return optimized;
}

}  // namespace duolod::shader
