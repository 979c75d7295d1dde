// quantize(): per-attribute bounds on real scenes, determinism, percentile clipping, metadata, bounds,
// argument errors; attribute error metrics.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "ply_test_util.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::QuantizeOptions;
using converter::QuantizationReport;

format::GaussianCloud load_cloud(const std::string& path) {
  auto r = converter::read_ply(path);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r->cloud);
}

format::EncodedScene quantize_ok(const format::GaussianCloud& cloud, const QuantizeOptions& options = {},
                                 QuantizationReport* report = nullptr) {
  auto e = converter::quantize(cloud, options, report);
  REQUIRE_MESSAGE(e.ok(), e.status().to_string());
  return std::move(e).value();
}

/// Every mean inside the AABB and, evaluated in float32, inside the sphere.
void check_bounds(const format::GaussianCloud& cloud, const format::SceneBounds& b) {
  uint64_t outside = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    float d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const float v = cloud.means[i * 3 + a];
      outside += v < b.aabb_min[a] || v > b.aabb_max[a];
      const float d = v - b.sphere_center[a];
      d2 += d * d;
    }
    outside += std::sqrt(d2) > b.sphere_radius;
  }
  CHECK(outside == 0);
}

/// The full set of checks on one scene: bounds, metadata, determinism, error report consistency.
void check_scene(const format::GaussianCloud& cloud, const std::string& label) {
  CAPTURE(label);
  for (auto encoding : {format::ScaleEncoding::kLinear, format::ScaleEncoding::kLog}) {
    CAPTURE(format::to_string(encoding));
    QuantizeOptions options;
    options.scale_encoding = encoding;
    QuantizationReport report;
    const format::EncodedScene enc = quantize_ok(cloud, options, &report);
    CHECK(check_quantization_bounds(cloud, enc) == 0);
    const auto& m = enc.metadata;
    CHECK(m.sh_degree == cloud.sh_degree);
    CHECK(m.scale_encoding == encoding);
    CHECK(m.frame == format::CoordinateFrame::kColmap);
    CHECK(m.quaternion_order == format::QuaternionOrder::kWxyz);
    CHECK(m.opacity_encoding == format::OpacityEncoding::kSigmoid);
    CHECK(m.sh_layout == format::ShLayout::kCoefficientMajor);
    CHECK(m.sh_quantization.bits == 8);
    CHECK(m.sh_quantization.clip_percentile == 100.0f);
    std::string why;
    CHECK_MESSAGE(format::is_valid_quantization(m.sh_quantization, m.sh_degree, &why), why);
    for (int d = 0; d < 4; ++d) {
      for (int c = 0; c < 3; ++c) CHECK(report.sh_clipped[d][c] == 0);
    }
    // Max rule: each (d, c) uses ±127 somewhere (when not all zero).
    const uint32_t k_count = cloud.sh_coefficients();
    for (uint32_t d = 0; d <= cloud.sh_degree; ++d) {
      for (uint32_t c = 0; c < 3; ++c) {
        if (m.sh_quantization.scales[d][c] == 0) continue;
        int peak = 0;
        for (size_t i = 0; i < cloud.size(); ++i) {
          for (uint32_t k = d * d; k < (d + 1) * (d + 1); ++k) peak = std::max(peak, std::abs(int{enc.sh[(i * k_count + k) * 3 + c]}));
        }
        CHECK(peak == 127);
      }
    }
    check_bounds(cloud, m.bounds);
    CHECK(same_encoded(enc, quantize_ok(cloud, options)));  // deterministic

    // measure_quantization_errors == measure_attribute_errors(dequantize); SH errors within s/2.
    auto chunked = converter::measure_quantization_errors(cloud, enc);
    REQUIRE(chunked.ok());
    auto deq = format::dequantize(enc);
    REQUIRE(deq.ok());
    auto whole = converter::measure_attribute_errors(cloud, *deq);
    REQUIRE(whole.ok());
    CHECK(std::memcmp(&*chunked, &*whole, sizeof(converter::AttributeErrors)) == 0);
    // The measurement fused into quantize() gives the same bits, and the same report.
    converter::AttributeErrors fused;
    converter::QuantizationReport fused_report, plain_report;
    auto enc_fused = converter::quantize(cloud, options, &fused_report, &fused);
    REQUIRE(enc_fused.ok());
    REQUIRE(converter::quantize(cloud, options, &plain_report).ok());
    CHECK(same_encoded(enc, *enc_fused));
    CHECK(std::memcmp(&fused, &*chunked, sizeof(converter::AttributeErrors)) == 0);
    CHECK(std::memcmp(&fused_report, &plain_report, sizeof(converter::QuantizationReport)) == 0);
    CHECK(chunked->position.max == 0.0);
    CHECK(chunked->rotation_deg.max < 0.2);
    if (encoding == format::ScaleEncoding::kLinear) CHECK(chunked->opacity.max <= std::ldexp(1.0, -11));
    for (uint32_t d = 0; d <= cloud.sh_degree; ++d) {
      CHECK(chunked->sh[d].samples == cloud.size() * (2 * d + 1) * 3);
      for (int c = 0; c < 3; ++c) {
        // dequantize() forms s·q in float32: s/2 plus 127·2^-24·s.
        CHECK(chunked->sh_channel[d][c].max <= m.sh_quantization.scales[d][c] * (0.5 + 127.0 * std::ldexp(1.0, -24)));
      }
    }
  }
}

