// Minimal fork-join used by the CPU renderer (private to rgs_runtime).
//
// Work items must write disjoint outputs (or results combined in a fixed order by the caller), so results
// never depend on the number of threads or on scheduling.
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

namespace rgs::runtime::detail {

/// Thread count for a request: `requested`, or hardware_concurrency() when 0; at least 1.
inline unsigned resolve_thread_count(unsigned requested) {
  unsigned n = requested != 0 ? requested : std::thread::hardware_concurrency();
  return std::max(1u, n);
}

/// Calls fn(i) for every i in [0, n), on up to `threads` threads that take items dynamically (one at a time,
/// in increasing order). The calling thread works too; if a thread cannot be started, the others do its
/// share. An allocation failure inside `fn`, on any thread, stops the remaining items and gives
/// kOutOfMemory once every thread has stopped (an exception escaping a std::thread would abort the
/// process). `fn` must throw nothing else; anything else is rethrown on the calling thread after the join.
template <typename Fn>
[[nodiscard]] Status parallel_for(uint64_t n, unsigned threads, Fn&& fn) {
  threads = static_cast<unsigned>(std::min<uint64_t>(threads, n));
  std::atomic<uint64_t> next{0};
  std::atomic<bool> out_of_memory{false};
  std::exception_ptr other;
  std::mutex other_mutex;
  auto worker = [&]() noexcept {
    try {
      for (uint64_t i = next.fetch_add(1, std::memory_order_relaxed); i < n;
           i = next.fetch_add(1, std::memory_order_relaxed)) {
        fn(i);
      }
    } catch (const std::bad_alloc&) {
      out_of_memory.store(true);
      next.store(n);  // the other threads take no further item
    } catch (...) {
      const std::lock_guard<std::mutex> lock(other_mutex);
      if (!other) other = std::current_exception();
      next.store(n);
    }
  };
  std::vector<std::thread> pool;
  if (threads > 1) {
    try {
      pool.reserve(threads - 1);
    } catch (const std::bad_alloc&) {
      threads = 1;  // no room for the pool: the calling thread does everything
    }
  }
  for (unsigned t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error&) {
      break;  // fewer threads; the rest still covers every item
    } catch (const std::bad_alloc&) {
      break;
    }
  }
  worker();
  for (std::thread& th : pool) th.join();
  if (other) std::rethrow_exception(other);
  if (out_of_memory.load()) {
    return Status(StatusCode::kOutOfMemory, "out of memory in a worker thread (" + std::to_string(n) + " items)");
  }
  return Status();
}

/// Calls fn(begin, end) for consecutive chunks of [0, n) of size `chunk` (the last may be shorter), spread
/// over `threads` threads as parallel_for does, with its error behaviour.
template <typename Fn>
[[nodiscard]] Status parallel_chunks(uint64_t n, uint64_t chunk, unsigned threads, Fn&& fn) {
  const uint64_t chunks = (n + chunk - 1) / chunk;
  return parallel_for(chunks, threads, [&](uint64_t c) { fn(c * chunk, std::min(n, (c + 1) * chunk)); });
}

}  // namespace rgs::runtime::detail
