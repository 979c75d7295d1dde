// Attribute errors and attribution of candidates stored in another order than the source, or lacking some of its
// Gaussians: an archive .rgs (Draco's order, Gaussians left out), a level-of-detail .rgs (chunk order), SOG and
// SPZ (positions quantized), a shuffled PLY, and a scene that is not the source's. The audit pairs Gaussians by
// content (audit::pair_with_source) and must report the converter's own figures, or say that it cannot.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "audit_test_util.h"
#include "rgs/api/convert.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/audit/audit_scene.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/runtime/camera.h"

namespace {

using namespace rgs;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / name).string();
}

/// `source` converted by api::convert into `name` in the temporary folder; the report with the converter's own
/// figures.
api::ConvertReport convert_to(const std::string& source, const std::string& name, const api::ConvertOptions& options) {
  auto report = api::convert(source, temp_path(name), options);
  REQUIRE_MESSAGE(report.ok(), report.status().to_string());
  return std::move(report).value();
}

/// One CPU audit on one small view (the attribute errors are what these tests read).
audit::AuditResult audited(const audit::AuditScene& source, const std::vector<audit::AuditScene>& cands) {
  auto cams = runtime::orbit_cameras(source.bounds, 1, 64, 36);
  REQUIRE(cams.ok());
  audit::AuditOptions options;
  options.worst_views = 0;
  auto result = audit::run_audit(source, cands, *cams, options);
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  return std::move(result).value();
}

void check_stats(const converter::ErrorStats& audit, const converter::ErrorStats& own, double epsilon) {
  CHECK(audit.samples == own.samples);
  CHECK(audit.max == doctest::Approx(own.max).epsilon(epsilon));
  CHECK(audit.rms == doctest::Approx(own.rms).epsilon(epsilon));
}

/// The audit's errors against the converter's (or another reference measurement's), attribute by attribute, each
/// within `epsilon` relative.
void check_errors(const converter::AttributeErrors& audit, const converter::AttributeErrors& own, uint32_t degree,
                  double epsilon = 1e-9) {
  check_stats(audit.position, own.position, epsilon);
  check_stats(audit.rotation_deg, own.rotation_deg, epsilon);
  check_stats(audit.scale_relative, own.scale_relative, epsilon);
  check_stats(audit.scale_of_largest_axis, own.scale_of_largest_axis, epsilon);
  check_stats(audit.opacity, own.opacity, epsilon);
  for (uint32_t d = 0; d <= degree; ++d) {
    CAPTURE(d);
    check_stats(audit.sh[d], own.sh[d], epsilon);
    for (int c = 0; c < 3; ++c) check_stats(audit.sh_channel[d][c], own.sh_channel[d][c], epsilon);
  }
}

/// Gaussian j of the result is Gaussian order[j] of `cloud`.
format::GaussianCloud gathered(const format::GaussianCloud& cloud, const std::vector<uint64_t>& order) {
  format::GaussianCloud out;
  out.sh_degree = cloud.sh_degree;
  out.resize(order.size());
  const size_t k = cloud.sh_coefficients() * 3;
  for (size_t j = 0; j < order.size(); ++j) {
    std::copy_n(&cloud.means[order[j] * 3], 3, &out.means[j * 3]);
    std::copy_n(&cloud.rotations[order[j] * 4], 4, &out.rotations[j * 4]);
    std::copy_n(&cloud.scales[order[j] * 3], 3, &out.scales[j * 3]);
    out.opacities[j] = cloud.opacities[order[j]];
    std::copy_n(&cloud.sh[order[j] * k], k, &out.sh[j * k]);
  }
  return out;
}

/// `cloud` written as a PLY named `name` in the temporary folder and loaded for the audit.
audit::AuditScene written_ply(const format::GaussianCloud& cloud, const std::string& name) {
  REQUIRE(converter::write_ply(temp_path(name), cloud).ok());
  return test::audit_scene(temp_path(name));
}

const char* const kScenes[] = {"samples/guitar.ply", test::kGuitarSh3};

