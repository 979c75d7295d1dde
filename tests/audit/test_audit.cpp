// The audit loop on the CPU reference: sizes, attribute errors, per-view metrics, worst-view images, JSON and
// the gate, on the bundled guitar and a conversion of it made in memory.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <vector>

#include "audit_test_util.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/runtime/camera.h"

namespace {

using namespace rgs;

std::vector<runtime::Camera> small_orbit(const format::SceneBounds& bounds, uint32_t views) {
  auto cams = runtime::orbit_cameras(bounds, views, 160, 90);
  REQUIRE_MESSAGE(cams.ok(), cams.status().to_string());
  return std::move(cams).value();
}

const audit::AuditScene& guitar() {
  static const audit::AuditScene s = test::audit_scene(test::repo_path("samples/guitar.ply"));
  return s;
}

TEST_CASE("CPU audit of guitar against its conversion") {
  const audit::AuditScene& source = guitar();
  std::vector<audit::AuditScene> candidates;
  candidates.push_back(test::converted_scene(source, "rgs_test_audit_guitar.rgs"));
  const auto cams = small_orbit(source.bounds, 4);
  audit::AuditOptions options;
  options.worst_views = 2;
  options.image_max_side = 64;  // 160x90 -> factor 3 -> 53x30
  options.keep_worst_heatmap = true;
  size_t progress_calls = 0;
  options.progress = [&](const audit::AuditProgress& p) {
    ++progress_calls;
    CHECK(p.views_done == progress_calls);
    CHECK(p.views_total == 4);
    CHECK(p.psnr_db.size() == 1);
    CHECK(p.remaining_s >= 0);
  };
  auto result = audit::run_audit(source, candidates, cams, options);
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  CHECK(progress_calls == 4);
  CHECK(result->backend == audit::Backend::kCpu);
  REQUIRE(result->candidates.size() == 1);
  const audit::CandidateResult& c = result->candidates[0];
  CHECK(c.scene.format == "rgs");
  CHECK(c.scene.gaussians == source.info.gaussians);
  CHECK(!c.scene.sections.empty());
  uint64_t stored = c.scene.overhead_bytes;
  for (const auto& s : c.scene.sections) stored += s.stored_bytes;
  CHECK(stored == c.scene.file_bytes);
  REQUIRE(c.attributes.has_value());
  CHECK(c.attributes->sh_quantization.has_value());
  CHECK(c.attributes->errors.position.max == 0.0);  // means are stored as FP32
  CHECK(c.attributes->errors.sh[0].max > 0.0);
  REQUIRE(c.views.size() == 4);
  for (const auto& v : c.views) {
    CHECK(std::isfinite(v.psnr_db));
    CHECK(v.psnr_db > 50.0);  // INT8 SH and FP16 geometry: far above visible loss
    CHECK(v.ssim > 0.999);
    CHECK(v.max_abs_diff > 0.f);
    CHECK(v.max_abs_diff < 0.05f);
  }
  for (const auto& v : c.views) CHECK(audit::verdict_view_psnr_db(c.views[c.summary.worst_view]) <= audit::verdict_view_psnr_db(v));
  REQUIRE(c.worst.size() == 2);
  CHECK(c.worst[0].view == c.summary.worst_view);
  CHECK(audit::verdict_view_psnr_db(c.views[c.worst[0].view]) <= audit::verdict_view_psnr_db(c.views[c.worst[1].view]));
  CHECK(c.worst[0].source.width == 53);
  CHECK(c.worst[0].source.height == 30);
  CHECK(c.worst[0].difference.channels == 1);
  // The candidate's own heat scale: the 99th percentile (nearest rank) of the non-zero |Δ| of its heatmaps,
  // so that most heatmap pixels with a difference are visibly above black.
  std::vector<float> nonzero;
  for (const auto& w : c.worst) {
    for (float d : w.abs_difference) {
      if (d > 0.f) nonzero.push_back(d);
    }
  }
  REQUIRE(!nonzero.empty());
  std::sort(nonzero.begin(), nonzero.end());
  CHECK(c.heat_scale == nonzero[size_t(std::ceil(0.99 * double(nonzero.size()))) - 1]);
  CHECK(c.heat_scale > 0.f);
  CHECK(c.heat_scale <= c.summary.max_abs_diff);
  // Pixels visibly above black (16 of 255) on this scale and on the largest |Δ|'s.
  size_t lit = 0, lit_on_max = 0, total = 0;
  for (const auto& w : c.worst) {
    CHECK(w.heat_scale == c.heat_scale);
    REQUIRE(w.abs_difference.size() == size_t{53} * 30);
    REQUIRE(w.difference.pixels.size() == w.abs_difference.size());
    for (size_t p = 0; p < w.abs_difference.size(); ++p) {
      const double expected = std::floor(double(w.abs_difference[p]) / c.heat_scale * 255.0 + 0.5);
      CHECK(double(w.difference.pixels[p]) == std::min(expected, 255.0));
      lit += w.difference.pixels[p] >= 16;
      lit_on_max += w.abs_difference[p] / c.summary.max_abs_diff * 255.f >= 15.5f;
      ++total;
    }
  }
  MESSAGE("heatmap pixels above 16/255: " << lit << " of " << total << " (" << lit_on_max << " on the largest |d|)");
  CHECK(lit >= lit_on_max);
  CHECK(double(lit) > 0.01 * double(total));
  CHECK(c.worst_heatmap.width == 160);
  CHECK(c.worst_heatmap.height == 90);
  // Foreground PSNR: guitar on a black background covers part of each view; the background only adds zero
  // error terms, so psnr - 10·log10(1 / fraction) <= foreground PSNR < psnr (equal when the candidate leaves
  // the source's background black).
  for (const auto& v : c.views) {
    CHECK(v.foreground_fraction > 0.0);
    CHECK(v.foreground_fraction < 1.0);
    CHECK(v.foreground_psnr_db < v.psnr_db);
    CHECK(v.foreground_psnr_db >= v.psnr_db - 10 * std::log10(1.0 / v.foreground_fraction) - 1e-9);
    CHECK(v.render_seconds > 0.0);
    CHECK(v.render_seconds <= v.seconds);
  }
  CHECK(c.summary.foreground_psnr_min_db <= c.summary.foreground_psnr_mean_db);
  CHECK(c.scene.load_seconds > 0.0);
  CHECK(result->source.load_seconds > 0.0);

  audit::ReportOptions ro;
  ro.tool_version = "test";
  ro.min_psnr_db = 40.0;
  ro.image_dir = "imgs/";
  const auto j = nlohmann::json::parse(audit::audit_json(*result, ro));
  CHECK(j["schema"] == "rgs-audit");
  CHECK(j["schema_version"] == audit::kAuditSchemaVersion);
  CHECK(j["backend"] == "cpu");
  CHECK(j["views"].size() == 4);
  CHECK(j["candidates"][0]["views"].size() == 4);
  CHECK(j["candidates"][0]["worst_views"].size() == 2);
  CHECK(j["candidates"][0]["worst_views"][0]["source_image"].get<std::string>().rfind("imgs/c0_v", 0) == 0);
  CHECK(j["gate"]["passed"] == true);
  CHECK(j["candidates"][0]["heat_scale"].get<float>() == c.heat_scale);
  CHECK(j["heat_scale_percentile"] == audit::kHeatScalePercentile);
  CHECK(j["verdict"]["threshold_db"] == audit::kDefaultVerdictThresholdDb);
  CHECK(j["verdict"]["passed"] == true);
  // Guitar has background: the verdict and the gate are on the foreground PSNR, the whole frame beside it.
  CHECK(audit::verdict_metric(*result) == audit::VerdictMetric::kForeground);
  CHECK(j["verdict"]["metric"] == "foreground");
  CHECK(j["gate"]["metric"] == "foreground");
  const auto& cv = j["candidates"][0]["verdict"];
  CHECK(cv["metric"] == "foreground");
  CHECK(cv["psnr_mean_db"].get<double>() == c.summary.foreground_psnr_mean_db);
  CHECK(cv["foreground_psnr_mean_db"].get<double>() == c.summary.foreground_psnr_mean_db);
  CHECK(cv["whole_frame_psnr_mean_db"].get<double>() == c.summary.psnr_mean_db);
  CHECK(cv["worst_view"]["psnr_db"].get<double>() == c.summary.foreground_psnr_min_db);
  // A threshold between the foreground and the whole-frame mean fails: the whole frame would pass it.
  const double between = (c.summary.foreground_psnr_mean_db + c.summary.psnr_mean_db) / 2;
  CHECK(!audit::verdict(*result, 0, between).passed);
  CHECK(audit::verdict(*result, 0, c.summary.foreground_psnr_mean_db).passed);
  // The gate on every view's foreground PSNR: between the foreground and the whole-frame minimum it fails.
  CHECK(!audit::passes_gate(*result, (c.summary.foreground_psnr_min_db + c.summary.psnr_min_db) / 2));
  CHECK(audit::passes_gate(*result, c.summary.foreground_psnr_min_db));
  CHECK(j["candidates"][0]["views"][0]["foreground_psnr_db"].get<double>() == c.views[0].foreground_psnr_db);
  CHECK(audit::passes_gate(*result, 40.0));
  CHECK(!audit::passes_gate(*result, 200.0));
  // Bytes per Gaussian of the source, also for a file that stores fewer Gaussians (an archive without its
  // opacity-0 ones).
  audit::AuditResult fewer = *result;
  fewer.candidates[0].scene.gaussians /= 2;
  const auto jf = nlohmann::json::parse(audit::audit_json(fewer, ro));
  const double per_source = double(c.scene.file_bytes) / double(result->source.gaussians);
  CHECK(jf["candidates"][0]["bytes_per_gaussian"].get<double>() == doctest::Approx(per_source).epsilon(1e-12));
  CHECK(jf["candidates"][0]["gaussians"] == c.scene.gaussians / 2);

  const auto dir = std::filesystem::temp_directory_path() / "rgs_test_audit_images";
  std::filesystem::remove_all(dir);
  REQUIRE(audit::write_report_images(*result, dir.string()).ok());
  const auto first = dir / j["candidates"][0]["worst_views"][0]["diff_image"].get<std::string>().substr(5);
  CHECK(std::filesystem::exists(first));
  CHECK(std::filesystem::file_size(first) == 53 * 30 + std::string("P5\n53 30\n255\n").size());
}

TEST_CASE("worst view: the summary, the images, the heatmap and the verdict name one view, by the verdict's PSNR") {
  // Guitar with one bright Gaussian added near the first camera, in the corner of its image where the source shows
  // background: that view's whole frame loses most, its foreground nothing. Ranked by the whole frame, the table
  // and the images would name another view than the verdict, which judges the foreground.
  const audit::AuditScene& source = guitar();
  const auto cams = small_orbit(source.bounds, 6);
  const runtime::Camera& cam = cams[0];
  const std::array<float, 3> eye = runtime::camera_centre(cam);
  const double depth = 0.5 * std::sqrt(std::pow(eye[0] - source.bounds.sphere_center[0], 2) +
                                       std::pow(eye[1] - source.bounds.sphere_center[1], 2) +
                                       std::pow(eye[2] - source.bounds.sphere_center[2], 2));
  const double x = (8.0 - cam.cx) * depth / cam.fx, y = (8.0 - cam.cy) * depth / cam.fy;  // pixel (8, 8)
  audit::AuditScene floater = source;
  format::GaussianCloud& cloud = floater.cloud;
  const size_t n = cloud.size(), k = cloud.sh_coefficients();
  cloud.resize(n + 1);
  for (int a = 0; a < 3; ++a) {  // eye + Rᵀ·(x, y, depth): the camera's axes are the rotation's rows
    cloud.means[n * 3 + a] = float(eye[a] + cam.rotation[a] * x + cam.rotation[3 + a] * y + cam.rotation[6 + a] * depth);
    cloud.scales[n * 3 + a] = float(3.0 * depth / cam.fx);  // about 3 pixels
    cloud.sh[(n * k) * 3 + a] = 1.7f;                        // white
  }
  cloud.rotations[n * 4] = 1.f;
  cloud.opacities[n] = 1.f;
  floater.info.gaussians = n + 1;
  audit::AuditOptions options;
  options.worst_views = 2;
  options.keep_worst_heatmap = true;
  auto result = audit::run_audit(source, {floater}, cams, options);
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  const audit::CandidateResult& c = result->candidates[0];
  size_t by_whole_frame = 0, by_verdict = 0;
  for (size_t v = 0; v < c.views.size(); ++v) {
    if (c.views[v].psnr_db < c.views[by_whole_frame].psnr_db) by_whole_frame = v;
    if (audit::verdict_view_psnr_db(c.views[v]) < audit::verdict_view_psnr_db(c.views[by_verdict])) by_verdict = v;
  }
  REQUIRE_MESSAGE(by_whole_frame != by_verdict, "the floater must make the two rankings differ");
  CHECK(c.summary.worst_view == by_verdict);
  CHECK(audit::verdict(*result, 0, 40.0).worst_view == result->views[by_verdict].name);
  REQUIRE(!c.worst.empty());
  CHECK(c.worst[0].view == by_verdict);
  const auto j = nlohmann::json::parse(audit::audit_json(*result, {}));
  CHECK(j["candidates"][0]["worst_view"] == result->views[by_verdict].name);
  CHECK(j["candidates"][0]["verdict"]["worst_view"]["name"] == result->views[by_verdict].name);
}

TEST_CASE("a scene against itself: PSNR inf, SSIM 1, no difference, two candidates in one run") {
  const audit::AuditScene& source = guitar();
  std::vector<audit::AuditScene> candidates;
  candidates.push_back(test::audit_scene(test::repo_path("samples/guitar.ply")));
  candidates.push_back(test::converted_scene(source, "rgs_test_audit_guitar2.rgs"));
  audit::AuditOptions options;
  options.worst_views = 1;
  auto result = audit::run_audit(source, candidates, small_orbit(source.bounds, 2), options);
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  REQUIRE(result->candidates.size() == 2);
  for (const auto& v : result->candidates[0].views) {
    CHECK(std::isinf(v.psnr_db));
    CHECK(v.ssim == doctest::Approx(1.0).epsilon(1e-12));
    CHECK(v.max_abs_diff == 0.f);
  }
  // Each candidate on its own scale: the identical one has none (0) and a black heatmap, the other one's is
  // not 0 and at most its largest |Δ|.
  CHECK(result->candidates[0].heat_scale == 0.f);
  CHECK(result->candidates[0].worst[0].heat_scale == 0.f);
  for (uint8_t p : result->candidates[0].worst[0].difference.pixels) CHECK(p == 0);
  CHECK(result->candidates[1].heat_scale > 0.f);
  CHECK(result->candidates[1].heat_scale <= result->candidates[1].summary.max_abs_diff);
  CHECK(result->candidates[1].worst[0].heat_scale == result->candidates[1].heat_scale);
  CHECK(std::isinf(result->candidates[0].summary.foreground_psnr_mean_db));
  CHECK(std::isfinite(result->candidates[1].summary.psnr_min_db));
  CHECK(audit::passes_gate(*result, 45.0));
  const auto j = nlohmann::json::parse(audit::audit_json(*result, {}));
  CHECK(j["candidates"][0]["psnr_db"]["min"] == "inf");
  CHECK(j["candidates"][0]["ratio"].get<double>() == doctest::Approx(1.0));
}

TEST_CASE("verdict: mean PSNR against the threshold, worst view, bytes saved") {
  audit::AuditResult r;
  r.source.file_bytes = 1000;
  r.views = {{"a", 16, 16}, {"b", 16, 16}, {"c", 16, 16}};
  auto candidate = [](uint64_t bytes, double mean, double min, size_t worst) {
    audit::CandidateResult c;
    c.scene.file_bytes = bytes;
    c.summary.psnr_mean_db = mean;
    c.summary.psnr_min_db = min;
    c.summary.worst_view = worst;
    c.views.resize(3);  // whole frame only (no foreground): the worst view's PSNR is the minimum
    for (size_t v = 0; v < 3; ++v) {
      c.views[v].psnr_db = v == worst ? min : mean;
      c.views[v].foreground_psnr_db = std::numeric_limits<double>::quiet_NaN();
    }
    return c;
  };
  r.candidates.push_back(candidate(400, 41.0, 38.0, 2));   // passes 40 on the mean, though a view is below
  r.candidates.push_back(candidate(1500, 39.99, 35.0, 0)); // larger than the source, and below 40
  r.candidates.push_back(candidate(0, 60.0, 59.0, 1));     // an attribution scene: no file, no size
  r.candidates.push_back(candidate(10, std::numeric_limits<double>::infinity(),
                                   std::numeric_limits<double>::infinity(), 0));

  const audit::Verdict a = audit::verdict(r, 0, 40.0);
  CHECK(a.passed);
  CHECK(a.threshold_db == 40.0);
  CHECK(a.psnr_mean_db == 41.0);
  CHECK(a.worst_view == "c");
  CHECK(a.worst_psnr_db == 38.0);
  REQUIRE(a.bytes_saved.has_value());
  CHECK(*a.bytes_saved == 600);
  CHECK(a.bytes_saved_fraction == doctest::Approx(0.6));
  CHECK(audit::verdict(r, 0, 41.0).passed);    // at the threshold: passes
  CHECK(!audit::verdict(r, 0, 41.01).passed);

  const audit::Verdict b = audit::verdict(r, 1, 40.0);
  CHECK(!b.passed);
  CHECK(b.worst_view == "a");
  REQUIRE(b.bytes_saved.has_value());
  CHECK(*b.bytes_saved == -500);
  CHECK(b.bytes_saved_fraction == doctest::Approx(-0.5));

  CHECK(!audit::verdict(r, 2, 40.0).bytes_saved.has_value());
  CHECK(audit::verdict(r, 3, 1000.0).passed);  // identical renders pass any threshold

  audit::ReportOptions ro;
  ro.threshold_db = 40.0;
  const auto j = nlohmann::json::parse(audit::audit_json(r, ro));
  CHECK(j["verdict"]["threshold_db"] == 40.0);
  CHECK(j["verdict"]["passed"] == false);  // candidate 1 fails
  CHECK(j["candidates"][0]["verdict"]["passed"] == true);
  CHECK(j["candidates"][0]["verdict"]["bytes_saved"] == 600);
  CHECK(j["candidates"][0]["verdict"]["worst_view"]["name"] == "c");
  CHECK(j["candidates"][1]["verdict"]["passed"] == false);
  CHECK(j["candidates"][2]["verdict"]["bytes_saved"].is_null());
  CHECK(j["candidates"][3]["verdict"]["psnr_mean_db"] == "inf");
  ro.threshold_db = 30.0;
  CHECK(nlohmann::json::parse(audit::audit_json(r, ro))["verdict"]["passed"] == true);
}

TEST_CASE("verdict and gate on the foreground PSNR where the source has background") {
  audit::AuditResult r;
  r.views = {{"a", 16, 16}, {"b", 16, 16}, {"c", 16, 16}};
  audit::CandidateResult c;
  // Whole frame (psnr, foreground psnr, fraction) per view; view c has no foreground.
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  const double views[3][3] = {{60.0, 50.0, 0.1}, {58.0, 52.0, 0.25}, {70.0, kNaN, 0.0}};
  for (const auto& v : views) {
    audit::ViewMetrics m;
    m.psnr_db = v[0];
    m.foreground_psnr_db = v[1];
    m.foreground_fraction = v[2];
    c.views.push_back(m);
  }
  c.summary.psnr_mean_db = (60.0 + 58.0 + 70.0) / 3;
  c.summary.psnr_min_db = 58.0;
  c.summary.worst_view = 0;  // run_audit's rank: lowest foreground PSNR (verdict_view_psnr_db), not b's whole frame
  c.summary.foreground_psnr_mean_db = 51.0;
  c.summary.foreground_psnr_min_db = 50.0;
  r.candidates.push_back(c);
  CHECK(audit::verdict_metric(r) == audit::VerdictMetric::kForeground);
  const audit::Verdict v = audit::verdict(r, 0, 55.0);  // between the foreground and the whole-frame mean
  CHECK(!v.passed);
  CHECK(v.metric == audit::VerdictMetric::kForeground);
  CHECK(v.psnr_mean_db == 51.0);
  CHECK(v.whole_frame_psnr_mean_db == c.summary.psnr_mean_db);
  CHECK(v.foreground_psnr_mean_db == 51.0);
  CHECK(v.worst_view == "a");  // lowest foreground PSNR, not b (lowest whole frame) nor c (no foreground)
  CHECK(v.worst_psnr_db == 50.0);
  CHECK(audit::verdict(r, 0, 51.0).passed);
  CHECK(!audit::passes_gate(r, 54.0));  // every view's foreground: a is at 50
  CHECK(audit::passes_gate(r, 50.0));
  audit::ReportOptions ro;
  ro.threshold_db = 55.0;
  ro.min_psnr_db = 54.0;
  const auto j = nlohmann::json::parse(audit::audit_json(r, ro));
  CHECK(j["verdict"]["metric"] == "foreground");
  CHECK(j["verdict"]["passed"] == false);
  CHECK(j["candidates"][0]["verdict"]["psnr_mean_db"] == 51.0);
  CHECK(j["candidates"][0]["verdict"]["whole_frame_psnr_mean_db"].get<double>() == c.summary.psnr_mean_db);
  CHECK(j["gate"]["passed"] == false);

  // A source that covers every pixel of every view: the whole frame decides.
  for (auto& m : r.candidates[0].views) m.foreground_fraction = 1.0, m.foreground_psnr_db = m.psnr_db;
  r.candidates[0].summary.worst_view = 1;
  CHECK(audit::verdict_metric(r) == audit::VerdictMetric::kWholeFrame);
  CHECK(audit::verdict(r, 0, 55.0).passed);
  CHECK(audit::verdict(r, 0, 55.0).worst_view == "b");
  CHECK(audit::passes_gate(r, 54.0));
}

TEST_CASE("attribution: the source with one attribute group from the candidate, the INT8 DC term costing most") {
  const audit::AuditScene& source = guitar();
  converter::QuantizeOptions int8_dc;  // the paper's INT8 DC term, without the residual
  int8_dc.sh_dc_bits = 8;
  const audit::AuditScene converted = test::converted_scene(source, "rgs_test_audit_attribution.rgs", int8_dc);
  auto hybrids = audit::attribution_scenes(source, converted);
  REQUIRE_MESSAGE(hybrids.ok(), hybrids.status().to_string());
  // guitar has SH degree 0: no "SH bands 1+" group.
  const char* groups[] = {"means", "rotations", "scales", "opacities", "SH DC"};
  REQUIRE(hybrids->size() == 5);
  for (size_t g = 0; g < hybrids->size(); ++g) {
    const audit::AuditScene& h = (*hybrids)[g];
    CAPTURE(groups[g]);
    CHECK(h.info.label == "converted: " + std::string(groups[g]) + " only");
    // Exactly its group from the candidate, everything else from the source.
    CHECK(h.cloud.means == (g == 0 ? converted.cloud.means : source.cloud.means));
    CHECK(h.cloud.rotations == (g == 1 ? converted.cloud.rotations : source.cloud.rotations));
    CHECK(h.cloud.scales == (g == 2 ? converted.cloud.scales : source.cloud.scales));
    CHECK(h.cloud.opacities == (g == 3 ? converted.cloud.opacities : source.cloud.opacities));
    CHECK(h.cloud.sh == (g == 4 ? converted.cloud.sh : source.cloud.sh));
  }
  std::vector<audit::AuditScene> candidates{converted};
  for (audit::AuditScene& h : *hybrids) candidates.push_back(std::move(h));
  auto result = audit::run_audit(source, candidates, small_orbit(source.bounds, 2), {});
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  const double whole = result->candidates[0].summary.psnr_mean_db;
  // Means are stored exactly; of the rest, the INT8 DC term is what the runtime profile's PSNR is made of.
  CHECK(std::isinf(result->candidates[1].summary.psnr_mean_db));
  const double dc = result->candidates[5].summary.psnr_mean_db;
  CHECK(dc == doctest::Approx(whole).epsilon(0.01));
  for (size_t c = 2; c < 5; ++c) CHECK(result->candidates[c].summary.psnr_mean_db > dc + 10);

  // The DC residual (the default) removes that cost: the DC term then costs less than every other group.
  const audit::AuditScene refined = test::converted_scene(source, "rgs_test_audit_attribution_dc16.rgs");
  auto refined_hybrids = audit::attribution_scenes(source, refined);
  REQUIRE(refined_hybrids.ok());
  std::vector<audit::AuditScene> refined_candidates{refined, (*refined_hybrids)[4]};
  auto refined_result = audit::run_audit(source, refined_candidates, small_orbit(source.bounds, 2), {});
  REQUIRE_MESSAGE(refined_result.ok(), refined_result.status().to_string());
  CHECK(refined_result->candidates[0].summary.psnr_mean_db > whole + 10);
  CHECK(refined_result->candidates[1].summary.psnr_mean_db > dc + 40);
  for (size_t c = 2; c < 5; ++c) {
    CHECK(refined_result->candidates[1].summary.psnr_mean_db > result->candidates[c].summary.psnr_mean_db);
  }

  audit::AuditScene other = source;
  other.cloud.resize(10);
  CHECK(audit::attribution_scenes(other, converted).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("bad audits are errors") {
  const audit::AuditScene& source = guitar();
  std::vector<audit::AuditScene> none;
  auto cams = small_orbit(source.bounds, 1);
  CHECK(audit::run_audit(source, none, cams, {}).status().code() == StatusCode::kInvalidArgument);
  std::vector<audit::AuditScene> one;
  one.push_back(test::audit_scene(test::repo_path("samples/guitar.ply")));
  CHECK(audit::run_audit(source, one, {}, {}).status().code() == StatusCode::kInvalidArgument);
  cams[0].width = 10;
  CHECK(audit::run_audit(source, one, cams, {}).status().code() == StatusCode::kInvalidArgument);
  CHECK(audit::load_audit_scene("/nonexistent/x.rgs").status().code() == StatusCode::kIoError);
}

}  // namespace
