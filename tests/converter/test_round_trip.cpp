// PLY writer: INRIA layout byte for byte, PLY -> cloud -> PLY round trips, and the idempotence of
// quantize -> dequantize -> PLY -> read -> quantize.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/half.h"
#include "test_data.h"

namespace rgs::test {
namespace {

format::GaussianCloud read_cloud_bytes(const std::vector<uint8_t>& bytes) {
  auto r = converter::read_ply_bytes(bytes.data(), bytes.size(), "round_trip.ply");
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r->cloud);
}

std::vector<uint8_t> serialize_ok(const format::GaussianCloud& cloud) {
  auto bytes = converter::serialize_ply(cloud);
  REQUIRE_MESSAGE(bytes.ok(), bytes.status().to_string());
  return std::move(bytes).value();
}

/// read(serialize(cloud)) against cloud: means and SH bit-exact, the rest within float tolerances of
/// the inverse activations (log/exp and logit/sigmoid in float32 storage).
void check_float_round_trip(const format::GaussianCloud& cloud) {
  const auto back = read_cloud_bytes(serialize_ok(cloud));
  REQUIRE(back.size() == cloud.size());
  REQUIRE(back.sh_degree == cloud.sh_degree);
  CHECK(same_floats(back.means, cloud.means));
  CHECK(same_floats(back.sh, cloud.sh));
  uint64_t bad = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    // Rotations are written as given and renormalized on read: a unit quaternion moves by an ulp or two.
    for (int a = 0; a < 4; ++a) bad += std::fabs(back.rotations[i * 4 + a] - cloud.rotations[i * 4 + a]) > 2.5e-7f;
    // Scale: log stored in float32 (relative error 2^-24 of |log s|), so exp is off by <= |log s|·2^-24.
    for (int a = 0; a < 3; ++a) {
      const double s = cloud.scales[i * 3 + a];
      const double tol = (std::fabs(std::log(s)) + 1) * std::ldexp(1.0, -23) * s;
      bad += std::fabs(back.scales[i * 3 + a] - s) > tol;
    }
    // Opacity: logit clamped to [1e-6, 1 − 1e-6] and stored in float32.
    // Opacity: logit ℓ of o clamped to [1e-6, 1 − 1e-6], stored in float32 (error <= 2^-24·|ℓ|), moves
    // sigmoid by o(1−o)·2^-24·|ℓ|, plus the float32 rounding of the sigmoid itself.
    const double o = std::clamp(static_cast<double>(cloud.opacities[i]), 1e-6, 1 - 1e-6);
    const double logit = std::log(o / (1 - o));
    const double tol = (o * (1 - o) * (std::fabs(logit) + 1) + o) * std::ldexp(1.0, -23);
    bad += std::fabs(back.opacities[i] - o) > tol;
  }
  CHECK(bad == 0);
}

