// SortByError's renders made ahead on their own thread: see sort_prefetch.hpp for why.
#include "lod/sort_prefetch.hpp"

#include <exception>
#include <new>

namespace duolod::lod {

SortByErrorPrefetch::SortByErrorPrefetch(const core::Asset& asset,
                                         std::vector<shader::Variant> shaders,
                                         std::vector<Level> levels, std::vector<Job> jobs,
                                         render::ContextOptions context)
    : asset_(asset),
      shaders_(std::move(shaders)),
      levels_(std::move(levels)),
      jobs_(std::move(jobs)),
      context_(context) {
  for (const Job& job : jobs_) states_.emplace(std::make_pair(job.level, job.shader), State::kQueued);
  thread_ = std::thread([this] { run(); });
}

SortByErrorPrefetch::~SortByErrorPrefetch() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

std::optional<SortByErrorPrefetch::Rendered> SortByErrorPrefetch::take(int level, int shader) {
  std::unique_lock lock(mutex_);
  const auto key = std::make_pair(level, shader);
  auto state = states_.find(key);
  if (state == states_.end()) return std::nullopt;
  if (state->second == State::kQueued) {
    state->second = State::kTaken;
    return std::nullopt;
  }
  changed_.wait(lock, [&] { return state->second != State::kRunning || stopped_; });
  if (state->second != State::kDone) return std::nullopt;  // stopped mid-render, or taken
  state->second = State::kTaken;
  auto result = results_.find(key);
  Rendered rendered = std::move(result->second);
  results_.erase(result);
  return rendered;
}

int SortByErrorPrefetch::rendered() const {
  std::lock_guard lock(mutex_);
  return rendered_;
}

std::string SortByErrorPrefetch::failure() const {
  std::lock_guard lock(mutex_);
  return failure_;
}

// An exception must not leave the thread (std::terminate: a render that ran out of memory
// aborted the process). Like any failure here it stops this thread, and the caller renders the
// rest itself.
void SortByErrorPrefetch::run() {
  try {
    renderAhead();
  } catch (const std::bad_alloc&) {
    stop("SortByError prefetch: out of memory");
  } catch (const std::exception& e) {
    stop(std::string("SortByError prefetch: ") + e.what());
  } catch (...) {
    stop("SortByError prefetch: an unknown exception");
  }
}

void SortByErrorPrefetch::stop(std::string failure) {
  {
    std::lock_guard lock(mutex_);
    failure_ = std::move(failure);
    stopped_ = true;
  }
  changed_.notify_all();
}

void SortByErrorPrefetch::renderAhead() {
  auto renderer = render::Renderer::create(context_);
  if (!renderer) return stop("SortByError prefetch context: " + renderer.error().message);
  // M_0 uploaded as the caller uploads it (uploadMesh over the asset's materials), so both draw
  // the same vertex buffer in the same order.
  auto materials = (*renderer)->uploadAsset(asset_);
  if (!materials) return stop("SortByError prefetch: " + materials.error().message);
  auto original = (*renderer)->uploadMesh(*materials, asset_.mesh);
  if (!original) return stop("SortByError prefetch: " + original.error().message);
  shader::EvaluationCache programs(**renderer);  // after the renderer: it must not outlive it

  for (const Job& job : jobs_) {
    const auto key = std::make_pair(job.level, job.shader);
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
      State& state = states_[key];
      if (state != State::kQueued) continue;  // the caller took it first
      state = State::kRunning;
    }
    const shader::Variant& variant = shaders_[job.shader];
    auto program = programs.program(variant);
    if (!program) return stop("SortByError prefetch: " + program.error().message);
    if (auto set = (*renderer)->setProgramUniforms(*program, variant.uniforms); !set)
      return stop("SortByError prefetch: " + set.error().message);
    const Level& level = levels_[job.level];
    render::RenderStats stats;
    auto images = (*renderer)->render(*original, *program, level.samples,
                                      {.resolution = level.resolution, .count_work = true}, &stats);
    if (!images) return stop("SortByError prefetch: " + images.error().message);
    {
      std::lock_guard lock(mutex_);
      results_.emplace(key, Rendered{std::move(*images), stats.work});
      states_[key] = State::kDone;
      ++rendered_;
    }
    changed_.notify_all();
  }
  std::lock_guard lock(mutex_);
  stopped_ = true;
  changed_.notify_all();
}

}  // namespace duolod::lod
