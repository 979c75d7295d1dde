// The archive profile: lossy storage that decodes into the runtime profile's arrays (SPEC.md §3.3).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/status.h"

namespace rgs::format {

/// Default largest position error of the archive profile, relative to the scene extent (the longest
/// side of the means' AABB): each axis is quantized with a step of 2 * error * extent. 2^-17 (7.6e-6)
/// gives 17-bit Draco positions (measured in docs/AUDITS.md).
inline constexpr double kDefaultArchivePositionError = 1.0 / 131072.0;

/// SPZ v4's steps, which the archive's automatic settings stay one bit finer than (half the step) and no finer,
/// so that the default archive is no larger than the scene's SPZ at no lower PSNR (docs/AUDITS.md#the-default-archive-against-spz):
/// positions in scene units (24-bit fixed point, 12 fractional bits), and the SH coefficients of degrees 1..3
/// (5 bits for degree 1, 4 for degrees 2 and 3, over [-1, 1]).
inline constexpr double kSpzPositionStep = 1.0 / 4096.0;
inline constexpr std::array<double, 4> kSpzShSteps = {0.0, 1.0 / 16.0, 1.0 / 8.0, 1.0 / 8.0};

/// Opacities below this never blend in any renderer (α <= opacity < 1/255, docs/DESIGN.md#blending-and-output):
/// the default ArchiveOptions::opacity_floor, which leaves them out at no change to any render.
inline constexpr double kInvisibleOpacity = 1.0 / 255.0;

/// The archive's quantized codes also try .xz streams (ArchiveOptions::xz) from this zstd level on, and at any
/// level for scenes under kArchiveDenseGaussians (where LZMA costs little time): LZMA takes 2-5 % off the measured
/// archives for about the time zstd takes at this level (docs/lab/AUDIT_RUNS.md#entropy-coding-of-the-codes).
inline constexpr int kArchiveXzMinZstdLevel = 19;

/// Choices of the archive profile (SPEC §3.3). The defaults are the measured ones of docs/AUDITS.md.
struct ArchiveOptions {
  /// Largest |decoded - source| per mean component, relative to the extent (the longest AABB side), in
  /// (0, 0.5]. The Draco quantization bits are the fewest whose step is at most 2 * error * extent
  /// (at most 30, Draco's limit). 0 (default): kDefaultArchivePositionError, or the error of half SPZ's step
  /// (kSpzPositionStep / 4 scene units) where that is larger (resolve_archive_options).
  double position_error = 0;
  /// Bits per smallest-three quaternion component, 4..16 (§3.3.2 transform 1); 0 (default): by scene
  /// size, 10, or 7 from kArchiveDenseGaussians on (resolve_archive_options).
  uint32_t rotation_bits = 0;
  /// The rotation codes the writer uses, spaced by this many codes, in [1, 4096]: each component is rounded
  /// to the nearest multiple of the step (then to a code). Above 1 the codes use fewer values than the bits
  /// allow, so rotations get coarser by less than a bit, or below the 4-bit minimum; readers see ordinary
  /// codes. Likewise opacity_step for the opacity codes.
  double rotation_step = 1;
  /// Bits per log-scale code, 4..16 (§3.3.2 transform 2); 0 (default): 9, or 7 for dense scenes.
  uint32_t scale_bits = 0;
  /// Step of the log-scale codes as a multiple of the bits' own step, (max − min) / (2^bits − 1) of ln(scale)
  /// per axis, in [1, 4096]; the step is a parameter of transform 2, so above 1 the codes use fewer values
  /// than the bits allow, as with rotation_step.
  double scale_step = 1;
  /// Bits per opacity code, 4..16 (§3.3.2 transform 3); 0 (default): 8, or 6 for dense scenes.
  uint32_t opacity_bits = 0;
  /// Spacing of the opacity codes the writer uses, in [1, 4096] (as rotation_step).
  double opacity_step = 1;
  /// Gaussians whose opacity (the stored binary16 value, activated, in [0, 1]) is below this are left out too,
  /// in [0, 1): a rate-distortion choice of rate control, which steps it upwards from the default,
  /// kInvisibleOpacity (Gaussians that never blend in the source: α ≤ opacity < 1/255). 0: only those of opacity
  /// code 0 are left out.
  double opacity_floor = kInvisibleOpacity;
  /// Multiplier of the INT8 SH step per degree 0..3, 1..127 (§3.3.2 transform 4); 1 keeps the runtime's
  /// INT8 values. 0 (default): 1 for degree 0; for degree d >= 1 the larger of kArchiveShMultipliers[d] and the
  /// most that keeps the step at most half SPZ's (kSpzShSteps[d] / 2 over the largest INT8 step of the degree's
  /// channels), at most 127.
  std::array<uint32_t, 4> sh_step_multipliers = {0, 0, 0, 0};
  /// SH codebook (§3.3.3, transform 5), for SH degree >= 1. 0 (default): each distinct record of rest
  /// codes is stored once (exact: the values of transform 4), when at most 3/4 of the records are
  /// distinct; otherwise transform 6 (transform 4's codes as colour differences, §3.3.2). 2..65536: a lossy
  /// codebook of that many entries (at most N), a variance-splitting tree over the rest vectors; not a default,
  /// since on the measured scenes it costs 10+ dB of PSNR for its bytes (docs/AUDITS.md). 1 is refused.
  uint32_t sh_codebook_size = 0;
  /// zstd level 1..22 of the coded sections (api::convert sets it from ConvertOptions::zstd_level). It changes
  /// the bytes, not the decoded values: 19 codes the measured archives 1-10 % smaller than 6 (docs/AUDITS.md).
  int zstd_level = 19;
  /// Also code each quantized section's codes as an .xz stream (LZMA2, §3.3.2; version 1.5) where LZMA beats
  /// zstd on their first MiB, and keep whichever of it and the zstd frame is smaller: 3-7 % off the quantized
  /// sections of the measured fits (docs/lab/AUDIT_RUNS.md#entropy-coding-of-the-codes), for about one more encoding of
  /// each section. It changes the bytes, not the decoded values; rate control's search codes without it
  /// (faster) and writes with it; resolve_archive_options keeps it from kArchiveXzMinZstdLevel on, or for a scene
  /// under kArchiveDenseGaussians.
  bool xz = true;
  /// Draco encoding speed 0..10 (0 = densest, 10 = fastest); it changes the bytes, not the decoded values.
  int draco_speed = 6;
  /// Worker threads for encoding: the sections are coded in parallel, and each section's zstd frame spreads its
  /// jobs (SPEC §7) over its share; the bytes do not depend on it. 0 (default): the machine's hardware threads.
  uint32_t threads = 0;
};

/// From this many Gaussians on, a scene is *dense*: each Gaussian covers few pixels, so the default bits
/// of rotations, scales and opacities are lower (measured in docs/AUDITS.md: 542,104-Gaussian daffodils
/// lose 2.2 dB for 2.7 B/G less; the 38,347-Gaussian flowers would lose 2.6 dB at only 8/8/7 bits).
inline constexpr uint64_t kArchiveDenseGaussians = uint64_t{1} << 18;

/// Checks every field of `options` against the range its comment states (position error in (0, 0.5], NaN
/// refused; bits, steps, SH multipliers, opacity floor, codebook size, zstd level, Draco speed), before any
/// scene is read. Errors: kInvalidArgument naming the option, its value and the range.
Status check_archive_options(const ArchiveOptions& options);

/// The SH step multipliers per degree below which the automatic ones (ArchiveOptions::sh_step_multipliers) go
/// no finer, whatever the scene's SH scales.
inline constexpr std::array<uint32_t, 4> kArchiveShMultipliers = {1, 3, 5, 6};

/// `options` with its automatic (0) settings replaced by their values for `scene` (its count, extent and SH
/// scales; see each field), and xz kept only where resolved to apply.
ArchiveOptions resolve_archive_options(const ArchiveOptions& options, const EncodedScene& scene);

/// Position quantization of the archive profile for a scene of the given AABB (SPEC §3.3.1).
struct ArchivePositionQuantization {
  uint32_t bits = 0;       ///< Draco quantization bits, 1..30
  float origin[3] = {};    ///< quantization origin: the AABB minimum
  float range = 0;         ///< longest AABB side (the extent); 0 for a single point
  double step = 0;         ///< range / (2^bits - 1), world units
};

/// Chooses the position quantization for `bounds` and `position_error` (see ArchiveOptions).
/// Errors: kInvalidArgument when the error is outside (0, 0.5] or not finite, or when the bounds span float32's
/// largest value or more on an axis (no float32 grid range covers them; the runtime profile keeps such means).
Result<ArchivePositionQuantization> choose_position_quantization(const SceneBounds& bounds, double position_error);

/// An archive-coded scene: what a reader will decode, and the stored bytes of each per-Gaussian section.
///
/// A source Gaussian whose opacity code is 0 decodes to opacity 0, which every renderer skips (α < 1/255,
/// docs/DESIGN.md#blending-and-output): the archive omits it, so the file renders as the archive with it would,
/// and stores decoded.count = source_count − omitted.size() Gaussians (SPEC §3.3.2). So does one whose opacity is
/// below ArchiveOptions::opacity_floor. When that would be every Gaussian, none is omitted (the file keeps the
/// scene's Gaussians rather than becoming empty).
struct ArchiveScene {
  /// The scene as RgsFile::read_scene returns it from the archive file, in file order: means decoded
  /// from Draco, the other arrays through their transforms; metadata bounds recomputed from the decoded
  /// means, the SH scales those of the source.
  EncodedScene decoded;
  /// Gaussian i of `decoded` is Gaussian source_index[i] of the source (Draco's kd-tree order, SPEC §3.3.1).
  std::vector<uint64_t> source_index;
  /// Gaussians in the source.
  uint64_t source_count = 0;
  /// Source indices of the omitted Gaussians (opacity code 0, or opacity below the floor), ascending.
  std::vector<uint64_t> omitted;
  ArchivePositionQuantization position;
  /// Stored bytes of the means (draco), rotations, scales, opacities and sh (quantized) sections.
  std::array<std::vector<uint8_t>, 5> stored;
  /// The options it was encoded with, resolved (no automatic bit counts).
  ArchiveOptions options;
};

/// Encodes `scene` (a valid runtime-profile scene) into the archive profile and decodes it back, so
/// that `decoded` is exactly what readers of the file will see. Deterministic: same scene and options,
/// same bytes, whatever `threads`. `earlier`, an archive of the same `scene` (not checked beyond its count),
/// lends each section whose settings are those of `options`: the means when the position bits, draco_speed
/// and the omitted Gaussians match (and with them the point order), then each other section whose own setting
/// matches (rotation_bits and rotation_step, scale_bits and scale_step, opacity_bits and opacity_step, the SH
/// multipliers and codebook size) at the same zstd_level. The result is the same as
/// without it; callers that vary one setting at a time (rate control) encode one section instead of five.
/// Errors: kInvalidArgument (options out of range, an inconsistent scene, an `earlier` of another count),
/// kOutOfMemory.
Result<ArchiveScene> encode_archive(const EncodedScene& scene, const ArchiveOptions& options,
                                    const ArchiveScene* earlier = nullptr);

}  // namespace rgs::format