TEST_CASE("reordered outputs: the audit's attribute errors are the converter's own") {
  for (const char* scene : kScenes) {
    CAPTURE(scene);
    const std::string path = test::repo_path(scene);
    const audit::AuditScene source = test::audit_scene(path);
    api::ConvertOptions archive;
    archive.profile = format::StorageProfile::kArchive;
    archive.archive.opacity_floor = 0;  // every Gaussian kept (the default leaves out those that never blend)
    api::ConvertOptions floor = archive;  // leaves Gaussians out
    floor.archive.opacity_floor = 0.1;
    api::ConvertOptions lod;
    lod.lod_levels = 0;
    const api::ConvertReport own_archive = convert_to(path, "rgs_test_pairing_archive.rgs", archive);
    const api::ConvertReport own_floor = convert_to(path, "rgs_test_pairing_floor.rgs", floor);
    const api::ConvertReport own_lod = convert_to(path, "rgs_test_pairing_lod.rgs", lod);
    REQUIRE(own_floor.rgs->archive_omitted > 0);
    convert_to(path, "rgs_test_pairing.sog", {});
    convert_to(path, "rgs_test_pairing.spz", {});
    const std::vector<audit::AuditScene> cands = {
        test::audit_scene(temp_path("rgs_test_pairing_archive.rgs")),
        test::audit_scene(temp_path("rgs_test_pairing_floor.rgs")),
        test::audit_scene(temp_path("rgs_test_pairing_lod.rgs")),
        test::audit_scene(temp_path("rgs_test_pairing.sog")),
        test::audit_scene(temp_path("rgs_test_pairing.spz"))};
    const std::vector<audit::CandidateResult> results = audited(source, cands).candidates;
    for (const audit::CandidateResult& c : results) {
      CAPTURE(c.scene.path);
      REQUIRE_MESSAGE(c.attributes.has_value(), c.attributes_note);
      CHECK(c.attributes->pairing == converter::PairingMethod::kContent);
    }
    const uint32_t degree = source.cloud.sh_degree;
    check_errors(results[0].attributes->errors, own_archive.rgs->errors, degree);
    CHECK(results[0].attributes->source_unpaired == 0);
    check_errors(results[1].attributes->errors, own_floor.rgs->errors, degree);
    CHECK(results[1].attributes->source_unpaired == own_floor.rgs->archive_omitted);
    check_errors(results[2].attributes->errors, own_lod.rgs->errors, degree);
    CHECK(results[2].attributes->position_tolerance == 0);  // the same means, in chunk order
    // SOG and SPZ keep the source's order: the content pairing must find it, so the errors are those index by
    // index.
    for (size_t i = 3; i < 5; ++i) {
      auto by_index = converter::measure_attribute_errors(source.cloud, cands[i].cloud);
      REQUIRE(by_index.ok());
      check_errors(results[i].attributes->errors, *by_index, degree);
    }
  }
}

TEST_CASE("splat-transform's SOG and compressed PLY of a crop: Morton order, a subset of the source") {
  // tests/data/sog/make_sog_reference.py: 877 Gaussians of samples/guitar.ply, cropped and written by
  // splat-transform 3.7, which stores them in Morton order.
  const audit::AuditScene source = test::audit_scene(test::repo_path("samples/guitar.ply"));
  const std::vector<audit::AuditScene> cands = {
      test::audit_scene(test::repo_path("tests/data/sog/guitar_crop.sog")),
      test::audit_scene(test::repo_path("tests/data/sog/guitar_crop_sog_reference.ply")),
      test::audit_scene(test::repo_path("tests/data/sog/guitar_crop.compressed.ply"))};
  const std::vector<audit::CandidateResult> results = audited(source, cands).candidates;
  for (const audit::CandidateResult& c : results) {
    CAPTURE(c.scene.path);
    REQUIRE_MESSAGE(c.attributes.has_value(), c.attributes_note);
    CHECK(c.attributes->pairing == converter::PairingMethod::kContent);
    CHECK(c.attributes->source_unpaired == source.cloud.size() - 877);
    CHECK(c.attributes->errors.position.samples == 877);
  }
  // Far below the 3.5e-05 units between guitar's two nearest Gaussians: each pair is the Gaussian itself.
  CHECK(results[0].attributes->errors.position.max < 1e-5);
  CHECK(results[2].attributes->errors.position.max < 3e-4);
  CHECK(results[2].attributes->errors.sh[0].max < 0.02);
  // The SOG and splat-transform's own decode of it: the same values (to the PLY's float rounding of the
  // quaternions), so the same errors.
  check_errors(results[0].attributes->errors, results[1].attributes->errors, 0, 1e-4);
}

