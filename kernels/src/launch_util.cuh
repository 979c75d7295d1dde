// Launch-configuration helpers shared by the .cu files of rgs_kernels.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

namespace rgs::kernels::detail {

/// Threads per block of the one-thread-per-element kernels.
constexpr uint32_t kBlockSize = 256;

/// Blocks for `count` elements at kBlockSize threads each (at least 1, so an empty launch stays valid).
inline unsigned blocks_for(uint64_t count) {
  const uint64_t blocks = (count + kBlockSize - 1) / kBlockSize;
  return static_cast<unsigned>(blocks == 0 ? 1 : blocks);
}

/// The error of the last launch on this thread (cudaGetLastError also clears it).
inline cudaError_t launch_result() { return cudaGetLastError(); }

}  // namespace rgs::kernels::detail
