// GaussianSplats3D .ksplat: the files its own converter wrote from shipped PLY scenes (tests/data/ksplat,
// make_ksplat_fixtures.mjs) against their source, SH degree 3 through an encoder written from the layout, and
// inputs that must fail.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "interop_test_util.h"
#include "ply_test_util.h"
#include "rgs/converter/gaussian_pairing.h"
#include "rgs/converter/ksplat_reader.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/half.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::InteropReadOptions;

constexpr double kC0 = 0.28209479177387814;

void put32(std::vector<uint8_t>* b, size_t at, uint32_t v) { std::memcpy(b->data() + at, &v, 4); }
void put16(std::vector<uint8_t>* b, size_t at, uint16_t v) { std::memcpy(b->data() + at, &v, 2); }
void putf(std::vector<uint8_t>* b, size_t at, float v) { std::memcpy(b->data() + at, &v, 4); }

uint32_t u32_at(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
float f32_at(const std::vector<uint8_t>& b, size_t at) {
  float v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

/// The first `n` Gaussians of `c`.
format::GaussianCloud first_gaussians(const format::GaussianCloud& c, size_t n) {
  format::GaussianCloud out;
  out.sh_degree = c.sh_degree;
  const size_t k3 = c.sh_coefficients() * 3;
  out.means.assign(c.means.begin(), c.means.begin() + n * 3);
  out.rotations.assign(c.rotations.begin(), c.rotations.begin() + n * 4);
  out.scales.assign(c.scales.begin(), c.scales.begin() + n * 3);
  out.opacities.assign(c.opacities.begin(), c.opacities.begin() + n);
  out.sh.assign(c.sh.begin(), c.sh.begin() + n * k3);
  return out;
}

struct Fixture {
  const char* file;
  const char* source;
  size_t count;
  uint32_t level, sh_degree, sections;
};

/// The bounds, per attribute, of what the file's writer can change (GaussianSplats3D 0.4.7's SplatBuffer):
/// - positions: level 0 copies float32 (exact); levels 1-2 round the offset from the bucket centre to steps of
///   block size / 2 / 32767 = 7.63e-5 (block 5): half a step, and float32 rounding of the sum;
/// - linear scales, quaternion components and (level 1) SH rest values: level 0 copies float32 (quaternions
///   normalized first: 1e-6); levels 1-2 store float16 through three.js's DataUtils.toHalfFloat, which truncates
///   the float32 value towards zero: the decoded magnitude lies in (|v| − 2^-10·|v| − 2^-24, |v|] (one float16 ulp,
///   2^-24 in float16's subnormal range), so a quaternion component moves by less than 2^-11 and the rotation by
///   less than 2·asin(2 · 2^-11) = 0.112°;
/// - colour and opacity: floor(255 · value), so the decoded value lies in (value − 1/255, value] in colour units
///   (f_dc: 1/(255 · C0) = 0.0139), colours clamped to [0, 1] first;
/// - SH rest at level 2: floor over [min, max] in 255 steps: the decoded value lies in (v − (max − min)/255, v].
TEST_CASE("ksplat: the files GaussianSplats3D 0.4.7 wrote match their source PLY within the format's steps") {
  const Fixture fixtures[] = {
      {"guitar_256_l0.ksplat", "tests/data/interop/guitar_256.ply", 256, 0, 0, 1},
      {"guitar_256_l1.ksplat", "tests/data/interop/guitar_256.ply", 256, 1, 0, 1},
      {"guitar_256_l2.ksplat", "tests/data/interop/guitar_256.ply", 256, 2, 0, 1},
      {"guitar_sh3_1024_l0_sh1.ksplat", kGuitarSh3, 1024, 0, 1, 1},
      {"guitar_sh3_1024_l1_sh2.ksplat", kGuitarSh3, 1024, 1, 2, 3},
      {"guitar_sh3_1024_l2_sh2.ksplat", kGuitarSh3, 1024, 2, 2, 1},
  };
  for (const Fixture& f : fixtures) {
    const std::string file = f.file;
    CAPTURE(file);
    const std::string path = repo_path(std::string("tests/data/ksplat/") + f.file);
    const std::vector<uint8_t> bytes = load_bytes(path);
    REQUIRE(bytes.size() < (1u << 20));
    CHECK(converter::looks_like_ksplat(bytes.data(), bytes.size(), bytes.size()));
    CHECK(bytes[20] == f.level);
    CHECK(u32_at(bytes, 4) == f.sections);
    auto source = converter::read_ply(repo_path(f.source));
    REQUIRE(source.ok());
    const format::GaussianCloud ref = first_gaussians(source->cloud, f.count);
    auto r = converter::read_ksplat(path);
    REQUIRE_MESSAGE(r.ok(), r.status().to_string());
    const format::GaussianCloud& got = r->cloud;
    REQUIRE(got.size() == f.count);  // minimum alpha 0: every Gaussian kept
    CHECK(r->declared_gaussians == f.count);
    CHECK(got.sh_degree == f.sh_degree);
    CHECK(r->hygiene.dropped_gaussians == 0);
    // The writer reorders (by distance to the scene centre, then by bucket): pair by content.
    converter::PairingOptions po;
    po.max_position_distance = 1e-3;
    auto pairing = converter::pair_gaussians(ref, got, po);
    REQUIRE(pairing.ok());
    REQUIRE(pairing->complete());
    CHECK(pairing->unpaired_reference == 0);
    const double step = f.level == 0 ? 0 : 5.0 / 2 / 32767;
    // Magnitude lost to float16 truncation (levels 1-2), or float32 rounding (level 0): within [-lo, hi].
    auto truncated = [&](double v, double decoded) {
      const double lost = std::fabs(v) - std::fabs(decoded);
      const double hi = f.level == 0 ? 1e-6 * std::fabs(v) : std::ldexp(std::fabs(v), -10) + std::ldexp(1.0, -24);
      return (v == 0 || decoded == 0 || (v > 0) == (decoded > 0)) && lost >= -1e-7 * std::fabs(v) && lost <= hi;
    };
    const double sh_lo = f32_at(bytes, 36), sh_hi = f32_at(bytes, 40);
    const uint32_t kr = ref.sh_coefficients(), kg = got.sh_coefficients();
    double worst_pos = 0, worst_scale = 0, worst_rot = 0, worst_op = 0, worst_dc = 0, worst_rest = 0;
    size_t outside = 0;
    for (size_t j = 0; j < got.size(); ++j) {
      const size_t i = pairing->reference_of_test[j];
      for (int a = 0; a < 3; ++a) {
        const double e = std::fabs(double{got.means[j * 3 + a]} - ref.means[i * 3 + a]);
        worst_pos = std::max(worst_pos, e);
        outside += e > step / 2 + 2e-7 * (1 + std::fabs(ref.means[i * 3 + a]));
        const double s = ref.scales[i * 3 + a];
        worst_scale = std::max(worst_scale, std::fabs(got.scales[j * 3 + a] - s));
        outside += !truncated(s, got.scales[j * 3 + a]);
      }
      const double rot = rotation_angle_deg(&ref.rotations[i * 4], &got.rotations[j * 4]);
      worst_rot = std::max(worst_rot, rot);
      outside += rot > (f.level == 0 ? 1e-3 : 0.112);
      const double op = ref.opacities[i] - got.opacities[j];
      worst_op = std::max(worst_op, std::fabs(op));
      outside += op < -1e-6 || op > 1.0 / 255 + 1e-6;
      for (int c = 0; c < 3; ++c) {
        const double colour = std::clamp(0.5 + kC0 * ref.sh[i * kr * 3 + c], 0.0, 1.0);
        const double e = colour - (0.5 + kC0 * got.sh[j * kg * 3 + c]);
        worst_dc = std::max(worst_dc, std::fabs(e) / kC0);
        outside += e < -1e-6 || e > 1.0 / 255 + 1e-6;
      }
      for (uint32_t k = 1; k < kg; ++k) {
        for (int c = 0; c < 3; ++c) {
          const double v = ref.sh[(i * kr + k) * 3 + c], e = v - got.sh[(j * kg + k) * 3 + c];
          worst_rest = std::max(worst_rest, std::fabs(e));
          if (f.level < 2) {
            outside += !truncated(v, got.sh[(j * kg + k) * 3 + c]);
          } else {
            outside += e < -1e-6 || e > (sh_hi - sh_lo) / 255 + 1e-6;
          }
        }
      }
    }
    MESSAGE(file << ": position " << worst_pos << ", scale " << worst_scale << ", rotation " << worst_rot
                   << " deg, opacity " << worst_op << ", f_dc " << worst_dc << ", SH rest " << worst_rest);
    CHECK(outside == 0);
    if (f.level > 0) CHECK(worst_pos > step / 4);  // positions did go through the 16-bit grid
  }
}

/// A level-0 .ksplat of `c` in one section, written from the layout in ksplat_reader.h (the package writes SH
/// degree 2 at most from a PLY; degree 3 extends its band order).
std::vector<uint8_t> encode_level0(const format::GaussianCloud& c) {
  const uint32_t rest = 3 * (c.sh_coefficients() - 1);
  const size_t record = 44 + 4 * rest, n = c.size();
  std::vector<uint8_t> b(4096 + 1024 + n * record, 0);
  b[1] = 1;
  put32(&b, 4, 1);
  put32(&b, 8, 1);
  put32(&b, 12, static_cast<uint32_t>(n));
  put32(&b, 16, static_cast<uint32_t>(n));
  put32(&b, 4096, static_cast<uint32_t>(n));
  put32(&b, 4100, static_cast<uint32_t>(n));
  put32(&b, 4096 + 28, static_cast<uint32_t>(n * record));
  put16(&b, 4096 + 40, static_cast<uint16_t>(c.sh_degree));
  const uint32_t k = c.sh_coefficients();
  for (size_t i = 0; i < n; ++i) {
    const size_t r = 5120 + i * record;
    for (int a = 0; a < 3; ++a) putf(&b, r + 4 * a, c.means[i * 3 + a]);
    for (int a = 0; a < 3; ++a) putf(&b, r + 12 + 4 * a, c.scales[i * 3 + a]);
    for (int a = 0; a < 4; ++a) putf(&b, r + 24 + 4 * a, c.rotations[i * 4 + a]);
    for (int ch = 0; ch < 3; ++ch) {
      b[r + 40 + ch] = static_cast<uint8_t>(std::clamp(std::floor((0.5 + kC0 * c.sh[i * k * 3 + ch]) * 255), 0.0, 255.0));
    }
    b[r + 43] = static_cast<uint8_t>(std::floor(c.opacities[i] * 255));
    size_t v = 0;
    for (uint32_t band = 1; band <= c.sh_degree; ++band) {
      for (int ch = 0; ch < 3; ++ch) {
        for (uint32_t m = 0; m < 2 * band + 1; ++m) putf(&b, r + 44 + 4 * v++, c.sh[(i * k + band * band + m) * 3 + ch]);
      }
    }
  }
  return b;
}

TEST_CASE("ksplat: SH degree 3 at level 0 reads back the float32 values bit for bit") {
  const format::GaussianCloud in = make_interop_cloud(300, 3);
  const std::vector<uint8_t> bytes = encode_level0(in);
  auto r = converter::read_ksplat_bytes(bytes.data(), bytes.size(), "sh3.ksplat");
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  REQUIRE(r->cloud.size() == 300);
  REQUIRE(r->cloud.sh_degree == 3);
  CHECK(r->cloud.means == in.means);
  CHECK(r->cloud.scales == in.scales);
  size_t differ = 0;
  for (size_t i = 0; i < in.sh.size(); ++i) differ += (i % (16 * 3)) >= 3 && r->cloud.sh[i] != in.sh[i];
  CHECK(differ == 0);
  for (size_t i = 0; i < 300; ++i) CHECK(rotation_angle_deg(&in.rotations[i * 4], &r->cloud.rotations[i * 4]) < 1e-3);
}

TEST_CASE("ksplat: detection by content, and read_scene") {
  const std::string path = repo_path("tests/data/ksplat/guitar_sh3_1024_l1_sh2.ksplat");
  auto id = converter::detect_scene_format(path);
  REQUIRE(id.ok());
  CHECK(*id == "ksplat");
  auto scene = converter::read_scene(path);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  CHECK(scene->format_id == "ksplat");
  CHECK(scene->cloud.size() == 1024);
  CHECK(scene->description == "GaussianSplats3D .ksplat v0.1");
  REQUIRE(!scene->notes.empty());
  CHECK(scene->notes[0].find("compression level 1") != std::string::npos);
  // Neither a .splat nor a PLY looks like one.
  const std::vector<uint8_t> splat = load_bytes(repo_path("tests/data/interop/guitar_256_splat_transform.splat"));
  CHECK(!converter::looks_like_ksplat(splat.data(), splat.size(), splat.size()));
  const std::vector<uint8_t> ply = load_bytes(repo_path("tests/data/interop/guitar_256.ply"));
  CHECK(!converter::looks_like_ksplat(ply.data(), ply.size(), ply.size()));
}

TEST_CASE("ksplat: inputs that must fail name the cause") {
  const std::vector<uint8_t> l1 = load_bytes(repo_path("tests/data/ksplat/guitar_sh3_1024_l1_sh2.ksplat"));
  const std::vector<uint8_t> l0 = load_bytes(repo_path("tests/data/ksplat/guitar_256_l0.ksplat"));
  auto fails = [](const std::vector<uint8_t>& b, StatusCode code, const std::string& words,
                  const InteropReadOptions& o = {}) {
    auto r = converter::read_ksplat_bytes(b.data(), b.size(), "bad.ksplat", o);
    REQUIRE(!r.ok());
    MESSAGE(r.status().to_string());
    CHECK(r.status().code() == code);
    CHECK(r.status().message().find("bad.ksplat: ") == 0);
    CHECK(r.status().message().find(words) != std::string::npos);
  };
  auto edit = [](std::vector<uint8_t> b, size_t at, uint32_t v, int bytes = 4) {
    if (bytes == 4) put32(&b, at, v); else if (bytes == 2) put16(&b, at, static_cast<uint16_t>(v)); else b[at] = static_cast<uint8_t>(v);
    return b;
  };
  const size_t s1 = 4096 + 1024;  // the second section's header
  fails({}, StatusCode::kCorruptData, "less than the 4096-byte header");
  fails(std::vector<uint8_t>(l1.begin(), l1.end() - 1), StatusCode::kCorruptData, "section 2: ends at byte 80968");
  std::vector<uint8_t> longer = l1;
  longer.push_back(0);
  fails(longer, StatusCode::kCorruptData, "the sections end at byte 80968 but the file has 80969 bytes");
  fails(edit(l1, 0, 1, 1), StatusCode::kUnsupportedVersion, "version 1.1");
  fails(edit(l1, 1, 0, 1), StatusCode::kUnsupportedVersion, "version 0.0");
  fails(edit(l1, 20, 3, 2), StatusCode::kUnsupportedFeature, "compression level 3");
  fails(edit(l1, 8, 2), StatusCode::kCorruptData, "2 of 3 sections");
  fails(edit(l1, 16, 1000), StatusCode::kCorruptData, "1000 of 1024 Gaussians loaded");
  fails(edit(l1, 12, 1023), StatusCode::kCorruptData, "(a partially written file)");
  fails(edit(edit(l1, 4, 0xffffffffu), 8, 0xffffffffu), StatusCode::kCorruptData, "section headers end at byte");
  fails(edit(edit(l1, 4, 4), 8, 4), StatusCode::kCorruptData, "section ");  // the data shifted by one header
  fails(edit(l1, s1, 399), StatusCode::kCorruptData, "section 1: 399 of 400 Gaussians loaded");
  fails(edit(edit(l1, s1, 0xffffffffu), s1 + 4, 0xffffffffu), StatusCode::kCorruptData, "section 1: ends at byte");
  fails(edit(l1, s1 + 40, 4, 2), StatusCode::kUnsupportedFeature, "section 1: SH degree 4");
  // A size that moves the following section: its bucket lengths are read from the wrong bytes.
  fails(edit(l1, s1 + 40, 1, 2), StatusCode::kCorruptData, "section 2: its buckets hold 743352546 Gaussians");
  fails(edit(l1, s1 + 20, 16, 2), StatusCode::kCorruptData, "16 bytes per bucket centre");
  fails(edit(l1, s1 + 32, 2), StatusCode::kCorruptData, "2 full and 1 partially filled buckets, but 2 buckets");
  fails(edit(l1, s1 + 16, 0), StatusCode::kCorruptData, "section 1: bucket block size 0");
  fails(edit(l1, s1 + 16, 0x7fc00000u), StatusCode::kCorruptData, "bucket block size nan");
  fails(edit(l1, s1 + 8, 255), StatusCode::kCorruptData, "section 1: its buckets hold 399 Gaussians, not 400");
  fails(edit(l1, s1 + 8, 0xffffffffu), StatusCode::kCorruptData, "its buckets hold 4294967295 Gaussians");
  // The first partially filled bucket's length, in the section's first bytes.
  const size_t section1 = 4096 + 3 * 1024 + 28828;
  fails(edit(l1, section1, 0x80000000u), StatusCode::kCorruptData, "section 1: its buckets hold");
  InteropReadOptions small;
  small.max_gaussians = 1023;
  fails(l1, StatusCode::kLimitExceeded, "1024 Gaussians, above the limit of 1023", small);
  // Values: a NaN position, a negative scale, a zero quaternion (level 0, Gaussian 5 at byte 5120 + 5 · 44).
  const size_t g5 = 5120 + 5 * 44;
  fails(edit(l0, g5, 0x7fc00000u), StatusCode::kCorruptData, "non-finite");
  fails(edit(l0, g5 + 16, 0xbf800000u), StatusCode::kCorruptData, "Gaussian 5 has a negative scale");
  std::vector<uint8_t> zero_rot = l0;
  std::fill(zero_rot.begin() + g5 + 24, zero_rot.begin() + g5 + 40, 0);
  fails(zero_rot, StatusCode::kCorruptData, "zero");
  InteropReadOptions sanitize;
  sanitize.invalid_policy = converter::InvalidPolicy::kSanitize;
  auto r = converter::read_ksplat_bytes(zero_rot.data(), zero_rot.size(), "z.ksplat", sanitize);
  REQUIRE(r.ok());
  CHECK(r->cloud.size() == 255);
  CHECK(r->hygiene.zero_norm_quaternions == 1);
  CHECK(r->hygiene.first_invalid_index == 5);
  // An infinite 8-bit SH range decodes to non-finite SH values (level 2).
  const std::vector<uint8_t> l2 = load_bytes(repo_path("tests/data/ksplat/guitar_sh3_1024_l2_sh2.ksplat"));
  fails(edit(l2, 40, 0x7f800000u), StatusCode::kCorruptData, "non-finite");
}

}  // namespace
}  // namespace rgs::test
