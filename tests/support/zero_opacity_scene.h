// A scene with some Gaussians' opacity set to 0, and the same scene without them: the pair of scenes that
// must render the same bits if a renderer skips opacity 0 (the archive profile leaves such Gaussians out,
// format/SPEC.md §3.3.2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rgs/format/gaussian_cloud.h"

namespace rgs::test {

struct ZeroOpacityScene {
  format::GaussianCloud with_zeros;  ///< the source with every `every`-th Gaussian's opacity set to 0
  format::GaussianCloud without;     ///< the source without those Gaussians, the others in order
};

/// Sets the opacity of Gaussians 0, every, 2·every, ... of `source` to 0 and drops them for `without`.
inline ZeroOpacityScene zero_opacity_scene(const format::GaussianCloud& source, size_t every) {
  ZeroOpacityScene s{source, source};
  std::vector<uint64_t> zeroed;
  for (size_t i = 0; i < source.size(); i += every) {
    s.with_zeros.opacities[i] = 0.f;
    zeroed.push_back(i);
  }
  s.without.remove_gaussians(zeroed);
  return s;
}

}  // namespace rgs::test
