// Archive profile (SPEC §3.3): round-trip bounds, determinism, must-fail files (truncated Draco stream,
// wrong counts, unknown codec, missing required flag).
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "internal_xz.h"
#include "rgs/format/archive.h"
#include "rgs/format/half.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

using namespace rgs;
using namespace rgs::test;

format::WriteOptions archive_options() {
  format::WriteOptions o;
  o.profile = format::StorageProfile::kArchive;
  return o;
}

/// The archive file of `scene` written with `options` decodes to `decoded` (encode_archive's scene).
void check_file_decodes_to(const format::EncodedScene& scene, const format::ArchiveOptions& options,
                           const format::EncodedScene& decoded) {
  format::WriteOptions w = archive_options();
  w.archive = options;
  auto bytes = format::serialize_scene(scene, w);
  REQUIRE(bytes.ok());
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  REQUIRE(file.ok());
  auto read = file->read_scene();
  REQUIRE(read.ok());
  check_same_scene(*read, decoded);
}

/// Index of the table entry of section `id` in a serialized file.
size_t entry_index(const std::vector<uint8_t>& b, format::SectionId id) {
  const uint32_t count = get_u32(b, 32);
  for (size_t i = 0; i < count; ++i) {
    if (get_u32(b, entry_at(i)) == static_cast<uint32_t>(id)) return i;
  }
  return SIZE_MAX;
}

}  // namespace

TEST_CASE("archive: sections lent by an earlier archive give the archive encoded from scratch") {
  const format::EncodedScene scene = make_random_scene(3000, 2, 11);
  format::ArchiveOptions base;
  base.rotation_bits = 9;
  base.scale_bits = 8;
  base.opacity_bits = 7;
  auto earlier = format::encode_archive(scene, base);
  REQUIRE(earlier.ok());
  CHECK(earlier->options.rotation_bits == 9);
  // Some Gaussians are left out (opacity code 0): the lent means and order are mapped through the kept ones,
  // and variants 2, 4 and 9 (other opacity settings) leave out others, so their means are encoded again.
  CHECK(!earlier->omitted.empty());
  // Each setting alone, all of them, the position (which changes the order and so every section), and the
  // zstd level (which changes every section's bytes but the means').
  std::vector<format::ArchiveOptions> variants(10, base);
  variants[0].rotation_bits = 7;
  variants[1].scale_bits = 6;
  variants[2].opacity_bits = 5;
  variants[3].sh_step_multipliers = {2, 4, 6, 8};
  variants[4] = {};
  variants[4].opacity_floor = 0;  // 8 bits leave out fewer than base's 7 (the default floor would match them)
  variants[5].position_error = earlier->options.position_error * 8;
  variants[6].zstd_level = base.zstd_level + 3;
  variants[7].rotation_step = 1.5;
  variants[8].scale_step = 2;
  variants[9].opacity_step = 1.25;
  for (size_t v = 0; v < variants.size(); ++v) {
    CAPTURE(v);
    auto fresh = format::encode_archive(scene, variants[v]);
    auto lent = format::encode_archive(scene, variants[v], &*earlier);
    REQUIRE(fresh.ok());
    REQUIRE(lent.ok());
    for (size_t k = 0; k < 5; ++k) CHECK(lent->stored[k] == fresh->stored[k]);
    CHECK(lent->source_index == fresh->source_index);
    CHECK(lent->omitted == fresh->omitted);
    CHECK((lent->omitted == earlier->omitted) == (v != 2 && v != 4 && v != 9));
    CHECK(lent->position.bits == fresh->position.bits);
    check_same_scene(lent->decoded, fresh->decoded);
    // What was lent is what a reader decodes from the lent bytes.
    check_file_decodes_to(scene, variants[v], lent->decoded);
  }
  CHECK_FALSE(format::encode_archive(make_random_scene(10, 0, 1), base, &*earlier).ok());
}

