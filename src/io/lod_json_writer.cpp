// lod.json: the LOD policy of Liang et al., "Automatic Mesh and Shader Level of Detail" (per level
// the switch distance d_i of §3.1, the bound of eq. 3/4, absolute and transition errors of eq. 1/5,
// predicted and measured cost), in the schema include/duolod/runtime.hpp reads.
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "duolod/io.hpp"

namespace duolod::io {
namespace {
using nlohmann::ordered_json;

ordered_json optionalNumber(const std::optional<double>& value) {
  return value ? ordered_json(*value) : ordered_json(nullptr);
}

// A parameter the runtime reads back: a location in [0, 65535] and 1-4 finite values (a NaN is
// written as null, which the runtime refuses).
core::Status checkParameters(const std::vector<LodJsonLevel::Parameter>& parameters,
                             const std::string& where) {
  for (const LodJsonLevel::Parameter& parameter : parameters) {
    if (parameter.location < 0 || parameter.location > 65535)
      return core::Error{where + ": parameter '" + parameter.name + "' at location " +
                         std::to_string(parameter.location) + ": must be in [0, 65535]"};
    if (parameter.value.empty() || parameter.value.size() > 4)
      return core::Error{where + ": parameter '" + parameter.name + "' has " +
                         std::to_string(parameter.value.size()) + " values, not 1-4"};
    for (float value : parameter.value)
      if (!std::isfinite(value))
        return core::Error{where + ": parameter '" + parameter.name +
                           "' has a value that is not "
                           "a finite number"};
  }
  return core::okStatus();
}

core::Status checkDocument(const LodJsonDocument& document, const std::string& path) {
  if (document.levels.empty()) return core::Error{path + ": lod.json needs at least one level"};
  if (document.autolod)
    if (auto valid = checkParameters(document.autolod->parameters, path + ": autolod"); !valid)
      return valid;
  for (size_t i = 0; i < document.levels.size(); ++i) {
    const LodJsonLevel& level = document.levels[i];
    std::string where = path + ": levels[" + std::to_string(i) + "]";
    if (auto valid = checkParameters(level.shader_parameters, where + ".shader"); !valid)
      return valid;
    if (!std::isfinite(level.switch_distance) || level.switch_distance < 0)
      return core::Error{where + ".switch_distance must be a non-negative number"};
    if (!(level.screen_coverage >= 0 && level.screen_coverage <= 1))
      return core::Error{where + ".screen_coverage must be in [0, 1]"};
    if (i == 0) continue;
    const LodJsonLevel& previous = document.levels[i - 1];
    if (!(level.switch_distance > previous.switch_distance))
      return core::Error{where + ".switch_distance must exceed the previous level's"};
    if (level.screen_coverage > previous.screen_coverage)
      return core::Error{where + ".screen_coverage must not exceed the previous level's"};
  }
  return core::okStatus();
}

}  // namespace

std::string lodJsonText(const LodJsonDocument& document) {
  auto filesJson = [](const std::vector<std::pair<std::string, std::string>>& files) {
    ordered_json object = ordered_json::object();
    for (const auto& [kind, file] : files) object[kind] = file;
    return object;
  };
  auto parametersJson = [](const std::vector<LodJsonLevel::Parameter>& parameters) {
    ordered_json array = ordered_json::array();
    for (const LodJsonLevel::Parameter& parameter : parameters)
      array.push_back(
          {{"name", parameter.name}, {"location", parameter.location}, {"value", parameter.value}});
    return array;
  };
  ordered_json levels = ordered_json::array();
  for (const LodJsonLevel& level : document.levels) {
    ordered_json files = filesJson(level.shader_files);
    ordered_json parameters = parametersJson(level.shader_parameters);
    levels.push_back({
        {"level", level.level},
        {"distance", level.distance},
        {"switch_distance", level.switch_distance},
        {"screen_coverage", level.screen_coverage},
        {"triangles", level.triangles},
        {"vertices", level.vertices},
        {"mesh", level.mesh_file},
        {"shader",
         {{"summary", level.shader_summary}, {"files", files}, {"parameters", parameters}}},
        {"error",
         {{"absolute", level.error},
          {"bound", level.error_bound},
          {"transition", optionalNumber(level.transition_error)}}},
        {"cost",
         {{"predicted", optionalNumber(level.predicted_cost)},
          {"measured", optionalNumber(level.measured_cost)}}},
    });
  }
  const core::Sphere& sphere = document.bounds;
  ordered_json root = {
      {"format", "duolod-lod"},
      {"version", 1},
      {"generator", "duolod " DUOLOD_VERSION},
      {"asset",
       {{"name", document.asset_name},
        {"source", document.asset_source},
        {"bounding_sphere",
         {{"center", {sphere.center.x, sphere.center.y, sphere.center.z}},
          {"radius", sphere.radius},
          {"culling_radius", std::max<double>(document.culling_radius, sphere.radius)}}}}},
      {"display",
       {{"fov_y_deg", document.fov_y_deg},
        {"height_px", document.screen_height_px},
        {"aspect", document.screen_aspect}}},
      {"bound",
       {{"d_near", document.d_near},
        {"d_far", document.d_far},
        {"q", document.q},
        {"e_max", document.e_max},
        {"time_tolerance", document.time_tolerance},
        {"merge_min_gain", document.merge_min_gain},
        {"views", document.views}}},
      {"optimizer", document.optimizer},
      {"cost", {{"source", document.cost_source}, {"unit", document.cost_unit}}},
      {"levels", levels},
  };
  if (const auto& autolod = document.autolod)
    root["autolod"] = {{"files", filesJson(autolod->files)},
                       {"uniform", autolod->uniform},
                       {"location", autolod->location},
                       {"parameters", parametersJson(autolod->parameters)}};
  // Names that are not UTF-8 (a Latin-1 file name) are written with U+FFFD, not thrown on.
  return root.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

core::Status writeLodJson(const LodJsonDocument& document, const std::string& path) {
  if (auto valid = checkDocument(document, path); !valid) return valid;
  return writeFileAtomic(path, lodJsonText(document));
}

}  // namespace duolod::io
