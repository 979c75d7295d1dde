// query_device: the device's name and memory in use (runtime::cuda_device_info, cudaMemGetInfo).
#include "rgs/api/scene.h"

#include <algorithm>
#include <thread>

#include "rgs/config.h"

#if RGS_HAS_CUDA
#include <cuda_runtime_api.h>

#include "internal_gpu_scene_loading.h"
#include "rgs/runtime/cuda_device.h"
#endif

namespace rgs::api {

Result<DeviceInfo> query_device(Device device, int cuda_device) {
  DeviceInfo info;
  info.device = device;
  info.host_threads = std::max(1u, std::thread::hardware_concurrency());
  if (device == Device::kCpu) {
    info.name = "CPU, " + std::to_string(info.host_threads) + " hardware thread" + (info.host_threads == 1 ? "" : "s");
    return info;
  }
#if RGS_HAS_CUDA
  RGS_RETURN_IF_ERROR(require_cuda_device(cuda_device));
  RGS_ASSIGN_OR_RETURN(runtime::CudaDeviceInfo cuda, runtime::cuda_device_info(cuda_device));
  size_t free_bytes = 0, total_bytes = 0;
  RGS_RETURN_IF_CUDA_ERROR(cudaMemGetInfo(&free_bytes, &total_bytes), "query_device: cudaMemGetInfo");
  info.cuda_device = cuda_device;
  info.name = cuda.name;
  info.memory_total_bytes = total_bytes;
  info.memory_free_bytes = free_bytes;
  info.compute_major = cuda.compute_major;
  info.compute_minor = cuda.compute_minor;
  return info;
#else
  (void)cuda_device;
  return Status(StatusCode::kUnsupportedFeature,
                "query_device: device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF)");
#endif
}

}  // namespace rgs::api
