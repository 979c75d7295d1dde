// What a device is and how much of its memory is in use: for status panels and reports (rgs-view's page).
// Usable without CUDA headers.
#pragma once

#include <cstdint>
#include <string>

#include "rgs/api/scene.h"
#include "rgs/format/status.h"

namespace rgs::api {

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
