// The duolod command line: a thin layer over libduolod. Each subcommand parses flags, calls the
// library, and prints what a user needs; errors go to stderr with a non-zero exit code.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>

#include "duolod/core.hpp"
#include "duolod/io.hpp"
#include "duolod/lod.hpp"
#include "duolod/mesh.hpp"
#include "duolod/metric.hpp"
#include "duolod/render.hpp"
#include "duolod/shader.hpp"
#include "shader/lod_search.hpp"

namespace {
namespace fs = std::filesystem;
using namespace duolod;

// A numeric flag's check, run on the text before CLI11 converts it: unlike CLI::Range it refuses
// NaN and infinities, and a negative value for an unsigned option (which the conversion would
// wrap around to a huge one). `need` completes "must be ...", e.g. "in (0, 180)".
CLI::Validator numberWhere(const std::string& need, std::function<bool(double)> acceptable) {
  return CLI::Validator(
      [need, acceptable](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size())
          return "'" + text + "' is not a number";
        if (!std::isfinite(value)) return "must be a finite number " + need + ", got " + text;
        if (!acceptable(value)) return "must be " + need + ", got " + text;
        return {};
      },
      need);
}
CLI::Validator atLeast(double low) {
  char text[32];
  std::snprintf(text, sizeof text, ">= %.10g", low);
  return numberWhere(text, [low](double v) { return v >= low; });
}
CLI::Validator positive() {
  return numberWhere("> 0", [](double v) { return v > 0; });
}
CLI::Validator between(double low, double high) {  // inclusive
  char text[48];
  std::snprintf(text, sizeof text, "in [%.10g, %.10g]", low, high);
  return numberWhere(text, [low, high](double v) { return v >= low && v <= high; });
}

// The library says what was not asked for; on the command line, the flag that asks for it.
std::string withFlagHints(std::string message) {
  static const std::pair<std::string_view, std::string_view> kHints[] = {
      {", and replacing files was not asked for", " (use --force to replace it)"},
      {", and writing into a folder that holds files was not asked for",
       " (use --force to write into it)"},
      {"(ContextOptions::device)", "(--device N)"},
      {"(CompileOptions::entry_point)", "(name the entry with --vert-entry / --frag-entry)"},
      {"-pixel tile exceeds the device's 16384 limit",
       "-pixel tile (the footprint × the reference's 4×4 supersampling) exceeds the renderer's "
       "16384 px: fewer --near-pixels or --pixels, or a larger --d-near or --distance"}};
  for (const auto& [library, flag] : kHints)
    for (size_t at = message.find(library); at != std::string::npos; at = message.find(library))
      message.replace(at, library.size(), flag);
  return message;
}

int fail(const std::string& message) {
  std::fprintf(stderr, "duolod: error: %s\n", withFlagHints(message).c_str());
  return 1;
}

// What a slow first draw means for the command running, appended to the note (set by `shader`
// and `generate` before their first GPU request; read by the monitor thread only afterwards).
std::string slow_first_draw_consequence;

// A wait on the GPU that is not explained looks like a hang: a note when one request has taken
// DUOLOD_SLOW_NOTICE_SECONDS (default 30; 0 or "off": never), and again each time it doubles
// (render.hpp, SlowRequest).
void reportSlowGpuRequests() {
  double first_after = 30;
  if (const char* text = std::getenv("DUOLOD_SLOW_NOTICE_SECONDS")) {
    char* end = nullptr;
    const double seconds = std::strtod(text, &end);
    if (std::string_view(text) == "off" || (end != text && *end == '\0' && seconds == 0)) return;
    if (end == text || *end != '\0' || !(seconds > 0) || !std::isfinite(seconds))
      std::fprintf(stderr,
                   "duolod: warning: DUOLOD_SLOW_NOTICE_SECONDS='%s' is not a number of seconds "
                   "(or 0, or off); using 30\n",
                   text);
    else
      first_after = seconds;
  }
  render::setSlowRequestSink(first_after, [](const render::SlowRequest& request) {
    // Tenths below 10 s (a short DUOLOD_SLOW_NOTICE_SECONDS printed "taken 0 s").
    const int decimals = request.seconds < 10 ? 1 : 0;
    if (request.report > 0) {
      std::fprintf(stderr, "duolod: note: still waiting on the GPU after %.*f s: %s\n", decimals,
                   request.seconds, request.what.c_str());
      return;
    }
    std::string why =
        request.first_draw
            ? "It holds the program's first draw, which includes the driver's compile of it: on "
              "llvmpipe a fragment stage with many loops whose trip counts are not constants "
              "compiles slowly (16 such loops: over a minute; each more: 2-3x as long)."
            : "Large footprints, supersampling and many samples take long on a CPU rasterizer.";
    if (request.first_draw && !slow_first_draw_consequence.empty())
      why += " " + slow_first_draw_consequence;
    std::fprintf(stderr,
                 "duolod: note: one GPU request has taken %.*f s so far: %s. %s Still waiting "
                 "(Ctrl-C stops, removing unfinished output).\n",
                 decimals, request.seconds, request.what.c_str(), why.c_str());
  });
}

std::string lowerExtension(const std::string& path) {
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

bool isHlslFile(const std::string& path) {
  return lowerExtension(path) == ".hlsl";
}
bool isSpirvFile(const std::string& path) {
  return lowerExtension(path) == ".spv";
}

// Options shared by the commands that render.
struct ShadingFlags {
  std::string shader = "pbr";
  std::string vert, frag, bindings;
  std::string vert_entry = "main", frag_entry = "main";
  int device = -1;
  float fov_y_deg = 45.0f;
  int screen_height = 1080;
  float distance = 0;
  int pixels = 0;
  std::string views = "sphere";
  CLI::Option* shader_option = nullptr;
  CLI::Option* vert_entry_option = nullptr;
  CLI::Option* frag_entry_option = nullptr;

  void add(CLI::App* command) {
    command
        ->add_option("--views", views,
                     "the domain's views: sphere (20 around the object, the paper's §7) or "
                     "upright (20 from -10 to 35 degrees of elevation, for objects standing on "
                     "the ground with +Y up, seen from around eye height)")
        ->check(CLI::IsMember({"sphere", "upright"}))
        ->capture_default_str();
    shader_option =
        command
            ->add_option("--shader", shader,
                         "duolod shader by name (pbr, noise_phong, blend, constant) or a path "
                         "prefix P with P.vert and P.frag")
            ->capture_default_str();
    command->add_option("--vert", vert,
                        "vertex shader: GLSL 450, HLSL when the file name ends in .hlsl, "
                        "SPIR-V (for OpenGL or Vulkan) when it ends in .spv (README, Shaders); "
                        "needs --frag");
    command->add_option("--frag", frag,
                        "fragment (pixel) shader: GLSL 450, HLSL when the file name ends in "
                        ".hlsl, SPIR-V when it ends in .spv; needs --vert");
    vert_entry_option =
        command
            ->add_option("--vert-entry", vert_entry,
                         "entry point of an HLSL or SPIR-V --vert (SPIR-V: else its first "
                         "vertex entry point)")
            ->capture_default_str();
    frag_entry_option =
        command
            ->add_option("--frag-entry", frag_entry,
                         "entry point of an HLSL or SPIR-V --frag (SPIR-V: else its first "
                         "fragment entry point)")
            ->capture_default_str();
    command->add_option("--bindings", bindings,
                        "JSON file moving the shader interface's attribute locations, block and "
                        "texture bindings, e.g. {\"attributes\": {\"color\": 7}} (README, "
                        "Formats)");
    command
        ->add_option("--device", device,
                     "EGL device index; -1 = Mesa surfaceless (llvmpipe without a GPU)")
        ->check(atLeast(-1))
        ->capture_default_str();
    command->add_option("--fov", fov_y_deg, "display vertical field of view, degrees")
        ->check(numberWhere("in (0, 180)", [](double v) { return v > 0 && v < 180; }))
        ->capture_default_str();
    command->add_option("--screen-height", screen_height, "display height in pixels")
        ->check(between(1, 65536))
        ->capture_default_str();
  }

  // The shader pair, checked against what duolod feeds it (shader::checkShaderInterface): what
  // reads zeros is a warning, a pair that cannot render right an error.
  core::Result<render::GlslSource> source() const {
    auto pair = readSource();
    if (!pair) return pair;
    auto bound = parsedBindings();
    if (!bound) return bound.error();
    auto warnings = shader::checkShaderInterface(*pair, *bound);
    if (!warnings) return warnings.error();
    for (const std::string& warning : *warnings) core::log(core::LogLevel::kWarning, warning);
    return pair;
  }

  core::Result<render::GlslSource> readSource() const {
    if (vert.empty() != frag.empty()) return core::Error{"--vert and --frag go together"};
    if (!vert.empty() && shader_option && shader_option->count() > 0)
      return core::Error{"give --shader or --vert with --frag, not both"};
    // An entry point names a function of an HLSL file or a SPIR-V module; GLSL's is main().
    for (auto [option, file, flag] : {std::tuple{vert_entry_option, &vert, "--vert"},
                                      std::tuple{frag_entry_option, &frag, "--frag"}})
      if (option && option->count() > 0 && !isHlslFile(*file) && !isSpirvFile(*file))
        return core::Error{option->get_name() +
                           " names the entry point of an HLSL (.hlsl) or "
                           "SPIR-V (.spv) " +
                           flag + " file; " +
                           (file->empty() ? std::string("there is none")
                                          : *file + " is GLSL, whose entry point is main()")};
    if (!vert.empty()) {
      // GLSL as it is; HLSL translated to GLSL 450 first (shader::hlslToGlsl), which is what
      // every later stage takes. HLSL vertex inputs are placed by semantic where the bindings
      // put the mesh's streams.
      auto bound = parsedBindings();
      if (!bound) return bound.error();
      const std::map<std::string, uint32_t> input_locations =
          render::hlslVertexInputLocations(*bound);
      std::vector<std::pair<std::string, std::vector<uint32_t>>> spirv_modules;
      auto read = [&](const std::string& path, shader::Stage stage,
                      const std::string& entry) -> core::Result<std::string> {
        auto bytes = io::readFileBytes(path);  // names a missing file or a folder
        if (!bytes) return bytes.error();
        if (isSpirvFile(path)) {  // compiled (for OpenGL or Vulkan): GLSL 450 by SPIRV-Cross
          if (bytes->size() % 4 != 0)
            return core::Error{path + ": not a SPIR-V module (" + std::to_string(bytes->size()) +
                               " bytes, not a whole number of 32-bit words)"};
          std::vector<uint32_t> words(bytes->size() / 4);
          std::memcpy(words.data(), bytes->data(), bytes->size());
          // Without --vert-entry/--frag-entry: the module's first entry point of the stage.
          const CLI::Option* chosen =
              stage == shader::Stage::kVertex ? vert_entry_option : frag_entry_option;
          auto glsl = shader::spirvToGlsl(words, stage, path,
                                          chosen && chosen->count() > 0 ? entry : std::string());
          if (glsl) spirv_modules.emplace_back(path, std::move(words));
          return glsl;
        }
        std::string text(core::withoutByteOrderMark(
            {reinterpret_cast<const char*>(bytes->data()), bytes->size()}));
        if (!isHlslFile(path)) return text;
        shader::CompileOptions options;
        options.entry_point = entry;
        options.include_dirs = {fs::path(path).parent_path().string()};
        if (stage == shader::Stage::kVertex) options.vertex_input_locations = input_locations;
        return shader::hlslToGlsl(text, stage, path, options);
      };
      auto name = [](const std::string& path) {
        return isHlslFile(path) || isSpirvFile(path) ? path + " (as GLSL)" : path;
      };
      if (isHlslFile(vert) && isHlslFile(frag)) {
        // An HLSL pair: its varyings are matched by semantic, as Direct3D matches them.
        auto vertex_text = io::readFileBytes(vert);
        if (!vertex_text) return vertex_text.error();
        auto fragment_text = io::readFileBytes(frag);
        if (!fragment_text) return fragment_text.error();
        shader::CompileOptions vertex_options, fragment_options;
        vertex_options.entry_point = vert_entry;
        vertex_options.include_dirs = {fs::path(vert).parent_path().string()};
        vertex_options.vertex_input_locations = input_locations;
        fragment_options.entry_point = frag_entry;
        fragment_options.include_dirs = {fs::path(frag).parent_path().string()};
        auto text = [](const std::vector<uint8_t>& bytes) {
          return std::string(core::withoutByteOrderMark(
              {reinterpret_cast<const char*>(bytes.data()), bytes.size()}));
        };
        auto pair = shader::hlslPairToGlsl(text(*vertex_text), vert, text(*fragment_text), frag,
                                           vertex_options, fragment_options);
        if (!pair) return pair.error();
        return render::GlslSource{pair->vertex, pair->fragment, name(vert), name(frag)};
      }
      auto v = read(vert, shader::Stage::kVertex, vert_entry);
      if (!v) return v.error();
      auto f = read(frag, shader::Stage::kFragment, frag_entry);
      if (!f) return f.error();
      if (auto distinct = shader::checkBindingsAcrossSets(spirv_modules); !distinct)
        return distinct.error();
      return render::GlslSource{*v, *f, name(vert), name(frag)};
    }
    return render::loadShaderPair(shader);
  }

  // The --bindings file's, else the interface's (shaders/INTERFACE.md).
  core::Result<render::Bindings> parsedBindings() const {
    if (bindings.empty()) return render::Bindings{};
    auto bytes = io::readFileBytes(bindings);
    if (!bytes) return bytes.error();
    return render::parseBindings(std::string(bytes->begin(), bytes->end()), bindings);
  }

  render::Display display() const { return {fov_y_deg, screen_height}; }
  render::ViewSet viewSet() const {
    return views == "upright" ? render::ViewSet::kUpright : render::ViewSet::kDodecahedron;
  }
};

struct Session {
  std::unique_ptr<render::Renderer> renderer;
  render::Renderer::ProgramId program = -1;
};

core::Result<Session> openSession(const ShadingFlags& flags) {
  auto source = flags.source();
  if (!source) return source.error();
  auto bindings = flags.parsedBindings();
  if (!bindings) return bindings.error();
  auto renderer = render::Renderer::create({.device = flags.device, .bindings = *bindings});
  if (!renderer) return renderer.error();
  auto program = (*renderer)->compileProgram(*source);
  if (!program) return program.error();
  return Session{std::move(renderer.value()), *program};
}

core::Result<core::Asset> loadWithWarnings(const std::string& path,
                                           const io::LoadOptions& options = {}) {
  auto asset = io::loadAsset(path, options);
  if (asset)
    for (const std::string& warning : asset->warnings) {
      // The OBJ and PLY readers' warnings name the file (and line) already: no second path.
      const bool names_the_file = warning.starts_with(path + ":");
      std::fprintf(stderr, "duolod: warning: %s%s%s\n", names_the_file ? "" : path.c_str(),
                   names_the_file ? "" : ": ", warning.c_str());
    }
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

// The entries of `folder`, listed before any is removed, without throwing (a folder that changes
// or cannot be read lists what could be read).
std::vector<fs::path> entriesOf(const fs::path& folder) {
  std::vector<fs::path> entries;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec))
    entries.push_back(it->path());
  return entries;
}

