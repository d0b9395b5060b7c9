// The walk-through scene (Liang et al. §7.2.2): loading `duolod generate` folders, the seeded
// field of instances and the camera path, and per-frame level selection and batching.
#include "runtime/walkthrough.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <sstream>

#include "duolod/io.hpp"

namespace duolod::runtime {
namespace {

namespace fs = std::filesystem;
using core::Error;

double numberAt(const JsonValue& root, std::initializer_list<const char*> path, double fallback) {
  const JsonValue* value = &root;
  for (const char* key : path) {
    value = value->find(key);
    if (!value) return fallback;
  }
  return value->number(fallback);
}

core::Result<std::vector<uint32_t>> readWords(const fs::path& path) {
  auto bytes = io::readFileBytes(path.string());
  if (!bytes) return bytes.error();
  if (bytes->empty() || bytes->size() % 4 != 0)
    return Error{path.string() + ": not a SPIR-V binary (size " + std::to_string(bytes->size()) +
                 " bytes is not a positive multiple of 4)"};
  std::vector<uint32_t> words(bytes->size() / 4);
  std::memcpy(words.data(), bytes->data(), bytes->size());
  return words;
}

// "time      mesh ... total 123.4 s" in the generator's printed summary.
double generationSecondsFromLog(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  double seconds = -1;
  while (std::getline(in, line)) {
    if (line.rfind("time", 0) != 0) continue;
    size_t at = line.find("total ");
    if (at != std::string::npos) seconds = std::strtod(line.c_str() + at + 6, nullptr);
  }
  return seconds;
}

// A deterministic uniform double in [0, 1) (std distributions differ between libraries).
double unit(std::mt19937_64& random) { return double(random() >> 11) * 0x1.0p-53; }

core::Mat4 translation(core::Vec3 t) {
  core::Mat4 m = core::Mat4::identity();
  m.at(0, 3) = t.x;
  m.at(1, 3) = t.y;
  m.at(2, 3) = t.z;
  return m;
}
core::Mat4 scaling(float s) {
  core::Mat4 m = core::Mat4::identity();
  m.at(0, 0) = m.at(1, 1) = m.at(2, 2) = s;
  return m;
}
core::Mat4 turnAboutY(float radians) {
  core::Mat4 m = core::Mat4::identity();
  m.at(0, 0) = std::cos(radians);
  m.at(0, 2) = std::sin(radians);
  m.at(2, 0) = -std::sin(radians);
  m.at(2, 2) = std::cos(radians);
  return m;
}

// Pixels per unit of (size / distance) on a display: height / (2·tan(fov/2)).
double focalPixels(const render::Display& display) {
  return display.height_px / (2.0 * std::tan(display.fov_y_deg * std::numbers::pi / 360.0));
}

}  // namespace

core::Result<LodFolder> loadLodFolder(const std::string& directory) {
  LodFolder folder;
  folder.directory = directory;
  const fs::path root(directory);
  const std::string json_path = (root / "lod.json").string();
  auto text = io::readFileBytes(json_path);
  if (!text) return text.error();
  const std::string_view json(reinterpret_cast<const char*>(text->data()), text->size());
  JsonValue document;
  std::string error;
  if (!JsonValue::parse(json, document, &error)) return Error{json_path + ": " + error};
  if (!policyFromJson(document, folder.policy, &error)) return Error{json_path + ": " + error};

  const JsonValue* asset = document.find("asset");
  const JsonValue* sphere = asset ? asset->find("bounding_sphere") : nullptr;
  const JsonValue* center = sphere ? sphere->find("center") : nullptr;
  if (!center || center->items().size() != 3)
    return Error{json_path + ": asset.bounding_sphere.center must be 3 numbers"};
  folder.bounds.center = {float(center->items()[0].number()), float(center->items()[1].number()),
                          float(center->items()[2].number())};
  folder.bounds.radius = float(numberAt(*sphere, {"radius"}, 0));
  if (!(folder.bounds.radius > 0))
    return Error{json_path + ": asset.bounding_sphere.radius must be positive"};
  // `source` is relative to lod.json's folder (files written before session 28: to wherever
  // generate ran, tried second).
  if (const JsonValue* source = asset->find("source")) {
    namespace fs = std::filesystem;
    folder.asset_source = source->string();
    const fs::path beside = fs::path(json_path).parent_path() / folder.asset_source;
    std::error_code ec;
    if (fs::path(folder.asset_source).is_relative() && fs::exists(beside, ec))
      folder.asset_source = beside.lexically_normal().string();
  }
  folder.display.fov_y_deg = float(numberAt(document, {"display", "fov_y_deg"}, 45));
  folder.display.height_px = int(numberAt(document, {"display", "height_px"}, 1080));
  folder.bound.d_near = float(numberAt(document, {"bound", "d_near"}, 1));
  folder.bound.d_far = float(numberAt(document, {"bound", "d_far"}, 10));
  folder.bound.q = float(numberAt(document, {"bound", "q"}, 0.5));
  folder.bound.e_max = float(numberAt(document, {"bound", "e_max"}, 0.1));
  if (const JsonValue* optimizer = document.find("optimizer"))
    folder.optimizer = optimizer->string();
  if (const JsonValue* levels = document.find("levels"); levels && !levels->items().empty()) {
    const JsonValue* shader = levels->items().front().find("shader");
    folder.lists_parameters = shader && shader->find("parameters");
  }

  for (size_t k = 0; k < folder.policy.levels.size(); ++k) {
    const Level& level = folder.policy.levels[k];
    const std::string where = json_path + ": levels[" + std::to_string(k) + "]";
    // "lod.gltf#node3": node 3 of the chain.
    std::string file = level.mesh;
    int node = -1;
    if (size_t hash = file.find("#node"); hash != std::string::npos) {
      node = std::atoi(file.c_str() + hash + 5);
      file.resize(hash);
    }
    if (file.empty()) return Error{where + ".mesh is empty"};
    io::LoadOptions options;
    options.load_textures = false;  // materials and textures come from the original asset
    options.gltf_node = node;
    auto mesh = io::loadAsset((root / file).string(), options);
    if (!mesh) return Error{where + ": " + mesh.error().message};
    folder.meshes.push_back(std::move(mesh->mesh));

    auto vertex = level.shader_files.find("spirv_vert");
    auto fragment = level.shader_files.find("spirv_frag");
    if (vertex == level.shader_files.end() || fragment == level.shader_files.end())
      return Error{where + ".shader.files needs spirv_vert and spirv_frag"};
    render::SpirvBinary binary;
    auto vertex_words = readWords(root / vertex->second);
    if (!vertex_words) return vertex_words.error();
    auto fragment_words = readWords(root / fragment->second);
    if (!fragment_words) return fragment_words.error();
    binary.vertex = std::move(*vertex_words);
    binary.fragment = std::move(*fragment_words);
    folder.shaders.push_back(std::move(binary));
  }
  fs::path log = root;
  log += ".log";
  folder.generation_seconds = generationSecondsFromLog(log);
  return folder;
}

// ---------------------------------------------------------------------------------------------

WalkScene buildWalkScene(std::span<const core::Mesh* const> kinds,
                         const WalkSceneOptions& options) {
  WalkScene scene;
  if (kinds.empty() || options.objects < 1) return scene;
  struct KindFrame {
    core::Sphere sphere;
    float lowest = 0;
  };
  std::vector<KindFrame> frames;
  for (const core::Mesh* mesh : kinds)
    frames.push_back({core::computeBoundingSphere(*mesh), core::computeBounds(*mesh).min.y});

  std::mt19937_64 random(options.seed);
  const int columns = static_cast<int>(std::ceil(std::sqrt(double(options.objects))));
  const float step = options.spacing;
  scene.half_extent = 0.5f * columns * step + step;
  // One object of `kind` standing at (x, z) (its sphere centred over it, its lowest point on the
  // ground), turned by `turn`, scaled to radius 1.
  auto place = [&](int kind, float x, float z, float turn) {
    const KindFrame& frame = frames[kind];
    const float scale = 1.0f / frame.sphere.radius;
    const core::Vec3 pivot{frame.sphere.center.x, frame.lowest, frame.sphere.center.z};
    WalkInstance instance;
    instance.kind = kind;
    instance.scale = scale;
    instance.model = translation({x, 0, z}) * turnAboutY(turn) * scaling(scale) *
                     translation(-pivot);
    instance.center = core::transformPoint(instance.model, frame.sphere.center);
    scene.instances.push_back(instance);
  };
  for (int i = 0; i < options.objects; ++i) {
    const int column = i % columns, row = i / columns;
    const int kind = static_cast<int>(unit(random) * kinds.size()) % int(kinds.size());
    const float x = (column - 0.5f * (columns - 1)) * step +
                    float(unit(random) * 2 - 1) * options.jitter * step;
    const float z = (row - 0.5f * (columns - 1)) * step +
                    float(unit(random) * 2 - 1) * options.jitter * step;
    const float turn = float(unit(random) * 2 * std::numbers::pi);
    if (!options.compound || kinds.size() == 1) {
      place(kind, x, z, turn);
      continue;
    }
    // The model's parts on a ring around (x, z), the ring turned with the model.
    for (size_t part = 0; part < kinds.size(); ++part) {
      const float angle = turn + float(2 * std::numbers::pi * double(part) / double(kinds.size()));
      place(int(part), x + options.part_ring * std::sin(angle),
            z + options.part_ring * std::cos(angle), turn);
    }
  }

  // The corridor between the two middle columns (a grid line when the count is odd, so shift by
  // half a step then), walked from outside the field to its far side.
  const float corridor_x = (columns % 2 == 0 ? 0.0f : 0.5f * step);
  const float start_z = -0.5f * columns * step - 2 * step, end_z = 0.5f * columns * step;
  const int frame_count = std::max(1, options.frames);
  for (int f = 0; f < frame_count; ++f) {
    const float t = frame_count == 1 ? 0.0f : float(f) / float(frame_count - 1);
    const float z = start_z + t * (end_z - start_z);
    const float sway = 0.35f * std::sin(float(2 * std::numbers::pi) * 1.5f * t);  // radians
    const core::Vec3 eye{corridor_x, options.eye_height, z};
    const core::Vec3 target =
        eye + core::Vec3{std::sin(sway), -0.08f, std::cos(sway)} * 10.0f;
    scene.path.push_back({eye, target});
  }
  return scene;
}

core::Mesh groundMesh(float half_extent) {
  core::Mesh mesh;
  const float h = half_extent;
  mesh.positions = {{-h, 0, -h}, {h, 0, -h}, {h, 0, h}, {-h, 0, h}};
  mesh.normals.assign(4, {0, 1, 0});
  const float repeat = half_extent;  // one texture tile per world unit pair
  mesh.uv0 = {{0, 0}, {repeat, 0}, {repeat, repeat}, {0, repeat}};
  mesh.indices = {0, 2, 1, 0, 3, 2};  // counter-clockwise seen from above
  mesh.submeshes = {{0, 6, 0}};
  return mesh;
}

// ---------------------------------------------------------------------------------------------

core::Result<KindLevels> uploadLevels(render::Renderer& renderer, const core::Asset& materials,
                                      const LodFolder& folder, const render::Display& display) {
  KindLevels levels;
  levels.policy = folder.policy;
  levels.bound = folder.bound;
  levels.display_factor = focalPixels(folder.display) / focalPixels(display);
  auto carrier = renderer.uploadAsset(materials);
  if (!carrier) return carrier.error();
  for (size_t k = 0; k < folder.meshes.size(); ++k) {
    auto asset = renderer.uploadMesh(*carrier, folder.meshes[k]);
    if (!asset) return Error{folder.directory + ": level " + std::to_string(k) + ": " +
                             asset.error().message};
    auto program = renderer.compileProgram(folder.shaders[k]);
    if (!program) return Error{folder.directory + ": level " + std::to_string(k) + " shader: " +
                               program.error().message};
    std::vector<render::UniformValue> uniforms;
    for (const Level::Parameter& parameter : folder.policy.levels[k].shader_parameters) {
      render::UniformValue value;
      value.location = parameter.location;
      value.components = static_cast<int>(parameter.value.size());
      std::copy(parameter.value.begin(), parameter.value.end(), value.value.begin());
      uniforms.push_back(value);
    }
    if (!uniforms.empty())
      if (auto set = renderer.setProgramUniforms(*program, uniforms); !set)
        return Error{folder.directory + ": level " + std::to_string(k) + ": " +
                     set.error().message};
    levels.assets.push_back(*asset);
    levels.programs.push_back(*program);
  }
  return levels;
}

core::Result<KindLevels> uploadOriginal(render::Renderer& renderer, const core::Asset& asset,
                                        const render::GlslSource& shader,
                                        const LodFolder& reference,
                                        const render::Display& display) {
  KindLevels levels;
  Level original;
  original.triangles = asset.mesh.triangleCount();
  levels.policy.levels.push_back(original);
  levels.bound = reference.bound;
  levels.display_factor = focalPixels(reference.display) / focalPixels(display);
  auto uploaded = renderer.uploadAsset(asset);
  if (!uploaded) return uploaded.error();
  auto program = renderer.compileProgram(shader);
  if (!program) return program.error();
  levels.assets.push_back(*uploaded);
  levels.programs.push_back(*program);
  return levels;
}

// ---------------------------------------------------------------------------------------------

FrameSelector::FrameSelector(const Configuration& configuration, const WalkScene& scene,
                             SelectorOptions options)
    : configuration_(configuration), scene_(scene) {
  selectors_.reserve(scene.instances.size());
  for (const WalkInstance& instance : scene.instances)
    selectors_.emplace_back(configuration.kinds[instance.kind].policy, options);
}

FrameSelector::Frame FrameSelector::select(const CameraPose& pose,
                                           const render::SceneCamera& camera) {
  Frame frame;
  // Frustum planes of projection · view (Gribb & Hartmann), normalised: a sphere is outside when
  // its centre is more than its radius behind any plane.
  const core::Mat4 clip = camera.projection * camera.view;
  std::array<std::array<float, 4>, 6> planes;
  for (int p = 0; p < 6; ++p) {
    const int axis = p / 2;
    const float sign = p % 2 == 0 ? 1.0f : -1.0f;
    float length = 0;
    for (int c = 0; c < 4; ++c) {
      planes[p][c] = clip.at(3, c) + sign * clip.at(axis, c);
      if (c < 3) length += planes[p][c] * planes[p][c];
    }
    length = std::sqrt(length);
    for (float& v : planes[p]) v /= length;
  }

  struct Pick {
    int level, kind;
    float distance;
    size_t instance;
  };
  std::vector<Pick> picks;
  for (size_t i = 0; i < scene_.instances.size(); ++i) {
    const WalkInstance& instance = scene_.instances[i];
    const float radius = 1.0f;  // instances are scaled to radius 1
    bool inside = true;
    for (const auto& plane : planes)
      if (plane[0] * instance.center.x + plane[1] * instance.center.y +
              plane[2] * instance.center.z + plane[3] < -radius)
        inside = false;
    if (!inside) continue;
    const float distance = core::length(instance.center - pose.eye);
    const KindLevels& kind = configuration_.kinds[instance.kind];
    const double equivalent = distance / instance.scale * kind.display_factor;
    const Selection selection = selectors_[i].selectByDistance(equivalent);
    picks.push_back({selection.level, instance.kind, distance, i});
    if (int(frame.level_histogram.size()) <= selection.level)
      frame.level_histogram.resize(selection.level + 1, 0);
    ++frame.level_histogram[selection.level];
    ++frame.visible;
  }
  std::sort(picks.begin(), picks.end(), [](const Pick& a, const Pick& b) {
    if (a.level != b.level) return a.level < b.level;
    if (a.kind != b.kind) return a.kind < b.kind;
    if (a.distance != b.distance) return a.distance < b.distance;
    return a.instance < b.instance;
  });
  for (size_t p = 0; p < picks.size(); ++p) {
    const Pick& pick = picks[p];
    if (p == 0 || pick.level != picks[p - 1].level || pick.kind != picks[p - 1].kind) {
      const KindLevels& kind = configuration_.kinds[pick.kind];
      frame.batch_levels.push_back(pick.level);
      frame.batch_kinds.push_back(pick.kind);
      frame.batches.push_back({.asset = kind.assets[pick.level],
                               .program = kind.programs[pick.level],
                               .models = {}});
    }
    frame.batches.back().models.push_back(scene_.instances[pick.instance].model);
  }
  return frame;
}

render::SceneCamera sceneCamera(const CameraPose& pose, int width, int height, float fov_y_deg) {
  render::SceneCamera camera;
  camera.width = width;
  camera.height = height;
  camera.eye = pose.eye;
  camera.light = pose.eye + core::Vec3{0, 3, 0} - core::normalize(pose.target - pose.eye) * 2.0f;
  camera.view = core::lookAt(pose.eye, pose.target, {0, 1, 0});
  camera.projection = core::perspective(fov_y_deg * float(std::numbers::pi) / 180.0f,
                                        float(width) / float(height), 0.05f, 500.0f);
  camera.clear_color = {0.55f, 0.65f, 0.8f};
  return camera;
}

}  // namespace duolod::runtime
