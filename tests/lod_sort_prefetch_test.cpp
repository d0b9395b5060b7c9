// SortByErrorPrefetch (src/lod/sort_prefetch.hpp): the renders its thread makes, in its own GL
// context, are the caller's own renders bit for bit (images and work counts), and every job is
// rendered exactly once, by the thread or by the caller, however the two race.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "duolod/shader.hpp"
#include "lod/sort_prefetch.hpp"
#include "mesh_test_meshes.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

using lod::SortByErrorPrefetch;

shader::Variant variantOf(const std::string& name) {
  auto source = render::loadShaderPair(test::sourcePath("shaders/" + name));
  EXPECT_TRUE(source) << source.error().message;
  auto vertex = shader::compileToSpirv(source->vertex, shader::Stage::kVertex, name + ".vert");
  EXPECT_TRUE(vertex) << vertex.error().message;
  auto fragment =
      shader::compileToSpirv(source->fragment, shader::Stage::kFragment, name + ".frag");
  EXPECT_TRUE(fragment) << fragment.error().message;
  return shader::Variant{render::SpirvBinary{*vertex, *fragment}, {}, {}};
}

class SortPrefetchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string failure;
    renderer_.reset(test::createRenderer(failure));
    ASSERT_NE(renderer_, nullptr) << "no OpenGL 4.5 context: " << failure;
    asset_.source_path = "icosphere";
    asset_.mesh = test::icosphere(3);
    core::computeNormals(asset_.mesh);
    core::Material material;
    material.base_color_factor = {0.7f, 0.5f, 0.3f, 1};
    asset_.materials = {material};
    shaders_ = {variantOf("noise_phong"), variantOf("constant")};
    const core::Sphere bounds = core::computeBoundingSphere(asset_.mesh);
    for (float distance : {4.0f, 9.0f}) {
      auto samples = render::domainSamples(bounds, distance);
      samples.resize(10);  // 2 views × 5 lights: enough to compare, quick under sanitizers
      levels_.push_back({samples, distance < 5 ? 40 : 20});
    }
    for (int level = 0; level < 2; ++level)
      for (int shader = 0; shader < 2; ++shader) jobs_.push_back({level, shader});
  }

  // What the caller renders itself: M_0 uploaded as the generator uploads it.
  SortByErrorPrefetch::Rendered own(int level, int shader) {
    if (mesh_ < 0) {
      auto materials = renderer_->uploadAsset(asset_);
      EXPECT_TRUE(materials) << materials.error().message;
      auto mesh = renderer_->uploadMesh(*materials, asset_.mesh);
      EXPECT_TRUE(mesh) << mesh.error().message;
      mesh_ = *mesh;
    }
    auto program = renderer_->compileProgram(shaders_[shader].spirv);
    EXPECT_TRUE(program) << program.error().message;
    render::RenderStats stats;
    auto images = renderer_->render(
        mesh_, *program, levels_[level].samples,
        {.resolution = levels_[level].resolution, .count_work = true}, &stats);
    EXPECT_TRUE(images) << images.error().message;
    return {std::move(*images), stats.work};
  }

  static void expectSame(const SortByErrorPrefetch::Rendered& a,
                         const SortByErrorPrefetch::Rendered& b) {
    EXPECT_EQ(a.images.count, b.images.count);
    EXPECT_EQ(a.images.width, b.images.width);
    EXPECT_TRUE(a.images.pixels == b.images.pixels) << "the thread's images differ";
    EXPECT_EQ(a.work.vertex_invocations, b.work.vertex_invocations);
    EXPECT_EQ(a.work.fragment_invocations, b.work.fragment_invocations);
    EXPECT_GT(a.work.fragment_invocations, 0u);
  }

  std::unique_ptr<render::Renderer> renderer_;
  core::Asset asset_;
  std::vector<shader::Variant> shaders_;
  std::vector<SortByErrorPrefetch::Level> levels_;
  std::vector<SortByErrorPrefetch::Job> jobs_;
  render::Renderer::AssetId mesh_ = -1;
};

TEST_F(SortPrefetchTest, TheThreadsRendersAreTheCallersOwn) {
  SortByErrorPrefetch prefetch(asset_, shaders_, levels_, jobs_, {});
  // Nothing taken yet, so the thread renders every job; wait for it (bounded).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (prefetch.rendered() < int(jobs_.size()) && prefetch.failure().empty() &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(prefetch.failure(), "");
  ASSERT_EQ(prefetch.rendered(), int(jobs_.size()));
  for (const SortByErrorPrefetch::Job& job : jobs_) {
    auto taken = prefetch.take(job.level, job.shader);
    ASSERT_TRUE(taken) << "level " << job.level << " shader " << job.shader;
    expectSame(*taken, own(job.level, job.shader));
    EXPECT_FALSE(prefetch.take(job.level, job.shader)) << "handed out twice";
  }
  EXPECT_FALSE(prefetch.take(5, 0)) << "not a job";
}

TEST_F(SortPrefetchTest, EveryJobIsRenderedOnceWhenTheCallerRacesTheThread) {
  SortByErrorPrefetch prefetch(asset_, shaders_, levels_, jobs_, {});
  int by_caller = 0;
  // The caller walks the jobs in the thread's own order at once: each is either the thread's
  // (finished or waited for) or claimed and rendered here, never both.
  for (const SortByErrorPrefetch::Job& job : jobs_) {
    auto taken = prefetch.take(job.level, job.shader);
    SortByErrorPrefetch::Rendered mine = own(job.level, job.shader);
    if (taken)
      expectSame(*taken, mine);
    else
      ++by_caller;
  }
  EXPECT_EQ(prefetch.failure(), "");
  EXPECT_EQ(prefetch.rendered() + by_caller, int(jobs_.size()));
}

}  // namespace
}  // namespace duolod
