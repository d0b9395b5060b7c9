// Wall-clock draw cost of programs on one object over the view domain, for the cost of a pair
// (Liang et al. §5.3, Cost(f(M,S,d))) and for calibrating cost models. llvmpipe's GL_TIME_ELAPSED
// times only part of the work (DESIGN.md, "Measuring cost"), so time is taken on the CPU around
// glFinish; the protocol is described with TimingOptions in render.hpp.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "duolod/render.hpp"
#include "render/renderer_internal.hpp"

namespace duolod::render {
using namespace internal;

core::Result<std::vector<DrawTime>> Renderer::measureDrawTimes(AssetId asset_id,
                                                               std::span<const ProgramId> programs,
                                                               std::span<const Sample> samples,
                                                               const TimingOptions& options) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  State& s = *state_;
  if (programs.empty()) return core::Error{"measureDrawTimes: no programs to time"};
  if (options.repeats < 1 || options.max_passes_per_repeat < 1 || options.min_repeat_seconds < 0)
    return core::Error{"measureDrawTimes: repeats and passes must be >= 1"};
  RenderOptions render_options{.resolution = options.resolution};
  for (ProgramId program : programs)
    if (auto ok = checkRequest(s, asset_id, program, samples, render_options); !ok)
      return core::Error{"measureDrawTimes: " + ok.error().message};

  const GpuAsset& asset = *s.assets[asset_id];
  const int tile = options.resolution;
  const int count = static_cast<int>(samples.size());
  AtlasLayout layout = planAtlas(count, tile, s.max_size, 0);
  GLsizeiptr stride = roundUp(sizeof(FrameBlock), s.ubo_alignment);
  ChunkDrawer{s, asset, 0}.uploadFrames(samples, stride);
  if (auto ok = ensureFramebuffer(s.atlas, layout.columns * tile, layout.rows * tile, 0, GL_RGBA8,
                                  true, false);
      !ok)
    return ok.error();

  // The GL programs to time, then 0: the clear-only baseline.
  std::vector<GLuint> entries;
  bool first_draw = false;
  for (ProgramId program : programs) {
    entries.push_back(s.programs[program]);
    first_draw = s.firstDraw(s.programs[program], State::kTimingRequest) || first_draw;
  }
  entries.push_back(0);
  const SlowRequestWatch watch(first_draw, "timing %zu program%s over %d image%s of %d px (%s%s)",
                               programs.size(), pluralS(long(programs.size())), count,
                               pluralS(count), tile, s.programName(entries.front()),
                               programs.size() > 1 ? ", ..." : "");

  // One pass: every chunk of the domain cleared and drawn once.
  auto drawPass = [&](GLuint program) {
    for (int first = 0; first < count; first += layout.per_chunk) {
      beginDrawing(s.atlas);
      if (program) ChunkDrawer{s, asset, program}.drawChunk(first, std::min(layout.per_chunk,
                                                                            count - first),
                                                            tile, layout, stride);
    }
  };
  // Seconds per pass over `passes` passes queued back to back, up to glFinish.
  auto timePasses = [&](GLuint program, int passes) {
    glFinish();
    auto start = std::chrono::steady_clock::now();
    for (int p = 0; p < passes; ++p) drawPass(program);
    glFinish();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() /
           passes;
  };

  // Warm-up: llvmpipe builds each shader variant for the draw state at its first draw; one
  // sample triggers it.
  for (GLuint program : entries) {
    beginDrawing(s.atlas);
    if (program) ChunkDrawer{s, asset, program}.drawChunk(0, 1, tile, layout, stride);
    glFinish();
  }
  std::vector<int> passes(entries.size());
  for (size_t e = 0; e < entries.size(); ++e) {
    double one = std::max(timePasses(entries[e], 1), 1e-7);
    passes[e] = static_cast<int>(std::clamp(std::ceil(options.min_repeat_seconds / one), 1.0,
                                            double(options.max_passes_per_repeat)));
  }
  // Interleaved repeats (A B C base A B C base ...): drift and other load affect all alike.
  std::vector<std::vector<double>> times(entries.size());
  for (int r = 0; r < options.repeats; ++r)
    for (size_t e = 0; e < entries.size(); ++e)
      times[e].push_back(timePasses(entries[e], passes[e]));
  glDisable(GL_SCISSOR_TEST);
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return core::Error{"measureDrawTimes: OpenGL error " + std::to_string(error)};

  double clear_seconds = core::median(times.back());
  std::vector<DrawTime> results;
  for (size_t e = 0; e + 1 < entries.size(); ++e) {
    DrawTime result;
    result.pass_seconds = core::median(times[e]);
    result.clear_seconds = clear_seconds;
    result.seconds = std::max(0.0, result.pass_seconds - clear_seconds);
    auto [low, high] = std::minmax_element(times[e].begin(), times[e].end());
    result.spread = result.pass_seconds > 0 ? (*high - *low) / result.pass_seconds : 0;
    result.passes_per_repeat = passes[e];
    result.repeats = options.repeats;
    results.push_back(result);
  }
  return results;
}

core::Result<DrawTime> Renderer::measureDrawTime(AssetId asset, ProgramId program,
                                                 std::span<const Sample> samples,
                                                 const TimingOptions& options) {
  auto times = measureDrawTimes(asset, std::span(&program, 1), samples, options);
  if (!times) return times.error();
  return times->front();
}

}  // namespace duolod::render
