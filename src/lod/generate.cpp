// Joint mesh + shader LOD generation, end to end: Liang et al., "Automatic Mesh and Shader Level of
// Detail", Algorithm 1 (§3.3, §5) with the smoothest path (§6.1) and merging (§6.2).
//
//   levels        N distances between d_near and d_far, bounds e_a(d_i)·s_d (eq. 3/4)
//   references    f̄(M_0, S_0, d_i) per level, k×k supersampled (eq. 1)
//   meshes        image-driven simplification per level against that reference, K candidates
//                 where the error changes most (§4.2, §5.1); or one quadric record (fast mode)
//   shaders       GP Pareto fronts (predicted cost and error) at a few levels on a few of their
//                 meshes, united and shared by all levels (§5.2)
//   pairs         SortByError + SearchPairs per level with rendered errors (Algorithm 2)
//   path, merge   Algorithm 3 over the pair sets, then §6.2
//
// Every rendered pair is cached by (distance level, mesh set, mesh, shader), so the baselines
// (mesh only, shader only) are the same problem restricted to one axis and cost almost nothing
// extra. Costs are per draw (one view of the object), in seconds: predicted by the cost model
// from the pair's own vertex and fragment invocation counts, or measured on the wall clock.
#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <tuple>

#include "core/clock.hpp"
#include "duolod/io.hpp"
#include "duolod/lod.hpp"
#include "duolod/mesh.hpp"
#include "duolod/shader.hpp"
#include "lod/separate.hpp"
#include "lod/sort_prefetch.hpp"
#include "shader/autolod.hpp"
#include "shader/cost_model.hpp"
#include "shader/evaluate.hpp"
#include "shader/instrument.hpp"
#include "shader/nsga2.hpp"
#include "shader/rules.hpp"
#include "shader/scoring.hpp"
#include "shader/search.hpp"
#include "shader/summary.hpp"

namespace duolod::lod {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using render::Renderer;

std::string shortNumber(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", value);
  return text;
}

using core::internal::secondsSince;

// How a GP configuration scores variants: at `distance`, on the run's display and supersampling.
shader::EvaluationConfig evaluationConfig(const GenerateOptions& options, float distance) {
  shader::EvaluationConfig config;
  config.distance = distance;
  config.display = options.levels.display;
  config.supersample = options.supersample;
  config.domain.views = options.views;
  return config;
}

struct LevelState {
  DistanceLevel level;
  std::vector<render::Sample> samples;
  render::ImageBatchF reference;  // f̄(M_0, S_0, d_i); its first tile only once trimmed
  bool trimmed = false;           // (referenceOf renders it whole again if ever needed)
  double coverage_px = 0;         // s_d, measured on the reference
  double bound = 0;               // e_a(d_i)·s_d
  double search_bound = 0;        // what the searches aim at: bound × (1 − bound_margin)
};

// One mesh candidate: a prefix of a simplification's progressive record (§5.1), extracted when
// first needed (rendered, handed to a shader search, exported) and kept from then on, or a mesh
// given as it is (the original). Sets share candidates (a level's set carries the nearer
// level's), so each is extracted and uploaded once. Extracting all K (500) candidates of every
// level up front kept them all: on spot's ten levels ~450 MB of the run's 1.69 GB peak (K = 50:
// 1.24 GB), where the pair search renders a few dozen of each set (bench/RESULTS.md, session 47).
struct MeshCandidate {
  std::shared_ptr<const mesh::ProgressiveRecord> record;  // null when `mesh` was given
  size_t step = 0;
  size_t triangles = 0;
  std::shared_ptr<const core::Mesh> mesh;  // extracted (or given)
  Renderer::AssetId uploaded = -1;
};

// The candidates of one level's mesh set; index 0 is the original (or the level's start mesh).
struct MeshSet {
  std::vector<std::shared_ptr<MeshCandidate>> meshes;
  // The simplifier's error of each candidate (image: ε; quadric: 0); infinity for the quadric
  // continuation's, whose ε is known only once a pair is rendered.
  std::vector<double> errors;
  // Image mode: meshes[0, cascade) come from the image-driven cascade (carried and the level's
  // own); the rest continue past its coarsest mesh by quadric collapses (makeMeshCandidates).
  size_t cascade = 0;
};

struct ShaderCandidate {
  std::shared_ptr<const shader::ShaderProgram> program;
  shader::Variant variant;  // optimised: what is rendered and timed
  std::string summary;
  bool profiled = false;
  shader::OpClassCounts vertex_ops{}, fragment_ops{};  // per invocation (the cost model)
};

struct PairRecord {
  metric::ImageError error;
  double cost = 0;  // predicted seconds per draw
};

// §5.2's GP configurations, run on a thread of their own with their own GL context while the
// mesh cascade goes on: each configuration starts as soon as its level's mesh set is complete.
// Why: the cascade is bound by llvmpipe's rasterizer (one per screen, shared by all contexts:
// perf had it ~1.4 cores busy) and the GP by LLVM compiling on the compile-ahead workers; side by
// side they fill both cores. A configuration's results depend only on its inputs and seed, so
// running it here instead of on the caller's thread changes nothing but the time.
class ShaderSearchThread {
 public:
  struct Configuration {
    int index = 0;  // in the order configurations are made: seed and merge order
    int level = 0, mesh = 0;
    core::Mesh drawn;  // a copy: the caller's mesh sets keep growing meanwhile
    float distance = 0;
  };
  struct Event {
    std::string line;  // a finished configuration's summary
    int finished = 0;  // configurations done so far
  };

  ShaderSearchThread(const core::Asset& asset, const shader::ShaderProgram& original,
                     shader::RuleContext context, const GenerateOptions& options,
                     render::ContextOptions gl)
      : asset_(asset),
        original_(original),
        context_(std::move(context)),
        options_(options),
        gl_(std::move(gl)) {
    thread_ = std::thread([this] { run(); });
  }
  ~ShaderSearchThread() {
    {
      std::lock_guard lock(mutex_);
      cancelled_ = closed_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }
  void add(Configuration configuration) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(configuration));
      ++added_;
    }
    changed_.notify_all();
  }
  int added() const {
    std::lock_guard lock(mutex_);
    return added_;
  }
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    changed_.notify_all();
  }
  // Finished-configuration lines so far (without waiting).
  std::vector<Event> takeEvents() {
    std::lock_guard lock(mutex_);
    return std::exchange(events_, {});
  }
  // Waits for the next event; nothing once every configuration is done (or one failed).
  std::optional<Event> waitEvent() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return !events_.empty() || done_; });
    if (events_.empty()) return std::nullopt;
    Event event = std::move(events_.front());
    events_.erase(events_.begin());
    return event;
  }
  // After waitEvent() returned nothing: every configuration's front, by configuration index.
  // An exception the thread ended with (std::bad_alloc) is rethrown here, on the caller's thread.
  core::Result<std::vector<std::vector<shader::SearchVariant>>> results() {
    std::lock_guard lock(mutex_);
    if (thrown_) std::rethrow_exception(std::exchange(thrown_, nullptr));
    if (!failure_.empty()) return core::Error{failure_};
    return std::move(fronts_);
  }
  double busySeconds() const {
    std::lock_guard lock(mutex_);
    return busy_seconds_;
  }

 private:
  // An exception must not leave the thread (std::terminate: a search that runs out of memory
  // aborted the process): it ends the searches and goes to the caller through results().
  void run() {
    try {
      searchConfigurations();
    } catch (...) {
      std::lock_guard lock(mutex_);
      thrown_ = std::current_exception();
      done_ = true;
      changed_.notify_all();
    }
  }
  void searchConfigurations() {
    auto failed = [&](const std::string& message) {
      std::lock_guard lock(mutex_);
      failure_ = message;
      done_ = true;
      changed_.notify_all();
    };
    auto renderer = Renderer::create(gl_);
    if (!renderer) return failed("shader search context: " + renderer.error().message);
    auto original_asset = (*renderer)->uploadAsset(asset_);
    if (!original_asset) return failed(original_asset.error().message);
    auto cache = std::make_shared<shader::EvaluationCache>(**renderer);
    for (;;) {
      Configuration configuration;
      {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [&] { return cancelled_ || closed_ || !queue_.empty(); });
        if (cancelled_ || queue_.empty()) break;
        configuration = std::move(queue_.front());
        queue_.pop_front();
      }
      const auto start = Clock::now();
      auto front = search(**renderer, cache, *original_asset, configuration);
      if (!front) return failed(front.error().message);
      const double seconds = secondsSince(start);
      const shader::EvaluationCache::Counters& compiled = cache->counters();
      char line[256];
      std::snprintf(line, sizeof line,
                    "shader search level %d (mesh %d): %zu variants on the front; so far %d "
                    "programs compiled in %.1f s, %d cost profiles (%d compiled ahead, %d "
                    "profiled ahead); %.1f s",
                    configuration.level, configuration.mesh, front->variants.size(),
                    compiled.programs_compiled, compiled.compile_seconds, front->cost_profiles,
                    front->compiled_ahead, front->profiled_ahead, seconds);
      std::lock_guard lock(mutex_);
      if (fronts_.size() <= size_t(configuration.index)) fronts_.resize(configuration.index + 1);
      fronts_[configuration.index] = std::move(front->variants);
      busy_seconds_ += seconds;
      events_.push_back({line, ++finished_});
      changed_.notify_all();
    }
    std::lock_guard lock(mutex_);
    done_ = true;
    changed_.notify_all();
  }

  struct Front {
    std::vector<shader::SearchVariant> variants;
    int cost_profiles = 0, compiled_ahead = 0, profiled_ahead = 0;
  };
  core::Result<Front> search(
      Renderer& renderer, const std::shared_ptr<shader::EvaluationCache>& cache,
      Renderer::AssetId original_asset, const Configuration& configuration) {
    auto asset = renderer.uploadMesh(original_asset, configuration.drawn);
    if (!asset) return asset.error();
    auto scoring = shader::ConfigurationScorer::create(
        renderer, cache, *asset, configuration.drawn, original_,
        evaluationConfig(options_, configuration.distance));
    if (!scoring) return scoring.error();
    if (options_.compile_ahead) {
      // What the scorer draws: this mesh uploaded over the asset (uploadMesh above).
      // The workers draw this context's textures (they draw little: a few profile samples a
      // variant) instead of each uploading a copy (WaterBottle: 85 MB a context).
      render::ContextOptions workers = gl_;
      if (auto shared = renderer.shareTextures(original_asset); shared)
        workers.textures = std::move(*shared);
      (*scoring)->enableCompileAhead(asset_, configuration.drawn, workers);
    }
    // Moving to parameter (He et al.): values averaged over the training domain by an
    // instrumented render on this configuration's mesh and distance.
    shader::RuleContext context = context_;
    if (options_.move_to_parameter)
      context.average_value = (*scoring)->averageValue(options_.average_resolution);
    shader::SearchCache search_cache(original_, context, (*scoring)->scorer());
    shader::GeneticSearchOptions genetic;
    genetic.population_size = options_.population;
    genetic.generations = options_.generations;
    genetic.seed = options_.seed + static_cast<uint64_t>(configuration.index + 1);
    // Variants erring far beyond the largest bound can never be chosen.
    genetic.max_error = 4.0 * options_.levels.bound.e_max;
    auto searched = shader::searchGenetic(search_cache, genetic);
    renderer.releaseAsset(*asset);
    if (!searched) return searched.error();
    return Front{std::move(searched->variants), (*scoring)->costProfiles(),
                 (*scoring)->compileAheadCounts().first, (*scoring)->costProfilesAhead()};
  }

  const core::Asset& asset_;
  const shader::ShaderProgram& original_;
  const shader::RuleContext context_;
  const GenerateOptions& options_;
  const render::ContextOptions gl_;  // its own context's and its workers'
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Configuration> queue_;
  std::vector<Event> events_;
  std::vector<std::vector<shader::SearchVariant>> fronts_;
  std::string failure_;
  std::exception_ptr thrown_;
  int added_ = 0, finished_ = 0;
  double busy_seconds_ = 0;
  bool closed_ = false, cancelled_ = false, done_ = false;
  std::thread thread_;  // last: starts after every member above exists
};

