// Rate control of the archive profile: the fits for a PSNR target and for a byte budget on the search's views,
// checked at the views' own size (fit_archive), and its progress in steps (FitProgress).
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rate_control.h"
#include "knobs.h"
#include "measurer.h"
#include "search.h"
#include "rgs/converter/scene_reader.h"

namespace rgs::api::detail {

namespace {

/// Progress steps of fit_psnr: the ladder's point and its check, and kMaxAttempts PSNR searches each followed by
/// a check, the last by up to three.
constexpr uint32_t kFitPsnrSteps = 2 + kMaxAttempts * (kPsnrSearchSteps + 1) + 2;

uint32_t search_max_side(const FitOptions& options) {
  if (options.target.search_max_side != 0) return options.target.search_max_side;
  return options.target.device == Device::kCuda ? kCudaSearchMaxSide : kCpuSearchMaxSide;
}

/// The search's views: at most `max_views` of `cameras`, evenly spread, reduced to `max_side`.
std::vector<runtime::Camera> reduced(const std::vector<runtime::Camera>& cameras, uint32_t max_side,
                                     uint32_t max_views) {
  std::vector<runtime::Camera> subset;
  const size_t n = cameras.size(), k = std::min<size_t>(n, std::max<uint32_t>(max_views, 1));
  for (size_t i = 0; i < k; ++i) subset.push_back(cameras[i * n / k]);
  std::vector<runtime::Camera> out;
  max_side = std::max<uint32_t>(max_side, 16);
  for (const runtime::Camera& c : subset) {
    const uint32_t side = std::max(c.width, c.height);
    if (side <= max_side) {
      out.push_back(c);
      continue;
    }
    const double f = double(max_side) / double(side);
    const auto w = uint32_t(std::max(16L, std::lround(c.width * f)));
    const auto h = uint32_t(std::max(16L, std::lround(c.height * f)));
    out.push_back(runtime::resize_camera(c, w, h));
  }
  return out;
}

/// A PSNR target: checks the ladder's point for the target on the cameras at their own size, searches at the
/// target moved by the difference measured between the two sizes, checks the search's last step, and searches
/// again at a target moved by the difference measured between the two sizes while the check
/// misses the target or lands more than kMaxAboveDb above it. On the last attempt, a miss is followed by
/// checks of the earlier steps of the path. A (moved) target above the finest archive on the search views
/// ends the search with a check of that finest archive: the search views may read below or above the
/// cameras' own size. Sets result->chosen and result->report.search_psnr_db.
Status fit_psnr(Measurer& measurer, Search& search, const runtime::Camera& first, double target, FitResult* result) {
  const FitSteps steps = search.part(kFitPsnrSteps);
  const std::string size = std::to_string(first.width) + "x" + std::to_string(first.height);
  std::optional<FitPoint> best;
  double best_search_psnr = kNaN;
  auto keep = [&](const FitPoint& checked, double search_psnr) {
    if (checked.psnr_mean_db >= target && (!best || checked.bytes < best->bytes)) {
      best = checked;
      best_search_psnr = search_psnr;
    }
  };
  // Whether `searched` failed because `search_target` is above the finest archive on the search views.
  auto above_finest = [&](const Status& searched, double search_target) {
    return searched.code() == StatusCode::kInvalidArgument && search.finest() &&
           !(search.finest()->psnr_mean_db >= search_target);
  };
  auto check_finest = [&]() -> Status {
    const FitPoint finest = *search.finest();
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> checked, measurer.measure({finest.options}, true));
    search.report("check of the finest archive at " + size + ": " + db_text(checked[0].psnr_mean_db) +
                      " (search views: " + db_text(finest.psnr_mean_db) + ")",
                  1);
    keep(checked[0], finest.psnr_mean_db);
    if (best) return Status();
    return Status(StatusCode::kInvalidArgument,
                  "target " + db_text(target) + " is above what the archive profile reaches on these views: " +
                      db_text(checked[0].psnr_mean_db) + " at the finest settings (" +
                      describe_archive_options(finest.options, search.sh_degree()) + ")");
  };
  auto settle = [&]() {
    result->chosen = *best;
    result->report.search_psnr_db = best_search_psnr;
    return Status();
  };

