// Local re-rendering for image-driven simplification (Lindstrom & Turk, "Image-driven
// simplification", 2000; Liang et al. §3.2 "incremental image updates"). A collapse changes a few
// pixels of each view, so instead of redrawing whole views we draw, for many candidate changes at
// once, only the triangles around each change into a small tile of an atlas. The user's vertex
// stage is wrapped: after it computes gl_Position in its view's clip space, an affine map moves the
// vertex by whole pixels into its tile and four clip planes cut it to the tile, so every tile is
// rasterized exactly like the corresponding region of the full view.
#include <algorithm>
#include <array>
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

// Appended to the user's vertex shader, whose main() has been renamed duolod_user_main(). The
// vertex keeps the position the user's stage computed, so the rasterizer sees exactly the full
// view's window coordinates (moving it into an atlas tile by whole pixels in float NDC changed
// its 1/256-px snapping in wide atlases); it is sent to its tile's layer and clipped to the tile's
// region there.
constexpr const char* kWrapper = R"(
// ---- duolod region wrapper: the vertex's layer, clipped to its region ----
layout(std430, binding = 15) readonly buffer DuolodTilePlacement { vec4 duolod_tile[]; };
layout(location = 30) uniform vec4 duolod_atlas_transform;  // x lights per view, y this light
void main() {
  duolod_user_main();
  vec4 bounds = duolod_tile[gl_VertexID * 2];  // region min x, min y, max x, max y (view NDC)
  vec4 group = duolod_tile[gl_VertexID * 2 + 1];
  vec4 p = gl_Position;
  gl_ClipDistance[0] = p.x - bounds.x * p.w;
  gl_ClipDistance[1] = bounds.z * p.w - p.x;
  gl_ClipDistance[2] = p.y - bounds.y * p.w;
  gl_ClipDistance[3] = bounds.w * p.w - p.y;
  gl_Layer = int(group.x) * int(duolod_atlas_transform.x) + int(duolod_atlas_transform.y);
}
)";
constexpr const char* kLayerExtension = "#extension GL_ARB_shader_viewport_layer_array : require\n";

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

// Tiles [first, last) of a soup and their triangles, tile indices renumbered from 0.
Renderer::RegionSoup soupOfTiles(const Renderer::RegionSoup& soup, int first, int last) {
  Renderer::RegionSoup part;
  part.tiles.assign(soup.tiles.begin() + first, soup.tiles.begin() + last);
  const core::Mesh& all = soup.triangles;
  core::Mesh& kept = part.triangles;
  auto copyCorners = [](const auto& from, auto& to, size_t triangle) {
    if (!from.empty())
      to.insert(to.end(), from.begin() + triangle * 3, from.begin() + triangle * 3 + 3);
  };
  for (size_t t = 0; t < soup.triangle_tile.size(); ++t) {
    const uint32_t tile = soup.triangle_tile[t];
    if (tile < uint32_t(first) || tile >= uint32_t(last)) continue;
    part.triangle_tile.push_back(tile - uint32_t(first));
    part.triangle_material.push_back(soup.triangle_material[t]);
    copyCorners(all.positions, kept.positions, t);
    copyCorners(all.normals, kept.normals, t);
    copyCorners(all.tangents, kept.tangents, t);
    copyCorners(all.uv0, kept.uv0, t);
    copyCorners(all.uv1, kept.uv1, t);
    copyCorners(all.colors, kept.colors, t);
  }
  return part;
}

}  // namespace

