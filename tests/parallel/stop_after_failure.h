// The property both CPU pools share (fork_join.h's parallel_items, worker_pool.h's WorkerPool::run): an
// allocation failure in an item is kOutOfMemory, and no item starts after it.
#pragma once

#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <new>
#include <string>
#include <thread>

#include "rgs/format/status.h"

namespace rgs::test {

/// run(items, fn) runs fn(worker, item) for items [0, items) on `workers` workers and returns their Status.
/// Item 5 throws std::bad_alloc. Items after it wait until it throws, then take 100 us each: a pool that stops
/// claiming items after a failure runs a handful more, one that does not runs all 99,994. The wait keeps the
/// count independent of scheduling (the thread holding item 5 may be preempted for as long as the others like).
template <typename Run>
void check_stops_after_failure(unsigned workers, Run run) {
  constexpr uint64_t kItems = 100000;
  std::atomic<uint64_t> ran{0};
  std::atomic<bool> thrown{false};
  const Status s = run(kItems, [&](unsigned, uint64_t i) {
    if (i == 5) {
      thrown.store(true);
      throw std::bad_alloc();
    }
    if (i > 5) {
      while (!thrown.load()) std::this_thread::yield();
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    ++ran;
  });
  CHECK(s.code() == StatusCode::kOutOfMemory);
  CHECK(s.message().find("out of memory in a worker thread (100000 items)") != std::string::npos);
  if (workers == 1) CHECK(ran.load() == 5);
  CHECK(ran.load() < 1000);
}

}  // namespace rgs::test
