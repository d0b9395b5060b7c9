// Marking renderer requests for the slow-request reports (render.hpp, SlowRequest). Internal:
// the renderer's passes mark their requests; tests drive the reports with a time of their own.
#pragma once

#include <chrono>

namespace duolod::render::internal {

// Marks a renderer request, from construction to destruction, for the slow-request reports
// (setSlowRequestSink; slow_requests.cpp). `format` describes it (printf-style), formatted only
// while a sink is set. Takes no allocation.
class SlowRequestWatch {
 public:
  SlowRequestWatch(bool first_draw, const char* format, ...) __attribute__((format(printf, 3, 4)));
  ~SlowRequestWatch();
  SlowRequestWatch(const SlowRequestWatch&) = delete;
  SlowRequestWatch& operator=(const SlowRequestWatch&) = delete;

 private:
  int slot_ = -1;
};
// "s" unless n is 1, for the requests' descriptions ("1 image", "100 images").
inline const char* pluralS(long n) {
  return n == 1 ? "" : "s";
}

// Reports the marked requests due at `now` to the sink (the monitor thread calls it four times a
// second; tests call it with a time of their choosing).
void reportSlowRequests(std::chrono::steady_clock::time_point now);

}  // namespace duolod::render::internal
