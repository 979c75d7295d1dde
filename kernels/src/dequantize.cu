// Widening of the compact .rgs runtime profile into the FP32 arrays of the baseline pipeline, the device
// twin of format::dequantize() (format/src/encoded_scene.cpp): same operations, same bits (FP16 → FP32 is
// exact; SH = s[d][c]·q is one rounded product; log scales go through expf, which may differ from the
// host's std::exp by an ulp).
#include <cuda_fp16.h>

#include "launch_util.cuh"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/shared/spherical_harmonics.h"

namespace rgs::kernels {
namespace {

__device__ inline float half_to_float(uint16_t bits) { return __half2float(__ushort_as_half(bits)); }

/// Degree of SH coefficient k: 0 for k = 0, 1 for 1..3, 2 for 4..8, 3 for 9..15.
__device__ inline int sh_degree_of(int k) { return k == 0 ? 0 : k < 4 ? 1 : k < 9 ? 2 : 3; }

__global__ void __launch_bounds__(detail::kBlockSize)
    dequantize_kernel(CompactGaussiansView c, float* rotations, float* scales, float* opacities, float* sh) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= c.count) return;
  for (int a = 0; a < 4; ++a) rotations[4 * i + a] = half_to_float(c.rotations[4 * i + a]);
  for (int a = 0; a < 3; ++a) {
    const float v = half_to_float(c.scales[3 * i + a]);
    scales[3 * i + a] = c.scale_encoding == CompactScaleEncoding::kLog ? expf(v) : v;
  }
  opacities[i] = half_to_float(c.opacities[i]);
  const int k_count = sh_coefficients_for(int(c.sh_degree));
  const uint64_t base = uint64_t(i) * uint64_t(k_count) * 3;
  for (int k = 0; k < k_count; ++k) {
    const int d = sh_degree_of(k);
    for (int ch = 0; ch < 3; ++ch) {
      sh[base + 3 * k + ch] = c.sh_scales[d][ch] * static_cast<float>(c.sh[base + 3 * k + ch]);
    }
  }
}

}  // namespace

cudaError_t dequantize(const CompactGaussiansView& compact, float* rotations, float* scales, float* opacities,
                       float* sh, cudaStream_t stream) {
  if (compact.count == 0) return cudaSuccess;
  dequantize_kernel<<<detail::blocks_for(compact.count), detail::kBlockSize, 0, stream>>>(compact, rotations,
                                                                                         scales, opacities, sh);
  return detail::launch_result();
}

}  // namespace rgs::kernels
