// Compiling coming programs on a second GL context (compile_ahead.hpp).
#include "shader/compile_ahead.hpp"

#include "shader/instrument.hpp"
#include "shader/ir.hpp"
#include "shader/scoring.hpp"
#include "shader/search.hpp"

namespace duolod::shader {

CompileAhead::CompileAhead(core::Asset asset, render::Sample sample, int resolution,
                           render::ContextOptions context)
    : sample_(sample), resolution_(resolution) {
  worker_ = std::thread([this, asset = std::move(asset), context]() mutable {
    run(std::move(asset), context);
  });
}

CompileAhead::~CompileAhead() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    queue_.clear();
  }
  changed_.notify_all();
  worker_.join();
}

void CompileAhead::enqueue(std::span<const std::shared_ptr<const ShaderProgram>> programs) {
  {
    std::lock_guard lock(mutex_);
    // Forms nobody took belong to programs whose scores were already known: drop them.
    done_.clear();
    for (const std::shared_ptr<const ShaderProgram>& program : programs) {
      uint64_t hash = programHash(*program);
      bool known = hash == in_progress_;
      for (const auto& queued : queue_) known = known || queued.first == hash;
      if (!known) queue_.emplace_back(hash, program);
    }
  }
  changed_.notify_all();
}

std::optional<core::Result<Variant>> CompileAhead::take(uint64_t program_hash) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return in_progress_ != program_hash; });
  if (auto found = done_.find(program_hash); found != done_.end()) {
    core::Result<Variant> variant = std::move(found->second);
    done_.erase(found);
    ++counters_.taken;
    return variant;
  }
  // Not started: the scorer compiles it itself now, so the worker must not spend time on it.
  for (auto queued = queue_.begin(); queued != queue_.end(); ++queued)
    if (queued->first == program_hash) {
      queue_.erase(queued);
      break;
    }
  return std::nullopt;
}

CompileAhead::Counters CompileAhead::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

void CompileAhead::run(core::Asset asset, render::ContextOptions context) {
  // The worker's own context and copy of the asset. If either fails the worker only makes
  // evaluation forms (the scorer then compiles cold, as without a worker).
  std::unique_ptr<render::Renderer> renderer;
  render::Renderer::AssetId asset_id = -1;
  if (auto created = render::Renderer::create(context); created) {
    renderer = std::move(*created);
    if (auto uploaded = renderer->uploadAsset(asset); uploaded) asset_id = *uploaded;
  }
  asset = core::Asset{};  // the GL copy is all the worker needs
  for (;;) {
    std::shared_ptr<const ShaderProgram> program;
    uint64_t hash = 0;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) break;
      std::tie(hash, program) = queue_.front();
      queue_.pop_front();
      in_progress_ = hash;
    }
    core::Result<Variant> variant = evaluationVariant(*program);
    bool drawn = false;
    if (variant && renderer && asset_id >= 0) {
      auto vertex = ir::parseModule(variant->spirv.vertex);
      auto fragment = ir::parseModule(variant->spirv.fragment);
      // The scorer's own profile draw (profileBlockCounts), on one sample: what it draws is
      // what gets compiled. Its result is not needed.
      if (vertex && fragment)
        drawn = profileBlockCounts(*renderer, asset_id, *vertex, *fragment, {&sample_, 1},
                                   resolution_, variant->uniforms)
                    .ok();
    }
    {
      std::lock_guard lock(mutex_);
      done_.insert_or_assign(hash, std::move(variant));
      if (drawn) ++counters_.compiled;
      in_progress_.reset();
    }
    changed_.notify_all();
  }
}

}  // namespace duolod::shader