  // A first estimate of the difference between the sizes, at the ladder's point for the target.
  Result<FitPoint> ladder_point = search.ladder_for_psnr(target);
  if (!ladder_point.ok()) {
    if (!above_finest(ladder_point.status(), target)) return std::move(ladder_point).status();
    RGS_RETURN_IF_ERROR(check_finest());
    return settle();
  }
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> calibration, measurer.measure({ladder_point->options}, true));
  search.report("check at " + size + ": " + db_text(calibration[0].psnr_mean_db) + " (search views: " +
                    db_text(ladder_point->psnr_mean_db) + ")",
                2);  // the ladder and its check
  double search_target =
      std::max(target, target + ladder_point->psnr_mean_db - calibration[0].psnr_mean_db + kCalibrationMarginDb);
  keep(calibration[0], ladder_point->psnr_mean_db);
  std::vector<FitPoint> path;
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    measurer.set_search_offset(search_target - target);
    Result<std::vector<FitPoint>> searched = search.for_psnr(search_target, path);
    if (!searched.ok()) {
      if (!above_finest(searched.status(), search_target)) return std::move(searched).status();
      if (!best) RGS_RETURN_IF_ERROR(check_finest());
      break;
    }
    path = std::move(searched).value();
    const bool last_attempt = attempt + 1 == kMaxAttempts;
    // From the search's last (cheapest) step back, on the last attempt: the first that meets the target.
    FitPoint last_checked;
    bool settled = false;  // this search's choice (or on the last attempt, a step before it) meets the target
    for (size_t back = 0; back < (last_attempt ? std::min<size_t>(path.size(), 3) : 1); ++back) {
      const FitPoint& at = path[path.size() - 1 - back];
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> checked, measurer.measure({at.options}, true));
      if (back == 0) last_checked = checked[0];
      search.report("check at " + size + ": " + db_text(checked[0].psnr_mean_db) + " (search views: " +
                        db_text(at.psnr_mean_db) + ")",
                    1);
      keep(checked[0], at.psnr_mean_db);
      if (checked[0].psnr_mean_db >= target) {
        settled = checked[0].psnr_mean_db <= target + kMaxAboveDb;
        break;
      }
    }
    if (settled) break;
    // The difference between the search views and the final ones at the search's last step.
    const double offset = path.back().psnr_mean_db - last_checked.psnr_mean_db;
    double next = target + offset + kCalibrationMarginDb;
    if (last_checked.psnr_mean_db < target) next = std::max(next, search_target + kCalibrationMarginDb);
    if (std::abs(next - search_target) < 0.01) break;
    search_target = next;
  }
  if (!best) {
    return Status(StatusCode::kInvalidArgument,
                  "target " + db_text(target) + " is not met by any archive the search measured at " + size +
                      " (the finest reached " + db_text(search.finest() ? search.finest()->psnr_mean_db : kNaN) +
                      " at the search size)");
  }
  return settle();
}