TEST_CASE("quantize: shipped guitar sample") {
  const auto cloud = load_cloud(repo_path("samples/guitar.ply"));
  check_scene(cloud, "guitar sample");
}

TEST_CASE("quantize: SH3 built from guitar (no shared data needed)") {
  const auto bytes = build_ply("binary_little_endian", inria_props(3), 20000, [&](uint64_t i, const std::string& n) {
    static const RawPly raw = parse_raw_ply(load_bytes(repo_path("samples/guitar.ply")));
    if (n.rfind("f_rest_", 0) == 0) {
      const int r = std::stoi(n.substr(7));
      return static_cast<double>(raw.get(i, "f_dc_" + std::to_string(r / 15)) * (static_cast<float>(r % 7) - 3.0f) / 8.0f);
    }
    return static_cast<double>(raw.get(i, n));
  });
  auto r = converter::read_ply_bytes(bytes.data(), bytes.size(), "sh3.ply");
  REQUIRE(r.ok());
  check_scene(r->cloud, "SH3 from guitar");
}

TEST_CASE("quantize: real scenes from $RGS_DATA_DIR") {
  for (const char* file : {"mipnerf360_flowers_c3dgs.ply", "tiny_unknown_inria_sh3_it7000.ply", "biker.ply",
                           "playcanvas_flowers_lod0.ply"}) {
    const std::string path = shared_scene(file);
    if (path.empty()) continue;
    check_scene(load_cloud(path), file);
  }
}

TEST_CASE("quantize: percentile clipping") {
  const auto cloud = load_cloud(repo_path("samples/guitar.ply"));
  QuantizeOptions options;
  options.sh_clip_percentile = 99.0f;
  QuantizationReport report;
  const auto enc = quantize_ok(cloud, options, &report);
  CHECK(enc.metadata.sh_quantization.clip_percentile == 99.0f);
  CHECK(same_encoded(enc, quantize_ok(cloud, options)));
  const uint64_t n = cloud.size();
  for (int c = 0; c < 3; ++c) {
    // Nearest rank: about 1% of the DC coefficients exceed the 99th percentile and clip.
    std::vector<float> mags(n);
    for (uint64_t i = 0; i < n; ++i) mags[i] = std::fabs(cloud.sh[i * 3 + c]);
    std::sort(mags.begin(), mags.end());
    const float p99 = mags[static_cast<size_t>(std::ceil(0.99 * static_cast<double>(n))) - 1];
    const float s = enc.metadata.sh_quantization.scales[0][c];
    CHECK(s == static_cast<float>(static_cast<double>(p99) / 127.0));
    uint64_t clipped = 0;
    for (uint64_t i = 0; i < n; ++i) {
      const double v = cloud.sh[i * 3 + c];
      const int q = enc.sh[i * 3 + c];
      if (std::round(v / s) > 127 || std::round(v / s) < -127) {
        ++clipped;
        CHECK(std::abs(q) == 127);
      } else {
        CHECK(std::fabs(static_cast<double>(s) * q - v) <= 0.5 * s * (1 + 1e-12));
      }
    }
    CHECK(clipped == report.sh_clipped[0][c]);
    CHECK(clipped > n / 200);
    CHECK(clipped <= n / 100);
  }
}

