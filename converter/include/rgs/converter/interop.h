// What the readers of other splat formats (SPZ, antimatter15 .splat, KHR_gaussian_splatting glTF) share:
// read options, the decoded scene, and the coordinate frames involved (converter/INTEROP.md).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rgs/converter/ply_reader.h"
#include "rgs/format/gaussian_cloud.h"

namespace rgs::converter {

/// The axes an SPZ file is taken to hold when the file does not say (converter/INTEROP.md "SPZ axes"). Only a
/// SPZ_ADOBE_coordinate_system extension says; otherwise nothing in an SPZ file tells the two kinds of writer
/// apart, so the reader and writer assume kRub unless told otherwise (for all files, or per file:
/// SceneReadOptions::spz_frame_by_path).
enum class SpzFrame : uint8_t {
  /// RUB (x right, y up, z back), as Niantic's format description and spz library prescribe: turned
  /// into RoofGS's RDF on read (y and z negated) and back on write.
  kRub = 0,
  /// The axes as stored, no turn: the PLY's own axes, as splat-transform (3.7) writes and reads SPZ.
  /// A frame the file declares (SPZ_ADOBE_coordinate_system) is still turned to RDF.
  kAsStored = 1,
};

/// "rub" or "as-stored": the spelling of the tools' --spz-frame, Python's spz_frame and JSON.
const char* spz_frame_name(SpzFrame frame);

/// Parses "rub" / "as-stored"; nullopt for anything else.
std::optional<SpzFrame> parse_spz_frame(std::string_view name);

/// The sentence the tools print whenever an SPZ file is read (`writing` false) or written: which axes were
/// assumed and how to choose the other ones.
std::string spz_frame_note(SpzFrame frame, bool writing);

/// Options of read_spz, read_splat and read_gltf (the same limits and hygiene rules as PlyReadOptions).
struct InteropReadOptions {
  InvalidPolicy invalid_policy = InvalidPolicy::kReject;
  /// Refuse files declaring more Gaussians than this (kLimitExceeded), checked before allocating.
  uint64_t max_gaussians = uint64_t{1} << 28;
  /// The file's codec layers (zstd, gzip, glTF accessors without data) may decode to at most this many bytes
  /// per byte of file, counting the file as at least 1 MiB (format/SPEC.md §5.5, applied to every format;
  /// format::ReadLimits::max_decompression_ratio's default). Checked before allocating (kLimitExceeded).
  uint32_t max_decompression_ratio = 8;
  /// Convert from the format's stored axes into the PLY/COLMAP frame RoofGS uses everywhere (x right,
  /// y down, z forward: "RDF"). False keeps the stored axes, for files whose writer skipped the
  /// conversion its format prescribes (some SPZ writers store the PLY's axes unchanged); an SPZ file that
  /// declares its frame (InteropScene::frame_declared) is converted from that frame either way.
  bool convert_frame = true;
};

/// A scene read from a non-PLY splat file.
struct InteropScene {
  /// Activated float Gaussians in the PLY/COLMAP frame (GaussianCloud documents the layout), unless
  /// InteropReadOptions::convert_frame was false.
  format::GaussianCloud cloud;
  /// Problem values found (always zero for SPZ, whose fields cannot hold them).
  InputHygiene hygiene;
  /// Size of the input in bytes (for .gltf: the JSON file and the buffer bytes it reads from other files).
  uint64_t file_bytes = 0;
  /// Files read besides the input itself, when it names others (a .gltf's buffers), the input first; empty
  /// for single-file inputs.
  std::vector<std::string> files;
  /// Gaussians declared by the file, before sanitizing.
  uint64_t declared_gaussians = 0;
  /// Container name: "spz", "splat", "glb" or "gltf".
  std::string format;
  /// Version of that container (SPZ 2..4, glTF 2; 0 for .splat, which has none).
  uint32_t format_version = 0;
  /// Axes the file stores, in three letters (x y z: Right/Left, Up/Down, Back/Front), e.g. "RUB".
  std::string stored_frame;
  /// Whether the cloud was converted from stored_frame to RDF.
  bool frame_converted = false;
  /// Whether the file itself names stored_frame (SPZ: a SPZ_ADOBE_coordinate_system extension), so that no
  /// assumption about its writer was needed.
  bool frame_declared = false;
  /// What the file said that the cloud cannot hold or that was ignored, one sentence each, for the
  /// conversion summary (e.g. "SPZ antialiased flag set: the cloud carries no mip-splat filter").
  std::vector<std::string> notes;
};

}  // namespace rgs::converter