class Generator {
 public:
  Generator(const core::Asset& asset, const GenerateOptions& options)
      : asset_(asset), options_(options) {}

  core::Result<GenerateResult> run(const render::GlslSource& source);

 private:
  void progress(std::string_view stage, double fraction) const {
    if (options_.progress) options_.progress({stage, fraction, {}});
  }
  core::Status setUp(const render::GlslSource& source);
  core::Status makeLevels();
  core::Status makeMeshCandidates(const render::GlslSource& source);
  // Appends to mesh set `set` up to `count` candidates of a quadric record continuing past its
  // cascade's coarsest mesh (MeshSet::cascade).
  void appendContinuation(int set, size_t count);
  // Starts the GP configurations' thread (separate optimizer); configurations join it as their
  // levels' mesh sets complete (addReadyConfigurations), makeShaderCandidates collects them.
  void startShaderSearch();
  void addReadyConfigurations(int completed_level);
  void relayShaderSearchLines(std::string_view stage);
  core::Status makeShaderCandidates();
  // Starts SortByError's renders of the joint search on their own thread (SortByErrorPrefetch).
  void startSortPrefetch();
  core::Result<ShaderCandidate> candidateFrom(std::shared_ptr<const shader::ShaderProgram> program,
                                              std::string summary);
  core::Status profile(ShaderCandidate& candidate);
  core::Result<Renderer::AssetId> meshAsset(int set, int mesh);
  // The candidate's mesh, extracted from its record on first use.
  const core::Mesh& candidateMesh(int set, int mesh);
  // Scores shader variants on (mesh of `set`, level's distance): the GP configurations of §5.2
  // and the interleaved generations of §4.3.
  core::Result<std::unique_ptr<shader::ConfigurationScorer>> scorerFor(int level, int set,
                                                                       int mesh);
  core::Result<render::ImageBatch8> renderPair(int distance_level, int set, int mesh, int shader,
                                               render::WorkCounts* work) {
    const LevelState& level = levels_[distance_level];
    return renderPairOn(level.samples, level.level.footprint_px, set, mesh, shader, work);
  }
  core::Result<render::ImageBatch8> renderPairOn(std::span<const render::Sample> samples,
                                                 int resolution, int set, int mesh, int shader,
                                                 render::WorkCounts* work);
  core::Result<Renderer::ProgramId> programOf(int shader);
  int setFor(int level) const {
    return options_.scope == LodScope::kShaderOnly ? 0 : set_of_level_[level];
  }
  core::Result<PairRecord> evaluatePair(int distance_level, int set, int mesh, int shader);
  core::Result<double> transitionError(int level, int from_set, const EvaluatedPair& from,
                                       int to_set, const EvaluatedPair& to);
  SeparateProblem problem(LodScope scope);
  core::Result<SeparateSolution> runInterleaved(const SeparateOptions& options);
  core::Result<int> coarsestMeshWithin(int level, int shader);
  core::Result<int> addShaderCandidate(std::shared_ptr<const shader::ShaderProgram> program,
                                       std::string summary);
  core::Status measureChosen(GenerateResult& result);
  // Views and lights outside the training domain (an icosahedron's vertices, the light cross
  // turned 45°) at a level's distance, with f̄ rendered there.
  struct HeldOutDomain {
    std::vector<render::Sample> samples;
    render::ImageBatchF reference;
  };
  core::Result<HeldOutDomain> heldOutDomain(int level);
  // ε_a of (mesh of `pair_set`, shader) against that f̄, and the bound there. `pair_set`: the
  // mesh set the pair's mesh index refers to (its own level's).
  core::Result<HeldOutCheck> checkHeldOut(const HeldOutDomain& domain, int level, int pair_set,
                                          const EvaluatedPair& pair, bool fallback);
  void fillReport(GenerateResult& result, const SeparateSolution& joint,
                  const std::map<LodScope, SeparateSolution>& baselines);

  // Every context this run makes: the device and the shader interface.
  render::ContextOptions contextOptions() const {
    return {.device = options_.device, .bindings = options_.bindings};
  }

  const core::Asset& asset_;
  GenerateOptions options_;
  std::unique_ptr<Renderer> renderer_;
  std::shared_ptr<shader::EvaluationCache> cache_;
  Renderer::AssetId original_asset_ = -1;
  core::Sphere bounds_;
  shader::ShaderProgram original_;
  std::vector<LevelState> levels_;
  std::vector<MeshSet> mesh_sets_;
  std::vector<int> set_of_level_;  // which mesh set each level searches
  std::unique_ptr<ShaderSearchThread> shader_search_;
  std::unique_ptr<SortByErrorPrefetch> sort_prefetch_;
  std::vector<int> search_levels_;  // §5.2's evenly chosen levels
  size_t next_search_level_ = 0;    // the first of them not yet handed to shader_search_
  std::vector<ShaderCandidate> shaders_;
  std::map<std::tuple<int, int, int, int>, PairRecord> pairs_;
  // Pair renders kept for the transition errors (eq. 5), by (distance level, set, mesh, shader).
  // Only the renders of pairs in some optimization's level pair sets are compared there
  // (wantRendersOf): a level's other renders are dropped as its search ends (dropUnwanted), and
  // one found missing later is rendered again (renders are deterministic). Kept all, spot's
  // default run peaked at 1.24 GB, 0.2 GB more.
  // (The joint search's renders of pairs that can be in no set go at once: on_discarded.)
  using KeptRenders = std::map<std::tuple<int, int, int, int>, render::ImageBatch8>;
  KeptRenders images_;
  std::set<std::tuple<int, int, int, int>> wanted_images_;
  core::Result<render::ImageBatchF> renderReference(const LevelState& level);
  core::Result<const render::ImageBatchF*> referenceOf(int level);
  size_t kept_bytes_ = 0, kept_bytes_peak_ = 0, rendered_bytes_ = 0;  // of images_' pixels
  const render::ImageBatch8& keepRender(const std::tuple<int, int, int, int>& key,
                                        render::ImageBatch8 images);
  void wantRendersOf(LodScope scope, int level, const std::vector<EvaluatedPair>& pairs);
  void dropUnwanted(int level);
  KeptRenders::iterator eraseRender(KeptRenders::iterator it);
  int setIn(LodScope scope, int level) const {
    return scope == LodScope::kShaderOnly ? 0 : set_of_level_[level];
  }
  int pair_evaluations_ = 0, transition_evaluations_ = 0, transition_renders_ = 0;
  double shader_search_seconds_ = 0;
};

core::Status Generator::setUp(const render::GlslSource& source) {
  auto vertex = shader::compileToSpirv(source.vertex, shader::Stage::kVertex, source.vertex_name);
  if (!vertex) return vertex.error();
  auto fragment =
      shader::compileToSpirv(source.fragment, shader::Stage::kFragment, source.fragment_name);
  if (!fragment) return fragment.error();
  auto original = shader::parseProgram(*vertex, *fragment);
  if (!original) return original.error();
  if (auto room = shader::checkRoomForAutoLod(*original, source.vertex_name, source.fragment_name);
      !room)
    return room.error();
  original_ = std::move(*original);

  auto renderer = Renderer::create(contextOptions());
  if (!renderer) return renderer.error();
  renderer_ = std::move(*renderer);
  if (!renderer_->canCountWork())
    return core::Error{"the GPU context cannot count shader invocations "
                       "(ARB_pipeline_statistics_query), which the cost model needs"};
  auto uploaded = renderer_->uploadAsset(asset_);
  if (!uploaded) return uploaded.error();
  original_asset_ = *uploaded;
  cache_ = std::make_shared<shader::EvaluationCache>(*renderer_);
  bounds_ = core::computeBoundingSphere(asset_.mesh);

  auto candidate = candidateFrom(std::make_shared<shader::ShaderProgram>(original_), "original");
  if (!candidate) return candidate.error();
  shaders_.push_back(std::move(*candidate));
  return core::okStatus();
}

