// The device's binary16 exp2 over every input pattern, for the check that the CPU reference emulates it bit for
// bit (kernels/shared/half_blend.h half2_exp2; tests/gpu/test_gpu_half_exp2.cpp).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

namespace rgs::kernels {

/// Number of binary16 patterns: the length of device_half_exp2_table's output.
constexpr uint32_t kHalfPatterns = 1u << 16;

/// Writes half2_exp2 as the device computes it for every binary16 pattern x: out[x] = the device's
/// ex2.approx.f16 of x, two patterns per ex2.approx.f16x2 instruction as the render issues it.
/// @param out  [kHalfPatterns] uint16_t, device memory
cudaError_t device_half_exp2_table(uint16_t* out, cudaStream_t stream);

}  // namespace rgs::kernels
