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
#include <system_error>
#include <thread>
#include <vector>

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

/// Worker count for `items` units of similar cost: items / min_per_worker, at least 1 and at most
/// available_cpus() (capped at 16).
inline unsigned worker_count(uint64_t items, uint64_t min_per_worker) {
  unsigned hw = available_cpus();
  hw = std::min(hw, 16u);
  const uint64_t by_size = min_per_worker == 0 ? hw : items / min_per_worker;
  return static_cast<unsigned>(std::max<uint64_t>(1, std::min<uint64_t>(hw, by_size)));
}

/// Calls fn(slice, begin, end) for `workers` contiguous slices of [0, n): slice t is
/// [n·t/workers, n·(t+1)/workers). Slice 0 runs on the calling thread; a slice whose thread cannot be
/// started runs inline, so this never throws for lack of threads. `fn` must not throw.
template <typename Fn>
void parallel_slices(uint64_t n, unsigned workers, Fn&& fn) {
  if (workers <= 1 || n < 2) {
    fn(0u, uint64_t{0}, n);
    return;
  }
  auto bound = [n, workers](unsigned t) {
    return (n / workers) * t + (n % workers) * t / workers;  // floor(n·t / workers) without overflow
  };
  std::vector<std::thread> threads;
  std::vector<unsigned> inline_slices;
  threads.reserve(workers - 1);
  for (unsigned t = 1; t < workers; ++t) {
    try {
      threads.emplace_back([&fn, t, b = bound(t), e = bound(t + 1)] { fn(t, b, e); });
    } catch (const std::system_error&) {
      inline_slices.push_back(t);
    }
  }
  fn(0u, bound(0), bound(1));
  for (unsigned t : inline_slices) fn(t, bound(t), bound(t + 1));
  for (std::thread& th : threads) th.join();
}

/// Calls fn(worker, item) once for every item of [0, items), `workers` threads taking the next unclaimed
/// item in turn (balances items of uneven cost). Which worker runs an item varies between runs, so results
/// must be stored per item, not per worker. Threads that cannot be started leave their share to the others;
/// `fn` must not throw.
template <typename Fn>
void parallel_items(uint64_t items, unsigned workers, Fn&& fn) {
  std::atomic<uint64_t> next{0};
  parallel_slices(workers, workers, [&](unsigned t, uint64_t, uint64_t) {
    for (uint64_t item = next.fetch_add(1); item < items; item = next.fetch_add(1)) fn(t, item);
  });
}

}  // namespace rgs::converter::detail