TEST_CASE("archive: means spanning float32's largest value on an axis are refused, any narrower span has a grid") {
  format::SceneBounds bounds;
  const float big = std::numeric_limits<float>::max();
  for (int a = 0; a < 3; ++a) bounds.aabb_max[a] = 1.f;
  bounds.aabb_min[0] = -big / 2;
  bounds.aabb_max[0] = big / 2;  // an extent of float32's largest value
  auto refused = format::choose_position_quantization(bounds, 1e-3);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
  CHECK(refused.status().message().find("span") != std::string::npos);
  bounds.aabb_max[0] = big / 4;  // three quarters of it
  auto held = format::choose_position_quantization(bounds, 1e-3);
  REQUIRE(held.ok());
  CHECK(std::isfinite(held->range));
  CHECK(double(held->range) >= double(big / 4) + double(big / 2));
}

TEST_CASE("archive: options out of range are refused, naming the option") {
  const format::EncodedScene scene = make_random_scene(100, 1, 3);
  for (double bad : {0.5, 0.0, -1.0, 5000.0, std::numeric_limits<double>::quiet_NaN()}) {
    CAPTURE(bad);
    for (int which = 0; which < 3; ++which) {
      format::ArchiveOptions o;
      (which == 0 ? o.rotation_step : which == 1 ? o.scale_step : o.opacity_step) = bad;
      auto r = format::encode_archive(scene, o);
      REQUIRE_FALSE(r.ok());
      CHECK(r.status().code() == StatusCode::kInvalidArgument);
      CHECK(r.status().message().find(which == 0 ? "rotation step" : which == 1 ? "scale step" : "opacity step") !=
            std::string::npos);
    }
  }
  for (double bad : {-0.01, 1.0, std::numeric_limits<double>::quiet_NaN()}) {
    CAPTURE(bad);
    format::ArchiveOptions o;
    o.opacity_floor = bad;
    auto r = format::encode_archive(scene, o);
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().message().find("opacity floor") != std::string::npos);
  }
  for (double bad : {0.6, -1e-6, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    CAPTURE(bad);
    format::ArchiveOptions o;
    o.position_error = bad;
    const Status checked = format::check_archive_options(o);  // what tools and api::convert check up front
    CHECK(checked.code() == StatusCode::kInvalidArgument);
    CHECK(checked.message().find("position error") != std::string::npos);
    CHECK(format::encode_archive(scene, o).status().code() == StatusCode::kInvalidArgument);
  }
  CHECK(format::check_archive_options({}).ok());
  format::ArchiveOptions o;
  o.rotation_bits = 3;
  CHECK_FALSE(format::check_archive_options(o).ok());
  CHECK_FALSE(format::encode_archive(scene, o).ok());
}

TEST_CASE("archive: an opacity floor leaves out exactly the Gaussians below it, and the file decodes to the rest") {
  format::EncodedScene scene = make_random_scene(4000, 1, 5);
  // Opacities spread over [0, 0.2): 16-bit codes, so no code is 0 above 1/131070 and the floor decides.
  for (uint64_t i = 0; i < scene.count; ++i) {
    scene.opacities[i] = format::float_to_half_bits(0.2f * float(i % 1000) / 1000.0f);
  }
  // The last Gaussian, kept, has the largest scales (e^3 against at most e^1): the scale codes' range is that of
  // the Gaussians kept, not of as many Gaussians from the start of the arrays.
  const uint64_t last = scene.count - 1;
  for (int a = 0; a < 3; ++a) scene.scales[last * 3 + a] = format::float_to_half_bits(std::exp(3.0f));
  format::ArchiveOptions o;
  o.opacity_bits = 16;
  o.opacity_floor = 0.05;
  auto archive = format::encode_archive(scene, o);
  REQUIRE(archive.ok());
  std::vector<uint64_t> expected;
  for (uint64_t i = 0; i < scene.count; ++i) {
    const float opacity = format::half_bits_to_float(scene.opacities[i]);
    if (opacity < 0.05f || std::floor(opacity * 65535.0 + 0.5) == 0) expected.push_back(i);
  }
  CHECK(expected.size() > 900);  // the floor, not the code 0, leaves most of them out
  CHECK(archive->omitted == expected);
  CHECK(archive->decoded.count == scene.count - expected.size());
  for (uint64_t i = 0; i < archive->decoded.count; ++i) {
    CHECK(format::half_bits_to_float(scene.opacities[archive->source_index[i]]) >= 0.05f);
    if (archive->source_index[i] != last) continue;
    for (int a = 0; a < 3; ++a) {
      const float decoded = format::half_bits_to_float(archive->decoded.scales[i * 3 + a]);
      CHECK(decoded == doctest::Approx(std::exp(3.0f)).epsilon(0.02));
    }
  }
  check_file_decodes_to(scene, o, archive->decoded);
  // A floor of 0 leaves out only the Gaussians of opacity code 0.
  o.opacity_floor = 0;
  auto all = format::encode_archive(scene, o);
  REQUIRE(all.ok());
  CHECK(all->omitted.size() == 4);  // opacity 0 at i % 1000 == 0
}

