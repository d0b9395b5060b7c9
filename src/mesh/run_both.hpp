// Two independent pieces of work on the two cores of the machine (the image-driven mode's tile
// builds, the two sides of surfaceDistance, the attribute-aware passes' pricing).
#pragma once

#include <cstdint>
#include <exception>
#include <system_error>
#include <thread>

#include "mesh/second_core.hpp"

namespace duolod::mesh {

// Runs `first` and `second` at once on two cores when the machine has them (mostly `first` on
// this thread), else one after the other here; the two share only what they read, so the results
// do not depend on which. The other core is the process's helper thread (second_core.hpp) when no
// other call holds it (waking it costs ~44 us here, starting and joining a thread ~100 us;
// bench/RESULTS.md, issue 3, session 46), else a thread of its own. The helper sleeps right after
// its part instead of spinning for a next one: these calls come far apart, and the image-driven
// mode renders in between on llvmpipe's threads, which need the core (spinning, its renders took
// 10-30% longer). An exception from either is rethrown here, once neither runs (on one core
// `second` is not started once `first` threw).
template <class First, class Second>
void runBoth(First&& first, Second&& second) {
  std::exception_ptr thrown[2];
  {
    SecondCore helper(/*wanted=*/true, /*linger=*/false);
    if (helper.available()) {
      // The parts are claimed one by one by either thread: mostly `first` here and `second` on
      // the helper, but a helper already spinning may take `first`, and one still waking finds
      // both taken.
      helper.forEach(2, [&](uint32_t part) {
        try {
          if (part == 0)
            first();
          else
            second();
        } catch (...) {
          thrown[part] = std::current_exception();
        }
      });
      for (const std::exception_ptr& e : thrown)
        if (e) std::rethrow_exception(e);
      return;
    }
  }
  static const bool two_cores = second_core_detail::usableCpus() >= 2;
  std::thread other;
  if (two_cores) {
    try {
      // Under this thread's floating-point control, as on the helper.
      other = std::thread([&, control = second_core_detail::floatControl()] {
        second_core_detail::setFloatControl(control);
        try {
          second();
        } catch (...) {
          thrown[1] = std::current_exception();
        }
      });
    } catch (const std::system_error&) {  // no thread to be had: both here
    }
  }
  try {
    first();
  } catch (...) {
    if (other.joinable()) other.join();
    throw;
  }
  if (other.joinable())
    other.join();
  else
    second();
  if (thrown[1]) std::rethrow_exception(thrown[1]);
}

}  // namespace duolod::mesh