// After a run with --force into a folder an earlier run wrote: the level shader files this run
// did not write (levels it does not have, or another command's names: generate writes levelK.*,
// shader levelNN.*), which would otherwise read as part of this result. Only names of exactly
// that form are removed. `level_stem(k)` is this run's name of level k.
void removeStaleLevelFiles(const std::string& folder, size_t level_count,
                           const std::function<std::string(size_t)>& level_stem) {
  // "level" + 1-6 digits + one of the shader files' suffixes (no <regex>: GCC 12 warns inside it
  // under the sanitizers).
  static const char* const kSuffixes[] = {".vert.spv", ".vert.glsl", ".vert.es.glsl", ".vert.hlsl",
                                          ".frag.spv", ".frag.glsl", ".frag.es.glsl", ".frag.hlsl"};
  std::set<std::string> written;
  for (size_t k = 0; k < level_count; ++k) written.insert(level_stem(k));
  std::error_code ec;
  for (const fs::path& entry : entriesOf(folder)) {
    const std::string name = entry.filename().string();
    if (!name.starts_with("level")) continue;
    size_t digits = 0;
    while (5 + digits < name.size() && std::isdigit(static_cast<unsigned char>(name[5 + digits])))
      ++digits;
    if (digits == 0 || digits > 6) continue;
    const std::string suffix = name.substr(5 + digits);
    const bool ours = std::any_of(std::begin(kSuffixes), std::end(kSuffixes),
                                  [&](const char* known) { return suffix == known; });
    if (ours && !written.contains(name.substr(0, 5 + digits))) fs::remove(entry, ec);
  }
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
  // By position, as the quadric mode sees it: misoriented and non-manifold edges lock their
  // vertices, which is why a mesh can stop short of a simplification target.
  const mesh::SurfaceTopology topology = mesh::surfaceTopology(mesh);
  std::printf(
      "  topology    %zu edges: %zu border, %zu non-manifold, %zu misoriented (two "
      "triangles running the same way); Euler characteristic %lld (welded by position)\n",
      topology.edges, topology.border_edges, topology.non_manifold_edges,
      topology.misoriented_edges, topology.eulerCharacteristic());
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
  return render::distanceForDiameterPixels(sphere, flags.pixels, flags.display());
}

std::string lowerExtension(const std::string& path);
std::string formatNumber(double value);

// The largest footprint a `supersample`×`supersample` reference can have (--pixels N spans a
// hair over N: its footprint rounds up to N + 1).
int largestSupersampledPixels(int supersample) {
  return render::kMaxTileSize / supersample - 1;
}

// A render's viewpoint, checked before any work: the camera outside the asset's bounding sphere,
// and a tile (the footprint, × `supersample` for a supersampled reference) the renderer takes.
// `how` is the flag that placed the camera ("--distance 2"), `fix` what to give instead.
core::Status checkViewpointAt(const std::string& path, const std::string& how,
                              const core::Sphere& sphere, float distance,
                              const render::Display& display, int supersample,
                              const std::string& supersample_note, const std::string& fix) {
  if (!(distance > sphere.radius))
    return core::Error{path + ": " + how + " puts the camera inside the asset's bounding sphere "
                       "(radius " + formatNumber(sphere.radius) + ", distance " +
                       formatNumber(distance) + "); the domain's views look at it from outside"};
  const double across = render::projectedDiameterPixels(sphere, distance, display);
  const double tile = std::ceil(across) * supersample;
  if (supersample > 1 && tile > render::kMaxTileSize)
    return core::Error{
        path + ": with " + how + " the object spans " + formatNumber(std::ceil(across)) +
        " px, and " + supersample_note + ", rendered " + std::to_string(supersample) + "×" +
        std::to_string(supersample) + " supersampled, would be " + formatNumber(tile) +
        " px across, above the renderer's " + std::to_string(render::kMaxTileSize) + " px: " + fix};
  return core::okStatus();
}

// The same for the render flags (--distance or --pixels).
core::Status checkViewpoint(const std::string& path, const ShadingFlags& flags,
                            const core::Sphere& sphere, float distance, int supersample,
                            const std::string& supersample_note) {
  const std::string how = flags.distance > 0 ? "--distance " + formatNumber(flags.distance)
                                             : "--pixels " + std::to_string(flags.pixels);
  return checkViewpointAt(
      path, how, sphere, distance, flags.display(), supersample, supersample_note,
      "give at most --pixels " + std::to_string(largestSupersampledPixels(supersample)) +
          " (or a larger --distance)");
}

// An output folder (generate, shader), checked before any work: a folder or not there yet, where
// files can be created; not the folder of an input, even with --force; empty unless --force
// (leftovers of killed runs' staging do not count); and never holding the other command's
// result, whose manifest would be left pointing at files this run replaces or removes.
core::Status checkOutputFolder(const std::string& out, bool force,
                               const std::vector<std::string>& inputs, const char* other_manifest,
                               const char* other_command) {
  if (out.empty()) return core::Error{"--out: empty path; give the folder to write into"};
  if (auto ok = io::checkWritableFolder(out); !ok) return ok;
  std::error_code ec;
  const fs::path target = fs::weakly_canonical(fs::absolute(out), ec);
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    if (target == fs::weakly_canonical(fs::absolute(input).parent_path(), ec))
      return core::Error{out + ": is the folder of the input " + input + "; choose another --out"};
  }
  if (!fs::is_directory(target, ec)) return core::okStatus();
  auto holds_files = io::folderHoldsFiles(target.string());
  if (!holds_files) return holds_files.error();
  if (*holds_files && !force)
    return core::Error{out + ": exists and is not empty (use --force to write into it)"};
  if (fs::exists(target / other_manifest, ec))
    return core::Error{out + ": holds a `duolod " + other_command + "` result (" +
                       other_manifest + "), whose files this run would replace or remove; " +
                       "choose another --out"};
  return core::okStatus();
}

int runRender(const std::string& path, ShadingFlags& flags, int view, int light, int supersample,
              const std::string& out, bool force) {
  if ((flags.distance > 0) == (flags.pixels > 0))
    return fail("give exactly one of --distance D or --pixels N");
  // Never over a file this run reads: the asset, the shader files and the bindings (below: the
  // asset's own .bin, .mtl and textures).
  std::vector<std::string> inputs = {path, flags.vert, flags.frag, flags.bindings};
  if (flags.vert.empty())
    inputs.insert(inputs.end(), {flags.shader + ".vert", flags.shader + ".frag"});
  if (auto ok = io::checkWritablePath(out); !ok) return fail(ok.error().message);
  if (auto ok = checkOutputPath(out, inputs, force); !ok) return fail(ok.error().message);
  if (lowerExtension(out) != ".png")
    return fail(out + ": the render is written as PNG: name it .png");
  auto asset = loadWithWarnings(path);
  if (!asset) return fail(asset.error().message);
  // The asset's own files: its .bin, .mtl and textures, those found beside it included.
  if (auto ok = io::refuseSourceFile(*asset, out); !ok) return fail(ok.error().message);
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  float distance = resolveDistance(flags, sphere);
  if (auto ok = checkViewpoint(path, flags, sphere, distance, supersample,
                               "the render (--supersample " + std::to_string(supersample) + ")");
      !ok)
    return fail(ok.error().message);
  auto session = openSession(flags);
  if (!session) return fail(session.error().message);
  auto& renderer = *session->renderer;
  auto asset_id = renderer.uploadAsset(*asset);
  if (!asset_id) return fail(asset_id.error().message);
  int resolution = render::footprintPixels(sphere, distance, flags.display());
  if (render::projectedDiameterPixels(sphere, distance, flags.display()) > render::kMaxTileSize)
    std::fprintf(stderr,
                 "duolod: warning: %s: at distance %g the object spans more than %d px; "
                 "rendered at %d px\n",
                 path.c_str(), distance, render::kMaxTileSize, render::kMaxTileSize);
  std::vector<render::Sample> all =
      render::domainSamples(sphere, distance, {.views = flags.viewSet()});
  std::vector<render::Sample> chosen;
  for (const render::Sample& s : all)
    if ((view < 0 || s.view_index == view) && s.light_index == light) chosen.push_back(s);
  if (chosen.empty()) return fail("no such view/light (views 0-19, lights 0-4)");
  render::RenderOptions options{.resolution = resolution, .supersample = supersample};
  render::RenderStats stats;
  core::ImageRGBA8 image;
  if (supersample > 1) {
    auto batch = renderer.renderReference(*asset_id, session->program, chosen, options, &stats);
    if (!batch) return fail(path + ": " + batch.error().message);
    render::ImageBatch8 converted{batch->width, batch->height, batch->count, {}};
    for (int i = 0; i < batch->count; ++i) {
      core::ImageRGBA8 tile = render::tileImage(*batch, i);
      converted.pixels.insert(converted.pixels.end(), tile.pixels.begin(), tile.pixels.end());
    }
    image = view >= 0 ? render::tileImage(converted, 0) : render::contactSheet(converted, 5);
  } else {
    auto batch = renderer.render(*asset_id, session->program, chosen, options, &stats);
    if (!batch) return fail(path + ": " + batch.error().message);
    image = view >= 0 ? render::tileImage(*batch, 0) : render::contactSheet(*batch, 5);
  }
  if (auto written = io::writePng(image, out); !written) return fail(written.error().message);
  std::printf("%s: distance %g, footprint %d px, %zu image%s, %.3f s on %s\n", out.c_str(),
              distance, resolution, chosen.size(), chosen.size() == 1 ? "" : "s", stats.seconds,
              renderer.deviceDescription().c_str());
  return 0;
}