core::Result<ShaderCandidate> Generator::candidateFrom(
    std::shared_ptr<const shader::ShaderProgram> program, std::string summary) {
  auto variant = shader::evaluationVariant(*program);
  if (!variant) return variant.error();
  ShaderCandidate candidate;
  candidate.program = std::move(program);
  candidate.variant = std::move(*variant);
  candidate.summary = std::move(summary);
  return candidate;
}

core::Status Generator::makeLevels() {
  LevelOptions level_options = options_.levels;
  metric::BoundConfig& bound = level_options.bound;
  if (bound.d_near <= 0)
    bound.d_near =
        render::distanceForFootprint(bounds_, options_.near_footprint_px, level_options.display);
  if (bound.d_far <= 0)
    bound.d_far =
        render::distanceForFootprint(bounds_, options_.far_footprint_px, level_options.display);
  options_.levels = level_options;
  auto levels = distanceLevels(bounds_, level_options);
  if (!levels) return levels.error();

  for (size_t i = 0; i < levels->size(); ++i) {
    progress("references", double(i) / levels->size());
    LevelState state;
    state.level = (*levels)[i];
    state.samples =
        render::domainSamples(bounds_, float(state.level.distance), {.views = options_.views});
    auto reference = renderReference(state);
    if (!reference) return reference.error();
    if (auto covered = metric::checkReferenceCoverage(*reference); !covered) return covered.error();
    state.reference = std::move(*reference);
    // s_d of eq. (3): the reference's covered pixels (the error of f̄ against itself is 0).
    state.coverage_px = metric::imageError(state.reference, state.reference).coverage_px;
    state.bound = errorBound(state.level, state.coverage_px);
    state.search_bound = state.bound * (1.0 - std::clamp(options_.bound_margin, 0.0, 0.9));
    levels_.push_back(std::move(state));
  }
  return core::okStatus();
}

// Keeps at most `limit` of the set's meshes, evenly by index, always the first and the last.
void thinEvenly(MeshSet& set, size_t limit) {
  const size_t count = set.meshes.size();
  if (limit < 2 || count <= limit) return;
  MeshSet thinned;
  for (size_t i = 0; i < limit; ++i) {
    size_t index = i * (count - 1) / (limit - 1);
    thinned.meshes.push_back(set.meshes[index]);
    thinned.errors.push_back(set.errors[index]);
  }
  set = std::move(thinned);
}

// A candidate kept as step `step` of `record` (extracted when first drawn: candidateMesh).
std::shared_ptr<MeshCandidate> recordCandidate(
    const std::shared_ptr<const mesh::ProgressiveRecord>& record, size_t step, size_t triangles) {
  auto candidate = std::make_shared<MeshCandidate>();
  candidate->record = record;
  candidate->step = step;
  candidate->triangles = triangles;
  return candidate;
}

void Generator::appendContinuation(int set_index, size_t count) {
  MeshSet& set = mesh_sets_[set_index];
  const core::Mesh& coarsest = candidateMesh(set_index, int(set.cascade) - 1);
  constexpr size_t kTetrahedron = 4;
  if (coarsest.triangleCount() <= kTetrahedron) return;
  mesh::SimplifyResult simplified =
      mesh::simplifyQuadric(coarsest, {.target_triangles = kTetrahedron, .record = true});
  auto record = std::make_shared<const mesh::ProgressiveRecord>(std::move(simplified.record));
  std::vector<size_t> steps = mesh::chooseCandidates(*record, count + 1);
  const std::vector<size_t> triangles = mesh::countTriangles(*record, steps);
  for (size_t i = 0; i < steps.size(); ++i) {
    // Step 0 is the coarsest mesh itself (already the cascade's last); so is a step that
    // removed nothing (seams welded).
    if (triangles[i] >= coarsest.triangleCount()) continue;
    set.meshes.push_back(recordCandidate(record, steps[i], triangles[i]));
    set.errors.push_back(std::numeric_limits<double>::infinity());
  }
}

core::Status Generator::makeMeshCandidates(const render::GlslSource& source) {
  const int level_count = static_cast<int>(levels_.size());
  // The original, as given (the Generator's asset outlives every set).
  const auto original = std::make_shared<MeshCandidate>();
  original->triangles = asset_.mesh.triangleCount();
  original->mesh = std::shared_ptr<const core::Mesh>(&asset_.mesh, [](const core::Mesh*) {});
  auto addSet = [&](mesh::ProgressiveRecord&& simplified, bool from_original) {
    auto record = std::make_shared<const mesh::ProgressiveRecord>(std::move(simplified));
    std::vector<size_t> steps = mesh::chooseCandidates(*record, options_.mesh_candidates);
    const std::vector<size_t> triangles = mesh::countTriangles(*record, steps);
    MeshSet set;
    for (size_t i = 0; i < steps.size(); ++i) {
      set.meshes.push_back(recordCandidate(record, steps[i], triangles[i]));
      set.errors.push_back(steps[i] == 0 ? 0.0 : record->steps[steps[i] - 1].cumulative_error);
    }
    // A record of the original starts with its cleaned (welded) copy: M_0 is the original itself
    // (every set's M_0 is rendered once, as set 0's).
    if (from_original && !steps.empty() && steps.front() == 0) set.meshes.front() = original;
    mesh_sets_.push_back(std::move(set));
    return static_cast<int>(mesh_sets_.size()) - 1;
  };
  // Set 0 is the original alone: level 0 (bound 0) and the shader-only baseline use it.
  mesh_sets_.push_back(MeshSet{.meshes = {original}, .errors = {0.0}, .cascade = 1});
  set_of_level_.assign(level_count, 0);
  addReadyConfigurations(0);
  if (options_.scope == LodScope::kShaderOnly) return core::okStatus();

  if (options_.mesh_mode == MeshCandidateMode::kQuadric) {
    mesh::SimplifyOptions quadric{.target_triangles = 4, .record = true};
    mesh::SimplifyResult simplified = mesh::simplifyQuadric(asset_.mesh, quadric);
    int set = addSet(std::move(simplified.record), /*from_original=*/true);
    mesh_sets_[set].cascade = mesh_sets_[set].meshes.size();
    for (int level = 1; level < level_count; ++level) set_of_level_[level] = set;
    return core::okStatus();
  }
  // Levels in order of distance, each continuing from the previous level's coarsest mesh: the
  // bounds grow with distance, so a farther level's image-driven run (§5.1) would first redo the
  // nearer level's collapses. Continuing makes the whole cascade cost about one simplification of
  // the input instead of one per level. The finer meshes a farther level then lacks are the
  // nearer level's candidates (simplified against a nearer reference, so if anything more
  // conservative); the set keeps them so a costlier shader can still pair with a finer mesh.
  int previous_set = -1;  // an index: addSet may move the sets
  int previous_level = 0;
  for (int level = 1; level < level_count; ++level) {
    progress("mesh candidates", double(level - 1) / std::max(1, level_count - 1));
    mesh::ImageSimplifyOptions image{.target_error = levels_[level].search_bound,
                                     .distance = float(levels_[level].level.distance),
                                     .display = options_.levels.display,
                                     .domain = {.views = options_.views},
                                     .supersample = options_.supersample,
                                     .max_edge_pixels = options_.max_edge_pixels};
    image.start = previous_set >= 0
                      ? &candidateMesh(previous_set, int(mesh_sets_[previous_set].cascade) - 1)
                      : nullptr;
    image.reference = &levels_[level].reference;
    image.uploaded = original_asset_;  // its textures are not uploaded again
    mesh::ImageSimplifyStats stats;
    auto simplified = mesh::simplifyImage(*renderer_, asset_, source, image, &stats);
    if (!simplified)
      return core::Error{"mesh candidates at level " + std::to_string(level) + ": " +
                         simplified.error().message};
    const size_t start_triangles = simplified->record.base.triangleCount();
    const int own = addSet(std::move(simplified->record), /*from_original=*/previous_set < 0);
    mesh_sets_[own].errors[0] = stats.initial_error;  // the start mesh's own ε at this distance
    const bool collapsed = mesh_sets_[own].meshes.size() > 1;
    if (previous_set >= 0) {
      MeshSet carried = mesh_sets_[previous_set];
      carried.meshes.resize(carried.cascade);  // its continuation is not carried: made anew
      carried.errors.resize(carried.cascade);
      // Carried meshes first (finer), then this level's own after its start mesh. Their errors
      // were measured nearer, summed over more covered pixels: scaled to this level's coverage
      // (the per-pixel error is what carries over), and none above this level's start (they
      // are finer).
      MeshSet& set = mesh_sets_[own];
      MeshSet combined;
      combined.meshes = carried.meshes;
      const double coverage_scale =
          levels_[level].coverage_px / std::max(1e-9, levels_[previous_level].coverage_px);
      for (double error : carried.errors)
        combined.errors.push_back(std::min(error * coverage_scale, stats.initial_error));
      combined.meshes.pop_back();  // == this level's start, set.meshes[0]
      combined.errors.pop_back();
      for (size_t k = 0; k < set.meshes.size(); ++k) {
        combined.meshes.push_back(set.meshes[k]);
        combined.errors.push_back(k == 0 ? stats.initial_error : set.errors[k]);
      }
      set = std::move(combined);
    }
    // The continuation: quadric collapses past the cascade's coarsest mesh, down to a
    // tetrahedron's four triangles. The image-driven run stops where its ε reaches the level's aim
    // with the ORIGINAL shader, or earlier where every edge left is longer than D pixels (§4.2)
    // or its neighbourhood wider than a tile; a simplified shader (textures to average colours
    // take their aliasing away) leaves room for much coarser meshes, which only a rendered pair
    // can tell. On spot, the Avocado and WaterBottle, a quadric record's candidates were within
    // the bound at 41-756 triangles where the cascade stopped at 680-5,008 (bench/RESULTS.md,
    // session 51). Candidates in order of triangles still, so the pair search's walk stays valid;
    // a level whose run made no collapse shares the previous level's continuation (the same
    // meshes, so they are extracted, uploaded and rendered once).
    MeshSet& set = mesh_sets_[own];
    const size_t continuation_budget = options_.mesh_candidates / 4;
    thinEvenly(set, std::max<size_t>(1, options_.mesh_candidates - continuation_budget));
    set.cascade = set.meshes.size();
    if (continuation_budget > 0) {
      if (!collapsed && previous_set >= 0) {
        const MeshSet& previous = mesh_sets_[previous_set];
        set.meshes.insert(set.meshes.end(), previous.meshes.begin() + long(previous.cascade),
                          previous.meshes.end());
        set.errors.insert(set.errors.end(), previous.errors.begin() + long(previous.cascade),
                          previous.errors.end());
      } else {
        appendContinuation(own, continuation_budget);
      }
    }
    set_of_level_[level] = own;
    addReadyConfigurations(level);
    relayShaderSearchLines("mesh candidates");
    previous_set = own;
    previous_level = level;
    if (options_.progress) {
      char line[200];
      std::snprintf(line, sizeof line,
                    "mesh level %d (%d px): %zu -> %zu triangles, eps %.2f (aim %.2f), %zu "
                    "renders, %.1f s; %zu candidates past it by quadric collapses",
                    level, stats.footprint_px, start_triangles, simplified->mesh.triangleCount(),
                    stats.final_error, levels_[level].search_bound, stats.rendered_evaluations,
                    stats.total_seconds, set.meshes.size() - set.cascade);
      options_.progress({"mesh candidates", double(level) / std::max(1, level_count - 1), line});
    }
  }
  return core::okStatus();
}

