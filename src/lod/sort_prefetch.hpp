// SortByError's renders (Liang et al. §5, Algorithm 1 line 6: every shader candidate on the
// original mesh M_0 at d_i) made ahead, on a thread of their own with their own GL context, while
// the caller walks the levels (SortByError, then SearchPairs, level after level).
//
// Why: in the pair search the drawing thread is the bottleneck. llvmpipe runs vertex shading and
// triangle binning on the thread that draws, and M_0 is the largest mesh drawn there (100 views ×
// lights per render), so perf had that thread ~0.7 of a core and the rasterizer threads ~0.5: one
// core idle. A second drawing thread fills it. The images are the same as the caller's own (same
// driver, program, uniforms, mesh and samples), so the prefetch changes nothing but the time.
// Private to src/lod.
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"
#include "shader/evaluate.hpp"

namespace duolod::lod {

class SortByErrorPrefetch {
 public:
  struct Level {
    std::vector<render::Sample> samples;
    int resolution = 0;  // the level's footprint in pixels
  };
  struct Job {
    int level = 0, shader = 0;
  };
  struct Rendered {
    render::ImageBatch8 images;
    render::WorkCounts work;  // the cost model's invocation counts of the render
  };

  // Renders the jobs in order: shader `job.shader` of `shaders` (its program and CPU-set values,
  // as the caller draws it) on `asset`'s mesh, at level `job.level` of `levels`. The thread starts
  // at once; the destructor stops it after the render under way.
  SortByErrorPrefetch(const core::Asset& asset, std::vector<shader::Variant> shaders,
                      std::vector<Level> levels, std::vector<Job> jobs,
                      render::ContextOptions context);
  ~SortByErrorPrefetch();
  SortByErrorPrefetch(const SortByErrorPrefetch&) = delete;
  SortByErrorPrefetch& operator=(const SortByErrorPrefetch&) = delete;

  // The pair's render, when this thread has made it or is making it (then it waits). Nothing
  // when the caller should render it itself: not a job, not started yet (it is then taken off
  // this thread's list, so it is never rendered twice), or this thread failed.
  std::optional<Rendered> take(int level, int shader);

  int rendered() const;         // renders made by this thread so far
  std::string failure() const;  // why this thread stopped early, or empty

 private:
  enum class State { kQueued, kRunning, kDone, kTaken };
  void run();
  void renderAhead();
  void stop(std::string failure);  // this thread ends early, saying why

  const core::Asset& asset_;
  const std::vector<shader::Variant> shaders_;
  const std::vector<Level> levels_;
  const std::vector<Job> jobs_;
  const render::ContextOptions context_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::pair<int, int>, State> states_;
  std::map<std::pair<int, int>, Rendered> results_;
  std::string failure_;
  int rendered_ = 0;
  bool stopping_ = false, stopped_ = false;
  std::thread thread_;  // last: starts after every member above exists
};

}  // namespace duolod::lod
