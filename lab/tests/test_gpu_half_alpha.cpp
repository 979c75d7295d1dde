// The device's α in half-precision blending (half2_alpha: ex2.approx.ftz.f32, then rounded to binary16) against
// the CPU reference's (the exact 2^v rounded once): equal but where 2^v lies within the device's exp2 error of a
// binary16 rounding boundary, and there one binary16 unit apart (kernels/shared/half_blend.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/kernels/shared/half_blend.h"
#include "rgs/lab/half_alpha.h"

namespace rgs::test {
namespace {

namespace k = rgs::kernels;

TEST_CASE("half2_alpha: the device's alpha is the host's but within its exp2 error of a binary16 boundary") {
  if (!have_gpu()) return;
  // Powers in base 2 densely over the blended range and beyond both ends, then the special values.
  constexpr uint64_t kDense = uint64_t(1) << 22;
  const double lowest = std::log2(1.0 / 255) - 0.05, highest = 0.05;
  std::vector<float> powers;
  for (uint64_t i = 0; i < kDense; ++i) powers.push_back(float(lowest + (highest - lowest) * double(i) / kDense));
  for (float v : {0.f, -0.f, -1e-30f, 1e-3f, -1.f, -8.f, 15.99f, 16.f, 20.f, -30.f, -1e30f, INFINITY, -INFINITY,
                  std::nanf("")}) {
    powers.push_back(v);
  }
  if (powers.size() % 2 != 0) powers.push_back(-1.f);
  const uint64_t pairs = powers.size() / 2;
  runtime::DeviceBuffer<float> device_powers;
  runtime::DeviceBuffer<uint32_t> device_alpha;
  REQUIRE(device_powers.allocate_exactly(powers.size(), "powers").ok());
  REQUIRE(device_alpha.allocate_exactly(pairs, "alpha").ok());
  REQUIRE(cudaMemcpy(device_powers.data(), powers.data(), powers.size() * sizeof(float), cudaMemcpyHostToDevice) ==
          cudaSuccess);
  REQUIRE(lab::device_half_alpha(device_powers.data(), device_alpha.data(), pairs, nullptr) == cudaSuccess);
  std::vector<uint32_t> alpha(pairs);
  REQUIRE(cudaMemcpy(alpha.data(), device_alpha.data(), pairs * sizeof(uint32_t), cudaMemcpyDeviceToHost) ==
          cudaSuccess);
  const uint16_t alpha_min = uint16_t(k::kHalf2AlphaMin);
  uint64_t differing = 0, at_skip_boundary = 0;
  double farthest = 0;  // the largest relative distance of 2^v from the boundary between two differing α
  for (uint64_t i = 0; i < pairs; ++i) {
    const k::Half2Bits host = k::half2_alpha(powers[2 * i], powers[2 * i + 1]);
    for (int lane = 0; lane < 2; ++lane) {
      const auto d = uint16_t(alpha[i] >> (16 * lane)), h = uint16_t(host >> (16 * lane));
      if (d == h) continue;
      ++differing;
      const double exact = std::exp2(double(powers[2 * i + lane]));
      // Skipped on one side, 1/255's binary16 on the other: 2^v at the skip's boundary (0x1c03 / 0x1c04).
      const bool skip_boundary = (d == 0 && h == alpha_min) || (h == 0 && d == alpha_min);
      if (skip_boundary) {
        ++at_skip_boundary;
      } else {
        CHECK(std::abs(int(d) - int(h)) == 1);  // adjacent binary16 values, on either side of 2^v's boundary
      }
      // The two values 2^v lies between: at the skip, 1/255's binary16 and the one below it.
      const uint16_t upper = skip_boundary ? alpha_min : std::max(d, h);
      const uint16_t lower = skip_boundary ? uint16_t(alpha_min - 1) : std::min(d, h);
      const double boundary = (k::detail::half_bits_to_double(upper) + k::detail::half_bits_to_double(lower)) / 2;
      farthest = std::max(farthest, std::fabs(exact - boundary) / exact);
    }
  }
  MESSAGE(differing << " of " << 2 * pairs << " alphas differ (" << at_skip_boundary
                    << " at the 1/255 skip); 2^v at most " << farthest << " (relative) from the boundary between");
  CHECK(farthest < std::ldexp(1.0, -20));      // the device's exp2: within a few FP32 units of 2^v
  CHECK(double(differing) < 0.01 * double(2 * pairs));  // rare: 2^v near a boundary
}

}  // namespace
}  // namespace rgs::test
