// Attributes (UVs, normals) stay sane through quadric simplification of real textured assets, and
// renders prove it (issue 3). Spot (OBJ, a 1024² texture, UV seams around head, legs and body) and
// WaterBottle (glTF, 2048² PBR textures, a vertical UV seam down the body and seams around the
// cap) are simplified to 50% and 10% with simplifyQuadric and rendered over the paper's domain (20
// views × 5 lights) at a footprint of 256 px, beside the original. The simplified mesh is compared
// with the original's plain render (same framing, same samples), so the error is the mesh change
// alone, without the aliasing floor a supersampled reference would add.
//
// Two renders:
//   - pbr, the shaded image a user sees: its per-pixel error (eq. 6 / covered pixels) must stay
//     small. It mixes everything (silhouettes, faceting, texture), so it shows a torn seam only
//     where the texture differs across it.
//   - a diagnostic UV render (red = u, green = v): a smooth UV field gives a smooth image, so a
//     seam torn or smeared by simplification shows as pixels whose UV is wrong by a large
//     amount, whatever the texture there.
//
// A control proves the measures catch broken attributes: the same mesh with its attribute seams
// destroyed before simplification (every wedge of a position takes the first wedge's attributes,
// so the triangles on the other side of a seam interpolate UVs across the texture atlas — the
// smear a seam-unaware simplifier produces), simplified to the same count. Its errors must be
// clearly larger.
//
// Contact sheets (rows: original, simplified, simplified with seams destroyed, |original −
// simplified| × 4, |original − seams destroyed| × 4; five views, light 0), pbr and UV, are written
// to the test's scratch folder (printed as "[ sheet ]") for a person to look at.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <span>

#include "duolod/io.hpp"
#include "duolod/mesh.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

constexpr int kFootprintPx = 256;
constexpr int kViews = 20;
constexpr int kSheetViews[] = {0, 4, 8, 12, 16};
// A pixel's UV is "torn" when its (u, v) is off by more than ~0.22 of the atlas (squared RGB
// distance > 0.05 in the UV render). Moving a vertex along a smooth UV field never does that at
// 256 px; interpolating across a seam (u jumping from one island to another) does.
constexpr double kTornUvSquared = 0.05;

// Every wedge of a position takes the attributes of the position's first wedge (the indices are
// redirected to it): no attribute seams are left, and the UVs and normals jump across the old ones.
core::Mesh weldByPositionOnly(const core::Mesh& input) {
  core::Mesh out = input;
  std::map<std::array<float, 3>, uint32_t> first;
  std::vector<uint32_t> remap(input.vertexCount());
  for (uint32_t v = 0; v < input.vertexCount(); ++v) {
    core::Vec3 p = input.positions[v];
    remap[v] = first.emplace(std::array<float, 3>{p.x, p.y, p.z}, v).first->second;
  }
  for (uint32_t& index : out.indices) index = remap[index];
  return out;  // the unreferenced duplicates are dropped by the simplifier
}

// Fraction of the pixels covered in both batches whose RGB differs by more than kTornUvSquared.
double tornFraction(const render::ImageBatch8& image, const render::ImageBatch8& reference) {
  size_t covered = 0, torn = 0;
  const size_t pixels = size_t(image.width) * image.height;
  for (int t = 0; t < image.count; ++t) {
    const uint8_t* a = image.tile(t);
    const uint8_t* b = reference.tile(t);
    for (size_t p = 0; p < pixels; ++p) {
      if (a[p * 4 + 3] != 255 || b[p * 4 + 3] != 255) continue;  // silhouettes are not UVs
      double squared = 0;
      for (int c = 0; c < 3; ++c) {
        double d = (int(a[p * 4 + c]) - int(b[p * 4 + c])) / 255.0;
        squared += d * d;
      }
      ++covered;
      torn += squared > kTornUvSquared;
    }
  }
  return covered ? double(torn) / double(covered) : 0.0;
}

// The diagnostic UV render: red = u, green = v (clamped to [0,1]), no lighting.
render::GlslSource uvShader() {
  const char* frame_block = R"(
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
)";
  render::GlslSource source;
  source.vertex = std::string("#version 450 core\n") + frame_block + R"(
layout(location = 0) in vec3 inPosition;
layout(location = 3) in vec2 inUV0;
layout(location = 0) out vec2 vUV;
void main() {
  vUV = inUV0;
  gl_Position = uProjection * (uView * (uModel * vec4(inPosition, 1.0)));
}
)";
  source.fragment = R"(#version 450 core
layout(location = 0) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() { outColor = vec4(clamp(vUV, 0.0, 1.0), 0.0, 1.0); }
)";
  source.vertex_name = "uv.vert";
  source.fragment_name = "uv.frag";
  return source;
}

// Thresholds for one asset at one ratio, set from measurement (llvmpipe, this commit's quadric
// simplifier) with a margin of about 2×; the measured values are in the comments at the call sites.
struct Limits {
  double ratio;
  double max_pbr_per_pixel;  // pbr: ε / covered pixels, simplified vs original
  double max_torn_fraction;  // UV render: share of torn pixels, simplified vs original
};

class AttributesRenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto created = render::Renderer::create();
    if (!created) {
      failure_ = created.error().message;
      return;
    }
    renderer_ = std::move(created.value()).release();
    auto pbr = render::loadShaderPair("pbr");
    if (!pbr) {
      failure_ = pbr.error().message;
      return;
    }
    auto pbr_program = renderer_->compileProgram(*pbr);
    auto uv_program = renderer_->compileProgram(uvShader());
    if (!pbr_program || !uv_program) {
      failure_ = !pbr_program ? pbr_program.error().message : uv_program.error().message;
      return;
    }
    pbr_program_ = *pbr_program;
    uv_program_ = *uv_program;
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }

  void SetUp() override {
    ASSERT_NE(renderer_, nullptr) << "no OpenGL 4.5 context: " << failure_;
    ASSERT_GE(uv_program_, 0) << failure_;
  }

  // The asset with `mesh` in place of its own, rendered over `samples`.
  static render::ImageBatch8 renderWith(const core::Asset& asset, const core::Mesh& mesh,
                                        render::Renderer::ProgramId program,
                                        std::span<const render::Sample> samples) {
    core::Asset copy = asset;
    copy.mesh = mesh;
    auto id = renderer_->uploadAsset(copy);
    EXPECT_TRUE(id) << id.error().message;
    if (!id) return {};
    auto images = renderer_->render(*id, program, samples, {.resolution = kFootprintPx});
    renderer_->releaseAsset(*id);
    EXPECT_TRUE(images) << images.error().message;
    return images ? std::move(*images) : render::ImageBatch8{};
  }

  // Rows of light-0 tiles of the sheet views: original, simplified, seams destroyed, then the
  // differences of the last two from the original, amplified 4×.
  static void writeSheet(const render::ImageBatch8& original, const render::ImageBatch8& simplified,
                         const render::ImageBatch8& destroyed, int lights_per_view,
                         const std::string& path) {
    render::ImageBatch8 sheet{original.width, original.height, 0, {}};
    const size_t tile_bytes = size_t(sheet.width) * sheet.height * 4;
    auto append = [&](const uint8_t* tile) {
      sheet.pixels.insert(sheet.pixels.end(), tile, tile + tile_bytes);
      ++sheet.count;
    };
    for (const render::ImageBatch8* row : {&original, &simplified, &destroyed})
      for (int view : kSheetViews) append(row->tile(view * lights_per_view));
    for (const render::ImageBatch8* row : {&simplified, &destroyed})
      for (int view : kSheetViews) {
        const uint8_t* a = original.tile(view * lights_per_view);
        const uint8_t* b = row->tile(view * lights_per_view);
        std::vector<uint8_t> diff(tile_bytes);
        for (size_t p = 0; p < tile_bytes / 4; ++p) {
          for (int c = 0; c < 3; ++c)
            diff[p * 4 + c] =
                uint8_t(std::min(255, 4 * std::abs(int(a[p * 4 + c]) - b[p * 4 + c])));
          diff[p * 4 + 3] = 255;
        }
        append(diff.data());
      }
    auto written = io::writePng(render::contactSheet(sheet, int(std::size(kSheetViews))), path);
    EXPECT_TRUE(written) << written.error().message;
    std::printf("[ sheet    ] %s\n", path.c_str());
  }

  // Simplifies the asset at each ratio, checks the limits, and checks that destroying the seams
  // first is caught. `pbr_catches_seams`: whether the shaded render shows the destroyed seams
  // clearly (it does where the texture differs across them).
  static void checkAsset(const std::string& path, const std::string& label,
                         std::initializer_list<Limits> limits, bool pbr_catches_seams) {
    auto asset = io::loadAsset(path);
    ASSERT_TRUE(asset) << asset.error().message;
    const core::Mesh& input = asset->mesh;
    ASSERT_FALSE(input.uv0.empty());
    ASSERT_FALSE(input.normals.empty());
    const core::Sphere sphere = core::computeBoundingSphere(input);
    const render::Display display;
    const float distance = render::distanceForDiameterPixels(sphere, kFootprintPx, display);
    ASSERT_NEAR(render::footprintPixels(sphere, distance, display), kFootprintPx, 1);
    const std::vector<render::Sample> samples = render::domainSamples(sphere, distance);
    const int lights_per_view = int(samples.size()) / kViews;
    const render::ImageBatch8 pbr_original = renderWith(*asset, input, pbr_program_, samples);
    const render::ImageBatch8 uv_original = renderWith(*asset, input, uv_program_, samples);
    ASSERT_EQ(pbr_original.count, int(samples.size()));
    ASSERT_EQ(uv_original.count, int(samples.size()));
    const core::Mesh seamless = weldByPositionOnly(input);
    const std::filesystem::path scratch = test::scratchDir("sheets");

    for (const Limits& limit : limits) {
      const int percent = int(std::lround(limit.ratio * 100));
      SCOPED_TRACE(label + " at " + std::to_string(percent) + "%");
      const size_t target = size_t(std::lround(double(input.triangleCount()) * limit.ratio));
      const mesh::SimplifyOptions options{.target_triangles = target, .record = false};
      const core::Mesh simplified = mesh::simplifyQuadric(input, options).mesh;
      const core::Mesh destroyed = mesh::simplifyQuadric(seamless, options).mesh;
      EXPECT_LE(simplified.triangleCount(), target + 1);
      EXPECT_LE(destroyed.triangleCount(), target + 1);
      ASSERT_EQ(simplified.uv0.size(), simplified.vertexCount());
      ASSERT_EQ(simplified.normals.size(), simplified.vertexCount());

      const render::ImageBatch8 pbr_simplified =
          renderWith(*asset, simplified, pbr_program_, samples);
      const render::ImageBatch8 pbr_destroyed =
          renderWith(*asset, destroyed, pbr_program_, samples);
      const render::ImageBatch8 uv_simplified =
          renderWith(*asset, simplified, uv_program_, samples);
      const render::ImageBatch8 uv_destroyed = renderWith(*asset, destroyed, uv_program_, samples);
      ASSERT_EQ(pbr_simplified.count, pbr_original.count);
      ASSERT_EQ(pbr_destroyed.count, pbr_original.count);
      ASSERT_EQ(uv_simplified.count, uv_original.count);
      ASSERT_EQ(uv_destroyed.count, uv_original.count);

      const double pbr_good = metric::imageError(pbr_simplified, pbr_original).per_pixel;
      const double pbr_bad = metric::imageError(pbr_destroyed, pbr_original).per_pixel;
      const double torn_good = tornFraction(uv_simplified, uv_original);
      const double torn_bad = tornFraction(uv_destroyed, uv_original);
      std::printf(
          "[ measured ] %s %d%%: %zu -> %zu triangles; pbr per-pixel %.5f (seams destroyed "
          "%.5f); torn UV pixels %.5f (seams destroyed %.5f)\n",
          label.c_str(), percent, input.triangleCount(), simplified.triangleCount(), pbr_good,
          pbr_bad, torn_good, torn_bad);

      EXPECT_LT(pbr_good, limit.max_pbr_per_pixel);
      EXPECT_LT(torn_good, limit.max_torn_fraction);
      // The control: the measured margins are 4.7× (WaterBottle 10%) to 100× (Spot 50%).
      EXPECT_GT(torn_bad, 3 * torn_good) << "destroyed seams are not caught by the UV render";
      if (pbr_catches_seams) {
        EXPECT_GT(pbr_bad, 2 * pbr_good) << "destroyed seams are not caught by the pbr render";
      }

      const std::string stem = (scratch / (label + "_" + std::to_string(percent) + "pct")).string();
      writeSheet(pbr_original, pbr_simplified, pbr_destroyed, lights_per_view, stem + "_pbr.png");
      writeSheet(uv_original, uv_simplified, uv_destroyed, lights_per_view, stem + "_uv.png");
    }
  }

  static inline render::Renderer* renderer_ = nullptr;
  static inline render::Renderer::ProgramId pbr_program_ = -1;
  static inline render::Renderer::ProgramId uv_program_ = -1;
  static inline std::string failure_;
};