core::Result<Renderer::ProgramId> Renderer::compileRegionProgram(const GlslSource& source) {
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
  if (!epoxy_has_gl_extension("GL_ARB_shader_viewport_layer_array"))
    return Error{"region rendering needs GL_ARB_shader_viewport_layer_array (gl_Layer written by "
                 "the vertex stage), which this OpenGL context lacks"};
  auto [begin, end] = findMainDefinition(source.vertex);
  if (begin == std::string::npos)
    return Error{source.vertex_name + ": no 'void main()' found to wrap for region rendering"};
  std::string wrapped = source.vertex;
  wrapped.replace(begin, end - begin, "void duolod_user_main()");
  if (wrapped.find("gl_PerVertex") != std::string::npos)
    return Error{source.vertex_name +
                 ": redeclares gl_PerVertex; region rendering needs gl_ClipDistance[4]"};
  wrapped += kWrapper;
  // The extension directive must precede the code: right after the #version line.
  size_t version = wrapped.find("#version");
  size_t line_end = version == std::string::npos ? 0 : wrapped.find('\n', version);
  wrapped.insert(line_end == std::string::npos ? wrapped.size() : line_end + 1, kLayerExtension);
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
  if (auto bound = state_->context.makeCurrent(); !bound) return bound.error();
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

  // Layers: tiles whose regions overlap (in any view: a layer is one view-sized canvas) go to
  // different groups; group g's tiles for light l are drawn in layer g * lights + l.
  const int R = view_resolution;
  std::vector<int> tile_group(tile_count);
  std::vector<std::vector<uint8_t>> occupied;
  auto regionOf = [&](const RegionTile& tile) {
    int w = tile.width > 0 ? std::min(tile.width, tile_size) : tile_size;
    int h = tile.height > 0 ? std::min(tile.height, tile_size) : tile_size;
    return std::array<int, 4>{std::clamp(tile.x0, 0, R), std::clamp(tile.y0, 0, R),
                              std::clamp(tile.x0 + w, 0, R), std::clamp(tile.y0 + h, 0, R)};
  };
  for (int t = 0; t < tile_count; ++t) {
    auto [x0, y0, x1, y1] = regionOf(soup.tiles[t]);
    size_t g = 0;
    for (;; ++g) {
      if (g == occupied.size()) occupied.emplace_back(size_t(R) * R, 0);
      bool free = true;
      for (int y = y0; y < y1 && free; ++y)
        for (int x = x0; x < x1 && free; ++x) free = !occupied[g][size_t(y) * R + x];
      if (free) break;
    }
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) occupied[g][size_t(y) * R + x] = 1;
    tile_group[t] = int(g);
  }
  const int layers = int(occupied.size()) * lights_per_view;
  GLint max_layers = 0, max_framebuffer_layers = 0;
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  glGetIntegerv(GL_MAX_FRAMEBUFFER_LAYERS, &max_framebuffer_layers);
  if (max_framebuffer_layers > 0) max_layers = std::min(max_layers, max_framebuffer_layers);
  if (layers > max_layers) {
    // More overlapping tiles than the device has layers (small views, where every tile overlaps
    // most others): draw the two halves of the tile list apart. Outputs are tile-major, so the
    // halves' batches are the whole one's, concatenated.
    if (tile_count < 2 || lights_per_view > max_layers)
      return Error{"renderRegions: one tile needs " + std::to_string(lights_per_view) +
                   " layers, more than the device's " + std::to_string(max_layers)};
    const int half = tile_count / 2;
    RenderStats total;
    for (auto [first, last] : {std::pair{0, half}, std::pair{half, tile_count}}) {
      RegionSoup part = soupOfTiles(soup, first, last);
      RenderStats part_stats;
      auto images = renderRegions(asset_id, program_id, part, samples, lights_per_view,
                                  view_resolution, tile_size, &part_stats);
      if (!images) return images.error();
      std::copy(images->pixels.begin(), images->pixels.end(),
                batch.pixels.begin() + ptrdiff_t(size_t(first) * lights_per_view) *
                                           tile_size * tile_size * 4);
      total.draws += part_stats.draws;
      total.chunks += part_stats.chunks;
      total.work += part_stats.work;
    }
    total.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stats) *stats = total;
    return batch;
  }
  if (s.region_size != R || s.region_layers < layers) {
    if (s.region_fbo) glDeleteFramebuffers(1, &s.region_fbo);
    GLuint old_textures[] = {s.region_color, s.region_depth};
    glDeleteTextures(2, old_textures);
    // Grown by doubling (fewer reallocations as batches grow), never past the device's limit.
    const int allocate = std::min<int>(
        max_layers, std::max(layers, s.region_size == R ? 2 * s.region_layers : layers));
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &s.region_color);
    glTextureStorage3D(s.region_color, 1, GL_RGBA8, R, R, allocate);
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &s.region_depth);
    glTextureStorage3D(s.region_depth, 1, GL_DEPTH_COMPONENT24, R, R, allocate);
    glCreateFramebuffers(1, &s.region_fbo);
    glNamedFramebufferTexture(s.region_fbo, GL_COLOR_ATTACHMENT0, s.region_color, 0);
    glNamedFramebufferTexture(s.region_fbo, GL_DEPTH_ATTACHMENT, s.region_depth, 0);
    if (glCheckNamedFramebufferStatus(s.region_fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      return Error{"renderRegions: the layered target is incomplete"};
    s.region_size = R;
    s.region_layers = allocate;
  }

  // Draw order: by view (one camera per draw), then material (one material per draw).
  std::vector<uint32_t> order(triangle_count);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    int va = soup.tiles[soup.triangle_tile[a]].view_index;
    int vb = soup.tiles[soup.triangle_tile[b]].view_index;
    return va != vb ? va < vb : soup.triangle_material[a] < soup.triangle_material[b];
  });

  // Per-vertex placement, in the sorted order: the region's bounds in the view's NDC (GL's y up)
  // and the tile's group.
  std::vector<float> placement(triangle_count * 3 * 8);
  for (size_t i = 0; i < triangle_count; ++i) {
    uint32_t t = soup.triangle_tile[order[i]];
    auto [x0, y0, x1, y1] = regionOf(soup.tiles[t]);
    const float r = float(R);
    float values[8] = {2 * x0 / r - 1, 2 * (r - y1) / r - 1, 2 * x1 / r - 1, 2 * (r - y0) / r - 1,
                       float(tile_group[t]), 0, 0, 0};
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
  Framebuffer target;
  target.fbo = s.region_fbo;
  target.width = target.height = R;
  beginDrawing(target);
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
      glUniform4f(kAtlasTransformLocation, float(lights_per_view), float(light), 0.0f, 0.0f);
      glDrawArrays(GL_TRIANGLES, GLint(run_start * 3), GLsizei((run_end - run_start) * 3));
      ++local.draws;
    }
    run_start = run_end;
  }
  for (int plane = 0; plane < 4; ++plane) glDisable(GL_CLIP_DISTANCE0 + plane);

  std::vector<uint8_t> layer_pixels(size_t(R) * R * 4 * layers);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureSubImage(s.region_color, 0, 0, 0, 0, R, R, layers, GL_RGBA, GL_UNSIGNED_BYTE,
                       GLsizei(layer_pixels.size()), layer_pixels.data());
  releaseSoup();
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return Error{"renderRegions: OpenGL error " + std::to_string(error)};

  // Tile t, light l → output tile t * lights + l: the region's pixels at its top-left, rows top
  // first (the layer's rows run up).
  for (int light = 0; light < lights_per_view; ++light)
    for (int t = 0; t < tile_count; ++t) {
      auto [x0, y0, x1, y1] = regionOf(soup.tiles[t]);
      const size_t layer = size_t(tile_group[t]) * lights_per_view + light;
      uint8_t* out = batch.tile(t * lights_per_view + light);
      for (int y = y0; y < y1; ++y)
        std::copy_n(layer_pixels.data() + ((layer * R + size_t(R - 1 - y)) * R + x0) * 4,
                    size_t(x1 - x0) * 4, out + size_t(y - y0) * tile_size * 4);
    }
  local.chunks = 1;
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return batch;
}

}  // namespace duolod::render
