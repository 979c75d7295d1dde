// The front door's renderer: one call renders a Scene with a preset into the caller's memory, on the GPU
// (caller's device pointer, on the caller's CUDA stream) or with the CPU reference (caller's host pointer).
//
// Thread safety: a Renderer is not thread-safe: use one per thread (and per CUDA stream). Scenes may be
// shared between Renderers (scene.h). An Image is owned by one thread at a time.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/api/preset.h"
#include "rgs/api/scene.h"
#include "rgs/format/status.h"

/// The CUDA runtime's stream type without including CUDA headers: cudaStream_t is `CUstream_st*`, so a
/// cudaStream_t converts to api::Stream and back implicitly.
struct CUstream_st;

namespace rgs::api {

/// A CUDA stream (cudaStream_t). nullptr is the default stream.
using Stream = CUstream_st*;

/// Pixel formats of a colour image; four channels R, G, B, A in that order in memory.
enum class PixelFormat {
  kRgba32f = 0,  ///< 4 × float32 (16 B/pixel), values as rendered (not clamped)
  kRgba16f = 1,  ///< 4 × IEEE binary16 (8 B/pixel), round to nearest even
  kRgba8 = 2,    ///< 4 × uint8 (4 B/pixel), floor(clamp(v, 0, 1)·255 + 0.5) (the 3DGS 8-bit rule)
};

/// Bytes per pixel of `format` (16, 8 or 4).
size_t bytes_per_pixel(PixelFormat format);

/// "rgba32f", "rgba16f", "rgba8"; parse_pixel_format() accepts these. @return kInvalidArgument otherwise.
const char* pixel_format_name(PixelFormat format);
Result<PixelFormat> parse_pixel_format(const std::string& name);

/// The caller's image a frame is rendered into: device memory for a GPU scene, host memory for a CPU scene.
/// The library never allocates, frees or keeps it; on the GPU it must stay valid until the frame's work on
/// the stream is done.
/// - Colour: row y (top row first) at `color` + y·`color_pitch` bytes, `width` pixels of `format`. RGB =
///   C + T·bg, the values the 3DGS rasterizer outputs (no sRGB transfer applied; linear for the renderer).
///   A = 1 − T (coverage), or 1 when `write_alpha` is false. `color_pitch` ≥ width·bytes_per_pixel(format)
///   and a multiple of the channel size, `color` aligned to the channel size (cudaMallocPitch gives both).
/// - Depth (optional, null for none): float32 expected view-space depth Σ wᵢzᵢ / Σ wᵢ (world units; 0 where
///   nothing blended), row y at `depth` + y·`depth_pitch` bytes; `depth_pitch` ≥ 4·width, multiple of 4.
struct ImageTarget {
  uint32_t width = 0, height = 0;  ///< must equal the camera's size
  void* color = nullptr;
  size_t color_pitch = 0;
  PixelFormat format = PixelFormat::kRgba32f;
  bool write_alpha = true;
  float* depth = nullptr;
  size_t depth_pitch = 0;
};

/// How a frame is rendered.
struct RenderSettings {
  Preset preset = Preset::kFastest;
  /// Background colour (out = C + T·bg), finite.
  std::array<float, 3> background = {0.f, 0.f, 0.f};
  /// CPU renderer threads; 0 = all hardware threads. The image does not depend on it.
  unsigned cpu_threads = 0;
  /// GPU: record CUDA events around each stage of the frame and fill FrameStats::times. The call then waits on
  /// the host until the frame is finished (so it no longer overlaps the caller's next work: for monitoring and
  /// benchmarks, not for pipelines that keep the GPU busy). CPU: ignored (FrameStats::times.timed stays false).
  bool time_stages = false;
  /// GPU: bound on the renderer's scratch memory in bytes (0: none). A frame whose (tile, Gaussian) pairs do
  /// not fit renders in groups of tile rows, with the same image; a budget too small for the scene's
  /// per-Gaussian buffers, or for one tile row's pairs, fails with kLimitExceeded
  /// (docs/RENDERER.md#bounded-pair-memory). The CPU renderer ignores it.
  uint64_t gpu_scratch_budget = 0;
  /// GPU level-of-detail scenes: stream what the frame selects before drawing it (LodStreamer::prepare again
  /// while a wanted level is on its way, at most kLodSettlePrepares times), so the image shows its own
  /// selection, as the CPU reference's does, instead of the coarser levels resident when the camera moved.
  /// For offline images (rgs-render); real-time callers keep the default and let levels arrive two frames later.
  /// A level the pool cannot hold is still drawn coarser (FrameStats::lod.chunks_not_resident). Ignored otherwise.
  bool lod_settle = false;
};

/// Most LodStreamer::prepare calls of one settled frame (RenderSettings::lod_settle): a level is drawable on the
/// second prepare after the one that requests it, and each requests at most LodSettings::stream_bytes_per_frame.
inline constexpr int kLodSettlePrepares = 64;

/// Level-of-detail counts of one frame of a level-of-detail scene (SceneInfo::lod.active; docs/LOD.md); all zero
/// for other scenes. GPU: runtime::LodFrameStats of the frame's LodStreamer::prepare. CPU: every level is
/// resident, so nothing streams and no chunk waits.
struct LodFrameCounts {
  uint64_t splats = 0;               ///< Gaussians drawn (the chosen levels; FrameStats::gaussians too)
  uint32_t chunks_drawn = 0;         ///< chunks whose sphere meets the view frustum
  uint32_t chunks_culled = 0;        ///< chunks outside it (not drawn)
  uint32_t chunks_coarsened = 0;     ///< drawn coarser than the pixel threshold allows, for the splat budget
  uint32_t chunks_not_resident = 0;  ///< GPU: drawn at a coarser resident level while the wanted one streams in
  /// GPU: levels requested this frame (drawable two frames later; settled frames: over all their prepares)
  uint32_t ranges_streamed = 0;
  uint64_t bytes_streamed = 0;  ///< GPU: their bytes, read from the file and uploaded
  /// Bytes of the levels held: GPU, those in the pool (requested ones included); CPU, every level as stored
  /// in the file (its runtime sections' bytes).
  uint64_t bytes_resident = 0;
};

/// Stage times of one GPU frame from CUDA events, milliseconds (RenderSettings::time_stages;
/// runtime::StageTimes). A frame rendered in groups of tile rows sums each stage over its groups.
struct StageTimes {
  bool timed = false;       ///< true when the times below were measured (a GPU frame with time_stages)
  float preprocess_ms = 0;  ///< projection, SH colour, the offset scan, the pair-count read-back and duplication
  float sort_ms = 0;        ///< the (tile, Gaussian) pair sort
  float ranges_ms = 0;      ///< per-tile ranges of the sorted pairs
  float render_ms = 0;      ///< blending the tiles into the image (and its output conversion)
  float total_ms = 0;       ///< the frame from its first event to its last (level-of-detail gathers excluded)
};

/// Counts of one frame.
struct FrameStats {
  uint64_t gaussians = 0;  ///< input Gaussians (level-of-detail scenes: those of the frame's levels)
  uint64_t pairs = 0;      ///< (tile, Gaussian) pairs sorted
  uint32_t tile_groups = 1;  ///< GPU: passes over groups of tile rows (1: the whole frame at once)
  LodFrameCounts lod;        ///< level-of-detail scenes: what the frame selected and streamed
  StageTimes times;          ///< GPU frames rendered with RenderSettings::time_stages
};

/// An image owned by the library (Renderer::render_image): device memory for GPU scenes (cudaMalloc), host
/// memory for CPU scenes. Move-only. Tightly packed: pitch = width·bytes_per_pixel.
class Image {
 public:
  Image();
  Image(Image&&) noexcept;
  Image& operator=(Image&&) noexcept;
  ~Image();

