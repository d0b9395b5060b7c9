// Local re-rendering for image-driven simplification (Lindstrom & Turk, "Image-driven
// simplification", 2000; Liang et al. §3.2 "incremental image updates"). A collapse changes a few
// pixels of each view, so instead of redrawing whole views we draw, for many candidate changes at
// once, only the triangles around each change into a small tile of an atlas. The user's vertex
// stage is wrapped: after it computes gl_Position in its view's clip space, an affine map moves the
// vertex by whole pixels into its tile and four clip planes cut it to the tile, so every tile is
// rasterized exactly like the corresponding region of the full view.
#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <numeric>
#include <optional>
#include <system_error>
#include <utility>

#include "render/renderer_internal.hpp"

namespace duolod::render {
namespace {
using core::Error;
using namespace internal;

constexpr int kTileDataBinding = 15;  // SSBO binding of per-vertex tile placement
// SSBO binding of the draw's light: (lights per view, this light). Not a uniform: a program's
// uniforms are shared by the contexts that share it, and two contexts draw different lights at
// once (State::drawing_threads); a buffer binding is each context's own.
constexpr int kLightLayerBinding = 14;

// Appended to the user's vertex shader, whose main() has been renamed duolod_user_main(). The
// vertex keeps the position the user's stage computed (moving it into an atlas tile by whole
// pixels in float NDC changed its 1/256-px snapping in wide atlases); it is sent to its tile's
// layer and column (a viewport moved by whole bins, as render()'s atlas moves its tiles) and
// clipped to the tile's region there.
constexpr const char* kWrapper = R"(
// ---- duolod region wrapper: the vertex's layer and column, clipped to its region ----
layout(std430, binding = 15) readonly buffer DuolodTilePlacement { vec4 duolod_tile[]; };
layout(std430, binding = 14) readonly buffer DuolodLight { vec4 duolod_light; };  // x lights per view, y this light
void main() {
  duolod_user_main();
  vec4 bounds = duolod_tile[gl_VertexID * 2];  // region min x, min y, max x, max y (view NDC)
  vec4 canvas = duolod_tile[gl_VertexID * 2 + 1];  // x layer group, y column
  vec4 p = gl_Position;
  gl_ClipDistance[0] = p.x - bounds.x * p.w;
  gl_ClipDistance[1] = bounds.z * p.w - p.x;
  gl_ClipDistance[2] = p.y - bounds.y * p.w;
  gl_ClipDistance[3] = bounds.w * p.w - p.y;
  gl_Layer = int(canvas.x) * int(duolod_light.x) + int(duolod_light.y);
  gl_ViewportIndex = int(canvas.y);
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

// The tiles `tiles` of a soup (in that order, renumbered from 0) and their triangles.
Renderer::RegionSoup soupOfTiles(const Renderer::RegionSoup& soup, std::span<const int> tiles) {
  constexpr uint32_t kNotTaken = ~0u;
  std::vector<uint32_t> renumbered(soup.tiles.size(), kNotTaken);
  Renderer::RegionSoup part;
  for (int t : tiles) {
    renumbered[t] = uint32_t(part.tiles.size());
    part.tiles.push_back(soup.tiles[t]);
  }
  const core::Mesh& all = soup.triangles;
  core::Mesh& kept = part.triangles;
  auto copyCorners = [](const auto& from, auto& to, size_t triangle) {
    if (!from.empty())
      to.insert(to.end(), from.begin() + triangle * 3, from.begin() + triangle * 3 + 3);
  };
  for (size_t t = 0; t < soup.triangle_tile.size(); ++t) {
    const uint32_t tile = renumbered[soup.triangle_tile[t]];
    if (tile == kNotTaken) continue;
    part.triangle_tile.push_back(tile);
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

std::vector<int> tileRange(int first, int last) {
  std::vector<int> tiles(size_t(last - first));
  std::iota(tiles.begin(), tiles.end(), first);
  return tiles;
}

// Below this many tiles a call is drawn in one context: handing half of it to the helper's thread
// costs more than it saves.
constexpr int kSplitMinimumTiles = 4;

// The tiles of the soup in two parts by view, for two drawing contexts: views in order, the first
// part until it holds about half the work (each tile's triangles, drawn once per light on the
// thread that draws, and its pixels, shaded per light by the rasterizer). Both parts keep the
// soup's tile order. `there` is empty when the soup is too small or one view holds everything.
void splitByViews(const Renderer::RegionSoup& soup, int view_count, int tile_size,
                  std::vector<int>& here, std::vector<int>& there) {
  const int tile_count = int(soup.tiles.size());
  if (tile_count < kSplitMinimumTiles) return;
  std::vector<double> tile_work(tile_count, 0), view_work(view_count, 0);
  for (uint32_t t : soup.triangle_tile) tile_work[t] += 3;  // three vertices a triangle
  for (int t = 0; t < tile_count; ++t) {
    const Renderer::RegionTile& tile = soup.tiles[t];
    const int w = tile.width > 0 ? std::min(tile.width, tile_size) : tile_size;
    const int h = tile.height > 0 ? std::min(tile.height, tile_size) : tile_size;
    view_work[tile.view_index] += tile_work[t] + double(w) * h;
  }
  const double total = std::accumulate(view_work.begin(), view_work.end(), 0.0);
  // The first views up to `last` go here: the boundary that leaves the parts most nearly equal.
  int last = -1;
  double sum = 0, best = total;
  for (int v = 0; v + 1 < view_count; ++v) {
    sum += view_work[v];
    if (std::abs(total - 2 * sum) < best) best = std::abs(total - 2 * sum), last = v;
  }
  for (int t = 0; t < tile_count; ++t)
    (soup.tiles[t].view_index <= last ? here : there).push_back(t);
  if (here.empty() || there.empty()) here.clear(), there.clear();
}

// What one drawing context needs for a renderRegions() call; the rest of the request is the same
// for every part.
struct RegionRequest {
  const GpuAsset* asset = nullptr;
  GLuint program = 0;
  std::span<const Sample> samples;
  int lights_per_view = 1, view_resolution = 0, tile_size = 0;
};

// Draws the soup's tiles with the current context into its `target` and reads them back: output
// tile t * lights + l for (tile t, light l). Tile t goes to the column columns[t] (0 or 1) of its
// layer: given by the caller, from the tile's place in the whole call, so that a tile's pixels do
// not depend on how the call was split (the second column's viewport can snap a vertex
// differently by 1/256 px).
core::Result<ImageBatch8> drawRegions(Renderer::State& s, RegionTarget& target,
                                      const RegionRequest& request,
                                      const Renderer::RegionSoup& soup,
                                      std::span<const uint8_t> columns, RenderStats* stats);

// Column i % 2 of each tile i of `tiles` (indices into the whole call).
std::vector<uint8_t> columnsOf(std::span<const int> tiles) {
  std::vector<uint8_t> columns(tiles.size());
  for (size_t i = 0; i < tiles.size(); ++i) columns[i] = uint8_t(tiles[i] % 2);
  return columns;
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
  GLint vertex_storage_blocks = 0;
  glGetIntegerv(GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS, &vertex_storage_blocks);
  if (vertex_storage_blocks < 2)
    return Error{"region rendering needs 2 shader storage blocks in the vertex stage; this OpenGL "
                 "context allows " + std::to_string(vertex_storage_blocks)};
  GlslSource region = source;
  region.vertex = std::move(wrapped);
  region.vertex_name = source.vertex_name + " (region wrapper)";
  auto program = compileProgram(region);
  if (program) state_->region_programs[state_->programs[*program]] = {std::move(region), {}, 0};
  return program;
}

namespace {

core::Result<ImageBatch8> drawRegions(Renderer::State& s, RegionTarget& target,
                                      const RegionRequest& request,
                                      const Renderer::RegionSoup& soup,
                                      std::span<const uint8_t> columns, RenderStats* stats) {
  using RegionSoup = Renderer::RegionSoup;
  using RegionTile = Renderer::RegionTile;
  const int tile_count = static_cast<int>(soup.tiles.size());
  const size_t triangle_count = soup.triangle_tile.size();
  const core::Mesh& mesh = soup.triangles;
  const int lights_per_view = request.lights_per_view, tile_size = request.tile_size;
  auto start = std::chrono::steady_clock::now();
  ImageBatch8 batch;
  batch.width = batch.height = tile_size;
  batch.count = tile_count * lights_per_view;
  batch.pixels.assign(size_t(batch.count) * tile_size * tile_size * 4, 0);
  // Nothing to draw (the regions show only background): the cleared target's zeros. (An empty
  // vertex buffer would be a GL error.)
  if (tile_count == 0 || triangle_count == 0) {
    if (stats) *stats = {};
    return batch;
  }

  // Canvases. A layer holds two view-sized canvases side by side, `column_offset` pixels apart
  // (a multiple of 64), so that they lie in different 64×64 bins: llvmpipe rasterizes a scene's
  // bins on its threads at once, and a single view-sized canvas (one bin at small footprints) kept
  // one thread busy (bench/RESULTS.md, issue 3, session 29). Tiles alternate between the columns
  // by their place in the whole call (`columns`), so the layout does not depend on the machine;
  // in a column, tiles whose regions overlap (in any view) go to different layers: tile t is
  // drawn for light l in layer tile_layer[t] * lights + l, column columns[t].
  const int R = request.view_resolution;
  const int column_offset = roundUp(std::max(R, 1), 64);
  if (size_t(column_offset) * 2 > size_t(s.max_size))
    return Error{"renderRegions: views of " + std::to_string(R) +
                 " px are too large for two columns of this device's " +
                 std::to_string(s.max_size) + "-px textures"};
  std::vector<int> tile_layer(tile_count);
  std::vector<std::vector<uint8_t>> occupied[2];
  auto regionOf = [&](const RegionTile& tile) {
    int w = tile.width > 0 ? std::min(tile.width, tile_size) : tile_size;
    int h = tile.height > 0 ? std::min(tile.height, tile_size) : tile_size;
    return std::array<int, 4>{std::clamp(tile.x0, 0, R), std::clamp(tile.y0, 0, R),
                              std::clamp(tile.x0 + w, 0, R), std::clamp(tile.y0 + h, 0, R)};
  };
  for (int t = 0; t < tile_count; ++t) {
    auto [x0, y0, x1, y1] = regionOf(soup.tiles[t]);
    std::vector<std::vector<uint8_t>>& column = occupied[columns[t]];
    size_t g = 0;
    for (;; ++g) {
      if (g == column.size()) column.emplace_back(size_t(R) * R, 0);
      bool free = true;
      for (int y = y0; y < y1 && free; ++y)
        for (int x = x0; x < x1 && free; ++x) free = !column[g][size_t(y) * R + x];
      if (free) break;
    }
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) column[g][size_t(y) * R + x] = 1;
    tile_layer[t] = int(g);
  }
  const int layers = int(std::max(occupied[0].size(), occupied[1].size())) * lights_per_view;
  const int width = 2 * column_offset;
  GLint max_layers = 0, max_framebuffer_layers = 0;
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  glGetIntegerv(GL_MAX_FRAMEBUFFER_LAYERS, &max_framebuffer_layers);
  if (max_framebuffer_layers > 0) max_layers = std::min(max_layers, max_framebuffer_layers);
  // And a memory budget: colour and depth, 4 bytes each, and the colour read back (large views
  // would otherwise take gigabytes, and the read-back size must fit a GLsizei).
  constexpr size_t kBudgetBytes = size_t(512) << 20;
  max_layers = int(std::min<size_t>(size_t(max_layers),
                                    std::max<size_t>(1, kBudgetBytes / (size_t(width) * R * 12))));
  if (layers > max_layers) {
    // More overlapping tiles than the device has layers (small views, where every tile overlaps
    // most others): draw the two halves of the tile list apart. Outputs are tile-major, so the
    // halves' batches are the whole one's, concatenated.
    if (tile_count < 2 || lights_per_view > max_layers)
      return Error{"renderRegions: one tile needs " + std::to_string(lights_per_view) +
                   " layers of " + std::to_string(width) + "x" + std::to_string(R) +
                   " px, more than fit (" + std::to_string(max_layers) +
                   ": the device's limit or 512 MB)"};
    const int half = tile_count / 2;
    RenderStats total;
    for (auto [first, last] : {std::pair{0, half}, std::pair{half, tile_count}}) {
      RegionSoup part = soupOfTiles(soup, tileRange(first, last));
      RenderStats part_stats;
      auto images = drawRegions(s, target, request, part, columns.subspan(first, last - first),
                                &part_stats);
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
  if (target.width != width || target.height != R || target.layers < layers) {
    const bool same_shape = target.width == width && target.height == R;
    const int grown = same_shape ? 2 * target.layers : layers;
    target.destroy();
    // Grown by doubling (fewer reallocations as batches grow), never past the device's limit.
    const int allocate = std::min<int>(max_layers, std::max(layers, grown));
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &target.color);
    glTextureStorage3D(target.color, 1, GL_RGBA8, width, R, allocate);
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &target.depth);
    glTextureStorage3D(target.depth, 1, GL_DEPTH_COMPONENT24, width, R, allocate);
    glCreateFramebuffers(1, &target.fbo);
    glNamedFramebufferTexture(target.fbo, GL_COLOR_ATTACHMENT0, target.color, 0);
    glNamedFramebufferTexture(target.fbo, GL_DEPTH_ATTACHMENT, target.depth, 0);
    if (glCheckNamedFramebufferStatus(target.fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      return Error{"renderRegions: the layered target is incomplete"};
    target.width = width;
    target.height = R;
    target.layers = allocate;
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
                       float(tile_layer[t]), float(columns[t]), 0, 0};
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
  const GpuAsset& asset = *request.asset;
  GpuAsset soup_asset;
  uploadVertexStreams(sorted, soup_asset);
  GLuint placement_buffer = addBuffer(soup_asset, placement.data(), placement.size() * sizeof(float));
  // (lights per view, light) of each light's draws, one entry per aligned offset.
  GLint light_alignment = 16;
  glGetIntegerv(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &light_alignment);
  const size_t light_stride = size_t(roundUp(4 * sizeof(float), std::max(light_alignment, 1)));
  std::vector<uint8_t> light_entries(light_stride * lights_per_view, 0);
  for (int light = 0; light < lights_per_view; ++light) {
    const float entry[4] = {float(lights_per_view), float(light), 0.0f, 0.0f};
    std::memcpy(light_entries.data() + light_stride * light, entry, sizeof entry);
  }
  GLuint light_buffer = addBuffer(soup_asset, light_entries.data(), light_entries.size());
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
  ChunkDrawer drawer{s, soup_asset, request.program};
  drawer.uploadFrames(request.samples, stride, target.frame_ubo, target.frame_ubo_size);

  RenderStats local;
  Framebuffer target_buffer;
  target_buffer.fbo = target.fbo;
  target_buffer.width = width;
  target_buffer.height = R;
  beginDrawing(target_buffer);
  glDisable(GL_SCISSOR_TEST);
  // The two columns' viewports: the view's own window coordinates, the second moved by whole
  // bins (as render()'s atlas moves its tiles by whole tiles).
  glViewportIndexedf(0, 0, 0, float(R), float(R));
  glViewportIndexedf(1, float(column_offset), 0, float(R), float(R));
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
      if (s.bindings.frame_block >= 0)  // -1: the shader reads no frame block
        glBindBufferRange(GL_UNIFORM_BUFFER, s.bindings.frame_block, target.frame_ubo,
                          stride * sample, sizeof(FrameBlock));
      glBindBufferRange(GL_SHADER_STORAGE_BUFFER, kLightLayerBinding, light_buffer,
                        GLintptr(light_stride * light), 4 * sizeof(float));
      glDrawArrays(GL_TRIANGLES, GLint(run_start * 3), GLsizei((run_end - run_start) * 3));
      ++local.draws;
    }
    run_start = run_end;
  }
  for (int plane = 0; plane < 4; ++plane) glDisable(GL_CLIP_DISTANCE0 + plane);

  std::vector<uint8_t> layer_pixels(size_t(width) * R * 4 * layers);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureSubImage(target.color, 0, 0, 0, 0, width, R, layers, GL_RGBA, GL_UNSIGNED_BYTE,
                       GLsizei(layer_pixels.size()), layer_pixels.data());
  releaseSoup();
  if (GLenum error = glGetError(); error != GL_NO_ERROR)
    return Error{"renderRegions: OpenGL error " + std::to_string(error)};

  // Tile t, light l → output tile t * lights + l: the region's pixels at its top-left, rows top
  // first (the layer's rows run up).
  for (int light = 0; light < lights_per_view; ++light)
    for (int t = 0; t < tile_count; ++t) {
      auto [x0, y0, x1, y1] = regionOf(soup.tiles[t]);
      const size_t layer = size_t(tile_layer[t]) * lights_per_view + light;
      const size_t column_x = size_t(columns[t]) * column_offset + x0;
      uint8_t* out = batch.tile(t * lights_per_view + light);
      for (int y = y0; y < y1; ++y)
        std::copy_n(
            layer_pixels.data() + ((layer * R + size_t(R - 1 - y)) * width + column_x) * 4,
            size_t(x1 - x0) * 4, out + size_t(y - y0) * tile_size * 4);
    }
  local.chunks = 1;
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return batch;
}

}  // namespace

void internal::RegionTarget::destroy() {
  if (fbo) glDeleteFramebuffers(1, &fbo);
  GLuint textures[] = {color, depth};
  glDeleteTextures(2, textures);
  if (frame_ubo) glDeleteBuffers(1, &frame_ubo);
  *this = {};
}

core::Result<std::unique_ptr<internal::RegionHelper>> internal::RegionHelper::start(
    const GlContext& share) {
  std::unique_ptr<RegionHelper> helper(new RegionHelper());
  std::promise<core::Status> started;
  std::future<core::Status> result = started.get_future();
  try {
    helper->thread_ = std::thread(&RegionHelper::loop, helper.get(), &share, &started);
  } catch (const std::system_error& e) {
    return Error{std::string("renderRegions: cannot start a second drawing thread: ") + e.what()};
  }
  core::Status status = result.get();  // `share` and `started` are not used after this
  if (!status) return status.error();  // the thread has ended: the destructor joins it
  return helper;
}

void internal::RegionHelper::loop(const GlContext* share, std::promise<core::Status>* started) {
  auto context = GlContext::createSharing(*share);
  if (!context) {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    started->set_value(context.error());
    return;
  }
  started->set_value(core::okStatus());
  Context objects;
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return stopping_ || job_; });
    if (!job_) break;  // stopping, nothing left to run
    auto job = std::move(job_);
    job_ = nullptr;
    lock.unlock();
    std::exception_ptr thrown;
    try {
      job(objects);
    } catch (...) {
      thrown = std::current_exception();  // rethrown by wait(), on the caller's thread
    }
    lock.lock();
    thrown_ = thrown;
    busy_ = false;
    changed_.notify_all();
  }
  lock.unlock();
  objects.target.destroy();
  for (const auto& [original, copy] : objects.programs) glDeleteProgram(copy.program);
}

void internal::RegionHelper::run(std::function<void(Context&)> job) {
  std::lock_guard lock(mutex_);
  job_ = std::move(job);
  busy_ = true;
  changed_.notify_all();
}

void internal::RegionHelper::wait() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return !busy_; });
  if (thrown_) std::rethrow_exception(std::exchange(thrown_, nullptr));
}

