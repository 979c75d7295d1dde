// What the readers of other splat formats (SPZ, antimatter15 .splat, KHR_gaussian_splatting glTF) share:
// read options, the decoded scene, and the coordinate frames involved (converter/INTEROP.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/ply_reader.h"
#include "rgs/format/gaussian_cloud.h"

namespace rgs::converter {

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
  /// conversion its format prescribes (some SPZ writers store the PLY's axes unchanged).
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
  /// What the file said that the cloud cannot hold or that was ignored, one sentence each, for the
  /// conversion summary (e.g. "SPZ antialiased flag set: the cloud carries no mip-splat filter").
  std::vector<std::string> notes;
};

}  // namespace rgs::converter
