// Two independent pieces of work on the two cores of the machine (the image-driven mode's tile
// builds, the two sides of surfaceDistance).
#pragma once

#include <exception>
#include <system_error>
#include <thread>

namespace duolod::mesh {

// Runs `first` here and `second` beside it on another thread when the machine has a second core
// and a thread can be had, else one after the other; the two share only what they read, so the
// results do not depend on which. An exception from either is rethrown here, after both ended.
template <class First, class Second>
void runBoth(First&& first, Second&& second) {
  static const bool two_cores = std::thread::hardware_concurrency() >= 2;
  std::exception_ptr thrown;
  std::thread other;
  if (two_cores) {
    try {
      other = std::thread([&] {
        try {
          second();
        } catch (...) {
          thrown = std::current_exception();
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
  if (thrown) std::rethrow_exception(thrown);
}

}  // namespace duolod::mesh
