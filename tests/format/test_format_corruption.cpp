// Seeded corruption of valid files (CONTRIBUTING.md#tests): every single-byte change and every truncation is an
// error, never a crash; random damage behind recomputed checksums exercises the deeper checks.
// Each candidate is a fresh heap copy of exactly its size, so ASan sees any read past the end.
#include <doctest/doctest.h>

#include <random>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

using namespace rgs;
using namespace rgs::format;

std::vector<std::vector<uint8_t>> valid_files() {
  std::vector<std::vector<uint8_t>> files = {test::read_file_bytes(test::data_path("v1.0/small_sh3.rgs")),
                                             test::read_file_bytes(test::data_path("v1.0/small_sh0_zstd.rgs"))};
  // A small file of our own zstd frames (real compressed blocks, not only raw and RLE ones).
  WriteOptions zstd;
  for (SectionId id : {SectionId::kMetadata, SectionId::kProvenance, SectionId::kMeans, SectionId::kRotations,
                       SectionId::kScales, SectionId::kOpacities, SectionId::kSh}) {
    zstd.codecs[id] = Codec::kZstd;
  }
  auto own = serialize_scene(test::make_random_scene(40, 2, 4242), zstd);
  REQUIRE(own.ok());
  files.push_back(std::move(own).value());
  for (const auto& f : files) REQUIRE(validate(f.data(), f.size()).ok());
  return files;
}

/// Runs every reader entry point on `bytes`; returns validate()'s status.
Status exercise(const std::vector<uint8_t>& bytes) {
  const Status validated = validate(bytes.data(), bytes.size());
  for (bool verify : {true, false}) {
    ReadOptions options;
    options.verify_checksums = verify;
    auto file = RgsFile::from_bytes(bytes.data(), bytes.size(), options);
    if (!file.ok()) continue;
    for (const SectionEntry& e : file->sections()) {
      (void)file->stored_bytes(e.id);
      if (e.raw_size <= (uint64_t{1} << 24)) {
        std::vector<uint8_t> raw(static_cast<size_t>(e.raw_size));
        (void)file->decode_section(e.id, raw.data(), raw.size());
      }
    }
    auto scene = file->read_scene();
    if (scene.ok()) (void)dequantize(*scene);
  }
  return validated;
}

}  // namespace

TEST_CASE("corruption: every single-byte change of a valid file fails validate()") {
  for (const auto& original : valid_files()) {
    CAPTURE(original.size());
    size_t failures = 0;
    for (size_t pos = 0; pos < original.size(); ++pos) {
      for (uint8_t mask : {uint8_t{0x01}, uint8_t{0x80}, uint8_t{0xff}}) {
        std::vector<uint8_t> bytes = original;
        bytes[pos] = static_cast<uint8_t>(bytes[pos] ^ mask);
        const Status s = exercise(bytes);
        if (s.ok()) {
          FAIL_CHECK("flipping mask " << int{mask} << " at byte " << pos << " was not detected");
          ++failures;
        }
        if (failures > 10) return;
      }
    }
  }
}

TEST_CASE("corruption: every truncation fails to open and to validate") {
  for (const auto& original : valid_files()) {
    for (size_t length = 0; length < original.size(); ++length) {
      const std::vector<uint8_t> bytes(original.begin(), original.begin() + static_cast<long>(length));
      const Status s = exercise(bytes);
      REQUIRE_MESSAGE(!s.ok(), "truncation to " << length << " bytes was not detected");
      CHECK_FALSE(RgsFile::from_bytes(bytes.data(), bytes.size()).ok());
    }
  }
}

TEST_CASE("corruption: random damage with recomputed checksums never crashes") {
  // Fixing the checksums after the damage lets it reach the table, metadata, provenance, frame and value
  // checks. Some damage is legitimately valid (an SH value changed within range), so only count.
  std::mt19937 rng(20261121);
  const auto files = valid_files();
  size_t rejected = 0, total = 0;
  for (int iteration = 0; iteration < 6000; ++iteration) {
    std::vector<uint8_t> bytes = files[static_cast<size_t>(iteration) % files.size()];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      // Bias towards the header, the table and the metadata, where the structure lives.
      const size_t region = rng() % 3 == 0 ? bytes.size() : std::min<size_t>(bytes.size(), 1024);
      const size_t pos = rng() % region;
      switch (rng() % 4) {
        case 0: bytes[pos] = static_cast<uint8_t>(rng()); break;
        case 1: bytes[pos] ^= static_cast<uint8_t>(1u << (rng() % 8)); break;
        case 2: bytes[pos] = rng() % 2 ? 0x00 : 0xff; break;
        default:  // a plausible 64-bit value: small, a power of two, or all ones
          if (pos + 8 <= bytes.size()) {
            const uint64_t v = rng() % 3 == 0 ? ~uint64_t{0} : rng() % 2 ? (uint64_t{1} << (rng() % 64)) : rng() % 4096;
            test::put_u64(bytes, pos, v);
          }
      }
    }
    if (rng() % 4 == 0) bytes.resize(rng() % (bytes.size() + 1));
    test::fix_all_checksums(bytes);
    const Status s = exercise(bytes);
    ++total;
    if (!s.ok()) ++rejected;
    CHECK(s.code() != StatusCode::kOutOfMemory);
  }
  MESSAGE("random damage: " << rejected << " of " << total << " files rejected");
  CHECK(rejected > total / 2);
}

TEST_CASE("corruption: huge sizes in a checksummed table are refused before allocating") {
  const std::vector<uint8_t> original = test::read_file_bytes(test::data_path("v1.0/small_sh3.rgs"));
  // Claim 2^40 bytes of raw SH data in a zstd section: the expansion bound and the limits stop it.
  for (uint64_t raw : {uint64_t{1} << 40, ~uint64_t{0}, uint64_t{1} << 33}) {
    std::vector<uint8_t> bytes = original;
    const size_t sh = test::entry_at(6);
    test::put_u16(bytes, sh + 4, 1);  // codec zstd
    test::put_u64(bytes, sh + 40, raw);
    test::fix_header_checksum(bytes);
    const Status s = validate(bytes.data(), bytes.size());
    CHECK_FALSE(s.ok());
    CHECK(s.code() != StatusCode::kOutOfMemory);
  }
  // The same count in the header and every section: the limit on Gaussians refuses it.
  std::vector<uint8_t> bytes = original;
  test::put_u64(bytes, 24, uint64_t{1} << 36);
  test::fix_header_checksum(bytes);
  CHECK(validate(bytes.data(), bytes.size()).code() == StatusCode::kLimitExceeded);
}
