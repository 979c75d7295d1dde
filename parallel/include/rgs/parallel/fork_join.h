// The one fork-join of the RoofGS CPU code (converter and runtime; private to the libraries, never installed:
// parallel/CMakeLists.txt explains the layering).
//
// - Thread counts follow the CPUs this process may run on (available_cpus: the affinity mask on Linux, so
//   `taskset` and cgroup cpusets are honoured), never the machine's total.
// - Threads are started per call and joined before it returns: no global pool, no state between calls, so
//   the libraries stay reentrant and nothing runs after a call returns.
// - The calling thread works too. A thread that cannot be started leaves its share to the others, so a call
//   never fails for lack of threads.
// - An allocation failure (std::bad_alloc) in `fn`, on any thread, stops the work that has not started and
//   gives kOutOfMemory once every thread has returned; an exception escaping a std::thread would abort the
//   process. `fn` must throw nothing else: anything else is rethrown on the calling thread after the join
//   (a programmer error).
//
// Results must not depend on the number of threads: callers write disjoint outputs per index, or combine
// per-slice results with order-independent operations (integer sums, max) or in slice order.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "rgs/format/status.h"

#if defined(__linux__)
#include <sched.h>
#endif

namespace rgs::parallel {

/// CPUs this process may run on: the affinity mask on Linux, else std::thread::hardware_concurrency();
/// at least 1.
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

/// Thread count for a caller's request: `requested`, or available_cpus() when 0; at least 1.
inline unsigned thread_count(unsigned requested) { return requested != 0 ? requested : available_cpus(); }

/// Thread count for `items` units of similar cost: items / min_per_worker (every CPU when min_per_worker is
/// 0), at least 1, at most available_cpus() and `max_workers`.
inline unsigned worker_count(uint64_t items, uint64_t min_per_worker, unsigned max_workers) {
  const unsigned cpus = std::min(available_cpus(), std::max(1u, max_workers));
  const uint64_t by_size = min_per_worker == 0 ? cpus : items / min_per_worker;
  return static_cast<unsigned>(std::max<uint64_t>(1, std::min<uint64_t>(cpus, by_size)));
}

/// What went wrong in the threads of one call: an allocation failure (kOutOfMemory) or another exception.
class WorkerFailures {
 public:
  /// Runs `call`, recording instead of propagating what it throws.
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
  /// After the join: rethrows another exception, or gives kOutOfMemory naming `what`, or ok.
  Status result(const std::string& what) {
    if (other_) std::rethrow_exception(other_);
    if (out_of_memory_.load())
      return Status(StatusCode::kOutOfMemory, "out of memory in a worker thread (" + what + ")");
    return Status();
  }

 private:
  std::atomic<bool> out_of_memory_{false};
  std::mutex mutex_;
  std::exception_ptr other_;
};

/// Calls fn(slice, begin, end) for `workers` contiguous slices of [0, n): slice t is
/// [n·t/workers, n·(t+1)/workers). Slice 0 runs on the calling thread; a slice whose thread cannot be
/// started runs there too, after it. Errors as the file comment says.
template <typename Fn>
[[nodiscard]] Status parallel_slices(uint64_t n, unsigned workers, Fn&& fn) {
  WorkerFailures failures;
  const std::string what = std::to_string(n) + " items";
  if (n < 2 || workers == 0) workers = 1;
  auto bound = [n, workers](unsigned t) {
    return (n / workers) * t + (n % workers) * t / workers;  // floor(n·t / workers) without overflow
  };
  auto slice = [&](unsigned t) { failures.run([&] { fn(t, bound(t), bound(t + 1)); }); };
  std::vector<std::thread> threads;
  unsigned started = 1;  // slices [1, started) run on their own threads, the others here after slice 0
  try {
    threads.reserve(workers - 1);
    for (; started < workers; ++started) threads.emplace_back(slice, started);
  } catch (const std::system_error&) {
  } catch (const std::bad_alloc&) {
  }
  slice(0);
  for (unsigned t = started; t < workers; ++t) slice(t);
  for (std::thread& th : threads) th.join();
  return failures.result(what);
}

/// The loop of one worker of parallel_items (and WorkerPool::run): fn(worker, item) for each item it claims
/// from `next`, in increasing order, until none is left. What fn throws stops further items and propagates.
template <typename Fn>
void claim_items(std::atomic<uint64_t>& next, uint64_t items, unsigned worker, Fn& fn) {
  try {
    for (uint64_t item; (item = next.fetch_add(1, std::memory_order_relaxed)) < items;) fn(worker, item);
  } catch (...) {
    next.store(items);  // no further item starts
    throw;              // recorded by the caller's WorkerFailures
  }
}

/// Calls fn(worker, item) once for every item of [0, items) on up to `workers` threads (never more than
/// items), each taking the next unclaimed item in increasing order: balances items of uneven cost. Which
/// worker runs an item varies between runs, so results must be stored per item, not per worker. After a
/// failure no further item is started.
template <typename Fn>
[[nodiscard]] Status parallel_items(uint64_t items, unsigned workers, Fn&& fn) {
  workers = static_cast<unsigned>(std::max<uint64_t>(1, std::min<uint64_t>(workers, items)));
  std::atomic<uint64_t> next{0};
  Status s = parallel_slices(workers, workers, [&](unsigned t, uint64_t, uint64_t) { claim_items(next, items, t, fn); });
  if (s.code() == StatusCode::kOutOfMemory) {
    return Status(StatusCode::kOutOfMemory, "out of memory in a worker thread (" + std::to_string(items) + " items)");
  }
  return s;
}

/// fn(i) for every i in [0, n), as parallel_items.
template <typename Fn>
[[nodiscard]] Status parallel_for(uint64_t n, unsigned threads, Fn&& fn) {
  return parallel_items(n, threads, [&](unsigned, uint64_t i) { fn(i); });
}

/// fn(begin, end) for consecutive chunks of [0, n) of `chunk` items (the last may be shorter), as
/// parallel_items.
template <typename Fn>
[[nodiscard]] Status parallel_chunks(uint64_t n, uint64_t chunk, unsigned threads, Fn&& fn) {
  const uint64_t chunks = (n + chunk - 1) / chunk;
  return parallel_items(chunks, threads, [&](unsigned, uint64_t c) { fn(c * chunk, std::min(n, (c + 1) * chunk)); });
}

}  // namespace rgs::parallel