core::Result<Renderer::AssetId> Generator::meshAsset(int set, int mesh) {
  if (mesh == 0) set = 0;  // the original (set 0 holds it alone)
  MeshCandidate& candidate = *mesh_sets_[set].meshes[mesh];
  if (candidate.uploaded >= 0) return candidate.uploaded;
  auto uploaded = renderer_->uploadMesh(original_asset_, candidateMesh(set, mesh));
  if (!uploaded) return uploaded.error();
  candidate.uploaded = *uploaded;
  return *uploaded;
}

const core::Mesh& Generator::candidateMesh(int set, int mesh) {
  MeshCandidate& candidate = *mesh_sets_[set].meshes[mesh];
  if (!candidate.mesh)
    candidate.mesh =
        std::make_shared<const core::Mesh>(mesh::extractMesh(*candidate.record, candidate.step));
  return *candidate.mesh;
}

core::Result<std::unique_ptr<shader::ConfigurationScorer>> Generator::scorerFor(int level, int set,
                                                                                int mesh) {
  auto asset = meshAsset(set, mesh);
  if (!asset) return asset.error();
  return shader::ConfigurationScorer::create(
      *renderer_, cache_, *asset, candidateMesh(mesh == 0 ? 0 : set, mesh), original_,
      evaluationConfig(options_, float(levels_[level].level.distance)));
}

// The cost model's per-invocation op counts of a shader candidate: one instrumented render of the
// original mesh at a middle level, a few views (the counts per invocation hardly depend on the
// mesh; the invocation counts, which do, come from each pair's own render).
core::Status Generator::profile(ShaderCandidate& candidate) {
  if (candidate.profiled) return core::okStatus();
  auto vertex = shader::ir::parseModule(candidate.variant.spirv.vertex);
  if (!vertex) return vertex.error();
  auto fragment = shader::ir::parseModule(candidate.variant.spirv.fragment);
  if (!fragment) return fragment.error();
  const LevelState& level = levels_[levels_.size() / 2];
  std::vector<render::Sample> samples;
  for (size_t i = 0; i < level.samples.size(); i += 20) samples.push_back(level.samples[i]);
  auto counts = shader::profileBlockCounts(*renderer_, original_asset_, *vertex, *fragment, samples,
                                           level.level.footprint_px);
  if (!counts) return counts.error();
  candidate.vertex_ops = shader::dynamicOpCounts(*vertex, counts->vertex_executions);
  candidate.fragment_ops = shader::dynamicOpCounts(*fragment, counts->fragment_executions);
  candidate.profiled = true;
  return core::okStatus();
}

// The shader candidate's program with its CPU-set values applied (program state in GL).
core::Result<Renderer::ProgramId> Generator::programOf(int shader) {
  const ShaderCandidate& candidate = shaders_[shader];
  auto program = cache_->program(candidate.variant);
  if (!program) return program.error();
  if (auto set_uniforms = renderer_->setProgramUniforms(*program, candidate.variant.uniforms);
      !set_uniforms)
    return set_uniforms.error();
  return *program;
}

core::Result<render::ImageBatch8> Generator::renderPairOn(std::span<const render::Sample> samples,
                                                          int resolution, int set, int mesh,
                                                          int shader, render::WorkCounts* work) {
  auto asset = meshAsset(set, mesh);
  if (!asset) return asset.error();
  auto program = programOf(shader);
  if (!program) return program.error();
  render::RenderOptions render_options{.resolution = resolution, .count_work = work != nullptr};
  render::RenderStats stats;
  auto images = renderer_->render(*asset, *program, samples, render_options, &stats);
  if (!images) return images.error();
  if (work) *work = stats.work;
  return images;
}

core::Result<PairRecord> Generator::evaluatePair(int distance_level, int set, int mesh,
                                                 int shader) {
  if (mesh == 0) set = 0;  // M_0 is the original in every set: one render serves them all
  auto key = std::make_tuple(distance_level, set, mesh, shader);
  if (auto found = pairs_.find(key); found != pairs_.end()) return found->second;
  render::WorkCounts work;
  std::optional<render::ImageBatch8> images;
  if (mesh == 0 && sort_prefetch_)
    if (auto prefetched = sort_prefetch_->take(distance_level, shader)) {
      images = std::move(prefetched->images);
      work = prefetched->work;
    }
  if (!images) {
    auto rendered = renderPair(distance_level, set, mesh, shader, &work);
    if (!rendered) return rendered.error();
    images = std::move(*rendered);
  }
  ++pair_evaluations_;
  // Kept while a transition error (eq. 5) may compare it (wantRendersOf, dropUnwanted).
  const render::ImageBatch8& kept = keepRender(key, std::move(*images));
  ShaderCandidate& candidate = shaders_[shader];
  if (auto profiled = profile(candidate); !profiled) return profiled.error();
  const LevelState& level = levels_[distance_level];
  double draws = static_cast<double>(level.samples.size());
  shader::CostFeatures features{
      .vertex_ops = candidate.vertex_ops,
      .fragment_ops = candidate.fragment_ops,
      .vertex_invocations = static_cast<double>(work.vertex_invocations) / draws,
      .fragment_invocations = static_cast<double>(work.fragment_invocations) / draws};
  auto reference = referenceOf(distance_level);
  if (!reference) return reference.error();
  PairRecord record{.error = metric::imageError(kept, **reference),
                    .cost = shader::predictCost(features, shader::calibratedCostWeights())};
  pairs_.emplace(key, record);
  // At a bound of 0 (d_near, eq. 4) every optimizer evaluates the original pair only (nothing
  // can be within the bound), and the report shows the reference's first tile: the rest of the
  // largest reference of the run (spot: 105 MB of 256 px floats) goes.
  if (level.bound <= 0) {
    LevelState& trimmed = levels_[distance_level];
    trimmed.reference.count = 1;
    trimmed.reference.pixels.resize(size_t(trimmed.reference.width) * trimmed.reference.height * 4);
    trimmed.reference.pixels.shrink_to_fit();
    trimmed.trimmed = true;
  }
  return record;
}

core::Result<render::ImageBatchF> Generator::renderReference(const LevelState& level) {
  auto program = cache_->program(shaders_[0].variant);
  if (!program) return program.error();
  return renderer_->renderReference(
      original_asset_, *program, level.samples,
      {.resolution = level.level.footprint_px, .supersample = options_.supersample});
}

core::Result<const render::ImageBatchF*> Generator::referenceOf(int level_index) {
  LevelState& level = levels_[level_index];
  if (level.trimmed) {  // (no optimizer asks for it at present)
    auto whole = renderReference(level);
    if (!whole) return whole.error();
    level.reference = std::move(*whole);
    level.trimmed = false;
  }
  return &level.reference;
}

// ε_t of eq. (5): both pairs rendered at d_{level+1} and compared with each other.
core::Result<double> Generator::transitionError(int level, int from_set,
                                                const EvaluatedPair& from, int to_set,
                                                const EvaluatedPair& to) {
  const int at = level + 1;
  auto imageOf = [&](int set, const EvaluatedPair& pair) -> core::Result<const render::ImageBatch8*> {
    if (pair.mesh == 0) set = 0;  // as in evaluatePair
    auto key = std::make_tuple(at, set, pair.mesh, pair.shader);
    auto found = images_.find(key);
    if (found == images_.end()) {
      auto images = renderPair(at, set, pair.mesh, pair.shader, nullptr);
      if (!images) return images.error();
      ++transition_renders_;
      return &keepRender(key, std::move(*images));
    }
    return &found->second;
  };
  auto a = imageOf(from_set, from);
  if (!a) return a.error();
  auto b = imageOf(to_set, to);
  if (!b) return b.error();
  ++transition_evaluations_;
  return metric::imageError(**a, **b).epsilon;
}

// A transition at level L (eq. 5) compares a pair of level L's set with one of level L + 1's, both
// rendered at d_{L+1}: a level's pairs are wanted at the next level's distance, and (but level 0's,
// which nothing precedes) at their own.
void Generator::wantRendersOf(LodScope scope, int level, const std::vector<EvaluatedPair>& pairs) {
  for (const EvaluatedPair& pair : pairs) {
    const int set = pair.mesh == 0 ? 0 : setIn(scope, level);  // as in evaluatePair
    if (level > 0) wanted_images_.insert({level, set, pair.mesh, pair.shader});
    if (size_t(level) + 1 < levels_.size())
      wanted_images_.insert({level + 1, set, pair.mesh, pair.shader});
  }
}

void Generator::dropUnwanted(int level) {
  for (auto it = images_.lower_bound({level, INT_MIN, INT_MIN, INT_MIN});
       it != images_.end() && std::get<0>(it->first) == level;) {
    if (wanted_images_.count(it->first)) {
      ++it;
      continue;
    }
    it = eraseRender(it);
  }
}

