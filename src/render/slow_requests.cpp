// Reports of renderer requests that keep the device busy for long (render.hpp, SlowRequest).
//
// Why a table of fixed slots: a request is marked on every render call, on the main thread and on
// worker threads with renderers of their own (compile-ahead), which must not allocate where a
// failed allocation would end more than that worker. Marking takes a lock and copies at most
// kWhatSize characters; with no sink set it is one atomic load.
#include "render/slow_requests.hpp"

#include <algorithm>
#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <mutex>
#include <thread>
#include <vector>

#include "duolod/render.hpp"

namespace duolod::render {
namespace {

constexpr size_t kSlots = 32;  // more concurrent requests than any run makes; extra ones unmarked
constexpr size_t kWhatSize = 192;

struct Slot {
  bool used = false;
  bool first_draw = false;
  int reports = 0;  // made so far
  std::chrono::steady_clock::time_point start;
  char what[kWhatSize] = {};
};

struct Monitor {
  std::atomic<bool> enabled{false};
  // Held while the sink runs, and to replace it: once setSlowRequestSink returns, the old sink
  // is not running and never will again (a test's sink refers to its locals). Taken before
  // `mutex`.
  std::mutex calling;
  std::mutex mutex;  // guards everything below
  double first_after_seconds = 30;
  std::function<void(const SlowRequest&)> sink;
  Slot slots[kSlots];
  bool thread_started = false;
};

// Never destroyed: the monitor thread and late requests may outlive static destruction.
Monitor& monitor() {
  static Monitor* const instance = new Monitor;
  return *instance;
}

}  // namespace

void setSlowRequestSink(double first_after_seconds, std::function<void(const SlowRequest&)> sink) {
  Monitor& m = monitor();
  std::lock_guard calling(m.calling);
  std::lock_guard lock(m.mutex);
  m.first_after_seconds = first_after_seconds > 0 ? first_after_seconds : 30;
  m.sink = std::move(sink);
  m.enabled = static_cast<bool>(m.sink);
  if (m.enabled && !m.thread_started) {
    m.thread_started = true;
    // Polls four times a second: a report a quarter of a second late is as useful.
    std::thread([] {
      for (;;) {
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
        internal::reportSlowRequests(std::chrono::steady_clock::now());
      }
    }).detach();
  }
}

namespace internal {

SlowRequestWatch::SlowRequestWatch(bool first_draw, const char* format, ...) {
  Monitor& m = monitor();
  if (!m.enabled.load(std::memory_order_relaxed)) return;
  std::lock_guard lock(m.mutex);
  for (size_t i = 0; i < kSlots; ++i) {
    Slot& slot = m.slots[i];
    if (slot.used) continue;
    slot.used = true;
    slot.first_draw = first_draw;
    slot.reports = 0;
    slot.start = std::chrono::steady_clock::now();
    va_list arguments;
    va_start(arguments, format);
    std::vsnprintf(slot.what, kWhatSize, format, arguments);
    va_end(arguments);
    slot_ = static_cast<int>(i);
    return;
  }
}

SlowRequestWatch::~SlowRequestWatch() {
  if (slot_ < 0) return;
  Monitor& m = monitor();
  std::lock_guard lock(m.mutex);
  m.slots[slot_].used = false;
}

void reportSlowRequests(std::chrono::steady_clock::time_point now) {
  Monitor& m = monitor();
  if (!m.enabled.load(std::memory_order_relaxed)) return;
  std::lock_guard calling(m.calling);
  std::vector<SlowRequest> due;
  std::function<void(const SlowRequest&)> sink;
  {
    std::lock_guard lock(m.mutex);
    if (!m.sink) return;  // turned off since the check above
    for (Slot& slot : m.slots) {
      if (!slot.used) continue;
      const double seconds = std::chrono::duration<double>(now - slot.start).count();
      // Report k is due at first_after × 2^k: a note, then fewer as the wait grows.
      const double due_at = m.first_after_seconds * double(1ull << std::min(slot.reports, 40));
      if (seconds < due_at) continue;
      due.push_back(SlowRequest{slot.what, seconds, slot.first_draw, slot.reports});
      ++slot.reports;
    }
    if (!due.empty()) sink = m.sink;
  }
  // Outside `mutex`: the sink may take its time, and requests may be marked meanwhile.
  for (const SlowRequest& request : due) sink(request);
}

}  // namespace internal
}  // namespace duolod::render
