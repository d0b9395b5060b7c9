// The walk-through benchmark of Liang et al., "Automatic Mesh and Shader Level of Detail", §7.2.2
// (Tables 2 and 4, Fig. 4): ~400 instances of generated LOD assets on a ground plane, a camera
// walking through them, and the frame time of five configurations on the same path in the same
// run — no LOD, mesh-only LOD, shader-only LOD, separate (joint) LOD, interleaved (joint) LOD —
// each level chosen per object and frame by the runtime selector (include/duolod/runtime.hpp).
//
// Frame time is the wall clock from the clear to glFinish (DESIGN.md, "Measuring cost"); every
// frame is rendered once per configuration per repeat, the configurations alternated and their
// order rotated from frame to frame so drift hits all alike. A counting pass before the timed
// ones warms llvmpipe's shader variants up and records the deterministic work of every frame
// (vertex and fragment invocations, triangles) and the image error of each configuration against
// no LOD (eq. 6 summed over the frame) next to the bound of eq. (3) summed over the visible
// objects.
//
//   bench_walkthrough --object /work/runs/dragon:noise_phong --out out/walk-dragon
// reads /work/runs/dragon-{mesh,shader,sep,int} (`duolod generate --only mesh`, `--only shader`,
// default, `--optimizer interleaved`); several --object flags make a mixed scene. --quick (few
// objects, small display, few frames) generates Spot's four folders itself when no --object is
// given and checks only deterministic facts: it is the ctest test walkthrough_quick.

#include "runtime/walkthrough.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>
#include <thread>

#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "support/options.hpp"

using namespace duolod;
namespace fs = std::filesystem;

namespace {

// The five configurations, in the order of the paper's Table 2, and the folder suffix of each.
constexpr int kConfigurations = 5;
// A sixth, diagnostic entry is timed with them: the original meshes with duolod's `constant`
// shader (no lighting), i.e. the frame's vertex, raster and fixed cost without the shading.
constexpr int kTimed = kConfigurations + 1;
constexpr const char* kConfigurationNames[kTimed] = {
    "no LOD", "mesh LOD", "shader LOD", "separate LOD", "interleaved LOD",
    "(no LOD meshes, constant shader)"};
constexpr const char* kFolderSuffix[kConfigurations] = {"", "-mesh", "-shader", "-sep", "-int"};

// The ground: a checkerboard lit by the point light, written with alpha 0 so that alpha marks the
// objects' pixels (the s_d of eq. 3 for the frame).
constexpr const char* kGroundVertex = R"(#version 450 core
layout(location = 0) in vec3 inPosition;
layout(location = 3) in vec2 inUV0;
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) out vec3 vWorld;
layout(location = 1) out vec2 vUV;
void main() {
  vec4 world = uModel * vec4(inPosition, 1.0);
  vWorld = world.xyz;
  vUV = inUV0;
  gl_Position = uProjection * uView * world;
}
)";
constexpr const char* kGroundFragment = R"(#version 450 core
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) in vec3 vWorld;
layout(location = 1) in vec2 vUV;
layout(location = 0) out vec4 outColor;
void main() {
  vec2 cell = floor(vUV);
  float checker = mod(cell.x + cell.y, 2.0);
  vec3 albedo = mix(vec3(0.32, 0.30, 0.27), vec3(0.42, 0.40, 0.36), checker);
  float lit = max(dot(vec3(0.0, 1.0, 0.0), normalize(uLightPosition.xyz - vWorld)), 0.0);
  outColor = vec4(pow(albedo * (0.35 + 0.65 * lit), vec3(1.0 / 2.2)), 0.0);
}
)";

