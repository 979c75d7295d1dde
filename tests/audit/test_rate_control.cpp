// Rate control of the archive profile on the bundled guitar, its SH-degree-3 excerpt and biker (when
// $RGS_DATA_DIR has it): the written file meets the PSNR target, measured independently with run_audit, and
// lands within half a dB of it; a byte budget is
// kept; a target no archive reaches is refused with what the finest archive reaches; a target the reduced
// search views cannot reach is met by the finest archive when it meets it at the cameras' size.
#include <doctest/doctest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "audit_test_util.h"
#include "rgs/api/camera.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/rate_control.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

using test::measured_psnr;
using test::small_orbit;

/// Fits `source` to `target` dB on `views` into `out` and checks the written file's own PSNR (run_audit) lands in
/// [target, target + 0.5] and equals what the fit reported.
audit::FittedConversion fit_db(const std::string& source, const std::string& out, double target = 40,
                               const api::CameraChoice& views = small_orbit()) {
  audit::FitOptions fit;
  fit.target_psnr_db = target;
  auto fitted = audit::convert_fitted(source, out, {}, views, fit);
  REQUIRE_MESSAGE(fitted.ok(), fitted.status().to_string());
  const double psnr = measured_psnr(source, out, views);
  CHECK(psnr >= target);
  CHECK(psnr <= target + 0.5);
  CHECK(fitted->fit.chosen.psnr_mean_db == doctest::Approx(psnr).epsilon(1e-9));
  return std::move(fitted).value();
}

}  // namespace

TEST_CASE("rate control meets a 40 dB target on guitar within 0.5 dB") {
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  const std::string out = dir.file("guitar_40db.rgs");
  const audit::FittedConversion fitted = fit_db(source, out);
  // The bytes the fit reported are the file's.
  CHECK(fitted.convert.output_bytes == std::filesystem::file_size(out));
  CHECK(fitted.convert.output_description == "RoofGS .rgs, archive profile");
  // Smaller than the default archive, which is far above the target.
  api::ConvertOptions archive;
  archive.profile = format::StorageProfile::kArchive;
  auto defaults = api::convert(source, dir.file("guitar_default_archive.rgs"), archive);
  REQUIRE_MESSAGE(defaults.ok(), defaults.status().to_string());
  CHECK(fitted.convert.output_bytes < defaults->output_bytes);
  // Written from the scene the fit read, its means lent by the fit's archive: the bytes of a conversion with the
  // chosen settings alone.
  archive.archive = fitted.fit.chosen.options;
  const std::string chosen = dir.file("guitar_chosen_archive.rgs");
  auto again = api::convert(source, chosen, archive);
  REQUIRE_MESSAGE(again.ok(), again.status().to_string());
  CHECK(test::slurp(out) == test::slurp(chosen));
  CHECK(!test::slurp(out).empty());
}

TEST_CASE("rate control meets a 40 dB target within 0.5 dB on a scene of SH degree 3") {
  // Eight knobs (the SH step of every degree among them), as on the real scenes of SH degree 3.
  test::TempDir dir;
  fit_db(test::repo_path(test::kGuitarSh3), dir.file("guitar_sh3_40db.rgs"));
}

TEST_CASE("rate control's files grow with the target on guitar: 35, 40 and 45 dB") {
  // The exchanges between knobs take each fit off the rounds' greedy path; a search that stopped at an earlier
  // check's choice instead of searching again after a miss ended the 40 dB fit above the 45 dB one.
  // The quality cards' views (an orbit of 4 at 480x270).
  api::CameraChoice views = small_orbit();
  views.orbit = 4;
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  uint64_t previous = 0;
  for (double target : {35.0, 40.0, 45.0}) {
    CAPTURE(target);
    const audit::FittedConversion fitted = fit_db(source, dir.file("guitar.rgs"), target, views);
    CHECK(fitted.convert.output_bytes > previous);
    previous = fitted.convert.output_bytes;
  }
}

TEST_CASE("rate control lands within 0.5 dB where whole steps cannot: biker at 35 dB, below the 4-bit minimum") {
  // biker's 35 dB point has rotations, scales and opacities at the format's 4-bit minimum: with whole steps only,
  // the fit on four orbit views ended 2.69 dB above the target.
  const std::string source = test::shared_scene("biker.ply");
  if (source.empty()) return;  // shared_scene reported the skip
  test::TempDir dir;
  const audit::FittedConversion fitted = fit_db(source, dir.file("biker_35db.rgs"), 35);
  const format::ArchiveOptions& o = fitted.fit.chosen.options;
  CHECK(o.rotation_step * o.scale_step * o.opacity_step > 1);
}

