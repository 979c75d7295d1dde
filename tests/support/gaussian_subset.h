// Subsets of a real scene for tests that need small or degenerate scenes made from real Gaussians.
#pragma once

#include <algorithm>
#include <cstddef>

#include "rgs/format/gaussian_cloud.h"

namespace rgs::test {

/// The first `n` Gaussians of `cloud` (n <= cloud.size()); with `copies`, Gaussian 0 repeated n times.
inline format::GaussianCloud first_gaussians(const format::GaussianCloud& cloud, size_t n, bool copies = false) {
  format::GaussianCloud out;
  out.sh_degree = cloud.sh_degree;
  out.resize(n);
  const size_t sh = size_t{cloud.sh_coefficients()} * 3;
  for (size_t i = 0; i < n; ++i) {
    const size_t j = copies ? 0 : i;
    std::copy_n(&cloud.means[j * 3], 3, &out.means[i * 3]);
    std::copy_n(&cloud.rotations[j * 4], 4, &out.rotations[i * 4]);
    std::copy_n(&cloud.scales[j * 3], 3, &out.scales[i * 3]);
    out.opacities[i] = cloud.opacities[j];
    std::copy_n(&cloud.sh[j * sh], sh, &out.sh[i * sh]);
  }
  return out;
}

}  // namespace rgs::test
