// Shared by the benchmarks: wall-clock medians of repeated runs.
#pragma once

#include <algorithm>
#include <chrono>
#include <type_traits>
#include <vector>

#include "duolod/core.hpp"

namespace duolod::bench {

using core::median;

// Median wall time of `repeats` calls of `run`. A `run` returning bool false stops and gives -1.
template <class F>
double medianSeconds(int repeats, F&& run) {
  std::vector<double> times;
  for (int r = 0; r < repeats; ++r) {
    auto start = std::chrono::steady_clock::now();
    if constexpr (std::is_same_v<decltype(run()), bool>) {
      if (!run()) return -1;
    } else {
      run();
    }
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return median(times);
}

}  // namespace duolod::bench
