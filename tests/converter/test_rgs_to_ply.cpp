// The .rgs -> PLY path refuses values the spec rules out and writes only finite values.
#include <doctest/doctest.h>

#include <cmath>

#include "bad_value_files.h"
#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "test_data.h"

namespace rgs::test {

TEST_CASE("rgs -> PLY: files whose values break the spec are refused before anything is written") {
  // The library steps of `rgs-convert x.rgs x.ply` start with open and read_scene, which refuse them.
  check_read_scene_refuses_bad_values();
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
