// Minimal fork-join used by the CPU renderer (private to rgs_runtime).
//
// Work items must write disjoint outputs (or results combined in a fixed order by the caller), so results
// never depend on the number of threads or on scheduling.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <system_error>
#include <thread>
#include <vector>

namespace rgs::runtime::detail {

/// Thread count for a request: `requested`, or hardware_concurrency() when 0; at least 1.
inline unsigned resolve_thread_count(unsigned requested) {
  unsigned n = requested != 0 ? requested : std::thread::hardware_concurrency();
  return std::max(1u, n);
}

/// Calls fn(i) for every i in [0, n), on up to `threads` threads that take items dynamically (one at a time,
/// in increasing order). The calling thread works too; if a thread cannot be started, the others do its
/// share. `fn` must not throw.
template <typename Fn>
void parallel_for(uint64_t n, unsigned threads, Fn&& fn) {
  threads = static_cast<unsigned>(std::min<uint64_t>(threads, n));
  if (threads <= 1) {
    for (uint64_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<uint64_t> next{0};
  auto worker = [&] {
    for (uint64_t i = next.fetch_add(1, std::memory_order_relaxed); i < n;
         i = next.fetch_add(1, std::memory_order_relaxed)) {
      fn(i);
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (unsigned t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error&) {
      break;  // fewer threads; the rest still covers every item
    }
  }
  worker();
  for (std::thread& th : pool) th.join();
}

/// Calls fn(begin, end) for consecutive chunks of [0, n) of size `chunk` (the last may be shorter), spread
/// over `threads` threads as parallel_for does.
template <typename Fn>
void parallel_chunks(uint64_t n, uint64_t chunk, unsigned threads, Fn&& fn) {
  const uint64_t chunks = (n + chunk - 1) / chunk;
  parallel_for(chunks, threads, [&](uint64_t c) { fn(c * chunk, std::min(n, (c + 1) * chunk)); });
}

}  // namespace rgs::runtime::detail