Generator::KeptRenders::iterator Generator::eraseRender(KeptRenders::iterator it) {
  kept_bytes_ -= it->second.pixels.size();
  return images_.erase(it);
}

const render::ImageBatch8& Generator::keepRender(const std::tuple<int, int, int, int>& key,
                                                 render::ImageBatch8 images) {
  auto [it, added] = images_.emplace(key, std::move(images));
  if (added) {
    kept_bytes_ += it->second.pixels.size();
    rendered_bytes_ += it->second.pixels.size();
    kept_bytes_peak_ = std::max(kept_bytes_peak_, kept_bytes_);
  }
  return it->second;
}

SeparateProblem Generator::problem(LodScope scope) {
  SeparateProblem problem;
  problem.level_count = static_cast<int>(levels_.size());
  for (int level = 0; level < problem.level_count; ++level) {
    problem.error_bounds.push_back(levels_[level].search_bound);
    int set = scope == LodScope::kShaderOnly ? 0 : set_of_level_[level];
    problem.mesh_counts.push_back(static_cast<int>(mesh_sets_[set].meshes.size()));
    std::vector<double>& sizes = problem.mesh_sizes.emplace_back();
    for (const auto& candidate : mesh_sets_[set].meshes)
      sizes.push_back(double(candidate->triangles));
  }
  problem.shader_count = scope == LodScope::kMeshOnly ? 1 : static_cast<int>(shaders_.size());
  auto setOf = [this, scope](int level) { return setIn(scope, level); };
  problem.evaluate = [this, setOf](int level, int mesh,
                                   int shader) -> core::Result<PairEvaluation> {
    auto record = evaluatePair(level, setOf(level), mesh, shader);
    if (!record) return record.error();
    return PairEvaluation{.error = record->error.epsilon, .cost = record->cost};
  };
  problem.transition = [this, setOf](int level, const EvaluatedPair& from,
                                     const EvaluatedPair& to) {
    return transitionError(level, setOf(level), from, setOf(level + 1), to);
  };
  problem.cost_at = [this, setOf](int pair_level, const EvaluatedPair& pair,
                                  int distance_level) -> core::Result<double> {
    auto record = evaluatePair(distance_level, setOf(pair_level), pair.mesh, pair.shader);
    if (!record) return record.error();
    return record->cost;
  };
  return problem;
}


// §5.2: GP fronts on (mesh, distance) configurations at a few evenly chosen levels, on the
// coarsest meshes of each whose own error leaves room for the shader's (half the bound), united.
void Generator::startShaderSearch() {
  if (options_.scope == LodScope::kMeshOnly || options_.optimizer == Optimizer::kInterleaved) return;
  const int level_count = static_cast<int>(levels_.size());
  const int wanted = std::clamp(options_.shader_search_levels, 1, std::max(1, level_count - 1));
  for (int i = 0; i < wanted; ++i) {
    int level = level_count == 1 ? 0
                                 : 1 + static_cast<int>(std::lround(double(i) * (level_count - 2) /
                                                                    std::max(1, wanted - 1)));
    if (search_levels_.empty() || search_levels_.back() != level) search_levels_.push_back(level);
  }
  shader::RuleContext context;
  context.texture_averages = shader::textureAverages(asset_, options_.bindings);
  shader_search_ = std::make_unique<ShaderSearchThread>(asset_, original_, std::move(context),
                                                        options_, contextOptions());
}

void Generator::addReadyConfigurations(int completed_level) {
  if (!shader_search_) return;
  for (; next_search_level_ < search_levels_.size() &&
         search_levels_[next_search_level_] <= completed_level;
       ++next_search_level_) {
    const int level = search_levels_[next_search_level_];
    const int set = set_of_level_[level];
    const MeshSet& mesh_set = mesh_sets_[set];
    // The top meshes: the coarsest candidates that use at most half of what the bound leaves
    // above the original mesh's own error (its aliasing against f̄ already takes part of it).
    const double room = mesh_set.errors[0] + 0.5 * (levels_[level].search_bound - mesh_set.errors[0]);
    int taken = 0;
    for (int mesh = static_cast<int>(mesh_set.meshes.size()) - 1;
         mesh >= 0 && taken < options_.shader_search_meshes; --mesh)
      if (mesh == 0 || mesh_set.errors[mesh] <= room) {
        shader_search_->add({.index = shader_search_->added(),
                             .level = level,
                             .mesh = mesh,
                             .drawn = candidateMesh(mesh == 0 ? 0 : set, mesh),
                             .distance = float(levels_[level].level.distance)});
        ++taken;
      }
  }
}

// The searches' finished-configuration lines, as details of whatever stage is on the display.
void Generator::relayShaderSearchLines(std::string_view stage) {
  if (!shader_search_ || !options_.progress) return;
  for (const ShaderSearchThread::Event& event : shader_search_->takeEvents())
    options_.progress({stage, 0.0, event.line});
}

core::Status Generator::makeShaderCandidates() {
  if (!shader_search_) return core::okStatus();
  shader_search_->close();
  const int configurations = std::max(1, shader_search_->added());
  relayShaderSearchLines("shader candidates");
  while (auto event = shader_search_->waitEvent())
    if (options_.progress)
      options_.progress({"shader candidates", double(event->finished) / configurations, event->line});
  auto fronts = shader_search_->results();
  if (!fronts) return fronts.error();
  shader_search_seconds_ = shader_search_->busySeconds();
  shader_search_.reset();

  std::set<uint64_t> seen{shader::programHash(original_)};
  std::vector<shader::SearchVariant> found;
  for (std::vector<shader::SearchVariant>& front : *fronts)
    for (shader::SearchVariant& variant : front)
      if (seen.insert(shader::programHash(*variant.program)).second)
        found.push_back(std::move(variant));
  // Thin the union evenly along the predicted error, so the candidates span the whole range.
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return a.predicted_error < b.predicted_error;
  });
  const size_t keep = std::min(found.size(), size_t(std::max(0, options_.max_shader_candidates - 1)));
  for (size_t i = 0; i < keep; ++i) {
    size_t index = keep == found.size() ? i : i * (found.size() - 1) / std::max<size_t>(1, keep - 1);
    auto candidate = candidateFrom(found[index].program, shader::summarizeSites(found[index].sites));
    if (!candidate) return candidate.error();
    shaders_.push_back(std::move(*candidate));
  }
  return core::okStatus();
}

// Algorithm 1 line 6 renders every shader candidate on M_0 at every searched level before that
// level's walk: those renders go to a thread of their own, which takes the levels from the
// farthest while the walk goes from the nearest and renders itself what the thread has not
// started, so the two meet where their work is about even (M_0's renders are most of it).
void Generator::startSortPrefetch() {
  std::vector<SortByErrorPrefetch::Level> levels;
  std::vector<SortByErrorPrefetch::Job> jobs;
  for (size_t level = 0; level < levels_.size(); ++level) {
    levels.push_back({levels_[level].samples, levels_[level].level.footprint_px});
    if (levels_[level].search_bound <= 0) continue;  // optimizeSeparate skips it (bound 0)
    for (size_t shader = 0; shader < shaders_.size(); ++shader)
      if (!pairs_.count(std::make_tuple(int(level), 0, 0, int(shader))))
        jobs.push_back({int(level), int(shader)});
  }
  if (jobs.empty()) return;
  std::reverse(jobs.begin(), jobs.end());
  std::vector<shader::Variant> variants;
  for (const ShaderCandidate& candidate : shaders_) variants.push_back(candidate.variant);
  sort_prefetch_ = std::make_unique<SortByErrorPrefetch>(
      asset_, std::move(variants), std::move(levels), std::move(jobs), contextOptions());
}

