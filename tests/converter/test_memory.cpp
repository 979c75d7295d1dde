// Allocation failures in the converter's worker threads become kOutOfMemory, never an abort; the .rgs ->
// PLY path refuses values the spec rules out and writes only finite values.
#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <new>
#include <string>

#include "../../converter/src/internal_parallel.h"
#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "test_data.h"

namespace rgs::test {

TEST_CASE("parallel_slices / parallel_items: bad_alloc in a worker thread is kOutOfMemory") {
  for (unsigned workers : {1u, 2u, 4u}) {
    CAPTURE(workers);
    // The last slice runs on a worker thread whenever workers > 1.
    Status s = converter::detail::parallel_slices(1000, workers, [&](unsigned t, uint64_t, uint64_t) {
      if (t + 1 == workers) throw std::bad_alloc();
    });
    CHECK(s.code() == StatusCode::kOutOfMemory);
    std::atomic<uint64_t> ran{0};
    s = converter::detail::parallel_items(100000, workers, [&](unsigned, uint64_t item) {
      if (item == 10) throw std::bad_alloc();
      ++ran;
    });
    CHECK(s.code() == StatusCode::kOutOfMemory);
    CHECK(ran.load() < 100000 - 1);  // no further items after the failure (workers stop early)
    CHECK(converter::detail::parallel_items(1000, workers, [&](unsigned, uint64_t) {}).ok());
  }
}

TEST_CASE("rgs -> PLY: files whose values break the spec are refused before anything is written") {
  const auto dir = std::filesystem::temp_directory_path() / "rgs_test_convert_values";
  std::filesystem::create_directories(dir);
  for (const char* name : {"nan_mean", "zero_rotation", "negative_linear_scale", "opacity_above_one"}) {
    CAPTURE(name);
    // The library steps of `rgs-convert x.rgs x.ply`: open, read_scene, dequantize, write_ply.
    auto file = format::RgsFile::open(repo_path(std::string("tests/data/bad/") + name + ".rgs"));
    REQUIRE(file.ok());
    auto scene = file->read_scene();
    REQUIRE_FALSE(scene.ok());
    CHECK(scene.status().code() == StatusCode::kCorruptData);
    CHECK(scene.status().message().find(name) != std::string::npos);
  }
}

TEST_CASE("rgs -> PLY: guitar's 101 linear-FP16 zero scales are written finite and counted") {
  auto ply = converter::read_ply(repo_path("samples/guitar.ply"));
  REQUIRE(ply.ok());
  auto encoded = converter::quantize(ply->cloud, {});
  REQUIRE(encoded.ok());
  auto cloud = format::dequantize(*encoded);
  REQUIRE(cloud.ok());
  converter::PlyWriteReport report;
  auto bytes = converter::serialize_ply(*cloud, &report);
  REQUIRE(bytes.ok());
  CHECK(report.zero_scales == 101);
  auto back = converter::read_ply_bytes(bytes->data(), bytes->size(), "guitar_restored.ply");
  REQUIRE(back.ok());
  uint64_t floored = 0;
  for (float s : back->cloud.scales) {
    REQUIRE(std::isfinite(s));
    floored += s > 0.0f && s < 3e-8f;
  }
  CHECK(floored == 101);
  // Converting the restored PLY again gives the same scales: the floor is below FP16's smallest step.
  auto again = converter::quantize(back->cloud, {});
  REQUIRE(again.ok());
  CHECK(again->scales == encoded->scales);
}

}  // namespace rgs::test