TEST_CASE("archive: round trip within the per-attribute bounds, file decodes to encode_archive's scene") {
  const format::EncodedScene scene = make_random_scene(5000, 3, 7);
  const format::ArchiveOptions options;
  auto archive = format::encode_archive(scene, options);
  REQUIRE(archive.ok());
  auto bytes = format::serialize_scene(scene, archive_options());
  REQUIRE(bytes.ok());
  CHECK(format::validate(bytes->data(), bytes->size()).ok());
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  REQUIRE(file.ok());
  // SH transform 6 sets its flag (1.4); codes the writer stored as .xz set theirs (1.5, SPEC §6).
  const uint32_t xz_sections = count_xz_sections(*bytes);
  CHECK(file->header().minor == (xz_sections > 0 ? 5 : 4));
  CHECK(file->header().required_flags == (format::kRequiredFlagArchiveCodecs |
                                          format::kRequiredFlagShColourDifferences |
                                          (xz_sections > 0 ? format::kRequiredFlagXzCodes : 0u)));
  CHECK(file->find(format::SectionId::kMeans)->codec == format::Codec::kDraco);
  CHECK(file->find(format::SectionId::kSh)->codec == format::Codec::kQuantized);
  auto read = file->read_scene();
  REQUIRE(read.ok());
  check_same_scene(*read, archive->decoded);

  const auto& d = archive->decoded;
  const double step = archive->position.step;
  for (uint64_t i = 0; i < d.count; ++i) {
    const uint64_t s = archive->source_index[i];
    for (int a = 0; a < 3; ++a) {
      CHECK(std::fabs(d.means[i * 3 + a] - scene.means[s * 3 + a]) <=
            0.5 * step * 1.05 + 1e-6);  // plus Draco's float32 arithmetic
    }
    // Rotation: same rotation up to sign, within the smallest-three step.
    double dot = 0;
    for (int a = 0; a < 4; ++a) {
      dot +=
          format::half_bits_to_float(d.rotations[i * 4 + a]) * format::half_bits_to_float(scene.rotations[s * 4 + a]);
    }
    CHECK(std::fabs(dot) > 0.999);
    CHECK(std::fabs(format::half_bits_to_float(d.opacities[i]) - format::half_bits_to_float(scene.opacities[s])) <=
          0.5 / 255 + 1e-3);
    const uint32_t values = 48;
    for (uint32_t c = 0; c < values; ++c) {
      const int m = static_cast<int>(archive->options.sh_step_multipliers[format::sh_degree_of_coefficient(c / 3)]);
      CHECK(std::abs(d.sh[i * values + c] - scene.sh[s * values + c]) <= m);
    }
  }
}

TEST_CASE("archive: a scene with the DC residual is archived at the INT8 DC step, without the residual section") {
  format::EncodedScene scene = make_random_scene(2000, 0, 11);
  auto plain = format::serialize_scene(scene, archive_options());
  REQUIRE(plain.ok());
  scene.sh_dc_residual.assign(scene.count * 3, int8_t{-77});
  auto bytes = format::serialize_scene(scene, archive_options());
  REQUIRE(bytes.ok());
  CHECK(*bytes == *plain);
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  REQUIRE(file.ok());
  CHECK(file->find(format::SectionId::kShDcResidual) == nullptr);
  CHECK(file->header().minor == (count_xz_sections(*bytes) > 0 ? 5 : 4));  // not gated by the residual's 1.2
}

