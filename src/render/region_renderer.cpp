// Local re-rendering for image-driven simplification (Lindstrom & Turk, "Image-driven
// simplification", 2000; Liang et al. §3.2 "incremental image updates"). A collapse changes a few
// pixels of each view, so instead of redrawing whole views we draw, for many candidate changes at
// once, only the triangles around each change into a small tile of an atlas. The user's vertex
// stage is wrapped: after it computes gl_Position in its view's clip space, an affine map moves the
// vertex by whole pixels into its tile and four clip planes cut it to the tile, so every tile is
// rasterized exactly like the corresponding region of the full view.
#include <algorithm>
#include <chrono>
#include <numeric>
#include <cctype>

#include "render/renderer_internal.hpp"

namespace duolod::render {
namespace {
using core::Error;
using namespace internal;

constexpr int kTileDataBinding = 15;       // SSBO binding of per-vertex tile placement
constexpr int kAtlasTransformLocation = 30;  // uniform vec4 (scale x, scale y, band offset x, y)

// Appended to the user's vertex shader, whose main() has been renamed duolod_user_main().
constexpr const char* kWrapper = R"(
// ---- duolod region wrapper: place the vertex in its atlas tile and clip it to the tile ----
layout(std430, binding = 15) readonly buffer DuolodTilePlacement { vec4 duolod_tile[]; };
layout(location = 30) uniform vec4 duolod_atlas_transform;
void main() {
  duolod_user_main();
  vec4 offset_and_min = duolod_tile[gl_VertexID * 2];  // xy clip offset, zw tile min (atlas NDC)
  vec4 tile_max = duolod_tile[gl_VertexID * 2 + 1];     // xy tile max (atlas NDC)
  vec4 p = gl_Position;
  vec2 band = duolod_atlas_transform.zw;
  p.xy = p.xy * duolod_atlas_transform.xy + (offset_and_min.xy + band) * p.w;
  gl_Position = p;
  gl_ClipDistance[0] = p.x - (offset_and_min.z + band.x) * p.w;
  gl_ClipDistance[1] = (tile_max.x + band.x) * p.w - p.x;
  gl_ClipDistance[2] = p.y - (offset_and_min.w + band.y) * p.w;
  gl_ClipDistance[3] = (tile_max.y + band.y) * p.w - p.y;
}
)";

// Finds "void main()" / "void main(void)" (any spacing) and returns [begin, end) of it, or npos.
std::pair<size_t, size_t> findMainDefinition(const std::string& text) {
  auto skipSpace = [&](size_t i) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    return i;
  };
  auto isIdentifier = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  for (size_t at = text.find("void"); at != std::string::npos; at = text.find("void", at + 4)) {
    if (at > 0 && isIdentifier(text[at - 1])) continue;
    size_t i = skipSpace(at + 4);
    if (i == at + 4 || text.compare(i, 4, "main") != 0) continue;
    i = skipSpace(i + 4);
    if (i >= text.size() || text[i] != '(') continue;
    i = skipSpace(i + 1);
    if (text.compare(i, 4, "void") == 0) i = skipSpace(i + 4);
    if (i < text.size() && text[i] == ')') return {at, i + 1};
  }
  return {std::string::npos, std::string::npos};
}

}  // namespace

core::Result<Renderer::ProgramId> Renderer::compileRegionProgram(const GlslSource& source) {
  auto [begin, end] = findMainDefinition(source.vertex);
  if (begin == std::string::npos)
    return Error{source.vertex_name + ": no 'void main()' found to wrap for region rendering"};
  std::string wrapped = source.vertex;
  wrapped.replace(begin, end - begin, "void duolod_user_main()");
  if (wrapped.find("gl_PerVertex") != std::string::npos)
    return Error{source.vertex_name +
                 ": redeclares gl_PerVertex; region rendering needs gl_ClipDistance[4]"};
  wrapped += kWrapper;
  GlslSource region = source;
  region.vertex = std::move(wrapped);
  region.vertex_name = source.vertex_name + " (region wrapper)";
  return compileProgram(region);
}

