// The front door: load a scene from any supported file (convert.h converts files). Usable without CUDA headers; GPU
// scenes exist only in builds with RGS_HAS_CUDA (rgs/config.h).
//
// Thread safety: a Scene is immutable once loaded; copies share it (reference counted), and one Scene may be
// rendered by several Renderers on several threads at once. The one exception is a level-of-detail scene on the
// GPU (SceneInfo::lod.active, device kCuda): its frames are drawn from a pool of streamed levels that each frame
// changes, so its renders take turns (a mutex in the scene) and each frame's gather waits on the GPU for the
// previous frame's render, whichever stream that was on; sharing it is safe, but its frames are not concurrent.
// load() and convert() are reentrant.
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

/// How load() renders a level-of-detail .rgs (rgs-convert --lod-levels; format/SPEC.md §4.9, docs/LOD.md): every
/// frame draws one level per chunk in the view frustum (runtime::select_lod): the coarsest whose projected error
/// is at most `pixel_error`, then coarser levels where the frame would exceed `splat_budget`. On the GPU the levels
/// a frame wants are streamed from the mapped file into a pool of device memory (runtime::LodStreamer): a level
/// requested in frame k is drawn from frame k + 2, coarser resident levels stand in meanwhile, so a frame depends
/// on the frames before it. On the CPU every level is held in host memory and every frame draws its selection.
/// Files without levels of detail ignore these settings (load() adds a note to SceneInfo::notes when a value
/// differs from its default).
struct LodSettings {
  /// True: a file with levels of detail renders each frame's selection under the budgets below. False: it renders
  /// its full detail (level 0 of every chunk: the ordinary scene, as a reader of an older format sees it).
  bool enabled = true;
  /// Most Gaussians (splats) one frame draws; 0: no limit. When even the coarsest level of every chunk in view
  /// exceeds it, the frame draws those coarsest levels. GPU: at most 2^31 − 1 (kLimitExceeded otherwise).
  uint64_t splat_budget = 3'000'000;
  /// Largest projected error a drawn level may show, in pixels (SPEC §4.9.1: world error · focal length /
  /// distance); finite and >= 0. 0 with no splat budget draws level 0 everywhere: the full detail. The default,
  /// runtime::LodBudget's, is chosen in docs/LOD.md#measuring-quality.
  float pixel_error = 1.5f;
  /// GPU: device bytes for the level pool, the frame arrays (one Gaussian per splat of the budget) and the upload
  /// buffer together; 0: a pool that holds every level. Too small for the frame arrays and the coarsest level of
  /// every chunk: kLimitExceeded, the message giving the bytes needed. The renderer's own scratch is bounded
  /// separately (RenderSettings::gpu_scratch_budget). CPU: not used (every level is in host memory; a non-zero
  /// value adds a note).
  uint64_t memory_budget = 0;
  /// GPU: most bytes read from the file and uploaded per frame, > 0: the bound on how long a frame waits for the
  /// file (levels that do not fit wait for a later frame). CPU: not used.
  uint64_t stream_bytes_per_frame = uint64_t{32} << 20;
};

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
  /// Presets of `presets` that the scene cannot render are left out instead of failing the load: kFaithful reads
  /// FP32 attributes, which a level-of-detail scene on CUDA does not hold (it streams the compact ones). For a
  /// caller that offers every preset the scene can render (rgs-view); SceneInfo (has_fp32, lod.active) says which.
  bool skip_unrenderable_presets = false;
  /// Files other than .rgs (any format converter::read_scene detects): true quantizes them in memory with the
  /// converter's defaults (what `rgs-convert in.ply out.rgs` writes, converter::QuantizeOptions{}), so that they render
  /// exactly as the converted file would and the GPU holds the compact profile; false keeps the PLY's float values
  /// (GPU: FP32 arrays only; the RoofGS presets then read FP32).
  bool quantize_other_formats = true;
  /// How the file is read (converter::read_scene for every format: limits, the SPZ axes; a .rgs file
  /// uploaded as stored is opened with converter::rgs_read_options of it).
  converter::SceneReadOptions read_options;
  /// Level-of-detail files: budgets and whether to use the levels at all (LodSettings).
  LodSettings lod;
};

/// A loaded scene's levels of detail (LodSettings).
struct SceneLodInfo {
  /// True when frames draw a per-camera selection of levels (a level-of-detail .rgs loaded with
  /// LodSettings::enabled); Renderer::render then fills FrameStats::lod.
  bool active = false;
  /// The file's index: chunks and levels per chunk (0 for a file without levels of detail).
  uint32_t chunks = 0;
  uint32_t levels = 0;
  /// Gaussians of every level of every chunk (the file's Gaussian count); SceneInfo::gaussians is the full
  /// detail, level 0 of every chunk.
  uint64_t stored_gaussians = 0;
  /// The settings frames are drawn with (active scenes).
  LodSettings settings;
  /// GPU: bytes of the level pool (runtime::LodStreamer::pool_bytes), within SceneInfo::memory_bytes; CPU: 0.
  uint64_t pool_bytes = 0;
};