core::Result<GenerateResult> Generator::run(const render::GlslSource& source) {
  const auto start = Clock::now();
  if (auto ready = setUp(source); !ready) return ready.error();
  GenerateResult result;
  result.device = renderer_->deviceDescription();
  result.cost_source = options_.cost_source == CostSource::kMeasured
                           ? "measured (chosen pairs; the search used predicted)"
                           : "predicted (cost model)";
  if (auto made = makeLevels(); !made) return made.error();
  for (const LevelState& level : levels_) result.all_levels.push_back(level.level);
  result.bound = options_.levels.bound;  // as makeLevels placed it

  auto mesh_start = Clock::now();
  result.timings.setup_seconds = std::chrono::duration<double>(mesh_start - start).count();
  startShaderSearch();
  if (auto made = makeMeshCandidates(source); !made) return made.error();
  addReadyConfigurations(static_cast<int>(levels_.size()) - 1);  // quadric mode, shader only
  result.timings.mesh_seconds = secondsSince(mesh_start);
  for (int set : set_of_level_)
    result.mesh_candidates.push_back(static_cast<int>(mesh_sets_[set].meshes.size()));

  SeparateOptions separate;
  separate.time_tolerance = options_.time_tolerance;
  separate.merge_min_gain = options_.merge_min_gain;
  separate.bisection_stop = options_.bisection_stop;
  separate.brute_force = options_.brute_force;
  const bool interleaved = options_.optimizer == Optimizer::kInterleaved;
  auto shader_start = Clock::now();
  // The baselines with the same thresholds, on the same cached renders (report plots). The
  // mesh-only one needs only the original shader, so it runs while the GP searches finish on
  // their own thread (the caller's thread would only wait); its renders are also the joint
  // walk's first column (S_0 errs least on M_0).
  std::map<LodScope, SeparateSolution> baselines;
  auto keepRendersOf = [this](LodScope scope) {
    return [this, scope](int level, const std::vector<EvaluatedPair>& pairs) {
      wantRendersOf(scope, level, pairs);
      dropUnwanted(level);
    };
  };
  // What an optimization step rendered and compared, for the log.
  struct Tally {
    int pair_renders = 0, transitions = 0, transition_renders = 0;
  };
  auto tally = [this] {
    return Tally{pair_evaluations_, transition_evaluations_, transition_renders_};
  };
  auto describe = [&](const char* what, const Tally& before, Clock::time_point since) {
    char line[240];
    std::snprintf(
        line, sizeof line, "%s: %d pair renders, %d transitions (%d renders for them), %.1f s",
        what, pair_evaluations_ - before.pair_renders, transition_evaluations_ - before.transitions,
        transition_renders_ - before.transition_renders, secondsSince(since));
    return std::string(line);
  };
  if (options_.scope == LodScope::kJoint && shader_search_) {
    const auto baseline_start = Clock::now();
    const Tally before = tally();
    separate.on_level_pairs = keepRendersOf(LodScope::kMeshOnly);
    auto baseline = optimizeSeparate(problem(LodScope::kMeshOnly), separate);
    if (!baseline) return baseline.error();
    if (options_.progress)
      options_.progress(
          {"shader candidates", 0.0,
           describe("mesh-only baseline (while the searches run)", before, baseline_start)});
    baselines.emplace(LodScope::kMeshOnly, std::move(*baseline));
  }
  if (!interleaved)
    if (auto made = makeShaderCandidates(); !made) return made.error();
  result.timings.shader_seconds = secondsSince(shader_start);
  result.timings.shader_search_seconds = shader_search_seconds_;

  auto optimization_start = Clock::now();
  auto level_start = Clock::now();
  int level_renders = pair_evaluations_;
  separate.on_level = [&](int level, int evaluations) {
    char line[160];
    std::snprintf(line, sizeof line, "pairs level %d: %d evaluations so far, %d new renders, %.1f s",
                  level, evaluations, pair_evaluations_ - level_renders, secondsSince(level_start));
    level_start = Clock::now();
    level_renders = pair_evaluations_;
    if (options_.progress)
      options_.progress({"pair search", double(level + 1) / levels_.size(), line});
  };
  if (!interleaved && options_.sort_prefetch && options_.scope != LodScope::kMeshOnly)
    startSortPrefetch();
  if (options_.scope == LodScope::kJoint && !interleaved) {
    // The shader-only baseline, which runs after this optimization, compares the renders of M_0
    // with its shaders. Its searches use only the SortByError records this one makes at each
    // level (and the same shader candidates), so its pair sets are known as each level ends: the
    // renders they want are kept instead of dropped and rendered again (35 renders, 2 s, on spot).
    separate.on_level_pairs = [this, &separate, keep = keepRendersOf(options_.scope)](
                                  int level, const std::vector<EvaluatedPair>& pairs) {
      SeparateSolution ahead;  // (on failure the renders are made again when wanted)
      if (searchLevel(problem(LodScope::kShaderOnly), separate, level, ahead))
        wantRendersOf(LodScope::kShaderOnly, level, ahead.level_pairs.back());
      keep(level, pairs);
    };
  } else {
    separate.on_level_pairs = keepRendersOf(options_.scope);
  }
  // The joint search's renders of pairs that cannot be in a level's set go as they are found
  // (out of the bound or more than T above the cheapest): with the candidates past the
  // image-driven cascade the Dragon's first level kept 523 MB of them until its set was known.
  // Only keys of this scope's sets (mesh 0 is set 0's, shared with the baselines), and never one
  // some set wants; one wanted later after all is drawn again, the same bit for bit.
  if (!interleaved)
    separate.on_discarded = [this, scope = options_.scope](int level, int mesh, int shader) {
      if (mesh == 0) return;
      const auto key = std::make_tuple(level, setIn(scope, level), mesh, shader);
      if (wanted_images_.count(key)) return;
      if (auto it = images_.find(key); it != images_.end()) eraseRender(it);
    };
  auto joint = interleaved ? runInterleaved(separate)
                           : optimizeSeparate(problem(options_.scope), separate);
  separate.on_discarded = nullptr;
  if (sort_prefetch_) {
    if (options_.progress) {
      const std::string failure = sort_prefetch_->failure();
      char line[160];
      std::snprintf(line, sizeof line, "SortByError renders made ahead on a second thread: %d",
                    sort_prefetch_->rendered());
      options_.progress({"pair search", 1.0, line});
      if (!failure.empty())
        options_.progress({"pair search", 1.0,
                           "warning: the SortByError thread stopped early (this thread rendered "
                           "the rest): " + failure});
    }
    sort_prefetch_.reset();
  }
  if (!joint) return joint.error();
  auto logStep = [&](const char* what, Clock::time_point since, const Tally& before) {
    if (options_.progress)
      options_.progress({"smoothing and merging", 1.0, describe(what, before, since)});
  };
  logStep(
      interleaved ? "interleaved optimization" : "separate optimization (with smoothing, merging)",
      optimization_start, Tally{});
  result.shader_candidates = static_cast<int>(shaders_.size());
  if (options_.scope == LodScope::kJoint) {
    separate.on_level = nullptr;
    for (LodScope scope : {LodScope::kMeshOnly, LodScope::kShaderOnly}) {
      if (baselines.count(scope)) continue;
      const auto baseline_start = Clock::now();
      const Tally before = tally();
      separate.on_level_pairs = keepRendersOf(scope);
      auto baseline = optimizeSeparate(problem(scope), separate);
      if (!baseline) return baseline.error();
      logStep(scope == LodScope::kMeshOnly ? "mesh-only baseline" : "shader-only baseline",
              baseline_start, before);
      baselines.emplace(scope, std::move(*baseline));
    }
  }
  if (options_.progress) {
    char line[160];
    std::snprintf(line, sizeof line,
                  "pair renders kept for the transitions: at most %.1f MB at once of %.1f MB "
                  "made (%d renders for the transitions alone)",
                  double(kept_bytes_peak_) / (1 << 20), double(rendered_bytes_) / (1 << 20),
                  transition_renders_);
    options_.progress({"smoothing and merging", 1.0, line});
  }
  result.timings.optimization_seconds = secondsSince(optimization_start);

  // Every kept level re-evaluated on views and lights outside the training domain. Errors there
  // run up to ~12% above the training errors (the searches aim at 1 − bound_margin of the bound
  // for this reason), so a pair chosen right at that aim can still break its bound there: such a
  // level is dropped from the chain, and the finer level before it covers its distances (its
  // error shrinks with distance while the bound grows). At d_near the bound is 0 (eq. 4): the
  // level is the original by definition, and re-rendering it would show nothing.
  std::vector<int>& kept = joint->merge.kept_levels;
  std::vector<std::optional<HeldOutCheck>> checks;
  for (size_t k = 0; k < kept.size();) {
    const int level = kept[k];
    progress("held-out check", double(k) / kept.size());
    if (levels_[level].bound <= 0) {
      checks.emplace_back();
      ++k;
      continue;
    }
    auto domain = heldOutDomain(level);
    if (!domain) return domain.error();
    auto check = checkHeldOut(*domain, level, setFor(level), joint->chosen[level],
                              joint->fallback_to_original[level]);
    if (!check) return check.error();
    if (!check->within && !check->original_fallback && k > 0) {
      // What the runtime will draw there instead: the finer level before, checked the same way.
      const int before = kept[k - 1];
      auto covering = checkHeldOut(*domain, level, setFor(before), joint->chosen[before], false);
      if (!covering) return covering.error();
      check->covering_error = covering->error;
      result.dropped.push_back(*check);
      kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(k));
      continue;
    }
    checks.push_back(*check);
    ++k;
  }
  for (size_t k = 0; k < checks.size(); ++k)
    if (checks[k]) {
      checks[k]->level = static_cast<int>(k);
      result.held_out.push_back(*checks[k]);
    }

  // The kept levels.
  for (size_t k = 0; k < kept.size(); ++k) {
    const int level = kept[k];
    const EvaluatedPair& pair = joint->chosen[level];
    const int set = setFor(level);
    const ShaderCandidate& candidate = shaders_[pair.shader];
    GeneratedLevel out;
    out.level = levels_[level].level;
    out.switch_distance = k == 0 ? 0.0 : levels_[level].level.distance;
    out.mesh = candidateMesh(set, pair.mesh);
    auto readable = shader::emitProgram(*candidate.program, /*optimize=*/false);
    if (!readable) return readable.error();
    out.readable = {std::move(readable->vertex), std::move(readable->fragment)};
    out.optimized = candidate.variant.spirv;
    out.parameters = candidate.variant.uniforms;
    for (const shader::ParameterValue& parameter : candidate.program->parameters)
      out.parameter_names.push_back(parameter.name);
    out.shader_summary = candidate.summary;
    out.mesh_candidate = pair.mesh;
    out.shader_candidate = pair.shader;
    out.error = pair.error;
    out.error_bound = levels_[level].bound;
    out.original_fallback = joint->fallback_to_original[level];
    out.predicted_cost = pair.cost;
    result.levels.push_back(std::move(out));
  }
  // ε_t between consecutive kept levels, at the farther one's distance.
  for (size_t k = 0; k + 1 < kept.size(); ++k) {
    auto error = transitionError(kept[k + 1] - 1, setFor(kept[k]), joint->chosen[kept[k]],
                                 setFor(kept[k + 1]), joint->chosen[kept[k + 1]]);
    if (!error) return error.error();
    result.levels[k].transition_error = *error;
  }
  if (options_.cost_source == CostSource::kMeasured)
    if (auto measured = measureChosen(result); !measured) return measured.error();
  result.pair_evaluations = pair_evaluations_;
  result.transition_evaluations = transition_evaluations_;
  result.transition_renders = transition_renders_;
  result.kept_render_bytes_peak = kept_bytes_peak_;
  fillReport(result, *joint, baselines);
  result.timings.total_seconds = secondsSince(start);
  return result;
}