// The bound pass: every object pixel gets e_a(d) of eq. (4) at its object's distance, so the
// frame's bound Σ e_a(d)·pixels is exact per pixel (nearest surface wins, as in the image). The
// distance is the runtime's: eye to the bounding-sphere centre, in asset units on the display the
// LOD was made for. e_a / uScale.y is written as 16 bits, high byte in red, low byte in green.
// Its vertex stage is the constant shader's (position only).
constexpr const char* kBoundFragment = R"(#version 450 core
layout(std140, binding = 0) uniform Frame {
  mat4 uModel; mat4 uView; mat4 uProjection; mat4 uNormalMatrix;
  vec4 uCameraPosition; vec4 uLightPosition; vec4 uLightColor; vec4 uAmbientColor; vec4 uObjectInfo;
};
layout(location = 0) uniform vec4 uBound;  // d_near, d_far, Q, e_max
layout(location = 1) uniform vec4 uScale;   // display factor, 1 / the encoding's full scale
layout(location = 0) out vec4 outColor;
void main() {
  vec3 centre = (uModel * vec4(uObjectInfo.xyz, 1.0)).xyz;
  float distance = length(uCameraPosition.xyz - centre) / length(uModel[0].xyz) * uScale.x;
  float t = clamp((distance - uBound.x) / max(uBound.y - uBound.x, 1e-9), 0.0, 1.0);
  float value = clamp(pow(t, uBound.z) * uBound.w * uScale.y, 0.0, 1.0) * 65535.0;
  float high = floor(value / 256.0);
  outColor = vec4(high / 255.0, (value - high * 256.0) / 255.0, 0.0, 1.0);
}
)";

struct ObjectSpec {
  std::string prefix, shader, asset;  // asset empty: lod.json's asset.source
};
core::Result<ObjectSpec> parseObject(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ':');) parts.push_back(part);
  if (parts.size() < 2 || parts.size() > 3 || parts[0].empty() || parts[1].empty())
    return core::Error{"--object " + text + ": expected FOLDER_PREFIX:SHADER[:ASSET]"};
  return ObjectSpec{parts[0], parts[1], parts.size() == 3 ? parts[2] : ""};
}

struct Percentiles {
  double mean = 0, median = 0, p10 = 0, p90 = 0;
};
Percentiles percentiles(std::vector<double> values) {
  Percentiles p;
  if (values.empty()) return p;
  std::sort(values.begin(), values.end());
  for (double v : values) p.mean += v / values.size();
  p.median = core::median(values);
  auto at = [&](double q) { return values[size_t(std::lround(q * (values.size() - 1)))]; };
  p.p10 = at(0.1);
  p.p90 = at(0.9);
  return p;
}

// The anti-aliased frame f̄ of eq. (1): `big` (factor × the display on each side) box-filtered
// to the display, RGBA in [0, 1] (alpha: object coverage; the ground writes 0).
std::vector<float> boxFiltered(const core::ImageRGBA8& big, int factor) {
  const int w = big.width / factor, h = big.height / factor;
  std::vector<float> rgba(size_t(w) * h * 4, 0.0f);
  const float weight = 1.0f / (255.0f * factor * factor);
  for (int y = 0; y < big.height; ++y)
    for (int x = 0; x < big.width; ++x) {
      const uint8_t* p = &big.pixels[(size_t(y) * big.width + x) * 4];
      float* out = &rgba[(size_t(y / factor) * w + x / factor) * 4];
      for (int c = 0; c < 4; ++c) out[c] += p[c] * weight;
    }
  return rgba;
}

// Σ over the objects' pixels of |rgb − rgb_reference|² (RGB in [0, 1]): eq. (6) for one frame,
// against the anti-aliased frame as the paper's bound is (§3.3: errors are measured against f̄).
// Pixels where neither image has an object are left out: there only the ground's own aliasing
// differs, which no LOD changes and the objects' bound does not cover.
double frameSquaredError(const core::ImageRGBA8& image, const std::vector<float>& reference) {
  double sum = 0;
  for (size_t i = 0; i < image.pixels.size(); i += 4) {
    if (image.pixels[i + 3] == 0 && reference[i + 3] == 0) continue;
    for (int c = 0; c < 3; ++c) {
      double d = image.pixels[i + c] / 255.0 - reference[i + c];
      sum += d * d;
    }
  }
  return sum;
}

// Σ over pixels of the bound pass's e_a (decoded from 16 bits), divided by factor² when the pass
// was rendered factor × larger: fractional coverage at the silhouettes, as f̄ has.
double boundSum(const core::ImageRGBA8& image, double full_scale, int factor) {
  double sum = 0;
  for (size_t i = 0; i < image.pixels.size(); i += 4)
    if (image.pixels[i + 3] > 0)
      sum += (image.pixels[i] * 256.0 + image.pixels[i + 1]) / 65535.0 * full_scale;
  return sum / (double(factor) * factor);
}

