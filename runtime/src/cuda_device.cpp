#include "rgs/runtime/cuda_device.h"

namespace rgs::runtime {

Status cuda_status(cudaError_t result, const std::string& what) {
  if (result == cudaSuccess) return Status();
  cudaGetLastError();  // clear a non-sticky error so the next call is not blamed for this one
  const StatusCode code = result == cudaErrorMemoryAllocation ? StatusCode::kOutOfMemory : StatusCode::kCudaError;
  return Status(code, what + ": " + cudaGetErrorName(result) + ": " + cudaGetErrorString(result));
}

int cuda_device_count(std::string* why) {
  int count = 0;
  const cudaError_t result = cudaGetDeviceCount(&count);
  if (result != cudaSuccess) {
    cudaGetLastError();
    if (why != nullptr) *why = std::string(cudaGetErrorName(result)) + ": " + cudaGetErrorString(result);
    return 0;
  }
  if (count == 0 && why != nullptr) *why = "the CUDA runtime reports 0 devices";
  return count;
}

Result<CudaDeviceInfo> cuda_device_info(int ordinal) {
  cudaDeviceProp prop{};
  RGS_RETURN_IF_CUDA_ERROR(cudaGetDeviceProperties(&prop, ordinal),
                           "cudaGetDeviceProperties(" + std::to_string(ordinal) + ")");
  CudaDeviceInfo info;
  info.ordinal = ordinal;
  info.name = prop.name;
  info.compute_major = prop.major;
  info.compute_minor = prop.minor;
  info.multiprocessors = prop.multiProcessorCount;
  info.global_memory_bytes = prop.totalGlobalMem;
  info.l2_cache_bytes = uint64_t(prop.l2CacheSize);
  RGS_RETURN_IF_CUDA_ERROR(cudaDriverGetVersion(&info.driver_version), "cudaDriverGetVersion");
  RGS_RETURN_IF_CUDA_ERROR(cudaRuntimeGetVersion(&info.runtime_version), "cudaRuntimeGetVersion");
  return info;
}

Status use_cuda_device(int ordinal) {
  RGS_RETURN_IF_CUDA_ERROR(cudaSetDevice(ordinal), "cudaSetDevice(" + std::to_string(ordinal) + ")");
  return Status();
}

}  // namespace rgs::runtime