TEST_CASE("rate control keeps a byte budget on guitar") {
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  const std::string out = dir.file("guitar_budget.rgs");
  audit::FitOptions fit;
  fit.goal = audit::FitGoal::kTargetBytes;
  fit.target_bytes = 400000;
  auto fitted = audit::convert_fitted(source, out, {}, small_orbit(), fit);
  REQUIRE_MESSAGE(fitted.ok(), fitted.status().to_string());
  CHECK(std::filesystem::file_size(out) <= 400000);
  CHECK(std::filesystem::file_size(out) > 300000);  // the budget is used, not left mostly empty
  CHECK(fitted->fit.chosen.psnr_mean_db == doctest::Approx(measured_psnr(source, out, small_orbit())).epsilon(1e-9));
}

TEST_CASE("rate control refuses targets no archive reaches, writing nothing") {
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  const std::string out = dir.file("never.rgs");
  audit::FitOptions fit;
  fit.target_psnr_db = 120;  // above the runtime profile's own PSNR, which the archive cannot exceed
  auto fitted = audit::convert_fitted(source, out, {}, small_orbit(), fit);
  REQUIRE_FALSE(fitted.ok());
  CHECK(fitted.status().code() == StatusCode::kInvalidArgument);
  const std::string message = fitted.status().message();
  CHECK_MESSAGE(message.find("above what the archive profile reaches") != std::string::npos, message);
  CHECK_MESSAGE(message.find("guitar.ply") != std::string::npos, message);
  CHECK_FALSE(std::filesystem::exists(out));

  fit.goal = audit::FitGoal::kTargetBytes;
  fit.target_bytes = 1000;
  fitted = audit::convert_fitted(source, out, {}, small_orbit(), fit);
  REQUIRE_FALSE(fitted.ok());
  CHECK_MESSAGE(std::string(fitted.status().message()).find("below the smallest archive") != std::string::npos,
                fitted.status().message());
  CHECK_FALSE(std::filesystem::exists(out));
}

TEST_CASE("rate control takes the finest archive when the search views cannot reach the target") {
  // Views of 16x9 pixels in the search read several dB below the 480x270 ones: the finest archive reaches
  // about 71 dB there and about 75 dB at the cameras' size. A target between the two is met by the finest
  // archive, checked at the cameras' size; one above both is refused with the PSNR at the cameras' size.
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  const std::string out = dir.file("guitar_74db.rgs");
  audit::FitOptions fit;
  fit.target_psnr_db = 74;
  fit.search_max_side = 16;
  auto fitted = audit::convert_fitted(source, out, {}, small_orbit(), fit);
  REQUIRE_MESSAGE(fitted.ok(), fitted.status().to_string());
  CHECK(fitted->fit.search_width == 16);
  CHECK(fitted->fit.search_psnr_db < 74);
  const double psnr = measured_psnr(source, out, small_orbit());
  CHECK(psnr >= 74);
  CHECK(fitted->fit.chosen.psnr_mean_db == doctest::Approx(psnr).epsilon(1e-9));

  fit.target_psnr_db = psnr + 1;
  const std::string never = dir.file("never.rgs");
  fitted = audit::convert_fitted(source, never, {}, small_orbit(), fit);
  REQUIRE_FALSE(fitted.ok());
  const std::string message = fitted.status().message();
  char reached[64];
  std::snprintf(reached, sizeof(reached), "above what the archive profile reaches on these views: %.2f dB", psnr);
  CHECK_MESSAGE(message.find(reached) != std::string::npos, message);
  CHECK_FALSE(std::filesystem::exists(never));
}

TEST_CASE("rate control's byte search is never worse than a PSNR search at no more bytes on guitar") {
  // The PSNR search's file at 35 and 45 dB, then a byte budget of its size: the byte search's file, on the same
  // views, reads as high within 0.3 dB (both searches compare archives on reduced views, which rank close archives
  // differently from the views' own size; the byte search checks its best few at that size).
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  for (double target : {35.0, 45.0}) {
    CAPTURE(target);
    const audit::FittedConversion by_psnr = fit_db(source, dir.file("by_psnr.rgs"), target);
    audit::FitOptions fit;
    fit.goal = audit::FitGoal::kTargetBytes;
    fit.target_bytes = by_psnr.convert.output_bytes;
    const std::string out = dir.file("by_bytes.rgs");
    auto by_bytes = audit::convert_fitted(source, out, {}, small_orbit(), fit);
    REQUIRE_MESSAGE(by_bytes.ok(), by_bytes.status().to_string());
    CHECK(std::filesystem::file_size(out) <= fit.target_bytes);
    const double psnr = measured_psnr(source, out, small_orbit());
    CHECK(psnr == doctest::Approx(by_bytes->fit.chosen.psnr_mean_db).epsilon(1e-9));
    CHECK(psnr >= by_psnr.fit.chosen.psnr_mean_db - 0.3);
  }
}