TEST_CASE("a shuffled candidate gives the errors of the unshuffled one") {
  const std::string path = test::repo_path(test::kGuitarSh3);
  const audit::AuditScene source = test::audit_scene(path);
  api::ConvertOptions archive;
  archive.profile = format::StorageProfile::kArchive;
  convert_to(path, "rgs_test_pairing_shuffle.rgs", archive);
  const audit::AuditScene decoded = test::audit_scene(temp_path("rgs_test_pairing_shuffle.rgs"));
  std::vector<uint64_t> order(decoded.cloud.size());
  std::iota(order.begin(), order.end(), uint64_t{0});
  const audit::AuditScene in_file_order = written_ply(decoded.cloud, "rgs_test_pairing_unshuffled.ply");
  std::shuffle(order.begin(), order.end(), std::mt19937_64(11));
  const audit::AuditScene shuffled = written_ply(gathered(decoded.cloud, order), "rgs_test_pairing_shuffled.ply");
  // The source itself, shuffled: paired exactly, no error at all.
  const audit::AuditScene source_shuffled = written_ply(gathered(source.cloud, order), "rgs_test_pairing_source.ply");
  const std::vector<audit::CandidateResult> results =
      audited(source, {in_file_order, shuffled, source_shuffled}).candidates;
  for (const audit::CandidateResult& c : results) {
    CAPTURE(c.scene.path);
    REQUIRE_MESSAGE(c.attributes.has_value(), c.attributes_note);
    CHECK(c.attributes->pairing == converter::PairingMethod::kContent);
  }
  const converter::AttributeErrors& a = results[0].attributes->errors;
  const converter::AttributeErrors& b = results[1].attributes->errors;
  CHECK(a.position.max > 0);
  CHECK(a.position.max == b.position.max);
  CHECK(a.position.rms == b.position.rms);
  CHECK(a.rotation_deg.max == b.rotation_deg.max);
  CHECK(a.rotation_deg.rms == b.rotation_deg.rms);
  CHECK(a.scale_of_largest_axis.max == b.scale_of_largest_axis.max);
  CHECK(a.opacity.max == b.opacity.max);
  for (int d = 0; d < 4; ++d) {
    CHECK(a.sh[d].max == b.sh[d].max);
    CHECK(a.sh[d].rms == b.sh[d].rms);
  }
  const converter::AttributeErrors& exact = results[2].attributes->errors;
  CHECK(results[2].attributes->position_tolerance == 0);
  CHECK(exact.position.max == 0);
  CHECK(exact.rotation_deg.max < 1e-3);  // the PLY's quaternions normalized again
  CHECK(exact.opacity.max < 1e-6);       // and its opacities through the logit
  CHECK(exact.sh[0].max == 0);
}