/// A byte target: the search codes its candidates at zstd level kSearchZstdLevel without .xz, the file at
/// `file_zstd_level` (with .xz where `file_xz`), which is fewer bytes by a share that depends on the settings, so
/// the search's budget is `target` over the ratio of the two codings: measured at the anchor for the descent
/// (Search::descend), then where the descent ends for Search::for_bytes, and at its choice for another search (at
/// most kMaxAttempts, trading only on the steps as measured), while the choice's file is over `target` or more than
/// kBytesSlack below it. Of the archives within the largest budget whose choice's file fit, the kBytesFinalists of
/// the highest search PSNR whose files fit are measured at the cameras' own size, where the search views rank
/// close archives differently, and the highest is chosen. Sets result->chosen and result->report.search_psnr_db.
Status fit_bytes(Measurer& measurer, Search& search, uint64_t target, int file_zstd_level, bool file_xz,
                 FitResult* result) {
  std::optional<FitSteps> steps(std::in_place, search.progress(), kMaxAttempts * kBytesSearchSteps);
  // The search's budget for `target` in the file, by the ratio of the two codings at `at`.
  const auto budget_at = [&](const FitPoint& at) -> Result<uint64_t> {
    RGS_ASSIGN_OR_RETURN(const uint64_t file, measurer.file_bytes(at.options, file_zstd_level, file_xz));
    return uint64_t(double(target) * double(at.bytes) / double(std::max<uint64_t>(file, 1)));
  };
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> anchor, measurer.bytes({search.anchor()}));
  RGS_ASSIGN_OR_RETURN(uint64_t budget, budget_at(anchor[0]));
  RGS_ASSIGN_OR_RETURN(const FitPoint descended, search.descend(budget));
  RGS_ASSIGN_OR_RETURN(budget, budget_at(descended));
  uint64_t fitting_budget = 0;
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    RGS_ASSIGN_OR_RETURN(const FitPoint best, search.for_bytes(budget, attempt == 0));
    RGS_ASSIGN_OR_RETURN(const uint64_t file, measurer.file_bytes(best.options, file_zstd_level, file_xz));
    search.report("search's choice within " + group_digits(budget) + " bytes: " + group_digits(best.bytes) +
                  " bytes there, " + group_digits(file) + " in the file");
    if (file <= target) fitting_budget = std::max(fitting_budget, budget);
    if (file <= target && double(target - file) <= kBytesSlack * double(target)) break;
    RGS_ASSIGN_OR_RETURN(const uint64_t next, budget_at(best));
    if (next == budget) break;
    budget = next;
  }
  steps.reset();
  steps.emplace(search.progress(), kBytesFinalists);
  std::optional<FitPoint> chosen;
  double chosen_search_db = kNaN;
  for (const FitPoint& p : measurer.best_within(fitting_budget, kBytesFinalists)) {
    RGS_ASSIGN_OR_RETURN(const uint64_t file, measurer.file_bytes(p.options, file_zstd_level, file_xz));
    if (file > target) continue;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> checked, measurer.measure({p.options}, true));
    search.report("check at the cameras' size: " + db_text(checked[0].psnr_mean_db) + " (search views: " +
                      db_text(p.psnr_mean_db) + "), " + group_digits(file) + " bytes in the file",
                  1);
    if (!chosen || checked[0].psnr_mean_db > chosen->psnr_mean_db) {
      chosen = checked[0];
      chosen_search_db = p.psnr_mean_db;
    }
  }
  if (!chosen) {
    return Status(StatusCode::kLimitExceeded, "no archive the search measured codes into " + group_digits(target) +
                                                  " bytes at zstd level " + std::to_string(file_zstd_level));
  }
  result->chosen = *chosen;
  result->report.search_psnr_db = chosen_search_db;
  return Status();
}

}  // namespace

void FitProgress::begin(uint32_t steps) {
  if (!parts_.empty()) {
    Part& parent = parts_.back();
    const uint32_t left = parent.start + parent.steps > done_ ? parent.start + parent.steps - done_ : 0;
    if (steps > left) {
      bound_ += steps - left;
      parent.steps += steps - left;
    }
  } else {
    bound_ += steps;
  }
  parts_.push_back({done_, steps});
}

void FitProgress::end() {
  if (parts_.empty()) return;
  const Part part = parts_.back();
  parts_.pop_back();
  const uint32_t used = done_ - part.start;
  if (used >= part.steps) return;
  const uint32_t unused = part.steps - used;
  bound_ = std::max(done_, bound_ - std::min(bound_, unused));
  if (!parts_.empty()) parts_.back().steps -= std::min(parts_.back().steps, unused);
}

