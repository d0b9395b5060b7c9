// A helper thread on the machine's second core that stays for the life of the process, for work
// split in parts within one call, many times a call (the position-only fast path's passes: a
// thread started per pass cost more than the pass's half saved, bench/RESULTS.md, issue 3,
// session 12). It spins while jobs come, so that a part handed over is taken within a fraction
// of a microsecond, and sleeps on a futex (std::atomic::wait) once none has come for a while.
// The parts are claimed one by one by both threads, so a helper that wakes late (or a machine
// with one core, or a helper held by another call) only means that the calling thread runs more
// of them: the results never depend on who ran which part.
#pragma once

#include <atomic>
#include <cfenv>
#include <chrono>
#include <cstdint>
#include <thread>
#include <type_traits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__linux__)
#include <sched.h>
#endif

namespace duolod::mesh {

namespace second_core_detail {

// The calling thread's floating-point control (rounding, flush-to-zero): the helper runs a job's
// parts under its caller's, so that a part gives the same bits on either thread.
inline uint32_t floatControl() {
#if defined(__SSE2__)
  return _mm_getcsr();
#else
  return uint32_t(std::fegetround());
#endif
}
inline void setFloatControl(uint32_t control) {
#if defined(__SSE2__)
  _mm_setcsr(control);
#else
  std::fesetround(int(control));
#endif
}

// CPUs this process may run on (its affinity mask and cgroup pinning, not the machine's count).
inline unsigned usableCpus() {
#if defined(__linux__)
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) == 0) return unsigned(CPU_COUNT(&set));
#endif
  return std::thread::hardware_concurrency();
}

inline void relax() {
#if defined(__SSE2__)
  _mm_pause();
#else
  std::this_thread::yield();
#endif
}

// One job at a time: `claim` packs the job's generation (high half) and its next part (low
// half), so that a part is only ever claimed for the job whose fields were read (a stale
// claim fails its compare-exchange, or finds the part count reached).
struct Helper {
  static constexpr uint32_t kClosed = ~0u;
  static constexpr std::chrono::microseconds kSpinTime{200};
  std::atomic<uint32_t> held{0};  // a SecondCore holds the helper
  std::atomic<uint32_t> sleeping{0};
  std::atomic<uint32_t> wake{0};  // the futex word the helper sleeps on
  // The job's fields, then (on lines of their own: the caller spins on `done` while the helper
  // claims) the claim and the count of parts the helper ran.
  std::atomic<void (*)(void*, uint32_t)> call{nullptr};
  std::atomic<void*> context{nullptr};
  std::atomic<uint32_t> count{0};
  std::atomic<uint32_t> float_control{0};
  // Spin for the next job after this one (kSpinTime), or sleep at once: a caller whose next job
  // comes after a long serial stretch, or whose serial work runs on other threads that need the
  // core (llvmpipe's rasterizer, beside the image-driven mode's tile builds), asks it to sleep.
  std::atomic<bool> linger{true};
  alignas(64) std::atomic<uint64_t> claim{0};
  alignas(64) std::atomic<uint32_t> done{0};
  // The caller waits on `done` (it ran out of parts while the helper still runs one): the
  // helper wakes it after counting its parts.
  std::atomic<uint32_t> caller_waiting{0};

  // Runs parts of the job that `claim` now holds until none is left; the number run. A job is
  // opened in two steps (SecondCore::run): `claim` is first closed under a new generation, then
  // the fields are written (release), then the claim opens under the generation after it. A
  // claim succeeds only on the generation that was open when the fields were read, so the fields
  // are that job's: had they been newer, the closing store would have come first (acquire) and
  // the compare-exchange would fail.
  uint32_t work() {
    uint64_t c = claim.load(std::memory_order_acquire);
    if (uint32_t(c) == kClosed) return 0;
    const uint64_t generation = c >> 32;
    void (*const f)(void*, uint32_t) = call.load(std::memory_order_acquire);
    void* const data = context.load(std::memory_order_acquire);
    const uint32_t parts = count.load(std::memory_order_acquire);
    const uint32_t control = float_control.load(std::memory_order_acquire);
    const uint32_t own_control = floatControl();
    uint32_t ran = 0;
    while ((c >> 32) == generation && uint32_t(c) < parts) {
      if (claim.compare_exchange_weak(c, c + 1, std::memory_order_acq_rel,
                                      std::memory_order_acquire)) {
        if (control != own_control) setFloatControl(control);
        f(data, uint32_t(c));
        if (control != own_control) setFloatControl(own_control);
        ++ran;
        c = claim.load(std::memory_order_acquire);
      }
    }
    return ran;
  }

