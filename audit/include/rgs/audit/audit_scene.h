// Scenes the audit compares: any file it can read, as float Gaussians plus what its file says about sizes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

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
  /// .rgs: the metadata bounds; otherwise converter::compute_bounds.
  format::SceneBounds bounds;
  /// .rgs only: the SH quantization, for counting clipped coefficients against a source.
  std::optional<format::ShQuantization> sh_quantization;
};

/// Loads any scene file the audit can compare through converter::read_scene(path, options): a .rgs
/// dequantized (with its SH quantization and section table), or any other format it detects by content
/// (PLY, compressed PLY, SOG, SPZ, .splat, glTF). `label` defaults to the file name. Errors: those of
/// read_scene, naming `path`.
Result<AuditScene> load_audit_scene(const std::string& path, const std::string& label = {},
                                    const converter::SceneReadOptions& options = {});

/// Where a candidate loses its fidelity, attribute by attribute: one scene per attribute group (means,
/// rotations, scales, opacities, the SH DC term, the higher SH bands when the source has them), each the
/// source with only that group taken from `candidate`, labelled "<candidate label>: <group> only". Audited
/// as candidates against the source, each one's PSNR is what that attribute's encoding alone costs.
/// Needs the same Gaussians in the same order: kInvalidArgument when the counts or SH degrees differ.
Result<std::vector<AuditScene>> attribution_scenes(const AuditScene& source, const AuditScene& candidate);

}  // namespace rgs::audit
