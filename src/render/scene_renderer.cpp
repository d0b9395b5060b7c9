// Scene frames: many placed instances of uploaded assets seen by one camera, for the walk-through
// benchmark (Liang et al. §7.2.2: ~400 objects on the ground, rendering time per configuration).
// Instances are batched by (asset, program) by the caller; a batch binds its program, vertex
// arrays and materials once and then only moves the Frame block's range per instance, so the CPU
// side stays a small part of a frame. Time is wall clock up to glFinish (DESIGN.md, "Measuring
// cost": llvmpipe's GL_TIME_ELAPSED is wrong).
#include <chrono>

#include "duolod/render.hpp"
#include "render/renderer_internal.hpp"

namespace duolod::render {
using namespace internal;

core::Result<SceneFrame> Renderer::renderScene(std::span<const InstanceBatch> batches,
                                               const SceneCamera& camera,
                                               const SceneOptions& options) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  State& s = *state_;
  if (camera.width < 1 || camera.height < 1 || camera.width > s.max_size ||
      camera.height > s.max_size)
    return core::Error{"renderScene: display " + std::to_string(camera.width) + "x" +
                       std::to_string(camera.height) + " outside 1.." +
                       std::to_string(s.max_size)};
  if (options.count_work && !s.work_queries.available)
    return core::Error{"renderScene: work counting needs ARB_pipeline_statistics_query"};
  size_t instances = 0;
  for (const InstanceBatch& batch : batches) {
    if (batch.asset < 0 || batch.asset >= static_cast<int>(s.assets.size()) ||
        !s.assets[batch.asset])
      return core::Error{"renderScene: unknown asset id " + std::to_string(batch.asset)};
    if (batch.program < 0 || batch.program >= static_cast<int>(s.programs.size()) ||
        !s.programs[batch.program])
      return core::Error{"renderScene: unknown program id " + std::to_string(batch.program)};
    instances += batch.models.size();
  }
  if (auto ok = ensureFramebuffer(s.atlas, camera.width, camera.height, 0, GL_RGBA8, true, false);
      !ok)
    return ok.error();

  SceneFrame frame;
  glFinish();  // earlier work must not be timed with this frame
  const auto start = std::chrono::steady_clock::now();

  // Every instance's Frame block, uploaded once; draws bind ranges of it.
  const GLsizeiptr stride = roundUp(sizeof(FrameBlock), s.ubo_alignment);
  std::vector<uint8_t> bytes(std::max<size_t>(instances, 1) * stride);
  size_t slot = 0;
  for (const InstanceBatch& batch : batches) {
    const GpuAsset& asset = *s.assets[batch.asset];
    for (const core::Mat4& model : batch.models) {
      FrameBlock block =
          makeFrameBlock(s, model, core::transpose(core::inverse(model)), camera.view,
                         camera.projection, camera.eye, camera.light, asset.bounds);
      std::memcpy(bytes.data() + slot++ * stride, &block, sizeof block);
    }
  }
  uploadFrameBytes(s, bytes);

  beginDrawing(s.atlas);
  glDisable(GL_SCISSOR_TEST);
  glClearColor(camera.clear_color.x, camera.clear_color.y, camera.clear_color.z, 0);
  glClear(GL_COLOR_BUFFER_BIT);
  glClearColor(0, 0, 0, 0);
  const bool per_batch = options.count_work && options.count_work_per_batch;
  if (per_batch) frame.batch_work.resize(batches.size());
  if (options.count_work && !per_batch) s.work_queries.begin();
  slot = 0;
  for (size_t b = 0; b < batches.size(); ++b) {
    const InstanceBatch& batch = batches[b];
    if (batch.models.empty()) continue;
    if (per_batch) s.work_queries.begin();
    const GpuAsset& asset = *s.assets[batch.asset];
    ChunkDrawer drawer{s, asset, s.programs[batch.program]};
    drawer.bindInputs();
    // One material per submesh: bind it once per batch when the asset has a single submesh.
    const bool single_material = asset.submeshes.size() == 1;
    if (single_material) drawer.bindMaterial(asset.submeshes.front().material);
    for (size_t i = 0; i < batch.models.size(); ++i, ++slot) {
      if (s.bindings.frame_block >= 0)  // -1: the shader reads no frame block
        glBindBufferRange(GL_UNIFORM_BUFFER, s.bindings.frame_block, s.frame_ubo,
                          stride * static_cast<GLsizeiptr>(slot), sizeof(FrameBlock));
      for (const GpuSubmesh& sub : asset.submeshes) {
        if (!single_material) drawer.bindMaterial(sub.material);
        glDrawElements(GL_TRIANGLES, sub.index_count, GL_UNSIGNED_INT,
                       reinterpret_cast<const void*>(sub.first_index * 4));
        ++frame.draws;
      }
    }
    if (per_batch) {
      s.work_queries.end();
      s.work_queries.addResults(frame.batch_work[b]);
      s.work_queries.addResults(frame.work);  // the same results, into the frame's total
    }
  }
  if (options.count_work && !per_batch) s.work_queries.end();
  glFinish();
  frame.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (options.count_work && !per_batch) s.work_queries.addResults(frame.work);

  if (options.read_back) {
    std::vector<uint8_t> rows(size_t(camera.width) * camera.height * 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, s.atlas.fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, camera.width, camera.height, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
    frame.image.width = camera.width;
    frame.image.height = camera.height;
    frame.image.pixels.resize(rows.size());
    const size_t row_bytes = size_t(camera.width) * 4;
    for (int y = 0; y < camera.height; ++y)  // GL rows are bottom-up
      std::memcpy(frame.image.pixels.data() + y * row_bytes,
                  rows.data() + size_t(camera.height - 1 - y) * row_bytes, row_bytes);
  }
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return core::Error{"renderScene: OpenGL error " + std::to_string(error)};
  return frame;
}

}  // namespace duolod::render
