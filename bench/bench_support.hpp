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

// Two workloads timed alternately (a, b, a, b, ...) so that both see the same machine drift: on a
// shared VM the speed moves by 10-30% over seconds, and timing all of a's repeats before all of
// b's put that drift into the ratio. Returns the medians of a's and b's times and the median of
// the per-pair ratios a / b.
struct PairedTimes {
  double a_seconds = 0, b_seconds = 0, ratio = 0;
};
template <class A, class B>
PairedTimes pairedMedianSeconds(int repeats, A&& run_a, B&& run_b) {
  auto time = [](auto&& run) {
    const auto start = std::chrono::steady_clock::now();
    run();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  std::vector<double> a, b, ratios;
  for (int r = 0; r < repeats; ++r) {
    a.push_back(time(run_a));
    b.push_back(time(run_b));
    ratios.push_back(b.back() > 0 ? a.back() / b.back() : 0);
  }
  return {median(a), median(b), median(ratios)};
}

}  // namespace duolod::bench
