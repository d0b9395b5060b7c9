// A failed allocation on one of the library's worker threads ends that worker's part, never the
// process. Before, std::bad_alloc left the thread's function and std::terminate aborted (exit
// 134): a request that fits beside the caller's work but not beside the workers' (the SortByError
// prefetch's renders, a compile-ahead worker's forms, a GP search's renders) killed the run.
//   - SortByErrorPrefetch and CompileAhead only speed things up: their failure is reported (or
//     not), and the caller does the work itself;
//   - generateLod's shader-search thread hands the exception to the caller, which sees it thrown
//     from generateLod (the CLI then says "out of memory").
// The failures are injected: this executable replaces operator new, and while a test arms it,
// allocations of at least a given size made off the test's own thread throw std::bad_alloc.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <limits>
#include <new>
#include <thread>

#include "duolod/lod.hpp"
#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "lod/sort_prefetch.hpp"
#include "mesh_test_meshes.hpp"
#include "shader/compile_ahead.hpp"
#include "shader/rules.hpp"
#include "shader/search.hpp"
#include "test_support.hpp"

namespace {

constexpr size_t kNever = std::numeric_limits<size_t>::max();
// Constant-initialized, so operator new can read it before any dynamic initialization.
std::atomic<size_t> g_fail_from_bytes{kNever};
const std::thread::id g_test_thread = std::this_thread::get_id();

// Allocations of at least `bytes` made off the test's thread fail while this lives.
class FailingWorkerAllocations {
 public:
  explicit FailingWorkerAllocations(size_t bytes) { g_fail_from_bytes = bytes; }
  ~FailingWorkerAllocations() { g_fail_from_bytes = kNever; }
  FailingWorkerAllocations(const FailingWorkerAllocations&) = delete;
  FailingWorkerAllocations& operator=(const FailingWorkerAllocations&) = delete;
};

}  // namespace

