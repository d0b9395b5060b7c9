// A variant's rule applications in a few words for people (lod.json's shader summary, the
// report): grouped by what they do, e.g. "fbm loop: 4 → 2 iterations; per vertex: radiance;
// 2 operations removed (gradientNoise, fbm)".
#pragma once

#include <span>
#include <string>

#include "shader/rules.hpp"

namespace duolod::shader {

std::string summarizeSites(std::span<const RuleSite> sites);

}  // namespace duolod::shader
