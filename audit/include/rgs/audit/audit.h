// The per-view audit: renders a source scene and one or more candidate scenes from the same cameras with the
// faithful 3DGS baseline (FP32, black background) on the CPU reference or the CUDA renderer, and compares
// each candidate's image with the source's (PSNR, SSIM, maximum difference). Also per-attribute errors,
// sizes, and small images of the worst views for the report.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/audit/audit_scene.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/image_metrics.h"

namespace rgs::audit {

/// Where the views are rendered and compared.
enum class Backend {
  kCpu,   ///< runtime::render_cpu and compare_images (the reference)
  kCuda,  ///< runtime::GpuRenderer (baseline pipeline) and the GPU metrics (gpu_image_metrics.h)
};

/// "cpu" or "cuda".
const char* backend_name(Backend backend);

/// Reported after every view.
struct AuditProgress {
  size_t views_done = 0, views_total = 0;
  std::string view;             ///< name of the view just finished
  std::vector<double> psnr_db;  ///< that view's PSNR per candidate
  double elapsed_s = 0;         ///< since run_audit started rendering
  double remaining_s = 0;       ///< elapsed / done × (total − done)
};

/// Options of run_audit().
struct AuditOptions {
  Backend backend = Backend::kCpu;
  int cuda_device = 0;  ///< device ordinal for kCuda
  /// Worst views (lowest PSNR) per candidate kept as small images for the report; 0 keeps none.
  uint32_t worst_views = 3;
  /// Largest side of the kept images: a view is reduced by the smallest integer factor that fits (box mean
  /// for the colour images, box maximum for the difference so that single pixels stay visible).
  uint32_t image_max_side = 1024;
  /// Keep the full-size difference image of the first candidate's worst view (worst_heatmap).
  bool keep_worst_heatmap = false;
  /// CPU backend worker threads (runtime::RenderOptions::num_threads; 0 = all cores).
  unsigned cpu_threads = 0;
  /// Called after each view on the calling thread; may be empty.
  std::function<void(const AuditProgress&)> progress;
  /// Called with every render before it is compared, on the calling thread; may be empty. `scene` is 0 for the
  /// source and i + 1 for candidate i; `rgba` is the render, [H, W, 4] float32 on the host, linear RGB (not
  /// clamped) and alpha = 1 − T, top row first. An error stops the audit with that error.
  std::function<Status(size_t view, size_t scene, const runtime::ImageRef& rgba)> on_render;
};

/// Metrics of one view of one candidate.
struct ViewMetrics {
  double psnr_db = 0;   ///< +inf when the clamped images are equal
  double ssim = 0;
  float max_abs_diff = 0;
  /// PSNR over the source render's foreground (foreground_psnr: alpha or colour not the black background);
  /// +inf when equal there, NaN when the view has no foreground pixel.
  double foreground_psnr_db = 0;
  double foreground_fraction = 0;  ///< foreground pixels / W·H of the source render
  double seconds = 0;   ///< wall time of this candidate's render and comparison (CPU: both renders' share)
  /// Wall time of this candidate's render alone, seconds (CUDA: until the device finished it).
  double render_seconds = 0;
};

/// The PSNR that ranks a view for the verdict, the gate and every "worst view" (table, JSON, report, images,
/// heatmap): the foreground PSNR where the source shows something, else the whole frame's (a view the source
/// leaves black is judged by what the candidate draws there). So every place names the same worst view.
inline double verdict_view_psnr_db(const ViewMetrics& m) {
  return m.foreground_psnr_db == m.foreground_psnr_db ? m.foreground_psnr_db : m.psnr_db;  // NaN: no foreground
}

/// An 8-bit image, row-major, top row first.
struct Image8 {
  uint32_t width = 0, height = 0, channels = 0;  ///< channels 1 (grey) or 3 (RGB)
  std::vector<uint8_t> pixels;                   ///< [H, W, channels]
};

/// Reduced images of one view for the report.
struct ViewImages {
  size_t view = 0;     ///< index into AuditResult::views
  double psnr_db = 0;
  Image8 source;       ///< clamped linear RGB × 255, 3DGS rounding floor(v·255 + 0.5)
  Image8 candidate;
  /// [H, W] float32 of the reduced size: per-pixel max over R, G, B of |Δ| of the clamped values (box maximum
  /// when reduced, so that single pixels stay visible).
  std::vector<float> abs_difference;
  /// Grey: abs_difference scaled so that heat_scale is 255, floor(v / heat_scale · 255 + 0.5), clamped (a |Δ|
  /// above the scale is 255).
  Image8 difference;
  /// The |Δ| that maps to 255: CandidateResult::heat_scale, one scale for every heatmap of this candidate.
  float heat_scale = 0;
};

/// Per-attribute errors of a candidate against the source: each candidate Gaussian against the source Gaussian
/// it is paired with (pair_with_source), only when every candidate Gaussian has one.
struct AttributeReport {
  /// converter::measure_paired_attribute_errors over the pairs; source Gaussians without a pair are left out.
  converter::AttributeErrors errors;
  /// How the Gaussians were paired: index by index, or by content (a candidate stored in another order).
  converter::PairingMethod pairing = converter::PairingMethod::kIndex;
  /// Largest distance between the means of a pair allowed by content, scene units (0 index by index).
  double position_tolerance = 0;
  /// Source Gaussians the candidate has no version of (an archive leaves out those of opacity code 0 or below its
  /// opacity floor).
  uint64_t source_unpaired = 0;
  /// Candidate .rgs only: SH scales s[d][c] and the source's coefficients clipped by them
  /// (|SH| ≥ 127.5·s, or s = 0 with SH ≠ 0).
  std::optional<format::ShQuantization> sh_quantization;
  uint64_t clipped[4][3] = {};
};

/// Mean and minimum over views.
struct Summary {
  double psnr_mean_db = 0, psnr_min_db = 0;  ///< the mean of the per-view dB values
  double ssim_mean = 0, ssim_min = 0;
  /// Mean and minimum of the per-view foreground PSNR over the views that have a foreground (NaN: none has).
  double foreground_psnr_mean_db = 0, foreground_psnr_min_db = 0;
  double render_seconds = 0;  ///< sum of the views' render_seconds
  float max_abs_diff = 0;  ///< over all views
  size_t worst_view = 0;   ///< lowest verdict_view_psnr_db (first of equals)
};

/// Percentile of the non-zero |Δ| of a candidate's heatmaps that is the top of its heat scale
/// (CandidateResult::heat_scale): nearest rank, ceil(p/100 · n)-th smallest.
inline constexpr double kHeatScalePercentile = 99.0;

/// Everything about one candidate.
struct CandidateResult {
  SceneInfo scene;
  std::optional<AttributeReport> attributes;
  std::string attributes_note;  ///< why there are no attribute errors (SH degrees, Gaussians without a pair)
  /// What the candidate is compared with, when not the whole source: one sentence naming the edits its
  /// conversion recorded, applied to a copy of the source (docs/AUDITS.md#how-rgs-audit-measures, "Edited candidates"), or why they
  /// were not. Empty: the whole source.
  std::string reference;
  /// Gaussians of what the candidate is compared with: the source's, or what its recorded edits kept of them.
  uint64_t reference_gaussians = 0;
  std::vector<ViewMetrics> views;  ///< one per AuditResult::views entry
  Summary summary;
  std::vector<ViewImages> worst;  ///< lowest PSNR first, at most AuditOptions::worst_views
  /// The |Δ| shown as 255 in this candidate's heatmaps: the kHeatScalePercentile-th percentile of the non-zero
  /// |Δ| of its heatmaps (the worst views' reduced |Δ|, or the full-size one without them), so that one bright
  /// pixel does not darken the rest; 0 when they have no non-zero |Δ|. summary.max_abs_diff is the largest.
  float heat_scale = 0;
  /// Full-size difference of the worst view (keep_worst_heatmap, first candidate), grey, scaled like the
  /// report's images (heat_scale is 255).
  Image8 worst_heatmap;
};

/// A view as rendered.
struct ViewInfo {
  std::string name;
  uint32_t width = 0, height = 0;
};

/// Result of run_audit().
struct AuditResult {
  Backend backend = Backend::kCpu;
  std::string device;  ///< "CPU reference (N threads)" or the CUDA device's name
  SceneInfo source;
  std::vector<ViewInfo> views;
  std::vector<CandidateResult> candidates;
  double render_seconds = 0;  ///< the per-view loop (uploads and CUDA set-up included)
  /// audit_files: how default_views chose the views when no camera was named (DefaultViews::note); else empty.
  std::string views_note;
};

/// Renders every camera for the source and every candidate, compares, and summarizes. The source is
/// rendered once per view. Candidates may have any Gaussian count; attribute errors only for equal counts and
/// SH degrees.
/// @return kInvalidArgument (no cameras, no candidates, a camera below 11 pixels a side),
///         kUnsupportedFeature (kCuda in a build without CUDA or with no device), the renderers' errors
///         (naming the scene and the view), kCudaError / kOutOfMemory from the GPU.
Result<AuditResult> run_audit(const AuditScene& source, const std::vector<AuditScene>& candidates,
                              const std::vector<runtime::Camera>& cameras, const AuditOptions& options);

/// The files and views of one audit, as rgs-audit and roofgs.audit() name them (audit_files).
struct AuditFiles {
  std::string source;                   ///< the source scene's path; its label is "source"
  std::vector<std::string> candidates;  ///< the candidate scenes' paths, at least one
  /// Labels of the first candidates, in order; the others get load_audit_scene's default (the file name).
  std::vector<std::string> labels;
  converter::SceneReadOptions read;  ///< how every scene is read (load_audit_scene)
  /// Also audit each candidate's attribution_scenes, after all the candidates.
  bool attribution = false;
  /// The views when set. Else api::make_cameras(views, content_frame of the source) when `views` names a
  /// cameras file, an orbit or a path; else api::default_views(source, its cloud, views).
  std::optional<std::vector<runtime::Camera>> cameras;
  api::CameraChoice views;
  /// Called with each scene's reader notes as it is loaded (SceneInfo::notes), then with default_views' note
  /// when it chose the views.
  std::function<void(const std::vector<std::string>& notes)> on_notes = [](const std::vector<std::string>&) {};
  /// Called once the scenes are loaded and the views chosen, before the first render, with the candidates
  /// (attribution scenes included), the views and the options run_audit takes, which it may change (e.g. to set
  /// AuditOptions::on_render); may be empty. An error stops the audit with that error.
  std::function<Status(const std::vector<AuditScene>& candidates, const std::vector<runtime::Camera>& cameras,
                       AuditOptions& options)>
      before_render;
};

/// The whole audit of files: loads the source and the candidates (load_audit_scene), adds the attribution
/// scenes, chooses the views (AuditFiles::cameras) and runs run_audit with `options`; the result's views_note
/// says how default_views chose the views. Errors: those of load_audit_scene, attribution_scenes,
/// api::make_cameras, api::default_views, before_render and run_audit.
Result<AuditResult> audit_files(const AuditFiles& files, AuditOptions options);

}  // namespace rgs::audit
