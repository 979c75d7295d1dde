// Benchmark scenes from real ones: a scene file tiled K times, as the bytes of a .rgs file (rgs-bench
// --replicate K).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/scene_reader.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"

namespace rgs::lab {

/// Largest Gaussian count a scene may have on the GPU (runtime::GpuScene and replicate(): 2^31 − 1).
inline constexpr uint64_t kMaxGpuGaussians = 0x7fffffff;

/// A scene tiled K times for benchmarks, as the bytes of a complete .rgs file so that the GPU loads it
/// through the path of a file (format::RgsFile::from_bytes, runtime::GpuScene::from_rgs).
struct ReplicatedScene {
  /// A .rgs file (SPEC v1.0), every section uncompressed; provenance gains "replicated" = K.
  std::vector<uint8_t> rgs_bytes;
  /// Bounds of all copies (the .rgs metadata).
  format::SceneBounds bounds;
  uint64_t source_gaussians = 0;
  uint64_t gaussians = 0;  ///< copies × source_gaussians
  uint32_t copies = 1;
  uint32_t sh_degree = 0;
  bool source_is_rgs = false;
  uint64_t source_file_bytes = 0;
  /// How the copies were quantized (the source .rgs's own quantization, or the converter's defaults).
  std::string quantization;
  /// What the reader noted about the source (converter::InputScene::notes).
  std::vector<std::string> notes;
};

/// Reads `path` and tiles it `copies` times with replicate() (a grid in the x–z plane). A .rgs
/// source is replicated as stored; a source in another format (read through converter::read_scene) is
/// first quantized with the default QuantizeOptions (what `rgs-convert in.ply out.rgs` writes). For a .rgs
/// file the count is checked from the header first.
/// Errors: kInvalidArgument (copies 0), kLimitExceeded (copies × Gaussians > kMaxGpuGaussians, naming both
/// numbers), those of reading `path` (which they name) and of quantizing/serializing.
Result<ReplicatedScene> replicate_scene_file(const std::string& path, uint32_t copies,
                                             const converter::SceneReadOptions& options = {});

}  // namespace rgs::lab
