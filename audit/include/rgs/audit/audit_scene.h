// Scenes the audit compares: any file it can read, as float Gaussians plus what its file says about sizes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rgs/converter/gaussian_pairing.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"

namespace rgs::audit {

/// Stored size of one section of a sectioned file (.rgs: the section table).
struct SectionSize {
  std::string name;   ///< e.g. "sh" (format::section_name)
  std::string codec;  ///< e.g. "none", "zstd" (format::codec_name)
  uint64_t stored_bytes = 0;  ///< bytes in the file (after the codec)
  uint64_t raw_bytes = 0;     ///< bytes after decoding
};

/// What the audit reports about one scene file.
struct SceneInfo {
  std::string path;
  std::string label;   ///< short name for tables and plots (default: the file name)
  std::string format;  ///< "rgs" or "ply"
  uint64_t file_bytes = 0;
  uint64_t gaussians = 0;
  uint32_t sh_degree = 0;
  /// Per-section sizes (.rgs); empty for formats without a section table.
  std::vector<SectionSize> sections;
  /// file_bytes minus the sections' stored bytes (header, table, padding); 0 without sections.
  uint64_t overhead_bytes = 0;
  /// What the reader noted (converter::InputScene::notes: the SPZ axes assumed, ignored fields).
  std::vector<std::string> notes;
  /// Wall time of load_audit_scene for this file, seconds: reading, decoding and (.rgs) the section table;
  /// 0 for a scene not read from a file (attribution_scenes).
  double load_seconds = 0;
};

/// A scene loaded for the audit: decoded float Gaussians as a renderer sees them.
struct AuditScene {
  SceneInfo info;
  /// Activated float Gaussians (a PLY as read, a .rgs dequantized: format::dequantize).
  format::GaussianCloud cloud;
  /// .rgs: the metadata bounds; otherwise converter::compute_bounds (attribution_scenes: the source's, and for
  /// the means scene those of its own means).
  format::SceneBounds bounds;
  /// .rgs only: the SH quantization, for counting clipped coefficients against a source.
  std::optional<format::ShQuantization> sh_quantization;
  /// Made from the source Gaussian by Gaussian (attribution_scenes): Gaussian i is a version of the source's
  /// Gaussian i, so pair_with_source pairs it index by index without a search.
  bool source_order = false;
  /// .rgs only: its provenance's "options" entry, the settings of the conversion that wrote it. run_audit compares
  /// a candidate whose conversion edited the scene with the source under the same edits, --decimate apart
  /// (converter::parse_recorded_edits).
  std::string conversion_options;
};

/// Loads any scene file the audit can compare through converter::read_scene(path, options): a .rgs
/// dequantized (with its SH quantization and section table), or any other format it detects by content
/// (PLY, compressed PLY, SOG, SPZ, .ksplat, .splat, glTF). `label` defaults to the file name. Errors: those of
/// read_scene, naming `path`.
Result<AuditScene> load_audit_scene(const std::string& path, const std::string& label = {},
                                    const converter::SceneReadOptions& options = {});

/// Largest distance between the means of a candidate Gaussian and the source Gaussian it is paired with, as a
/// fraction of the source's extent (the longest side of its means' box): above the position errors of the
/// writers and readers the audit compares (SPZ's half step of 2^-13 units, an archive's √3 × its position error,
/// at most 0.0028 of the extent in the measured rate-control fits), and far below the distance between two
/// unrelated scenes' Gaussians, which then get no pairing.
inline constexpr double kPairingMaxDistanceOfExtent = 1.0 / 128;

/// Pairs each Gaussian of `candidate` with the source Gaussian it is a version of: index by index for a scene
/// made from the source (AuditScene::source_order), else converter::pair_gaussians with a largest distance of
/// kPairingMaxDistanceOfExtent × the source's extent (index by index when the means agree at every index, else by
/// content, whatever order either file keeps; gaussian_pairing.h says what the pairing guarantees and costs).
/// A pairing with GaussianPairing::unpaired_test > 0 is no error: unpaired_note() says why. Errors: those of
/// pair_gaussians, naming the candidate.
Result<converter::GaussianPairing> pair_with_source(const AuditScene& source, const AuditScene& candidate);

/// Why an incomplete `pairing` of a candidate of `candidate_gaussians` Gaussians pairs nothing, one sentence
/// with the counts and the distance, e.g. "1,024 of 90,854 candidate Gaussians have no source Gaussian within
/// 0.0342 scene units (1/128 of the source's extent)".
std::string unpaired_note(const converter::GaussianPairing& pairing, uint64_t candidate_gaussians);

/// Where a candidate loses its fidelity, attribute by attribute: one scene per attribute group (means,
/// rotations, scales, opacities, the SH DC term, the higher SH bands when the source has them), each the
/// source with only that group taken from `candidate`, labelled "<candidate label>: <group> only". Audited
/// as candidates against the source, each one's PSNR is what that attribute's encoding alone costs.
/// Each candidate Gaussian's values go to the source Gaussian it is paired with (pair_with_source), whatever
/// order the candidate's file keeps; source Gaussians the candidate lacks (an archive leaves out those of
/// opacity code 0 or below its opacity floor) keep the source's values, except in the opacities scene, where
/// their opacity is 0: leaving them out is what the candidate did to their opacity. The scenes hold the source's
/// Gaussians in its order (AuditScene::source_order).
/// Errors: kInvalidArgument when the SH degrees differ or some candidate Gaussian cannot be paired (the message
/// gives unpaired_note()); those of pair_with_source.
Result<std::vector<AuditScene>> attribution_scenes(const AuditScene& source, const AuditScene& candidate);

}  // namespace rgs::audit
