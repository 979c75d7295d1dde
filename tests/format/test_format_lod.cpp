// Level-of-detail files (SPEC §4.9): the writer's lod section and range checksums, the reader's index and ranges,
// the version and flag they stamp, the writer's refusals and the per-range checks of lod_range().
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "format_test_util.h"
#include "rgs/format/half.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "temp_dir.h"

namespace {

using namespace rgs;
using namespace rgs::format;
using rgs::test::range_checksum;

/// A scene holding every level of every chunk, level-major, and its index.
struct LodScene {
  EncodedScene scene;
  LodIndex index;
};

double linear_scale(uint16_t bits, ScaleEncoding encoding) {
  const double v = half_bits_to_float(bits);
  return encoding == ScaleEncoding::kLog ? std::exp(v) : v;
}

/// Appends Gaussian `i` of `from` to `to`.
void append_gaussian(const EncodedScene& from, uint64_t i, EncodedScene* to) {
  const size_t k3 = 3 * sh_coefficient_count(from.metadata.sh_degree);
  to->means.insert(to->means.end(), from.means.begin() + i * 3, from.means.begin() + i * 3 + 3);
  to->rotations.insert(to->rotations.end(), from.rotations.begin() + i * 4, from.rotations.begin() + i * 4 + 4);
  to->scales.insert(to->scales.end(), from.scales.begin() + i * 3, from.scales.begin() + i * 3 + 3);
  to->opacities.push_back(from.opacities[i]);
  to->sh.insert(to->sh.end(), from.sh.begin() + i * k3, from.sh.begin() + (i + 1) * k3);
  if (!from.sh_dc_residual.empty()) {
    to->sh_dc_residual.insert(to->sh_dc_residual.end(), from.sh_dc_residual.begin() + i * 3,
                              from.sh_dc_residual.begin() + i * 3 + 3);
  }
  ++to->count;
}

/// `chunks` chunks of `per_chunk` Gaussians of a random pool (split along x), each at `levels` levels: level l of
/// chunk c holds max(1, per_chunk >> (l + (c odd and l > 0))) of the chunk's Gaussians (another subset per level),
/// its error 0.5 l + 0.125 c for l > 0. Chunk spheres are the smallest around the chunk's AABB centre that hold every
/// level's 3-sigma extents, rounded up to the next float.
LodScene make_lod_scene(uint32_t chunks, uint32_t levels, uint64_t per_chunk, uint32_t seed,
                        ScaleEncoding encoding = ScaleEncoding::kLinear, bool residual = true) {
  EncodedScene pool = test::make_random_scene(chunks * per_chunk, 2, seed, encoding);
  if (residual) {
    for (uint64_t i = 0; i < pool.count * 3; ++i) pool.sh_dc_residual.push_back(static_cast<int8_t>(i * 7 % 256 - 128));
  }
  std::vector<uint64_t> order(pool.count);
  std::iota(order.begin(), order.end(), uint64_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](uint64_t a, uint64_t b) { return pool.means[a * 3] < pool.means[b * 3]; });
  LodScene out;
  EncodedScene& s = out.scene;
  s.metadata = pool.metadata;  // every level copies pool Gaussians: the pool's bounds hold them all
  s.provenance = pool.provenance;
  LodIndex& index = out.index;
  index.chunk_count = chunks;
  index.level_count = levels;
  std::vector<std::vector<uint64_t>> members(chunks);  // pool indices of each chunk, over all levels
  for (uint32_t l = 0; l < levels; ++l) {
    for (uint32_t c = 0; c < chunks; ++c) {
      LodLevel& v = index.levels.emplace_back();
      v.first = s.count;
      v.count = std::max<uint64_t>(1, per_chunk >> (l + ((c % 2 == 1 && l > 0) ? 1 : 0)));
      v.error = l == 0 ? 0.0f : 0.5f * static_cast<float>(l) + 0.125f * static_cast<float>(c);
      for (uint64_t j = 0; j < v.count; ++j) {
        const uint64_t i = order[c * per_chunk + (j << l) % per_chunk];
        append_gaussian(pool, i, &s);
        members[c].push_back(i);
      }
    }
  }
  for (uint32_t c = 0; c < chunks; ++c) {
    LodChunk& k = index.chunks.emplace_back();
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint64_t i : members[c]) {
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], pool.means[i * 3 + a]);
        hi[a] = std::max(hi[a], pool.means[i * 3 + a]);
      }
    }
    for (int a = 0; a < 3; ++a) k.center[a] = 0.5f * (lo[a] + hi[a]);
    double radius = 0;
    for (uint64_t i : members[c]) {
      double d2 = 0, largest = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = static_cast<double>(pool.means[i * 3 + a]) - k.center[a];
        d2 += d * d;
        largest = std::max(largest, linear_scale(pool.scales[i * 3 + a], encoding));
      }
      radius = std::max(radius, std::sqrt(d2) + 3 * largest);
    }
    k.radius = std::nextafter(static_cast<float>(radius), INFINITY);
  }
  return out;
}

