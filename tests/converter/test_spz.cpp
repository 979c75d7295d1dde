// SPZ: the real biker.spz against the same capture's PLY, our writer read back (v2, v3, v4), files written
// by splat-transform, frames and the coordinate-system extension, and inputs that must fail.
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "interop_test_util.h"
#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/spz.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::InteropReadOptions;
using converter::InteropScene;
using converter::read_spz_bytes;
using converter::serialize_spz;
using converter::SpzWriteOptions;
using converter::SpzWriteSummary;

InteropScene read_ok(const std::vector<uint8_t>& bytes, const InteropReadOptions& o = {}) {
  auto r = read_spz_bytes(bytes.data(), bytes.size(), "test.spz", o);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

StatusCode read_code(const std::vector<uint8_t>& bytes, const InteropReadOptions& o = {}) {
  auto r = read_spz_bytes(bytes.data(), bytes.size(), "test.spz", o);
  if (!r.ok()) MESSAGE(r.status().to_string());
  return r.status().code();
}

std::vector<uint8_t> encode(const format::GaussianCloud& c, const SpzWriteOptions& o = {},
                            SpzWriteSummary* s = nullptr) {
  auto r = serialize_spz(c, o, s);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

std::vector<uint8_t> gunzip(const std::vector<uint8_t>& in) {
  z_stream zs{};
  REQUIRE(inflateInit2(&zs, 16 + MAX_WBITS) == Z_OK);
  std::vector<uint8_t> out(1 << 20);
  zs.next_in = const_cast<Bytef*>(in.data());
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  REQUIRE(inflate(&zs, Z_FINISH) == Z_STREAM_END);
  out.resize(out.size() - zs.avail_out);
  inflateEnd(&zs);
  return out;
}

std::vector<uint8_t> gzip(const std::vector<uint8_t>& in) {
  z_stream zs{};
  REQUIRE(deflateInit2(&zs, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) == Z_OK);
  std::vector<uint8_t> out(deflateBound(&zs, static_cast<uLong>(in.size())) + 64);
  zs.next_in = const_cast<Bytef*>(in.data());
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  REQUIRE(deflate(&zs, Z_FINISH) == Z_STREAM_END);
  out.resize(out.size() - zs.avail_out);
  deflateEnd(&zs);
  return out;
}

/// Bounds of one SPZ round trip at 8 SH bits (half a quantization step per attribute, plus float slack).
void check_spz_bounds(const format::GaussianCloud& in, const format::GaussianCloud& out, double position_step,
                      uint32_t version) {
  const CloudDiff d = diff_clouds(in, out);
  MESSAGE("SPZ v" << version << " round trip: " << describe(d));
  CHECK(d.position <= position_step / 2 * 1.0001 + 1e-6);
  CHECK(d.log_scale <= 1.0 / 32 + 1e-5);
  CHECK(d.opacity <= 0.5 / 255 + 1e-6);
  CHECK(d.dc <= 0.5 / (0.15 * 255) + 1e-5);
  CHECK(d.rest <= 0.5 / 128 + 1e-6);
  // Smallest three: each of three components within sqrt(1/2)/511/2, about 0.1°. Version 2 stores
  // x, y, z in 8 bits and derives w = sqrt(1 − |xyz|²), whose error grows as w → 0 (near half turns):
  // bounded at 3.5° where |w| >= 0.25, several degrees below (why version 3 changed the encoding).
  if (version >= 3) {
    CHECK(d.rotation_deg <= 0.25);
  } else {
    double worst = 0;
    for (size_t i = 0; i < in.size(); ++i) {
      if (std::fabs(in.rotations[i * 4]) >= 0.25) {
        worst = std::max(worst, rotation_angle_deg(&in.rotations[i * 4], &out.rotations[i * 4]));
      }
    }
    CHECK(worst <= 3.5);
  }
}

TEST_CASE("spz: biker.spz matches biker.ply within both files' quantization") {
  const std::string spz_path = shared_scene("biker.spz");
  const std::string ply_path = shared_scene("biker.ply");
  if (spz_path.empty() || ply_path.empty()) return;
  auto spz = converter::read_spz(spz_path);
  REQUIRE_MESSAGE(spz.ok(), spz.status().to_string());
  auto ply = converter::read_ply(ply_path);
  REQUIRE(ply.ok());
  CHECK(spz->format_version == 4);
  CHECK(spz->stored_frame == "RUB");
  CHECK(spz->frame_converted);
  CHECK(spz->cloud.size() == 152746);
  CHECK(spz->cloud.sh_degree == 0);
  const CloudDiff d = diff_clouds(ply->cloud, spz->cloud);
  MESSAGE("biker.spz vs biker.ply: " << describe(d));
  // SPZ holds ln(scale) in [−10, 5.94] only; count the PLY's scales outside it and bound the others.
  uint64_t clamped = 0;
  double log_scale = 0;
  for (size_t j = 0; j < ply->cloud.scales.size(); ++j) {
    const double l = std::log(double{ply->cloud.scales[j]});
    if (l < -10.0 - 1.0 / 32 || l > 5.9375 + 1.0 / 32) {
      ++clamped;
      continue;
    }
    log_scale = std::max(log_scale, std::fabs(l - std::log(double{spz->cloud.scales[j]})));
  }
  MESSAGE("biker: " << clamped << " scale values below e^-10 clamped by SPZ; others within " << log_scale);
  CHECK(clamped < ply->cloud.scales.size() / 100);
  // biker.ply was decoded from the capture's compressed PLY (positions quantized to 10-11 bits per chunk
  // of 256 Gaussians, log scales to 10-11 bits, colours and alpha to 8 bits, rotations to 3 × 10 bits);
  // the SPZ quantizes the same source independently (2^-12 position steps, 1/16 ln-scale steps, 8-bit
  // colour and alpha, 3 × 9-bit rotations). The bounds add both steps.
  CHECK(d.position <= 0.5 / 4096 + 2e-3);
  CHECK(log_scale <= 1.0 / 32 + 2e-2);
  CHECK(d.opacity <= 1.0 / 255 + 1e-4);
  CHECK(d.dc <= 1.0 / (0.15 * 255) + 2.0 / (0.2820948 * 255));
  CHECK(d.rotation_deg <= 1.0);
  // Without the frame conversion, y and z come out negated.
  InteropReadOptions raw;
  raw.convert_frame = false;
  auto stored = converter::read_spz(spz_path, raw);
  REQUIRE(stored.ok());
  CHECK(stored->cloud.means[1] == -spz->cloud.means[1]);
  CHECK(stored->cloud.means[2] == -spz->cloud.means[2]);
  CHECK(stored->cloud.means[0] == spz->cloud.means[0]);
}

TEST_CASE("spz: our writer read back, versions 2, 3 and 4, SH degrees 0-3") {
  for (uint32_t version : {2u, 3u, 4u}) {
    for (uint32_t degree : {0u, 1u, 3u}) {
      CAPTURE(version);
      CAPTURE(degree);
      const format::GaussianCloud in = make_interop_cloud(500, degree);
      SpzWriteOptions o;
      o.version = version;
      o.sh1_bits = o.sh_rest_bits = 8;
      SpzWriteSummary summary;
      const auto bytes = encode(in, o, &summary);
      CHECK(summary.version == version);
      CHECK(summary.sh_degree == degree);
      CHECK(summary.fractional_bits == 12);
      CHECK(summary.bytes == bytes.size());
      CHECK(summary.scales_clamped == 0);
      CHECK(summary.colors_clamped == 0);
      CHECK(!summary.limitations.empty());
      CHECK(converter::looks_like_spz(bytes.data(), std::min<size_t>(bytes.size(), 4096)));
      const InteropScene out = read_ok(bytes);
      CHECK(out.format_version == version);
      check_spz_bounds(in, out.cloud, summary.position_step, version);
      CHECK(encode(in, o) == bytes);  // deterministic
    }
  }
}

TEST_CASE("spz: default SH bits keep the spz library's buckets, frame flags, large scenes drop fractional bits") {
  const format::GaussianCloud in = make_interop_cloud(200, 2);
  const InteropScene out = read_ok(encode(in));
  // 4-bit buckets of 16/128 for degree 2 (5 bits for degree 1): half a bucket after rounding to 1/128.
  CHECK(diff_clouds(in, out.cloud).rest <= 8.5 / 128 + 1e-6);
  SpzWriteOptions keep;
  keep.frame = converter::SpzFrame::kAsStored;
  InteropReadOptions raw;
  raw.convert_frame = false;
  const InteropScene flipped = read_ok(encode(in), raw);
  const InteropScene same = read_ok(encode(in, keep), raw);
  CHECK(std::fabs(flipped.cloud.means[1] + same.cloud.means[1]) < 1e-3);
  CHECK(std::fabs(flipped.cloud.means[0] - same.cloud.means[0]) < 1e-3);
  format::GaussianCloud big = make_interop_cloud(10, 0);
  big.means[4] = 30000.0f;
  SpzWriteSummary s;
  const InteropScene back = read_ok(encode(big, {}, &s));
  CHECK(s.fractional_bits == 8);  // 30000 · 2^8 < 2^23
  CHECK(std::fabs(back.cloud.means[4] - 30000.0f) <= 1.0 / 512);
  SpzWriteOptions fixed;
  fixed.fractional_bits = 12;
  CHECK(!serialize_spz(big, fixed).ok());
}

TEST_CASE("spz: files written by splat-transform 3.7.0 (v3 and v4) decode to their source PLY") {
  auto ply = converter::read_ply(repo_path("tests/data/interop/guitar_256.ply"));
  REQUIRE(ply.ok());
  for (const char* file : {"guitar_256_splat_transform_v3.spz", "guitar_256_splat_transform_v4.spz"}) {
    CAPTURE(file);
    // splat-transform stores the PLY's axes unconverted (from/to UNSPECIFIED), so read them as stored.
    InteropReadOptions raw;
    raw.convert_frame = false;
    auto spz = converter::read_spz(repo_path(std::string("tests/data/interop/") + file), raw);
    REQUIRE_MESSAGE(spz.ok(), spz.status().to_string());
    const CloudDiff d = diff_clouds(ply->cloud, spz->cloud);
    MESSAGE(file << ": " << describe(d));
    CHECK(d.position <= 0.5 / 4096 + 1e-6);
    double log_scale = 0;  // ln scales below −10 are clamped by SPZ
    for (size_t j = 0; j < ply->cloud.scales.size(); ++j) {
      const double l = std::log(double{ply->cloud.scales[j]});
      if (l >= -10.0) log_scale = std::max(log_scale, std::fabs(l - std::log(double{spz->cloud.scales[j]})));
    }
    CHECK(log_scale <= 1.0 / 32 + 1e-5);
    CHECK(d.opacity <= 0.5 / 255 + 1e-6);
    CHECK(d.dc <= 0.5 / (0.15 * 255) + 1e-5);
    CHECK(d.rotation_deg <= 0.25);
  }
}

TEST_CASE("spz: coordinate-system extension sets the stored frame") {
  const format::GaussianCloud in = make_interop_cloud(50, 1);
  SpzWriteOptions keep;
  keep.frame = converter::SpzFrame::kAsStored;  // stored as RDF...
  std::vector<uint8_t> bytes = encode(in, keep);
  // ...and say so: an extension record [0xADBE0003][4][6 = RDF] between header and TOC.
  std::vector<uint8_t> ext = {0x03, 0x00, 0xBE, 0xAD, 4, 0, 0, 0, 6, 0, 0, 0};
  bytes.insert(bytes.begin() + 32, ext.begin(), ext.end());
  bytes[14] |= 0x2;
  bytes[16] = 32 + 12;
  const InteropScene out = read_ok(bytes);
  CHECK(out.stored_frame == "RDF");
  CHECK(out.frame_declared);
  CHECK(diff_clouds(in, out.cloud).position <= 0.5 / 4096 + 1e-6);
  // The file tells, so the assumption for files that do not (convert_frame) changes nothing...
  InteropReadOptions raw;
  raw.convert_frame = false;
  CHECK(diff_clouds(in, read_ok(bytes, raw).cloud).position <= 0.5 / 4096 + 1e-6);
  // ...and a declared RUB is turned even when files without the record are read as stored.
  std::vector<uint8_t> rub = encode(in);  // stored as RUB
  rub.insert(rub.begin() + 32, ext.begin(), ext.end());
  rub[14] |= 0x2;
  rub[16] = 32 + 12;
  rub[32 + 8] = 4;  // RUB: value − 1 = 0b011 (R, U, B)
  const InteropScene declared_rub = read_ok(rub, raw);
  CHECK(declared_rub.stored_frame == "RUB");
  CHECK(declared_rub.frame_converted);
  CHECK(diff_clouds(in, declared_rub.cloud).position <= 0.5 / 4096 + 1e-6);
  bytes[32 + 8] = 11;  // LFU: a rotated frame
  CHECK(read_code(bytes) == StatusCode::kUnsupportedFeature);
  bytes[32 + 4] = 40;  // record longer than the block
  CHECK(read_code(bytes) == StatusCode::kCorruptData);
}

TEST_CASE("spz: each frame round-trips with itself and turns the scene over with the other") {
  const format::GaussianCloud in = make_interop_cloud(200, 2);
  for (const converter::SpzFrame written : {converter::SpzFrame::kRub, converter::SpzFrame::kAsStored}) {
    CAPTURE(converter::spz_frame_name(written));
    SpzWriteOptions o;
    o.frame = written;
    const std::vector<uint8_t> bytes = encode(in, o);
    InteropReadOptions same, other;
    same.convert_frame = written == converter::SpzFrame::kRub;
    other.convert_frame = !same.convert_frame;
    const InteropScene right = read_ok(bytes, same), wrong = read_ok(bytes, other);
    CHECK_FALSE(right.frame_declared);
    CHECK(diff_clouds(in, right.cloud).position <= 0.5 / 4096 + 1e-6);
    // Read with the other frame, y and z come back negated: upside down.
    CHECK(diff_clouds(in, wrong.cloud).position > 0.1);
    for (size_t i = 0; i < right.cloud.size(); ++i) {
      CHECK(wrong.cloud.means[i * 3 + 0] == right.cloud.means[i * 3 + 0]);
      CHECK(wrong.cloud.means[i * 3 + 1] == -right.cloud.means[i * 3 + 1]);
      CHECK(wrong.cloud.means[i * 3 + 2] == -right.cloud.means[i * 3 + 2]);
    }
  }
}

TEST_CASE("spz: inputs that must fail") {
  const format::GaussianCloud in = make_interop_cloud(300, 1);
  const std::vector<uint8_t> v4 = encode(in);
  SpzWriteOptions o3;
  o3.version = 3;
  const std::vector<uint8_t> v3 = encode(in, o3);
  auto patched = [](std::vector<uint8_t> b, size_t at, uint8_t v) {
    b[at] = v;
    return b;
  };
  SUBCASE("empty and foreign") {
    CHECK(read_code({}) == StatusCode::kCorruptData);
    CHECK(read_code({'p', 'l', 'y', '\n'}) == StatusCode::kCorruptData);
    CHECK(!converter::looks_like_spz(reinterpret_cast<const uint8_t*>("ply\n"), 4));
  }
  SUBCASE("truncated v4 header, TOC and streams") {
    for (size_t cut : {size_t{20}, size_t{40}, v4.size() / 2, v4.size() - 1}) {
      CAPTURE(cut);
      CHECK(read_code(std::vector<uint8_t>(v4.begin(), v4.begin() + cut)) == StatusCode::kIoError);
    }
  }
  SUBCASE("v4 header fields") {
    CHECK(read_code(patched(v4, 4, 5)) == StatusCode::kUnsupportedVersion);
    CHECK(read_code(patched(v4, 4, 3)) == StatusCode::kUnsupportedVersion);
    // A version field no SPZ has is damage, and the file is still recognised as an SPZ file.
    for (const auto& [at, value] : {std::pair<size_t, uint8_t>{4, 0}, {6, 0xc7}, {7, 0x01}}) {
      const std::vector<uint8_t> damaged = patched(v4, at, value);
      CHECK(converter::looks_like_spz(damaged.data(), damaged.size()));
      auto r = read_spz_bytes(damaged.data(), damaged.size(), "test.spz", {});
      CHECK(r.status().code() == StatusCode::kCorruptData);
      CHECK_MESSAGE(r.status().message().find("damaged SPZ file: its version field reads") != std::string::npos,
                    r.status().to_string());
    }
    CHECK(read_code(patched(v4, 12, 4)) == StatusCode::kUnsupportedFeature);
    CHECK(read_code(patched(v4, 12, 9)) == StatusCode::kCorruptData);
    CHECK(read_code(patched(v4, 15, 5)) == StatusCode::kCorruptData);    // stream count
    CHECK(read_code(patched(v4, 25, 1)) == StatusCode::kCorruptData);    // reserved
    CHECK(read_code(patched(v4, 8, 0x2d)) == StatusCode::kCorruptData);  // count ≠ stream sizes
    InteropReadOptions unlimited;
    unlimited.max_gaussians = UINT32_MAX;
    CHECK(read_code(patched(v4, 11, 0x7f), unlimited) == StatusCode::kCorruptData);
    CHECK(read_code(patched(v4, 16, 31)) == StatusCode::kCorruptData);   // TOC inside the header
  }
  SUBCASE("count over the limit is refused before allocating") {
    InteropReadOptions small;
    small.max_gaussians = 299;
    CHECK(read_code(v4, small) == StatusCode::kLimitExceeded);
    CHECK(read_code(v3, small) == StatusCode::kLimitExceeded);
    // A 2^31 − 1 point header in a small gzip member: more than deflate can expand to.
    std::vector<uint8_t> plain = gunzip(v3);
    plain[8] = plain[9] = plain[10] = 0xff;
    plain[11] = 0x7f;
    InteropReadOptions unlimited;
    unlimited.max_gaussians = UINT32_MAX;
    CHECK(read_code(gzip(plain), unlimited) == StatusCode::kCorruptData);
  }
  SUBCASE("corrupt zstd payload: content checksum") {
    std::vector<uint8_t> b = v4;
    b[b.size() - 10] ^= 0x55;
    const StatusCode c = read_code(b);
    CHECK((c == StatusCode::kChecksumMismatch || c == StatusCode::kCorruptData));
  }
  SUBCASE("legacy gzip: wrong version, bad deflate data, CRC, truncation, trailing data") {
    std::vector<uint8_t> plain = gunzip(v3);
    plain[4] = 1;
    CHECK(read_code(gzip(plain)) == StatusCode::kUnsupportedVersion);
    plain[4] = 4;
    CHECK(read_code(gzip(plain)) == StatusCode::kUnsupportedVersion);
    plain[4] = 3;
    CHECK(read_ok(gzip(plain)).cloud.size() == 300);
    std::vector<uint8_t> extra = plain;
    extra.push_back(0);
    CHECK(read_code(gzip(extra)) == StatusCode::kCorruptData);  // bytes after the arrays, no extension flag
    std::vector<uint8_t> shorter(plain.begin(), plain.end() - 5);
    CHECK(read_code(gzip(shorter)) == StatusCode::kCorruptData);
    std::vector<uint8_t> crc = v3;
    crc[crc.size() - 6] ^= 0xff;  // CRC-32 in the gzip trailer
    CHECK(read_code(crc) == StatusCode::kChecksumMismatch);
    std::vector<uint8_t> bad = v3;
    for (size_t i = 12; i < 40; ++i) bad[i] = 0xff;
    const StatusCode c = read_code(bad);
    CHECK((c == StatusCode::kCorruptData || c == StatusCode::kChecksumMismatch));
    CHECK(read_code(std::vector<uint8_t>(v3.begin(), v3.begin() + v3.size() / 2)) == StatusCode::kIoError);
    std::vector<uint8_t> trailing = v3;
    trailing.push_back(0);
    CHECK(read_code(trailing) == StatusCode::kCorruptData);
  }
  SUBCASE("writer arguments") {
    SpzWriteOptions bad;
    bad.version = 5;
    CHECK(serialize_spz(in, bad).status().code() == StatusCode::kInvalidArgument);
    format::GaussianCloud nan = in;
    nan.means[7] = std::nanf("");
    CHECK(serialize_spz(nan).status().code() == StatusCode::kInvalidArgument);
  }
}

}  // namespace
}  // namespace rgs::test
