// Archive profile round trips (format/SPEC.md §3.3) on real scenes: PLY -> quantize -> archive bytes ->
// validate -> read_scene. The file decodes to exactly encode_archive's scene, every attribute stays within
// the bound its codec promises relative to the runtime-profile scene, the Gaussians left out are exactly those
// whose opacity code is 0, and the bytes do not depend on the thread count. Runs on the shipped sample and on
// every real scene of $RGS_DATA_DIR (skipped visibly), and on the sample with code steps coarser than the bits
// (ArchiveOptions::rotation_step, scale_step, opacity_step), and on scenes whose attributes leave a quantizer
// nothing to span: a flat axis of zero scales (2D-Gaussian and surfel exports), constant attributes, one Gaussian.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/archive.h"
#include "rgs/format/half.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "gaussian_subset.h"
#include "test_data.h"

namespace {

using namespace rgs;
using test::first_gaussians;

double half(uint16_t h) { return format::half_bits_to_float(h); }

format::GaussianCloud read_cloud(const std::string& path, uint64_t expected_count) {
  auto ply = converter::read_ply(path);
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  REQUIRE(ply->cloud.size() == expected_count);
  return std::move(ply->cloud);
}

void check_archive_round_trip(const format::GaussianCloud& cloud, bool check_threads,
                              const format::ArchiveOptions& options = {},
                              format::ScaleEncoding scale_encoding = format::ScaleEncoding::kLinear) {
  converter::QuantizeOptions quantize;
  quantize.scale_encoding = scale_encoding;
  auto quantized = converter::quantize(cloud, quantize);
  REQUIRE_MESSAGE(quantized.ok(), quantized.status().to_string());
  const format::EncodedScene& src = *quantized;
  const uint64_t n = src.count;

  format::WriteOptions write;
  write.profile = format::StorageProfile::kArchive;
  write.archive = options;
  auto archive = format::encode_archive(src, write.archive);
  REQUIRE_MESSAGE(archive.ok(), archive.status().to_string());
  auto bytes = format::serialize_scene(src, write);
  REQUIRE_MESSAGE(bytes.ok(), bytes.status().to_string());
  const Status valid = format::validate(bytes->data(), bytes->size());
  CHECK_MESSAGE(valid.ok(), valid.to_string());
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  auto read = file->read_scene();
  REQUIRE_MESSAGE(read.ok(), read.status().to_string());
  CHECK(test::same_encoded(*read, archive->decoded));
  if (check_threads) {
    format::WriteOptions one = write;
    one.archive.threads = 1;
    auto single = format::serialize_scene(src, one);
    REQUIRE(single.ok());
    CHECK(*single == *bytes);
  }

  // Per-attribute bounds against the runtime-profile scene (SPEC §3.3.1, §3.3.2).
  const format::ArchiveOptions o = format::resolve_archive_options(write.archive, src);
  const format::EncodedScene& d = archive->decoded;
  const double pos_bound = 0.5 * archive->position.step * 1.05 + 1e-6 * archive->position.range;
  // A code step k rounds to a multiple of k, then to a code: within k/2 + 1/2 codes (k/2 for an integer k).
  auto codes_off = [](double k) { return k == std::floor(k) ? k : k + 1; };
  const double rot_step = std::sqrt(2.0) / ((1u << o.rotation_bits) - 1) * codes_off(o.rotation_step);
  const double rot_err = std::sqrt(3.0) * rot_step / 2 + 2e-3;  // + FP16 rounding of both quaternions
  const double opa_bound = 0.5 * codes_off(o.opacity_step) / ((1u << o.opacity_bits) - 1) + 1.0 / 2048;
  const bool log_scales = src.metadata.scale_encoding == format::ScaleEncoding::kLog;
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = std::numeric_limits<double>::infinity(), hi[a] = -lo[a];
  auto ln = [&](uint16_t h) {
    const double v = half(h);
    return log_scales ? (v <= -65504.0 ? -std::numeric_limits<double>::infinity() : v) : std::log(v);
  };
  for (uint64_t i = 0; i < n * 3; ++i) {
    const double v = ln(src.scales[i]);
    if (std::isfinite(v)) lo[i % 3] = std::min(lo[i % 3], v), hi[i % 3] = std::max(hi[i % 3], v);
  }
  // Omitted: exactly the Gaussians whose opacity code is 0 (value below half a code step of the writer's
  // grid) or whose opacity is below the floor (none of them ever blends), each either kept once or omitted; every
  // kept one decodes to a visible opacity.
  const double opacity_codes = static_cast<double>((1u << o.opacity_bits) - 1);
  auto zero_code = [&](uint16_t h) {
    return std::floor(half(h) * opacity_codes / o.opacity_step + 0.5) == 0 || half(h) < o.opacity_floor;
  };
  std::vector<int> times(n, 0);
  for (uint64_t s : archive->omitted) times[s] += 2;
  for (uint64_t s : archive->source_index) times[s] += 1;
  uint64_t wrong_omission = 0, visible_omitted = 0;
  for (uint64_t s = 0; s < n; ++s) {
    wrong_omission += times[s] == 2 ? !zero_code(src.opacities[s]) : times[s] != 1 || zero_code(src.opacities[s]);
    visible_omitted += times[s] == 2 && half(src.opacities[s]) * opacity_codes >= 0.5 * o.opacity_step &&
                       half(src.opacities[s]) >= o.opacity_floor;
  }
  CHECK(archive->source_count == n);
  CHECK(d.count + archive->omitted.size() == n);
  CHECK(wrong_omission == 0);
  CHECK(visible_omitted == 0);
  CHECK(std::all_of(d.opacities.begin(), d.opacities.end(), [](uint16_t h) { return half(h) > 0; }));
  MESSAGE(archive->omitted.size() << " of " << n << " Gaussians omitted (opacity code 0 or below the floor)");

  const uint32_t values = 3 * format::sh_coefficient_count(src.metadata.sh_degree);
  uint64_t bad_pos = 0, bad_rot = 0, bad_scale = 0, bad_opa = 0, bad_sh = 0;
  for (uint64_t i = 0; i < d.count; ++i) {
    const uint64_t s = archive->source_index[i];
    for (int a = 0; a < 3; ++a) bad_pos += std::fabs(d.means[i * 3 + a] - src.means[s * 3 + a]) > pos_bound;
    double dot = 0, na = 0, nb = 0;
    for (int a = 0; a < 4; ++a) {
      const double x = half(d.rotations[i * 4 + a]), y = half(src.rotations[s * 4 + a]);
      dot += x * y, na += x * x, nb += y * y;
    }
    bad_rot += 1 - std::fabs(dot) / std::sqrt(na * nb) > 2 * rot_err * rot_err;
    for (int a = 0; a < 3; ++a) {
      const double want = ln(src.scales[s * 3 + a]), got = ln(d.scales[i * 3 + a]);
      const double smallest = std::log(6.2e-5);  // FP16 normals: relative rounding 2^-11
      if (!std::isfinite(want) || (!log_scales && (want < smallest || got < smallest))) {
        // A scale of 0 (linear 0, log -65504) decodes to 0 where the axis has no other, else to the axis' smallest.
        const bool zero_axis = !(lo[a] <= hi[a]);
        bad_scale += !std::isfinite(want) && (zero_axis ? got != want : !(got >= lo[a] - 1e-3 && got <= hi[a] + 1e-3));
        continue;
      }
      const double step = (hi[a] - lo[a]) / ((1u << o.scale_bits) - 1) * o.scale_step;
      bad_scale += std::fabs(got - want) > 0.5 * step + 1e-3 + (log_scales ? std::fabs(want) / 1024 : 0);
    }
    bad_opa += std::fabs(half(d.opacities[i]) - half(src.opacities[s])) > opa_bound;
    for (uint32_t c = 0; c < values; ++c) {
      const int m = static_cast<int>(o.sh_step_multipliers[format::sh_degree_of_coefficient(c / 3)]);
      bad_sh += std::abs(d.sh[i * values + c] - src.sh[s * values + c]) > m;
    }
  }
  // A scale axis of one value in every kept Gaussian (a flat axis of zero scales, one size for all, a scene of one
  // Gaussian) has a quantizer step of 0: it decodes to exactly the runtime profile's value. (Draco's kd-tree coder
  // chooses its own grid for the means, and rotations, opacities and SH have fixed grids: the bounds below.)
  auto check_constant = [&](const std::string& attribute, uint32_t components, auto&& src_value,
                            auto&& decoded_value) {
    if (d.count == 0) return;
    for (uint32_t c = 0; c < components; ++c) {
      const auto first = src_value(archive->source_index[0], c);
      bool constant = true;
      for (uint64_t i = 1; i < d.count && constant; ++i) constant = src_value(archive->source_index[i], c) == first;
      if (!constant) continue;
      uint64_t differ = 0;
      for (uint64_t i = 0; i < d.count; ++i) differ += decoded_value(i, c) != first;
      CAPTURE(attribute);
      CAPTURE(c);
      CAPTURE(double(first));
      CAPTURE(double(decoded_value(0, c)));
      CHECK(differ == 0);
    }
  };
  check_constant("scale", 3, [&](uint64_t s, uint32_t a) { return src.scales[s * 3 + a]; },
                 [&](uint64_t i, uint32_t a) { return d.scales[i * 3 + a]; });
  CHECK(bad_pos == 0);
  CHECK(bad_rot == 0);
  CHECK(bad_scale == 0);
  CHECK(bad_opa == 0);
  CHECK(bad_sh == 0);
  // A code step of k leaves about 1/k of the codes in use (decoded opacities: one value per code).
  std::vector<uint16_t> opacities(d.opacities.begin(), d.opacities.end());
  std::sort(opacities.begin(), opacities.end());
  const auto used = std::unique(opacities.begin(), opacities.end()) - opacities.begin();
  CHECK(double(used) <= std::ceil(double((1u << o.opacity_bits) - 1) / o.opacity_step) + 1);
}

}  // namespace

