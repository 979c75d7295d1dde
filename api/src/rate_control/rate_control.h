// Rate control of the archive profile (ConvertOptions::target), private to rgs_api: fit_archive chooses
// format::ArchiveOptions for a PSNR target or a byte budget; fit_target runs it for convert() on the scene it read.
// How it searches and what it reaches: docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/api/scene.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/archive.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"

namespace rgs::api::detail {

/// zstd level at which the search codes its candidates when the file's is higher (FitOptions::start): level 19
/// costs 8x the time of 6 on a 542k-Gaussian scene, and rate control encodes dozens of candidates.
constexpr int kSearchZstdLevel = 6;

/// ConvertTarget::search_max_side's automatic values, pixels on the longer side.
constexpr uint32_t kCpuSearchMaxSide = 320, kCudaSearchMaxSide = 1920;

/// Rate control's progress in steps (a stage of a search, a check at the views' own size) against an upper bound
/// on the steps of the whole fit. Each part of the search reserves its most steps (begin) and gives back what it
/// did not use when it ends (end), so that the bound shrinks as the search settles and done / bound never
/// decreases. Reports each step, with a line of text, to `sink`.
class FitProgress {
 public:
  using Sink = std::function<void(const std::string& what, uint32_t done, uint32_t bound)>;
  explicit FitProgress(Sink sink = {}) : sink_(std::move(sink)) {}
  /// Reserves `steps` for a part of the search: out of the enclosing part's reservation, else added to the bound.
  void begin(uint32_t steps);
  /// Ends the innermost part: the steps of its reservation it did not use leave the bound (and the enclosing
  /// part's reservation).
  void end();
  /// `steps` more steps done (0: only a new line of text), reported with `what`.
  void advance(const std::string& what, uint32_t steps = 1);
  uint32_t done() const { return done_; }
  uint32_t bound() const { return bound_; }

 private:
  struct Part {
    uint32_t start = 0, steps = 0;
  };
  Sink sink_;
  std::vector<Part> parts_;
  uint32_t done_ = 0, bound_ = 0;
};

/// A part of the search in FitProgress: begin(steps) when made, end() when it goes out of scope (an early error
/// return included). Does nothing without a FitProgress.
class FitSteps {
 public:
  FitSteps(FitProgress* progress, uint32_t steps) : progress_(progress) {
    if (progress_) progress_->begin(steps);
  }
  ~FitSteps() {
    if (progress_) progress_->end();
  }
  FitSteps(const FitSteps&) = delete;
  FitSteps& operator=(const FitSteps&) = delete;

 private:
  FitProgress* progress_;
};

/// Options of fit_archive().
struct FitOptions {
  /// The goal (psnr_db or bytes: one is set, check_convert_options), the search's reduced views
  /// (search_max_side, search_max_views) and the renderer (device, cuda_device, cpu_threads). Its `views` are
  /// fit_archive's `cameras`, built by the caller.
  ConvertTarget target;
  /// How the source is quantized before the archive codecs (convert's settings; sh_dc_bits is 8 in the archive
  /// profile whatever it says).
  converter::QuantizeOptions quantize;
  /// Drop the SH bands above this degree before encoding (the source's render keeps them).
  std::optional<uint32_t> sh_degree;
  /// The archive options the search starts from; it chooses position_error, the bits and code steps of
  /// rotations, scales and opacities (rotation_step etc., in quarter bits), sh_step_multipliers and
  /// opacity_floor, and keeps sh_codebook_size, zstd_level, xz, draco_speed and threads. The search codes its
  /// candidates at zstd level min(zstd_level, kSearchZstdLevel) and without xz: they change the bytes, not the
  /// decoded values, so the PSNR it measures is the file's, while the bytes it counts (FitPoint::bytes) are those
  /// of the search's coding (level 19 wrote the measured fits 1-10 % smaller, the .xz codes 2-5 % smaller again,
  /// docs/lab/AUDIT_RUNS.md#entropy-coding-of-the-codes).
  format::ArchiveOptions start;
  /// Bytes the file will hold besides the sections the search measures and the metadata it knows: the
  /// provenance (convert writes the source name, its hash and the options there).
  uint64_t provenance_bytes = 1024;
  /// Where the search's steps are reported; may be null.
  FitProgress* progress = nullptr;
};

/// One measured archive.
struct FitPoint {
  format::ArchiveOptions options;  ///< resolved: no automatic (0) bit counts
  /// The file's bytes (sections measured at the search's zstd level, FitOptions::start; header, metadata,
  /// provenance estimated).
  uint64_t bytes = 0;
  double psnr_mean_db = 0;         ///< mean over the views, NaN when not rendered
  double psnr_min_db = 0;          ///< lowest view
};

/// What fit_archive() chose.
struct FitResult {
  /// The chosen archive, measured at the cameras' own size (psnr_*: the final check).
  FitPoint chosen;
  /// The finest archive the search measured on the way (a PSNR target: when it is refused, the best it
  /// reaches). Measured at the search size.
  std::optional<FitPoint> finest;
  /// What the fit reports (ConvertReport::rate_control): fit_archive fills every field but views_note, the chosen
  /// settings and PSNRs from `chosen` once it is settled; the search sets search_psnr_db (the chosen archive's mean
  /// PSNR at the search size).
  RateControlReport report;
  /// An archive the search encoded with the chosen settings' Draco points (null if none is kept): it lends the
  /// file that writes the choice its means (ConvertOptions::archive_earlier), so Draco does not run again.
  std::shared_ptr<const format::ArchiveScene> archive;
};

/// Chooses the archive options for `source` (activated float Gaussians, as read) on `cameras` (ConvertTarget and
/// convert() describe the search). Deterministic for a given device. The goal's target is checked by
/// check_convert_options.
/// @return kInvalidArgument: no cameras, an empty source, a PSNR target above what the finest archive reaches (the
///         message says what it reaches), a byte budget below the coarsest archive (the message says its size);
///         kLimitExceeded: no archive the bytes search measured fits target.bytes once coded at the file's zstd
///         level; the errors of quantize, encode_archive and rendering.
Result<FitResult> fit_archive(const format::GaussianCloud& source, const std::vector<runtime::Camera>& cameras,
                              const FitOptions& options);

/// convert()'s rate control on the scene it read from `src_name`: builds the views (options->target.views), fits
/// the archive (fit_archive, its quantize, sh_degree and start taken from `options`, the provenance estimated
/// from `src_name`), and sets options->profile, archive and archive_earlier to write the choice. `progress`
/// receives its steps. @return the report, or the errors of the views (prefixed with "<src_name>: rate control's
/// views") and of fit_archive (prefixed with `src_name`).
Result<RateControlReport> fit_target(const converter::InputScene& input, const std::string& src_name,
                                     ConvertOptions* options, const FitProgress::Sink& progress);

}  // namespace rgs::api::detail
