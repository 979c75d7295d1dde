// Renders a level-of-detail .rgs (format/SPEC.md §4.9) under a splat budget and a GPU memory budget: per frame
// it selects a level per chunk (lod_selection.h), streams missing ranges from the mapped file into a fixed pool
// of device pages, and gathers the frame's Gaussians into compact arrays that GpuRenderer renders
// (docs/LOD.md). Available only with RGS_WITH_CUDA.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <type_traits>
#include <string>
#include <utility>
#include <vector>

#include "rgs/format/reader.h"
#include "rgs/format/status.h"
#include "rgs/kernels/gather_gaussians.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/device_buffer.h"
#include "rgs/runtime/gpu_scene.h"
#include "rgs/runtime/lod_selection.h"

namespace rgs::runtime {

/// The budgets of LodStreamer.
struct LodStreamOptions {
  /// Splat budget and pixel threshold of the selection.
  LodBudget budget{3'000'000, 1.0f};
  /// Device bytes for the page pool, the frame arrays and the upload buffer together; 0: a pool that holds the
  /// whole file. The renderer's scratch is not included (GpuRenderOptions::scratch_budget bounds it).
  uint64_t memory_budget = 0;
  /// Most bytes read from the file and uploaded per frame. This is the bound on how long a frame waits for the
  /// disk: ranges that do not fit wait for a later frame, and the frame draws a coarser resident level.
  uint64_t stream_bytes_per_frame = uint64_t{256} << 20;
};

/// What one prepare() did.
struct LodFrameStats {
  uint64_t splats = 0;              ///< Gaussians in the frame's arrays
  uint32_t chunks_drawn = 0;        ///< chunks in the frustum
  uint32_t chunks_culled = 0;       ///< chunks outside it
  uint32_t chunks_coarsened = 0;    ///< drawn coarser than the pixel threshold, for the splat budget
  uint32_t chunks_not_resident = 0; ///< drawn at a coarser resident level while the wanted one streams in
  uint32_t ranges_streamed = 0;     ///< ranges read and uploaded this frame (resident from the next frame)
  uint64_t bytes_streamed = 0;      ///< their bytes
  uint64_t bytes_resident = 0;      ///< bytes of the ranges in the pool after this frame's uploads
  double wait_ms = 0;               ///< host time waiting for the previous uploads and reading the file
};

/// A level-of-detail scene streamed into a fixed device pool. Pages of kPageGaussians Gaussians hold ranges
/// (one level of one chunk); the coarsest level of every chunk is loaded at open and never evicted, so every
/// chunk can always be drawn; other ranges are evicted least recently used first. Uploads requested in frame k
/// are complete and drawable from frame k + 1, which makes a camera path's frames a function of the path and the
/// pool's state, whatever the disk's speed. Move-only; not thread-safe (one render stream).
class LodStreamer {
 public:
  /// Gaussians per pool page.
  static constexpr uint32_t kPageGaussians = 256;

  /// Sizes the pool from `options`, then reads and uploads the coarsest level of every chunk on `stream`, each
  /// range checked by RgsFile::lod_range. Errors: kInvalidArgument (no level-of-detail index, a splat budget the
  /// coarsest levels of one chunk exceed), kLimitExceeded (the memory budget cannot hold the frame arrays and
  /// the coarsest levels: the message gives the bytes needed), the file's errors, kOutOfMemory / kCudaError.
  static Result<LodStreamer> open(const format::RgsFile& file, const LodStreamOptions& options,
                                  cudaStream_t stream = nullptr);

  LodStreamer(LodStreamer&&) noexcept = default;
  LodStreamer& operator=(LodStreamer&&) noexcept = default;

  /// Selects the frame's levels for `camera`, gathers the resident ones into the frame arrays on `stream`
  /// (scene() is then valid for rendering on `stream`), and starts the uploads of wanted ranges that are not
  /// resident, on a copy stream, up to stream_bytes_per_frame. Errors: the file's (a range failing its checks),
  /// kCudaError.
  Result<LodFrameStats> prepare(const Camera& camera, cudaStream_t stream = nullptr);

  /// The frame's Gaussians, after prepare() (empty before).
  const GpuScene& scene() const { return frame_scene_; }
  /// Device bytes held: pool, frame arrays, upload buffer.
  uint64_t device_bytes() const;
  /// Pool capacity in bytes.
  uint64_t pool_bytes() const;

 private:
  LodStreamer() = default;
  /// One level of one chunk in the pool: its pages, in order, the last frame that drew it, whether it is the
  /// chunk's coarsest (never evicted) and whether its upload is complete (drawable).
  struct Range {
    std::vector<uint32_t> pages;
    uint64_t last_used = 0;
    bool pinned = false;
    bool ready = false;
  };
  using Key = std::pair<uint32_t, uint32_t>;  // (chunk, level)

  uint64_t range_bytes(uint32_t level, uint32_t chunk) const;
  /// Evicts ranges not drawn in `frame`, least recently used first, until `pages` pages are free; false if it
  /// cannot.
  bool make_room(uint64_t pages, uint64_t frame);
  /// make_room(), then moves `pages` free pages to `out`.
  bool take_pages(uint64_t pages, uint64_t frame, std::vector<uint32_t>* out);
  Status stage_range(uint32_t level, uint32_t chunk, uint64_t at, uint64_t frame);
  Status start_uploads(uint64_t staged);
  Status finish_uploads(double* wait_ms);

  std::optional<format::RgsFile> file_;
  LodStreamOptions options_;
  uint32_t sh_bytes_ = 0;
  bool residual_ = false;
  uint64_t frame_index_ = 0;
  std::map<Key, Range> resident_;
  std::vector<Key> pending_;
  std::vector<uint32_t> free_pages_;
  std::vector<kernels::GatherRun> scatter_runs_;
  uint64_t pool_pages_ = 0;
  // Device arrays: the pool (page p holds Gaussians [p·P, (p + 1)·P)), the frame, the upload buffer.
  struct Arrays {
    DeviceBuffer<float> means;
    DeviceBuffer<uint16_t> rotations, scales, opacities;
    DeviceBuffer<int8_t> sh, sh_dc_residual;
    Status allocate(uint64_t n, uint32_t sh_bytes, bool residual, const std::string& what);
    kernels::CompactArrays view() const;
    uint64_t bytes() const;
  };
  Arrays pool_, frame_, upload_;
  uint64_t upload_capacity_ = 0;  ///< Gaussians the upload buffer and the host staging hold
  DeviceBuffer<kernels::GatherRun> gather_runs_, upload_runs_;
  PinnedBuffer staging_, run_staging_, scatter_staging_;
  // Declared after the buffers, so destroyed first: the copy stream is drained before they are freed.
  struct StreamDeleter {
    void operator()(cudaStream_t s) const;
  };
  struct EventDeleter {
    void operator()(cudaEvent_t e) const;
  };
  std::unique_ptr<std::remove_pointer_t<cudaStream_t>, StreamDeleter> copy_stream_;
  std::unique_ptr<std::remove_pointer_t<cudaEvent_t>, EventDeleter> gathered_, uploaded_;
  GpuScene frame_scene_ = GpuScene::compact_view({}, {});
};

}  // namespace rgs::runtime