TEST_CASE("archive: each section's codes in the smaller of a zstd frame and an .xz stream, the same values") {
  // Skewed codes, as trained scenes have (most opacities high, scales and colours clustered): LZMA's adaptive
  // coding beats zstd's on some sections.
  format::EncodedScene scene = make_random_scene(20000, 1, 23);
  std::mt19937 rng(5);
  std::normal_distribution<float> clustered(0, 1);
  for (uint64_t i = 0; i < scene.count; ++i) {
    scene.opacities[i] = format::float_to_half_bits(std::min(1.0f, 0.9f + 0.05f * std::fabs(clustered(rng))));
    for (int a = 0; a < 3; ++a) {
      scene.scales[i * 3 + a] = format::float_to_half_bits(std::exp(-4 + 0.3f * clustered(rng)));
    }
  }
  format::WriteOptions zstd = archive_options(), xz = archive_options();
  zstd.archive.xz = false;
  auto a = format::serialize_scene(scene, zstd), b = format::serialize_scene(scene, xz);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  CHECK(count_xz_sections(*a) == 0);
  const uint32_t xz_sections = count_xz_sections(*b);
  CHECK(xz_sections > 0);
  CHECK(b->size() < a->size());
  auto fa = format::RgsFile::from_bytes(a->data(), a->size());
  auto fb = format::RgsFile::from_bytes(b->data(), b->size());
  REQUIRE(fa.ok());
  REQUIRE(fb.ok());
  CHECK(fa->header().minor == 4);
  CHECK(fb->header().minor == 5);
  CHECK((fb->header().required_flags & format::kRequiredFlagXzCodes) != 0);
  for (format::SectionId id : {format::SectionId::kRotations, format::SectionId::kScales,
                               format::SectionId::kOpacities, format::SectionId::kSh}) {
    CAPTURE(static_cast<uint32_t>(id));
    CHECK(fb->find(id)->stored_size <= fa->find(id)->stored_size);  // never larger than the zstd frame
  }
  auto ra = fa->read_scene(), rb = fb->read_scene();
  REQUIRE(ra.ok());
  REQUIRE(rb.ok());
  check_same_scene(*ra, *rb);
  CHECK(format::validate(b->data(), b->size()).ok());
}

TEST_CASE("archive: an .xz stream of several blocks has the same bytes whatever the threads, and decodes") {
  // Blocks of 8 MiB (SPEC §7): 17 MiB make three for the planes' near matches, 9 MiB two for the records' far ones.
  using format::detail::XzMatches;
  for (auto [matches, mib] : {std::pair{XzMatches::kNear, 17}, std::pair{XzMatches::kFar, 9}}) {
    CAPTURE(mib);
    // Skewed bytes, or for the far matches records of 24 drawn from 4,096 (as a codebook-trained scene's SH).
    std::vector<uint8_t> raw(size_t(mib) << 20), palette(4096 * 24);
    std::mt19937 rng(3);
    std::geometric_distribution<int> skewed(0.2);
    for (uint8_t& v : palette) v = static_cast<uint8_t>(skewed(rng));
    if (matches == XzMatches::kNear) {
      for (uint8_t& v : raw) v = static_cast<uint8_t>(skewed(rng));
    } else {
      for (size_t i = 0; i + 24 <= raw.size(); i += 24) {
        std::copy_n(palette.begin() + 24 * (rng() % 4096), 24, raw.begin() + static_cast<ptrdiff_t>(i));
      }
    }
    std::vector<uint8_t> one, three;
    REQUIRE(format::detail::compress_xz_stream(raw.data(), raw.size(), 4, matches, 1, &one).ok());
    REQUIRE(format::detail::compress_xz_stream(raw.data(), raw.size(), 4, matches, 3, &three).ok());
    CHECK(one == three);
    CHECK(format::detail::check_xz_stream(one.data(), one.size(), raw.size()).ok());
    CHECK(format::detail::check_xz_stream(one.data(), one.size(), raw.size() - 1).code() == StatusCode::kCorruptData);
    std::vector<uint8_t> back(raw.size());
    REQUIRE(format::detail::decode_xz_stream(one.data(), one.size(), back.data(), back.size()).ok());
    CHECK(back == raw);
  }
}

TEST_CASE("archive: deterministic whatever the thread count") {
  const format::EncodedScene scene = make_random_scene(3000, 2, 11);
  format::WriteOptions one = archive_options(), four = archive_options();
  one.archive.threads = 1;
  four.archive.threads = 4;
  auto a = format::serialize_scene(scene, one), b = format::serialize_scene(scene, four),
       c = format::serialize_scene(scene, one);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  REQUIRE(c.ok());
  CHECK(*a == *b);
  CHECK(*a == *c);
}

