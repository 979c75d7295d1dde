// Scene::Impl and Image::Impl, shared by scene.cpp and renderer.cpp.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <type_traits>

#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/lod.h"

#if RGS_HAS_CUDA
#include <cuda_runtime_api.h>

#include "rgs/runtime/gpu_scene.h"
#include "rgs/runtime/lod_streamer.h"
#endif

namespace rgs::api {

/// What a level-of-detail scene (SceneInfo::lod.active) draws its frames from.
struct LodState {
  /// The file's index (chunk spheres, level ranges and errors): what runtime::select_lod reads.
  format::LodIndex index;
  /// CPU: Gaussians [full detail, stored) of the file, the levels coarser than level 0, dequantized; the full
  /// detail is Scene::Impl::cloud. Level l of chunk c is index.at(l, c)'s range of the two, concatenated.
  format::GaussianCloud coarse;
  /// CPU: bytes of every level as the file stores them (FrameStats::lod.bytes_resident).
  uint64_t stored_bytes = 0;
#if RGS_HAS_CUDA
  /// GPU: the streamer (stateful, not thread-safe) and an event recorded on the stream of the last frame's
  /// render, which the next frame's gather waits for; both used only under `mutex`.
  std::mutex mutex;
  std::optional<runtime::LodStreamer> streamer;
  struct EventDeleter {
    void operator()(cudaEvent_t e) const { cudaEventDestroy(e); }
  };
  std::unique_ptr<std::remove_pointer_t<cudaEvent_t>, EventDeleter> frame_done;
#endif
};

struct Scene::Impl {
  SceneInfo info;
  format::GaussianCloud cloud;  // CPU scenes
#if RGS_HAS_CUDA
  std::optional<runtime::GpuScene> gpu;  // GPU scenes (not level-of-detail ones)
#endif
  /// Level-of-detail scenes; the pointee is the one part of a loaded scene that frames change (GPU), guarded by
  /// its mutex.
  std::unique_ptr<LodState> lod;
};

struct Image::Impl {
  Device device = Device::kCpu;
  int cuda_device = 0;
  uint32_t width = 0, height = 0;
  PixelFormat format = PixelFormat::kRgba32f;
  bool with_depth = false;
  FrameStats stats;                 // of the frame that produced the image
  std::vector<uint8_t> host_color;  // CPU images
  std::vector<float> host_depth;
  void* device_color = nullptr;  // GPU images (cudaMalloc)
  float* device_depth = nullptr;
#if RGS_HAS_CUDA
  cudaEvent_t ready = nullptr;  // recorded on the render stream after the frame
#endif
  ~Impl();
};

}  // namespace rgs::api
