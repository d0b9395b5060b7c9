// Compiling the programs a search is about to score on a second GL context, in a worker thread.
//
// Why: llvmpipe compiles a program (SPIR-V → NIR → LLVM → machine code) on the thread that draws
// with it, and the GP's scoring is mostly that compile: perf of a Dragon generation run had the
// shader stage on one core (LLVM 39%, SPIRV-Tools and our IR 50%) while the other core idled.
// The worker makes each coming program's evaluation form (SPIRV-Tools clean-up, the pure CPU part)
// and draws its instrumented profile copy once with the same GL state on its own context, so
// Mesa's on-disk shader cache already holds the compiled code when the scorer's own context
// compiles the same program. Results never depend on the worker: it only warms caches and hands
// over evaluation forms it made exactly as the scorer would (evaluationVariant).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <unordered_map>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"
#include "shader/evaluate.hpp"
#include "shader/instrument.hpp"
#include "shader/rules.hpp"

namespace duolod::shader {

class CompileAhead {
 public:
  // `asset` supplies the mesh, materials and textures drawn with (the same vertex layout and
  // sampler state as the scorer's draws, so the same compiled variants); `sample` and
  // `resolution` are one of the scorer's profile draws. `workers` threads (each with its own
  // context) take the queue in order: one worker was the shader stage's critical path (it has
  // about 3× the scorer's CPU per program), so a second one lets both cores compile.
  CompileAhead(core::Asset asset, render::Sample sample, int resolution,
               render::ContextOptions context, int workers = defaultWorkers());
  // The scorer's whole cost profile made on the workers too: `drawn` is uploaded over `asset`'s
  // materials exactly as the scorer's own draw (Renderer::uploadMesh: same vertex order, the
  // asset's bounding sphere), and each program without a parameter block is profiled on
  // `samples` at `resolution` with its uniforms, as ConfigurationScorer's predicted cost does
  // (its images kept when `keep_images`). A context renders what another renders, bit for bit
  // (SortByErrorPrefetch relies on it too), so the scorer takes the profile instead of
  // compiling and drawing the instrumented copy a second time on its own thread.
  struct FullProfile {
    core::Mesh drawn;
    std::vector<render::Sample> samples;
    int resolution = 0;
    bool keep_images = false;
  };
  CompileAhead(core::Asset asset, FullProfile full, render::ContextOptions context,
               int workers = defaultWorkers());
  // One per hardware thread, at least one.
  static int defaultWorkers();
  ~CompileAhead();
  CompileAhead(const CompileAhead&) = delete;
  CompileAhead& operator=(const CompileAhead&) = delete;

  // Queues programs (in the order they will be scored) after any still queued.
  void enqueue(std::span<const std::shared_ptr<const ShaderProgram>> programs);
  // The evaluation form of the program with this hash if the worker made it (waiting if it is
  // making it now); nothing if it has not started on it (it is then dropped from the queue).
  std::optional<core::Result<Variant>> take(uint64_t program_hash);
  // After take() handed a form over: that program's full profile (FullProfile mode), if made.
  struct Profiled {
    BlockProfile profile;
    std::optional<render::ImageBatch8> images;
  };
  std::optional<Profiled> takeProfile(uint64_t program_hash);

  struct Counters {
    int started = 0;   // programs the workers took off the queue
    int compiled = 0;  // programs the worker drew
    int taken = 0;     // evaluation forms handed to the scorer
  };
  Counters counters() const;

 private:
  void start(core::Asset asset, render::ContextOptions context, int workers);
  void run(std::shared_ptr<const core::Asset> asset, render::ContextOptions context);
  bool inProgress(uint64_t hash) const;  // under mutex_

  render::Sample sample_;
  int resolution_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::pair<uint64_t, std::shared_ptr<const ShaderProgram>>> queue_;
  std::unordered_map<uint64_t, core::Result<Variant>> done_;
  std::optional<FullProfile> full_;
  std::unordered_map<uint64_t, Profiled> profiles_;  // FullProfile mode, by program
  std::vector<uint64_t> in_progress_;  // the programs the workers are making now
  bool stop_ = false;
  Counters counters_;
  std::vector<std::thread> workers_;
};

}  // namespace duolod::shader