/// The content surrounds its core when half its weight lies more than this many times farther out than a quarter
/// of it: a uniform ball gives 1.26, a disc 1.41, a rod 2; Mip-NeRF 360 flowers 4.5, guitar and biker 1.5.
constexpr double kSurroundRatio = 3.0;
/// content_frame() weighs at most this many Gaussians, evenly spaced in the scene's order (a quantile of 2^18
/// samples moves by well under a percent of the extent), so that it costs every load the same few milliseconds.
constexpr uint64_t kContentFrameSamples = uint64_t{1} << 18;

/// Where a scene's content is, in world units, robust to floaters (content_frame): the sphere its orbits and first
/// views frame (make_cameras, content_views, the viewer's first view).
struct ContentFrame {
  /// Gaussians weighed: those with a finite mean among the kContentFrameSamples spaced evenly; 0 when there is none.
  uint64_t weighed = 0;
  /// Centre of the content: the opacity-weighted median of the means, per axis.
  float centre[3] = {0, 0, 0};
  /// Opacity-weighted quantiles of the means' distance from `centre`: a quarter and half of the weight lies within
  /// these radii.
  double radius_25 = 0, radius_50 = 0;
  /// Whether the content surrounds a central core (radius_50 > kSurroundRatio · radius_25: a capture whose
  /// background spreads far beyond its subject) rather than forming one object.
  bool surrounds = false;
  /// Radius of the sphere the views frame, around `target`: radius_25 around `centre` when the content surrounds,
  /// else half the diagonal of the box of the means' weighted 5th-95th percentiles per axis around that box's
  /// centre; when that is 0 (all the weight at one point), 3 times the largest scale of any Gaussian, else 1.
  double frame_radius = 1;
  float target[3] = {0, 0, 0};
  /// The frame sphere (`target`, `frame_radius`) as the orbit builders take it (runtime::orbit_cameras).
  format::SceneBounds sphere() const;
  /// The frame of `bounds`' sphere (centre and target its centre, frame_radius its radius, 1 when not > 0), for
  /// Gaussians that never reach the host (load_device_gaussians) and for views that must stay on a given sphere.
  static ContentFrame of_sphere(const format::SceneBounds& bounds);
};

/// Where `cloud`'s content is: each Gaussian weighs its opacity (all weigh 1 when none has any; means that are not
/// finite are left out), the centre is the weighted median and the extent comes from weighted quantiles, so a few
/// far Gaussians, however far, move nothing. Deterministic. A cloud without a finite mean gives the default frame
/// (the unit sphere at the origin, `weighed` 0).
ContentFrame content_frame(const format::GaussianCloud& cloud);

/// What load() produced.
struct SceneInfo {
  std::string path;
  Device device = Device::kCpu;
  uint64_t gaussians = 0;
  uint32_t sh_degree = 0;
  /// Trained with the 2D Mip filter (format::SceneMetadata::antialiased): every render scales the opacities by
  /// the filter's compensation (docs/RENDERER.md#anti-aliased-scenes).
  bool antialiased = false;
  /// Scene AABB and bounding sphere (the .rgs metadata, or converter::compute_bounds of a PLY).
  format::SceneBounds bounds;
  /// Where the content is (content_frame of the Gaussians the renderers draw, a level-of-detail scene's full detail;
  /// of a scene from device arrays, load_device_gaussians, its bounding sphere): what orbits and first views frame.
  ContentFrame content;
  /// True when the file was a .rgs (sniffed by magic or extension).
  bool source_is_rgs = false;
  /// The file's format in words ("RoofGS .rgs", "binary_little_endian PLY", "Niantic SPZ v4 ...").
  std::string description;
  uint64_t file_bytes = 0;
  /// GPU scenes: whether the compact runtime sections and the FP32 arrays are on the device.
  bool has_compact = false;
  bool has_fp32 = false;
  /// GPU scenes: device bytes the scene holds (runtime::GpuScene::device_bytes(); level-of-detail scenes:
  /// runtime::LodStreamer::device_bytes(), the pool, frame arrays and upload buffer); CPU scenes: host bytes of
  /// the float arrays (level-of-detail scenes: of every level).
  uint64_t memory_bytes = 0;
  /// Bytes of the .rgs runtime sections (means, rotations, scales, opacities, SH) uncompressed, 0 for a
  /// scene kept in FP32: the footprint a compact GPU scene is measured against.
  uint64_t runtime_section_bytes = 0;
  /// What the reader noted (converter::InputScene::notes), e.g. the SPZ axes assumed, or level-of-detail
  /// settings that the scene does not use.
  std::vector<std::string> notes;
  /// Levels of detail: whether frames select them, the file's index, the budgets.
  SceneLodInfo lod;
};

