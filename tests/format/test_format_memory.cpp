// Memory follows what a file proves (SPEC §5.5): small files that claim huge decoded sizes are refused by
// the decompression-ratio limit before anything is allocated, and when the limit is raised, damaged
// frames fail in bounded memory. Also read_scene's value rules (SPEC §4.3-4.7) on the must-fail corpus.
#include <doctest/doctest.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "bad_value_files.h"
#include "format_test_util.h"
#include "memory_corpus.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace rgs::test {
namespace {

format::ReadOptions ratio_options(uint32_t ratio) {
  format::ReadOptions options;
  options.limits.max_decompression_ratio = ratio;
  return options;
}

/// The committed file equals what the generator makes (set RGS_WRITE_MEMORY_CORPUS=1 to rewrite it).
void check_committed(const char* relative, const std::vector<uint8_t>& generated) {
  const std::string path = data_path(relative);
  if (const char* env = std::getenv("RGS_WRITE_MEMORY_CORPUS"); env && std::string(env) == "1") {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(generated.data()), static_cast<std::streamsize>(generated.size()));
    REQUIRE(out.good());
  }
  const std::vector<uint8_t> on_disk = read_file_bytes(path);
  CHECK_MESSAGE(on_disk == generated, path << " differs from make_zstd_memory_bomb(); rerun this test with "
                                              "RGS_WRITE_MEMORY_CORPUS=1");
}

}  // namespace

TEST_CASE("memory: a 65 KB file declaring 2^26 Gaussians is refused by the decompression-ratio limit") {
  const std::vector<uint8_t> bytes = make_zstd_memory_bomb(kRleBombGaussians, false);
  CHECK(bytes.size() < 70 * 1024);
  check_committed(kRleBombFile, bytes);

  auto file = format::RgsFile::from_bytes(bytes.data(), bytes.size(), {}, "bomb.rgs");
  REQUIRE_FALSE(file.ok());
  CHECK(file.status().code() == StatusCode::kLimitExceeded);
  CHECK(file.status().message().find("bomb.rgs") != std::string::npos);
  CHECK(file.status().message().find("decompression-ratio limit of 8") != std::string::npos);
  CHECK(file.status().message().find("2080374912 bytes") != std::string::npos);  // 2^26 x 31 + metadata
  const Status check = format::validate(bytes.data(), bytes.size(), {}, "bomb.rgs");
  CHECK(check.code() == StatusCode::kLimitExceeded);

  // zstd's own bound is 32768:1; the file is valid under it and streams through validate() in chunks.
  auto opened = format::RgsFile::from_bytes(bytes.data(), bytes.size(), ratio_options(32768), "bomb.rgs");
  REQUIRE(opened.ok());
  CHECK(opened->gaussian_count() == kRleBombGaussians);
  format::ReadLimits raised;
  raised.max_decompression_ratio = 32768;
  CHECK(format::validate(bytes.data(), bytes.size(), raised, "bomb.rgs").ok());
  CHECK(opened->verify_section(format::SectionId::kRotations).ok());
  // One ratio short of what the file needs: refused. 2^26 x 31 bytes is 1984 MiB, plus the metadata.
  const uint64_t needed = (uint64_t{31} << 26) / format::kDecompressionRatioMinBytes + 1;
  CHECK(format::RgsFile::from_bytes(bytes.data(), bytes.size(), ratio_options(static_cast<uint32_t>(needed) - 1))
            .status()
            .code() == StatusCode::kLimitExceeded);
  CHECK(format::RgsFile::from_bytes(bytes.data(), bytes.size(), ratio_options(static_cast<uint32_t>(needed))).ok());

  // --max-gaussians bounds the count whatever the ratio.
  format::ReadOptions few = ratio_options(32768);
  few.limits.max_gaussians = 1000;
  auto limited = format::RgsFile::from_bytes(bytes.data(), bytes.size(), few, "bomb.rgs");
  CHECK(limited.status().code() == StatusCode::kLimitExceeded);
  CHECK(limited.status().message().find("67108864 Gaussians exceed the limit of 1000") != std::string::npos);
}

TEST_CASE("memory: bogus frames claiming 2^28 Gaussians fail as corrupt before their raw size is allocated") {
  const std::vector<uint8_t> bytes = make_zstd_memory_bomb(kBogusFrameGaussians, true);
  CHECK(bytes.size() < 300 * 1024);
  check_committed(kBogusFrameFile, bytes);

  CHECK(format::RgsFile::from_bytes(bytes.data(), bytes.size()).status().code() == StatusCode::kLimitExceeded);
  auto file = format::RgsFile::from_bytes(bytes.data(), bytes.size(), ratio_options(32768), "bogus.rgs");
  REQUIRE(file.ok());
  const Status verified = file->verify_section(format::SectionId::kMeans);
  CHECK(verified.code() == StatusCode::kCorruptData);
  CHECK(verified.message().find("bogus.rgs: section 1 (means)") != std::string::npos);
  // read_scene verifies each frame in 1 MiB chunks first: it fails as corrupt, not out of memory after a
  // 3 GiB allocation for the means.
  auto scene = file->read_scene();
  REQUIRE_FALSE(scene.ok());
  CHECK(scene.status().code() == StatusCode::kCorruptData);
  format::ReadLimits raised;
  raised.max_decompression_ratio = 32768;
  CHECK(format::validate(bytes.data(), bytes.size(), raised).code() == StatusCode::kCorruptData);
}

TEST_CASE("memory: the default ratio limit accepts the golden files and real conversions") {
  for (const char* name : {"v1.0/small_sh3.rgs", "v1.0/small_sh0_zstd.rgs", "v1.0/forward_compat.rgs",
                           "v1.2/small_sh0_dc_residual.rgs"}) {
    const std::vector<uint8_t> bytes = read_file_bytes(data_path(name));
    CHECK_MESSAGE(format::RgsFile::from_bytes(bytes.data(), bytes.size()).ok(), name);
  }
  // A scene that zstd shrinks a lot but that is not degenerate: every section compressed.
  const format::EncodedScene scene = make_random_scene(20000, 3, 7);
  format::WriteOptions write;
  for (format::SectionId id : {format::SectionId::kMetadata, format::SectionId::kMeans, format::SectionId::kRotations,
                               format::SectionId::kScales, format::SectionId::kOpacities, format::SectionId::kSh}) {
    write.codecs[id] = format::Codec::kZstd;
  }
  auto bytes = format::serialize_scene(scene, write);
  REQUIRE(bytes.ok());
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  REQUIRE(file.ok());
  CHECK(file->read_scene().ok());
}

TEST_CASE("memory: read_scene applies the value rules, so no loading path renders invalid values") {
  // The files open (their structure and checksums are fine); only the values break SPEC §4.3-4.6.
  check_read_scene_refuses_bad_values();
}

}  // namespace rgs::test
