// The output folder of `duolod generate` (issue 5, item 7): the LOD chain as one glTF with
// MSFT_lod + MSFT_screencoverage, each level's shader in SPIR-V, GLSL 450, GLSL ES 300 and HLSL,
// Olano's single autoLOD shader over the levels' shaders, lod.json and report.html.
#include <algorithm>
#include <filesystem>

#include "duolod/io.hpp"
#include "duolod/lod.hpp"
#include "duolod/shader.hpp"
#include "shader/autolod.hpp"
#include "shader/rules.hpp"
#include "shader/shader_files.hpp"

namespace duolod::lod {
namespace {

namespace fs = std::filesystem;

// Whether the LOD may go into `directory` (written there by an io::OutputFolder).
core::Status checkDirectory(const std::string& directory, const core::Asset& asset, bool force) {
  std::error_code error;
  fs::path out = fs::weakly_canonical(directory, error);
  if (!asset.source_path.empty()) {
    fs::path asset_dir = fs::weakly_canonical(fs::path(asset.source_path).parent_path(), error);
    if (!asset_dir.empty() && out == asset_dir)
      return core::Error{directory + ": refusing to write the LOD into the asset's own folder"};
  }
  // (error_code overloads: an unreadable folder is an Error, not an exception after the run.)
  if (fs::exists(out, error)) {
    if (!fs::is_directory(out, error))
      return core::Error{directory + ": exists and is not a folder"};
    auto holds = io::folderHoldsFiles(out.string());
    if (!holds) return holds.error();
    if (*holds && !force)
      return core::Error{
          directory + ": not empty, and writing into a folder that holds files was not asked for"};
  }
  return core::okStatus();
}

}  // namespace

core::Status writeLodOutput(const GenerateResult& result, const core::Asset& asset,
                            const GenerateOptions& options, const std::string& directory,
                            bool force) {
  if (result.levels.empty()) return core::Error{"write LOD: no levels"};
  if (auto ready = checkDirectory(directory, asset, force); !ready) return ready;
  // All or nothing: written beside the folder, then moved in (a failure leaves it as it was).
  io::OutputFolder folder;
  if (auto begun = folder.begin(directory); !begun) return begun;
  const fs::path out(folder.stagingPath());

  // The glTF chain: each level's coverage is where the next one takes over.
  std::vector<core::Mesh> meshes;
  std::vector<double> coverage;
  for (size_t k = 0; k < result.levels.size(); ++k) {
    meshes.push_back(result.levels[k].mesh);
    // In the order a GPU's post-transform vertex cache reuses best (as the renderer draws it).
    core::optimizeVertexReuse(meshes.back());
    coverage.push_back(k + 1 < result.levels.size() ? result.levels[k + 1].level.screen_coverage
                                                    : 0.0);
  }
  if (auto ok = io::writeGltfLodChain(asset, meshes, coverage, (out / "lod.gltf").string()); !ok)
    return ok;

  io::LodJsonDocument document;
  document.asset_name = fs::path(asset.source_path).stem().string();
  // Relative to lod.json's folder, as every other path in it (the path as typed was relative to
  // wherever duolod ran).
  if (!asset.source_path.empty()) {
    std::error_code ec;
    const fs::path source = fs::weakly_canonical(fs::absolute(asset.source_path, ec), ec);
    const fs::path relative =
        source.lexically_relative(fs::weakly_canonical(fs::absolute(directory, ec), ec));
    document.asset_source = relative.empty() ? source.generic_string() : relative.generic_string();
  }
  document.bounds = core::computeBoundingSphere(asset.mesh);
  for (const core::Mesh& level_mesh : meshes)
    for (core::Vec3 p : level_mesh.positions)
      document.culling_radius =
          std::max(document.culling_radius, double(core::length(p - document.bounds.center)));
  document.fov_y_deg = options.levels.display.fov_y_deg;
  document.screen_aspect = options.levels.screen_aspect;
  document.screen_height_px = options.levels.display.height_px;
  // The bound as the levels were made with it (with one level, the last level's distance is
  // d_near, not d_far).
  document.d_near = result.bound.d_near;
  document.d_far = result.bound.d_far;
  document.q = result.bound.q;
  document.e_max = result.bound.e_max;
  document.time_tolerance = options.time_tolerance;
  document.merge_min_gain = options.merge_min_gain;
  document.views = options.views == render::ViewSet::kUpright ? "upright" : "sphere";
  document.optimizer = options.optimizer == Optimizer::kSeparate ? "separate" : "interleaved";
  document.cost_source = result.cost_source;
  document.cost_unit = "seconds per draw";

  std::vector<shader::ShaderProgram> programs;
  std::vector<float> thresholds;
  for (size_t k = 0; k < result.levels.size(); ++k) {
    const GeneratedLevel& level = result.levels[k];
    const std::string name = "level" + std::to_string(k);
    auto files = shader::writeShaderFiles(level.readable.vertex, level.readable.fragment, out, name,
                                          options.bindings);
    if (!files) return files.error();
    io::LodJsonLevel row;
    row.level = static_cast<int>(k);
    row.distance = level.level.distance;
    row.switch_distance = level.switch_distance;
    row.screen_coverage = k == 0 ? 1.0 : level.level.screen_coverage;
    row.triangles = level.mesh.indices.size() / 3;
    row.vertices = level.mesh.positions.size();
    row.mesh_file = "lod.gltf#node" + std::to_string(k);
    row.shader_summary = level.shader_summary;
    row.shader_files = std::move(*files);
    for (size_t i = 0; i < level.parameters.size(); ++i) {
      const render::UniformValue& value = level.parameters[i];
      row.shader_parameters.push_back(
          {.name = i < level.parameter_names.size() ? level.parameter_names[i]
                                                    : "parameter" + std::to_string(value.location),
           .location = value.location,
           .value = std::vector<float>(value.value.begin(), value.value.begin() + value.components)});
    }
    row.error = level.error;
    row.error_bound = level.error_bound;
    if (k + 1 < result.levels.size()) row.transition_error = level.transition_error;
    row.predicted_cost = level.predicted_cost;
    if (level.measured_cost > 0) row.measured_cost = level.measured_cost;
    document.levels.push_back(std::move(row));

    auto program = shader::parseProgram(level.readable.vertex, level.readable.fragment);
    if (!program) return program.error();
    for (size_t i = 0; i < level.parameters.size(); ++i) {
      const render::UniformValue& value = level.parameters[i];
      program->parameters.push_back({.name = i < level.parameter_names.size()
                                                 ? level.parameter_names[i]
                                                 : "parameter" + std::to_string(value.location),
                                     .location = static_cast<uint32_t>(value.location),
                                     .components = value.components,
                                     .value = value.value});
    }
    programs.push_back(std::move(*program));
    thresholds.push_back(static_cast<float>(k));
  }

  // Olano's single shader: autoLOD = k runs level k's shader.
  auto autolod = shader::buildAutoLodShader(programs, thresholds);
  if (!autolod) return autolod.error();
  auto autolod_words = shader::emitProgram(autolod->program, /*optimize=*/false);
  if (!autolod_words) return autolod_words.error();
  auto autolod_files = shader::writeShaderFiles(autolod_words->vertex, autolod_words->fragment, out,
                                                "autolod", options.bindings);
  if (!autolod_files) return autolod_files.error();
  io::LodJsonDocument::AutoLod& autolod_entry = document.autolod.emplace();
  autolod_entry.files = std::move(*autolod_files);
  autolod_entry.location = static_cast<int>(autolod->autolod_location);
  for (const shader::ParameterValue& parameter : autolod->program.parameters)
    autolod_entry.parameters.push_back(
        {.name = parameter.name,
         .location = static_cast<int>(parameter.location),
         .value = std::vector<float>(parameter.value.begin(),
                                     parameter.value.begin() + parameter.components)});

  if (auto ok = io::writeLodJson(document, (out / "lod.json").string()); !ok) return ok;
  if (auto ok = writeReport(result.report, (out / "report.html").string()); !ok) return ok;
  return folder.commit(&asset);
}

}  // namespace duolod::lod
