// The front door: load a scene from any supported file (convert.h converts files). Usable without CUDA headers; GPU
// scenes exist only in builds with RGS_HAS_CUDA (rgs/config.h).
//
// Thread safety: a Scene is immutable once loaded; copies share it (reference counted), and one Scene may be
// rendered by several Renderers on several threads at once. load() and convert() are reentrant.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgs/api/preset.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"

namespace rgs::runtime {
class GpuScene;
}

namespace rgs::api {

/// Where a scene lives and is rendered.
enum class Device {
  kCpu = 0,   ///< host memory, rendered by the CPU reference renderer (runtime::render_cpu)
  kCuda = 1,  ///< device memory, rendered by runtime::GpuRenderer
};

/// "cpu" or "cuda".
const char* device_name(Device device);

/// Parses "cpu" / "cuda" (also "gpu"), and "auto": kCuda when cuda_available(), else kCpu.
/// @return kInvalidArgument otherwise.
Result<Device> parse_device(const std::string& name);

/// True when this build has the CUDA renderer and a CUDA device answers (`why`, when given and false: the
/// reason, e.g. "built without CUDA" or the driver's error).
bool cuda_available(std::string* why = nullptr);

/// Options of load().
struct LoadOptions {
  Device device = Device::kCuda;
  /// CUDA device ordinal (made current on the calling thread while loading).
  int cuda_device = 0;
  /// Presets the scene will be rendered with: the GPU copy holds only what their pipelines read. With the
  /// default (kFastest, or kPaper) a .rgs scene holds its runtime sections only; adding kFaithful adds the
  /// FP32 arrays (about 4× the bytes at SH degree 3). Rendering a preset not listed here may fail with
  /// kInvalidArgument. Ignored on the CPU.
  std::vector<Preset> presets = {Preset::kFastest};
  /// Files other than .rgs (any format converter::read_scene detects): true quantizes them in memory with the
  /// converter's defaults (what `rgs-convert in.ply out.rgs` writes, converter::QuantizeOptions{}), so that they render
  /// exactly as the converted file would and the GPU holds the compact profile; false keeps the PLY's float values
  /// (GPU: FP32 arrays only; the RoofGS presets then read FP32).
  bool quantize_other_formats = true;
  /// How the file is read (converter::read_scene for every format: limits, the SPZ axes; a .rgs file
  /// uploaded as stored is opened with converter::rgs_read_options of it).
  converter::SceneReadOptions read_options;
};

/// What load() produced.
struct SceneInfo {
  std::string path;
  Device device = Device::kCpu;
  uint64_t gaussians = 0;
  uint32_t sh_degree = 0;
  /// Scene AABB and bounding sphere (the .rgs metadata, or converter::compute_bounds of a PLY).
  format::SceneBounds bounds;
  /// True when the file was a .rgs (sniffed by magic or extension).
  bool source_is_rgs = false;
  /// The file's format in words ("RoofGS .rgs", "binary_little_endian PLY", "Niantic SPZ v4 ...").
  std::string description;
  uint64_t file_bytes = 0;
  /// GPU scenes: whether the compact runtime sections and the FP32 arrays are on the device.
  bool has_compact = false;
  bool has_fp32 = false;
  /// GPU scenes: device bytes the scene holds (runtime::GpuScene::device_bytes()); CPU scenes: host bytes of
  /// the float arrays.
  uint64_t memory_bytes = 0;
  /// Bytes of the .rgs runtime sections (means, rotations, scales, opacities, SH) uncompressed, 0 for a
  /// scene kept in FP32: the footprint a compact GPU scene is measured against.
  uint64_t runtime_section_bytes = 0;
  /// What the reader noted (converter::InputScene::notes), e.g. the SPZ axes assumed.
  std::vector<std::string> notes;
};

/// A loaded scene. Cheap to copy (shared, immutable).
class Scene {
 public:
  const SceneInfo& info() const;
  Device device() const { return info().device; }
  uint64_t size() const { return info().gaussians; }
  /// CPU scenes: the activated float Gaussians rendered (format::GaussianCloud layout); null for GPU scenes.
  const format::GaussianCloud* cloud() const;
  /// GPU scenes: the device scene for the expert API (runtime/gpu_scene.h); null for CPU scenes.
  const runtime::GpuScene* gpu_scene() const;

  struct Impl;
  explicit Scene(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

 private:
  std::shared_ptr<const Impl> impl_;
};

/// Loads `path` (a .rgs file, or any format converter::read_scene detects: 3DGS PLY, PlayCanvas compressed
/// PLY / SOG, SPZ, glTF, .splat) for `options.device`.
/// - CUDA, .rgs: sections uploaded as stored (runtime::GpuScene::from_rgs), FP32 arrays only when a listed
///   preset reads them; CUDA, other formats: quantized in memory then uploaded the same way (or FP32, see options).
/// - CPU: the dequantized float Gaussians (the values the GPU's compact reads produce).
/// Synchronous (the upload is complete on return).
/// @return errors naming `path`: kIoError, kNotRgsFile, kCorruptData, kChecksumMismatch, kLimitExceeded,
/// kOutOfMemory; kUnsupportedFeature for device kCuda in a build without CUDA or on a host without a
/// usable device (the message says which); kCudaError.
Result<Scene> load(const std::string& path, const LoadOptions& options = {});

/// A scene from float Gaussians already in memory (format::GaussianCloud's layout; e.g. the decoded scenes an
/// audit compares) for `options.device`: the cloud itself on the CPU, FP32 arrays on the GPU (what the
/// faithful preset and lab configurations on FP32 read; options.presets and quantize_other_formats are not
/// used). `name` stands for the path in SceneInfo and messages; `bounds` are the scene's (compute_bounds).
/// @return kInvalidArgument (inconsistent cloud); for kCuda as load().
Result<Scene> load_cloud(format::GaussianCloud cloud, const format::SceneBounds& bounds, const std::string& name,
                         const LoadOptions& options = {});

}  // namespace rgs::api
