// Machine-readable output of an audit: versioned JSON, and the worst views' images as binary PPM/PGM files
// that the HTML report (report_html.h) embeds.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rgs/audit/audit.h"
#include "rgs/format/file_io.h"
#include "rgs/format/status.h"

namespace rgs::audit {

/// The JSON's "schema" value.
inline constexpr const char* kAuditSchemaName = "rgs-audit";
/// The JSON's "schema_version": raised when a field changes meaning or goes away; new fields do not raise it.
/// Version 1 was the single-candidate report of earlier rgs-audit releases (no schema field); version 2 divided
/// each file's bytes by its own Gaussians, version 3 by the source's (a file may store fewer Gaussians, or more);
/// version 4 has a heat scale per candidate instead of the top-level one, and decides the verdict and the gate on
/// the foreground PSNR where the source has background (verdict_metric).
inline constexpr int kAuditSchemaVersion = 4;

/// Default threshold of the report's verdict (rgs-audit --threshold): a candidate passes when its mean PSNR
/// over the views (verdict_metric's) is at least this many dB.
inline constexpr double kDefaultVerdictThresholdDb = 40.0;

/// The PSNR that the verdict and the --min-psnr gate compare.
enum class VerdictMetric {
  kWholeFrame,  ///< ViewMetrics::psnr_db, over every pixel
  kForeground,  ///< ViewMetrics::foreground_psnr_db, over the source render's foreground
};

/// "whole_frame" or "foreground" (the JSON's `metric`).
const char* verdict_metric_name(VerdictMetric metric);

/// The metric of every verdict and the gate of `result`: kForeground when the source's renders have background
/// (some view's foreground_fraction is below 1) and a foreground (some view's is above 0), because the
/// background's zero errors raise the whole-frame PSNR by 10·log10(1/fraction) (docs/AUDITS.md); else
/// kWholeFrame. Depends on the source's renders only, so it is the same for every candidate.
/// Precondition: result has at least one candidate.
VerdictMetric verdict_metric(const AuditResult& result);

/// The smallest share of the source's Gaussians that a candidate compared with its edited source
/// (CandidateResult::reference) may keep and still pass: below it, its PSNR against what is left says nothing of
/// the source (guitar cropped to one Gaussian reads 109 dB; docs/AUDITS.md), so the candidate has lost its content
/// and fails.
inline constexpr double kMinContentKept = 0.01;

/// The report's first line for one candidate: pass or fail against a mean-PSNR threshold on verdict_metric,
/// its worst view and the bytes it saves against the source file.
struct Verdict {
  /// psnr_mean_db ≥ threshold_db (an identical image's +inf passes any threshold) and no content_lost
  bool passed = false;
  /// Why the candidate fails whatever its PSNR: it has no Gaussian while the source has, or its recorded edits kept
  /// under kMinContentKept of the source's Gaussians. Empty otherwise.
  std::string content_lost;
  double threshold_db = 0;    ///< dB
  VerdictMetric metric = VerdictMetric::kWholeFrame;  ///< verdict_metric(result): what psnr_mean_db is
  /// The candidate's mean over the views of `metric`, dB (+inf when every view is identical there).
  double psnr_mean_db = 0;
  double whole_frame_psnr_mean_db = 0;  ///< Summary::psnr_mean_db, dB
  double foreground_psnr_mean_db = 0;   ///< Summary::foreground_psnr_mean_db, dB (NaN: no view has foreground)
  std::string worst_view;     ///< name of the view of lowest `metric` (views without foreground left out)
  double worst_psnr_db = 0;   ///< its PSNR in `metric`, dB
  /// Source file bytes minus candidate file bytes (negative when the candidate is larger); empty for a scene
  /// not read from a file (--attribution), which has no size.
  std::optional<int64_t> bytes_saved;
  double bytes_saved_fraction = 0;  ///< bytes_saved / source bytes (0 without bytes_saved)
};

/// The verdict of candidate `candidate` (index into result.candidates) against `threshold_db`.
/// Precondition: candidate < result.candidates.size() and the result has at least one view (run_audit's).
Verdict verdict(const AuditResult& result, size_t candidate, double threshold_db);

/// What the JSON carries besides the result.
struct ReportOptions {
  std::string tool_version;        ///< e.g. RGS_VERSION_STRING
  std::string command_line;        ///< as run, for the record
  std::optional<double> min_psnr_db;  ///< the gate, when one was asked for
  double threshold_db = kDefaultVerdictThresholdDb;  ///< the verdict's mean-PSNR threshold, dB (verdict_metric)
  double total_seconds = 0;        ///< loading included
  /// Folder of the images relative to the JSON file (e.g. "flowers_files/"), as written by
  /// write_report_images; empty: the JSON names no images.
  std::string image_dir;
};

/// True when every candidate's minimum per-view PSNR in verdict_metric(result) (Verdict::worst_psnr_db) is at
/// least `min_psnr_db` (an identical image's +inf passes any gate).
bool passes_gate(const AuditResult& result, double min_psnr_db);

/// The audit as JSON text (UTF-8, 2-space indent, newline at the end). PSNR +inf is written as the string
/// "inf". Field reference: docs/AUDITS.md "JSON".
std::string audit_json(const AuditResult& result, const ReportOptions& options);

/// Every candidate's worst-view images with their paths in `dir`: "<dir>/c<i>_v<view>_source.ppm",
/// "_candidate.ppm" and "_diff.pgm", the names audit_json() gives under ReportOptions::image_dir. The images
/// are `result`'s own (valid while it is).
std::vector<std::pair<std::string, const Image8*>> report_images(const AuditResult& result, const std::string& dir);

/// Writes report_images(result, dir) into `dir` (created if missing), each into `files` (default: written
/// atomically in place). Errors: kIoError naming the path.
Status write_report_images(const AuditResult& result, const std::string& dir,
                           format::FileSink& files = format::atomic_files());

/// Writes `image` as binary PPM (P6, 3 channels) or PGM (P5, 1 channel), maxval 255, into `files`.
/// Errors: kInvalidArgument (size or channel mismatch), kIoError naming `path`.
Status write_netpbm(const std::string& path, const Image8& image, format::FileSink& files = format::atomic_files());

/// Reads a binary PPM (P6) or PGM (P5) of maxval 255, as write_netpbm writes it (comments allowed).
/// Errors: kIoError naming `path` (missing, unreadable), kCorruptData naming it (another format, a size that
/// does not match its bytes).
Result<Image8> read_netpbm(const std::string& path);

}  // namespace rgs::audit