std::vector<uint8_t> must_serialize(const EncodedScene& scene, const WriteOptions& options) {
  auto bytes = serialize_scene(scene, options);
  REQUIRE_MESSAGE(bytes.ok(), bytes.status().to_string());
  return std::move(bytes).value();
}

std::vector<uint8_t> must_serialize(const LodScene& lod, WriteOptions options = {}) {
  options.lod = &lod.index;
  return must_serialize(lod.scene, options);
}

RgsFile must_open(const std::vector<uint8_t>& bytes, const ReadOptions& options = {}) {
  auto file = RgsFile::from_bytes(bytes.data(), bytes.size(), options, "lod.rgs");
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  return std::move(file).value();
}

/// The writer's refusal of `lod` (modified by the caller) for `scene`: kInvalidArgument naming `fragment`.
void check_refused(const EncodedScene& scene, const LodIndex& lod, const WriteOptions& base, const char* fragment) {
  WriteOptions options = base;
  options.lod = &lod;
  auto bytes = serialize_scene(scene, options);
  REQUIRE_FALSE(bytes.ok());
  CHECK_MESSAGE(bytes.status().code() == StatusCode::kInvalidArgument, bytes.status().to_string());
  CHECK_MESSAGE(bytes.status().message().find(fragment) != std::string::npos,
                "expected \"" << fragment << "\" in: " << bytes.status().to_string());
}