core::Result<ImageBatch8> Renderer::renderRegions(AssetId asset_id, ProgramId program_id,
                                                  const RegionSoup& soup,
                                                  std::span<const Sample> samples,
                                                  int lights_per_view, int view_resolution,
                                                  int tile_size, RenderStats* stats) {
  State& s = *state_;
  auto start = std::chrono::steady_clock::now();
  if (asset_id < 0 || asset_id >= static_cast<int>(s.assets.size()) || !s.assets[asset_id])
    return Error{"renderRegions: unknown asset id " + std::to_string(asset_id)};
  if (program_id < 0 || program_id >= static_cast<int>(s.programs.size()) || !s.programs[program_id])
    return Error{"renderRegions: unknown program id " + std::to_string(program_id)};
  const size_t triangle_count = soup.triangle_tile.size();
  const core::Mesh& mesh = soup.triangles;
  if (mesh.positions.size() != triangle_count * 3 || soup.triangle_material.size() != triangle_count)
    return Error{"renderRegions: soup streams disagree with its triangle count"};
  if (auto valid = core::validateMesh(core::Mesh{mesh.positions, mesh.normals, mesh.tangents,
                                                 mesh.uv0, mesh.uv1, mesh.colors, {}, {}});
      !valid)
    return Error{"renderRegions: " + valid.error().message};
  if (lights_per_view < 1 || samples.size() % lights_per_view != 0)
    return Error{"renderRegions: samples are not view-major with " +
                 std::to_string(lights_per_view) + " lights per view"};
  const int view_count = static_cast<int>(samples.size()) / lights_per_view;
  const int tile_count = static_cast<int>(soup.tiles.size());
  for (const RegionTile& tile : soup.tiles)
    if (tile.view_index < 0 || tile.view_index >= view_count)
      return Error{"renderRegions: tile refers to view " + std::to_string(tile.view_index)};
  for (uint32_t t : soup.triangle_tile)
    if (t >= soup.tiles.size()) return Error{"renderRegions: triangle refers to a missing tile"};

  ImageBatch8 batch;
  batch.width = batch.height = tile_size;
  batch.count = tile_count * lights_per_view;
  batch.pixels.assign(size_t(batch.count) * tile_size * tile_size * 4, 0);
  if (tile_count == 0) return batch;

  // Atlas: one band per light; in each band, tile t sits at slot t.
  const int columns = std::max(1, std::min(tile_count, s.max_size / tile_size));
  const int rows = (tile_count + columns - 1) / columns;
  const int band_height = rows * tile_size;
  const int width = columns * tile_size, height = band_height * lights_per_view;
  if (height > s.max_size)
    return Error{"renderRegions: " + std::to_string(tile_count) + " tiles of " +
                 std::to_string(tile_size) + " px exceed one atlas; split the batch"};

  // Draw order: by view (one camera per draw), then material (one material per draw).
  std::vector<uint32_t> order(triangle_count);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    int va = soup.tiles[soup.triangle_tile[a]].view_index;
    int vb = soup.tiles[soup.triangle_tile[b]].view_index;
    return va != vb ? va < vb : soup.triangle_material[a] < soup.triangle_material[b];
  });

  // Per-vertex placement, in the sorted order: clip-space offset and tile bounds (atlas NDC, band 0).
  // A view pixel (px, py) (GL: y up) maps to atlas pixel (px − gx0 + ax, py − gy0 + ay).
  std::vector<float> placement(triangle_count * 3 * 8);
  const float R = float(view_resolution), W = float(width), H = float(height);
  for (size_t i = 0; i < triangle_count; ++i) {
    uint32_t t = soup.triangle_tile[order[i]];
    const RegionTile& tile = soup.tiles[t];
    float ax = float((t % columns) * tile_size), ay = float((t / columns) * tile_size);
    float gx0 = float(tile.x0), gy0 = float(view_resolution - tile.y0 - tile_size);
    // Clip to the region (its top rows are the tile's top rows: GL's y runs up).
    float region_w = float(tile.width > 0 ? std::min(tile.width, tile_size) : tile_size);
    float region_h = float(tile.height > 0 ? std::min(tile.height, tile_size) : tile_size);
    float clip_y0 = ay + tile_size - region_h;
    float values[8] = {(R - 2 * gx0 + 2 * ax) / W - 1, (R - 2 * gy0 + 2 * ay) / H - 1,
                       2 * ax / W - 1, 2 * clip_y0 / H - 1,
                       2 * (ax + region_w) / W - 1, 2 * (ay + tile_size) / H - 1, 0, 0};
    for (int v = 0; v < 3; ++v) std::copy_n(values, 8, placement.data() + (i * 3 + v) * 8);
  }

  // Upload the soup, in draw order, like an asset's vertices; it borrows the asset's materials
  // and textures.
  core::Mesh sorted;
  auto reorder = [&](const auto& values, auto& out) {
    if (values.empty()) return;
    out.resize(values.size());
    for (size_t i = 0; i < triangle_count; ++i)
      for (int v = 0; v < 3; ++v) out[i * 3 + v] = values[order[i] * 3 + v];
  };
  reorder(mesh.positions, sorted.positions);
  reorder(mesh.normals, sorted.normals);
  reorder(mesh.tangents, sorted.tangents);
  reorder(mesh.uv0, sorted.uv0);
  reorder(mesh.uv1, sorted.uv1);
  reorder(mesh.colors, sorted.colors);
  const GpuAsset& asset = *s.assets[asset_id];
  GpuAsset soup_asset;
  uploadVertexStreams(sorted, soup_asset);
  GLuint placement_buffer = addBuffer(soup_asset, placement.data(), placement.size() * sizeof(float));
  soup_asset.material_ubo = asset.material_ubo;
  soup_asset.material_stride = asset.material_stride;
  soup_asset.textures = asset.textures;
  soup_asset.materials = asset.materials;
  soup_asset.bounds = asset.bounds;
  // Frees what this call created, but not the borrowed material buffer.
  auto releaseSoup = [&] {
    glDeleteBuffers(GLsizei(soup_asset.buffers.size()), soup_asset.buffers.data());
    glDeleteVertexArrays(1, &soup_asset.vao);
  };

  // The camera/light blocks are those of the full-view passes.
  GLsizeiptr stride = roundUp(sizeof(FrameBlock), s.ubo_alignment);
  ChunkDrawer drawer{s, soup_asset, s.programs[program_id]};
  drawer.uploadFrames(samples, stride);

  RenderStats local;
  if (auto ok = ensureFramebuffer(s.atlas, width, height, 0, GL_RGBA8, true, false); !ok) {
    releaseSoup();
    return ok.error();
  }
  beginDrawing(s.atlas);
  glDisable(GL_SCISSOR_TEST);
  for (int plane = 0; plane < 4; ++plane) glEnable(GL_CLIP_DISTANCE0 + plane);
  drawer.bindInputs();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTileDataBinding, placement_buffer);
  // Runs of equal (view, material) in the sorted order: one draw per run and light.
  size_t run_start = 0;
  while (run_start < triangle_count) {
    uint32_t first = order[run_start];
    int view = soup.tiles[soup.triangle_tile[first]].view_index;
    uint32_t material = soup.triangle_material[first];
    size_t run_end = run_start + 1;
    while (run_end < triangle_count &&
           soup.tiles[soup.triangle_tile[order[run_end]]].view_index == view &&
           soup.triangle_material[order[run_end]] == material)
      ++run_end;
    drawer.bindMaterial(material);
    for (int light = 0; light < lights_per_view; ++light) {
      int sample = view * lights_per_view + light;
      glBindBufferRange(GL_UNIFORM_BUFFER, s.bindings.frame_block, s.frame_ubo, stride * sample,
                        sizeof(FrameBlock));
      glUniform4f(kAtlasTransformLocation, R / W, R / H, 0.0f, 2.0f * band_height * light / H);
      glDrawArrays(GL_TRIANGLES, GLint(run_start * 3), GLsizei((run_end - run_start) * 3));
      ++local.draws;
    }
    run_start = run_end;
  }
  for (int plane = 0; plane < 4; ++plane) glDisable(GL_CLIP_DISTANCE0 + plane);

  std::vector<uint8_t> atlas_pixels(size_t(width) * height * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, s.atlas.fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, atlas_pixels.data());
  releaseSoup();
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return Error{"renderRegions: OpenGL error " + std::to_string(error)};

  // Tile t of light band l → output tile t * lights + l (rows top first).
  for (int light = 0; light < lights_per_view; ++light)
    for (int t = 0; t < tile_count; ++t) {
      int x0 = (t % columns) * tile_size, y0 = light * band_height + (t / columns) * tile_size;
      uint8_t* out = batch.tile(t * lights_per_view + light);
      for (int row = 0; row < tile_size; ++row)
        std::copy_n(atlas_pixels.data() + (size_t(y0 + tile_size - 1 - row) * width + x0) * 4,
                    size_t(tile_size) * 4, out + size_t(row) * tile_size * 4);
    }
  local.chunks = 1;
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return batch;
}

}  // namespace duolod::render