// Measured: pbr per-pixel 0.0022 at 50% (below the plain render's own aliasing against a 4×4
// reference, 0.0039 at 256 px: bench/RESULTS.md) and 0.036 at 10% (facets, silhouettes and the
// texture's spot edges shifting by a pixel or two); torn UV pixels 0.0004 and 0.0080. With the
// seams destroyed: pbr 0.0052 and 0.109 (the texture smears across the legs and the neck), torn
// 0.040 and 0.074.
TEST_F(AttributesRenderTest, SpotKeepsUvsAndNormals) {
  DUOLOD_REQUIRE_ASSET(path, "obj/spot/spot.obj");
  checkAsset(path, "spot", {{0.5, 0.004, 0.002}, {0.1, 0.06, 0.015}}, /*pbr_catches_seams=*/true);
}

// Measured: pbr per-pixel 0.00064 at 50% and 0.0066 at 10%; torn UV pixels 0.0008 and 0.0063. With
// the seams destroyed: torn 0.018 and 0.030, but pbr 0.00058 and 0.0073 — the body's seam runs
// through nearly uniform texture, so the shaded image barely shows it (a faint stripe in the
// sheet); the UV render catches it.
TEST_F(AttributesRenderTest, WaterBottleKeepsUvsAndNormals) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  checkAsset(path, "waterbottle", {{0.5, 0.0015, 0.002}, {0.1, 0.012, 0.012}},
             /*pbr_catches_seams=*/false);
}

}  // namespace
}  // namespace duolod
