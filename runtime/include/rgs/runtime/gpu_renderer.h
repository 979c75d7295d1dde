// The CUDA renderer: renders a GpuScene from a Camera into a float RGBA image in device memory.
// Available only with RGS_WITH_CUDA. docs/RENDERER.md describes the pipelines.
#pragma once

#include <cuda_runtime_api.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/device_buffer.h"
#include "rgs/runtime/gpu_scene.h"

namespace rgs::runtime {

/// An image in device memory, row-major, top row first. Move-only.
class DeviceImage {
 public:
  /// Makes the image width × height (contents undefined), with a depth plane when `with_depth`.
  /// Errors: kInvalidArgument (a zero or > 32768 side), kOutOfMemory, kCudaError.
  Status resize(uint32_t width, uint32_t height, bool with_depth);

  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  bool has_depth() const { return has_depth_; }
  /// [H, W, 4] float32 RGBA: rgb = C + T·bg (linear, not clamped; SH colours can exceed 1), a = 1 − T.
  float* rgba() const { return rgba_.data(); }
  /// [H, W] float32 expected view-space depth Σ wᵢzᵢ / Σ wᵢ (0 where nothing blended), or nullptr.
  float* depth() const { return has_depth_ ? depth_.data() : nullptr; }
  kernels::ImageView view() const { return kernels::ImageView{rgba(), depth()}; }

 private:
  uint32_t width_ = 0, height_ = 0;
  bool has_depth_ = false;
  DeviceBuffer<float> rgba_, depth_;
};

/// A DeviceImage copied to host memory.
struct HostImage {
  uint32_t width = 0, height = 0;
  std::vector<float> rgba;   ///< [H, W, 4] as DeviceImage::rgba()
  std::vector<float> depth;  ///< [H, W], empty when the image had no depth plane
};

/// Copies `image` to the host on `stream` and waits. Errors: kCudaError.
Result<HostImage> download(const DeviceImage& image, cudaStream_t stream = nullptr);

/// Options of GpuRenderer::render().
struct GpuRenderOptions {
  /// Background colour (linear RGB, out = C + T·bg).
  std::array<float, 3> background = {0.f, 0.f, 0.f};
  /// Record CUDA events around each stage and fill GpuRenderStats::times (waits for the frame to finish).
  bool time_stages = false;
};

/// Stage times of one frame from CUDA events, milliseconds. preprocess covers preprocess, the offset scan,
/// the pair-count read-back and duplication (3DGS's geometry + binning steps before the sort).
struct StageTimes {
  float preprocess_ms = 0, sort_ms = 0, ranges_ms = 0, render_ms = 0, total_ms = 0;
};

/// Counts of one frame.
struct GpuRenderStats {
  uint64_t gaussians = 0;      ///< input Gaussians
  uint64_t pairs = 0;          ///< (tile, Gaussian) pairs sorted
  uint32_t tiles_x = 0, tiles_y = 0;
  int sort_bits = 0;           ///< key bits the radix sort covered (32 + ceil(log2(tiles)) for the baseline)
  bool timed = false;          ///< times is valid (GpuRenderOptions::time_stages)
  StageTimes times;
};

/// Renders scenes with the 3DGS baseline pipeline (kernels/baseline_pipeline.h): the same conventions and
/// per-Gaussian bits as render_cpu() (runtime/cpu_renderer.h); pixels differ from it only through the
/// device's expf. Keeps its scratch buffers between frames and grows them as needed (by a quarter more
/// than asked), so a steady sequence of frames allocates nothing. Not thread-safe; one renderer per
/// stream. Move-only.
///
/// Each frame reads the pair count back to the host once (a wait on `stream`), like 3DGS.
class GpuRenderer {
 public:
  /// Creates a renderer on the current device. Errors: kCudaError (no device, driver problem).
  static Result<GpuRenderer> create();

  GpuRenderer(GpuRenderer&&) noexcept;
  GpuRenderer& operator=(GpuRenderer&&) noexcept;
  ~GpuRenderer();

  /// Renders `scene` from `camera` into `image`, resized to the camera's size (with a depth plane if it
  /// already had one), all work on `stream`. When it returns ok the frame is enqueued (and finished if
  /// options.time_stages). Errors: kInvalidArgument (validate_camera(), background not finite),
  /// kOutOfMemory (pair buffers too large for the device: the message gives the pair count; the renderer
  /// frees what it held and stays usable), kCudaError (a failed launch or copy, naming the stage).
  Result<GpuRenderStats> render(const GpuScene& scene, const Camera& camera, const GpuRenderOptions& options,
                                DeviceImage* image, cudaStream_t stream = nullptr);

  /// Device bytes held by the scratch buffers now.
  uint64_t scratch_bytes() const;

 private:
  GpuRenderer() = default;
  struct Buffers;
  std::unique_ptr<Buffers> buffers_;  // scratch buffers and events (gpu_renderer.cpp)
};

}  // namespace rgs::runtime