TEST_CASE("quantize: edge cases") {
  format::GaussianCloud cloud;
  cloud.sh_degree = 1;
  cloud.resize(3);
  for (size_t i = 0; i < 3; ++i) {
    cloud.rotations[i * 4] = 2.0f;  // not normalized: quantize normalizes
    cloud.rotations[i * 4 + 3] = -2.0f;
    for (int a = 0; a < 3; ++a) cloud.scales[i * 3 + a] = 1e-9f * static_cast<float>(i);  // below FP16 range
    cloud.opacities[i] = 0.5f;
  }
  cloud.sh[0] = 0.25f;  // only one non-zero DC value, all degree-1 SH zero
  SUBCASE("zero SH rows get scale 0 and code 0") {
    const auto enc = quantize_ok(cloud);
    const auto& s = enc.metadata.sh_quantization.scales;
    CHECK(s[0][0] == static_cast<float>(0.25 / 127));
    CHECK(s[0][1] == 0.0f);
    CHECK(s[1][2] == 0.0f);
    CHECK(s[2][0] == 0.0f);
    CHECK(enc.sh[0] == 127);
    for (size_t j = 1; j < enc.sh.size(); ++j) CHECK(enc.sh[j] == 0);
    CHECK(format::half_bits_to_float(enc.rotations[0]) == doctest::Approx(std::sqrt(0.5)).epsilon(1e-3));
    CHECK(enc.scales[3] == 0);  // 1e-9 underflows linear FP16 (documented)
    CHECK(check_quantization_bounds(cloud, enc) == 0);
  }
  SUBCASE("ties round half away from zero, exactly at the boundary") {
    // max |DC red| = 127·2^-7, so s = 2^-7 exactly and (k + 0.5)·s are exact floats.
    format::GaussianCloud ties;
    ties.resize(2 * 128 + 1);
    const float s = std::ldexp(1.0f, -7);
    for (size_t i = 0; i < ties.size(); ++i) {
      ties.rotations[i * 4] = 1.0f;
      ties.opacities[i] = 0.5f;
    }
    ties.sh[0] = 127 * s;
    for (int k = 0; k < 127; ++k) {
      const float half = (static_cast<float>(k) + 0.5f) * s;
      ties.sh[(1 + 2 * k) * 3] = (k % 2 ? -half : half);                                   // tie
      ties.sh[(2 + 2 * k) * 3] = std::nextafter(half, 0.0f) * (k % 2 ? -1.0f : 1.0f);      // just below
    }
    const auto enc = quantize_ok(ties);
    REQUIRE(enc.metadata.sh_quantization.scales[0][0] == s);
    CHECK(enc.sh[0] == 127);
    for (int k = 0; k < 127; ++k) {
      CAPTURE(k);
      const int sign = k % 2 ? -1 : 1;
      CHECK(enc.sh[(1 + 2 * k) * 3] == sign * (k + 1));
      CHECK(enc.sh[(2 + 2 * k) * 3] == sign * k);
    }
    CHECK(check_quantization_bounds(ties, enc) == 0);
  }
  SUBCASE("log scale keeps tiny scales and stores log(0) as the lowest finite half") {
    QuantizeOptions log_options;
    log_options.scale_encoding = format::ScaleEncoding::kLog;
    const auto enc = quantize_ok(cloud, log_options);
    CHECK(format::half_bits_to_float(enc.scales[0]) == -65504.0f);
    CHECK(std::exp(format::half_bits_to_float(enc.scales[0])) == 0.0f);
    CHECK(format::half_bits_to_float(enc.scales[3]) == doctest::Approx(std::log(1e-9)).epsilon(1e-3));
  }
  SUBCASE("log scale stores scales up to the largest float with a finite exp (SPEC §4.5)") {
    // ln(FLT_MAX) = 88.7228 rounds to the binary16 88.75, whose exp overflows: such scales are stored as
    // 88.6875, the binary16 below. (A .splat file stores linear float scales; fuzz_interop_read found 3.4e38.)
    auto huge = cloud;
    huge.scales[0] = std::numeric_limits<float>::max();
    huge.scales[1] = 3.35e38f;  // ln = 88.7096, nearest binary16 88.6875 already
    huge.scales[2] = 1e38f;     // ln = 87.4982 -> 87.5
    QuantizeOptions log_options;
    log_options.scale_encoding = format::ScaleEncoding::kLog;
    const auto enc = quantize_ok(huge, log_options);
    CHECK(format::half_bits_to_float(enc.scales[0]) == 88.6875f);
    CHECK(format::half_bits_to_float(enc.scales[1]) == 88.6875f);
    CHECK(format::half_bits_to_float(enc.scales[2]) == 87.5f);
    CHECK(std::isfinite(std::exp(88.6875f)));
    CHECK(std::isinf(std::exp(88.75f)));
    const auto bytes = format::serialize_scene(enc);
    REQUIRE(bytes.ok());
    CHECK(format::validate(bytes->data(), bytes->size()).ok());
  }
  SUBCASE("empty cloud") {
    format::GaussianCloud empty;
    empty.sh_degree = 3;
    const auto enc = quantize_ok(empty);
    CHECK(enc.count == 0);
    CHECK(enc.metadata.sh_degree == 3);
    CHECK(enc.is_consistent());
  }
  SUBCASE("argument errors") {
    QuantizeOptions bad;
    for (float p : {0.0f, -1.0f, 100.5f, std::numeric_limits<float>::quiet_NaN()}) {
      bad.sh_clip_percentile = p;
      CHECK(converter::quantize(cloud, bad).status().code() == StatusCode::kInvalidArgument);
    }
    auto broken = cloud;
    broken.sh.pop_back();
    CHECK(converter::quantize(broken, {}).status().code() == StatusCode::kInvalidArgument);
    auto nan_sh = cloud;
    nan_sh.sh[5] = std::numeric_limits<float>::quiet_NaN();
    const Status s = converter::quantize(nan_sh, {}).status();
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(s.message().find("Gaussian 0") != std::string::npos, s.message());
    auto huge = cloud;
    huge.scales[4] = 70000.0f;
    const Status h = converter::quantize(huge, {}).status();
    CHECK(h.code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(h.message().find("log scale") != std::string::npos, h.message());
    QuantizeOptions log_options;
    log_options.scale_encoding = format::ScaleEncoding::kLog;
    CHECK(converter::quantize(huge, log_options).ok());
    auto zero_rot = cloud;
    for (int a = 0; a < 4; ++a) zero_rot.rotations[4 + a] = 0.0f;
    CHECK(converter::quantize(zero_rot, {}).status().code() == StatusCode::kInvalidArgument);
    auto logit = cloud;
    logit.opacities[2] = 3.0f;
    CHECK(converter::quantize(logit, {}).status().code() == StatusCode::kInvalidArgument);
  }
}

TEST_CASE("compute_bounds") {
  format::GaussianCloud cloud;
  cloud.resize(3);
  const float pts[9] = {1, 2, 3, -1, 0, 7, 4, 2, -3};
  std::memcpy(cloud.means.data(), pts, sizeof(pts));
  const auto b = converter::compute_bounds(cloud);
  CHECK(b.aabb_min[0] == -1);
  CHECK(b.aabb_max[0] == 4);
  CHECK(b.aabb_min[2] == -3);
  CHECK(b.aabb_max[2] == 7);
  CHECK(b.sphere_center[0] == 1.5f);
  CHECK(b.sphere_center[1] == 1.0f);
  CHECK(b.sphere_center[2] == 2.0f);
  const double r = std::sqrt(2.5 * 2.5 + 1 + 25);  // (-1, 0, 7) and (4, 2, -3) are farthest
  CHECK(b.sphere_radius >= r);
  CHECK(b.sphere_radius <= r * (1 + 2e-6));
  check_bounds(cloud, b);
  CHECK(converter::compute_bounds(format::GaussianCloud()).sphere_radius == 0.0f);
}

TEST_CASE("compute_bounds: the radius is measured from the stored float centre (guitar, centres off the float grid)") {
  // The AABB midpoints of guitar's first 100 means are not floats; the radius must still be the rule's value
  // from the rounded centre: max |mean − centre| in double, times 1 + 1e-6, rounded up to float.
  auto ply = converter::read_ply(repo_path("samples/guitar.ply"));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  for (const size_t n : {size_t{100}, ply->cloud.size()}) {
    CAPTURE(n);
    format::GaussianCloud cloud = ply->cloud;
    cloud.means.resize(n * 3);
    const format::SceneBounds b = converter::compute_bounds(cloud);
    double r2 = 0;
    for (size_t i = 0; i < n; ++i) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = double(cloud.means[i * 3 + a]) - double(b.sphere_center[a]);
        d2 += d * d;
      }
      r2 = std::max(r2, d2);
    }
    const double r = std::sqrt(r2) * (1.0 + 1e-6);
    float expected = static_cast<float>(r);
    if (double(expected) < r) expected = std::nextafter(expected, std::numeric_limits<float>::infinity());
    CHECK(b.sphere_radius == expected);
  }
}