  // Spins while jobs come (each pass of a simplification hands one over), and sleeps on `wake`
  // once none has come for kSpinTime: it does not hold a core between calls, nor through a
  // long serial stretch of one. Whoever opens a job wakes it if it sleeps (SecondCore::run);
  // the sleeping flag and the claim are both written then read in sequentially consistent order
  // on either side, so one of the two always sees the other.
  void loop() {
    // From the claim's first generation, not the one found when this thread starts: a job
    // opened before that (the first call of a process, when the thread is slow to start) is
    // still taken (read as already seen, its caller ran every part alone; found by review,
    // bench/RESULTS.md, session 46).
    uint64_t seen = 0;
    for (;;) {
      auto last_job = std::chrono::steady_clock::now();
      for (uint32_t spins = 1;; ++spins) {
        const uint64_t generation = claim.load(std::memory_order_acquire) >> 32;
        if (generation != seen) {
          seen = generation;
          if (const uint32_t ran = work()) {
            done.fetch_add(ran, std::memory_order_seq_cst);
            if (caller_waiting.load(std::memory_order_seq_cst)) done.notify_one();
          }
          // The job's own wish: the flag read first, then the claim found still open under the
          // job's generation. A newer job stores its flag after closing the claim, so had the
          // flag been the newer job's, the claim would be seen closed or newer.
          const bool stay = linger.load(std::memory_order_acquire);
          const uint64_t c = claim.load(std::memory_order_acquire);
          if ((c >> 32) == generation && uint32_t(c) != kClosed && !stay) break;
          last_job = std::chrono::steady_clock::now();
          continue;
        }
        relax();
        if (spins % 64 == 0 && std::chrono::steady_clock::now() - last_job > kSpinTime) break;
      }
      const uint32_t ticket = wake.load(std::memory_order_seq_cst);
      sleeping.store(1, std::memory_order_seq_cst);
      if ((claim.load(std::memory_order_seq_cst) >> 32) == seen) wake.wait(ticket);
      sleeping.store(0, std::memory_order_relaxed);
    }
  }
};

// The process's helper, started on first use; nullptr on a machine with one core or when no
// thread can be had. Never destroyed: it sleeps between calls and ends with the process.
inline Helper* helper() {
  static Helper* const instance = []() -> Helper* {
    if (usableCpus() < 2) return nullptr;
    Helper* h = new Helper;
    try {
      std::thread([h] { h->loop(); }).detach();
    } catch (...) {
      delete h;
      return nullptr;
    }
    return h;
  }();
  return instance;
}

}  // namespace second_core_detail

// Holds the helper for the lifetime of the object (one call's work), or nothing when another
// holds it, the machine has one core or the work is too small to be worth it (`wanted`).
class SecondCore {
 public:
  // `linger`: the helper spins for the next job after each one (for jobs that come one after
  // another, as a simplification's passes), or sleeps at once.
  explicit SecondCore(bool wanted = true, bool linger = true) : linger_(linger) {
    if (!wanted) return;
    second_core_detail::Helper* h = second_core_detail::helper();
    uint32_t free = 0;
    if (h && h->held.compare_exchange_strong(free, 1, std::memory_order_acquire)) {
      helper_ = h;
    }
  }
  ~SecondCore() {
    if (!helper_) return;
    helper_->held.store(0, std::memory_order_release);
  }
  SecondCore(const SecondCore&) = delete;
  SecondCore& operator=(const SecondCore&) = delete;

  bool available() const { return helper_ != nullptr; }

  // Calls part(i) for every i in [0, parts), here and on the helper, and returns when all have
  // run. `part` must not throw (a throw ends the process), and the parts must not depend on each
  // other's order. A forEach inside a part runs its parts on that part's thread.
  template <class Part>
  void forEach(uint32_t parts, Part&& part) {
    if (!helper_ || parts < 2 || in_job_) {
      for (uint32_t i = 0; i < parts; ++i) part(i);
      return;
    }
    using P = std::remove_reference_t<Part>;
    in_job_ = true;
    run(
        parts, [](void* data, uint32_t i) noexcept { (*static_cast<P*>(data))(i); }, &part);
    in_job_ = false;
  }

 private:
  void run(uint32_t parts, void (*call)(void*, uint32_t), void* context) {
    second_core_detail::Helper& h = *helper_;
    // Closed first (see Helper::work), then the fields, then open.
    const uint64_t generation = (h.claim.load(std::memory_order_relaxed) >> 32) + 1;
    h.claim.store(generation << 32 | second_core_detail::Helper::kClosed,
                  std::memory_order_relaxed);
    h.done.store(0, std::memory_order_relaxed);
    h.call.store(call, std::memory_order_release);
    h.context.store(context, std::memory_order_release);
    h.count.store(parts, std::memory_order_release);
    h.float_control.store(second_core_detail::floatControl(), std::memory_order_release);
    h.linger.store(linger_, std::memory_order_release);
    h.claim.store((generation + 1) << 32, std::memory_order_seq_cst);
    if (h.sleeping.load(std::memory_order_seq_cst) != 0) {
      h.wake.fetch_add(1, std::memory_order_relaxed);
      h.wake.notify_one();
    }
    const uint32_t finished = h.work();
    // The helper runs its last parts: spin a little, then either give the CPU up in turns (a
    // lingering holder's jobs come one after another, each part microseconds: the first moment
    // counts), or sleep until the helper has counted them (runBoth's halves can take many
    // milliseconds: spinning, the caller took a core from llvmpipe's threads for as long; found
    // by review, session 46). The flag and `done` are written then read in sequentially
    // consistent order on both sides, so either the helper sees the flag or the caller sees the
    // count.
    for (uint32_t spins = 0; finished + h.done.load(std::memory_order_acquire) < parts; ++spins) {
      if (spins < 4096) {
        second_core_detail::relax();
        continue;
      }
      if (linger_) {
        std::this_thread::yield();
        continue;
      }
      h.caller_waiting.store(1, std::memory_order_seq_cst);
      const uint32_t counted = h.done.load(std::memory_order_seq_cst);
      if (finished + counted < parts) h.done.wait(counted, std::memory_order_seq_cst);
      h.caller_waiting.store(0, std::memory_order_relaxed);
    }
  }

  second_core_detail::Helper* helper_ = nullptr;
  bool linger_ = true;
  std::atomic<bool> in_job_{false};  // a job of this holder is open (read from its parts)
};

}  // namespace duolod::mesh