TEST_CASE("a candidate that is not the source's scene gets a note, not numbers") {
  const audit::AuditScene source = test::audit_scene(test::repo_path("samples/guitar.ply"));
  // The same number of Gaussians, mirrored across the scene's middle.
  format::GaussianCloud mirrored = source.cloud;
  float lo = mirrored.means[0], hi = mirrored.means[0];
  for (size_t i = 0; i < mirrored.size(); ++i) {
    lo = std::min(lo, mirrored.means[i * 3]);
    hi = std::max(hi, mirrored.means[i * 3]);
  }
  for (size_t i = 0; i < mirrored.size(); ++i) mirrored.means[i * 3] = lo + hi - mirrored.means[i * 3];
  const audit::AuditScene other = written_ply(mirrored, "rgs_test_pairing_mirrored.ply");
  const audit::AuditResult result = audited(source, {other});
  const audit::CandidateResult& c = result.candidates[0];
  CHECK(!c.attributes.has_value());
  CHECK(c.attributes_note.rfind("attribute errors not measured: ", 0) == 0);
  CHECK(c.attributes_note.find("candidate Gaussians have no source Gaussian within") != std::string::npos);
  MESSAGE(c.attributes_note);
  const auto j = nlohmann::json::parse(audit::audit_json(result, {}));
  CHECK(j["candidates"][0]["errors"].is_null());
  CHECK(j["candidates"][0]["errors_note"] == c.attributes_note);
  auto hybrids = audit::attribution_scenes(source, other);
  CHECK(hybrids.status().code() == StatusCode::kInvalidArgument);
  CHECK(hybrids.status().message().find("have no source Gaussian within") != std::string::npos);
}

TEST_CASE("attribution of an archive: each candidate Gaussian's values on the source Gaussian it is paired with") {
  const std::string path = test::repo_path("samples/guitar.ply");
  const audit::AuditScene source = test::audit_scene(path);
  api::ConvertOptions floor;
  floor.profile = format::StorageProfile::kArchive;
  floor.archive.opacity_floor = 0.1;
  const api::ConvertReport own = convert_to(path, "rgs_test_pairing_attribution.rgs", floor);
  const audit::AuditScene archive = test::audit_scene(temp_path("rgs_test_pairing_attribution.rgs"));
  auto pairing = audit::pair_with_source(source, archive);
  REQUIRE(pairing.ok());
  REQUIRE(pairing->complete());
  auto hybrids = audit::attribution_scenes(source, archive);
  REQUIRE_MESSAGE(hybrids.ok(), hybrids.status().to_string());
  REQUIRE(hybrids->size() == 5);  // SH degree 0
  const format::GaussianCloud& means_only = (*hybrids)[0].cloud;
  const format::GaussianCloud& opacities_only = (*hybrids)[3].cloud;
  size_t misplaced = 0;
  for (size_t j = 0; j < archive.cloud.size(); ++j) {
    const uint64_t i = pairing->reference_of_test[j];
    for (int a = 0; a < 3; ++a) misplaced += means_only.means[i * 3 + a] != archive.cloud.means[j * 3 + a];
    misplaced += opacities_only.opacities[i] != archive.cloud.opacities[j];
  }
  CHECK(misplaced == 0);
  // The Gaussians the archive left out: opacity 0 in the opacities scene, the source's values elsewhere.
  const auto zero = std::count(opacities_only.opacities.begin(), opacities_only.opacities.end(), 0.f);
  CHECK(uint64_t(zero) >= own.rgs->archive_omitted);
  CHECK(means_only.opacities == source.cloud.opacities);

  std::vector<audit::AuditScene> cands{archive};
  for (audit::AuditScene& h : *hybrids) cands.push_back(std::move(h));
  auto cams = runtime::orbit_cameras(source.bounds, 2, 160, 90);
  REQUIRE(cams.ok());
  auto result = audit::run_audit(source, cands, *cams, {});
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  const double whole = result->candidates[0].summary.psnr_mean_db;
  MESSAGE("archive " << whole << " dB; means only " << result->candidates[1].summary.psnr_mean_db << " dB");
  // Each group alone costs less than the whole file (index by index, means alone read 25 dB on a 73 dB file).
  for (size_t c = 1; c < result->candidates.size(); ++c) {
    CAPTURE(result->candidates[c].scene.label);
    CHECK(result->candidates[c].summary.psnr_mean_db > whole - 0.5);
    REQUIRE(result->candidates[c].attributes.has_value());
    CHECK(result->candidates[c].attributes->pairing == converter::PairingMethod::kIndex);
  }
  // The means alone carry the archive's own position errors, over the Gaussians it kept.
  CHECK(result->candidates[1].attributes->errors.position.max == own.rgs->errors.position.max);
}

}  // namespace