/// Reads `file`'s index back against `lod` and every range against the scene: the index exactly, the checksums as
/// recomputed here, the views pointing into the sections at `first` records, read_scene() the level-0 prefix.
void check_lod_file(const RgsFile& file, const LodScene& lod) {
  const EncodedScene& s = lod.scene;
  CHECK(file.header().major == 1);
  CHECK(file.header().minor == 3);
  CHECK(file.header().required_flags == kRequiredFlagLod);
  CHECK(file.gaussian_count() == s.count);
  const SectionEntry* entry = file.find(SectionId::kLod);
  REQUIRE(entry != nullptr);
  CHECK(entry == &file.sections().back());  // written last
  CHECK(entry->codec == Codec::kNone);
  CHECK(entry->element_type == ElementType::kBytes);
  CHECK(entry->components == 1);
  CHECK(entry->raw_size == 16 + 16 * uint64_t{lod.index.chunk_count} +
                               24 * uint64_t{lod.index.chunk_count} * lod.index.level_count);
  const LodIndex* got = file.lod();
  REQUIRE(got != nullptr);
  REQUIRE(got->chunk_count == lod.index.chunk_count);
  REQUIRE(got->level_count == lod.index.level_count);
  REQUIRE(got->chunks.size() == lod.index.chunks.size());
  REQUIRE(got->levels.size() == lod.index.levels.size());
  for (size_t c = 0; c < got->chunks.size(); ++c) {
    for (int a = 0; a < 3; ++a) CHECK(test::same_bits(got->chunks[c].center[a], lod.index.chunks[c].center[a]));
    CHECK(test::same_bits(got->chunks[c].radius, lod.index.chunks[c].radius));
  }
  uint64_t n0 = 0;
  for (size_t r = 0; r < got->levels.size(); ++r) {
    CAPTURE(r);
    const LodLevel& v = got->levels[r];
    CHECK(v.first == lod.index.levels[r].first);
    CHECK(v.count == lod.index.levels[r].count);
    CHECK(test::same_bits(v.error, lod.index.levels[r].error));
    CHECK(v.checksum == range_checksum(s, v.first, v.count));
    if (r < got->chunk_count) n0 += v.count;
  }
  CHECK(n0 > 0);
  CHECK(got->full_detail_count() == n0);
  CHECK(file.full_detail_count() == n0);
  CHECK(lod.index.full_detail_count() == n0);

  const size_t k3 = 3 * sh_coefficient_count(s.metadata.sh_degree);
  const uint8_t* means = file.stored_bytes(SectionId::kMeans)->data;
  const uint8_t* sh = file.stored_bytes(SectionId::kSh)->data;
  for (uint32_t l = 0; l < got->level_count; ++l) {
    for (uint32_t c = 0; c < got->chunk_count; ++c) {
      CAPTURE(l);
      CAPTURE(c);
      auto range = file.lod_range(l, c);
      REQUIRE_MESSAGE(range.ok(), range.status().to_string());
      const LodLevel& v = got->at(l, c);
      CHECK(range->first == v.first);
      CHECK(range->count == v.count);
      CHECK(range->means.data == means + v.first * 12);
      CHECK(range->sh.data == sh + v.first * k3);
      CHECK(range->means.size == v.count * 12);
      CHECK(range->scales.size == v.count * 6);
      CHECK(range->sh.size == v.count * k3);
      CHECK(range->sh_dc_residual.size == (s.sh_dc_residual.empty() ? 0 : v.count * 3));
      CHECK(std::memcmp(range->means.data, s.means.data() + v.first * 3, range->means.size) == 0);
      CHECK(std::memcmp(range->rotations.data, s.rotations.data() + v.first * 4, range->rotations.size) == 0);
      CHECK(std::memcmp(range->opacities.data, s.opacities.data() + v.first, range->opacities.size) == 0);
    }
  }

  auto scene = file.read_scene();
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  CHECK(scene->count == n0);
  REQUIRE(scene->means.size() == n0 * 3);
  CHECK(std::memcmp(scene->means.data(), s.means.data(), n0 * 12) == 0);
  CHECK(scene->rotations == std::vector<uint16_t>(s.rotations.begin(), s.rotations.begin() + n0 * 4));
  CHECK(scene->scales == std::vector<uint16_t>(s.scales.begin(), s.scales.begin() + n0 * 3));
  CHECK(scene->opacities == std::vector<uint16_t>(s.opacities.begin(), s.opacities.begin() + n0));
  CHECK(scene->sh == std::vector<int8_t>(s.sh.begin(), s.sh.begin() + n0 * k3));
  CHECK(scene->sh_dc_residual ==
        (s.sh_dc_residual.empty() ? std::vector<int8_t>()
                                  : std::vector<int8_t>(s.sh_dc_residual.begin(), s.sh_dc_residual.begin() + n0 * 3)));
  CHECK(scene->provenance == s.provenance);
}

}  // namespace