TEST_CASE("archive round trip: flat, constant-attribute and one-Gaussian scenes decode to the runtime profile's values") {
  const format::GaussianCloud guitar = read_cloud(test::repo_path("samples/guitar.ply"), 90854);
  const format::GaussianCloud sh3 = read_cloud(test::repo_path(test::kGuitarSh3), 8000);
  for (const format::ScaleEncoding encoding : {format::ScaleEncoding::kLinear, format::ScaleEncoding::kLog}) {
    const bool log = encoding == format::ScaleEncoding::kLog;
    CAPTURE(log);
    // One axis of one log-scale in every Gaussian, as 2D-Gaussian and surfel exports write their flat axis (-inf
    // and values that linear FP16 flushes to 0), at the flush threshold and above it.
    for (const double log_scale : {-std::numeric_limits<double>::infinity(), -30.0, -20.0, -17.34, -17.0, -13.8155,
                                   -3.3}) {
      CAPTURE(log_scale);
      format::GaussianCloud flat = first_gaussians(guitar, 6000);
      for (size_t i = 0; i < flat.size(); ++i) flat.scales[i * 3 + 2] = static_cast<float>(std::exp(log_scale));
      check_archive_round_trip(flat, false, {}, encoding);
    }
    for (const format::GaussianCloud* cloud : {&guitar, &sh3}) {
      CAPTURE(cloud->sh_degree);
      check_archive_round_trip(first_gaussians(*cloud, 1), false, {}, encoding);            // one Gaussian
      check_archive_round_trip(first_gaussians(*cloud, 3000, true), false, {}, encoding);   // one Gaussian, repeated
      // One attribute constant, the others as trained.
      for (const char* attribute : {"scales", "opacities", "rotations", "sh", "means"}) {
        CAPTURE(attribute);
        format::GaussianCloud c = first_gaussians(*cloud, 3000);
        const std::string a = attribute;
        std::vector<float>& v = a == "scales"      ? c.scales
                                : a == "opacities" ? c.opacities
                                : a == "rotations" ? c.rotations
                                : a == "sh"        ? c.sh
                                                   : c.means;
        const size_t width = v.size() / c.size();
        for (size_t i = 1; i < c.size(); ++i) std::copy_n(&v[0], width, &v[i * width]);
        if (a == "means") {  // a flat scene: z constant, x and y as trained
          c.means = first_gaussians(*cloud, 3000).means;
          for (size_t i = 0; i < c.size(); ++i) c.means[i * 3 + 2] = c.means[2];
        }
        check_archive_round_trip(c, false, {}, encoding);
      }
    }
  }
}

