// The duolod command line: a thin layer over libduolod. Each subcommand parses flags, calls the
// library, and prints what a user needs; errors go to stderr with a non-zero exit code.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "duolod/core.hpp"
#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"

namespace {
namespace fs = std::filesystem;
using namespace duolod;

int fail(const std::string& message) {
  std::fprintf(stderr, "duolod: error: %s\n", message.c_str());
  return 1;
}

// Options shared by the commands that render.
struct ShadingFlags {
  std::string shader = "pbr";
  std::string vert, frag, bindings;
  int device = -1;
  float fov_y_deg = 45.0f;
  int screen_height = 1080;
  float distance = 0;
  int pixels = 0;

  void add(CLI::App* command) {
    command->add_option("--shader", shader,
                        "duolod shader by name (pbr, noise_phong, blend, constant) or a path "
                        "prefix P with P.vert and P.frag")
        ->capture_default_str();
    command->add_option("--vert", vert, "vertex shader (GLSL 450); needs --frag");
    command->add_option("--frag", frag, "fragment shader (GLSL 450); needs --vert");
    command->add_option("--bindings", bindings,
                        "JSON file mapping the shader's inputs (see shaders/INTERFACE.md)");
    command->add_option("--device", device,
                        "EGL device index; -1 = Mesa surfaceless (llvmpipe without a GPU)")
        ->capture_default_str();
    command->add_option("--fov", fov_y_deg, "display vertical field of view, degrees")
        ->capture_default_str();
    command->add_option("--screen-height", screen_height, "display height in pixels")
        ->capture_default_str();
  }

  core::Result<render::GlslSource> source() const {
    if (vert.empty() != frag.empty()) return core::Error{"--vert and --frag go together"};
    if (!vert.empty()) {
      auto read = [](const std::string& path) -> core::Result<std::string> {
        std::ifstream in(path);
        if (!in) return core::Error{path + ": shader file not found"};
        std::stringstream text;
        text << in.rdbuf();
        return text.str();
      };
      auto v = read(vert);
      if (!v) return v.error();
      auto f = read(frag);
      if (!f) return f.error();
      return render::GlslSource{*v, *f, vert, frag};
    }
    return render::loadShaderPair(shader);
  }

