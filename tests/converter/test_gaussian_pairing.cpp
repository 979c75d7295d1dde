// Pairing of two versions of one scene (converter::pair_gaussians) and the errors measured over a pairing
// (measure_paired_attribute_errors): on the shipped guitar and its SH-degree-3 excerpt, the archive encoder's own
// order (format::ArchiveScene::source_index) is the ground truth the content pairing must find, a shuffled copy
// pairs back to its permutation, and an unrelated scene pairs nothing.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/gaussian_pairing.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/archive.h"
#include "rgs/format/encoded_scene.h"
#include "test_data.h"

namespace {

using namespace rgs;

format::GaussianCloud read_cloud(const std::string& relative) {
  auto ply = converter::read_ply(test::repo_path(relative));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  return std::move(ply->cloud);
}

/// Gaussian j of the result is Gaussian order[j] of `cloud`.
format::GaussianCloud gathered(const format::GaussianCloud& cloud, const std::vector<uint64_t>& order) {
  format::GaussianCloud out;
  out.sh_degree = cloud.sh_degree;
  out.resize(order.size());
  const size_t k = cloud.sh_coefficients() * 3;
  for (size_t j = 0; j < order.size(); ++j) {
    const uint64_t i = order[j];
    std::copy_n(&cloud.means[i * 3], 3, &out.means[j * 3]);
    std::copy_n(&cloud.rotations[i * 4], 4, &out.rotations[j * 4]);
    std::copy_n(&cloud.scales[i * 3], 3, &out.scales[j * 3]);
    out.opacities[j] = cloud.opacities[i];
    std::copy_n(&cloud.sh[i * k], k, &out.sh[j * k]);
  }
  return out;
}

std::vector<uint64_t> shuffled_indices(uint64_t n, uint32_t seed) {
  std::vector<uint64_t> order(n);
  std::iota(order.begin(), order.end(), uint64_t{0});
  std::shuffle(order.begin(), order.end(), std::mt19937_64(seed));
  return order;
}

/// The largest distance the audit allows on guitar-sized scenes: 1/128 of the extent.
converter::PairingOptions options_for(const format::GaussianCloud& cloud, uint32_t threads = 0) {
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = cloud.means[size_t(a)];
  for (size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], cloud.means[i * 3 + a]);
      hi[a] = std::max(hi[a], cloud.means[i * 3 + a]);
    }
  }
  converter::PairingOptions options;
  options.max_position_distance = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}) / 128.0;
  options.threads = threads;
  return options;
}

void check_same_errors(const converter::AttributeErrors& a, const converter::AttributeErrors& b) {
  CHECK(a.position.max == b.position.max);
  CHECK(a.position.rms == b.position.rms);
  CHECK(a.rotation_deg.max == b.rotation_deg.max);
  CHECK(a.rotation_deg.rms == b.rotation_deg.rms);
  CHECK(a.scale_of_largest_axis.max == b.scale_of_largest_axis.max);
  CHECK(a.scale_relative.rms == b.scale_relative.rms);
  CHECK(a.opacity.max == b.opacity.max);
  CHECK(a.opacity.rms == b.opacity.rms);
  for (int d = 0; d < 4; ++d) {
    CHECK(a.sh[d].max == b.sh[d].max);
    CHECK(a.sh[d].rms == b.sh[d].rms);
    CHECK(a.sh[d].samples == b.sh[d].samples);
  }
}

/// The archive of `cloud` with `archive_options`, its decoded cloud paired with `cloud`: the pairing must be
/// the encoder's own order, Gaussian for Gaussian, and the errors over it those over the encoder's order.
void check_archive_pairing(const format::GaussianCloud& cloud, const format::ArchiveOptions& archive_options) {
  converter::QuantizeOptions quantize_options;
  quantize_options.sh_dc_bits = 8;  // what the archive stores
  auto encoded = converter::quantize(cloud, quantize_options);
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  auto archive = format::encode_archive(*encoded, archive_options);
  REQUIRE_MESSAGE(archive.ok(), archive.status().to_string());
  auto decoded = format::dequantize(archive->decoded);
  REQUIRE_MESSAGE(decoded.ok(), decoded.status().to_string());
  // The archive's Draco order is not the source's: index by index would compare unrelated Gaussians.
  REQUIRE(!std::is_sorted(archive->source_index.begin(), archive->source_index.end()));
  auto pairing = converter::pair_gaussians(cloud, *decoded, options_for(cloud));
  REQUIRE_MESSAGE(pairing.ok(), pairing.status().to_string());
  CHECK(pairing->method == converter::PairingMethod::kContent);
  REQUIRE(pairing->complete());
  CHECK(pairing->unpaired_reference == archive->omitted.size());
  CHECK(pairing->reference_of_test == archive->source_index);
  // τ follows the archive's position error: at most twice the largest, √3 / 2 steps per Gaussian.
  CHECK(pairing->position_tolerance > 0);
  CHECK(pairing->position_tolerance <= 2 * std::sqrt(3.0) / 2 * archive->position.step * (1 + 1e-6));
  auto over_pairing = converter::measure_paired_attribute_errors(cloud, *decoded, pairing->reference_of_test);
  auto over_truth = converter::measure_paired_attribute_errors(cloud, *decoded, archive->source_index);
  REQUIRE(over_pairing.ok());
  REQUIRE(over_truth.ok());
  check_same_errors(*over_pairing, *over_truth);
  CHECK(over_pairing->position.max <= std::sqrt(3.0) / 2 * archive->position.step * (1 + 1e-6));
  CHECK(over_pairing->position.samples == decoded->size());
}

