// ConvertOptions::memory_limit: the estimate of a conversion's peak memory and the refusal, before reading, of an
// input whose estimate is above the limit.
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>
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

TEST_CASE("convert: an input over memory_limit that cannot be read in batches is refused before it is read") {
  test::TempDir dir;
  const std::string src = test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz");
  const std::string dst = (dir.path() / "limited.rgs").string();
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.memory_limit = *estimate - 1;
  auto refused = api::convert(src, dst, options);
  REQUIRE(!refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  CHECK(refused.status().message().find("guitar_256_splat_transform_v4.spz: converting it is estimated to need") !=
        std::string::npos);
  CHECK(refused.status().message().find("memory_limit (--memory-limit)") != std::string::npos);
  CHECK(dir.entries().empty());
  options.memory_limit = *estimate;
  auto written = api::convert(src, dst, options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(written->rgs->lod_levels > 0);
  CHECK(written->rgs->out_of_core_partitions == 0);
  CHECK(std::filesystem::exists(dst));
}

/// The resident memory of this process (Linux), 0 when unknown.
uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, pages = 0;
  statm >> size >> pages;
  return pages * uint64_t(sysconf(_SC_PAGE_SIZE));
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST_CASE("convert: a binary PLY over memory_limit converts out of core to the bytes of the conversion in memory") {
  test::TempDir dir;
  const std::string src = test::repo_path(test::kGuitarSh3);
  const std::string in_memory = (dir.path() / "in_memory.rgs").string();
  const std::string out_of_core = (dir.path() / "out_of_core.rgs").string();
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.lod_chunk_gaussians = 512;
  options.scale_encoding = format::ScaleEncoding::kLog;
  auto memory = api::convert(src, in_memory, options);
  REQUIRE_MESSAGE(memory.ok(), memory.status().to_string());
  CHECK(memory->rgs->out_of_core_partitions == 0);
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  // The limit bounds the whole process: a suite run in one process (the GPU host's) may already hold more than
  // this small scene's estimate leaves the build. ctest runs each case in a process of its own.
  if (resident_bytes() + (uint64_t{40} << 20) > *estimate) {
    MESSAGE("skipped: this process already holds " << resident_bytes() << " bytes, too many for a limit of "
                                                   << *estimate - 1);
    return;
  }
  options.memory_limit = *estimate - 1;
  std::vector<std::string> stages;
  options.progress = [&](const api::ConvertProgress& p) { stages.push_back(p.stage); };
  auto streamed = api::convert(src, out_of_core, options);
  REQUIRE_MESSAGE(streamed.ok(), streamed.status().to_string());
  CHECK(streamed->rgs->out_of_core_partitions >= 1);
  CHECK(streamed->output_bytes == memory->output_bytes);
  CHECK(streamed->gaussians == memory->gaussians);
  CHECK(streamed->rgs->lod_gaussians == memory->rgs->lod_gaussians);
  CHECK(streamed->rgs->errors.sh[3].max == doctest::Approx(memory->rgs->errors.sh[3].max));
  CHECK(read_bytes(out_of_core) == read_bytes(in_memory));
  for (const char* stage : {"reading", "counting", "partitioning", "building levels of detail", "writing", "done"}) {
    CHECK_MESSAGE(std::find(stages.begin(), stages.end(), stage) != stages.end(), stage);
  }
  CHECK(dir.entries().size() == 2);  // the temporary folder is gone
}

TEST_CASE("convert: an ascii PLY over memory_limit is refused, as it is read whole") {
  test::TempDir dir;
  const std::string src = (dir.path() / "ascii.ply").string();
  {
    std::ofstream ply(src);
    ply << "ply\nformat ascii 1.0\nelement vertex 1\n";
    for (const char* p : {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
                          "rot_0", "rot_1", "rot_2", "rot_3"}) {
      ply << "property float " << p << "\n";
    }
    ply << "end_header\n0 0 0 0 0 0 0 0 0 0 1 0 0 0\n";
  }
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.memory_limit = 1 << 20;
  auto refused = api::convert(src, (dir.path() / "out.rgs").string(), options);
  REQUIRE(!refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  CHECK(refused.status().message().find("only a binary PLY converted with levels of detail is read in batches") !=
        std::string::npos);
}

}  // namespace
