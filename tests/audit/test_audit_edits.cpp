// The audit of an edited conversion: a .rgs records its conversion's edits in its provenance, and run_audit
// compares it with the source under the same edits (decimation apart), on the bundled guitar.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "audit_test_util.h"
#include "rgs/api/convert.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/converter/cloud_edits.h"
#include "rgs/runtime/camera.h"

namespace {

using namespace rgs;

converter::EditAction edit(const std::string& name, const std::string& value) {
  auto action = converter::parse_edit_action(name, value);
  REQUIRE_MESSAGE(action.ok(), action.status().to_string());
  return *action;
}

/// `source` converted with `edits` to `name` in the temporary folder, loaded for the audit.
audit::AuditScene edited_conversion(const std::string& source, const std::vector<converter::EditAction>& edits,
                                    const std::string& name) {
  api::ConvertOptions options;
  options.edits = edits;
  const std::string path = (std::filesystem::temp_directory_path() / name).string();
  auto report = api::convert(source, path, options);
  REQUIRE_MESSAGE(report.ok(), report.status().to_string());
  return test::audit_scene(path);
}

double mean_psnr(const audit::AuditScene& source, audit::AuditScene candidate, std::string* note) {
  auto cams = runtime::orbit_cameras(source.bounds, 3, 160, 90);
  REQUIRE(cams.ok());
  std::vector<audit::AuditScene> candidates;
  candidates.push_back(std::move(candidate));
  auto result = audit::run_audit(source, candidates, *cams, {});
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  *note = result->candidates[0].reference;
  return result->candidates[0].summary.psnr_mean_db;
}

}  // namespace

TEST_CASE("recorded edits: a provenance's options text gives the conversion's edits back, in order") {
  const std::vector<converter::EditAction> edits = {
      edit("rotate", "0,90,0"), edit("filter", "opacity gt 0.05"), edit("filter-nan", ""),
      edit("crop-box-outside", "-1,-2,-3,1,2,3"), edit("decimate", "0.5")};
  std::string options = "scale_encoding=linear sh_dc_bits=16 edits=";
  for (size_t i = 0; i < edits.size(); ++i) options += (i ? "; " : "") + converter::edit_action_text(edits[i]);
  options += " spz_frame=rub";
  auto parsed = converter::parse_recorded_edits(options);
  REQUIRE_MESSAGE(parsed.ok(), parsed.status().to_string());
  REQUIRE(parsed->size() == edits.size());
  for (size_t i = 0; i < edits.size(); ++i) {
    CAPTURE(i);
    CHECK((*parsed)[i].kind == edits[i].kind);
    CHECK((*parsed)[i].values == edits[i].values);
    CHECK((*parsed)[i].outside == edits[i].outside);
    CHECK((*parsed)[i].property == edits[i].property);
  }
  auto none = converter::parse_recorded_edits("scale_encoding=linear spz_frame=rub");
  REQUIRE(none.ok());
  CHECK(none->empty());
  for (const char* bad : {" edits=crop-box '1,2", " edits=spin '1'", " edits=scale '-1'"}) {
    CAPTURE(bad);
    CHECK(converter::parse_recorded_edits(bad).status().code() == StatusCode::kInvalidArgument);
  }
}

TEST_CASE("audit of a cropped, turned conversion: against the source under the same edits, not a loss") {
  const std::string guitar = test::repo_path("samples/guitar.ply");
  const audit::AuditScene source = test::audit_scene(guitar);
  const float* c = source.bounds.sphere_center;
  const float r = source.bounds.sphere_radius;
  const std::string box = std::to_string(c[0] - 2 * r) + "," + std::to_string(c[1] - 2 * r) + "," +
                          std::to_string(c[2] - 2 * r) + "," + std::to_string(c[0]) + "," +
                          std::to_string(c[1] + 2 * r) + "," + std::to_string(c[2] + 2 * r);
  const std::vector<converter::EditAction> edits = {edit("crop-box", box), edit("rotate", "0,0,30")};
  std::string note;
  // The .rgs records its edits: it is compared with the source cropped and turned the same way, and differs from
  // it by the quantization alone.
  const double understood = mean_psnr(source, edited_conversion(guitar, edits, "rgs_test_audit_edits.rgs"), &note);
  CHECK(understood > 45.0);
  CHECK(note.find("crop-box") != std::string::npos);
  CHECK(note.find("rotate") != std::string::npos);
  // The same Gaussians as a PLY carry no record: against the whole source, the crop and the turn are differences.
  const double blind = mean_psnr(source, edited_conversion(guitar, edits, "rgs_test_audit_edits.ply"), &note);
  CHECK(blind < understood - 40.0);
  CHECK(note.empty());
  // Decimation is part of what a conversion costs: the source is not decimated, and nothing else was edited.
  const double decimated = mean_psnr(
      source, edited_conversion(guitar, {edit("decimate", "0.25")}, "rgs_test_audit_decimated.rgs"), &note);
  CHECK(note.empty());
  CHECK(decimated < understood);
}

