// Variant summaries in words (shader/summary.hpp): grouped per kind, names kept, ids counted.
#include "shader/summary.hpp"

#include <gtest/gtest.h>

namespace duolod::shader {
namespace {

RuleSite site(RuleKind kind, std::string description) {
  RuleSite result;
  result.kind = kind;
  result.description = std::move(description);
  return result;
}

TEST(ShaderSummary, OriginalWhenNoSite) { EXPECT_EQ(summarizeSites({}), "original"); }

TEST(ShaderSummary, GroupsSitesByWhatTheyDo) {
  std::vector<RuleSite> sites = {
      site(RuleKind::kOperationRemoval, "fragment gradientNoise: mul(gk1, %505) → %505"),
      site(RuleKind::kPerVertex, "fragment: %923 computed in the vertex stage and interpolated"),
      site(RuleKind::kOperationRemoval, "vertex fbm: mul(%177, frequency) → frequency"),
      site(RuleKind::kLoopTruncation, "fragment: fbm loop: 4 → 2 iterations"),
      site(RuleKind::kPerVertex,
           "fragment: radiance computed in the vertex stage and interpolated"),
      site(RuleKind::kOperationRemoval, "fragment gradientNoise: add(a, b) → a"),
      site(RuleKind::kTextureAverage, "fragment: uBaseColorTexture sample → its average colour"),
      site(RuleKind::kTextureMip, "fragment: uNormalTexture sample → 2 mip level(s) coarser"),
      site(RuleKind::kMoveToParameter, "fragment: n → its average over the domain"),
  };
  EXPECT_EQ(summarizeSites(sites),
            "fbm loop: 4 → 2 iterations; uBaseColorTexture → average colour; uNormalTexture 2 mip "
            "level(s) coarser; per vertex: radiance and 1 unnamed value; constant (domain "
            "average): n; 3 operations removed (fbm, gradientNoise ×2)");
}

TEST(ShaderSummary, RepeatedTruncationsOfOneLoopReadAsOne) {
  std::vector<RuleSite> sites = {
      site(RuleKind::kLoopTruncation, "fragment: loop over octave in fbm: 4 → 2 iterations"),
      site(RuleKind::kLoopTruncation, "fragment: loop over i in blend: 3 → 2 iterations"),
      site(RuleKind::kLoopTruncation, "fragment: loop over octave in fbm: 2 → 1 iterations"),
  };
  EXPECT_EQ(summarizeSites(sites),
            "loop over octave in fbm: 4 → 1 iterations; loop over i in blend: 3 → 2 iterations");
}

TEST(ShaderSummary, UnexpectedWordingIsKeptWhole) {
  std::vector<RuleSite> sites = {site(RuleKind::kPerVertex, "something else")};
  EXPECT_EQ(summarizeSites(sites), "per vertex: something else");
}

}  // namespace
}  // namespace duolod::shader