TEST_CASE("measure_attribute_errors: exact values and argument errors") {
  format::GaussianCloud a;
  a.sh_degree = 1;
  a.resize(2);
  a.rotations = {1, 0, 0, 0, 0, 0, 0, 1};
  a.scales = {1, 2, 4, 1, 1, 1};
  a.opacities = {0.5f, 0.25f};
  auto b = a;
  const double theta = 1e-4 * 3.14159265358979323846 / 180;  // 1e-4 degrees about x
  b.rotations = {static_cast<float>(std::cos(theta / 2)), static_cast<float>(std::sin(theta / 2)), 0, 0,
                 0, 0, 0, -1};  // second: −q, the same rotation
  b.means[0] = 3;
  b.means[1] = 4;
  b.scales[2] = 5;
  b.opacities[1] = 0.75f;
  b.sh[1 * 12 + 3 * 3 + 2] = -0.5f;  // Gaussian 1, coefficient 3, channel B
  auto e = converter::measure_attribute_errors(a, b);
  REQUIRE(e.ok());
  CHECK(e->position.max == 5.0);
  CHECK(e->position.samples == 2);
  CHECK(e->position.rms == doctest::Approx(std::sqrt(12.5)));
  CHECK(e->rotation_deg.max == doctest::Approx(1e-4).epsilon(1e-3));  // float sin(θ/2) limits precision
  CHECK(e->scale_relative.max == 0.25);
  CHECK(e->scale_relative.samples == 6);
  CHECK(e->opacity.max == 0.5);
  CHECK(e->sh[1].max == 0.5);
  CHECK(e->sh[1].samples == 18);
  CHECK(e->sh[0].max == 0.0);
  CHECK(e->sh_channel[1][2].max == 0.5);
  CHECK(e->sh_channel[1][1].max == 0.0);
  CHECK(e->sh[2].samples == 0);

  auto other = a;
  other.sh_degree = 0;
  other.resize(2);
  other.sh.resize(6);
  CHECK(converter::measure_attribute_errors(a, other).status().code() == StatusCode::kInvalidArgument);
  auto shorter = a;
  shorter.resize(1);
  CHECK(converter::measure_attribute_errors(a, shorter).status().code() == StatusCode::kInvalidArgument);
  format::EncodedScene enc;
  enc.count = 2;
  enc.metadata.sh_degree = 1;
  CHECK(converter::measure_quantization_errors(a, enc).status().code() == StatusCode::kCorruptData);
}