  render::Display display() const { return {fov_y_deg, screen_height}; }
};

struct Session {
  std::unique_ptr<render::Renderer> renderer;
  render::Renderer::ProgramId program = -1;
};

core::Result<Session> openSession(const ShadingFlags& flags) {
  auto source = flags.source();
  if (!source) return source.error();
  auto renderer = render::Renderer::create({.device = flags.device});
  if (!renderer) return renderer.error();
  if (!flags.bindings.empty()) {
    auto bytes = io::readFileBytes(flags.bindings);
    if (!bytes) return bytes.error();
    auto bindings = render::parseBindings(std::string(bytes->begin(), bytes->end()), flags.bindings);
    if (!bindings) return bindings.error();
    (*renderer)->setBindings(*bindings);
  }
  auto program = (*renderer)->compileProgram(*source);
  if (!program) return program.error();
  return Session{std::move(renderer.value()), *program};
}

core::Result<core::Asset> loadWithWarnings(const std::string& path) {
  auto asset = io::loadAsset(path);
  if (asset)
    for (const std::string& warning : asset->warnings)
      std::fprintf(stderr, "duolod: warning: %s: %s\n", path.c_str(), warning.c_str());
  return asset;
}

core::Status checkOutputPath(const std::string& out, const std::vector<std::string>& inputs,
                             bool force) {
  std::error_code ec;
  for (const std::string& input : inputs)
    if (fs::exists(out, ec) && fs::equivalent(out, input, ec))
      return core::Error{out + ": is an input file; refusing to overwrite it"};
  if (fs::exists(out, ec) && !force)
    return core::Error{out + ": already exists (use --force to replace it)"};
  return core::okStatus();
}

int runInfo(const std::string& path) {
  auto asset = loadWithWarnings(path);
  if (!asset) return fail(asset.error().message);
  const core::Mesh& mesh = asset->mesh;
  core::Bounds bounds = core::computeBounds(mesh);
  core::Sphere sphere = core::computeBoundingSphere(mesh);
  std::printf("%s\n", path.c_str());
  std::printf("  triangles   %zu\n  vertices    %zu\n  submeshes   %zu\n", mesh.triangleCount(),
              mesh.vertexCount(), mesh.submeshes.size());
  std::printf("  attributes  position%s%s%s%s%s\n", mesh.normals.empty() ? "" : " normal",
              mesh.tangents.empty() ? "" : " tangent", mesh.uv0.empty() ? "" : " uv0",
              mesh.uv1.empty() ? "" : " uv1", mesh.colors.empty() ? "" : " color");
  std::printf("  bounds      min (%g, %g, %g) max (%g, %g, %g)\n", bounds.min.x, bounds.min.y,
              bounds.min.z, bounds.max.x, bounds.max.y, bounds.max.z);
  std::printf("  sphere      centre (%g, %g, %g) radius %g\n", sphere.center.x, sphere.center.y,
              sphere.center.z, sphere.radius);
  std::printf("  materials   %zu\n", asset->materials.size());
  for (const core::Material& m : asset->materials) {
    std::printf("    %-24s baseColor (%.3g %.3g %.3g %.3g) metallic %.3g roughness %.3g%s%s%s%s%s\n",
                m.name.c_str(), m.base_color_factor.x, m.base_color_factor.y,
                m.base_color_factor.z, m.base_color_factor.w, m.metallic_factor,
                m.roughness_factor, m.base_color_texture >= 0 ? " +baseColorTex" : "",
                m.metallic_roughness_texture >= 0 ? " +metallicRoughnessTex" : "",
                m.normal_texture >= 0 ? " +normalTex" : "",
                m.occlusion_texture >= 0 ? " +occlusionTex" : "",
                m.emissive_texture >= 0 ? " +emissiveTex" : "");
  }
  std::printf("  textures    %zu\n", asset->textures.size());
  for (const core::Texture& t : asset->textures)
    std::printf("    %-40s %dx%d %s\n", t.name.c_str(), t.image.width, t.image.height,
                t.srgb ? "sRGB" : "linear");
  return 0;
}

float resolveDistance(const ShadingFlags& flags, const core::Sphere& sphere) {
  if (flags.distance > 0) return flags.distance;
  // --pixels N: the distance at which the object spans N pixels on the display.
  float screen_half = std::tan(flags.fov_y_deg * 3.14159265f / 360.0f);
  float tan_half = flags.pixels / float(flags.screen_height) * screen_half;
  float half_angle = std::atan(tan_half);
  return sphere.radius / std::sin(half_angle);
}

int runRender(const std::string& path, ShadingFlags& flags, int view, int light, int supersample,
              const std::string& out, bool force) {
  if ((flags.distance > 0) == (flags.pixels > 0))
    return fail("give exactly one of --distance D or --pixels N");
  if (auto ok = checkOutputPath(out, {path}, force); !ok) return fail(ok.error().message);
  auto asset = loadWithWarnings(path);
  if (!asset) return fail(asset.error().message);
  auto session = openSession(flags);
  if (!session) return fail(session.error().message);
  auto& renderer = *session->renderer;
  auto asset_id = renderer.uploadAsset(*asset);
  if (!asset_id) return fail(asset_id.error().message);
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  float distance = resolveDistance(flags, sphere);
  int resolution = render::footprintPixels(sphere, distance, flags.display());
  std::vector<render::Sample> all = render::domainSamples(sphere, distance);
  std::vector<render::Sample> chosen;
  for (const render::Sample& s : all)
    if ((view < 0 || s.view_index == view) && s.light_index == light) chosen.push_back(s);
  if (chosen.empty()) return fail("no such view/light (views 0-19, lights 0-4)");
  render::RenderOptions options{.resolution = resolution, .supersample = supersample};
  render::RenderStats stats;
  core::ImageRGBA8 image;
  if (supersample > 1) {
    auto batch = renderer.renderReference(*asset_id, session->program, chosen, options, &stats);
    if (!batch) return fail(batch.error().message);
    render::ImageBatch8 converted{batch->width, batch->height, batch->count, {}};
    for (int i = 0; i < batch->count; ++i) {
      core::ImageRGBA8 tile = render::tileImage(*batch, i);
      converted.pixels.insert(converted.pixels.end(), tile.pixels.begin(), tile.pixels.end());
    }
    image = view >= 0 ? render::tileImage(converted, 0) : render::contactSheet(converted, 5);
  } else {
    auto batch = renderer.render(*asset_id, session->program, chosen, options, &stats);
    if (!batch) return fail(batch.error().message);
    image = view >= 0 ? render::tileImage(*batch, 0) : render::contactSheet(*batch, 5);
  }
  if (auto written = io::writePng(image, out); !written) return fail(written.error().message);
  std::printf("%s: distance %g, footprint %d px, %zu image%s, %.3f s on %s\n", out.c_str(),
              distance, resolution, chosen.size(), chosen.size() == 1 ? "" : "s", stats.seconds,
              renderer.deviceDescription().c_str());
  return 0;
}

int runError(const std::string& path_a, const std::string& path_b, ShadingFlags& flags,
             int supersample, const metric::BoundConfig& bound) {
  if ((flags.distance > 0) == (flags.pixels > 0))
    return fail("give exactly one of --distance D or --pixels N");
  auto a = loadWithWarnings(path_a);
  if (!a) return fail(a.error().message);
  auto b = loadWithWarnings(path_b);
  if (!b) return fail(b.error().message);
  auto session = openSession(flags);
  if (!session) return fail(session.error().message);
  auto& renderer = *session->renderer;
  auto id_a = renderer.uploadAsset(*a);
  if (!id_a) return fail(id_a.error().message);
  auto id_b = renderer.uploadAsset(*b);
  if (!id_b) return fail(id_b.error().message);
  // Both are framed by A's bounding sphere so that their pixels correspond.
  core::Sphere sphere = core::computeBoundingSphere(a->mesh);
  float distance = resolveDistance(flags, sphere);
  int resolution = render::footprintPixels(sphere, distance, flags.display());
  std::vector<render::Sample> samples = render::domainSamples(sphere, distance);
  render::RenderOptions options{.resolution = resolution, .supersample = supersample};
  auto reference = renderer.renderReference(*id_a, session->program, samples, options);
  if (!reference) return fail(reference.error().message);
  options.supersample = 1;
  auto image = renderer.render(*id_b, session->program, samples, options);
  if (!image) return fail(image.error().message);
  metric::ImageError error = metric::imageError(*image, *reference);
  double e_a = metric::perPixelBound(bound, distance);
  bool ok = metric::withinBound(error, bound, distance);
  std::printf("distance %g  footprint %d px  samples %d (20 views x 5 lights)\n", distance,
              resolution, error.samples);
  std::printf("epsilon (eq. 6)      %.6g\n", error.epsilon);
  std::printf("coverage s_d         %.1f px\n", error.coverage_px);
  std::printf("per-pixel error      %.6g\n", error.per_pixel);
  std::printf("bound e_a(d)*s_d     %.6g  (e_a = %.4g: e_max %.3g, Q %.3g, d %g..%g)\n",
              e_a * error.coverage_px, e_a, bound.e_max, bound.q, bound.d_near, bound.d_far);
  std::printf("within bound         %s\n", ok ? "yes" : "no");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "duolod " DUOLOD_VERSION
      " - automatic mesh and shader level of detail.\n"
      "Simplifies a 3D asset's mesh and shader together and picks, for every viewing distance,\n"
      "the cheapest pair whose rendered image stays within an error bound (Liang et al.)."};
  app.set_version_flag("--version", std::string("duolod ") + DUOLOD_VERSION);
  app.require_subcommand(1);

