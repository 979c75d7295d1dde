// CUDA device discovery and error translation for the GPU runtime. Available only when the project is built
// with RGS_WITH_CUDA (rgs/config.h: RGS_HAS_CUDA).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <string>

#include "rgs/format/status.h"

namespace rgs::runtime {

/// What the GPU tools and tests report about the device they ran on.
struct CudaDeviceInfo {
  int ordinal = 0;
  std::string name;                 ///< e.g. "NVIDIA H100 80GB HBM3"
  int compute_major = 0, compute_minor = 0;
  int multiprocessors = 0;
  uint64_t global_memory_bytes = 0;
  uint64_t l2_cache_bytes = 0;
  int driver_version = 0, runtime_version = 0;  ///< as cudaDriverGetVersion / cudaRuntimeGetVersion (13000 = 13.0)
};

/// Number of usable CUDA devices; 0 when there is no device or no driver (never an error). If `why` is given
/// and the count is 0, it receives the CUDA runtime's reason (e.g. "cudaErrorNoDevice: no CUDA-capable device
/// is detected").
int cuda_device_count(std::string* why = nullptr);

/// Properties of device `ordinal`. Errors: kCudaError (no such device, driver problem).
Result<CudaDeviceInfo> cuda_device_info(int ordinal = 0);

/// Makes `ordinal` the current device of the calling thread. Errors: kCudaError.
Status use_cuda_device(int ordinal);

/// Translates a CUDA runtime result: ok for cudaSuccess, kOutOfMemory for cudaErrorMemoryAllocation, else
/// kCudaError. The message is "<what>: <error name>: <error description>". Clears the runtime's last
/// non-sticky error so that later calls are not blamed for it.
Status cuda_status(cudaError_t result, const std::string& what);

/// Returns cuda_status(expr, what) from the calling function when expr is not cudaSuccess.
#define RGS_RETURN_IF_CUDA_ERROR(expr, what)                                        \
  do {                                                                             \
    const cudaError_t rgs_cuda_result_ = (expr);                                   \
    if (rgs_cuda_result_ != cudaSuccess) return ::rgs::runtime::cuda_status(rgs_cuda_result_, (what)); \
  } while (0)

}  // namespace rgs::runtime