TEST_CASE("serialize_ply: exact INRIA header and layout") {
  format::GaussianCloud cloud;
  cloud.sh_degree = 1;
  cloud.resize(2);
  for (size_t j = 0; j < cloud.sh.size(); ++j) cloud.sh[j] = static_cast<float>(j);
  cloud.means = {1, 2, 3, 4, 5, 6};
  cloud.rotations = {1, 0, 0, 0, 0.5f, 0.5f, 0.5f, 0.5f};
  cloud.scales = {1, 2, 0, 1, 1, 1};
  cloud.opacities = {0.5f, 1.0f};
  const auto bytes = serialize_ok(cloud);
  std::string expected =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float f_dc_0\n"
      "property float f_dc_1\nproperty float f_dc_2\n";
  for (int r = 0; r < 9; ++r) expected += "property float f_rest_" + std::to_string(r) + "\n";
  expected +=
      "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n"
      "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n";
  REQUIRE(bytes.size() == expected.size() + 2 * 26 * 4);
  CHECK(std::string(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(expected.size())) == expected);
  const RawPly raw = parse_raw_ply(bytes);
  CHECK(raw.get(1, "x") == 4);
  CHECK(raw.get(1, "nz") == 0);
  CHECK(raw.get(1, "f_dc_2") == 14);  // sh[(1·4 + 0)·3 + 2]
  // f_rest channel-major: f_rest[c·3 + k − 1] = SH coefficient k of channel c.
  CHECK(raw.get(1, "f_rest_0") == 15);  // k 1, c 0: sh[(4 + 1)·3 + 0]
  CHECK(raw.get(1, "f_rest_4") == 19);  // k 2, c 1: sh[(4 + 2)·3 + 1]
  CHECK(raw.get(1, "f_rest_8") == 23);  // k 3, c 2
  CHECK(raw.get(0, "opacity") == 0.0f);
  CHECK(raw.get(1, "opacity") == static_cast<float>(std::log((1 - 1e-6) / 1e-6)));  // 13.8155
  CHECK(raw.get(0, "scale_1") == static_cast<float>(std::log(2.0)));
  // A zero scale (linear FP16 underflow) is written as ln(2^-25), finite, not log(0) = -inf.
  CHECK(raw.get(0, "scale_2") == converter::kZeroScaleLog);
  CHECK(std::isfinite(raw.get(0, "scale_2")));
  CHECK(raw.get(1, "rot_3") == 0.5f);
  const float restored = read_cloud_bytes(bytes).scales[2];
  CHECK(restored == doctest::Approx(std::ldexp(1.0, -25)).epsilon(1e-6));
  CHECK(format::float_to_half_bits(restored) == 0);  // linear FP16 makes it 0 again: stable round trip
  converter::PlyWriteReport report;
  REQUIRE(converter::serialize_ply(cloud, &report).ok());
  CHECK(report.zero_scales == 1);

  auto broken = cloud;
  broken.opacities.pop_back();
  CHECK(converter::serialize_ply(broken).status().code() == StatusCode::kInvalidArgument);
  // Nothing non-finite reaches a PLY.
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -1.0f}) {
    auto with_bad = cloud;
    with_bad.scales[4] = bad;
    auto s = converter::serialize_ply(with_bad);
    CHECK(s.status().code() == StatusCode::kInvalidArgument);
    CHECK(s.status().message().find("Gaussian 1") != std::string::npos);
  }
  auto nan_mean = cloud;
  nan_mean.means[0] = std::numeric_limits<float>::quiet_NaN();
  CHECK(converter::serialize_ply(nan_mean).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("serialize_ply: INRIA files re-serialize to the same header and the same raw means/SH") {
  std::vector<std::string> paths = {repo_path("samples/guitar.ply")};
  for (const char* f : {"tiny_unknown_inria_sh3_it7000.ply", "mipnerf360_flowers_c3dgs.ply"}) {
    const std::string p = shared_scene(f);
    if (!p.empty()) paths.push_back(p);
  }
  for (const auto& path : paths) {
    CAPTURE(path);
    const auto original = load_bytes(path);
    const RawPly raw = parse_raw_ply(original);
    const auto cloud = read_cloud_bytes(original);
    const auto bytes = serialize_ok(cloud);
    REQUIRE(bytes.size() == original.size());
    const RawPly again = parse_raw_ply(bytes);
    CHECK(again.header == raw.header);  // byte-identical INRIA header (62 props incl. normals for SH3)
    uint64_t differ = 0;
    for (uint64_t i = 0; i < raw.count; ++i) {
      for (const auto& name : raw.names) {
        if (name == "opacity" || name.rfind("scale_", 0) == 0 || name.rfind("rot_", 0) == 0) continue;
        differ += again.get(i, name) != raw.get(i, name);
      }
    }
    CHECK(differ == 0);
    check_float_round_trip(cloud);
  }
}

TEST_CASE("write_ply: atomic file write equals serialize_ply") {
  const auto cloud = read_cloud_bytes(load_bytes(repo_path("samples/guitar.ply")));
  const auto dir = std::filesystem::temp_directory_path() / "rgs_test_converter_write";
  std::filesystem::create_directories(dir);
  const auto path = (dir / "out.ply").string();
  auto written = converter::write_ply(path, cloud);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  const auto bytes = load_bytes(path);
  CHECK(*written == bytes.size());
  CHECK(bytes == serialize_ok(cloud));
  // A failing write names the path and leaves nothing behind.
  const auto bad_path = (dir / "missing_dir" / "out.ply").string();
  auto failed = converter::write_ply(bad_path, cloud);
  CHECK(failed.status().code() == StatusCode::kIoError);
  CHECK_MESSAGE(failed.status().message().find("missing_dir") != std::string::npos, failed.status().message());
  auto broken = cloud;
  broken.means.pop_back();
  CHECK(converter::write_ply(path, broken).status().code() == StatusCode::kInvalidArgument);
  CHECK(load_bytes(path) == bytes);  // untouched
  std::filesystem::remove_all(dir);
}

/// quantize -> dequantize -> PLY -> read -> quantize gives the same codes.
void check_idempotent(const format::GaussianCloud& cloud, format::ScaleEncoding encoding) {
  converter::QuantizeOptions options;
  options.scale_encoding = encoding;
  auto enc = converter::quantize(cloud, options);
  REQUIRE(enc.ok());
  auto deq = format::dequantize(*enc);
  REQUIRE(deq.ok());
  const auto reread = read_cloud_bytes(serialize_ok(*deq));
  auto enc2 = converter::quantize(reread, options);
  REQUIRE(enc2.ok());
  CHECK(same_floats(enc2->means, enc->means));
  CHECK(enc2->sh == enc->sh);
  CHECK(enc2->scales == enc->scales);
  CHECK(enc2->opacities == enc->opacities);
  uint64_t rot_diff = 0, rot_far = 0;
  for (size_t j = 0; j < enc->rotations.size(); ++j) {
    const int d = std::abs(int{enc2->rotations[j]} - int{enc->rotations[j]});
    rot_diff += d != 0;
    rot_far += d > 1;
  }
  // Rotations: dequantized FP16 quaternions are unit only to ~2^-12, and quantize renormalizes, so a
  // component may move by one FP16 ulp on the second pass; never more.
  CHECK(rot_far == 0);
  MESSAGE(rot_diff << " of " << enc->rotations.size() << " rotation components moved by one FP16 ulp");
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 3; ++c) {
      const float s1 = enc->metadata.sh_quantization.scales[d][c];
      const float s2 = enc2->metadata.sh_quantization.scales[d][c];
      CHECK(std::fabs(s1 - s2) <= std::ldexp(s1, -23));  // s' = fl(fl(127·s)/127): s or one ulp away
    }
  }
}

TEST_CASE("round trip: quantize is idempotent through dequantize and PLY") {
  std::vector<std::string> paths = {repo_path("samples/guitar.ply")};
  for (const char* f : {"mipnerf360_flowers_c3dgs.ply", "tiny_unknown_inria_sh3_it7000.ply", "biker.ply",
                        "playcanvas_flowers_lod0.ply"}) {
    const std::string p = shared_scene(f);
    if (!p.empty()) paths.push_back(p);
  }
  for (const auto& path : paths) {
    CAPTURE(path);
    auto r = converter::read_ply(path);
    REQUIRE(r.ok());
    check_idempotent(r->cloud, format::ScaleEncoding::kLinear);
    check_idempotent(r->cloud, format::ScaleEncoding::kLog);
  }
}

}  // namespace
}  // namespace rgs::test
