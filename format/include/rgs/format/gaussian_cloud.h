// Float Gaussians in memory: what a PLY decodes to and what a .rgs dequantizes to.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace rgs::format {

/// Number of SH coefficients per colour channel for a degree: K = (degree + 1)^2.
constexpr uint32_t sh_coefficient_count(uint32_t degree) { return (degree + 1) * (degree + 1); }

/// A 3DGS scene as float32 structure-of-arrays, with the INRIA activations already applied, as the
/// original 3DGS code holds it at render time (docs/DESIGN.md#attributes).
///
/// All arrays hold size() Gaussians in the same order. Coordinates are the training (COLMAP) world frame.
struct GaussianCloud {
  /// SH degree 0..3; each Gaussian has K = (sh_degree+1)^2 coefficients per channel.
  uint32_t sh_degree = 0;
  /// [N, 3] float32 centre positions (x, y, z), world units.
  std::vector<float> means;
  /// [N, 4] float32 unit quaternions in (w, x, y, z) order (PLY rot_0..rot_3, normalized).
  std::vector<float> rotations;
  /// [N, 3] float32 linear scales (exp of the PLY's log scale_0..2), world units.
  std::vector<float> scales;
  /// [N] float32 activated opacities, sigmoid of the PLY logit, in [0, 1].
  std::vector<float> opacities;
  /// [N, K, 3] float32 SH coefficients, coefficient-major with the colour channel fastest:
  /// sh[(i*K + k)*3 + c]. k = 0 is the DC term (PLY f_dc_c); k >= 1 is PLY f_rest[c*(K-1) + k-1].
  std::vector<float> sh;
  /// [N, 4] float32 or empty: each Gaussian's opacity logit and log scale_0..2 as a PLY file held them, kept when
  /// asked (converter::PlyReadOptions::keep_pre_activation) because the float32 activations cannot give them back
  /// (the sigmoid saturates). The PLY writer writes a value where it still activates to `opacities` or `scales`.
  std::vector<float> pre_activation;
  /// Trained with the 2D Mip filter: renderers scale each opacity by its compensation (SceneMetadata::antialiased).
  bool antialiased = false;

  size_t size() const { return means.size() / 3; }
  uint32_t sh_coefficients() const { return sh_coefficient_count(sh_degree); }

  /// Resizes every array for n Gaussians at the current sh_degree (new values are zero).
  void resize(size_t n) {
    means.resize(n * 3);
    rotations.resize(n * 4);
    scales.resize(n * 3);
    opacities.resize(n);
    sh.resize(n * sh_coefficients() * 3);
  }
  /// Removes the Gaussians at `indices` (ascending, each < size()), keeping the order of the others; the
  /// arrays shrink in place, without reallocating.
  void remove_gaussians(const std::vector<uint64_t>& indices) {
    const size_t n = size();
    const size_t sv = size_t{sh_coefficients()} * 3;
    const bool pre = pre_activation.size() == n * 4;
    size_t out = 0, d = 0;
    for (size_t i = 0; i < n; ++i) {
      if (d < indices.size() && indices[d] == i) {
        ++d;
        continue;
      }
      if (out != i) {
        std::memmove(&means[out * 3], &means[i * 3], 3 * sizeof(float));
        std::memmove(&rotations[out * 4], &rotations[i * 4], 4 * sizeof(float));
        std::memmove(&scales[out * 3], &scales[i * 3], 3 * sizeof(float));
        opacities[out] = opacities[i];
        std::memmove(&sh[out * sv], &sh[i * sv], sv * sizeof(float));
        if (pre) std::memmove(&pre_activation[out * 4], &pre_activation[i * 4], 4 * sizeof(float));
      }
      ++out;
    }
    resize(out);
    if (pre) pre_activation.resize(out * 4);
  }
  /// True when every array has the length that size() and sh_degree imply.
  bool is_consistent() const {
    const size_t n = size();
    return means.size() == n * 3 && rotations.size() == n * 4 && scales.size() == n * 3 &&
           opacities.size() == n && sh.size() == n * sh_coefficients() * 3 && sh_degree <= 3;
  }
};

}  // namespace rgs::format