TEST_CASE("archive: must-fail files") {
  const format::EncodedScene scene = make_random_scene(2000, 1, 3);
  auto good = format::serialize_scene(scene, archive_options());
  REQUIRE(good.ok());
  const size_t means = entry_index(*good, format::SectionId::kMeans);
  const size_t sh = entry_index(*good, format::SectionId::kSh);
  REQUIRE(means != SIZE_MAX);

  SUBCASE("truncated Draco stream") {
    std::vector<uint8_t> b = *good;
    // Keep the header and the point count, zero the rest of the stream: Draco must refuse it.
    const uint64_t off = get_u64(b, entry_at(means) + 24), size = get_u64(b, entry_at(means) + 32);
    for (uint64_t i = off + 40; i < off + size; ++i) b[i] = 0;
    fix_all_checksums(b);
    const Status s = format::validate(b.data(), b.size());
    CHECK(s.code() == StatusCode::kCorruptData);
  }
  SUBCASE("Draco point count differs from N") {
    std::vector<uint8_t> b = *good;
    const uint64_t off = get_u64(b, entry_at(means) + 24);
    put_u32(b, off + 11, 1999);
    fix_all_checksums(b);
    CHECK(format::validate(b.data(), b.size()).code() == StatusCode::kCorruptData);
  }
  SUBCASE("quantized component count wrong") {
    std::vector<uint8_t> b = *good;
    const uint64_t off = get_u64(b, entry_at(sh) + 24);
    put_u32(b, off + 4, 13);
    fix_all_checksums(b);
    CHECK(format::validate(b.data(), b.size()).code() == StatusCode::kCorruptData);
  }
  SUBCASE("unknown codec on a known section") {
    std::vector<uint8_t> b = *good;
    put_u16(b, entry_at(means) + 4, 9);
    fix_all_checksums(b);
    CHECK(format::validate(b.data(), b.size()).code() == StatusCode::kUnsupportedFeature);
  }
  SUBCASE("archive codec without the required flag") {
    std::vector<uint8_t> b = *good;
    put_u32(b, 16, 0);
    fix_header_checksum(b);
    CHECK(format::validate(b.data(), b.size()).code() == StatusCode::kCorruptData);
  }
  SUBCASE("a decoded archive value that breaks a value rule: refused by validate and read_scene") {
    // The scales' offset of axis 0 (the quantized header's first parameter) moved to 1e6: finite, so the header
    // parses, but every decoded scale of that axis overflows FP16. read_scene decodes an archive section once and
    // checks it there (decode_verified_section) instead of verifying it beforehand.
    std::vector<uint8_t> b = *good;
    const size_t scales = entry_index(b, format::SectionId::kScales);
    const uint64_t off = get_u64(b, entry_at(scales) + 24);
    uint32_t huge = 0;
    const float value = 1e6f;
    std::memcpy(&huge, &value, 4);
    put_u32(b, off + 8, huge);
    fix_all_checksums(b);
    CHECK(format::validate(b.data(), b.size()).code() == StatusCode::kCorruptData);
    auto file = format::RgsFile::from_bytes(b.data(), b.size(), format::ReadOptions{}, "bad_scale.rgs");
    REQUIRE(file.ok());
    auto read = file->read_scene();
    REQUIRE_FALSE(read.ok());
    CHECK(read.status().code() == StatusCode::kCorruptData);
    CHECK(read.status().message().find("bad_scale.rgs") != std::string::npos);
    CHECK(read.status().message().find("scales") != std::string::npos);
    std::vector<uint8_t> raw(file->gaussian_count() * 3 * 2);
    CHECK(file->decode_section(format::SectionId::kScales, raw.data(), raw.size()).ok());  // decodes; values bad
    CHECK(file->decode_verified_section(format::SectionId::kScales, raw.data(), raw.size()).code() ==
          StatusCode::kCorruptData);
  }
  SUBCASE("draco codec on a section other than means") {
    std::vector<uint8_t> b = *good;
    put_u16(b, entry_at(sh) + 4, static_cast<uint16_t>(format::Codec::kDraco));
    fix_all_checksums(b);
    CHECK(format::validate(b.data(), b.size()).code() == StatusCode::kCorruptData);
  }
}