// ε (eq. 6) of each of `approximations` against the supersampled reference of `original`, over the
// 20 views × 5 lights at `distance`, all framed by the original's bounding sphere so that their
// pixels correspond.
struct ImageComparison {
  int footprint_px = 0;
  std::vector<metric::ImageError> errors;  // one per approximation
};

core::Result<ImageComparison> compareRendered(Session& session, const core::Asset& original,
                                              std::span<const core::Asset* const> approximations,
                                              float distance, const ShadingFlags& shading,
                                              int supersample) {
  const render::Display display = shading.display();
  auto& renderer = *session.renderer;
  ImageComparison comparison;
  core::Sphere sphere = core::computeBoundingSphere(original.mesh);
  comparison.footprint_px = render::footprintPixels(sphere, distance, display);
  std::vector<render::Sample> samples =
      render::domainSamples(sphere, distance, {.views = shading.viewSet()});
  render::RenderOptions options{.resolution = comparison.footprint_px, .supersample = supersample};
  auto original_id = renderer.uploadAsset(original);
  if (!original_id) return original_id.error();
  auto reference = renderer.renderReference(*original_id, session.program, samples, options);
  renderer.releaseAsset(*original_id);
  if (!reference) return reference.error();
  options.supersample = 1;
  for (const core::Asset* approximation : approximations) {
    auto id = renderer.uploadAsset(*approximation);
    if (!id) return id.error();
    auto image = renderer.render(*id, session.program, samples, options);
    renderer.releaseAsset(*id);
    if (!image) return image.error();
    comparison.errors.push_back(metric::imageError(*image, *reference));
  }
  return comparison;
}

// Exit code of `error --check` when the approximation is not within the bound: 1 and 2 are
// taken by failures and by the parser.
constexpr int kOutsideBoundExitCode = 3;

// The error bound's flags (eq. 4), the same for `generate` and `error`, so that `error` checks a
// level against the bound `generate` chose it by: --e-max, --q, and d_near / d_far given in asset
// units or (0) placed where the object spans --near-pixels / --far-pixels on the display.
struct BoundFlags {
  metric::BoundConfig* bound = nullptr;  // the flags' values (add)
  int* near_pixels = nullptr;
  int* far_pixels = nullptr;
  CLI::Option* near_pixels_option = nullptr;
  CLI::Option* far_pixels_option = nullptr;

  void add(CLI::App* command, metric::BoundConfig& bound_values, int& near_pixels_value,
           int& far_pixels_value) {
    bound = &bound_values;
    near_pixels = &near_pixels_value;
    far_pixels = &far_pixels_value;
    command->add_option("--e-max", bound->e_max, "maximum per-pixel error (eq. 4)")
        ->check(atLeast(0))
        ->capture_default_str();
    command->add_option("--q", bound->q, "quality falloff Q (eq. 4)")
        ->check(between(0, 1))
        ->capture_default_str();
    command
        ->add_option("--d-near", bound->d_near,
                     "nearest level's distance, asset units (0: where the object spans "
                     "--near-pixels)")
        ->check(atLeast(0))
        ->capture_default_str();
    command
        ->add_option("--d-far", bound->d_far,
                     "farthest level's distance, asset units (0: where the object spans "
                     "--far-pixels)")
        ->check(atLeast(0))
        ->capture_default_str();
    near_pixels_option =
        command
            ->add_option("--near-pixels", *near_pixels,
                         "with --d-near 0: d_near is where the object spans this many pixels")
            ->check(atLeast(1))
            ->capture_default_str();
    far_pixels_option =
        command
            ->add_option("--far-pixels", *far_pixels,
                         "with --d-far 0: d_far is where the object spans this many pixels")
            ->check(atLeast(1))
            ->capture_default_str();
  }

  // Flag combinations, checked before any file is read.
  core::Status check() const {
    if (bound->d_near > 0 && near_pixels_option->count() > 0)
      return core::Error{"give --d-near or --near-pixels, not both (--near-pixels places d_near)"};
    if (bound->d_far > 0 && far_pixels_option->count() > 0)
      return core::Error{"give --d-far or --far-pixels, not both (--far-pixels places d_far)"};
    if (bound->d_near > 0 && bound->d_far > 0 && !(bound->d_near < bound->d_far))
      return core::Error{"--d-near (" + formatNumber(bound->d_near) +
                         ") must be less than --d-far (" + formatNumber(bound->d_far) + ")"};
    if (bound->d_near == 0 && bound->d_far == 0 && !(*near_pixels > *far_pixels))
      return core::Error{"--near-pixels (" + std::to_string(*near_pixels) +
                         ") must be more than --far-pixels (" + std::to_string(*far_pixels) +
                         "): the object looks smaller farther away"};
    return core::okStatus();
  }
};

// `error`'s bound, defaulting to generate's placement of d_near and d_far.
struct ErrorBound {
  metric::BoundConfig bound{.d_near = 0, .d_far = 0};
  int near_pixels = lod::GenerateOptions{}.near_footprint_px;
  int far_pixels = lod::GenerateOptions{}.far_footprint_px;
  BoundFlags flags;
};

int runError(const std::string& path_a, const std::string& path_b, ShadingFlags& flags,
             int supersample, const ErrorBound& error_bound, bool check) {
  if ((flags.distance > 0) == (flags.pixels > 0))
    return fail("give exactly one of --distance D or --pixels N");
  if (auto ok = error_bound.flags.check(); !ok) return fail(ok.error().message);
  metric::BoundConfig bound = error_bound.bound;
  auto a = loadWithWarnings(path_a);
  if (!a) return fail(a.error().message);
  const core::Sphere sphere = core::computeBoundingSphere(a->mesh);
  std::string d_near_source = "--d-near", d_far_source = "--d-far";
  if (bound.d_near == 0) {
    bound.d_near = render::distanceForFootprint(sphere, error_bound.near_pixels, flags.display());
    d_near_source = "--near-pixels " + std::to_string(error_bound.near_pixels);
  }
  if (bound.d_far == 0) {
    bound.d_far = render::distanceForFootprint(sphere, error_bound.far_pixels, flags.display());
    d_far_source = "--far-pixels " + std::to_string(error_bound.far_pixels);
  }
  if (!(bound.d_near < bound.d_far))
    return fail(path_a + ": d_near (" + formatNumber(bound.d_near) + ", from " + d_near_source +
                ") must be less than d_far (" + formatNumber(bound.d_far) + ", from " +
                d_far_source + ")");
  float distance = resolveDistance(flags, sphere);
  if (auto ok = checkViewpoint(path_a, flags, sphere, distance, supersample,
                               "the reference (--supersample " + std::to_string(supersample) +
                                   ")");
      !ok)
    return fail(ok.error().message);
  auto b = loadWithWarnings(path_b);
  if (!b) return fail(b.error().message);
  auto session = openSession(flags);
  if (!session) return fail(session.error().message);
  // The renders take seconds to minutes on a CPU rasterizer: say what is being done.
  std::fprintf(stderr,
               "duolod: rendering 100 samples at %d px: %s %d×%d supersampled, then %s\n",
               render::footprintPixels(sphere, distance, flags.display()), path_a.c_str(),
               supersample, supersample, path_b.c_str());
  const core::Asset* approximations[] = {&*b};
  auto comparison =
      compareRendered(*session, *a, approximations, distance, flags, supersample);
  if (!comparison) return fail(comparison.error().message);
  const metric::ImageError& error = comparison->errors[0];
  double e_a = metric::perPixelBound(bound, distance);
  // A distance outside [d_near, d_far] gets the bound of the nearer end (0 below d_near).
  if (distance < bound.d_near || distance > bound.d_far)
    std::fprintf(stderr,
                 "duolod: warning: distance %g is outside [d_near, d_far] = [%g, %g] (%s, %s): "
                 "the bound is that of %s\n",
                 distance, bound.d_near, bound.d_far, d_near_source.c_str(), d_far_source.c_str(),
                 distance < bound.d_near ? "d_near, 0" : "d_far");
  bool ok = metric::withinBound(error, bound, distance);
  std::printf("distance %g  footprint %d px  samples %d (20 views x 5 lights)\n", distance,
              comparison->footprint_px, error.samples);
  std::printf("epsilon (eq. 6)      %.6g\n", error.epsilon);
  std::printf("coverage s_d         %.1f px\n", error.coverage_px);
  std::printf("per-pixel error      %.6g\n", error.per_pixel);
  std::printf("bound e_a(d)*s_d     %.6g  (e_a = %.4g: e_max %.3g, Q %.3g, d %g..%g)\n",
              e_a * error.coverage_px, e_a, bound.e_max, bound.q, bound.d_near, bound.d_far);
  std::printf("within bound         %s\n", ok ? "yes" : "no");
  return check && !ok ? kOutsideBoundExitCode : 0;
}

// ---------------------------------------------------------------------------------------------
// simplify