/// A loaded scene. Cheap to copy (shared, immutable).
class Scene {
 public:
  const SceneInfo& info() const;
  Device device() const { return info().device; }
  uint64_t size() const { return info().gaussians; }
  /// CPU scenes: the activated float Gaussians rendered (format::GaussianCloud layout); of a level-of-detail
  /// scene, its full detail (level 0 of every chunk, what a frame with every chunk at level 0 draws). Null for GPU
  /// scenes.
  const format::GaussianCloud* cloud() const;
  /// GPU scenes: the device scene for the expert API (runtime/gpu_scene.h); null for CPU scenes and for
  /// level-of-detail GPU scenes (SceneInfo::lod.active), whose Gaussians change with every frame.
  const runtime::GpuScene* gpu_scene() const;

  struct Impl;
  explicit Scene(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

 private:
  friend class Renderer;  // draws the frames of level-of-detail scenes from Impl's level state
  std::shared_ptr<const Impl> impl_;
};

/// Loads `path` (a .rgs file, or any format converter::read_scene detects: 3DGS PLY, PlayCanvas compressed
/// PLY / SOG, SPZ, glTF, .ksplat, .splat) for `options.device`.
/// - CUDA, .rgs: sections uploaded as stored (runtime::GpuScene::from_rgs), FP32 arrays only when a listed
///   preset reads them; CUDA, other formats: quantized in memory then uploaded the same way (or FP32, see options).
/// - CPU: the dequantized float Gaussians (the values the GPU's compact reads produce).
/// - A level-of-detail .rgs with options.lod.enabled (LodSettings): CUDA opens a runtime::LodStreamer (the
///   coarsest level of every chunk uploaded now, the others streamed as frames want them; compact attributes
///   only); CPU holds every level dequantized (every range checked, RgsFile::lod_range).
/// Synchronous (the upload is complete on return).
/// @return errors naming `path`: kIoError, kNotRgsFile, kCorruptData, kChecksumMismatch, kLimitExceeded,
/// kOutOfMemory; kInvalidArgument for options.lod out of range (pixel_error negative or not finite,
/// stream_bytes_per_frame 0) and for a level-of-detail scene on CUDA with a preset that reads FP32 attributes
/// (kFaithful: load with options.lod.enabled = false to render the full detail) unless
/// options.skip_unrenderable_presets; kUnsupportedFeature for
/// device kCuda in a build without CUDA or on a host without a usable device (the message says which);
/// kCudaError.
Result<Scene> load(const std::string& path, const LoadOptions& options = {});

/// A scene from float Gaussians already in memory (format::GaussianCloud's layout; e.g. the decoded scenes an
/// audit compares) for `options.device`: the cloud itself on the CPU, FP32 arrays on the GPU (what the
/// faithful preset and lab configurations on FP32 read; options.presets, quantize_other_formats and lod are not
/// used). `name` stands for the path in SceneInfo and messages; `bounds` are the scene's (compute_bounds).
/// @return kInvalidArgument (inconsistent cloud); for kCuda as load().
Result<Scene> load_cloud(format::GaussianCloud cloud, const format::SceneBounds& bounds, const std::string& name,
                         const LoadOptions& options = {});

// What a device is and how much of its memory is in use: for status panels and reports (rgs-view's page).
/// A device's name and memory at the time of the query.
struct DeviceInfo {
  Device device = Device::kCpu;
  int cuda_device = 0;  ///< kCuda: the ordinal queried; kCpu: 0
  /// kCuda: the CUDA device name ("NVIDIA H100 80GB HBM3"); kCpu: "CPU, N hardware threads".
  std::string name;
  /// Hardware threads of the host (std::thread::hardware_concurrency(), at least 1); what RenderSettings::
  /// cpu_threads = 0 uses.
  uint32_t host_threads = 1;
  /// kCuda: device memory in bytes, total and free device-wide (cudaMemGetInfo: every process's allocations
  /// count, not only this one's); used = total − free. kCpu: 0 (host memory is not reported).
  uint64_t memory_total_bytes = 0;
  uint64_t memory_free_bytes = 0;
  /// kCuda: compute capability (9.0 for an H100); kCpu: 0.
  int compute_major = 0, compute_minor = 0;
};

/// Describes `device` now. kCuda makes `cuda_device` the calling thread's current device (as Renderer::create
/// does). Cheap enough to call once per frame (no device synchronization).
/// @return kUnsupportedFeature for kCuda in a build without CUDA or on a host without that device (the message
/// says which), kCudaError (the driver's error).
Result<DeviceInfo> query_device(Device device, int cuda_device = 0);


}  // namespace rgs::api