// Box-filters `image` down by `factor` into the strip at (x0, y0).
void pasteReduced(const core::ImageRGBA8& image, int factor, core::ImageRGBA8& strip, int x0,
                  int y0) {
  const int w = image.width / factor, h = image.height / factor;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 4; ++c) {
        int sum = 0;
        for (int dy = 0; dy < factor; ++dy)
          for (int dx = 0; dx < factor; ++dx)
            sum += image.pixels[(size_t(y * factor + dy) * image.width + x * factor + dx) * 4 + c];
        strip.pixels[(size_t(y0 + y) * strip.width + x0 + x) * 4 + c] =
            c == 3 ? 255 : uint8_t(sum / (factor * factor));
      }
}

// Runs `duolod generate` for Spot's four folders with quick settings (the test's LOD input).
core::Result<std::string> generateQuickFolders(const fs::path& directory) {
#ifdef DUOLOD_CLI
  const std::string spot = std::string(DUOLOD_ASSET_DIR) + "/obj/spot/spot.obj";
  if (!fs::exists(spot)) return core::Error{"missing asset " + spot};
  fs::create_directories(directory);
  const std::string prefix = (directory / "spot").string();
  for (int c = 1; c < kConfigurations; ++c) {
    const std::string out = prefix + kFolderSuffix[c];
    if (fs::exists(fs::path(out) / "lod.json")) continue;  // reuse an earlier run's folders
    std::string command = std::string("'") + DUOLOD_CLI + "' generate '" + spot +
                          "' --shader noise_phong --mesh-mode quadric --levels 3 "
                          "--shader-levels 1 --population 6 --generations 2 --candidates 40 "
                          "--near-pixels 128 --quiet --force --out '" + out + "'";
    if (c == 1) command += " --only mesh";
    if (c == 2) command += " --only shader";
    if (c == 4) command += " --optimizer interleaved";
    command += " > '" + out + ".log' 2>&1";
    std::printf("generating %s ...\n", out.c_str());
    std::fflush(stdout);
    if (std::system(command.c_str()) != 0)
      return core::Error{"duolod generate failed; see " + out + ".log"};
  }
  return prefix + ":noise_phong";
#else
  (void)directory;
  return core::Error{"built without DUOLOD_CLI: pass --object"};
#endif
}