std::string formatNumber(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// D of §4.2 for the image-driven mode: simplify's and generate's --max-edge-pixels.
CLI::Option* addMaxEdgePixels(CLI::App* command, float& value, const std::string& applies_to) {
  return command
      ->add_option("--max-edge-pixels", value,
                   applies_to +
                       ": never collapse an edge longer than this many pixels on screen in any "
                       "view (D of the paper's §4.2, which uses 1); larger values let near, "
                       "large footprints coarsen until the image error stops them, at more "
                       "renders")
      ->check(numberWhere("in (0, 1000]", [](double v) { return v > 0 && v <= 1000; }))
      ->capture_default_str();
}

struct SimplifyFlags {
  std::string in, out;
  std::string mode = "quadric";
  std::string placement = "optimal";
  double ratio = 0;
  int64_t triangles = 0;  // signed, so that a negative count is reported rather than wrapped
  double error = 0;
  int grid = 0;
  bool lock_border = false;
  bool reorient = false;
  bool force = false;
  bool simplify_generated_normals = false;
  bool no_geometry = false;
  float max_edge_pixels = 1.0f;
  ShadingFlags shading;
  // Which of the optional flags were given (CLI11 counts them).
  CLI::Option* ratio_option = nullptr;
  CLI::Option* triangles_option = nullptr;
  CLI::Option* error_option = nullptr;
  CLI::Option* grid_option = nullptr;
  CLI::Option* placement_option = nullptr;
  CLI::Option* max_edge_pixels_option = nullptr;

  void add(CLI::App* command) {
    command->add_option("in", in, "glTF/GLB/OBJ/PLY/OFF file to simplify")->required();
    command->add_option("out", out, "output: .gltf (+ .bin and PNGs beside it), .glb or .obj")
        ->required();
    // Ranges as validators, like every other numeric flag: refused by the parser (exit code 2)
    // with the range in --help.
    ratio_option = command->add_option("--ratio", ratio, "target fraction of the triangles")
                       ->check(numberWhere("in (0, 1]", [](double v) { return v > 0 && v <= 1; }));
    triangles_option =
        command->add_option("--triangles", triangles, "target triangle count")->check(atLeast(1));
    error_option =
        command
            ->add_option(
                "--error", error,
                "error target: geometric distance in asset units (quadric: the collapse error; "
                "cluster: how far a vertex may move), or the image error epsilon of eq. (6) "
                "(image)")
            ->check(atLeast(0));
    command
        ->add_option("--mode", mode,
                     "quadric (fast), image (the paper's, needs a distance; never collapses "
                     "an edge longer than --max-edge-pixels there, so it reaches coarse "
                     "targets only at small footprints) or cluster (very fast, coarse)")
        ->check(CLI::IsMember({"quadric", "image", "cluster"}))
        ->capture_default_str();
    max_edge_pixels_option = addMaxEdgePixels(command, max_edge_pixels, "image mode");
    placement_option =
        command
            ->add_option("--placement", placement, "quadric mode: where a collapse puts the vertex")
            ->check(CLI::IsMember({"optimal", "endpoint"}))
            ->capture_default_str();
    grid_option = command
                      ->add_option("--grid", grid,
                                   "cluster mode: cells along the longest side (instead of a "
                                   "target)")
                      ->check(atLeast(1));
    command->add_flag("--lock-border", lock_border, "open-boundary vertices never move");
    command->add_flag("--reorient", reorient,
                      "first turn triangles round so that every edge between two triangles runs "
                      "opposite ways in them (closed parts facing outwards, open ones the way "
                      "most of their area faces): the collapse modes never move a vertex of an "
                      "edge two triangles run the same way");
    command->add_flag("--simplify-generated-normals", simplify_generated_normals,
                      "for a file of positions only: generate normals first and simplify them "
                      "as attributes (closer shading, the general engine: several times slower) "
                      "instead of deriving them again on the result");
    command->add_flag("--no-geometry", no_geometry,
                      "skip the geometry line (Hausdorff and mean distance by surface sampling): "
                      "on large meshes it takes longer than the simplification itself");
    shading.add(command);
    command
        ->add_option("--distance", shading.distance,
                     "camera distance (asset units): image mode's distance, and reports the "
                     "image error there")
        ->check(positive());
    command
        ->add_option("--pixels", shading.pixels,
                     "alternatively: the distance at which the object spans N pixels")
        ->check(between(1, 16384));
    command->add_flag("--force", force, "replace OUT if it exists");
  }

  bool given(const CLI::Option* option) const { return option && option->count() > 0; }

  // Flag combinations, checked before any file is read.
  core::Status check() const {
    int targets = given(ratio_option) + given(triangles_option) + given(error_option);
    if (mode == "cluster") {
      if (targets + given(grid_option) != 1)
        return core::Error{
            "cluster mode: give exactly one of --ratio R, --triangles N, --error E "
            "or --grid N"};
    } else {
      if (targets != 1)
        return core::Error{"give exactly one of --ratio R, --triangles N or --error E"};
      if (given(grid_option)) return core::Error{"--grid applies to --mode cluster only"};
    }
    if (given(ratio_option) && !(ratio > 0 && ratio <= 1))
      return core::Error{"--ratio must be in (0, 1], got " + formatNumber(ratio)};
    if (given(triangles_option) && triangles < 1)
      return core::Error{"--triangles must be at least 1, got " + std::to_string(triangles)};
    if (given(error_option) && !(std::isfinite(error) && error >= 0))
      return core::Error{"--error must be a finite number >= 0"};
    if (given(grid_option) && grid < 1) return core::Error{"--grid must be at least 1"};
    if (given(placement_option) && mode != "quadric")
      return core::Error{mode == "image"
                             ? "--placement applies to --mode quadric only (image mode always "
                               "places at an endpoint)"
                             : "--placement applies to --mode quadric only (cluster mode places "
                               "one vertex per cell)"};
    if (lock_border && mode == "cluster")
      return core::Error{"--lock-border does not apply to --mode cluster"};
    if (given(max_edge_pixels_option) && mode != "image")
      return core::Error{"--max-edge-pixels applies to --mode image only"};
    if (shading.distance > 0 && shading.pixels > 0)
      return core::Error{"give at most one of --distance D or --pixels N"};
    if (mode == "image" && shading.distance <= 0 && shading.pixels <= 0)
      return core::Error{
          "--mode image simplifies for one viewing distance: give --distance D or "
          "--pixels N"};
    std::string extension = lowerExtension(out);
    if (extension != ".gltf" && extension != ".glb" && extension != ".obj")
      return core::Error{out + ": output must be .gltf, .glb or .obj"};
    return core::okStatus();
  }

  bool wantsImageError() const { return shading.distance > 0 || shading.pixels > 0; }
  bool writesObj() const { return lowerExtension(out) == ".obj"; }
};

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Cluster mode with a triangle or error target: the grid resolution is its only control, so it is
// found by bisection over 1..65536 cells. Triangles grow and the error shrinks with the resolution,
// though not strictly, so the grid found meets the target but need not be the best that does.
mesh::SimplifyResult clusterToTarget(const core::Mesh& input, size_t target_triangles,
                                     double target_error, int* grid_used) {
  const bool by_triangles = target_triangles > 0;
  auto meets = [&](const mesh::SimplifyResult& r) {
    return by_triangles ? r.mesh.triangleCount() <= target_triangles : r.error <= target_error;
  };
  // `good` meets the target, `bad` does not: a triangle target wants the finest such grid, an error
  // target the coarsest.
  int good = by_triangles ? 1 : 65536;
  int bad = by_triangles ? 65536 : 1;
  mesh::SimplifyResult best = mesh::simplifyCluster(input, {.grid_resolution = good});
  while (std::abs(good - bad) > 1) {
    int middle = (good + bad) / 2;
    mesh::SimplifyResult trial = mesh::simplifyCluster(input, {.grid_resolution = middle});
    if (meets(trial)) {
      good = middle;
      best = std::move(trial);
    } else {
      bad = middle;
    }
  }
  // The finest grid under a triangle target can leave no triangle at all (every one with two
  // corners in one cell) where a finer one keeps some: the coarsest grid that keeps any is taken
  // then, above the target (which the simplify line and a warning say), rather than nothing.
  if (by_triangles && best.mesh.triangleCount() == 0) {
    int empty = good, kept = 65536;
    mesh::SimplifyResult finest = mesh::simplifyCluster(input, {.grid_resolution = kept});
    if (finest.mesh.triangleCount() > 0) {
      best = std::move(finest);
      while (kept - empty > 1) {
        const int middle = empty + (kept - empty) / 2;
        mesh::SimplifyResult trial = mesh::simplifyCluster(input, {.grid_resolution = middle});
        if (trial.mesh.triangleCount() > 0) {
          kept = middle;
          best = std::move(trial);
        } else {
          empty = middle;
        }
      }
      good = kept;
    } else {
      good = 65536;  // none keeps any: said so
    }
  }
  *grid_used = good;
  return best;
}

// The normals and tangents a mesh lacks, derived as io::loadAsset derives them (normal_mapped:
// core::normalMappedSubmeshes of its asset): for simplify and generate, which load without them
// when they derive them later (after --reorient, or again on a simplified mesh).
void deriveMissingNormalsAndTangents(core::Mesh& mesh, const std::vector<bool>& normal_mapped) {
  if (mesh.normals.empty()) core::computeNormals(mesh);
  if (mesh.tangents.empty() && !mesh.normals.empty() && !mesh.uv0.empty())
    core::computeTangentsPerSubmesh(mesh, normal_mapped);
}

// `--reorient` (simplify, generate): turns the mesh's triangles round to make its edges
// consistent (mesh::orientConsistently) and returns the line that reports it. Run before normals
// are derived, so that they follow the turned triangles.
std::string reorientLine(core::Mesh& mesh) {
  const mesh::OrientationRepair repair = mesh::orientConsistently(mesh);
  char line[256];
  std::snprintf(line, sizeof line,
                "reorient  %zu triangles turned round, %zu parts (%zu cannot be oriented: left "
                "as they were)\n",
                repair.turned_triangles, repair.parts, repair.non_orientable_parts);
  return line;
}

// The `geometry` line of `simplify`: symmetric Hausdorff and mean distance between the input and
// the result by surface sampling (mesh::surfaceDistance), and where the Hausdorff distance is.
void printGeometryReport(const core::Mesh& input, const core::Mesh& output) {
  const auto start = std::chrono::steady_clock::now();
  mesh::SurfaceDistance distances = mesh::surfaceDistance(input, output);
  // (In double: float's squares vanish for an asset ~1e-20 wide, and the diagonal read 0.)
  // (Its sides in double as well: a float side of an asset spanning ±3e38 is infinite.)
  const core::Bounds bounds = core::computeBounds(input);
  const double side[3] = {double(bounds.max.x) - bounds.min.x, double(bounds.max.y) - bounds.min.y,
                          double(bounds.max.z) - bounds.min.z};
  const double diagonal = std::sqrt(side[0] * side[0] + side[1] * side[1] + side[2] * side[2]);
  const double percent = diagonal > 0 ? 100.0 / diagonal : 0.0;
  // Where the Hausdorff distance is attained: on the input (detail lost) or on the output (it
  // left the surface).
  const bool lost = distances.max_a_to_b >= distances.max_b_to_a;
  const core::Vec3 farthest = lost ? distances.farthest_a_to_b : distances.farthest_b_to_a;
  std::printf(
      "geometry  Hausdorff %.4g (%.3f%% of the bounding-box diagonal %.4g) at (%.4g, %.4g, "
      "%.4g) on the %s, mean %.4g (%.4f%%), %.3f s\n",
      distances.hausdorff, distances.hausdorff * percent, diagonal, farthest.x, farthest.y,
      farthest.z, lost ? "input" : "output", distances.mean, distances.mean * percent,
      secondsSince(start));
}

// The files a mesh output writes beside OUT (io::writeObj's .mtl, writeGltf's .bin, either's
// STEM_textureN images): one that exists without --force fails the write, found before the work.
core::Status checkSideFiles(const std::string& out, bool force, bool textures) {
  if (force) return core::okStatus();
  const fs::path target(out);
  const std::string extension = lowerExtension(out);
  std::vector<fs::path> side;
  if (extension == ".obj") side.push_back(fs::path(target).replace_extension(".mtl"));
  if (extension == ".gltf") side.push_back(fs::path(target).replace_extension(".bin"));
  std::error_code ec;
  for (const fs::path& file : side)
    if (fs::exists(file, ec))
      return core::Error{file.string() + ": already exists, written beside " + out +
                         " (use --force to replace it)"};
  if (textures && (extension == ".obj" || extension == ".gltf")) {
    const std::string prefix = target.stem().string() + "_texture";
    const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    for (const fs::path& entry : entriesOf(folder)) {
      const std::string name = entry.filename().string();  // STEM_textureN.EXT
      if (name.starts_with(prefix) && name.size() > prefix.size() &&
          std::isdigit(static_cast<unsigned char>(name[prefix.size()])))
        return core::Error{entry.string() + ": already exists, and " + out +
                           "'s textures are written under that name (use --force to replace it)"};
    }
  }
  return core::okStatus();
}

int runSimplify(SimplifyFlags& flags) {
  if (auto ok = flags.check(); !ok) return fail(ok.error().message);
  // Before the work, not after it (an image-mode run takes minutes).
  if (auto ok = io::checkWritablePath(flags.out); !ok) return fail(ok.error().message);
  if (auto ok = checkOutputPath(flags.out, {flags.in}, flags.force); !ok)
    return fail(ok.error().message);
  if (auto ok = checkSideFiles(flags.out, flags.force, false); !ok) return fail(ok.error().message);

  auto start = std::chrono::steady_clock::now();
  // A file of positions only (OFF, a bare OBJ or PLY): the quadric and cluster modes simplify the
  // positions (the quadric fast path: CGAL's bunny to 10% in 0.08 s instead of 0.35-0.6 s with
  // generated normals as attributes; mean distance 0.000209 instead of 0.000251) and derive
  // normals again on the result. The shading moves more (bunny at 256 px: eq. 6's epsilon 110.8
  // instead of 96.1, the original's own 87.3); --simplify-generated-normals keeps the former way.
  // A file with other attributes keeps the loader's generated normals and tangents as attributes
  // (spot.obj, UVs and no normals, at 10%: epsilon 680 with them, 804 derived again). The image
  // mode and the image error render, so they see derived normals.
  // Textures are only written back unless something renders: their bytes are kept undecoded
  // (WaterBottle's four 2048² PNGs: load 0.25 s -> 0.011 s, write 1.9 s -> 0.025 s).
  auto asset = loadWithWarnings(flags.in, {.decode_textures = flags.wantsImageError(),
                                           .generate_normals = false,
                                           .generate_tangents = false});
  if (!asset) return fail(asset.error().message);
  if (auto ok = checkSideFiles(flags.out, flags.force, !asset->textures.empty()); !ok)
    return fail(ok.error().message);
  // Before normals are derived, so that they follow the turned triangles.
  const std::string reoriented = flags.reorient ? reorientLine(asset->mesh) : std::string();
  const bool positions_only = asset->mesh.normals.empty() && asset->mesh.tangents.empty() &&
                              asset->mesh.uv0.empty() && asset->mesh.uv1.empty() &&
                              asset->mesh.colors.empty() && !flags.simplify_generated_normals;
  const std::vector<bool> normal_mapped = core::normalMappedSubmeshes(*asset);
  auto derive = [&](core::Mesh& mesh) { deriveMissingNormalsAndTangents(mesh, normal_mapped); };
  // What a renderer sees (the loader's defaults): the asset itself, or for a file of positions
  // only a copy with derived normals.
  core::Asset derived_copy;
  const core::Asset* shaded = &*asset;
  if (positions_only) {
    derived_copy = *asset;
    derive(derived_copy.mesh);
    shaded = &derived_copy;
  } else {
    derive(asset->mesh);
  }
  const core::Mesh& input = asset->mesh;
  const size_t input_triangles = input.triangleCount();
  std::printf("load      %s: %zu triangles, %zu vertices, %.3f s\n", flags.in.c_str(),
              input_triangles, input.vertexCount(), secondsSince(start));
  std::fputs(reoriented.c_str(), stdout);

  size_t target_triangles = 0;
  if (flags.given(flags.ratio_option))
    target_triangles =
        std::max<size_t>(1, size_t(std::lround(double(input_triangles) * flags.ratio)));
  if (flags.given(flags.triangles_option)) target_triangles = size_t(flags.triangles);
  const double target_error =
      flags.given(flags.error_option) ? flags.error : std::numeric_limits<double>::infinity();

  // A renderer is needed for image mode and for the image error at a distance.
  Session session;
  float distance = 0;
  if (flags.wantsImageError()) {
    const core::Sphere sphere = core::computeBoundingSphere(input);
    distance = resolveDistance(flags.shading, sphere);
    // The image error's reference is rendered 4×4 supersampled (below).
    if (auto ok = checkViewpoint(flags.in, flags.shading, sphere, distance, 4,
                                 "the image error's reference");
        !ok)
      return fail(ok.error().message);
    auto opened = openSession(flags.shading);
    if (!opened) return fail(opened.error().message);
    session = std::move(*opened);
  }

  start = std::chrono::steady_clock::now();
  mesh::SimplifyResult result;
  mesh::ImageSimplifyStats image_stats;
  std::string detail;
  char text[256];
  // On a terminal, a line updated five times a second, from the first second on: the image-driven
  // mode renders for each collapse (minutes on large meshes), and the quadric mode on a mesh of a
  // million triangles with normals takes tens of seconds.
  const char* progress_label = flags.mode == "image" ? "image-driven" : "quadric";
  const auto progress_start = std::chrono::steady_clock::now();
  auto last_shown = progress_start;
  bool shown = false;
  auto show_progress = [&](size_t triangles) {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_shown < std::chrono::milliseconds(200) ||
        (!shown && now - progress_start < std::chrono::seconds(1)))
      return;
    last_shown = now;
    shown = true;
    const double seconds = secondsSince(progress_start);
    if (target_triangles > 0 && input_triangles > target_triangles)
      std::fprintf(stderr, "\r  %s: %zu -> %zu triangles (%.0f%%), %.1f s   ", progress_label,
                   triangles, target_triangles,
                   100.0 * (double(input_triangles) - double(triangles)) /
                       (double(input_triangles) - double(target_triangles)),
                   seconds);
    else
      std::fprintf(stderr, "\r  %s: %zu triangles, %.1f s   ", progress_label, triangles, seconds);
    std::fflush(stderr);
  };
  const std::function<void(size_t)> progress =
      isatty(fileno(stderr)) ? std::function<void(size_t)>(show_progress) : nullptr;
  if (flags.mode == "quadric") {
    result = mesh::simplifyQuadric(
        input, {.target_triangles = target_triangles,
                .target_error = target_error,
                .placement = flags.placement == "endpoint" ? mesh::Placement::kEndpoint
                                                           : mesh::Placement::kOptimal,
                .lock_border = flags.lock_border,
                .record = false,
                .progress = progress});
    if (shown) std::fprintf(stderr, "\n");
    std::snprintf(text, sizeof text, "largest collapse error %.4g (asset units)", result.error);
    detail = text;
  } else if (flags.mode == "cluster") {
    int grid = flags.grid;
    if (flags.given(flags.grid_option))
      result = mesh::simplifyCluster(input, {.grid_resolution = grid});
    else
      result = clusterToTarget(input, target_triangles, target_error, &grid);
    std::snprintf(text, sizeof text, "grid %d, largest vertex move %.4g (asset units)", grid,
                  result.error);
    detail = text;
  } else {
    auto source = flags.shading.source();
    if (!source) return fail(source.error().message);
    auto simplified = mesh::simplifyImage(*session.renderer, *shaded, *source,
                                          {.target_triangles = target_triangles,
                                           .target_error = target_error,
                                           .distance = distance,
                                           .display = flags.shading.display(),
                                           .domain = {.views = flags.shading.viewSet()},
                                           .max_edge_pixels = flags.max_edge_pixels,
                                           .lock_border = flags.lock_border,
                                           .record = false,
                                           .progress = progress},
                                          &image_stats);
    if (shown) std::fprintf(stderr, "\n");
    if (!simplified) return fail(simplified.error().message);
    result = std::move(*simplified);
    std::snprintf(text, sizeof text,
                  "distance %g, footprint %d px, epsilon %.4g -> %.4g (eq. 6), %zu rendered "
                  "evaluations",
                  distance, image_stats.footprint_px, image_stats.initial_error,
                  image_stats.final_error, image_stats.rendered_evaluations);
    detail = text;
  }
  const double simplify_seconds = secondsSince(start);
  const size_t output_triangles = result.mesh.triangleCount();
  if (target_triangles > 0 && output_triangles > target_triangles) {
    const mesh::SimplifyStats& s = result.stats;
    const size_t refused = s.rejected_topology + s.rejected_flip + s.rejected_border +
                           image_stats.rejected_long_edges + image_stats.rejected_wide_regions;
    if (flags.mode == "cluster")  // the grid is the only control (clusterToTarget)
      std::snprintf(text, sizeof text,
                    "; target %zu not reached (the coarsest grid that keeps any triangle keeps "
                    "this many)",
                    target_triangles);
    else if (refused == 0)  // no edge was a candidate at all (a cube's corners, say)
      std::snprintf(text, sizeof text,
                    "; target %zu not reached (no edge may collapse: every vertex left is a "
                    "corner of feature lines, seams, material or locked borders)",
                    target_triangles);
    else
      std::snprintf(text, sizeof text,
                    "; target %zu not reached (refused collapses: %zu topology, %zu flip, %zu "
                    "border, %zu longer than %g pixel%s, %zu wider than a tile)",
                    target_triangles, s.rejected_topology, s.rejected_flip, s.rejected_border,
                    image_stats.rejected_long_edges, double(flags.max_edge_pixels),
                    flags.max_edge_pixels == 1.0f ? "" : "s", image_stats.rejected_wide_regions);
    detail += text;
    // The edge-collapse modes never move a vertex of these edges (clustering ignores them).
    if (flags.mode != "cluster") {
      const mesh::SurfaceTopology topology = mesh::surfaceTopology(input);
      if (topology.misoriented_edges + topology.non_manifold_edges > 0) {
        std::snprintf(text, sizeof text,
                      "; the input has %zu misoriented and %zu non-manifold edges (duolod info), "
                      "whose vertices never move%s",
                      topology.misoriented_edges, topology.non_manifold_edges,
                      topology.misoriented_edges > 0 && !flags.reorient
                          ? " (--reorient turns triangles round to make edges consistent)"
                          : "");
        detail += text;
      }
    }
  }
  std::printf("simplify  %s: %zu -> %zu triangles (%.1f%%), %.3f s, %s\n", flags.mode.c_str(),
              input_triangles, output_triangles,
              input_triangles ? 100.0 * double(output_triangles) / double(input_triangles) : 0.0,
              simplify_seconds, detail.c_str());
  // Also on stderr, where a script's log shows warnings: the file is written, but not as asked.
  if (target_triangles > 0 && output_triangles > target_triangles)
    std::fprintf(stderr,
                 "duolod: warning: %s: the target of %zu triangles was not reached (%zu "
                 "left; see the simplify line)\n",
                 flags.in.c_str(), target_triangles, output_triangles);

  // A result with no triangles is no mesh: no reader (ours included) takes such a file, so it is
  // not written. Only the cluster mode gets here (a grid so coarse that every triangle has two
  // corners in one cell); the collapse modes keep at least one triangle per part.
  if (output_triangles == 0 && input_triangles > 0)
    return fail("the result has no triangles (" + detail.substr(0, detail.find(',')) +
                ": every triangle has two corners in one cell); nothing written. " +
                (detail.starts_with("grid 65536,")
                     ? std::string("Even the finest grid keeps none (the mesh's triangles are "
                                   "tiny against its bounding box): use --mode quadric")
                     : std::string("Use a finer --grid or a larger target")));

  // The output keeps the input's materials and textures (and its source path, so that the writers
  // refuse to replace the input or the files beside it).
  core::Asset output = *asset;
  output.mesh = std::move(result.mesh);
  // Normals derived again from the simplified positions (the image mode simplified them as
  // attributes).
  if (flags.mode != "image" && positions_only) derive(output.mesh);
  start = std::chrono::steady_clock::now();
  core::Status written = flags.writesObj()
                             ? io::writeObj(output, flags.out, {.replace_existing = flags.force})
                             : io::writeGltf(output, flags.out, {.replace_existing = flags.force});
  if (!written) return fail(written.error().message);
  std::printf("write     %s: %zu triangles, %zu vertices, %.3f s\n", flags.out.c_str(),
              output.mesh.triangleCount(), output.mesh.vertexCount(), secondsSince(start));

  if (!flags.no_geometry) printGeometryReport(input, output.mesh);

  if (flags.wantsImageError()) {
    start = std::chrono::steady_clock::now();
    const int supersample = 4;
    const core::Asset* approximations[] = {&output, shaded};
    auto comparison =
        compareRendered(session, *shaded, approximations, distance, flags.shading, supersample);
    if (!comparison) return fail(comparison.error().message);
    const metric::ImageError& simplified = comparison->errors[0];
    const metric::ImageError& original = comparison->errors[1];
    // The original's own ε (the aliasing of its plain render) is the scale to read the result by.
    std::printf(
        "image     distance %g, footprint %d px, %d samples (20 views x 5 lights, %dx%d "
        "reference): epsilon %.4g (original %.4g), per-pixel %.4g (original %.4g), "
        "%.3f s\n",
        distance, comparison->footprint_px, simplified.samples, supersample, supersample,
        simplified.epsilon, original.epsilon, simplified.per_pixel, original.per_pixel,
        secondsSince(start));
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// duolod generate: the joint mesh + shader LOD (issue 5).

struct GenerateFlags {
  ShadingFlags shading;
  std::string in, out;
  bool force = false;
  std::string optimizer = "separate", only = "joint", cost = "predicted", mesh_mode = "image";
  std::string level_spacing = "linear";
  lod::GenerateOptions options;
  bool quiet = false, verbose = false, no_compile_ahead = false, move_to_parameter = false;
  CLI::Option* quiet_option = nullptr;
  bool no_sort_prefetch = false;
  bool reorient = false;
  int jobs = 0;
  BoundFlags bound_flags;
  CLI::Option* max_edge_pixels_option = nullptr;

  // Flag combinations, checked before any file is read.
  core::Status check() const {
    if (max_edge_pixels_option && max_edge_pixels_option->count() > 0 && mesh_mode != "image")
      return core::Error{"--max-edge-pixels applies to --mesh-mode image only"};
    return bound_flags.check();
  }

  void add(CLI::App* command) {
    command->add_option("asset", in, "glTF/GLB/OBJ/PLY/OFF file")->required();
    shading.add(command);
    command->add_option("--out", out, "output folder (must not exist or be empty)")->required();
    command->add_flag("--force", force, "write into a non-empty --out folder");
    command->add_flag("--reorient", reorient,
                      "first turn triangles round so that every edge between two triangles runs "
                      "opposite ways in them (closed parts facing outwards, open ones the way "
                      "most of their area faces), then derive the normals and tangents the file "
                      "lacks: mesh simplification never moves a vertex of an edge two triangles "
                      "run the same way, and normals derived across it cancel");
    command->add_option("--optimizer", optimizer, "separate (§5) or interleaved (§4.3)")
        ->check(CLI::IsMember({"separate", "interleaved"}))
        ->capture_default_str();
    command->add_option("--only", only,
                        "joint, or a baseline with the same thresholds: mesh (original shader) "
                        "or shader (original mesh)")
        ->check(CLI::IsMember({"joint", "mesh", "shader"}))
        ->capture_default_str();
    command->add_option("--cost", cost,
                        "cost of a pair: predicted (cost model) or measured (wall clock around "
                        "glFinish for the chosen pairs)")
        ->check(CLI::IsMember({"predicted", "measured"}))
        ->capture_default_str();
    command->add_option("--mesh-mode", mesh_mode,
                        "mesh candidates: image (image-driven per level, the paper) or quadric "
                        "(one quadric record, fast)")
        ->check(CLI::IsMember({"image", "quadric"}))
        ->capture_default_str();
    max_edge_pixels_option =
        addMaxEdgePixels(command, options.max_edge_pixels, "--mesh-mode image");
    command->add_option("--levels", options.levels.level_count, "number of distance levels N")
        ->check(between(1, lod::kMaxLevelCount))
        ->capture_default_str();
    command
        ->add_option("--level-spacing", level_spacing,
                     "linear: d_i evenly spaced in [d_near, d_far] (§3.3); geometric: equal "
                     "ratios of projected size, so level 1 begins nearer")
        ->check(CLI::IsMember({"linear", "geometric"}))
        ->capture_default_str();
    bound_flags.add(command, options.levels.bound, options.near_footprint_px,
                    options.far_footprint_px);
    command->add_option("--candidates", options.mesh_candidates, "mesh candidates K per level")
        ->check(between(1, 1000000))
        ->capture_default_str();
    command
        ->add_option("--shader-levels", options.shader_search_levels,
                     "levels whose meshes get a GP shader search")
        ->check(atLeast(0))
        ->capture_default_str();
    command
        ->add_option("--shader-meshes", options.shader_search_meshes,
                     "meshes per such level searched")
        ->check(atLeast(1))
        ->capture_default_str();
    command->add_option("--population", options.population, "GP population size")
        ->check(atLeast(2))
        ->capture_default_str();
    command->add_option("--generations", options.generations, "GP generations")
        ->check(atLeast(0))
        ->capture_default_str();
    command->add_option("--seed", options.seed, "GP random seed")
        ->check(atLeast(0))
        ->capture_default_str();
    command->add_option("--time-tolerance", options.time_tolerance, "T of Algorithm 2")
        ->check(atLeast(0))
        ->capture_default_str();
    command->add_option("--merge-gain", options.merge_min_gain, "W of §6.2")
        ->check(atLeast(0))
        ->capture_default_str();
    command
        ->add_option("--bound-margin", options.bound_margin,
                     "searches aim at (1 - margin) x the error bound, so views and lights "
                     "outside the training domain stay within it")
        ->check(between(0, 0.9))
        ->capture_default_str();
    command
        ->add_option("--bisection-stop", options.bisection_stop,
                     "Algorithm 2's bisection stops when its bracketing meshes differ by at "
                     "most this fraction of their triangles (0 = the exact boundary)")
        ->check(between(0, 0.5))
        ->capture_default_str();
    command->add_flag("--brute-force", options.brute_force,
                      "search all mesh × shader pairs (the paper's 2D comparison)");
    quiet_option = command->add_flag("--quiet", quiet, "no progress display");
    command->add_flag("--move-to-parameter", move_to_parameter,
                      "also offer moving to parameter in the GP searches (a computed value "
                      "replaced by a uniform holding its average over the training domain)");
    command->add_flag("--no-compile-ahead", no_compile_ahead,
                      "compile shader variants only when scored (default: a worker thread with "
                      "its own GL context compiles the GP's coming ones; same results)");
    command->add_flag("--no-sort-prefetch", no_sort_prefetch,
                      "render SortByError's pairs (every shader on the original mesh) only when "
                      "the pair search reaches them (default: a second thread with its own GL "
                      "context renders them ahead; same results)");
    command->add_option("--jobs", jobs,
                        "threads the renderer may use (Mesa llvmpipe's LP_NUM_THREADS; 0 = one "
                        "per core, its default)")
        ->check(CLI::Range(0, 64))
        ->capture_default_str();
    command
        ->add_flag("--verbose", verbose,
                   "log each stage and step with its elapsed time (also when not a terminal)")
        ->excludes(quiet_option);
  }
};

// A one-line progress display with the stage, a bar and an ETA, only on a terminal; and/or a log
// of stage changes and finished steps with the elapsed time (--verbose, any output).
class ProgressLine {
 public:
  ProgressLine(bool bar, bool log) : bar_(bar), log_(log), start_(Clock::now()) {}
  ~ProgressLine() { finish(); }
  void update(const lod::GenerateProgress& progress) {
    if (!bar_ && !log_) return;
    auto now = Clock::now();
    if (progress.stage != stage_) {
      finish();
      stage_ = std::string(progress.stage);
      stage_start_ = now;
      if (log_) logLine(now, "stage: " + stage_);
    }
    if (log_ && !progress.detail.empty()) {
      finish();
      logLine(now, std::string(progress.detail));
    }
    if (!bar_) return;
    double elapsed = std::chrono::duration<double>(now - stage_start_).count();
    double fraction = std::clamp(progress.fraction, 0.0, 1.0);
    int filled = static_cast<int>(fraction * 30);
    std::string bar(filled, '#');
    bar.resize(30, '.');
    char eta[32] = "";
    if (fraction > 0.02) std::snprintf(eta, sizeof eta, "ETA %.0f s", elapsed * (1 - fraction) / fraction);
    std::fprintf(stderr, "\r  %-18s [%s] %3.0f%% %6.1f s %s   ", stage_.c_str(), bar.c_str(),
                 fraction * 100, elapsed, eta);
    std::fflush(stderr);
    shown_ = true;
  }
  void finish() {
    if (shown_) std::fprintf(stderr, "\n");
    shown_ = false;
  }

 private:
  using Clock = std::chrono::steady_clock;
  void logLine(Clock::time_point now, const std::string& text) {
    std::fprintf(stderr, "[%7.1f s] %s\n", std::chrono::duration<double>(now - start_).count(),
                 text.c_str());
    std::fflush(stderr);
  }
  bool bar_, log_;
  bool shown_ = false;
  std::string stage_;
  Clock::time_point start_, stage_start_;
};

// The nearest level's reference is rendered supersampled at d_near: a viewpoint the renderer
// cannot take (a tile beyond its limit, a camera inside the object) is refused before any work.
// (The library found it only when its references stage started, after the asset's set-up.)
core::Status checkNearestLevel(const GenerateFlags& flags, const core::Asset& asset) {
  const double d_near = flags.options.levels.bound.d_near;
  const int supersample = flags.options.supersample;
  const int limit_px = largestSupersampledPixels(supersample);
  if (d_near > 0) {
    return checkViewpointAt(
        flags.in, "--d-near " + formatNumber(d_near), core::computeBoundingSphere(asset.mesh),
        float(d_near), flags.shading.display(), supersample, "the nearest level's reference",
        "give a larger --d-near (where it spans at most " + std::to_string(limit_px) + " px)");
  }
  if (flags.options.near_footprint_px > limit_px)
    return core::Error{flags.in + ": --near-pixels " +
                       std::to_string(flags.options.near_footprint_px) +
                       ": the nearest level's reference, rendered " + std::to_string(supersample) +
                       "×" + std::to_string(supersample) + " supersampled, would be above the " +
                       "renderer's " + std::to_string(render::kMaxTileSize) +
                       " px: give at most --near-pixels " + std::to_string(limit_px)};
  return core::okStatus();
}

int runGenerate(GenerateFlags& flags) {
  auto start = std::chrono::steady_clock::now();
  if (auto valid = flags.check(); !valid) return fail(valid.error().message);
  slow_first_draw_consequence =
      "The shader searches compile a program for each variant they render, most of them about as "
      "slowly: fewer --shader-levels, --shader-meshes, --generations and --population compile "
      "fewer.";
  // Refuse a bad output folder before the long work, not after.
  if (auto ok = checkOutputFolder(
          flags.out, flags.force,
          {flags.in, flags.shading.vert, flags.shading.frag, flags.shading.bindings},
          "summary.json", "shader");
      !ok)
    return fail(ok.error().message);
  // With --reorient the normals and tangents the file lacks are derived after the turn (as the
  // loader would derive them), so that they follow the turned triangles.
  auto asset = loadWithWarnings(
      flags.in, {.generate_normals = !flags.reorient, .generate_tangents = !flags.reorient});
  if (!asset) return fail(asset.error().message);
  std::string reoriented;
  if (flags.reorient) {
    reoriented = reorientLine(asset->mesh);
    deriveMissingNormalsAndTangents(asset->mesh, core::normalMappedSubmeshes(*asset));
  } else if (const size_t misoriented = mesh::surfaceTopology(asset->mesh).misoriented_edges;
             misoriented > 0) {
    // Found before the long work: such a mesh stops short of coarse levels.
    std::fprintf(stderr,
                 "duolod: warning: %s: %zu edges are misoriented (two triangles run them the "
                 "same way): mesh simplification never moves their vertices, and normals "
                 "derived across them cancel; --reorient turns triangles round first\n",
                 flags.in.c_str(), misoriented);
  }
  if (auto ok = checkNearestLevel(flags, *asset); !ok) return fail(ok.error().message);
  auto source = flags.shading.source();
  if (!source) return fail(source.error().message);
  lod::GenerateOptions options = flags.options;
  options.levels.display = flags.shading.display();
  options.device = flags.shading.device;
  auto bindings = flags.shading.parsedBindings();
  if (!bindings) return fail(bindings.error().message);
  options.bindings = *bindings;
  options.compile_ahead = !flags.no_compile_ahead;
  options.sort_prefetch = !flags.no_sort_prefetch;
  options.move_to_parameter = flags.move_to_parameter;
  options.optimizer =
      flags.optimizer == "separate" ? lod::Optimizer::kSeparate : lod::Optimizer::kInterleaved;
  options.levels.spacing =
      flags.level_spacing == "geometric" ? lod::LevelSpacing::kGeometric : lod::LevelSpacing::kLinear;
  options.views = flags.shading.viewSet();
  options.scope = flags.only == "mesh"     ? lod::LodScope::kMeshOnly
                  : flags.only == "shader" ? lod::LodScope::kShaderOnly
                                           : lod::LodScope::kJoint;
  options.cost_source =
      flags.cost == "measured" ? lod::CostSource::kMeasured : lod::CostSource::kPredicted;
  options.mesh_mode = flags.mesh_mode == "quadric" ? lod::MeshCandidateMode::kQuadric
                                                   : lod::MeshCandidateMode::kImage;
  // llvmpipe reads LP_NUM_THREADS when the context is created (generateLod creates it).
  if (flags.jobs > 0) setenv("LP_NUM_THREADS", std::to_string(flags.jobs).c_str(), 1);
  ProgressLine line(!flags.quiet && !flags.verbose && isatty(fileno(stderr)), flags.verbose);
  options.progress = [&](const lod::GenerateProgress& progress) { line.update(progress); };
  std::printf("generate  %s: %zu triangles, shader %s + %s\n", flags.in.c_str(),
              asset->mesh.triangleCount(), source->vertex_name.c_str(),
              source->fragment_name.c_str());
  std::fputs(reoriented.c_str(), stdout);
  auto result = lod::generateLod(*asset, *source, options);
  line.finish();
  if (!result) return fail(result.error().message);
  auto export_start = std::chrono::steady_clock::now();
  // All or nothing: a failure leaves the folder as it was (io::OutputFolder).
  if (auto written = lod::writeLodOutput(*result, *asset, options, flags.out, flags.force);
      !written)
    return fail(written.error().message);
  removeStaleLevelFiles(flags.out, result->levels.size(),
                        [](size_t k) { return "level" + std::to_string(k); });
  result->timings.export_seconds = secondsSince(export_start);

  std::printf("device    %s\n", result->device.c_str());
  std::printf("levels    %zu of %zu kept; %d shader candidates; %d pair evaluations, %d transitions\n",
              result->levels.size(), result->all_levels.size(), result->shader_candidates,
              result->pair_evaluations, result->transition_evaluations);
  std::printf("\n  level  distance  pixels  triangles  error      bound      cost (%s)  shader\n",
              flags.cost.c_str());
  for (size_t k = 0; k < result->levels.size(); ++k) {
    const lod::GeneratedLevel& level = result->levels[k];
    double cost = flags.cost == "measured" ? level.measured_cost : level.predicted_cost;
    std::printf("  %5zu  %8.3f  %6d  %9zu  %-9.4g  %-9.4g  %-9.3g%s  %s\n", k, level.level.distance,
                level.level.footprint_px, level.mesh.triangleCount(), level.error, level.error_bound,
                cost * 1e3, " ms", level.original_fallback ? "(original: nothing within the bound)"
                                                          : level.shader_summary.c_str());
  }
  std::printf("\n  held-out views and lights (%s, light cross turned 45 deg)\n",
              options.views == render::ViewSet::kUpright ? "12 other views of the upright band"
                                                         : "icosahedron");
  std::printf("  level  error      bound      within\n");
  int violations = 0;
  for (const lod::HeldOutCheck& check : result->held_out) {
    std::printf("  %5d  %-9.4g  %-9.4g  %s\n", check.level, check.error, check.bound,
                check.within ? "yes" : (check.original_fallback ? "no (original)" : "NO"));
    if (!check.within && !check.original_fallback) ++violations;
  }
  if (!result->levels.empty() && result->levels.front().error_bound <= 0)
    std::printf("  (level 0 is the original at d_near, where the bound is 0: not re-checked)\n");
  for (const lod::HeldOutCheck& dropped : result->dropped) {
    std::printf("  dropped: the pair chosen at d = %.6g (%d px) erred %.4g there, over its bound "
                "%.4g; the level before covers its distances and errs %.4g there (%s)\n",
                result->all_levels[dropped.distance_level].distance,
                result->all_levels[dropped.distance_level].footprint_px, dropped.error,
                dropped.bound, dropped.covering_error,
                dropped.covering_error < dropped.bound ? "within" : "OVER");
    if (dropped.covering_error >= dropped.bound) ++violations;
  }
  const lod::GenerateTimings& t = result->timings;
  std::printf(
      "\ntime      references %.1f s, mesh %.1f s, shader %.1f s, optimization %.1f s, "
      "export %.1f s, total %.1f s\n",
      t.setup_seconds, t.mesh_seconds, t.shader_seconds, t.optimization_seconds, t.export_seconds,
      secondsSince(start));
  if (t.shader_search_seconds > 0)
    std::printf("          (the shader searches took %.1f s, alongside the mesh stage until it "
                "ended; the shader stage is what they added after it)\n",
                t.shader_search_seconds);
  // What the folder holds, by name pattern: lod.gltf's buffer and images go with it.
  bool has_bin = false, has_images = false;
  std::error_code ec;
  for (fs::directory_iterator it(flags.out, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    has_bin |= name == "lod.bin";
    has_images |= name.starts_with("lod_");
  }
  std::printf("wrote     %s{lod.gltf%s%s, lod.json, report.html, level*.*, autolod.*}\n",
              (fs::path(flags.out) / "").string().c_str(),  // one '/', with or without "out/"
              has_bin ? ", lod.bin" : "", has_images ? ", lod_*" : "");
  if (violations > 0) {
    std::fprintf(stderr, "duolod: warning: %d level(s) exceed their bound on held-out views\n",
                 violations);
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// duolod shader: shader LOD for one (mesh, distance) configuration (issue 4).

struct ShaderFlags {
  std::string in, out;
  std::string search = "gp";
  uint64_t seed = 1;
  int generations = 20;
  int population = 24;
  int greedy_steps = 32;
  int greedy_candidates = 64;
  bool no_timing = false, no_compile_ahead = false;
  bool force = false;
  ShadingFlags shading;
  // The search's own flags: each applies to one --search only.
  std::vector<CLI::Option*> gp_options, greedy_options;

  // A flag of the other search is a mistake the run would hide (it ignored them).
  core::Status check() const {
    for (const CLI::Option* option : search == "gp" ? greedy_options : gp_options)
      if (option->count() > 0)
        return core::Error{option->get_name() + " applies to --search " +
                           (search == "gp" ? "greedy" : "gp") + " only"};
    return core::okStatus();
  }

  void add(CLI::App* command) {
    command->add_option("asset", in, "glTF/GLB/OBJ/PLY/OFF file")->required();
    shading.add(command);
    command
        ->add_option("--distance", shading.distance,
                     "camera distance from the bounding-sphere centre, in asset units")
        ->check(positive());
    command
        ->add_option("--pixels", shading.pixels,
                     "alternatively: the distance at which the object spans N pixels")
        ->check(between(1, 16384));
    command->add_option("--search", search, "gp (genetic programming, NSGA-II) or greedy (He et al.)")
        ->check(CLI::IsMember({"gp", "greedy"}))
        ->capture_default_str();
    gp_options.push_back(command->add_option("--seed", seed, "GP random seed")
                             ->check(atLeast(0))
                             ->capture_default_str());
    gp_options.push_back(command->add_option("--generations", generations, "GP generations")
                             ->check(atLeast(0))
                             ->capture_default_str());
    gp_options.push_back(command->add_option("--population", population, "GP population size")
                             ->check(atLeast(2))
                             ->capture_default_str());
    greedy_options.push_back(
        command->add_option("--steps", greedy_steps, "greedy: most rules applied")
            ->check(atLeast(1))
            ->capture_default_str());
    greedy_options.push_back(
        command
            ->add_option("--candidates", greedy_candidates,
                         "greedy: sites scored per step, spread evenly over all sites (0: every "
                         "site; noise_phong offers ~650, each one a compile and two renders)")
            ->check(atLeast(0))
            ->capture_default_str());
    command->add_flag("--no-timing", no_timing, "skip the wall-clock timing of the variants");
    command->add_flag(
        "--no-compile-ahead", no_compile_ahead,
        "compile the variants only when scored (default: worker threads with their own "
        "GL contexts compile the coming ones, the GP's offspring or the greedy step's "
        "candidates, on the other cores; same results)");
    command->add_option("--out", out, "folder for the variants, the autoLOD shader and summary.json")
        ->required();
    command->add_flag("--force", force, "write into --out even if it holds files");
  }
};

// One rule in words ("per-vertex: fragment: ..."), or for several how many of each kind ("3
// rules: per-vertex, texture average, operation removal ×2"; summary.json spells them out), cut
// or padded to `width` characters.
std::string rulesInWords(const std::vector<shader::RuleSite>& sites, size_t width) {
  std::string text = shader::describeSites(sites);
  if (sites.size() > 1) {
    std::vector<std::pair<std::string, int>> kinds;  // in order of first appearance
    for (const shader::RuleSite& site : sites) {
      const std::string words = shader::describeSites({site});
      const std::string kind = words.substr(0, words.find(':'));
      auto found = std::find_if(kinds.begin(), kinds.end(),
                                [&](const auto& entry) { return entry.first == kind; });
      if (found == kinds.end())
        kinds.emplace_back(kind, 1);
      else
        ++found->second;
    }
    text = std::to_string(sites.size()) + " rules:";
    for (size_t i = 0; i < kinds.size(); ++i)
      text += (i ? ", " : " ") + kinds[i].first +
              (kinds[i].second > 1 ? " ×" + std::to_string(kinds[i].second) : "");
  }
  // Width in characters, cut between UTF-8 sequences (the rules' words hold "→", 3 bytes).
  auto isContinuation = [](char c) { return (static_cast<unsigned char>(c) & 0xC0) == 0x80; };
  size_t characters = 0, cut = text.size();
  for (size_t i = 0; i < text.size(); ++i) {
    if (isContinuation(text[i])) continue;
    if (characters == width - 3) cut = std::min(cut, i);
    if (++characters > width) {
      text = text.substr(0, cut) + "...";
      characters = width;
      break;
    }
  }
  // Padded to the column here: printf's %-52s would count bytes.
  return text + std::string(width - std::min(characters, width), ' ');
}

int runShader(ShaderFlags& flags) {
  if (!(flags.shading.distance > 0) && !(flags.shading.pixels > 0))
    return fail("shader: give --distance D (> 0) or --pixels N");
  if (auto ok = flags.check(); !ok) return fail(ok.error().message);
  slow_first_draw_consequence =
      flags.search == "gp"
          ? "The search compiles a program for each variant it renders, most of them about as "
            "slowly: fewer --generations and --population compile fewer."
          : "The search compiles a program for each variant it renders, most of them about as "
            "slowly: fewer --steps and --candidates compile fewer.";
  // Refuse a bad output folder before the long work, not after.
  if (auto ok = checkOutputFolder(
          flags.out, flags.force,
          {flags.in, flags.shading.vert, flags.shading.frag, flags.shading.bindings}, "lod.json",
          "generate");
      !ok)
    return fail(ok.error().message);
  auto source = flags.shading.source();
  if (!source) return fail(source.error().message);
  auto asset = loadWithWarnings(flags.in);
  if (!asset) return fail(asset.error().message);

  shader::ShaderLodOptions options;
  const core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  options.distance = resolveDistance(flags.shading, sphere);
  // Variants are compared with the original's reference, rendered 4×4 supersampled.
  if (auto ok = checkViewpoint(flags.in, flags.shading, sphere, options.distance, 4,
                               "the original's reference");
      !ok)
    return fail(ok.error().message);
  options.display = flags.shading.display();
  options.evaluation.domain.views = flags.shading.viewSet();
  options.device = flags.shading.device;
  auto bindings = flags.shading.parsedBindings();
  if (!bindings) return fail(bindings.error().message);
  options.bindings = *bindings;
  options.method = flags.search == "gp" ? shader::SearchMethod::kGenetic : shader::SearchMethod::kGreedy;
  options.genetic.seed = flags.seed;
  options.genetic.generations = flags.generations;
  options.genetic.population_size = flags.population;
  // Progress on stderr: a line per generation or greedy step (a greedy step scores up to
  // --candidates variants, each a compile and renders: tens of seconds on llvmpipe).
  const auto search_start = std::chrono::steady_clock::now();
  const auto elapsed = [search_start] { return secondsSince(search_start); };
  options.genetic.on_generation = [&](int generation, const shader::SearchCounters& counters) {
    std::fprintf(stderr, "duolod: generation %d of %d: %d variants predicted, %d genomes, %.0f s\n",
                 generation, flags.generations, counters.variants_predicted,
                 counters.genomes_evaluated, elapsed());
  };
  options.greedy.on_step = [&](int step, const shader::SearchCounters& counters) {
    std::fprintf(stderr, "duolod: step %d of at most %d: %d variants predicted, %.0f s\n", step,
                 flags.greedy_steps, counters.variants_predicted, elapsed());
  };
  options.greedy.max_steps = flags.greedy_steps;
  options.greedy.max_candidates_per_step = flags.greedy_candidates;
  options.measure_time = !flags.no_timing;
  options.compile_ahead = !flags.no_compile_ahead;
  auto report = shader::runShaderLod(*asset, *source, options);
  if (!report) return fail(report.error().message);
  if (auto written = shader::writeShaderLod(*report, flags.out, flags.force); !written)
    return fail(written.error().message);
  removeStaleLevelFiles(flags.out, report->variants.size(), shader::levelFileName);

  std::printf("%s at distance %s (footprint %d px, %d samples), %s search on %s\n", flags.in.c_str(),
              formatNumber(options.distance).c_str(), report->footprint_px, report->domain_samples,
              flags.search.c_str(), report->device.c_str());
  std::printf("%-6s %-52s %14s %10s %10s\n", "level", "rules applied", "pred. ms/draw",
              "time ratio", "error/px");
  for (size_t k = 0; k < report->variants.size(); ++k) {
    const shader::ShaderLodVariant& variant = report->variants[k];
    std::string ratio = options.measure_time ? formatNumber(variant.time_ratio) : "-";
    std::printf("%-6zu %s %14.4g %10s %10.4g\n", k, rulesInWords(variant.search.sites, 52).c_str(),
                variant.search.predicted_cost * 1e3, ratio.c_str(),
                variant.search.rendered_error.value_or(-1));
  }
  if (report->dropped_costlier > 0)
    std::printf(
        "(%d variant%s of the front predicted to cost as much as the original or more: not "
        "levels, left out)\n",
        report->dropped_costlier, report->dropped_costlier == 1 ? "" : "s");
  const shader::SearchCounters& counters = report->search;
  std::printf("variants: %d generated, %d predicted (%d compiled ahead), %d rendered, %d compiled; "
              "search %.1f s, total %.1f s\n",
              counters.variants_generated, counters.variants_predicted, report->compiled_ahead,
              counters.variants_rendered, report->compile.programs_compiled,
              report->search_seconds, report->total_seconds);
  std::printf("wrote %zu levels, the autoLOD shader (uniform float autoLOD at location %u) and "
              "summary.json to %s\n",
              report->variants.size(), report->autolod.autolod_location, flags.out.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Ctrl-C or a kill takes the unfinished output away (before any thread starts: see there).
  io::removeUnfinishedOutputsOnInterrupt("duolod");
  // The library's warnings in the CLI's own form.
  core::setLogSink([](core::LogLevel level, std::string_view message) {
    static const char* kNames[] = {"debug", "info", "warning", "error"};
    std::fprintf(stderr, "duolod: %s: %.*s\n", kNames[static_cast<int>(level)],
                 static_cast<int>(message.size()), message.data());
  });
  CLI::App app{
      "duolod " DUOLOD_VERSION
      " - automatic mesh and shader level of detail.\n"
      "Simplifies a 3D asset's mesh and shader together and picks, for every viewing distance,\n"
      "the cheapest pair whose rendered image stays within an error bound (Liang et al.)."};
  app.set_version_flag("-v,--version", std::string("duolod ") + DUOLOD_VERSION);
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
  render_cmd
      ->add_option("--distance", render_flags.distance,
                   "camera distance from the bounding-sphere centre, in asset units")
      ->check(positive());
  render_cmd
      ->add_option("--pixels", render_flags.pixels,
                   "alternatively: the distance at which the object spans N pixels")
      ->check(between(1, 16384));
  render_cmd->add_option("--view", render_view, "one view 0-19 (default: all, as a contact sheet)")
      ->check(between(0, 19));
  render_cmd->add_option("--light", render_light, "light 0-4")
      ->check(between(0, 4))
      ->capture_default_str();
  render_cmd
      ->add_option("--supersample", render_supersample,
                   "k: render k×k larger and box-filter (the reference of eq. 1)")
      ->check(between(1, 16))
      ->capture_default_str();
  render_cmd->add_option("--out", render_out, "PNG to write")->required();
  render_cmd->add_flag("--force", render_force, "replace --out if it exists");

  ShadingFlags error_flags;
  std::string error_a, error_b;
  int error_supersample = 4;
  ErrorBound error_bound;
  CLI::App* error_cmd = app.add_subcommand(
      "error", "Image error (eq. 6) of ASSET_B against the supersampled reference of ASSET_A");
  error_cmd->add_option("asset_a", error_a, "the original (reference) asset")->required();
  error_cmd->add_option("asset_b", error_b, "the approximation")->required();
  error_flags.add(error_cmd);
  error_cmd->add_option("--distance", error_flags.distance, "camera distance, asset units")
      ->check(positive());
  error_cmd->add_option("--pixels", error_flags.pixels, "alternatively: footprint in pixels")
      ->check(between(1, 16384));
  error_cmd->add_option("--supersample", error_supersample, "reference supersampling k")
      ->check(between(1, 16))
      ->capture_default_str();
  error_bound.flags.add(error_cmd, error_bound.bound, error_bound.near_pixels,
                        error_bound.far_pixels);
  bool error_check = false;
  error_cmd->add_flag("--check", error_check,
                      "exit with code 3 when ASSET_B is not within the bound (for scripts)");

  SimplifyFlags simplify_flags;
  CLI::App* simplify_cmd = app.add_subcommand(
      "simplify", "Simplify an asset's mesh (quadric, image-driven or clustering) and write it");
  simplify_flags.add(simplify_cmd);

  GenerateFlags generate_flags;
  CLI::App* generate_cmd = app.add_subcommand(
      "generate",
      "Generate the joint mesh + shader LOD of an asset: levels, glTF chain, shaders, lod.json, "
      "report.html");
  generate_flags.add(generate_cmd);
  ShaderFlags shader_flags;
  CLI::App* shader_cmd = app.add_subcommand(
      "shader", "Simplify an asset's shader for a distance: Pareto variants and an autoLOD shader");
  shader_flags.add(shader_cmd);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // CLI11's own messages in duolod's form; exit code 2, as for usage errors by convention.
    std::string message = e.what();
    if (argc > 1 && argv[1][0] != '-' && app.get_subcommands().empty()) {
      message = std::string("unknown command '") + argv[1] + "'; the commands are";
      for (const CLI::App* command : app.get_subcommands({})) message += " " + command->get_name();
    }
    std::fprintf(stderr, "duolod: error: %s\n(run 'duolod%s%s --help' for the options)\n",
                 message.c_str(), app.get_subcommands().empty() ? "" : " ",
                 app.get_subcommands().empty() ? "" : app.get_subcommands()[0]->get_name().c_str());
    return 2;
  }

  reportSlowGpuRequests();
  // A request larger than memory ends as an error, not an abort: the commands' unfinished
  // outputs are removed as the stack unwinds (`error --pixels 4095` asked for 100 float images
  // of 4095² pixels, 27 GB, and ended in "terminate called ... std::bad_alloc", exit 134).
  try {
    if (*info) return runInfo(info_path);
    if (*render_cmd)
      return runRender(render_path, render_flags, render_view, render_light, render_supersample,
                       render_out, render_force);
    if (*error_cmd)
      return runError(error_a, error_b, error_flags, error_supersample, error_bound, error_check);
    if (*simplify_cmd) return runSimplify(simplify_flags);
    if (*generate_cmd) return runGenerate(generate_flags);
    if (*shader_cmd) return runShader(shader_flags);
  } catch (const std::bad_alloc&) {
    return fail(
        "out of memory: the request needs more than this machine has (fewer pixels, "
        "samples, candidates or triangles need less)");
  }
  return 0;
}
