// Rotation of spherical-harmonic colour: the real Wigner D-matrices of SH bands 1..3 in the 3DGS basis
// (docs/DESIGN.md#spherical-harmonics: index k = l² + l + m, a minus sign on every odd-m constant).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace rgs::converter {

/// The real Wigner D-matrix of each SH band for one rotation, in double. Band l's matrix is
/// [(2l+1), (2l+1)] row-major over the band's coefficient indices k = l² .. l² + 2l in order: d[l][r*(2l+1) + c]
/// maps input coefficient l² + c to output coefficient l² + r. Band 0 is [1]. Entries beyond (2l+1)² are 0.
/// The matrices are orthogonal, D(I) = I, and D(R1·R2) = D(R1)·D(R2).
struct ShRotation {
  std::array<std::array<double, 49>, 4> band{};
};

/// The D-matrices of the proper rotation `rotation` (row-major [3, 3], applied to column vectors: p' = R·p),
/// such that the colour a rotated Gaussian shows towards R·d is the colour it showed towards d:
/// Σ_k Y_k(R·d)·(D·c)_k = Σ_k Y_k(d)·c_k for every unit direction d and coefficients c of one channel.
/// Built per band by evaluating the basis at 32 fixed, well-spread directions and solving the least-squares
/// system in double (exact up to rounding, since the rotated basis stays in its band). `rotation` must be
/// orthonormal with determinant +1 (not checked: a reflection or a scaled matrix gives a meaningless result).
ShRotation sh_rotation(const std::array<double, 9>& rotation);

/// Rotates the SH coefficients of `count` Gaussians in place: for each Gaussian, channel and band l = 1..degree,
/// c' = D_l · c, accumulated in double and rounded to float32; the DC term (k = 0) is left as is.
/// @param sh      [count, K, 3] float32, coefficient-major with the channel fastest (format::GaussianCloud::sh):
///                sh[(i*K + k)*3 + c], K = (degree+1)².
/// @param degree  0..3 (0 leaves everything unchanged; values above 3 are treated as 3).
void rotate_sh(const ShRotation& rotation, uint32_t degree, size_t count, float* sh);

}  // namespace rgs::converter