void FitProgress::advance(const std::string& what, uint32_t steps) {
  done_ += steps;
  bound_ = std::max(bound_, done_);
  if (sink_) sink_(what, done_, bound_);
}

Result<FitResult> fit_archive(const format::GaussianCloud& source, const std::vector<runtime::Camera>& cameras,
                              const FitOptions& options) {
  const auto start = Clock::now();
  RGS_RETURN_ERROR_IF(cameras.empty(), StatusCode::kInvalidArgument, "rate control: no views selected");
  RGS_RETURN_ERROR_IF(source.size() == 0, StatusCode::kInvalidArgument, "rate control: the scene has no Gaussians");
  const format::SceneBounds bounds = converter::compute_bounds(source);

  format::GaussianCloud encoded_cloud;
  const format::GaussianCloud* to_encode = &source;
  if (options.sh_degree && *options.sh_degree < source.sh_degree) {
    encoded_cloud = source;
    RGS_RETURN_IF_ERROR(converter::reduce_sh_degree(&encoded_cloud, *options.sh_degree));
    to_encode = &encoded_cloud;
  }
  converter::QuantizeOptions quantize = options.quantize;
  quantize.sh_dc_bits = 8;  // the archive drops the DC residual (SPEC §4.8)
  RGS_ASSIGN_OR_RETURN(format::EncodedScene quantized, converter::quantize(*to_encode, quantize));
  const uint32_t sh_degree = quantized.metadata.sh_degree;
  format::ArchiveOptions anchor = format::resolve_archive_options(options.start, quantized);
  // The zstd level and the .xz trial change a file's bytes, not what it decodes to: the search codes with zstd at
  // a quick level, the file is written as asked (FitOptions::start).
  const int file_zstd_level = anchor.zstd_level;
  const bool file_xz = anchor.xz;
  anchor.zstd_level = std::min(file_zstd_level, kSearchZstdLevel);
  anchor.xz = false;

  FitOptions resolved = options;
  resolved.start = anchor;
  const std::vector<runtime::Camera> search_cameras =
      reduced(cameras, search_max_side(options), options.target.search_max_views);
  Measurer measurer(source, bounds, std::move(quantized), resolved);
  RGS_RETURN_IF_ERROR(measurer.start(search_cameras, cameras));
  RGS_RETURN_IF_ERROR(measurer.measure_overhead());
  Search search(measurer, resolved, sh_degree, anchor);

  FitResult result;
  result.report.views = uint32_t(cameras.size());
  result.report.search_width = search_cameras[0].width;
  result.report.search_height = search_cameras[0].height;
  result.report.width = cameras[0].width;
  result.report.height = cameras[0].height;
  result.report.device = options.target.device;

  if (options.target.bytes) {
    RGS_RETURN_IF_ERROR(fit_bytes(measurer, search, *options.target.bytes, file_zstd_level, file_xz, &result));
  } else {
    RGS_RETURN_IF_ERROR(fit_psnr(measurer, search, cameras[0], options.target.psnr_db.value_or(0), &result));
  }
  result.finest = search.finest();
  result.archive = measurer.archive_with_points(result.chosen.options);
  auto as_asked = [&](format::ArchiveOptions* o) {
    o->zstd_level = file_zstd_level;
    o->xz = file_xz;
  };
  as_asked(&result.chosen.options);
  if (result.finest) as_asked(&result.finest->options);
  result.report.settings = result.chosen.options;
  result.report.psnr_mean_db = result.chosen.psnr_mean_db;
  result.report.psnr_min_db = result.chosen.psnr_min_db;
  result.report.encodings = measurer.encodings();
  result.report.renders = measurer.renders();
  result.report.encode_seconds = measurer.encode_seconds();
  result.report.render_seconds = measurer.render_seconds();
  result.report.device_name = measurer.device_name();
  result.report.seconds = seconds_since(start);
  return result;
}

}  // namespace rgs::api::detail
