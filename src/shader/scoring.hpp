// Scoring shader variants for one (mesh, distance) configuration (Liang et al. §5.2): the cost
// model's prediction (instrumented block counts × calibrated weights × the configuration's
// vertex and fragment invocations) and the evaluator's predicted and rendered eq. (6) errors, as
// the VariantScorer the searches use. Shared by the shader LOD pipeline and the joint optimizers.
#pragma once

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <vector>

#include "duolod/render.hpp"
#include "shader/compile_ahead.hpp"
#include "shader/evaluate.hpp"
#include "shader/rules.hpp"
#include "shader/search.hpp"
#include "shader/value_average.hpp"

namespace duolod::shader {

// The form of a program that is compiled, rendered and timed: both stages emitted with
// SPIRV-Tools' clean-up passes (dead code a rule leaves behind is gone), its CPU-set parameters
// as uniforms.
core::Result<Variant> evaluationVariant(const ShaderProgram& program);

// Average linear RGBA of the textures of the asset's first material, by the sampler binding of
// shaders/INTERFACE.md (or `bindings`' units): what texture removal substitutes (Olano et al.
// 2003). A binding the
// material has no texture for averages to the texel the renderer binds there instead
// (render::kMissingTextureTexel, kMissingNormalTexel), so its samples fold away exactly.
std::map<uint32_t, std::array<float, 4>> textureAverages(const core::Asset& asset,
                                                         const render::Bindings& bindings = {});

class CompileAhead;

class ConfigurationScorer {
 public:
  ~ConfigurationScorer();
  // `asset` is `mesh` uploaded to `renderer`; renders the original's references for `config`.
  static core::Result<std::unique_ptr<ConfigurationScorer>> create(
      render::Renderer& renderer, std::shared_ptr<EvaluationCache> cache,
      render::Renderer::AssetId asset, const core::Mesh& mesh, const ShaderProgram& original,
      const EvaluationConfig& config);

  // Scores for the searches; valid while this object lives. Errors are per-pixel (ε / s_d).
  VariantScorer scorer();
  VariantEvaluator& evaluator() { return *evaluator_; }
  // A RuleContext::average_value for this configuration, which enables "moving to parameter"
  // (He et al. 2015): a value's mean over the predicted-error samples, by an instrumented render
  // per component at `resolution` px (shader/value_average.hpp; cached by instrumented program).
  // Valid while this object lives; the first call fixes the resolution.
  std::function<core::Result<std::vector<float>>(const ShaderProgram&, Stage, ir::Id)> averageValue(
      int resolution = 64);
  int averageRenders() const;
  int costProfiles() const { return cost_profiles_; }
  // Of them, the profiles the compile-ahead workers made (enableCompileAhead with `drawn`).
  int costProfilesAhead() const { return cost_profiles_ahead_; }
  // Compiles the programs the search announces (VariantScorer::prepare) ahead in worker threads,
  // one per core, each with its own GL context (compile_ahead.hpp): `asset` is what the scorer draws (this
  // configuration's mesh with the asset's materials and textures), `context` the device. Scores
  // are the same with or without it.
  void enableCompileAhead(core::Asset asset, render::ContextOptions context);
  // The same, when the scorer draws `drawn` uploaded over `asset` (Renderer::uploadMesh): the
  // workers then make the whole cost profile too (CompileAhead::FullProfile).
  void enableCompileAhead(core::Asset asset, const core::Mesh& drawn,
                          render::ContextOptions context);
  // Programs the workers compiled, and evaluation forms they handed over (0, 0 without them).
  std::pair<int, int> compileAheadCounts() const;
  int footprint() const { return evaluator_->footprint(); }

 private:
  ConfigurationScorer() = default;
  // The optimised variant of `program`, made once per program (a one-entry memo: the searches
  // score a program's cost and then its error back to back).
  const core::Result<Variant>& optimised(const ShaderProgram& program);

  render::Renderer* renderer_ = nullptr;
  render::Renderer::AssetId asset_ = -1;
  std::unique_ptr<VariantEvaluator> evaluator_;
  std::unique_ptr<ValueAverager> averager_;
  std::vector<render::Sample> cost_samples_;
  int cost_profiles_ = 0, cost_profiles_ahead_ = 0;
  std::unique_ptr<CompileAhead> compile_ahead_;
  uint64_t memo_hash_ = 0;
  core::Result<Variant> memo_ = core::Error{"nothing scored yet"};
  std::optional<CompileAhead::Profiled> memo_profile_;  // the workers' profile of memo_'s program
};

}  // namespace duolod::shader
