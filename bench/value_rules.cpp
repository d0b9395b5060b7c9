// The value rules on a real asset: per-pixel → per-vertex (Wang et al. 2014) and moving to
// parameter (He et al. 2015) applied to named values of a reference shader, each alone. For each:
// the fragment stage's instructions before → after (function bodies, after the rule's dead-code
// removal), the vertex stage's, and the image error (eq. 6, per covered pixel) of the variant
// against the original rendered the same way (1×1, so only the rule's change is measured), over
// the paper's 20 views × 5 lights. Moving to parameter also reports the averaging time (one
// instrumented compile + render of the domain per component).
#include <chrono>
#include <cstdio>

#include "duolod/io.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/rules_internal.hpp"
#include "shader/value_average.hpp"
#include "support/options.hpp"

using namespace duolod;
using shader::RuleSite;
using shader::ShaderProgram;

namespace {

size_t bodyInstructions(const shader::ir::Module& module) {
  size_t count = 0;
  for (const auto& function : module.functions)
    for (const auto& block : function.blocks) count += block.instructions.size();
  return count;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  duolod::bench::Options app{
      "duolod value-rule benchmark: per-vertex and moving to parameter on a real asset"};
  std::string asset_path = std::string(DUOLOD_ASSET_DIR) + "/obj/spot/spot.obj";
  std::string shader_name = "noise_phong";
  std::vector<std::string> values = {"q",        "turbulence", "albedo",   "normal",   "viewDir",
                                     "lightDir", "diffuse",    "specular", "radiance", "outColor"};
  int resolution = 64;
  float distance_radii = 3;
  app.add("--asset", asset_path);
  app.add("--shader", shader_name);
  app.add("--values", values, "GLSL names of the values to move");
  app.add("--resolution", resolution);
  app.add("--distance", distance_radii, "camera distance in bounding radii");
  if (auto exit_code = app.parse(argc, argv)) return *exit_code;

  auto asset = io::loadAsset(asset_path);
  if (!asset) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 1;
  auto created = render::Renderer::create();
  if (!created) return std::fprintf(stderr, "%s\n", created.error().message.c_str()), 1;
  render::Renderer& renderer = **created;
  auto asset_id = renderer.uploadAsset(*asset);
  if (!asset_id) return std::fprintf(stderr, "%s\n", asset_id.error().message.c_str()), 1;
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  std::vector<render::Sample> samples =
      render::domainSamples(sphere, distance_radii * sphere.radius);

  auto source = render::loadShaderPair(shader_name);
  if (!source) return std::fprintf(stderr, "%s\n", source.error().message.c_str()), 1;
  auto vertex_words =
      shader::compileToSpirv(source->vertex, shader::Stage::kVertex, shader_name + ".vert");
  auto fragment_words =
      shader::compileToSpirv(source->fragment, shader::Stage::kFragment, shader_name + ".frag");
  if (!vertex_words || !fragment_words) return std::fprintf(stderr, "compile failed\n"), 1;
  auto vertex_module = shader::ir::parseModule(*vertex_words);
  auto fragment_module = shader::ir::parseModule(*fragment_words);
  if (!vertex_module || !fragment_module) return std::fprintf(stderr, "parse failed\n"), 1;
  ShaderProgram original;
  original.vertex = std::move(*vertex_module);
  original.fragment = std::move(*fragment_module);

  // Renders a program (parameters baked in, as the CPU would set them) over the domain.
  auto renderProgram = [&](const ShaderProgram& program) -> core::Result<render::ImageBatch8> {
    ShaderProgram baked = program;
    if (auto ok = shader::bakeParameters(baked.fragment, baked.parameters); !ok) return ok.error();
    render::SpirvBinary binary{shader::ir::emitModule(baked.vertex),
                               shader::ir::emitModule(baked.fragment)};
    if (auto ok = shader::validateSpirv(binary.vertex, "vertex"); !ok) return ok.error();
    if (auto ok = shader::validateSpirv(binary.fragment, "fragment"); !ok) return ok.error();
    auto compiled = renderer.compileProgram(binary);
    if (!compiled) return compiled.error();
    auto images = renderer.render(*asset_id, *compiled, samples, {.resolution = resolution});
    renderer.releaseProgram(*compiled);
    return images;
  };
  auto reference = renderProgram(original);
  if (!reference) return std::fprintf(stderr, "%s\n", reference.error().message.c_str()), 1;

  shader::ValueAverager averager(renderer, *asset_id, samples, {.resolution = resolution});
  shader::RuleContext context;
  context.average_value = averager.function();

  auto start = std::chrono::steady_clock::now();
  std::vector<RuleSite> per_vertex_sites = shader::findPerVertexSites(original, context);
  double per_vertex_find = secondsSince(start);
  start = std::chrono::steady_clock::now();
  std::vector<RuleSite> parameter_sites = shader::findMoveToParameterSites(original, context);
  double parameter_find = secondsSince(start);

  std::printf("asset %s (%zu triangles), shader %s, %zu samples at %d px, distance %.1f radii\n",
              asset_path.c_str(), asset->mesh.triangleCount(), shader_name.c_str(), samples.size(),
              resolution, distance_radii);
  std::printf("sites: per-vertex %zu (found in %.3f s), moving to parameter %zu (%.3f s)\n\n",
              per_vertex_sites.size(), per_vertex_find, parameter_sites.size(), parameter_find);
  std::printf("| rule | value | fragment instr. | vertex instr. | per-pixel error | apply s |\n");
  std::printf("|---|---|---:|---:|---:|---:|\n");
  for (const std::string& value : values) {
    for (int rule = 0; rule < 2; ++rule) {
      const std::vector<RuleSite>& sites = rule == 0 ? per_vertex_sites : parameter_sites;
      const RuleSite* site = nullptr;
      for (const RuleSite& candidate : sites)
        if (candidate.description.find(": " + value + " ") != std::string::npos) site = &candidate;
      if (!site) continue;
      start = std::chrono::steady_clock::now();
      auto applied = rule == 0 ? shader::applyPerVertex(original, *site, context)
                               : shader::applyMoveToParameter(original, *site, context);
      double apply_seconds = secondsSince(start);
      const char* rule_name = rule == 0 ? "per-vertex" : "to parameter";
      if (!applied) {
        std::printf("| %s | %s | failed: %s |\n", rule_name, value.c_str(),
                    applied.error().message.c_str());
        continue;
      }
      auto images = renderProgram(*applied);
      if (!images) {
        std::printf("| %s | %s | render failed: %s |\n", rule_name, value.c_str(),
                    images.error().message.c_str());
        continue;
      }
      metric::ImageError error = metric::imageError(*images, *reference);
      std::printf("| %s | %s | %zu → %zu | %zu → %zu | %.5f | %.2f |\n", rule_name, value.c_str(),
                  bodyInstructions(original.fragment), bodyInstructions(applied->fragment),
                  bodyInstructions(original.vertex), bodyInstructions(applied->vertex),
                  error.per_pixel, apply_seconds);
    }
  }
  std::printf("\naverager: %d instrumented renders, %lld covered pixels averaged\n",
              averager.counters().renders, static_cast<long long>(averager.counters().pixels));
  return 0;
}
