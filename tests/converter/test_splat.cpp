// antimatter15 .splat: a file written by splat-transform against its source PLY, detection, a round
// trip through an encoder written from the format description, and inputs that must fail.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "interop_test_util.h"
#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/splat_reader.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::InteropReadOptions;

/// Encodes records as antimatter15's convert.py does (truncating float → u8 after clipping).
std::vector<uint8_t> encode_splat(const format::GaussianCloud& c) {
  std::vector<uint8_t> out(c.size() * 32);
  auto to_u8 = [](double v) { return static_cast<uint8_t>(std::clamp(v, 0.0, 255.0)); };
  for (size_t i = 0; i < c.size(); ++i) {
    uint8_t* r = out.data() + i * 32;
    std::memcpy(r, &c.means[i * 3], 12);
    std::memcpy(r + 12, &c.scales[i * 3], 12);
    for (int ch = 0; ch < 3; ++ch) r[24 + ch] = to_u8((0.5 + 0.28209479177387814 * c.sh[i * 3 + ch]) * 255);
    r[27] = to_u8(c.opacities[i] * 255.0);
    for (int a = 0; a < 4; ++a) r[28 + a] = to_u8(c.rotations[i * 4 + a] * 128.0 + 128.0);
  }
  return out;
}

TEST_CASE("splat: round trip within the 8-bit steps, detection") {
  const format::GaussianCloud in = make_interop_cloud(400, 0);
  const std::vector<uint8_t> bytes = encode_splat(in);
  CHECK(converter::looks_like_splat(bytes.data(), std::min<size_t>(bytes.size(), 4096), bytes.size()));
  CHECK(!converter::looks_like_splat(bytes.data(), 4096, bytes.size() + 1));
  auto r = converter::read_splat_bytes(bytes.data(), bytes.size(), "test.splat");
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  CHECK(r->format == "splat");
  CHECK(r->stored_frame == "RDF");
  const CloudDiff d = diff_clouds(in, r->cloud);
  MESSAGE(".splat round trip: " << describe(d));
  CHECK(d.position == 0);
  CHECK(d.log_scale == 0);
  CHECK(d.opacity <= 1.0 / 255 + 1e-6);           // truncation: a full step
  CHECK(d.rotation_deg <= 1.0);  // 4 × 8 bits, truncated, decoded at the middle of each step
  // Colours are clipped to [0, 1] (f_dc within ±1.77); below that, within one 8-bit step.
  double dc = 0;
  for (size_t j = 0; j < in.sh.size(); ++j) {
    if (std::fabs(in.sh[j]) < 1.7) dc = std::max(dc, std::fabs(double{in.sh[j]} - r->cloud.sh[j]));
  }
  CHECK(dc <= 1.0 / (0.28209479 * 255) + 1e-5);
}

TEST_CASE("splat: the file splat-transform 3.7.0 wrote from guitar_256.ply") {
  auto ply = converter::read_ply(repo_path("tests/data/interop/guitar_256.ply"));
  REQUIRE(ply.ok());
  const std::string path = repo_path("tests/data/interop/guitar_256_splat_transform.splat");
  const std::vector<uint8_t> bytes = load_bytes(path);
  CHECK(converter::looks_like_splat(bytes.data(), bytes.size(), bytes.size()));
  auto r = converter::read_splat(path);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  REQUIRE(r->cloud.size() == ply->cloud.size());
  // The writer may reorder records: match each by position (exact float copies).
  size_t matched = 0;
  double worst_dc = 0, worst_op = 0, worst_rot = 0, worst_scale = 0, sum_rot = 0;
  for (size_t i = 0; i < ply->cloud.size(); ++i) {
    for (size_t j = 0; j < r->cloud.size(); ++j) {
      if (std::memcmp(&ply->cloud.means[i * 3], &r->cloud.means[j * 3], 12) != 0) continue;
      ++matched;
      for (int c = 0; c < 3; ++c) {
        if (std::fabs(ply->cloud.sh[i * 3 + c]) >= 1.7) continue;  // clipped by the 8-bit colour
        worst_dc = std::max(worst_dc, std::fabs(double{ply->cloud.sh[i * 3 + c]} - r->cloud.sh[j * 3 + c]));
        worst_scale =
            std::max(worst_scale, std::fabs(double{ply->cloud.scales[i * 3 + c]} / r->cloud.scales[j * 3 + c] - 1));
      }
      worst_op = std::max(worst_op, std::fabs(double{ply->cloud.opacities[i]} - r->cloud.opacities[j]));
      const double rot = rotation_angle_deg(&ply->cloud.rotations[i * 4], &r->cloud.rotations[j * 4]);
      worst_rot = std::max(worst_rot, rot);
      sum_rot += rot;
      break;
    }
  }
  MESSAGE("splat-transform .splat: matched " << matched << ", f_dc " << worst_dc << ", opacity " << worst_op
                                             << ", rotation " << worst_rot << " deg (mean " << sum_rot / matched
                                             << "), scale rel " << worst_scale);
  CHECK(matched == ply->cloud.size());
  CHECK(worst_scale <= 1e-6);
  CHECK(worst_op <= 1.0 / 255 + 1e-6);
  CHECK(worst_dc <= 1.0 / (0.28209479 * 255) + 1e-5);
  // The writer stores floor(q·128 + 128): decoding the middle of each step gives a mean angle error of
  // 0.43° on this file, where (b − 128)/128 gave 0.75° (converter/INTEROP.md ".splat").
  CHECK(worst_rot <= 0.8);
  CHECK(sum_rot / matched <= 0.45);
}

TEST_CASE("splat: inputs that must fail") {
  const format::GaussianCloud in = make_interop_cloud(8, 0);
  std::vector<uint8_t> bytes = encode_splat(in);
  auto code = [](const std::vector<uint8_t>& b, const InteropReadOptions& o = {}) {
    auto r = converter::read_splat_bytes(b.data(), b.size(), "test.splat", o);
    if (!r.ok()) MESSAGE(r.status().to_string());
    return r.status().code();
  };
  CHECK(code({}) == StatusCode::kCorruptData);
  CHECK(code(std::vector<uint8_t>(bytes.begin(), bytes.end() - 1)) == StatusCode::kCorruptData);
  InteropReadOptions small;
  small.max_gaussians = 7;
  CHECK(code(bytes, small) == StatusCode::kLimitExceeded);
  std::vector<uint8_t> zero_rot = bytes;
  for (int a = 0; a < 4; ++a) zero_rot[32 * 3 + 28 + a] = 128;
  CHECK(code(zero_rot) == StatusCode::kCorruptData);
  InteropReadOptions sanitize;
  sanitize.invalid_policy = converter::InvalidPolicy::kSanitize;
  auto r = converter::read_splat_bytes(zero_rot.data(), zero_rot.size(), "z.splat", sanitize);
  REQUIRE(r.ok());
  CHECK(r->cloud.size() == 7);
  CHECK(r->hygiene.zero_norm_quaternions == 1);
  CHECK(r->hygiene.first_invalid_index == 3);
  std::vector<uint8_t> nan = bytes;
  const float q = std::nanf("");
  std::memcpy(nan.data() + 4, &q, 4);
  CHECK(code(nan) == StatusCode::kCorruptData);
  CHECK(!converter::looks_like_splat(zero_rot.data(), zero_rot.size(), zero_rot.size()));
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 0\nend_header\n" + std::string(32, ' ');
  CHECK(!converter::looks_like_splat(reinterpret_cast<const uint8_t*>(ply.data()), ply.size(), ply.size()));
}

}  // namespace
}  // namespace rgs::test
