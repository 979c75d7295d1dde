// A scene with some Gaussians' opacity set to 0, and the same scene without them: the pair of scenes that
// must render the same bits if a renderer skips opacity 0 (the archive profile leaves such Gaussians out,
// format/SPEC.md §3.3.2).
#pragma once

#include <cstddef>

#include "rgs/format/gaussian_cloud.h"

namespace rgs::test {

struct ZeroOpacityScene {
  format::GaussianCloud with_zeros;  ///< the source with every `every`-th Gaussian's opacity set to 0
  format::GaussianCloud without;     ///< the source without those Gaussians, the others in order
};

/// Sets the opacity of Gaussians 0, every, 2·every, ... of `source` to 0 and drops them for `without`.
inline ZeroOpacityScene zero_opacity_scene(const format::GaussianCloud& source, size_t every) {
  ZeroOpacityScene s{source, {}};
  format::GaussianCloud& out = s.without;
  out.sh_degree = source.sh_degree;
  const size_t k = source.sh_coefficients() * 3;
  for (size_t i = 0; i < source.size(); ++i) {
    if (i % every == 0) {
      s.with_zeros.opacities[i] = 0.f;
      continue;
    }
    out.means.insert(out.means.end(), &source.means[i * 3], &source.means[i * 3] + 3);
    out.rotations.insert(out.rotations.end(), &source.rotations[i * 4], &source.rotations[i * 4] + 4);
    out.scales.insert(out.scales.end(), &source.scales[i * 3], &source.scales[i * 3] + 3);
    out.opacities.push_back(source.opacities[i]);
    out.sh.insert(out.sh.end(), &source.sh[i * k], &source.sh[i * k] + k);
  }
  return s;
}

}  // namespace rgs::test