  std::string info_path;
  CLI::App* info = app.add_subcommand("info", "Print an asset's counts, attributes, materials, bounds");
  info->add_option("asset", info_path, "glTF/GLB/OBJ/PLY/OFF file")->required();

  ShadingFlags render_flags;
  std::string render_path, render_out;
  int render_view = -1, render_light = 0, render_supersample = 1;
  bool render_force = false;
  CLI::App* render_cmd = app.add_subcommand(
      "render", "Render an asset from the paper's domain (a contact sheet of all 20 views, or one)");
  render_cmd->add_option("asset", render_path, "glTF/GLB/OBJ/PLY/OFF file")->required();
  render_flags.add(render_cmd);
  render_cmd->add_option("--distance", render_flags.distance,
                         "camera distance from the bounding-sphere centre, in asset units");
  render_cmd->add_option("--pixels", render_flags.pixels,
                         "alternatively: the distance at which the object spans N pixels");
  render_cmd->add_option("--view", render_view, "one view 0-19 (default: all, as a contact sheet)");
  render_cmd->add_option("--light", render_light, "light 0-4")->capture_default_str();
  render_cmd->add_option("--supersample", render_supersample,
                         "k: render k×k larger and box-filter (the reference of eq. 1)")
      ->capture_default_str();
  render_cmd->add_option("--out", render_out, "PNG to write")->required();
  render_cmd->add_flag("--force", render_force, "replace --out if it exists");

  ShadingFlags error_flags;
  std::string error_a, error_b;
  int error_supersample = 4;
  metric::BoundConfig bound;
  CLI::App* error_cmd = app.add_subcommand(
      "error", "Image error (eq. 6) of ASSET_B against the supersampled reference of ASSET_A");
  error_cmd->add_option("asset_a", error_a, "the original (reference) asset")->required();
  error_cmd->add_option("asset_b", error_b, "the approximation")->required();
  error_flags.add(error_cmd);
  error_cmd->add_option("--distance", error_flags.distance, "camera distance, asset units");
  error_cmd->add_option("--pixels", error_flags.pixels, "alternatively: footprint in pixels");
  error_cmd->add_option("--supersample", error_supersample, "reference supersampling k")
      ->capture_default_str();
  error_cmd->add_option("--e-max", bound.e_max, "maximum per-pixel error (eq. 4)")->capture_default_str();
  error_cmd->add_option("--q", bound.q, "quality falloff Q (eq. 4)")->capture_default_str();
  error_cmd->add_option("--d-near", bound.d_near, "nearest LOD distance (eq. 4)")->capture_default_str();
  error_cmd->add_option("--d-far", bound.d_far, "farthest LOD distance (eq. 4)")->capture_default_str();

  CLI11_PARSE(app, argc, argv);

  if (*info) return runInfo(info_path);
  if (*render_cmd)
    return runRender(render_path, render_flags, render_view, render_light, render_supersample,
                     render_out, render_force);
  if (*error_cmd) return runError(error_a, error_b, error_flags, error_supersample, bound);
  return 0;
}