TEST_CASE("an archive pairs back to the encoder's own order, Gaussians left out included") {
  for (const char* scene : {"samples/guitar.ply", test::kGuitarSh3}) {
    CAPTURE(scene);
    const format::GaussianCloud cloud = read_cloud(scene);
    format::ArchiveOptions defaults;
    defaults.zstd_level = 1;  // the bytes, not the decoded values
    defaults.xz = false;
    check_archive_pairing(cloud, defaults);
    // An opacity floor leaves Gaussians out: the pairing finds the others among them.
    format::ArchiveOptions floor = defaults;
    floor.opacity_floor = 0.1;
    check_archive_pairing(cloud, floor);
  }
}

TEST_CASE("a shuffled copy pairs back to its permutation, with the errors of the unshuffled one") {
  const format::GaussianCloud cloud = read_cloud(test::kGuitarSh3);
  auto same = converter::pair_gaussians(cloud, cloud, options_for(cloud));
  REQUIRE(same.ok());
  CHECK(same->method == converter::PairingMethod::kIndex);
  CHECK(same->position_tolerance == 0);
  std::vector<uint64_t> identity(cloud.size());
  std::iota(identity.begin(), identity.end(), uint64_t{0});
  CHECK(same->reference_of_test == identity);

  // A lossy version (the runtime profile's values) in a shuffled order, a few Gaussians left out.
  auto encoded = converter::quantize(cloud, {});
  REQUIRE(encoded.ok());
  auto lossy = format::dequantize(*encoded);
  REQUIRE(lossy.ok());
  std::vector<uint64_t> order = shuffled_indices(cloud.size(), 7);
  order.resize(cloud.size() - 100);
  const format::GaussianCloud shuffled = gathered(*lossy, order);
  for (uint32_t threads : {1u, 2u}) {
    CAPTURE(threads);
    auto pairing = converter::pair_gaussians(cloud, shuffled, options_for(cloud, threads));
    REQUIRE_MESSAGE(pairing.ok(), pairing.status().to_string());
    CHECK(pairing->method == converter::PairingMethod::kContent);
    REQUIRE(pairing->complete());
    CHECK(pairing->reference_of_test == order);
    CHECK(pairing->unpaired_reference == 100);
  }
  // The errors over a pairing do not depend on the candidate's order: those of the lossy cloud in the source's
  // order (index by index, its 100 Gaussians left out).
  std::vector<uint64_t> kept = order;
  std::sort(kept.begin(), kept.end());
  const format::GaussianCloud in_order = gathered(*lossy, kept);
  auto shuffled_errors = converter::measure_paired_attribute_errors(cloud, shuffled, order);
  auto in_order_errors = converter::measure_paired_attribute_errors(cloud, in_order, kept);
  REQUIRE(shuffled_errors.ok());
  REQUIRE(in_order_errors.ok());
  check_same_errors(*shuffled_errors, *in_order_errors);
  // The identity pairing gives measure_attribute_errors bit for bit.
  auto paired = converter::measure_paired_attribute_errors(cloud, *lossy, identity);
  auto by_index = converter::measure_attribute_errors(cloud, *lossy);
  REQUIRE(paired.ok());
  REQUIRE(by_index.ok());
  check_same_errors(*paired, *by_index);
  CHECK(by_index->rotation_deg.max > 0);
}

TEST_CASE("an unrelated scene or too many Gaussians pair nothing") {
  const format::GaussianCloud cloud = read_cloud("samples/guitar.ply");
  // The same count of Gaussians, mirrored across the scene's middle: another scene, mostly nowhere near.
  format::GaussianCloud mirrored = cloud;
  float lo = cloud.means[0], hi = cloud.means[0];
  for (size_t i = 0; i < cloud.size(); ++i) {
    lo = std::min(lo, cloud.means[i * 3]);
    hi = std::max(hi, cloud.means[i * 3]);
  }
  for (size_t i = 0; i < cloud.size(); ++i) mirrored.means[i * 3] = lo + hi - cloud.means[i * 3];
  auto pairing = converter::pair_gaussians(cloud, mirrored, options_for(cloud));
  REQUIRE(pairing.ok());
  CHECK(!pairing->complete());
  CHECK(pairing->far_test > 0);
  CHECK(pairing->unpaired_test == pairing->far_test);
  CHECK(pairing->reference_of_test.empty());
  CHECK(pairing->position_tolerance == options_for(cloud).max_position_distance);

  // Every Gaussian twice: half of them have no partner of their own.
  const format::GaussianCloud excerpt = read_cloud(test::kGuitarSh3);
  std::vector<uint64_t> twice(excerpt.size() * 2);
  for (size_t j = 0; j < twice.size(); ++j) twice[j] = j / 2;
  auto doubled = converter::pair_gaussians(excerpt, gathered(excerpt, twice), options_for(excerpt));
  REQUIRE(doubled.ok());
  CHECK(doubled->far_test == 0);
  CHECK(doubled->unpaired_test == excerpt.size());
  CHECK(doubled->reference_of_test.empty());
}

TEST_CASE("bad pairings are refused") {
  const format::GaussianCloud cloud = read_cloud(test::kGuitarSh3);
  converter::PairingOptions negative;
  negative.max_position_distance = -1;
  CHECK(converter::pair_gaussians(cloud, cloud, negative).status().code() == StatusCode::kInvalidArgument);
  std::vector<uint64_t> twice(cloud.size(), 0);
  CHECK(converter::measure_paired_attribute_errors(cloud, cloud, twice).status().code() ==
        StatusCode::kInvalidArgument);
  std::vector<uint64_t> beyond(cloud.size(), cloud.size());
  CHECK(converter::measure_paired_attribute_errors(cloud, cloud, beyond).status().code() ==
        StatusCode::kInvalidArgument);
  CHECK(converter::measure_paired_attribute_errors(cloud, cloud, {}).status().code() == StatusCode::kInvalidArgument);
}

}  // namespace