TEST_CASE("quantize: the report counts linear scales that FP16 stores as subnormals or flushes to zero") {
  auto ply = converter::read_ply(repo_path("samples/guitar.ply"));
  REQUIRE(ply.ok());
  const format::GaussianCloud& cloud = ply->cloud;
  converter::QuantizationReport linear_report;
  auto linear = converter::quantize(cloud, {}, &linear_report);
  REQUIRE(linear.ok());
  // Independent count from the source values: below 2^-25 rounds to 0, [2^-25, 2^-14) is subnormal
  // (values within half an ulp below 2^-14 round up to the smallest normal, values at 2^-25 tie to 0).
  uint64_t flushed = 0, subnormal = 0;
  for (float s : cloud.scales) {
    if (s == 0.0f) continue;
    if (s <= std::ldexp(1.0f, -25)) {
      ++flushed;
    } else if (s < std::ldexp(1.0f, -14) - std::ldexp(1.0f, -25)) {
      ++subnormal;
    }
  }
  CHECK(linear_report.scales_flushed_to_zero == flushed);
  CHECK(linear_report.scales_subnormal == subnormal);
  CHECK(flushed == 101);  // the shipped sample has 101 scales below 3e-8
  converter::QuantizeOptions log_options;
  log_options.scale_encoding = format::ScaleEncoding::kLog;
  converter::QuantizationReport log_report;
  REQUIRE(converter::quantize(cloud, log_options, &log_report).ok());
  CHECK(log_report.scales_flushed_to_zero == 0);
  CHECK(log_report.scales_subnormal == 0);
}

}  // namespace
}  // namespace rgs::test
