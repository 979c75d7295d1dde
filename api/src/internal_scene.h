// Scene::Impl and Image::Impl, shared by scene.cpp and renderer.cpp.
#pragma once

#include <optional>

#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"
#include "rgs/format/gaussian_cloud.h"

#if RGS_HAS_CUDA
#include <cuda_runtime_api.h>

#include "rgs/runtime/gpu_scene.h"
#endif

namespace rgs::api {

struct Scene::Impl {
  SceneInfo info;
  format::GaussianCloud cloud;  // CPU scenes
#if RGS_HAS_CUDA
  std::optional<runtime::GpuScene> gpu;  // GPU scenes
#endif
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