internal::RegionHelper::~RegionHelper() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    changed_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
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

  const RegionRequest request{&*s.assets[asset_id], s.programs[program_id],       samples,
                              lights_per_view,      view_resolution,             tile_size};
  const std::vector<uint8_t> columns = columnsOf(tileRange(0, tile_count));
  const internal::SlowRequestWatch watch(s.firstDraw(request.program, State::kRegionRequest),
                                         "rendering %d region%s of %d px, %d light%s each, with %s",
                                         tile_count, internal::pluralS(tile_count), tile_size,
                                         lights_per_view, internal::pluralS(lights_per_view),
                                         s.programName(request.program));
  // With a second drawing context (State::drawing_threads), the views go in two runs of about
  // equal work, one drawn here and one on the helper's thread at the same time, with its own copy
  // of the region program. A tile's pixels depend on its own triangles, view, light and column
  // alone, so the images are the same either way.
  std::vector<int> here, there;
  const auto region_program = s.region_programs.find(request.program);
  if (s.drawing_threads > 1 && region_program != s.region_programs.end() &&
      s.region_helper_failure.empty())
    splitByViews(soup, view_count, tile_size, here, there);
  if (!there.empty() && !s.region_helper) {
    auto helper = internal::RegionHelper::start(s.context);
    if (helper)
      s.region_helper = std::move(helper.value());
    else {
      // Drawn in this context from now on: the images are the same, only slower, so the run goes
      // on and the user is told why it is not using the second core.
      s.region_helper_failure = helper.error().message;
      core::log(core::LogLevel::kWarning,
                "render: the second drawing context could not start (" + s.region_helper_failure +
                    "); region renders use one context from now on");
    }
    if (auto bound = s.context.makeCurrent(); !bound) return bound.error();
  }
  if (there.empty() || !s.region_helper) {
    auto batch = drawRegions(s, s.region, request, soup, columns, stats);
    if (batch && stats)
      stats->seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return batch;
  }
  const RegionSoup near_part = soupOfTiles(soup, here), far_part = soupOfTiles(soup, there);
  const std::vector<uint8_t> near_columns = columnsOf(here), far_columns = columnsOf(there);
  // What this context made (the asset's buffers and textures, the parameter block) must be
  // complete before the helper's context reads it (GL 4.5 §5.3): a fence it waits for.
  GLsync made = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
  glFlush();
  std::optional<core::Result<ImageBatch8>> far_images;
  RenderStats near_stats, far_stats;
  const internal::RegionProgram& program = region_program->second;
  s.region_helper->run([&](internal::RegionHelper::Context& helper) {
    glWaitSync(made, 0, GL_TIMEOUT_IGNORED);
    internal::RegionHelper::Context::Copy& copy = helper.programs[request.program];
    if (copy.program == 0) {
      auto built = internal::buildProgram(program.source);
      if (!built) {
        helper.programs.erase(request.program);
        far_images = built.error();
        return;
      }
      copy.program = *built;
      copy.version = ~program.version;  // uniforms still to give
    }
    if (copy.version != program.version) {
      if (auto set = internal::setUniforms(copy.program, program.uniforms); !set) {
        far_images = set.error();
        return;
      }
      copy.version = program.version;
    }
    RegionRequest own = request;
    own.program = copy.program;
    far_images = drawRegions(s, helper.target, own, far_part, far_columns, &far_stats);
  });
  core::Result<ImageBatch8> near_images = ImageBatch8{};
  {
    // The helper's job refers to this frame: it is waited for however this block is left.
    struct WaitForHelper {
      internal::RegionHelper& helper;
      GLsync made;
      int unwinding = std::uncaught_exceptions();
      ~WaitForHelper() noexcept(false) {
        // Its exception goes to the caller, unless this frame is already unwinding with one.
        std::exception_ptr thrown;
        try {
          helper.wait();
        } catch (...) {
          thrown = std::current_exception();
        }
        glDeleteSync(made);  // after the helper's wait on it
        if (thrown && std::uncaught_exceptions() == unwinding) std::rethrow_exception(thrown);
      }
    } waiting{*s.region_helper, made};
    near_images = drawRegions(s, s.region, request, near_part, near_columns, &near_stats);
  }
  if (!near_images) return near_images.error();
  if (!far_images || !*far_images)
    return far_images ? far_images->error() : Error{"renderRegions: the helper drew nothing"};

  ImageBatch8 batch;
  batch.width = batch.height = tile_size;
  batch.count = tile_count * lights_per_view;
  batch.pixels.resize(size_t(batch.count) * tile_size * tile_size * 4);
  const size_t tile_bytes = size_t(tile_size) * tile_size * 4 * lights_per_view;
  for (auto [tiles, images] : {std::pair{&here, &near_images.value()},
                               std::pair{&there, &far_images->value()}})
    for (size_t i = 0; i < tiles->size(); ++i)
      std::copy_n(images->pixels.data() + i * tile_bytes, tile_bytes,
                  batch.pixels.data() + size_t((*tiles)[i]) * tile_bytes);
  if (stats) {
    *stats = {};
    stats->draws = near_stats.draws + far_stats.draws;
    stats->chunks = near_stats.chunks + far_stats.chunks;
    stats->work = near_stats.work;
    stats->work += far_stats.work;
    stats->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return batch;
}

}  // namespace duolod::render
