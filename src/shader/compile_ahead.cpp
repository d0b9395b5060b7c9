// Compiling coming programs on a second GL context (compile_ahead.hpp).
#include "shader/compile_ahead.hpp"

#include <algorithm>

#include "shader/instrument.hpp"
#include "shader/ir.hpp"
#include "shader/scoring.hpp"
#include "shader/search.hpp"

namespace duolod::shader {

CompileAhead::CompileAhead(core::Asset asset, render::Sample sample, int resolution,
                           render::ContextOptions context, int workers)
    : sample_(sample), resolution_(resolution) {
  start(std::move(asset), context, workers);
}

CompileAhead::CompileAhead(core::Asset asset, FullProfile full, render::ContextOptions context,
                           int workers)
    : resolution_(full.resolution), full_(std::move(full)) {
  if (!full_->samples.empty()) sample_ = full_->samples.front();
  start(std::move(asset), context, workers);
}

void CompileAhead::start(core::Asset asset, render::ContextOptions context, int workers) {
  // The workers share one copy of the asset until each has uploaded it to its own context.
  auto shared = std::make_shared<const core::Asset>(std::move(asset));
  // Taking a program never allocates on a worker (run() keeps what may throw inside its try).
  in_progress_.reserve(size_t(std::max(1, workers)));
  for (int i = 0; i < std::max(1, workers); ++i)
    workers_.emplace_back([this, shared, context]() mutable { run(std::move(shared), context); });
}

int CompileAhead::defaultWorkers() {
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

bool CompileAhead::inProgress(uint64_t hash) const {
  return std::find(in_progress_.begin(), in_progress_.end(), hash) != in_progress_.end();
}

CompileAhead::~CompileAhead() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    queue_.clear();
  }
  changed_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void CompileAhead::enqueue(std::span<const std::shared_ptr<const ShaderProgram>> programs) {
  {
    std::lock_guard lock(mutex_);
    // Forms nobody took belong to programs whose scores were already known: drop them.
    done_.clear();
    profiles_.clear();
    for (const std::shared_ptr<const ShaderProgram>& program : programs) {
      uint64_t hash = programHash(*program);
      bool known = inProgress(hash);
      for (const auto& queued : queue_) known = known || queued.first == hash;
      if (!known) queue_.emplace_back(hash, program);
    }
  }
  changed_.notify_all();
}

std::optional<CompileAhead::Profiled> CompileAhead::takeProfile(uint64_t program_hash) {
  std::lock_guard lock(mutex_);
  auto node = profiles_.extract(program_hash);
  if (node.empty()) return std::nullopt;
  return std::move(node.mapped());
}

std::optional<core::Result<Variant>> CompileAhead::take(uint64_t program_hash) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return !inProgress(program_hash); });
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

void CompileAhead::run(std::shared_ptr<const core::Asset> asset, render::ContextOptions context) {
  // The worker's own context and GL copy of the asset. If either fails the worker only makes
  // evaluation forms (the scorer then compiles cold, as without a worker).
  std::unique_ptr<render::Renderer> renderer;
  render::Renderer::AssetId asset_id = -1;
  try {
    if (auto created = render::Renderer::create(context); created) {
      renderer = std::move(*created);
      if (auto uploaded = renderer->uploadAsset(*asset); uploaded) asset_id = *uploaded;
      if (full_ && asset_id >= 0) {  // the scorer's upload: the drawn mesh over the asset
        auto drawn = renderer->uploadMesh(asset_id, full_->drawn);
        // The asset's own geometry is not drawn here: released (the drawn mesh keeps its
        // textures and bounding sphere), so that a worker holds one mesh, not two.
        renderer->releaseAsset(asset_id);
        asset_id = drawn ? *drawn : -1;
      }
    }
  } catch (...) {  // (out of memory) as if the context had failed
    asset_id = -1;
  }
  asset.reset();
  for (;;) {
    std::shared_ptr<const ShaderProgram> program;
    uint64_t hash = 0;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) break;
      std::tie(hash, program) = queue_.front();
      queue_.pop_front();
      in_progress_.push_back(hash);
      ++counters_.started;
    }
    // An exception must not leave the thread (std::terminate: a worker that ran out of memory
    // aborted the process). The worker then stops and hands over nothing for this program: the
    // scorer makes it itself, as it does a program no worker started.
    bool handed_over = false, drawn = false;
    std::optional<Profiled> profiled;
    try {
      core::Result<Variant> variant = evaluationVariant(*program);
      if (variant && renderer && asset_id >= 0) {
        auto vertex = ir::parseModule(variant->spirv.vertex);
        auto fragment = ir::parseModule(variant->spirv.fragment);
        // The scorer's own profile draw (profileBlockCounts), on one sample: what it draws is
        // what gets compiled. Its result is not needed.
        if (vertex && fragment && full_ && variant->parameter_block.empty()) {
          // The scorer's own call (ConfigurationScorer::scorer's predicted cost).
          render::ImageBatch8 images;
          auto profile = profileBlockCounts(*renderer, asset_id, *vertex, *fragment, full_->samples,
                                            resolution_, variant->uniforms,
                                            full_->keep_images ? &images : nullptr);
          drawn = profile.ok();
          if (drawn) {
            profiled.emplace();
            profiled->profile = std::move(*profile);
            if (full_->keep_images) profiled->images = std::move(images);
          }
        } else if (vertex && fragment) {
          drawn = profileBlockCounts(*renderer, asset_id, *vertex, *fragment, {&sample_, 1},
                                     resolution_, variant->uniforms)
                      .ok();
        }
      }
      std::lock_guard lock(mutex_);
      if (profiled) profiles_.insert_or_assign(hash, std::move(*profiled));
      done_.insert_or_assign(hash, std::move(variant));
      handed_over = true;
    } catch (...) {
    }
    {
      std::lock_guard lock(mutex_);
      if (handed_over && drawn) ++counters_.compiled;
      std::erase(in_progress_, hash);
    }
    changed_.notify_all();
    if (!handed_over) return;
  }
}

}  // namespace duolod::shader
