// Copies runs of compact Gaussians (gather_gaussians.h): one block per run, byte-granular per attribute.
#include "rgs/kernels/gather_gaussians.h"

namespace rgs::kernels {
namespace {

constexpr int kThreads = 256;

/// Copies `bytes` bytes from `src` to `dst` with the block's threads, 4 bytes at a time where both are aligned.
__device__ void copy_bytes(uint8_t* dst, const uint8_t* src, uint64_t bytes) {
  if ((reinterpret_cast<uintptr_t>(dst) & 3) == 0 && (reinterpret_cast<uintptr_t>(src) & 3) == 0) {
    const uint64_t words = bytes / 4;
    for (uint64_t i = threadIdx.x; i < words; i += blockDim.x) {
      reinterpret_cast<uint32_t*>(dst)[i] = reinterpret_cast<const uint32_t*>(src)[i];
    }
    for (uint64_t i = words * 4 + threadIdx.x; i < bytes; i += blockDim.x) dst[i] = src[i];
    return;
  }
  for (uint64_t i = threadIdx.x; i < bytes; i += blockDim.x) dst[i] = src[i];
}

__global__ void gather_kernel(const GatherRun* runs, CompactArrays src, CompactArrays dst, uint32_t sh_bytes) {
  const GatherRun run = runs[blockIdx.x];
  const uint64_t s = run.src, d = run.dst, n = run.count;
  auto part = [&](const void* from, void* to, uint64_t record) {
    copy_bytes(static_cast<uint8_t*>(to) + d * record, static_cast<const uint8_t*>(from) + s * record, n * record);
  };
  part(src.means, dst.means, 12);
  part(src.rotations, dst.rotations, 8);
  part(src.scales, dst.scales, 6);
  part(src.opacities, dst.opacities, 2);
  part(src.sh, dst.sh, sh_bytes);
  if (src.sh_dc_residual != nullptr && dst.sh_dc_residual != nullptr) part(src.sh_dc_residual, dst.sh_dc_residual, 3);
}

}  // namespace

cudaError_t gather_gaussians(const GatherRun* runs, uint32_t run_count, CompactArrays src, CompactArrays dst,
                             uint32_t sh_bytes, cudaStream_t stream) {
  if (run_count == 0) return cudaSuccess;
  gather_kernel<<<run_count, kThreads, 0, stream>>>(runs, src, dst, sh_bytes);
  return cudaGetLastError();
}

}  // namespace rgs::kernels