// Cost(f(M, S, d)) on the wall clock for each kept level's pair and for the original pair at the
// same distance, in one call each (times compare within a call; report both).
core::Status Generator::measureChosen(GenerateResult& result) {
  for (size_t k = 0; k < result.levels.size(); ++k) {
    progress("timing", double(k) / result.levels.size());
    GeneratedLevel& out = result.levels[k];
    const LevelState& level = levels_[out.level.index];
    render::TimingOptions timing{.resolution = level.level.footprint_px};
    auto measure = [&](int set, int mesh, int shader) -> core::Result<double> {
      auto asset = meshAsset(set, mesh);
      if (!asset) return asset.error();
      auto program = programOf(shader);
      if (!program) return program.error();
      auto time = renderer_->measureDrawTime(*asset, *program, level.samples, timing);
      if (!time) return time.error();
      return time->seconds / static_cast<double>(level.samples.size());
    };
    auto original = measure(0, 0, 0);
    if (!original) return original.error();
    auto chosen = measure(setFor(out.level.index), out.mesh_candidate, out.shader_candidate);
    if (!chosen) return chosen.error();
    out.original_measured_cost = *original;
    out.measured_cost = *chosen;
  }
  return core::okStatus();
}

// Every kept level on views and lights the optimization never saw: the held-out counterpart of
// the training views (the icosahedron's 12 for the dodecahedron's 20, the upright band's 12 for
// its 20) with the light cross turned by 45°.
core::Result<Generator::HeldOutDomain> Generator::heldOutDomain(int level_index) {
  auto original = cache_->program(shaders_[0].variant);
  if (!original) return original.error();
  const DistanceLevel& level = levels_[level_index].level;
  HeldOutDomain domain;
  domain.samples = render::domainSamples(
      bounds_, float(level.distance),
      {.views = render::heldOutViews(options_.views), .light_rotation_deg = 45.0f});
  auto reference = renderer_->renderReference(
      original_asset_, *original, domain.samples,
      {.resolution = level.footprint_px, .supersample = options_.supersample});
  if (!reference) return reference.error();
  domain.reference = std::move(*reference);
  return domain;
}

core::Result<HeldOutCheck> Generator::checkHeldOut(const HeldOutDomain& domain, int level_index,
                                                    int pair_set, const EvaluatedPair& pair,
                                                    bool fallback) {
  const DistanceLevel& level = levels_[level_index].level;
  auto images = renderPairOn(domain.samples, level.footprint_px, pair_set, pair.mesh, pair.shader,
                             nullptr);
  if (!images) return images.error();
  metric::ImageError error = metric::imageError(*images, domain.reference);
  HeldOutCheck check{.level = -1,
                     .distance_level = level_index,
                     .error = error.epsilon,
                     .bound = errorBound(level, error.coverage_px),
                     .original_fallback = fallback};
  check.within = check.error < check.bound;
  return check;
}

// A wireframe of `mesh` seen from `sample`, `size` pixels square, on white (the report's picture
// of a level's mesh). Edges are drawn once per triangle side with a DDA; no hidden-line removal.
core::ImageRGBA8 wireframe(const core::Mesh& mesh, const render::Sample& sample, int size) {
  core::ImageRGBA8 image{size, size, std::vector<uint8_t>(size_t(size) * size * 4, 255)};
  const core::Mat4 clip = sample.projection * sample.view;
  std::vector<std::array<float, 2>> screen(mesh.positions.size());
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    core::Vec4 p = core::transform(clip, {mesh.positions[v].x, mesh.positions[v].y,
                                          mesh.positions[v].z, 1.0f});
    float w = p.w > 1e-6f ? p.w : 1e-6f;
    screen[v] = {(p.x / w * 0.5f + 0.5f) * size, (0.5f - p.y / w * 0.5f) * size};
  }
  auto line = [&](uint32_t a, uint32_t b) {
    float dx = screen[b][0] - screen[a][0], dy = screen[b][1] - screen[a][1];
    int steps = std::max(1, static_cast<int>(std::ceil(std::max(std::abs(dx), std::abs(dy)))));
    steps = std::min(steps, 4 * size);
    for (int s = 0; s <= steps; ++s) {
      int x = static_cast<int>(screen[a][0] + dx * s / steps);
      int y = static_cast<int>(screen[a][1] + dy * s / steps);
      if (x < 0 || y < 0 || x >= size || y >= size) continue;
      uint8_t* pixel = &image.pixels[(size_t(y) * size + x) * 4];
      pixel[0] = 40, pixel[1] = 60, pixel[2] = 110;
    }
  };
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    line(mesh.indices[t], mesh.indices[t + 1]);
    line(mesh.indices[t + 1], mesh.indices[t + 2]);
    line(mesh.indices[t + 2], mesh.indices[t]);
  }
  return image;
}

void Generator::fillReport(GenerateResult& result, const SeparateSolution& joint,
                           const std::map<LodScope, SeparateSolution>& baselines) {
  ReportData& report = result.report;
  report.title = "duolod LOD of " + fs::path(asset_.source_path).filename().string();
  const metric::BoundConfig& bound = options_.levels.bound;
  report.facts = {
      {"asset", asset_.source_path},
      {"triangles", std::to_string(asset_.mesh.indices.size() / 3)},
      {"device", result.device},
      {"display", std::to_string(options_.levels.display.height_px) + " px high, FOV " +
                      shortNumber(options_.levels.display.fov_y_deg) + "°"},
      {"bound (eq. 4)", "d_near " + shortNumber(bound.d_near) + ", d_far " +
                            shortNumber(bound.d_far) + ", Q " + shortNumber(bound.q) +
                            ", e_max " + shortNumber(bound.e_max)},
      {"levels", std::to_string(levels_.size()) + " → " + std::to_string(result.levels.size()) +
                     " after merging (W = " + std::to_string(options_.merge_min_gain) + ")"},
      {"candidates", std::to_string(shaders_.size()) + " shaders; meshes per level up to " +
                         std::to_string(options_.mesh_candidates)},
      {"pair evaluations", std::to_string(pair_evaluations_) + " rendered (" +
                               std::to_string(transition_evaluations_) + " transitions)"},
      {"cost", result.cost_source},
  };
  for (size_t k = 0; k < result.levels.size(); ++k) {
    const GeneratedLevel& out = result.levels[k];
    const LevelState& level = levels_[out.level.index];
    ReportLevel row;
    row.index = static_cast<int>(k);
    row.distance = out.level.distance;
    row.screen_coverage = out.level.screen_coverage;
    row.triangles = out.mesh.indices.size() / 3;
    row.shader_summary = out.shader_summary;
    row.error = out.error;
    row.error_bound = out.error_bound;
    row.transition_error = out.transition_error;
    row.predicted_cost = out.predicted_cost;
    row.measured_cost = out.measured_cost;
    const int size = std::max(96, level.level.footprint_px);
    row.images.push_back({"mesh", wireframe(out.mesh, level.samples[0], size)});
    if (auto images = renderPair(out.level.index, setFor(out.level.index), out.mesh_candidate,
                                 out.shader_candidate, nullptr))
      row.images.push_back({"level", render::tileImage(*images, 0)});
    row.images.push_back({"reference f̄", render::tileImage(level.reference, 0)});
    report.levels.push_back(std::move(row));
  }
  auto plot = [](std::string title, std::string y_label) {
    ReportPlot made;
    made.title = std::move(title);
    made.x_label = "distance";
    made.y_label = std::move(y_label);
    return made;
  };
  auto series = [](std::string name) {
    ReportSeries made;
    made.name = std::move(name);
    return made;
  };
  ReportPlot errors = plot("Error against distance", "ε_a");
  ReportSeries bound_series = series("bound e_a(d)·s_d"), error_series = series("chosen pair");
  for (const LevelState& level : levels_) {
    bound_series.x.push_back(level.level.distance);
    bound_series.y.push_back(level.bound);
  }
  for (size_t level = 0; level < joint.chosen.size(); ++level) {
    error_series.x.push_back(levels_[level].level.distance);
    error_series.y.push_back(joint.chosen[level].error);
  }
  errors.series = {bound_series, error_series};
  report.plots.push_back(errors);

  ReportPlot costs = plot("Cost per draw against distance (" + result.cost_source + ")", "seconds");
  auto costSeries = [&](std::string name, const SeparateSolution& solution) {
    ReportSeries cost_series = series(std::move(name));
    // The pair in use at each distance: the last kept level at or before it.
    size_t kept = 0;
    for (size_t level = 0; level < solution.chosen.size(); ++level) {
      while (kept + 1 < solution.merge.kept_levels.size() &&
             solution.merge.kept_levels[kept + 1] <= static_cast<int>(level))
        ++kept;
      cost_series.x.push_back(levels_[level].level.distance);
      cost_series.y.push_back(solution.chosen[solution.merge.kept_levels[kept]].cost);
    }
    return cost_series;
  };
  ReportSeries no_lod = series("no LOD");
  for (size_t level = 0; level < levels_.size(); ++level)
    if (auto original = evaluatePair(static_cast<int>(level), 0, 0, 0)) {
      no_lod.x.push_back(levels_[level].level.distance);
      no_lod.y.push_back(original->cost);
    }
  costs.series.push_back(no_lod);
  if (auto found = baselines.find(LodScope::kMeshOnly); found != baselines.end())
    costs.series.push_back(costSeries("mesh only", found->second));
  if (auto found = baselines.find(LodScope::kShaderOnly); found != baselines.end())
    costs.series.push_back(costSeries("shader only", found->second));
  costs.series.push_back(costSeries("joint", joint));
  report.plots.push_back(costs);

  for (size_t level = 0; level < joint.searches.size(); ++level)
    report.searches.push_back(
        {.title = "level " + std::to_string(level) + ", d = " +
                  std::to_string(levels_[level].level.distance),
         .mesh_count = static_cast<int>(mesh_sets_[setFor(static_cast<int>(level))].meshes.size()),
         .shader_count = static_cast<int>(joint.shader_orders[level].size()),
         .result = joint.searches[level]});
  report.transitions = ReportTransitions{.level_pairs = joint.level_pairs, .path = joint.path};
}


core::Result<int> Generator::addShaderCandidate(
    std::shared_ptr<const shader::ShaderProgram> program, std::string summary) {
  auto candidate = candidateFrom(std::move(program), std::move(summary));
  if (!candidate) return candidate.error();
  shaders_.push_back(std::move(*candidate));
  return static_cast<int>(shaders_.size()) - 1;
}

