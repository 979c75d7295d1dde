// Renders a level-of-detail .rgs (format/SPEC.md §4.9) under a splat budget and a GPU memory budget: per frame
// it selects a level per chunk (lod_selection.h), streams missing ranges from the mapped file into a fixed pool
// of device pages, and gathers the frame's Gaussians into compact arrays that GpuRenderer renders
// (docs/LOD.md). Available only with RGS_WITH_CUDA.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <future>
#include <memory>
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

namespace rgs::parallel {
class WorkerPool;
}

namespace rgs::runtime {

/// The budgets of LodStreamer.
struct LodStreamOptions {
  /// Splat budget and pixel threshold of the selection.
  LodBudget budget{3'000'000, LodBudget{}.pixel_error};
  /// Device bytes for the page pool, the frame arrays and the upload buffer together; 0: a pool that holds the
  /// whole file. The renderer's scratch is not included (GpuRenderOptions::scratch_budget bounds it).
  uint64_t memory_budget = 0;
  /// Most bytes read from the file and uploaded per frame. This bounds how long a frame can wait for the file
  /// (docs/LOD.md#a-frame-under-a-budget): ranges that do not fit wait for a later frame, and the frame draws a
  /// coarser resident level meanwhile.
  uint64_t stream_bytes_per_frame = uint64_t{32} << 20;
};

/// What one prepare() did.
struct LodFrameStats {
  uint64_t splats = 0;              ///< Gaussians in the frame's arrays
  uint32_t chunks_drawn = 0;        ///< chunks in the frustum
  uint32_t chunks_culled = 0;       ///< chunks outside it
  uint32_t chunks_coarsened = 0;    ///< drawn coarser than the pixel threshold, for the splat budget
  uint32_t chunks_not_resident = 0; ///< drawn at a coarser resident level while the wanted one streams in
  uint32_t ranges_streamed = 0;     ///< ranges requested this frame (drawable two frames later)
  uint64_t bytes_streamed = 0;      ///< their bytes
  uint64_t bytes_resident = 0;      ///< bytes of the ranges in the pool, requested ones included
  double wait_ms = 0;               ///< host time waiting for the previous frame's reads and the uploads before
  double read_ms = 0;               ///< the reader's time for the previous frame's ranges (uploaded this frame)
};

/// A level-of-detail scene streamed into a fixed device pool. Pages of kPageGaussians Gaussians hold ranges
/// (one level of one chunk); the coarsest level of every chunk is loaded at open and never evicted, so every
/// chunk can always be drawn; other ranges are evicted least recently used first.
///
/// Streaming is a three-frame pipeline. Frame k requests the ranges it wants and a reader thread copies them
/// into pinned staging and checks the copies (RgsFile::read_lod_slice) while frame k renders, on every CPU but
/// one through threads kept for the streamer's life; frame k + 1 waits for that reader if it is not done, and
/// uploads the staging on a copy stream; the ranges are drawable from frame k + 2. A camera path's frames are
/// therefore a function of the path and the pool's state, whatever the speed of the disk and of the CPUs.
/// Move-only; not thread-safe (one render stream).
class LodStreamer {
 public:
  /// Gaussians per pool page.
  static constexpr uint32_t kPageGaussians = 256;

  /// Sizes the pool from `options`, then reads and uploads the coarsest level of every chunk on `stream`, each
  /// range checked in its copy (RgsFile::read_lod_slice, check_lod_checksum). Errors: kInvalidArgument (no
  /// level-of-detail index, a splat budget the coarsest levels of one chunk exceed), kLimitExceeded (the memory
  /// budget cannot hold the frame arrays and the coarsest levels: the message gives the bytes needed), the file's
  /// errors, kOutOfMemory / kCudaError.
  static Result<LodStreamer> open(const format::RgsFile& file, const LodStreamOptions& options,
                                  cudaStream_t stream = nullptr);

  /// Moving keeps a read in flight going: it writes into the same pinned staging, which the new object owns.
  LodStreamer(LodStreamer&&) noexcept = default;
  /// Not assignable: the old reader would write into freed staging.
  LodStreamer& operator=(LodStreamer&&) = delete;

  /// Uploads the ranges read since the previous frame, selects the frame's levels for `camera`, gathers the
  /// drawable ones into the frame arrays on `stream` (scene() is then valid for rendering on `stream`), and
  /// hands the wanted ranges that are not resident, up to stream_bytes_per_frame, to the reader thread.
  /// Errors: the file's (a range of the previous frame's reads failing its checks: those ranges are dropped
  /// and requested again when wanted), kCudaError.
  Result<LodFrameStats> prepare(const Camera& camera, cudaStream_t stream = nullptr);