  Device device() const;
  int cuda_device() const;  ///< ordinal of the device holding a GPU image (0 for CPU images)
  uint32_t width() const;
  uint32_t height() const;
  PixelFormat format() const;
  /// [H, W, 4] colour in `format()`, tightly packed.
  void* color() const;
  size_t color_pitch() const;
  /// [H, W] float32 depth, or null when not requested.
  float* depth() const;
  /// This image as an ImageTarget (to render into it again).
  ImageTarget target() const;
  /// The counts of the frame render_image() produced it with.
  const FrameStats& frame_stats() const;

  /// GPU images: makes `consumer` wait (cudaStreamWaitEvent, no host wait) until the render that produced
  /// this image is done; a no-op for CPU images. Errors: kCudaError.
  Status make_stream_wait(Stream consumer) const;
  /// GPU images: waits on the host until the render is done. Errors: kCudaError.
  Status synchronize() const;
  /// Copies colour (and depth, if both exist) to host memory, tightly packed; waits for the render first.
  /// `color_out` holds height·width·bytes_per_pixel bytes, `depth_out` height·width floats (or null).
  Status copy_to_host(void* color_out, float* depth_out) const;

  struct Impl;

 private:
  friend class Renderer;
  std::unique_ptr<Impl> impl_;
};

/// Encodes GPU images as baseline JPEG on their GPU with nvJPEG (runtime::GpuJpegEncoder), which is loaded at
/// run time, so every binary still runs where it is absent (docs/VIEWER.md#frames-encoded-on-the-gpu). One per
/// thread; move-only.
class GpuJpegEncoder {
 public:
  /// An encoder on CUDA device `cuda_device`. Errors: kUnsupportedFeature (no CUDA in this build, no usable
  /// device, or no nvJPEG library: the message says which), kCudaError.
  static Result<GpuJpegEncoder> create(int cuda_device = 0);