// The coarsest mesh of the level's set that, with `shader`, stays within the bound, by bisection
// over the candidates (their error grows with simplification); -1 when not even M_0 does.
core::Result<int> Generator::coarsestMeshWithin(int level, int shader) {
  const int set = set_of_level_[level];
  const double bound = levels_[level].search_bound;
  auto within = [&](int mesh) -> core::Result<bool> {
    auto record = evaluatePair(level, set, mesh, shader);
    if (!record) return record.error();
    return record->error.epsilon < bound;
  };
  auto finest = within(0);
  if (!finest) return finest.error();
  if (!*finest) return -1;
  int good = 0, bad = static_cast<int>(mesh_sets_[set].meshes.size());
  while (bad - good > 1) {
    int middle = (good + bad) / 2;
    auto ok = within(middle);
    if (!ok) return ok.error();
    (*ok ? good : bad) = middle;
  }
  return good;
}

// §4.3: per level, GP generations of shader variants. Each generation applies one rule to each
// seed (a seeded sample of the sites); the variants on the Pareto front of predicted (cost, error)
// are each paired with the coarsest mesh that keeps the pair within the bound (the progressive
// record replaces re-simplifying, §5.1); the pairs are sorted by cost and the top N% seed the next
// generation. The levels' pairs then go through the same smoothing and merging.
core::Result<SeparateSolution> Generator::runInterleaved(const SeparateOptions& options) {
  const int level_count = static_cast<int>(levels_.size());
  shader::RuleContext context;
  context.texture_averages = shader::textureAverages(asset_, options_.bindings);
  SeparateSolution solution;
  std::map<uint64_t, int> candidate_of_hash{{shader::programHash(original_), 0}};
  for (int level = 0; level < level_count; ++level) {
    progress("interleaved", double(level) / level_count);
    std::vector<EvaluatedPair> pairs;
    auto addPair = [&](int mesh, int shader) -> core::Status {
      auto record = evaluatePair(level, set_of_level_[level], mesh, shader);
      if (!record) return record.error();
      pairs.push_back({.mesh = mesh,
                       .shader = shader,
                       .error = record->error.epsilon,
                       .cost = record->cost,
                       .within_bound = record->error.epsilon < levels_[level].search_bound});
      return core::okStatus();
    };
    auto original_mesh = coarsestMeshWithin(level, 0);
    if (!original_mesh) return original_mesh.error();
    if (*original_mesh >= 0)
      if (auto added = addPair(*original_mesh, 0); !added) return added.error();
    if (level > 0 && options_.scope != LodScope::kMeshOnly) {
      auto scoring = scorerFor(level, set_of_level_[level], 0);
      if (!scoring) return scoring.error();
      shader::SearchCache search_cache(original_, context, (*scoring)->scorer());
      shader::SearchRandom rng(options_.seed * 7919 + static_cast<uint64_t>(level));
      std::vector<std::vector<shader::RuleSite>> seeds{{}};
      for (int generation = 0; generation < options_.interleaved_generations; ++generation) {
        struct Child {
          std::vector<shader::RuleSite> sites;
          std::shared_ptr<const shader::ShaderProgram> program;
          double cost = 0, error = 0;
        };
        std::vector<Child> children;
        for (const auto& seed : seeds) {
          auto parent = search_cache.materialise(seed);
          if (!parent) continue;
          std::vector<shader::RuleSite> sites = shader::enumerateSites(**parent, context);
          // A seeded sample of the sites, at most `population` per seed.
          for (size_t i = sites.size(); i > 1; --i) std::swap(sites[i - 1], sites[rng.index(i)]);
          if (static_cast<int>(sites.size()) > options_.population) sites.resize(options_.population);
          for (const shader::RuleSite& site : sites) {
            std::vector<shader::RuleSite> genome = seed;
            genome.push_back(site);
            auto program = search_cache.materialise(genome);
            if (!program) continue;
            auto score = search_cache.score(**program);
            if (!score) continue;
            children.push_back({genome, *program, score->cost, score->error});
          }
        }
        // The Pareto front of the generation (neither cheaper-and-better dominated).
        std::vector<Child> front;
        for (const Child& child : children) {
          bool dominated = false;
          for (const Child& other : children)
            if ((other.cost < child.cost && other.error <= child.error) ||
                (other.cost <= child.cost && other.error < child.error)) {
              dominated = true;
              break;
            }
          if (!dominated) front.push_back(child);
        }
        struct Scored {
          std::vector<shader::RuleSite> sites;
          double cost = 0;
        };
        std::vector<Scored> paired;
        for (const Child& child : front) {
          uint64_t hash = shader::programHash(*child.program);
          auto known = candidate_of_hash.find(hash);
          int shader_index;
          if (known != candidate_of_hash.end()) {
            shader_index = known->second;
          } else {
            auto added = addShaderCandidate(child.program, shader::summarizeSites(child.sites));
            if (!added) return added.error();
            shader_index = *added;
            candidate_of_hash.emplace(hash, shader_index);
          }
          auto mesh = coarsestMeshWithin(level, shader_index);
          if (!mesh) return mesh.error();
          if (*mesh < 0) continue;  // not even the original mesh keeps this shader in bounds
          if (auto added = addPair(*mesh, shader_index); !added) return added.error();
          paired.push_back({child.sites, pairs.back().cost});
        }
        if (paired.empty()) break;
        std::stable_sort(paired.begin(), paired.end(),
                         [](const Scored& a, const Scored& b) { return a.cost < b.cost; });
        const size_t top = std::max<size_t>(
            1, static_cast<size_t>(std::ceil(options_.interleaved_top_fraction * paired.size())));
        seeds.clear();
        for (size_t i = 0; i < top && i < paired.size(); ++i) seeds.push_back(paired[i].sites);
      }
      solution.evaluations += search_cache.counters().variants_predicted;
    }
    // The level's optimal set: within the bound and within T of the cheapest (Algorithm 2's rule).
    std::vector<EvaluatedPair> feasible;
    for (const EvaluatedPair& pair : pairs)
      if (pair.within_bound) feasible.push_back(pair);
    std::stable_sort(feasible.begin(), feasible.end(),
                     [](const auto& a, const auto& b) { return a.cost < b.cost; });
    std::vector<EvaluatedPair> optimal;
    for (const EvaluatedPair& pair : feasible)
      if (pair.cost - feasible.front().cost <= options.time_tolerance * feasible.front().cost)
        optimal.push_back(pair);
    const bool fallback = optimal.empty();
    if (fallback) {
      auto record = evaluatePair(level, set_of_level_[level], 0, 0);
      if (!record) return record.error();
      optimal.push_back({.mesh = 0, .shader = 0, .error = record->error.epsilon,
                         .cost = record->cost});
    }
    PairSearchResult search;
    search.visited = pairs;
    search.optimal = optimal;
    search.evaluations = static_cast<int>(pairs.size());
    solution.searches.push_back(std::move(search));
    solution.shader_orders.emplace_back();
    solution.level_pairs.push_back(std::move(optimal));
    solution.fallback_to_original.push_back(fallback);
    if (options.on_level_pairs) options.on_level_pairs(level, solution.level_pairs.back());
  }
  SeparateProblem whole = problem(LodScope::kJoint);
  if (auto finished = smoothAndMerge(whole, options, solution); !finished) return finished.error();
  return solution;
}

}  // namespace

namespace {

// The options' ranges, before any work: a count of 0 mesh candidates left the shader search
// reading the first candidate's error from an empty list. (The bound's and the display's
// parameters are checked where the levels are placed: distanceLevels.)
core::Status checkGenerateOptions(const GenerateOptions& options) {
  auto finiteAtLeast = [](double value, double low) {
    return std::isfinite(value) && value >= low;
  };
  struct Check {
    bool holds;
    const char* what;
  };
  const Check checks[] = {
      {options.mesh_candidates >= 1 && options.mesh_candidates <= 1000000,
       "mesh_candidates must be in [1, 1000000]"},
      {std::isfinite(options.max_edge_pixels) && options.max_edge_pixels > 0,
       "max_edge_pixels must be finite and > 0"},
      {options.shader_search_levels >= 0, "shader_search_levels must be >= 0"},
      {options.shader_search_meshes >= 1, "shader_search_meshes must be >= 1"},
      {options.population >= 2, "population must be >= 2"},
      {options.generations >= 0, "generations must be >= 0"},
      {options.max_shader_candidates >= 1, "max_shader_candidates must be >= 1"},
      {options.average_resolution >= 1, "average_resolution must be >= 1"},
      {options.near_footprint_px >= 1 && options.far_footprint_px >= 1,
       "near_footprint_px and far_footprint_px must be >= 1"},
      {finiteAtLeast(options.levels.bound.d_near, 0) &&
           finiteAtLeast(options.levels.bound.d_far, 0),
       "d_near and d_far must be finite and >= 0 (0: placed by the footprints)"},
      {finiteAtLeast(options.time_tolerance, 0), "time_tolerance must be finite and >= 0"},
      {finiteAtLeast(options.merge_min_gain, 0), "merge_min_gain must be finite and >= 0"},
      {options.supersample >= 1 && options.supersample <= 16, "supersample must be in [1, 16]"},
      {finiteAtLeast(options.bound_margin, 0) && options.bound_margin < 1,
       "bound_margin must be in [0, 1)"},
      {finiteAtLeast(options.bisection_stop, 0) && options.bisection_stop <= 1,
       "bisection_stop must be in [0, 1]"},
      {options.interleaved_top_fraction > 0 && options.interleaved_top_fraction <= 1,
       "interleaved_top_fraction must be in (0, 1]"},
      {options.interleaved_generations >= 1, "interleaved_generations must be >= 1"},
  };
  for (const Check& check : checks)
    if (!check.holds) return core::Error{std::string("generate: ") + check.what};
  return core::okStatus();
}

}  // namespace

core::Result<GenerateResult> generateLod(const core::Asset& asset, const render::GlslSource& shader,
                                         const GenerateOptions& options) {
  if (asset.mesh.indices.empty()) return core::Error{"generate: the asset has no triangles"};
  if (auto valid = checkGenerateOptions(options); !valid) return valid.error();
  const shader::OptimizationMemoScope memo;  // released when the run ends
  Generator generator(asset, options);
  return generator.run(shader);
}

}  // namespace duolod::lod