// Every unaligned form is replaced, so that whatever one of them allocates, any other may free
// (AddressSanitizer reports a free() of what its own operator new(std::nothrow) returned). The
// aligned forms stay the library's, in pairs.
void* operator new(std::size_t size) {
  if (size >= g_fail_from_bytes.load(std::memory_order_relaxed) &&
      std::this_thread::get_id() != g_test_thread)
    throw std::bad_alloc();
  if (void* memory = std::malloc(size == 0 ? 1 : size)) return memory;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  return operator new(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return std::malloc(size == 0 ? 1 : size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return std::malloc(size == 0 ? 1 : size);
}
// Not inlined: g++ would otherwise see free() called on what `new` returned and warn
// (-Wmismatched-new-delete), which is right for the standard's operators, not for these.
[[gnu::noinline]] void operator delete(void* memory) noexcept {
  std::free(memory);
}
[[gnu::noinline]] void operator delete(void* memory, std::size_t) noexcept {
  std::free(memory);
}
[[gnu::noinline]] void operator delete[](void* memory) noexcept {
  std::free(memory);
}
[[gnu::noinline]] void operator delete[](void* memory, std::size_t) noexcept {
  std::free(memory);
}
[[gnu::noinline]] void operator delete(void* memory, const std::nothrow_t&) noexcept {
  std::free(memory);
}
[[gnu::noinline]] void operator delete[](void* memory, const std::nothrow_t&) noexcept {
  std::free(memory);
}

// SPIRV-Tools (linked statically) frees its validator's options (48 bytes, made through its C
// API) on its normal path only: the injected std::bad_alloc that unwinds through the validator
// leaves them. A leak this test's injection causes in SPIRV-Tools, not one of duolod's.
extern "C" [[gnu::used]] const char* __lsan_default_suppressions() {
  return "leak:spvValidatorOptionsCreate\n";
}

namespace duolod {
namespace {

core::Asset sphereAsset() {
  core::Asset asset;
  asset.source_path = "icosphere";
  asset.mesh = test::icosphere(3);
  core::computeNormals(asset.mesh);
  core::Material material;
  material.base_color_factor = {0.7f, 0.5f, 0.3f, 1};
  asset.materials = {material};
  return asset;
}

bool haveContext(std::string& failure) {
  auto renderer = render::Renderer::create();
  if (!renderer) failure = renderer.error().message;
  return bool(renderer);
}

// The prefetch thread's render of 16 images of 512² pixels (16 MB) fails: the thread stops and
// says why, take() hands the job back, and the caller renders it itself.
TEST(WorkerFailure, APrefetchThreadOutOfMemoryStopsItAndTheCallerRenders) {
  std::string failure;
  if (!haveContext(failure)) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << failure;
  const core::Asset asset = sphereAsset();
  auto source = render::loadShaderPair(test::sourcePath("shaders/constant"));
  ASSERT_TRUE(source) << source.error().message;
  auto vertex = shader::compileToSpirv(source->vertex, shader::Stage::kVertex, "constant.vert");
  auto fragment =
      shader::compileToSpirv(source->fragment, shader::Stage::kFragment, "constant.frag");
  ASSERT_TRUE(vertex && fragment);
  std::vector<shader::Variant> shaders = {
      shader::Variant{render::SpirvBinary{*vertex, *fragment}, {}, {}}};
  auto samples = render::domainSamples(core::computeBoundingSphere(asset.mesh), 4.0f);
  samples.resize(16);
  std::optional<lod::SortByErrorPrefetch::Rendered> taken;
  {
    FailingWorkerAllocations failing(128u << 10);
    lod::SortByErrorPrefetch prefetch(asset, shaders, {{samples, 512}}, {{0, 0}}, {});
    // Wait for the thread to reach the render (take() would take a job it has not started).
    for (int i = 0; i < 6000 && prefetch.failure().empty() && prefetch.rendered() == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_EQ(prefetch.failure(), "SortByError prefetch: out of memory");
    taken = prefetch.take(0, 0);
    EXPECT_EQ(prefetch.rendered(), 0);
  }
  EXPECT_FALSE(taken) << "a failed thread handed over a render";

  auto renderer = render::Renderer::create();
  ASSERT_TRUE(renderer) << renderer.error().message;
  auto uploaded = (*renderer)->uploadAsset(asset);
  ASSERT_TRUE(uploaded) << uploaded.error().message;
  auto program = (*renderer)->compileProgram(shaders[0].spirv);
  ASSERT_TRUE(program) << program.error().message;
  auto images = (*renderer)->render(*uploaded, *program, samples, {.resolution = 512});
  ASSERT_TRUE(images) << images.error().message;
  EXPECT_EQ(images->count, 16);
}

constexpr const char* kVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec3 vPosition;
void main() { vPosition = inPosition; gl_Position = vec4(inPosition * 0.3, 1.0); }
)";

shader::ShaderProgram programTinted(float red) {
  const std::string fragment_source =
      "#version 450 core\nlayout(location = 0) in vec3 vPosition;\n"
      "layout(location = 0) out vec4 outColor;\nvoid main() { outColor = vec4(" +
      std::to_string(red) + ", sin(vPosition.x * 7.0), vPosition.z, 1.0); }\n";
  auto vertex = shader::compileToSpirv(kVertex, shader::Stage::kVertex, "tinted.vert");
  auto fragment = shader::compileToSpirv(fragment_source, shader::Stage::kFragment, "tinted.frag");
  EXPECT_TRUE(vertex && fragment);
  auto program = shader::parseProgram(*vertex, *fragment);
  EXPECT_TRUE(program) << program.error().message;
  return *program;
}

// A compile-ahead worker whose every allocation fails (once its context is made) hands over
// nothing for the program it was making and stops; take() then says "make it yourself", for that
// program and for the ones queued after it.
TEST(WorkerFailure, ACompileAheadWorkerOutOfMemoryHandsOverNothing) {
  std::string failure;
  if (!haveContext(failure)) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << failure;
  const core::Asset asset = sphereAsset();
  const render::Sample sample =
      render::domainSamples(core::computeBoundingSphere(asset.mesh), 4.0f).front();
  shader::CompileAhead ahead(asset, sample, 32, {}, /*workers=*/1);
  auto first = std::make_shared<const shader::ShaderProgram>(programTinted(0.25f));
  auto second = std::make_shared<const shader::ShaderProgram>(programTinted(0.5f));
  auto third = std::make_shared<const shader::ShaderProgram>(programTinted(0.75f));

  // The first program is made as usual (which also means the worker's context exists).
  ahead.enqueue(std::span(&first, 1));
  std::optional<core::Result<shader::Variant>> made;
  for (int i = 0; i < 6000 && !made; ++i) {
    if (ahead.counters().compiled == 1) made = ahead.take(shader::programHash(*first));
    if (!made) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(made) << "the worker never made the first program";
  EXPECT_TRUE(*made);

  {
    FailingWorkerAllocations failing(0);
    const std::shared_ptr<const shader::ShaderProgram> rest[] = {second, third};
    ahead.enqueue(rest);
    // Until the worker has started on it, take() would take it off the queue.
    for (int i = 0; i < 6000 && ahead.counters().started < 2; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_EQ(ahead.counters().started, 2);
    EXPECT_FALSE(ahead.take(shader::programHash(*second)));
    EXPECT_FALSE(ahead.take(shader::programHash(*third)));
  }
  EXPECT_EQ(ahead.counters().compiled, 1);
  EXPECT_EQ(ahead.counters().taken, 1);
}

// generateLod's GP search runs on a thread of its own; when its renders cannot be allocated, the
// caller gets std::bad_alloc from generateLod instead of an aborted process.
TEST(WorkerFailure, AShaderSearchOutOfMemoryIsThrownToTheCaller) {
  std::string failure;
  if (!haveContext(failure)) GTEST_SKIP() << "SKIPPED: no OpenGL 4.5 context: " << failure;
  const core::Asset asset = sphereAsset();
  auto source = render::loadShaderPair(test::sourcePath("shaders/noise_phong"));
  ASSERT_TRUE(source) << source.error().message;
  lod::GenerateOptions options;
  options.levels.level_count = 2;
  options.mesh_mode = lod::MeshCandidateMode::kQuadric;
  options.mesh_candidates = 20;
  options.shader_search_levels = 1;
  options.population = 4;
  options.generations = 1;
  options.compile_ahead = false;  // the search's own thread only
  options.sort_prefetch = false;
  FailingWorkerAllocations failing(128u << 10);
  EXPECT_THROW((void)lod::generateLod(asset, *source, options), std::bad_alloc);
}

}  // namespace
}  // namespace duolod
