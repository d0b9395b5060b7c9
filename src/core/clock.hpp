// Wall-clock helpers shared by the pipeline's stages. Internal: one definition, so that the unity
// build (eight files to a translation unit) never sees two file-private copies meet.
#pragma once

#include <chrono>

namespace duolod::core::internal {

// Seconds on the steady clock since `start`.
inline double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace duolod::core::internal
