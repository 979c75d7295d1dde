// The device's binary16 exp2 (ex2.approx.f16x2, the render's α in half-precision blending) equals the CPU
// reference's emulation of it (kernels/shared/half_blend.h detail::half_exp2_bits) on all 65,536 patterns.
#include <cstdint>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/kernels/half_exp2.h"
#include "rgs/kernels/shared/half_blend.h"

namespace rgs::test {
namespace {

TEST_CASE("half2_exp2: the device's ex2.approx.f16 equals the emulation on every pattern") {
  if (!have_gpu()) return;
  runtime::DeviceBuffer<uint16_t> table;
  REQUIRE(table.allocate_exactly(kernels::kHalfPatterns, "exp2 table").ok());
  REQUIRE(cudaMemset(table.data(), 0xff, kernels::kHalfPatterns * sizeof(uint16_t)) == cudaSuccess);  // poison
  REQUIRE(kernels::device_half_exp2_table(table.data(), nullptr) == cudaSuccess);
  std::vector<uint16_t> device(kernels::kHalfPatterns);
  REQUIRE(cudaMemcpy(device.data(), table.data(), device.size() * sizeof(uint16_t), cudaMemcpyDeviceToHost) ==
          cudaSuccess);
  int mismatches = 0;
  for (uint32_t x = 0; x < kernels::kHalfPatterns; ++x) {
    const uint16_t expected = kernels::detail::half_exp2_bits(uint16_t(x));
    if (device[x] != expected && ++mismatches <= 8) {
      MESSAGE("pattern 0x" << std::hex << x << ": device 0x" << device[x] << ", emulation 0x" << expected);
    }
  }
  CHECK(mismatches == 0);
}

}  // namespace
}  // namespace rgs::test
