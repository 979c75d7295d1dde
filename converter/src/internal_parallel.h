// Minimal fork-join over contiguous index slices (private to rgs_converter).
//
// Results computed with it must not depend on the number of workers: callers either write disjoint
// outputs per index or combine per-slice partial results with order-independent operations (integer
// sums, max) or in slice order.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <mutex>
#include <new>
#include <system_error>
#include <thread>
#include <vector>

#include "rgs/format/status.h"

#if defined(__linux__)
#include <sched.h>
#endif

namespace rgs::converter::detail {

/// CPUs this process may run on: the affinity mask on Linux (so `taskset` and cgroup cpusets are
/// honoured), else std::thread::hardware_concurrency(); at least 1.
inline unsigned available_cpus() {
#if defined(__linux__)
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return static_cast<unsigned>(n);
  }
#endif
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : hw;
}

/// Most workers worker_count() ever returns.
inline constexpr unsigned kMaxWorkers = 16;

/// Worker count for `items` units of similar cost: items / min_per_worker, at least 1 and at most
/// available_cpus() (capped at kMaxWorkers).
inline unsigned worker_count(uint64_t items, uint64_t min_per_worker) {
  unsigned hw = available_cpus();
  hw = std::min(hw, kMaxWorkers);
  const uint64_t by_size = min_per_worker == 0 ? hw : items / min_per_worker;
  return static_cast<unsigned>(std::max<uint64_t>(1, std::min<uint64_t>(hw, by_size)));
}

/// What went wrong in the workers of one parallel call: an allocation failure (reported as kOutOfMemory)
/// or another exception (a programmer error, rethrown on the calling thread after the join).
class WorkerFailures {
 public:
  /// Runs `call`, recording instead of propagating what it throws (an exception leaving a std::thread
  /// would abort the process).
  template <typename Call>
  void run(Call&& call) noexcept {
    try {
      call();
    } catch (const std::bad_alloc&) {
      out_of_memory_.store(true);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (!other_) other_ = std::current_exception();
    }
  }
  /// After the join: rethrows another exception, or gives kOutOfMemory, or ok.
  Status result() {
    if (other_) std::rethrow_exception(other_);
    if (out_of_memory_.load()) return Status(StatusCode::kOutOfMemory, "out of memory in a worker thread");
    return Status();
  }

 private:
  std::atomic<bool> out_of_memory_{false};
  std::mutex mutex_;
  std::exception_ptr other_;
};

/// Calls fn(slice, begin, end) for `workers` contiguous slices of [0, n): slice t is
/// [n·t/workers, n·(t+1)/workers). Slice 0 runs on the calling thread; a slice whose thread cannot be
/// started runs inline, so this never fails for lack of threads. An allocation failure inside `fn`, on
/// any thread, gives kOutOfMemory once every slice has returned; `fn` must throw nothing else (anything
/// else is rethrown on the calling thread after the join).
template <typename Fn>
[[nodiscard]] Status parallel_slices(uint64_t n, unsigned workers, Fn&& fn) {
  WorkerFailures failures;
  if (workers <= 1 || n < 2) {
    failures.run([&] { fn(0u, uint64_t{0}, n); });
    return failures.result();
  }
  auto bound = [n, workers](unsigned t) {
    return (n / workers) * t + (n % workers) * t / workers;  // floor(n·t / workers) without overflow
  };
  std::vector<std::thread> threads;
  std::vector<unsigned> inline_slices;
  try {
    threads.reserve(workers - 1);
    inline_slices.reserve(workers - 1);
  } catch (const std::bad_alloc&) {
    failures.run([&] {
      for (unsigned t = 0; t < workers; ++t) fn(t, bound(t), bound(t + 1));
    });
    return failures.result();
  }
  for (unsigned t = 1; t < workers; ++t) {
    try {
      threads.emplace_back([&fn, &failures, t, b = bound(t), e = bound(t + 1)] {
        failures.run([&] { fn(t, b, e); });
      });
    } catch (const std::system_error&) {
      inline_slices.push_back(t);  // capacity reserved above: does not allocate
    } catch (const std::bad_alloc&) {
      inline_slices.push_back(t);
    }
  }
  failures.run([&] { fn(0u, bound(0), bound(1)); });
  for (unsigned t : inline_slices) failures.run([&] { fn(t, bound(t), bound(t + 1)); });
  for (std::thread& th : threads) th.join();
  return failures.result();
}

/// Calls fn(worker, item) once for every item of [0, items), `workers` threads taking the next unclaimed
/// item in turn (balances items of uneven cost). Which worker runs an item varies between runs, so results
/// must be stored per item, not per worker. Threads that cannot be started leave their share to the others.
/// After an allocation failure no further item is started, and the call gives kOutOfMemory; `fn` must
/// throw nothing else.
template <typename Fn>
[[nodiscard]] Status parallel_items(uint64_t items, unsigned workers, Fn&& fn) {
  std::atomic<uint64_t> next{0};
  std::atomic<bool> stop{false};
  return parallel_slices(workers, workers, [&](unsigned t, uint64_t, uint64_t) {
    try {
      for (uint64_t item = next.fetch_add(1); item < items && !stop.load(std::memory_order_relaxed);
           item = next.fetch_add(1)) {
        fn(t, item);
      }
    } catch (...) {
      stop.store(true);
      throw;  // recorded by parallel_slices
    }
  });
}

}  // namespace rgs::converter::detail