struct FrameRecord {
  runtime::FrameSelector::Frame selection;
  render::WorkCounts work;
  std::vector<uint64_t> level_fragments;  // fragment invocations per level (ground excluded)
  int draws = 0;
  double error = -1, bound = -1;  // -1: not measured at this frame
  std::vector<double> seconds;    // one per timed repeat
};

}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{"duolod walk-through benchmark (Liang et al. §7.2.2, Table 2)"};
  std::vector<std::string> object_texts;
  std::string out_dir = "out/walkthrough", scene_name;
  runtime::WalkSceneOptions scene_options;
  int width = 1280, height = 720, repeats = 3, strip_frames = 3, strip_reduce = 4,
      error_every = 1, reference_supersample = 4;
  float fov_y_deg = 45;
  bool quick = false;
  std::vector<int> dump_frames;
  app.add("--object", object_texts,
          "FOLDER_PREFIX:SHADER[:ASSET]: reads PREFIX-mesh, -shader, -sep, -int "
          "(repeat for a mixed scene)");
  app.add("--name", scene_name, "scene name in the table (default: the prefixes)");
  app.add("--out", out_dir, "folder for walkthrough.md, frames.csv, strip.png");
  app.add("--objects", scene_options.objects);
  app.add("--frames", scene_options.frames, "camera poses on the path");
  app.add("--seed", scene_options.seed);
  app.add("--spacing", scene_options.spacing, "grid step in object radii");
  app.flag("--compound", scene_options.compound,
           "each grid point holds one model made of every --object, as parts on a ring "
           "around it, each part with its own LOD (the paper's Table 4, the Trooper); "
           "--objects counts models");
  app.add("--width", width);
  app.add("--height", height);
  app.add("--fov", fov_y_deg, "vertical field of view, degrees");
  app.add("--repeats", repeats, "timed passes over the path per configuration");
  app.add("--error-every", error_every, "image error at every Nth frame (0: none)");
  app.add("--reference-supersample", reference_supersample,
          "the image error's reference: no LOD rendered K×K larger and box-filtered (the "
          "anti-aliased f̄ the bound is defined against); 1 = the plain no-LOD frame");
  app.add("--strip-frames", strip_frames);
  app.add("--strip-reduce", strip_reduce, "strip images are 1/N of the display");
  app.add("--dump-frames", dump_frames,
          "also write these frames of every configuration at full size, as "
          "frame-F-C.png (C: 0 no LOD ... 4 interleaved)");
  app.flag("--quick", quick,
           "36 objects, 320x180, 8 frames, 1 repeat; generates Spot's folders when no "
           "--object; exits 1 when a deterministic check fails");
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;
  if (quick) {
    scene_options.objects = 36;
    scene_options.frames = 8;
    width = 320;
    height = 180;
    repeats = 1;
    strip_reduce = 1;
    strip_frames = 2;
  }
  auto fail = [](const std::string& message) {
    std::fprintf(stderr, "bench_walkthrough: %s\n", message.c_str());
    return 1;
  };
  if (width < 16 || height < 16 || repeats < 1 || scene_options.frames < 1 ||
      scene_options.objects < 1 || strip_reduce < 1)
    return fail("bad sizes: width/height >= 16, repeats, frames, objects, strip-reduce >= 1");
  fs::create_directories(out_dir);
  if (object_texts.empty()) {
    if (!quick) return fail("give at least one --object FOLDER_PREFIX:SHADER");
    auto generated = generateQuickFolders(fs::path(out_dir) / "lod");
    if (!generated) return fail(generated.error().message);
    object_texts.push_back(*generated);
  }

  // ---- Load the folders, the original assets and shaders.
  auto renderer_result = render::Renderer::create();
  if (!renderer_result) return fail(renderer_result.error().message);
  render::Renderer& renderer = **renderer_result;
  const bool can_count = renderer.canCountWork();
  const render::Display display{.fov_y_deg = fov_y_deg, .height_px = height};

  std::vector<runtime::Configuration> configurations(kTimed);
  for (int c = 0; c < kTimed; ++c) configurations[c].name = kConfigurationNames[c];
  auto constant_shader = render::loadShaderPair("constant");
  if (!constant_shader) return fail(constant_shader.error().message);
  std::vector<core::Asset> originals;
  std::vector<std::array<double, kConfigurations>> generation_seconds;
  std::vector<std::string> warnings;
  std::string default_name;
  for (const std::string& text : object_texts) {
    auto spec = parseObject(text);
    if (!spec) return fail(spec.error().message);
    default_name += (default_name.empty() ? "" : "+") + fs::path(spec->prefix).filename().string();
    std::array<runtime::LodFolder, kConfigurations> folders;
    std::array<double, kConfigurations> seconds{};
    for (int c = 1; c < kConfigurations; ++c) {
      auto folder = runtime::loadLodFolder(spec->prefix + kFolderSuffix[c]);
      if (!folder) return fail(folder.error().message);
      if (!folder->lists_parameters)
        warnings.push_back(folder->directory +
                           "/lod.json lists no shader parameters (made before they were "
                           "exported): moved-to-parameter values draw as 0");
      seconds[c] = folder->generation_seconds;
      folders[c] = std::move(*folder);
    }
    generation_seconds.push_back(seconds);
    std::string asset_path = spec->asset.empty() ? folders[3].asset_source : spec->asset;
    auto asset = io::loadAsset(asset_path);
    if (!asset) return fail(asset.error().message + " (give the asset as PREFIX:SHADER:ASSET)");
    auto shader = render::loadShaderPair(spec->shader);
    if (!shader) return fail(shader.error().message);
    auto original = runtime::uploadOriginal(renderer, *asset, *shader, folders[3], display);
    if (!original) return fail(original.error().message);
    configurations[0].kinds.push_back(std::move(*original));
    auto geometry_only =
        runtime::uploadOriginal(renderer, *asset, *constant_shader, folders[3], display);
    if (!geometry_only) return fail(geometry_only.error().message);
    configurations[kConfigurations].kinds.push_back(std::move(*geometry_only));
    for (int c = 1; c < kConfigurations; ++c) {
      auto levels = runtime::uploadLevels(renderer, *asset, folders[c], display);
      if (!levels) return fail(levels.error().message);
      configurations[c].kinds.push_back(std::move(*levels));
    }
    originals.push_back(std::move(*asset));
  }
  if (scene_name.empty()) scene_name = default_name;

  std::vector<const core::Mesh*> kinds;
  for (const core::Asset& asset : originals) kinds.push_back(&asset.mesh);
  const runtime::WalkScene scene = runtime::buildWalkScene(kinds, scene_options);
  core::Asset ground;
  ground.mesh = runtime::groundMesh(scene.half_extent);
  ground.materials.push_back(core::Material{.name = "ground"});
  auto ground_asset = renderer.uploadAsset(ground);
  if (!ground_asset) return fail(ground_asset.error().message);
  auto ground_program = renderer.compileProgram(
      render::GlslSource{kGroundVertex, kGroundFragment, "ground.vert", "ground.frag"});
  if (!ground_program) return fail(ground_program.error().message);
  const render::InstanceBatch ground_batch{.asset = *ground_asset,
                                           .program = *ground_program,
                                           .models = {core::Mat4::identity()}};

  // The bound pass's programs, one per kind (its eq. (4) configuration and display factor).
  double bound_full_scale = 0;
  for (const runtime::KindLevels& kind : configurations[0].kinds)
    bound_full_scale = std::max(bound_full_scale, double(kind.bound.e_max));
  std::vector<render::Renderer::ProgramId> bound_programs;
  for (const runtime::KindLevels& kind : configurations[0].kinds) {
    auto program = renderer.compileProgram(
        render::GlslSource{constant_shader->vertex, kBoundFragment, constant_shader->vertex_name,
                           "bound.frag"});
    if (!program) return fail(program.error().message);
    const std::vector<render::UniformValue> uniforms = {
        {.location = 0,
         .components = 4,
         .value = {kind.bound.d_near, kind.bound.d_far, kind.bound.q, kind.bound.e_max}},
        {.location = 1,
         .components = 4,
         .value = {float(kind.display_factor), float(1.0 / std::max(bound_full_scale, 1e-9)), 0,
                   0}}};
    if (auto set = renderer.setProgramUniforms(*program, uniforms); !set)
      return fail(set.error().message);
    bound_programs.push_back(*program);
  }

  const int frames = static_cast<int>(scene.path.size());
  std::vector<render::SceneCamera> cameras;
  for (const runtime::CameraPose& pose : scene.path)
    cameras.push_back(runtime::sceneCamera(pose, width, height, fov_y_deg));
  std::vector<int> strip_at;
  for (int i = 0; i < strip_frames; ++i)
    strip_at.push_back(std::min(frames - 1, (2 * i + 1) * frames / (2 * strip_frames)));

  // ---- Counting pass: level selection, work counters, image errors, the strip; warms llvmpipe.
  std::printf("scene %s: %zu objects, %d frames at %dx%d; device %s; %u hardware threads\n",
              scene_name.c_str(), scene.instances.size(), frames, width, height,
              renderer.deviceDescription().c_str(), std::thread::hardware_concurrency());
  std::fflush(stdout);
  std::vector<std::vector<FrameRecord>> records(kTimed, std::vector<FrameRecord>(frames));
  std::vector<runtime::FrameSelector> selectors;
  for (const runtime::Configuration& configuration : configurations)
    selectors.emplace_back(configuration, scene);
  const int strip_w = width / strip_reduce, strip_h = height / strip_reduce;
  core::ImageRGBA8 strip{.width = strip_w * kConfigurations + (kConfigurations - 1) * 4,
                         .height = strip_h * int(strip_at.size()) + (int(strip_at.size()) - 1) * 4,
                         .pixels = {}};
  strip.pixels.assign(size_t(strip.width) * strip.height * 4, 255);
  auto drawFrame = [&](int c, int f, const render::SceneOptions& options) {
    std::vector<render::InstanceBatch> batches = records[c][f].selection.batches;
    batches.push_back(ground_batch);
    return renderer.renderScene(batches, cameras[f], options);
  };
  const int supersample = std::max(1, reference_supersample);
  for (int f = 0; f < frames; ++f) {
    const bool strip_frame = std::find(strip_at.begin(), strip_at.end(), f) != strip_at.end();
    const bool error_frame = error_every > 0 && f % error_every == 0;
    const bool dump_frame =
        std::find(dump_frames.begin(), dump_frames.end(), f) != dump_frames.end();
    for (int c = 0; c < kTimed; ++c)
      records[c][f].selection = selectors[c].select(scene.path[f], cameras[f]);
    // The anti-aliased no-LOD frame: the same camera on a display `supersample` times larger.
    std::vector<float> reference;
    double frame_bound = 0;
    if (error_frame) {
      render::SceneCamera big = cameras[f];
      big.width *= supersample;
      big.height *= supersample;
      const runtime::FrameSelector::Frame& no_lod = records[0][f].selection;
      std::vector<render::InstanceBatch> batches = no_lod.batches;
      batches.push_back(ground_batch);
      auto frame = renderer.renderScene(batches, big, {.read_back = true});
      if (!frame) return fail("the supersampled reference: " + frame.error().message);
      reference = boxFiltered(frame->image, supersample);
      // eq. (3) summed over the frame: Σ over the objects' pixels of e_a(d) at their distance.
      batches.pop_back();
      for (size_t b = 0; b < batches.size(); ++b)
        batches[b].program = bound_programs[no_lod.batch_kinds[b]];
      auto bound_frame = renderer.renderScene(batches, big, {.read_back = true});
      if (!bound_frame) return fail("the bound pass: " + bound_frame.error().message);
      frame_bound = boundSum(bound_frame->image, bound_full_scale, supersample);
    }
    for (int c = 0; c < kTimed; ++c) {
      FrameRecord& record = records[c][f];
      const bool read_back = c < kConfigurations && (strip_frame || error_frame || dump_frame);
      auto frame = drawFrame(
          c, f, {.read_back = read_back, .count_work = can_count, .count_work_per_batch = can_count});
      if (!frame) return fail(frame.error().message);
      record.work = frame->work;
      const std::vector<int>& batch_levels = record.selection.batch_levels;
      for (size_t b = 0; b < frame->batch_work.size() && b < batch_levels.size(); ++b) {
        const size_t level = static_cast<size_t>(batch_levels[b]);
        if (record.level_fragments.size() <= level) record.level_fragments.resize(level + 1, 0);
        record.level_fragments[level] += frame->batch_work[b].fragment_invocations;
      }
      record.draws = frame->draws;
      if (frame->image.pixels.empty()) continue;
      if (dump_frame) {
        const std::string name = "frame-" + std::to_string(f) + "-" + std::to_string(c) + ".png";
        if (auto ok = io::writePng(frame->image, (fs::path(out_dir) / name).string()); !ok)
          return fail(ok.error().message);
      }
      if (error_frame) {
        record.error = frameSquaredError(frame->image, reference);
        record.bound = frame_bound;
      }
      if (strip_frame) {
        const int row = int(std::find(strip_at.begin(), strip_at.end(), f) - strip_at.begin());
        pasteReduced(frame->image, strip_reduce, strip, c * (strip_w + 4), row * (strip_h + 4));
      }
    }
  }
  if (auto ok = io::writePng(strip, (fs::path(out_dir) / "strip.png").string()); !ok)
    return fail(ok.error().message);

  // ---- Timed passes: every frame once per configuration per repeat, order rotated per frame.
  std::vector<double> ground_only;
  for (int r = 0; r < repeats; ++r)
    for (int f = 0; f < frames; ++f) {
      for (int j = 0; j < kTimed; ++j) {
        const int c = (j + f + r) % kTimed;
        auto frame = drawFrame(c, f, {});
        if (!frame) return fail(frame.error().message);
        records[c][f].seconds.push_back(frame->seconds);
      }
      auto fixed = renderer.renderScene(std::span(&ground_batch, 1), cameras[f], {});
      if (!fixed) return fail(fixed.error().message);
      ground_only.push_back(fixed->seconds);
    }

  // ---- Summaries.
  struct Summary {
    Percentiles ms;
    double vertices = 0, fragments = 0, triangles = 0, draws = 0;  // per frame
    double error_ratio_max = 0, error_ratio_median = 0;
    // (error − no LOD's error) / bound: what the LOD adds to the original's own aliasing, which
    // level 0 (the original, exempt from the bound: e_a(d_near) = 0) keeps in every configuration.
    double added_ratio_max = 0, added_ratio_median = 0;
    std::vector<long> levels;  // instance-frames per level
    std::vector<double> level_fragments;  // object fragment invocations per level, summed
  };
  std::vector<Summary> summaries(kTimed);
  for (int c = 0; c < kTimed; ++c) {
    Summary& summary = summaries[c];
    std::vector<double> frame_ms, ratios, added;
    for (int f = 0; f < frames; ++f) {
      const FrameRecord& record = records[c][f];
      if (record.error >= 0 && record.bound > 0)
        added.push_back((record.error - records[0][f].error) / record.bound);
      frame_ms.push_back(core::median(record.seconds) * 1e3);
      summary.vertices += double(record.work.vertex_invocations) / frames;
      summary.fragments += double(record.work.fragment_invocations) / frames;
      summary.triangles += double(record.work.primitives_submitted) / frames;
      summary.draws += double(record.draws) / frames;
      if (record.error >= 0 && record.bound > 0) ratios.push_back(record.error / record.bound);
      const auto& histogram = record.selection.level_histogram;
      if (summary.levels.size() < histogram.size()) summary.levels.resize(histogram.size(), 0);
      for (size_t k = 0; k < histogram.size(); ++k) summary.levels[k] += histogram[k];
      if (summary.level_fragments.size() < record.level_fragments.size())
        summary.level_fragments.resize(record.level_fragments.size(), 0);
      for (size_t k = 0; k < record.level_fragments.size(); ++k)
        summary.level_fragments[k] += double(record.level_fragments[k]);
    }
    summary.ms = percentiles(frame_ms);
    if (!ratios.empty()) {
      summary.error_ratio_max = *std::max_element(ratios.begin(), ratios.end());
      summary.error_ratio_median = core::median(ratios);
      summary.added_ratio_max = *std::max_element(added.begin(), added.end());
      summary.added_ratio_median = core::median(added);
    }
  }
  const Percentiles fixed_ms = [&] {
    for (double& s : ground_only) s *= 1e3;
    return percentiles(ground_only);
  }();

  std::ostringstream md;
  char line[1024];
  std::snprintf(line, sizeof line,
                "### %s — %zu objects, %d frames, %dx%d, %d timed repeats\n\n"
                "Frame time: mean over the path of each frame's median over repeats (ms), the "
                "speedup of that mean against no LOD, and the 10th–90th percentile over frames. "
                "Ground only (clear + ground): %.2f ms median. Error/bound: eq. (6) over the frame "
                "against the no-LOD frame rendered %d×%d larger and box-filtered (f̄, what the "
                "bound is defined against; no LOD's own row is its aliasing), over the frame's "
                "bound Σ e_a(d) over the objects' pixels (each at its object's distance); added: "
                "(error − no LOD's error) / bound, what the LOD adds to the original's own "
                "aliasing (level 0 is the original in every configuration).\n\n",
                scene_name.c_str(), scene.instances.size(), frames, width, height, repeats,
                fixed_ms.median, supersample, supersample);
  md << line;
  md << "| configuration | frame ms | speedup | p10–p90 ms | vertex inv./frame | fragment "
        "inv./frame | triangles/frame | draws/frame | error/bound median (max) | added/bound "
        "median (max) | instance-frames per level | object fragments per level |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n";
  for (int c = 0; c < kTimed; ++c) {
    const Summary& s = summaries[c];
    std::string levels;
    for (size_t k = 0; k < s.levels.size(); ++k)
      levels += (k ? " / " : "") + std::to_string(s.levels[k]);
    // Where the shading goes: each level's share of the objects' fragment invocations.
    double object_fragments = 0;
    for (double count : s.level_fragments) object_fragments += count;
    std::string fragment_shares;
    for (size_t k = 0; k < s.level_fragments.size(); ++k) {
      char share[16];
      std::snprintf(share, sizeof share, "%.0f%%",
                    object_fragments > 0 ? 100 * s.level_fragments[k] / object_fragments : 0.0);
      fragment_shares += (k ? " / " : "") + std::string(share);
    }
    std::snprintf(line, sizeof line,
                  "| %s | %.2f | %.2fx | %.2f–%.2f | %.0f | %.0f | %.0f | %.0f | %s | %s | %s | %s |\n",
                  kConfigurationNames[c], s.ms.mean, summaries[0].ms.mean / s.ms.mean, s.ms.p10,
                  s.ms.p90, s.vertices, s.fragments, s.triangles, s.draws,
                  c == kConfigurations ? "—"
                         : (std::to_string(s.error_ratio_median).substr(0, 5) + " (" +
                            std::to_string(s.error_ratio_max).substr(0, 5) + ")")
                               .c_str(),
                  c == 0 || c == kConfigurations
                      ? "—"
                      : (std::to_string(s.added_ratio_median).substr(0, 5) + " (" +
                         std::to_string(s.added_ratio_max).substr(0, 5) + ")")
                            .c_str(),
                  levels.c_str(), fragment_shares.c_str());
    md << line;
  }
  md << "\nLOD generation time (s, from FOLDER.log):";
  for (size_t k = 0; k < generation_seconds.size(); ++k)
    for (int c = 1; c < kConfigurations; ++c) {
      std::snprintf(line, sizeof line, " %s%s %s;", originals.size() > 1 ? (std::to_string(k) + ":").c_str() : "",
                    kConfigurationNames[c],
                    generation_seconds[k][c] >= 0
                        ? (std::to_string(std::lround(generation_seconds[k][c]))).c_str()
                        : "n/a");
      md << line;
    }
  md << "\n";
  for (const std::string& warning : warnings) md << "\nWarning: " << warning << "\n";
  std::printf("\n%s", md.str().c_str());
  if (auto ok = io::writeFileAtomic((fs::path(out_dir) / "walkthrough.md").string(), md.str()); !ok)
    return fail(ok.error().message);

  std::ostringstream csv;
  csv << "frame,configuration,ms_median,vertex_invocations,fragment_invocations,triangles,draws,"
         "visible,error,bound\n";
  for (int f = 0; f < frames; ++f)
    for (int c = 0; c < kTimed; ++c) {
      const FrameRecord& r = records[c][f];
      std::snprintf(line, sizeof line, "%d,\"%s\",%.3f,%llu,%llu,%llu,%d,%d,%.4g,%.4g\n", f,
                    kConfigurationNames[c], core::median(r.seconds) * 1e3,
                    (unsigned long long)r.work.vertex_invocations,
                    (unsigned long long)r.work.fragment_invocations,
                    (unsigned long long)r.work.primitives_submitted, r.draws, r.selection.visible,
                    r.error, r.bound);
      csv << line;
    }
  if (auto ok = io::writeFileAtomic((fs::path(out_dir) / "frames.csv").string(), csv.str()); !ok)
    return fail(ok.error().message);
  std::printf("wrote %s/{walkthrough.md, frames.csv, strip.png (rows: frames %s; columns: no, "
              "mesh, shader, separate, interleaved LOD)}\n",
              out_dir.c_str(), [&] {
                std::string list;
                for (int f : strip_at) list += (list.empty() ? "" : ",") + std::to_string(f);
                return list;
              }().c_str());
  if (!quick) return 0;

  // ---- --quick: deterministic checks only (levels chosen, work shrinks with LOD).
  int failures = 0;
  auto check = [&](bool ok, const std::string& what) {
    std::printf("check  %-4s %s\n", ok ? "ok" : "FAIL", what.c_str());
    if (!ok) ++failures;
  };
  if (!can_count) return fail("quick checks need ARB_pipeline_statistics_query");
  for (int c = 1; c < kConfigurations; ++c) {
    size_t most_levels = 0;
    for (const runtime::KindLevels& kind : configurations[c].kinds)
      most_levels = std::max(most_levels, kind.policy.levels.size());
    size_t used = 0;
    for (long count : summaries[c].levels) used += count > 0;
    if (most_levels > 1)
      check(used >= 2, std::string(kConfigurationNames[c]) + ": the selector used " +
                           std::to_string(used) + " of " + std::to_string(most_levels) +
                           " levels along the path");
  }
  auto total = [&](int c, uint64_t render::WorkCounts::*field) {
    uint64_t sum = 0;
    for (const FrameRecord& record : records[c]) sum += record.work.*field;
    return sum;
  };
  for (int c : {1, 3, 4}) {
    check(total(c, &render::WorkCounts::primitives_submitted) <
              total(0, &render::WorkCounts::primitives_submitted),
          std::string(kConfigurationNames[c]) + " submits fewer triangles than no LOD");
    check(total(c, &render::WorkCounts::vertex_invocations) <
              total(0, &render::WorkCounts::vertex_invocations),
          std::string(kConfigurationNames[c]) + " shades fewer vertices than no LOD");
  }
  check(total(2, &render::WorkCounts::primitives_submitted) ==
            total(0, &render::WorkCounts::primitives_submitted),
        "shader LOD keeps the original mesh: as many triangles as no LOD");
  // Counters are deterministic: frame 0 again gives the same work.
  for (int c = 0; c < kConfigurations; ++c) {
    auto again = drawFrame(c, 0, {.count_work = true});
    if (!again) return fail(again.error().message);
    check(again->work.vertex_invocations == records[c][0].work.vertex_invocations &&
              again->work.fragment_invocations == records[c][0].work.fragment_invocations &&
              again->work.primitives_submitted == records[c][0].work.primitives_submitted,
          std::string(kConfigurationNames[c]) + ": frame 0's work counts repeat exactly");
  }
  std::printf("%s\n", failures == 0 ? "all checks passed" : "SOME CHECKS FAILED");
  return failures == 0 ? 0 : 1;
}