TEST_CASE("audit of a conversion whose edits left (almost) nothing: it lost its content and fails, and says so") {
  const std::string guitar = test::repo_path("samples/guitar.ply");
  const audit::AuditScene source = test::audit_scene(guitar);
  // A box around one Gaussian's mean keeps that Gaussian; a box beside the scene keeps none.
  const float* m = &source.cloud.means[3 * 1000];
  std::string around_one;
  for (int bound : {-1, 1}) {
    for (int a = 0; a < 3; ++a) around_one += (around_one.empty() ? "" : ",") + std::to_string(m[a] + bound * 1e-4f);
  }
  api::ConvertOptions allow_empty;
  allow_empty.allow_empty = true;
  const std::string empty_path = (std::filesystem::temp_directory_path() / "rgs_test_audit_empty.rgs").string();
  allow_empty.edits = {edit("crop-box", "100,100,100,101,101,101")};
  REQUIRE(api::convert(guitar, empty_path, allow_empty).ok());
  std::vector<audit::AuditScene> candidates;
  candidates.push_back(edited_conversion(guitar, {edit("crop-box", around_one)}, "rgs_test_audit_one.rgs"));
  candidates.push_back(test::audit_scene(empty_path));
  auto cams = runtime::orbit_cameras(source.bounds, 2, 160, 90);
  REQUIRE(cams.ok());
  auto result = audit::run_audit(source, candidates, *cams, {});
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  const audit::CandidateResult& one = result->candidates[0];
  REQUIRE(one.reference_gaussians == 1);
  CHECK(one.reference.find("crop-box") != std::string::npos);
  CHECK(one.reference.find("1 of its 90,854 Gaussians") != std::string::npos);
  CHECK(one.summary.psnr_mean_db > 60.0);  // against the one Gaussian left: a perfect match that says nothing
  const audit::Verdict lost_one = audit::verdict(*result, 0, 40.0);
  CHECK(!lost_one.passed);
  CHECK(lost_one.content_lost.find("kept 1 of the source's 90,854 Gaussians") != std::string::npos);
  const audit::Verdict lost_all = audit::verdict(*result, 1, 40.0);
  CHECK(!lost_all.passed);
  CHECK(lost_all.content_lost == "it has no Gaussian");
  CHECK(!audit::passes_gate(*result, 0.0));
  const auto j = nlohmann::json::parse(audit::audit_json(*result, {}));
  CHECK(j["candidates"][0]["reference"]["gaussians"] == 1);
  CHECK(j["candidates"][0]["reference"]["description"].get<std::string>().find("crop-box") != std::string::npos);
  CHECK(j["candidates"][1]["verdict"]["content_lost"] == "it has no Gaussian");
  CHECK(j["candidates"][1]["verdict"]["passed"] == false);
}

TEST_CASE("audit of a moved conversion: the views move with its recorded edits and see the scene") {
  // Translated far away and scaled, the scene leaves the source's views: seen from them, the candidate and the
  // edited source both render black and compare as equal. Moved with the edits, the views see the scene again.
  const std::string guitar = test::repo_path("samples/guitar.ply");
  const audit::AuditScene source = test::audit_scene(guitar);
  std::vector<audit::AuditScene> candidates;
  candidates.push_back(edited_conversion(guitar, {edit("translate", "1000,0,0"), edit("rotate", "0,40,0"),
                                                  edit("scale", "2")},
                                         "rgs_test_audit_moved.rgs"));
  auto cams = runtime::orbit_cameras(source.bounds, 3, 160, 90);
  REQUIRE(cams.ok());
  auto result = audit::run_audit(source, candidates, *cams, {});
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  const audit::CandidateResult& c = result->candidates[0];
  CHECK(c.reference.find("translate") != std::string::npos);
  for (const audit::ViewMetrics& v : c.views) {
    CHECK(v.foreground_fraction > 0.05);  // the scene is in view
    CHECK(v.foreground_psnr_db > 45.0);   // and differs from the edited source by the quantization alone
    CHECK(std::isfinite(v.foreground_psnr_db));
  }
}
