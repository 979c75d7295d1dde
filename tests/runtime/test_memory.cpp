// The CPU renderer's thread pool turns allocation failures on any thread into kOutOfMemory, and the
// .rgs loading path (RgsFile::read_scene) refuses values the renderers must never see.
#include <doctest/doctest.h>

#include <atomic>
#include <new>
#include <string>

#include "../../runtime/src/internal_parallel.h"
#include "bad_value_files.h"
#include "rgs/format/reader.h"
#include "test_data.h"

namespace rgs::test {

TEST_CASE("parallel_for: bad_alloc in a worker thread is kOutOfMemory, and the other threads stop") {
  for (unsigned threads : {1u, 2u, 8u}) {
    CAPTURE(threads);
    std::atomic<uint64_t> ran{0};
    Status s = runtime::detail::parallel_for(100000, threads, [&](uint64_t i) {
      if (i == 5) throw std::bad_alloc();
      ++ran;
    });
    CHECK(s.code() == StatusCode::kOutOfMemory);
    CHECK(ran.load() < 100000 - 1);
    CHECK(runtime::detail::parallel_chunks(1000, 7, threads, [](uint64_t, uint64_t) {}).ok());
  }
}

TEST_CASE("CPU render path: .rgs files with NaN means, zero quaternions, negative scales or opacity 2 fail") {
  // tools::load_scene (rgs-render --backend cpu, rgs-audit) reads through RgsFile::read_scene.
  check_read_scene_refuses_bad_values();
}

}  // namespace rgs::test
