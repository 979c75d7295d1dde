// Rate control of the archive profile: chooses format::ArchiveOptions (bits and code steps of rotations, scales
// and opacities, SH step multipliers per degree, position error, opacity floor) so that the archive's render
// meets a PSNR target against the source's render at the fewest bytes, or fits a byte budget at the best PSNR.
// The search encodes each candidate in memory (format::encode_archive) and measures it with run_audit on
// the given cameras, reduced in size; the choice is then checked at the cameras' own size. How it searches
// and what it reaches: docs/AUDITS.md#rate-control-of-the-archive-profile.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/api/camera.h"
#include "rgs/audit/audit.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/archive.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"

namespace rgs::audit {

/// What fit_archive() aims at.
enum class FitGoal {
  kTargetPsnr,   ///< mean PSNR over the views >= target_psnr_db at the fewest bytes
  kTargetBytes,  ///< file bytes <= target_bytes at the highest mean PSNR
};

/// zstd level at which the search codes its candidates when the file's is higher (FitOptions::start): level 19
/// costs 8x the time of 6 on a 542k-Gaussian scene, and rate control encodes dozens of candidates.
constexpr int kSearchZstdLevel = 6;

/// FitOptions::search_max_side's automatic values, pixels on the longer side.
constexpr uint32_t kCpuSearchMaxSide = 320, kCudaSearchMaxSide = 1920;

/// Options of fit_archive().
struct FitOptions {
  FitGoal goal = FitGoal::kTargetPsnr;
  /// kTargetPsnr: the mean over the views of the per-view PSNR (dB, peak 1, clamped RGB; run_audit's) of the
  /// archive's render against the source's, at the cameras' own size.
  double target_psnr_db = 40;
  /// kTargetBytes: the largest output file, bytes (sections, header, metadata and provenance).
  uint64_t target_bytes = 0;
  /// How the source is quantized before the archive codecs (api::convert's settings; sh_dc_bits is 8 in the
  /// archive profile whatever it says).
  converter::QuantizeOptions quantize;
  /// Drop the SH bands above this degree before encoding (the source's render keeps them).
  std::optional<uint32_t> sh_degree;
  /// The archive options the search starts from; it chooses position_error, the bits and code steps of
  /// rotations, scales and opacities (rotation_step etc., in quarter bits), sh_step_multipliers and
  /// opacity_floor, and keeps sh_codebook_size, zstd_level, xz, draco_speed and threads. The search codes its
  /// candidates at zstd level min(zstd_level, kSearchZstdLevel) and without xz: they change the bytes, not the
  /// decoded values, so the PSNR it measures is the file's, while the bytes it counts (FitPoint::bytes) are those
  /// of the search's coding (level 19 wrote the measured fits 1-10 % smaller, the .xz codes 2-5 % smaller again,
  /// docs/AUDITS.md#entropy-coding-of-the-codes).
  format::ArchiveOptions start;
  /// The search renders the cameras reduced (field of view kept) so that their longer side is at most this
  /// many pixels (at least 16); the final check renders them at their own size. 0: kCpuSearchMaxSide with the
  /// CPU backend, kCudaSearchMaxSide with CUDA, where renders are cheap next to encoding and the reduced views
  /// of a dense scene read several dB above its full ones (docs/AUDITS.md, rate control).
  uint32_t search_max_side = 0;
  /// The search renders at most this many of the cameras, evenly spread; the final check renders them all.
  uint32_t search_max_views = 6;
  /// Bytes the file will hold besides the sections the search measures and the metadata it knows: the
  /// provenance (api::convert writes the source name, its hash and the options there).
  uint64_t provenance_bytes = 1024;
  /// Rendering: backend (CPU reference or CUDA), device, CPU threads; the rest is not used. The renders and
  /// the PSNR are run_audit's (faithful preset, black background, the whole frame's PSNR; on the GPU compared on
  /// the device, as run_audit does); the source is rendered once.
  AuditOptions audit;
  /// Called after each batch of measurements with a line of text such as "search: 6 archives measured, best
  /// 40.31 dB at 1,234,567 bytes"; may be empty.
  std::function<void(const std::string&)> progress;
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
  /// The chosen archive's mean PSNR at the search size.
  double search_psnr_db = 0;
  /// The finest archive the search measured on the way (kTargetPsnr: when a target is refused, the best it
  /// reaches). Measured at the search size.
  std::optional<FitPoint> finest;
  uint32_t views = 0;                      ///< cameras measured
  uint32_t search_width = 0, search_height = 0;  ///< first camera's size in the search
  uint32_t width = 0, height = 0;          ///< first camera's own size (the final check)
  uint32_t encodings = 0;                  ///< archives encoded (each measured for bytes)
  uint32_t renders = 0;                    ///< archives rendered (each on every camera)
  Backend backend = Backend::kCpu;
  std::string device;                      ///< "CPU reference renderer" or "CUDA device N"
  double seconds = 0;                      ///< wall time of fit_archive
  /// Of `seconds`: encoding the candidates (format::encode_archive), and loading and rendering them with the
  /// PSNR against the source (the source's own renders not included).
  double encode_seconds = 0, render_seconds = 0;
  /// An archive the search encoded with the chosen settings' Draco points (null if none is kept): it lends the
  /// file that writes the choice its means (api::ConvertOptions::archive_earlier), so Draco does not run again.
  std::shared_ptr<const format::ArchiveScene> archive;
};

/// Chooses the archive options for `source` (activated float Gaussians, as read) on `cameras`:
/// kTargetPsnr: the fewest bytes whose mean PSNR (archive render against `source`'s render, run_audit's
/// definition) at the cameras' size is >= target_psnr_db; kTargetBytes: the highest such PSNR whose file
/// fits target_bytes. The search: a ladder that coarsens every knob together from the defaults
/// (format::resolve_archive_options), bracketed at the search size; then rounds of one-knob steps
/// (kTargetPsnr: the steps that keep the target taken together, by bytes saved per squared error added, a
/// scan of the SH multipliers' integers, then exchanges of one knob a step coarser for another a step finer,
/// each followed by more rounds, and the code steps coarsened a quarter bit at a time while the target holds).
/// kTargetBytes runs those kTargetPsnr searches at the search size, searching over their target for the highest
/// one whose file fits, then spends what the budget leaves on finer single steps; of all the archives it measured
/// within the budget (counted as the file codes them), the few of the highest PSNR on the search views are checked
/// at the cameras' own size and the highest there is chosen; then kTargetPsnr fits a little above that choice
/// replace it while one fits and reads higher at the cameras' size.
/// kTargetPsnr calibrates the difference
/// between the search size and the cameras' own size at the ladder's point, and checks the search's choice at
/// the cameras' own size, searching again with the measured difference while it misses the target or lands over
/// 0.5 dB above it. Deterministic for a given backend.
/// @return kInvalidArgument: no cameras, an empty or invalid source, a target that is not finite or positive,
///         a PSNR target above what the finest archive reaches (the message says what it reaches), a byte
///         budget below the coarsest archive (the message says its size); kLimitExceeded: no archive the
///         bytes search measured fits target_bytes once coded at the file's zstd level; the errors of quantize,
///         encode_archive and run_audit.
Result<FitResult> fit_archive(const format::GaussianCloud& source, const std::vector<runtime::Camera>& cameras,
                              const FitOptions& options);

/// What convert_fitted() did: the fit and the conversion that wrote its choice.
struct FittedConversion {
  FitResult fit;
  api::ConvertReport convert;
  /// Which views the fit measured when `cameras` named none (DefaultViews::note); empty otherwise.
  std::string views_note;
};

/// Checks `options` as written with the archive profile (api::check_convert_options: kInvalidArgument before
/// anything is read, e.g. levels of detail), reads `src` (as api::convert does, with `options.read`, `sanitize`,
/// `sh_degree`), builds `cameras` (api::make_cameras on the scene's bounds; when it names no cameras file, orbit
/// or path, default_views: the scene's own cameras.json found beside it, else views guessed from its content),
/// runs fit_archive with `fit` (its quantize, sh_degree and start taken from `options`), then writes the scene
/// it read with api::convert_scene(…, dst, options), the archive profile and the chosen ArchiveOptions (the
/// fit's archive lending its means). `fit.provenance_bytes` is set from the source's name. The output is
/// written only on success. Errors: those of reading `src`, of make_cameras (prefixed with `src`) or
/// default_views, fit_archive and api::convert_scene; kInternal-free: a written file larger than a byte target
/// is kLimitExceeded (and not kept by `options.files`' caller: the transaction is not committed by this
/// function).
Result<FittedConversion> convert_fitted(const std::string& src, const std::string& dst, api::ConvertOptions options,
                                        const api::CameraChoice& cameras, FitOptions fit);

/// "rot 10, scale 9, opacity 8 bits; SH x1/3/5/6; position 7.63e-06": the chosen knobs in words.
std::string describe_archive_options(const format::ArchiveOptions& options, uint32_t sh_degree);

}  // namespace rgs::audit
