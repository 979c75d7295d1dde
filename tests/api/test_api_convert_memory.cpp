// ConvertOptions::memory_limit: the estimate of a conversion's peak memory and the refusal, before reading, of an
// input whose estimate is above the limit.
#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include "rgs/api/convert.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

TEST_CASE("estimate_convert_memory: above the input's bytes, growing with them, compact formats more per byte") {
  const std::string ply = test::repo_path(test::kGuitarSh3);
  const std::string spz = test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz");
  auto ply_estimate = api::estimate_convert_memory(ply);
  auto spz_estimate = api::estimate_convert_memory(spz);
  REQUIRE_MESSAGE(ply_estimate.ok(), ply_estimate.status().to_string());
  REQUIRE_MESSAGE(spz_estimate.ok(), spz_estimate.status().to_string());
  const uint64_t ply_bytes = std::filesystem::file_size(ply);
  const uint64_t spz_bytes = std::filesystem::file_size(spz);
  CHECK(*ply_estimate > ply_bytes);
  CHECK(*spz_estimate > spz_bytes);
  constexpr uint64_t kBase = uint64_t{64} << 20;  // what every conversion holds (convert_memory.cpp)
  CHECK(double(*spz_estimate - kBase) / double(spz_bytes) > double(*ply_estimate - kBase) / double(ply_bytes));
  CHECK(api::estimate_convert_memory(test::repo_path("tests/data/no_such_scene.ply")).status().code() ==
        StatusCode::kIoError);
}

TEST_CASE("convert_memory_limit: the option, else half the physical memory") {
  api::ConvertOptions options;
  const uint64_t machine = api::convert_memory_limit(options);
  CHECK(machine > (uint64_t{64} << 20));  // any machine that runs the suite
  options.memory_limit = 12345;
  CHECK(api::convert_memory_limit(options) == 12345);
}

TEST_CASE("convert: an input whose estimate is above memory_limit is refused before it is read, nothing written") {
  test::TempDir dir;
  const std::string src = test::repo_path(test::kGuitarSh3);
  const std::string dst = (dir.path() / "limited.rgs").string();
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.memory_limit = *estimate - 1;
  auto refused = api::convert(src, dst, options);
  REQUIRE(!refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  CHECK(refused.status().message().find("guitar_sh3.ply: converting it is estimated to need") != std::string::npos);
  CHECK(refused.status().message().find("memory_limit (--memory-limit)") != std::string::npos);
  CHECK(dir.entries().empty());
  options.memory_limit = *estimate;
  auto written = api::convert(src, dst, options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(written->rgs->lod_levels > 0);
  CHECK(std::filesystem::exists(dst));
}

}  // namespace
