// rgs/parallel/worker_pool.h: threads kept between calls, with parallel_items' contract on every call.
#include <doctest/doctest.h>

#include <atomic>
#include <cstdint>
#include <new>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "rgs/parallel/worker_pool.h"
#include "stop_after_failure.h"

namespace {

using namespace rgs;

TEST_CASE("WorkerPool: every item once on every call, on at most the workers asked for") {
  for (unsigned workers : {1u, 2u, 5u, 16u}) {
    CAPTURE(workers);
    parallel::WorkerPool pool(workers);
    CHECK(pool.workers() == workers);
    // Many calls in a row, of varying sizes and widths: the threads serve each call once, whichever they
    // slept through.
    for (int call = 0; call < 300; ++call) {
      const uint64_t items = static_cast<uint64_t>(call * 37 % 101);
      const unsigned max_workers = 1 + static_cast<unsigned>(call % 17);
      CAPTURE(call);
      std::vector<std::atomic<int>> seen(items);
      std::vector<std::atomic<int>> by_worker(workers);
      REQUIRE(pool.run(items, max_workers, [&](unsigned w, uint64_t i) {
                ++seen[i];
                ++by_worker[w];
              }).ok());
      for (uint64_t i = 0; i < items; ++i) CHECK(seen[i].load() == 1);
      unsigned used = 0;
      for (auto& n : by_worker) used += n.load() > 0;
      CHECK(used <= std::min<uint64_t>(max_workers, std::max<uint64_t>(1, items)));
    }
  }
}

TEST_CASE("WorkerPool: the caller works too, and the other workers are threads of the pool") {
  parallel::WorkerPool pool(4);
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<std::thread::id> ids(4);
  std::atomic<int> arrived{0};
  // Four items that each wait for the four: every worker holds one, so all four take part.
  REQUIRE(pool.run(4, 4, [&](unsigned w, uint64_t) {
            ids[w] = std::this_thread::get_id();
            ++arrived;
            while (arrived.load() < 4) std::this_thread::yield();
          }).ok());
  CHECK((ids[0] == caller));
  CHECK(std::set<std::thread::id>(ids.begin(), ids.end()).size() == 4);
}

TEST_CASE("WorkerPool: an allocation failure is kOutOfMemory and stops the call, and the pool serves the next call") {
  for (unsigned workers : {1u, 2u, 8u}) {
    CAPTURE(workers);
    parallel::WorkerPool pool(workers);
    for (int round = 0; round < 3; ++round) {
      test::check_stops_after_failure(workers, [&](uint64_t items, auto fn) { return pool.run(items, workers, fn); });
      CHECK_THROWS_AS(static_cast<void>(pool.run(10, workers, [](unsigned, uint64_t i) {
                        if (i == 3) throw std::logic_error("bug");
                      })),
                      std::logic_error);
      std::atomic<uint64_t> sum{0};
      REQUIRE(pool.run(1000, workers, [&](unsigned, uint64_t i) { sum += i; }).ok());
      CHECK(sum.load() == 999 * 1000 / 2);
    }
  }
}

}  // namespace