  GpuJpegEncoder(GpuJpegEncoder&&) noexcept;
  GpuJpegEncoder& operator=(GpuJpegEncoder&&) noexcept;
  ~GpuJpegEncoder();

  /// The library in use, e.g. "nvJPEG 13.0.1 (libnvjpeg.so.13)".
  const std::string& name() const;

  /// Encodes the colour of `image` (a GPU kRgba8 image on this encoder's device; alpha ignored) with the
  /// standard tables scaled to `quality` (1..100), 4:2:0 chroma when `subsample_chroma`, else 4:4:4. Waits on
  /// the GPU (not the host) for the render that produced the image, then on the host for the bitstream, which
  /// replaces `jpeg`'s contents. Errors: kInvalidArgument (a CPU image, another format or device, quality out
  /// of range), kOutOfMemory, kCudaError.
  Status encode(const Image& image, int quality, bool subsample_chroma, std::vector<uint8_t>* jpeg);

  struct Impl;

 private:
  explicit GpuJpegEncoder(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Renders Scenes with presets. Create one per thread/stream; it keeps scratch buffers between frames
/// (a steady sequence of frames allocates nothing on the GPU; on the CPU, runtime::CpuScratch keeps the frame's
/// working memory for reuse).
class Renderer {
 public:
  /// A renderer for scenes on `device` (kCuda: on CUDA device `cuda_device`, made current on the calling
  /// thread). Errors: kUnsupportedFeature (no CUDA in this build, or no usable device), kCudaError.
  static Result<Renderer> create(Device device = Device::kCuda, int cuda_device = 0);

  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;
  ~Renderer();

  Device device() const;

  /// Renders `scene` from `camera` with `settings` into `target`.
  /// GPU: every step is enqueued on `stream`; no device-wide synchronization. Like the 3DGS rasterizer it
  /// reads the frame's pair count back to the host once (a wait for this frame's preprocess on `stream`), so
  /// the call returns once the sort and blend are enqueued; the image is complete when `stream` reaches
  /// that point (use cudaStreamSynchronize or an event). Scratch buffers that must grow (first frames, a
  /// larger frame) are allocated with cudaMalloc. CPU: synchronous; `stream` is ignored.
  /// Level-of-detail scenes (SceneInfo::lod.active): the frame draws the levels runtime::select_lod picks for
  /// `camera` under LoadOptions::lod. GPU: under the scene's mutex, runtime::LodStreamer::prepare(camera,
  /// `stream`) (after a GPU wait for the scene's previous frame, on any stream), then its frame is rendered on
  /// `stream`; the image depends on the frames rendered before (levels arrive two frames after they are
  /// wanted) unless RenderSettings::lod_settle. CPU: the chosen ranges of every level held in host memory, in
  /// chunk order, as the GPU gathers them: a GPU frame whose chunks are all resident
  /// (FrameStats::lod.chunks_not_resident 0) draws the same Gaussians.
  /// @return kInvalidArgument (scene on another device than the renderer, an invalid camera or target, a
  /// preset whose data the scene was loaded without: LoadOptions::presets; on a level-of-detail GPU scene a
  /// preset reading FP32), kLimitExceeded, kOutOfMemory, kCudaError; level-of-detail GPU scenes also the file's
  /// errors for a level that fails its checks when read (kChecksumMismatch, kCorruptData; it is requested again
  /// when next wanted).
  Result<FrameStats> render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                            const ImageTarget& target, Stream stream = nullptr);

  /// Renders into a new library-owned Image of the camera's size (with a depth plane when `with_depth`),
  /// like render(). GPU images are complete once `stream` reaches the end of the frame (Image::synchronize,
  /// make_stream_wait).
  Result<Image> render_image(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                             PixelFormat format = PixelFormat::kRgba32f, bool with_depth = false,
                             Stream stream = nullptr);

  struct Impl;

 private:
  explicit Renderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rgs::api