TEST_CASE("archive round trip: shipped guitar sample") {
  check_archive_round_trip(read_cloud(test::repo_path("samples/guitar.ply"), 90854), true);
}

TEST_CASE("archive round trip: code steps coarser than the bits, below the 4-bit minimum") {
  format::ArchiveOptions o;
  o.rotation_bits = o.scale_bits = o.opacity_bits = 4;
  o.rotation_step = 2.5;
  o.scale_step = 3;
  o.opacity_step = 1.5;
  check_archive_round_trip(read_cloud(test::repo_path("samples/guitar.ply"), 90854), false, o);
}

TEST_CASE("archive round trip: every real scene of $RGS_DATA_DIR") {
  struct Scene {
    const char* file;
    uint64_t count;
  };
  for (const Scene& s : {Scene{"mipnerf360_flowers_c3dgs.ply", 38347}, Scene{"tiny_unknown_inria_sh3_it7000.ply", 9080},
                         Scene{"biker.ply", 152746}, Scene{"playcanvas_flowers_lod0.ply", 542104}}) {
    const std::string file = s.file;
    CAPTURE(file);
    const std::string path = test::shared_scene(file);
    if (path.empty()) continue;  // shared_scene reported the skip
    check_archive_round_trip(read_cloud(path, s.count), s.count < 200000);
  }
}
