// Widening of the compact .rgs runtime profile into the FP32 arrays of the baseline pipeline, the device
// twin of format::dequantize() (format/src/encoded_scene.cpp). It reads through the same functions the RoofGS
// kernels use to dequantize in registers (roofgs_gaussian.cuh), so both paths see the same values: FP16 → FP32
// is exact, SH = s[d][c]·q is one rounded product, and log scales go through expf (which may differ from the
// host's std::exp by an ulp).
#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

__global__ void __launch_bounds__(detail::kBlockSize)
    dequantize_kernel(CompactGaussiansView c, float* rotations, float* scales, float* opacities, float* sh) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= c.count) return;
  GaussianSource src{};
  src.compact = c;
  float mean[3], scale[3], q[4], opacity;
  detail::load_geometry<true>(src, i, mean, scale, q, &opacity);
  for (int a = 0; a < 4; ++a) rotations[4 * uint64_t(i) + a] = q[a];
  for (int a = 0; a < 3; ++a) scales[3 * uint64_t(i) + a] = scale[a];
  opacities[i] = opacity;
  const int values = sh_coefficients_for(int(c.sh_degree)) * 3;
  // Unrolled to the largest block so every s[d][c] index is a compile-time constant (no local-memory copy).
#pragma unroll
  for (int j = 0; j < kMaxShCoefficients * 3; ++j) {
    if (j < values) sh[uint64_t(i) * uint64_t(values) + uint64_t(j)] = detail::dequantize_sh(c, i, j);
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
