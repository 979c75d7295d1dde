// half2_alpha as the device computes it, for the check of how closely the CPU reference's α follows the device's
// (kernels/shared/half_blend.h; lab/tests/test_gpu_half_alpha.cpp). A test kernel, so the lab's, not the product's.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

namespace rgs::lab {

/// Writes out[i] = half2_alpha(powers[2i], powers[2i + 1]) as the render computes it, for i < pairs.
/// @param powers  [2·pairs] float, device memory: folded powers in base 2 (P·log2 e)
/// @param out     [pairs] uint32_t, device memory: the Half2Bits α of each pair of powers, the first in the low half
cudaError_t device_half_alpha(const float* powers, uint32_t* out, uint64_t pairs, cudaStream_t stream);

}  // namespace rgs::lab