  /// The frame's Gaussians, after prepare() (empty before).
  const GpuScene& scene() const { return frame_scene_; }
  /// Device bytes held: pool, frame arrays, upload buffer.
  uint64_t device_bytes() const;
  /// Pool capacity in bytes.
  uint64_t pool_bytes() const;

 private:
  LodStreamer() = default;
  /// One level of one chunk: its pages in the pool, in order, the last frame that drew or requested it, whether
  /// it is the chunk's coarsest (never evicted), and where it is in the pipeline (kAbsent: not in the pool).
  enum class RangeState { kAbsent, kReading, kUploading, kReady };
  struct Range {
    std::vector<uint32_t> pages;
    uint64_t last_used = 0;
    bool pinned = false;
    RangeState state = RangeState::kAbsent;
  };
  using Key = std::pair<uint32_t, uint32_t>;  // (chunk, level)
  /// One level of one chunk to read: its place in the staging buffer, in Gaussians.
  struct ReadItem {
    uint32_t level = 0, chunk = 0;
    uint64_t at = 0;
  };
  /// The ranges one frame requests: read into staging buffer `slot`, then uploaded and scattered into pages.
  struct Batch {
    std::vector<Key> keys;
    std::vector<ReadItem> items;
    std::vector<kernels::GatherRun> scatter_runs;
    uint64_t staged = 0;  ///< Gaussians
    uint64_t bytes = 0;
    int slot = 0;
  };

  uint64_t range_bytes(uint32_t level, uint32_t chunk) const;
  /// Evicts ranges not drawn or requested in `frame`, least recently used first (ties: the lowest key), until
  /// `pages` pages are free; false if it cannot.
  bool make_room(uint64_t pages, uint64_t frame);
  /// Gives (level, chunk) pages and a place in `batch`; false when the pool has no room.
  bool request_range(uint32_t level, uint32_t chunk, uint64_t frame, Batch* batch);
  /// Returns the pages of `batch`'s ranges to the free list (a read that failed).
  void drop(const Batch& batch);
  /// Starts reading `batch` on the reader thread.
  void start_reading(Batch batch);
  /// Waits for the reader, then enqueues the upload and scatter of what it read on the copy stream. Adds the
  /// wait to *wait_ms and the reader's own time to *read_ms.
  Status upload_read(double* wait_ms, double* read_ms);
  /// Waits for the previous frame's gather and upload; its ranges become drawable.
  Status finish_uploads(double* wait_ms);

  std::shared_ptr<const format::RgsFile> file_;
  LodStreamOptions options_;
  uint32_t sh_bytes_ = 0;
  bool residual_ = false;
  uint64_t frame_index_ = 0;
  /// Every (chunk, level) of the file, chunk-major (ranges_[chunk · levels + level]): found in constant time by
  /// the frame, which looks up every chunk it draws.
  std::vector<Range> ranges_;
  uint32_t level_count_ = 0;
  Range& range_at(const Key& key) { return ranges_[size_t{key.first} * level_count_ + key.second]; }
  /// Returns a range's pages to the free list and marks it absent.
  void evict(const Key& key);
  uint64_t resident_bytes_ = 0;
  std::vector<Key> uploading_;
  std::vector<uint32_t> free_pages_;
  // Eviction candidates of the current frame, least recently used first, and the next one to take.
  std::vector<Key> victims_;
  size_t next_victim_ = 0;
  uint64_t victims_frame_ = ~uint64_t{0};
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
  uint64_t upload_capacity_ = 0;  ///< Gaussians the upload buffer and each host staging buffer hold
  uint64_t frame_capacity_ = 0;   ///< Gaussians the frame arrays hold (the renderer sizes its buffers for it)
  DeviceBuffer<kernels::GatherRun> gather_runs_, upload_runs_;
  // Two staging buffers: the reader fills one while the other is uploaded.
  PinnedBuffer staging_[2], run_staging_, scatter_staging_;
  int next_slot_ = 0;
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
  // The reader's threads, kept between frames (rgs/parallel/worker_pool.h).
  struct PoolDeleter {
    void operator()(parallel::WorkerPool* pool) const;
  };
  std::unique_ptr<parallel::WorkerPool, PoolDeleter> readers_;
  // The reader's batch and its result; declared last, so a read in flight ends before anything is freed.
  struct ReadDone {
    Status status;
    double ms = 0;  ///< the reader's time, from its start to its end
  };
  Batch reading_batch_;
  std::future<ReadDone> reading_;
};

}  // namespace rgs::runtime
