// The render side of block-count profiling (shader/instrument.hpp): one render of the training
// samples with the instrumented program, counters in a shader storage buffer read back once.
// The Renderer's public API has no storage buffers, so the buffer is made here with plain OpenGL
// on the Renderer's context (current on the thread that created it); nothing else in the Renderer
// uses SSBO bindings.
#include <epoxy/gl.h>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "shader/cost_model.hpp"
#include "shader/instrument.hpp"

namespace duolod::shader {

using core::Error;

namespace {

// A zeroed buffer of `count` uint counters bound at `binding` for as long as it lives.
class CounterBuffer {
 public:
  CounterBuffer(int count, uint32_t binding) : count_(std::max(count, 1)), binding_(binding) {
    std::vector<uint32_t> zeros(static_cast<size_t>(count_), 0);
    glCreateBuffers(1, &buffer_);
    glNamedBufferStorage(buffer_, static_cast<GLsizeiptr>(zeros.size() * sizeof(uint32_t)),
                         zeros.data(), GL_DYNAMIC_STORAGE_BIT);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding_, buffer_);
  }
  ~CounterBuffer() {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding_, 0);
    glDeleteBuffers(1, &buffer_);
  }
  CounterBuffer(const CounterBuffer&) = delete;
  CounterBuffer& operator=(const CounterBuffer&) = delete;

  std::vector<uint64_t> read() const {
    std::vector<uint32_t> values(static_cast<size_t>(count_), 0);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(buffer_, 0, static_cast<GLsizeiptr>(values.size() * sizeof(uint32_t)),
                            values.data());
    return {values.begin(), values.end()};
  }

 private:
  int count_;
  uint32_t binding_;
  GLuint buffer_ = 0;
};

// Index of the entry point's first block among blockOpCounts() blocks (functions in module order).
core::Result<int> entryBlockIndex(const ir::Module& module, spv::ExecutionModel model) {
  const ir::Function* entry = module.entryFunction(model);
  if (!entry) return Error{"block profile: the module has no entry point for its stage"};
  int index = 0;
  for (const ir::Function& function : module.functions) {
    if (&function == entry) return index;
    index += static_cast<int>(function.blocks.size());
  }
  return Error{"block profile: entry function not found"};
}

// Executions per invocation: each counter over the entry block's, i.e. per invocation that ran.
core::Result<std::vector<double>> perInvocation(const std::vector<uint64_t>& totals, int count,
                                                int entry, const char* stage) {
  std::vector<double> executions(static_cast<size_t>(count), 0.0);
  const double invocations = static_cast<double>(totals[entry]);
  for (int i = 0; i < count; ++i) {
    if (totals[i] == std::numeric_limits<uint32_t>::max())
      return Error{std::string("block profile: a ") + stage +
                   " counter saturated at 2^32 - 1; profile fewer samples or a lower resolution"};
    executions[i] = invocations > 0 ? static_cast<double>(totals[i]) / invocations : 0.0;
  }
  return executions;
}

}  // namespace

core::Result<BlockProfile> profileBlockCounts(render::Renderer& renderer,
                                              render::Renderer::AssetId asset,
                                              const ir::Module& vertex, const ir::Module& fragment,
                                              std::span<const render::Sample> samples,
                                              int resolution,
                                              std::span<const render::UniformValue> uniforms,
                                              render::ImageBatch8* images_out) {
  const auto [vertex_binding, fragment_binding] = counterBindings(vertex, fragment);
  auto vertex_copy = instrumentBlockCounts(vertex, vertex_binding);
  if (!vertex_copy.ok()) return Error{"vertex stage: " + vertex_copy.error().message};
  auto fragment_copy = instrumentBlockCounts(fragment, fragment_binding);
  if (!fragment_copy.ok()) return Error{"fragment stage: " + fragment_copy.error().message};
  render::SpirvBinary binary{ir::emitModule(vertex_copy->module),
                             ir::emitModule(fragment_copy->module)};
  auto program = renderer.compileProgram(binary);
  if (!program.ok()) return Error{"block profile: " + program.error().message};
  if (!uniforms.empty()) {
    const std::vector<render::UniformValue> values(uniforms.begin(), uniforms.end());
    if (auto set = renderer.setProgramUniforms(*program, values); !set.ok()) {
      renderer.releaseProgram(*program);
      return Error{"block profile: " + set.error().message};
    }
  }

  BlockProfile profile;
  core::Status status = core::okStatus();
  {
    CounterBuffer vertex_counters(vertex_copy->counter_count, vertex_binding);
    CounterBuffer fragment_counters(fragment_copy->counter_count, fragment_binding);
    render::RenderOptions options{.resolution = resolution, .count_work = true};
    render::RenderStats stats;
    auto images = renderer.render(asset, *program, samples, options, &stats);
    if (!images.ok()) {
      status = Error{"block profile: " + images.error().message};
    } else {
      profile.vertex_totals = vertex_counters.read();
      profile.fragment_totals = fragment_counters.read();
      profile.vertex_invocations = stats.work.vertex_invocations;
      profile.fragment_invocations = stats.work.fragment_invocations;
      if (images_out) *images_out = std::move(*images);
    }
  }
  renderer.releaseProgram(*program);
  if (!status.ok()) return status.error();

  auto vertex_entry = entryBlockIndex(vertex, spv::ExecutionModelVertex);
  if (!vertex_entry.ok()) return vertex_entry.error();
  auto fragment_entry = entryBlockIndex(fragment, spv::ExecutionModelFragment);
  if (!fragment_entry.ok()) return fragment_entry.error();
  profile.vertex_runs = profile.vertex_totals[*vertex_entry];
  profile.fragment_runs = profile.fragment_totals[*fragment_entry];
  auto vertex_executions =
      perInvocation(profile.vertex_totals, vertex_copy->counter_count, *vertex_entry, "vertex");
  if (!vertex_executions.ok()) return vertex_executions.error();
  auto fragment_executions = perInvocation(profile.fragment_totals, fragment_copy->counter_count,
                                           *fragment_entry, "fragment");
  if (!fragment_executions.ok()) return fragment_executions.error();
  profile.vertex_executions = std::move(*vertex_executions);
  profile.fragment_executions = std::move(*fragment_executions);
  return profile;
}

}  // namespace duolod::shader
