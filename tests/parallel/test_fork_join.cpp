// rgs/parallel/fork_join.h: the one CPU pool of the converter and the runtime.
#include <doctest/doctest.h>

#include <atomic>
#include <cstdint>
#include <new>
#include <stdexcept>
#include <vector>

#include "rgs/parallel/fork_join.h"
#include "stop_after_failure.h"

#if defined(__linux__)
#include <sched.h>
#endif

namespace {

using namespace rgs;

TEST_CASE("parallel_slices, parallel_items, parallel_for and parallel_chunks visit every index once") {
  for (uint64_t n : {uint64_t{0}, uint64_t{1}, uint64_t{7}, uint64_t{1000}}) {
    for (unsigned workers : {1u, 2u, 3u, 16u}) {
      CAPTURE(n);
      CAPTURE(workers);
      std::vector<std::atomic<int>> seen(n);
      REQUIRE(parallel::parallel_slices(n, workers, [&](unsigned, uint64_t b, uint64_t e) {
                for (uint64_t i = b; i < e; ++i) ++seen[i];
              }).ok());
      REQUIRE(parallel::parallel_items(n, workers, [&](unsigned w, uint64_t i) {
                CHECK(w < workers);
                ++seen[i];
              }).ok());
      REQUIRE(parallel::parallel_for(n, workers, [&](uint64_t i) { ++seen[i]; }).ok());
      REQUIRE(parallel::parallel_chunks(n, 3, workers, [&](uint64_t b, uint64_t e) {
                CHECK(e - b <= 3);
                for (uint64_t i = b; i < e; ++i) ++seen[i];
              }).ok());
      for (uint64_t i = 0; i < n; ++i) CHECK(seen[i].load() == 4);
    }
  }
}

TEST_CASE("parallel_slices: slice bounds depend only on n and the worker count") {
  std::vector<uint64_t> begins(5), ends(5);
  REQUIRE(parallel::parallel_slices(23, 5, [&](unsigned t, uint64_t b, uint64_t e) {
            begins[t] = b;
            ends[t] = e;
          }).ok());
  CHECK(begins == std::vector<uint64_t>{0, 4, 9, 13, 18});
  CHECK(ends == std::vector<uint64_t>{4, 9, 13, 18, 23});
}

TEST_CASE("an allocation failure in any thread is kOutOfMemory, other exceptions reach the caller") {
  for (unsigned workers : {1u, 2u, 8u}) {
    CAPTURE(workers);
    test::check_stops_after_failure(workers, [&](uint64_t items, auto fn) {
      return parallel::parallel_for(items, workers, [&](uint64_t i) { fn(0, i); });
    });
    // The last slice runs on a started thread whenever workers > 1.
    const Status s = parallel::parallel_slices(100, workers, [&](unsigned t, uint64_t, uint64_t) {
      if (t + 1 == workers) throw std::bad_alloc();
    });
    CHECK(s.code() == StatusCode::kOutOfMemory);
    CHECK_THROWS_AS(static_cast<void>(parallel::parallel_items(10, workers, [](unsigned, uint64_t i) {
                      if (i == 3) throw std::logic_error("bug");
                    })),
                    std::logic_error);
  }
}

TEST_CASE("thread counts follow the CPU affinity mask") {
  CHECK(parallel::available_cpus() >= 1);
  CHECK(parallel::thread_count(3) == 3);
  CHECK(parallel::thread_count(0) == parallel::available_cpus());
  CHECK(parallel::worker_count(0, 1000, 16) == 1);
  CHECK(parallel::worker_count(uint64_t{1} << 40, 1, 2) <= 2);
#if defined(__linux__)
  cpu_set_t saved;
  CPU_ZERO(&saved);
  REQUIRE(sched_getaffinity(0, sizeof(saved), &saved) == 0);
  int first = -1;
  for (int c = 0; c < CPU_SETSIZE && first < 0; ++c) {
    if (CPU_ISSET(c, &saved)) first = c;
  }
  REQUIRE(first >= 0);
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  REQUIRE(sched_setaffinity(0, sizeof(one), &one) == 0);  // this thread only, as `taskset -c N` would
  CHECK(parallel::available_cpus() == 1);
  CHECK(parallel::thread_count(0) == 1);
  CHECK(parallel::worker_count(uint64_t{1} << 40, 1, 16) == 1);
  REQUIRE(sched_setaffinity(0, sizeof(saved), &saved) == 0);
  CHECK(parallel::available_cpus() == static_cast<unsigned>(CPU_COUNT(&saved)));
#endif
}

}  // namespace