TEST_CASE("lod: writer and reader round trip the index, its range checksums and the full-detail prefix") {
  const LodScene lod = make_lod_scene(4, 3, 24, 11);
  REQUIRE(lod.scene.count == 4 * 24 + (12 + 6 + 12 + 6) + (6 + 3 + 6 + 3));
  CHECK(lod.index.full_detail_count() == 96);
  const std::vector<uint8_t> bytes = must_serialize(lod);
  const RgsFile file = must_open(bytes);
  check_lod_file(file, lod);
  const Status valid = validate(bytes.data(), bytes.size(), ReadLimits{}, "lod.rgs");
  CHECK_MESSAGE(valid.ok(), valid.to_string());
  // Deterministic, and the checksums the caller's index holds are ignored: the writer computes them.
  LodScene garbage = lod;
  for (LodLevel& v : garbage.index.levels) v.checksum = ~v.checksum;
  CHECK(must_serialize(garbage) == bytes);
  // Written to a file (streamed from the scene's arrays), the same bytes.
  test::TempDir dir;
  WriteOptions options;
  options.lod = &lod.index;
  auto written = write_scene_file(dir.file("lod.rgs"), lod.scene, options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(*written == bytes.size());
  CHECK(test::read_file_bytes(dir.file("lod.rgs")) == bytes);
}

TEST_CASE("lod: log scales, no residual, one chunk of one level, and zstd on metadata and provenance") {
  SUBCASE("log scales, 3 chunks x 2 levels, no residual: the checksum streams stop at sh") {
    const LodScene lod = make_lod_scene(3, 2, 10, 12, ScaleEncoding::kLog, false);
    const std::vector<uint8_t> bytes = must_serialize(lod);
    const RgsFile file = must_open(bytes);
    CHECK(file.find(SectionId::kShDcResidual) == nullptr);
    check_lod_file(file, lod);
    CHECK(validate(bytes.data(), bytes.size(), ReadLimits{}, "lod.rgs").ok());
  }
  SUBCASE("one chunk, one level: the index covers the whole scene") {
    const LodScene lod = make_lod_scene(1, 1, 7, 13);
    REQUIRE(lod.scene.count == 7);
    const std::vector<uint8_t> bytes = must_serialize(lod);
    const RgsFile file = must_open(bytes);
    check_lod_file(file, lod);
    CHECK(file.full_detail_count() == 7);
    CHECK(file.lod_range(0, 0)->count == 7);
  }
  SUBCASE("16 levels (kMaxLodLevels)") {
    const LodScene lod = make_lod_scene(2, kMaxLodLevels, 5, 14);
    const std::vector<uint8_t> bytes = must_serialize(lod);
    check_lod_file(must_open(bytes), lod);
    CHECK(validate(bytes.data(), bytes.size(), ReadLimits{}, "lod.rgs").ok());
  }
  SUBCASE("metadata and provenance may be zstd frames; the per-Gaussian sections stay raw") {
    const LodScene lod = make_lod_scene(2, 3, 12, 15);
    WriteOptions options;
    options.codecs[SectionId::kMetadata] = Codec::kZstd;
    options.codecs[SectionId::kProvenance] = Codec::kZstd;
    options.zstd_level = 3;
    const std::vector<uint8_t> bytes = must_serialize(lod, options);
    const RgsFile file = must_open(bytes);
    CHECK(file.find(SectionId::kMetadata)->codec == Codec::kZstd);
    CHECK(file.find(SectionId::kProvenance)->codec == Codec::kZstd);
    check_lod_file(file, lod);
    CHECK(validate(bytes.data(), bytes.size(), ReadLimits{}, "lod.rgs").ok());
  }
}

TEST_CASE("lod: the index stamps 1.3 with kRequiredFlagLod, without it a file keeps its older version") {
  LodScene lod = make_lod_scene(2, 2, 8, 21);
  // With a residual: 1.2 without the index, 1.3 with it.
  {
    const std::vector<uint8_t> plain_bytes = must_serialize(lod.scene, WriteOptions{});
    const std::vector<uint8_t> lod_bytes = must_serialize(lod);
    const RgsFile plain = must_open(plain_bytes);  // the file views the bytes: they must outlive it
    CHECK(plain.header().minor == 2);
    CHECK(plain.header().required_flags == 0);
    CHECK(plain.lod() == nullptr);
    CHECK(plain.find(SectionId::kLod) == nullptr);
    CHECK(plain.full_detail_count() == lod.scene.count);
    CHECK(plain.read_scene()->count == lod.scene.count);
    const RgsFile with_lod = must_open(lod_bytes);
    CHECK(with_lod.header().minor == 3);
    CHECK(with_lod.header().required_flags == kRequiredFlagLod);
  }
  // Without: 1.0 and 1.3.
  lod.scene.sh_dc_residual.clear();
  {
    const std::vector<uint8_t> plain_bytes = must_serialize(lod.scene, WriteOptions{});
    const std::vector<uint8_t> lod_bytes = must_serialize(lod);
    const RgsFile plain = must_open(plain_bytes);
    CHECK(plain.header().minor == 0);
    CHECK(plain.header().required_flags == 0);
    const RgsFile with_lod = must_open(lod_bytes);
    CHECK(with_lod.header().minor == 3);
    CHECK(with_lod.header().required_flags == 2);
  }
}

TEST_CASE("lod: the writer refuses what validate() would reject (kInvalidArgument)") {
  const LodScene lod = make_lod_scene(3, 3, 12, 31);
  const EncodedScene& scene = lod.scene;
  SUBCASE("the archive profile") {
    WriteOptions options;
    options.profile = StorageProfile::kArchive;
    check_refused(scene, lod.index, options, "not the archive profile");
  }
  SUBCASE("zstd on a per-Gaussian section") {
    for (SectionId id : {SectionId::kMeans, SectionId::kScales, SectionId::kSh, SectionId::kShDcResidual}) {
      CAPTURE(section_name(id));
      WriteOptions options;
      options.codecs[id] = Codec::kZstd;
      check_refused(scene, lod.index, options, (std::string("stores section ") + section_name(id) + " raw").c_str());
    }
  }
  SUBCASE("an index that does not tile the scene") {
    LodIndex short_index = lod.index;
    short_index.levels.back().count -= 1;  // the ranges end one Gaussian early
    check_refused(scene, short_index, {}, "the levels hold");
    LodIndex long_index = lod.index;
    long_index.levels.back().count += 1;  // the last range runs past N
    check_refused(scene, long_index, {}, "pass the file's");
    LodIndex shifted = lod.index;
    shifted.levels[4].first += 1;  // `first` is checked, not trusted
    check_refused(scene, shifted, {}, "lod chunk 1 level 1: starts at Gaussian");
    LodIndex missing = lod.index;
    missing.levels.pop_back();
    check_refused(scene, missing, {}, "level records for 3 chunks of 3 levels");
  }
  SUBCASE("a Gaussian outside its chunk's sphere") {
    LodIndex small = lod.index;
    small.chunks[2].radius *= 0.5f;
    check_refused(scene, small, {}, "lod chunk 2 level 0: Gaussian");
    LodIndex moved = lod.index;
    moved.chunks[1].center[0] += moved.chunks[1].radius;
    check_refused(scene, moved, {}, "outside its radius");
  }
  SUBCASE("structural rules: counts, errors, sizes") {
    LodIndex zero = lod.index;
    zero.levels[0].error = 0.25f;
    check_refused(scene, zero, {}, "level 0 (the full detail) must have 0");
    LodIndex decreasing = lod.index;
    decreasing.at(2, 0).error = decreasing.at(1, 0).error * 0.5f;
    check_refused(scene, decreasing, {}, "lod chunk 0 level 2: error");
    LodIndex nan_radius = lod.index;
    nan_radius.chunks[0].radius = NAN;
    check_refused(scene, nan_radius, {}, "lod chunk 0: centre");
    LodIndex too_many = lod.index;
    too_many.level_count = kMaxLodLevels + 1;
    check_refused(scene, too_many, {}, "17 levels, must be 1..16");
    // Level 1 of chunk 0 larger than its level 0 (the total kept: level 0 gives one Gaussian to level 1).
    LodIndex growing = lod.index;
    growing.at(0, 0).count = 4;
    growing.at(1, 0).count = 14;
    uint64_t first = 0;
    for (LodLevel& v : growing.levels) v.first = std::exchange(first, first + v.count);
    REQUIRE(first == scene.count);
    check_refused(scene, growing, {}, "lod chunk 0 level 1: 14 Gaussians, more than level 0's 4");
  }
}

TEST_CASE("lod: lod_range() argument errors") {
  const LodScene lod = make_lod_scene(2, 3, 8, 41);
  const std::vector<uint8_t> plain_bytes = must_serialize(lod.scene, WriteOptions{});
  const RgsFile plain = must_open(plain_bytes);
  auto none = plain.lod_range(0, 0);
  REQUIRE_FALSE(none.ok());
  CHECK(none.status().code() == StatusCode::kInvalidArgument);
  CHECK(none.status().message().find("no level-of-detail index") != std::string::npos);

  const std::vector<uint8_t> bytes = must_serialize(lod);
  const RgsFile file = must_open(bytes);
  CHECK(file.lod_range(2, 1).ok());
  for (auto [level, chunk] : {std::pair<uint32_t, uint32_t>{3, 0}, {0, 2}, {3, 2}, {UINT32_MAX, 0}, {0, UINT32_MAX}}) {
    CAPTURE(level);
    CAPTURE(chunk);
    auto range = file.lod_range(level, chunk);
    REQUIRE_FALSE(range.ok());
    CHECK(range.status().code() == StatusCode::kInvalidArgument);
    CHECK(range.status().message().find("outside its 2 chunks of 3 levels") != std::string::npos);
  }
}

TEST_CASE("lod: read_lod_range() and read_lod_slice() copy exactly the range and check the copy") {
  const LodScene lod = make_lod_scene(3, 3, 12, 61);
  const std::vector<uint8_t> bytes = must_serialize(lod);
  const RgsFile file = must_open(bytes);
  const size_t k3 = 3 * sh_coefficient_count(lod.scene.metadata.sh_degree);
  const bool residual = file.find(SectionId::kShDcResidual) != nullptr;
  for (uint32_t l = 0; l < 3; ++l) {
    for (uint32_t c = 0; c < 3; ++c) {
      CAPTURE(l);
      CAPTURE(c);
      const LodRangeView in_file = file.lod_range(l, c).value();
      const uint64_t n = in_file.count;
      // One byte past each part, which the copy must leave alone.
      std::vector<uint8_t> means(n * 12 + 1, 0xa5), rotations(n * 8 + 1, 0xa5), scales(n * 6 + 1, 0xa5),
          opacities(n * 2 + 1, 0xa5), sh(n * k3 + 1, 0xa5), dc_residual(n * 3 + 1, 0xa5);
      const LodRangeTarget target{means.data(),     rotations.data(), scales.data(),
                                  opacities.data(), sh.data(),        residual ? dc_residual.data() : nullptr};
      auto copy = file.read_lod_range(l, c, target);
      REQUIRE_MESSAGE(copy.ok(), copy.status().to_string());
      CHECK(copy->first == in_file.first);
      CHECK(copy->count == n);
      const std::pair<ByteView, ByteView> parts[6] = {
          {in_file.means, copy->means}, {in_file.rotations, copy->rotations}, {in_file.scales, copy->scales},
          {in_file.opacities, copy->opacities}, {in_file.sh, copy->sh}, {in_file.sh_dc_residual, copy->sh_dc_residual}};
      const std::vector<uint8_t>* buffers[6] = {&means, &rotations, &scales, &opacities, &sh, &dc_residual};
      for (int a = 0; a < 6; ++a) {
        CHECK(parts[a].second.size == parts[a].first.size);
        if (parts[a].first.size == 0) continue;
        CHECK(parts[a].second.data == buffers[a]->data());  // the views are of the copy, not of the file
        CHECK(std::memcmp(parts[a].second.data, parts[a].first.data, parts[a].first.size) == 0);
        CHECK(buffers[a]->back() == 0xa5);
      }
    }
  }
  // Slices of 2 Gaussians copy the same bytes, and the copy's checksum then matches; a value damaged in the file
  // (checksums not verified) fails the slice holding it, naming the Gaussian, and no other slice.
  const LodRangeView whole = file.lod_range(0, 1).value();
  const uint64_t n = whole.count;
  REQUIRE(n > 4);
  std::vector<uint8_t> means(n * 12), rotations(n * 8), scales(n * 6), opacities(n * 2), sh(n * k3), dc(n * 3);
  const LodRangeTarget target{means.data(),     rotations.data(), scales.data(),
                              opacities.data(), sh.data(),        residual ? dc.data() : nullptr};
  for (uint64_t b = 0; b < n; b += 2) CHECK(file.read_lod_slice(0, 1, target, b, std::min(n, b + 2)).ok());
  CHECK(std::memcmp(means.data(), whole.means.data, whole.means.size) == 0);
  CHECK(std::memcmp(sh.data(), whole.sh.data, whole.sh.size) == 0);
  CHECK(file.check_lod_checksum(0, 1, target).ok());
  means[12 * 3] ^= 1;  // the copy, no longer the range
  CHECK(file.check_lod_checksum(0, 1, target).code() == StatusCode::kChecksumMismatch);
  CHECK(file.read_lod_slice(0, 1, target, 4, 3).code() == StatusCode::kInvalidArgument);
  CHECK(file.read_lod_slice(0, 1, target, 0, n + 1).code() == StatusCode::kInvalidArgument);
  std::vector<uint8_t> nan_mean = bytes;
  const float nan = NAN;
  std::memcpy(nan_mean.data() + file.find(SectionId::kMeans)->offset + (whole.first + 3) * 12 + 4, &nan, 4);
  ReadOptions unchecked;
  unchecked.verify_checksums = false;
  const RgsFile damaged = must_open(nan_mean, unchecked);
  for (uint64_t b = 0; b < n; b += 2) {
    const Status s = damaged.read_lod_slice(0, 1, target, b, std::min(n, b + 2));
    if (b == 2) {
      CHECK(s.code() == StatusCode::kCorruptData);
      CHECK_MESSAGE(s.message().find("lod chunk 1 level 0: means") != std::string::npos, s.to_string());
      CHECK_MESSAGE(s.message().find(std::to_string(whole.first + 3)) != std::string::npos, s.to_string());
    } else {
      CHECK_MESSAGE(s.ok(), s.to_string());
    }
  }

  LodRangeTarget no_sh{nullptr, nullptr, nullptr, nullptr, nullptr, nullptr};
  std::vector<uint8_t> room(1 << 16);
  no_sh.means = no_sh.rotations = no_sh.scales = no_sh.opacities = room.data();
  auto missing = file.read_lod_range(0, 0, no_sh);
  REQUIRE_FALSE(missing.ok());
  CHECK(missing.status().code() == StatusCode::kInvalidArgument);
  CHECK(missing.status().message().find("without a destination") != std::string::npos);
  auto outside = file.read_lod_range(3, 0, no_sh);
  REQUIRE_FALSE(outside.ok());
  CHECK(outside.status().message().find("outside its 3 chunks of 3 levels") != std::string::npos);
}

TEST_CASE("lod: a damaged byte fails its own range's checksum and no other (one chunk checked alone)") {
  const LodScene lod = make_lod_scene(3, 3, 12, 51);
  const std::vector<uint8_t> good = must_serialize(lod);
  const RgsFile reference = must_open(good);
  const uint32_t level = 1, chunk = 2;
  const LodLevel target = reference.lod()->at(level, chunk);
  const size_t k3 = 3 * sh_coefficient_count(lod.scene.metadata.sh_degree);
  // One SH byte of the range's second Gaussian, changed to another valid value (not -128).
  std::vector<uint8_t> bad = good;
  const size_t at = reference.find(SectionId::kSh)->offset + (target.first + 1) * k3 + 5;
  bad[at] = static_cast<uint8_t>(bad[at] == 0x05 ? 0x06 : 0x05);
  REQUIRE(bad[at] != good[at]);

  const RgsFile file = must_open(bad);  // open() reads no per-Gaussian byte
  for (uint32_t l = 0; l < 3; ++l) {
    for (uint32_t c = 0; c < 3; ++c) {
      CAPTURE(l);
      CAPTURE(c);
      auto range = file.lod_range(l, c);
      if (l == level && c == chunk) {
        REQUIRE_FALSE(range.ok());
        CHECK(range.status().code() == StatusCode::kChecksumMismatch);
        CHECK(range.status().message().find("lod.rgs: lod chunk 2 level 1: checksum") != std::string::npos);
      } else {
        CHECK_MESSAGE(range.ok(), range.status().to_string());
      }
    }
  }
  // The whole file fails validation: first at the sh section's own checksum, and with that one recomputed, at the
  // range's.
  Status valid = validate(bad.data(), bad.size(), ReadLimits{}, "lod.rgs");
  CHECK(valid.code() == StatusCode::kChecksumMismatch);
  CHECK(valid.message().find("(sh): checksum") != std::string::npos);
  test::fix_section_checksum(bad, static_cast<size_t>(file.find(SectionId::kSh) - file.sections().data()));
  valid = validate(bad.data(), bad.size(), ReadLimits{}, "lod.rgs");
  CHECK(valid.code() == StatusCode::kChecksumMismatch);
  CHECK(valid.message().find("lod chunk 2 level 1: checksum") != std::string::npos);
  // read_scene() checks whole sections (their checksums now match), not ranges: the value is a valid one.
  CHECK(must_open(bad).read_scene().ok());

  // Without checksum verification the range's values are still checked, and they are valid.
  ReadOptions unchecked;
  unchecked.verify_checksums = false;
  CHECK(must_open(bad, unchecked).lod_range(level, chunk).ok());

  // A damaged value is reported by the range's value rules once its checksum is skipped.
  std::vector<uint8_t> nan_mean = good;
  const size_t mean_at = reference.find(SectionId::kMeans)->offset + target.first * 12;
  const float nan = NAN;
  std::memcpy(nan_mean.data() + mean_at, &nan, 4);
  auto range = must_open(nan_mean, unchecked).lod_range(level, chunk);
  REQUIRE_FALSE(range.ok());
  CHECK(range.status().code() == StatusCode::kCorruptData);
  CHECK(range.status().message().find("lod chunk 2 level 1: means") != std::string::npos);
  CHECK(must_open(nan_mean).lod_range(level, chunk).status().code() == StatusCode::kChecksumMismatch);
  CHECK(must_open(nan_mean).lod_range(0, 0).ok());
}
