// Real spherical harmonics of degree 0..3 with the exact constants and signs of the 3DGS rasterizer
// (forward.cu computeColorFromSH; docs/DESIGN.md#spherical-harmonics lists them). The 3DGS basis carries a
// minus sign on every odd m of its constants table; with the textbook all-plus table the image is visibly
// wrong (27.7 dB).
// Coefficient index k = l² + l + m, k = 0 is the DC term.
#pragma once

#include "rgs/kernels/shared/host_device.h"

namespace rgs::kernels {

/// Largest SH degree of a 3DGS scene and the matching number of coefficients per channel.
constexpr int kMaxShDegree = 3;
constexpr int kMaxShCoefficients = 16;

// 3DGS SH_C0..SH_C3, with their signs.
constexpr float kShC0 = 0.28209479177387814f;
constexpr float kShC1 = 0.4886025119029199f;
constexpr float kShC2_0 = 1.0925484305920792f;
constexpr float kShC2_1 = -1.0925484305920792f;
constexpr float kShC2_2 = 0.31539156525252005f;
constexpr float kShC2_3 = -1.0925484305920792f;
constexpr float kShC2_4 = 0.5462742152960396f;
constexpr float kShC3_0 = -0.5900435899266435f;
constexpr float kShC3_1 = 2.890611442640554f;
constexpr float kShC3_2 = -0.4570457994644658f;
constexpr float kShC3_3 = 0.3731763325901154f;
constexpr float kShC3_4 = -0.4570457994644658f;
constexpr float kShC3_5 = 1.445305721320277f;
constexpr float kShC3_6 = -0.5900435899266435f;

/// Offset added to the SH sum before clamping at 0 (3DGS stores colours as SH minus 0.5).
constexpr float kShColourOffset = 0.5f;

/// Number of coefficients per channel of an SH degree: (degree + 1)².
RGS_HOST_DEVICE int sh_coefficients_for(int degree) { return (degree + 1) * (degree + 1); }

/// Degree l of coefficient index k = l² + l + m: 0 for k = 0, 1 for 1..3, 2 for 4..8, 3 for 9..15 (the index
/// of the .rgs per-degree SH quantization scale).
RGS_HOST_DEVICE int sh_degree_of_coefficient(int k) { return k == 0 ? 0 : k < 4 ? 1 : k < 9 ? 2 : 3; }

/// Basis values Y_k(dir) for k < (degree+1)², dir = (x, y, z) a unit vector (world frame, from the camera
/// centre to the Gaussian mean). Entries k >= (degree+1)² are set to 0. `degree` is clamped to [0, 3].
///   Y0 = C0;  Y1 = −C1·y, Y2 = C1·z, Y3 = −C1·x;
///   Y4 = C2_0·xy, Y5 = C2_1·yz, Y6 = C2_2·(2z² − x² − y²), Y7 = C2_3·xz, Y8 = C2_4·(x² − y²);
///   Y9 = C3_0·y·(3x² − y²), Y10 = C3_1·xy·z, Y11 = C3_2·y·(4z² − x² − y²), Y12 = C3_3·z·(2z² − 3x² − 3y²),
///   Y13 = C3_4·x·(4z² − x² − y²), Y14 = C3_5·z·(x² − y²), Y15 = C3_6·x·(x² − 3y²)
/// with the signed constants above (C2_1, C2_3, C3_0, C3_2, C3_4, C3_6 negative).
RGS_HOST_DEVICE void sh_basis(float x, float y, float z, int degree, float Y[kMaxShCoefficients]) {
  for (int k = 0; k < kMaxShCoefficients; ++k) Y[k] = 0.f;
  Y[0] = kShC0;
  if (degree < 1) return;
  Y[1] = -(kShC1 * y);
  Y[2] = kShC1 * z;
  Y[3] = -(kShC1 * x);
  if (degree < 2) return;
  const float xx = x * x, yy = y * y, zz = z * z;
  const float xy = x * y, yz = y * z, xz = x * z;
  Y[4] = kShC2_0 * xy;
  Y[5] = kShC2_1 * yz;
  Y[6] = kShC2_2 * (2.0f * zz - xx - yy);
  Y[7] = kShC2_3 * xz;
  Y[8] = kShC2_4 * (xx - yy);
  if (degree < 3) return;
  Y[9] = kShC3_0 * y * (3.0f * xx - yy);
  Y[10] = kShC3_1 * xy * z;
  Y[11] = kShC3_2 * y * (4.0f * zz - xx - yy);
  Y[12] = kShC3_3 * z * (2.0f * zz - 3.0f * xx - 3.0f * yy);
  Y[13] = kShC3_4 * x * (4.0f * zz - xx - yy);
  Y[14] = kShC3_5 * z * (xx - yy);
  Y[15] = kShC3_6 * x * (xx - 3.0f * yy);
}

/// RGB colour of one Gaussian seen along `dir` (unit, camera centre → mean):
/// colour_c = max(Σ_k sh[k][c]·Y_k(dir) + 0.5, 0).
/// @param sh      [K, 3] float32, channel fastest: sh[k*3 + c]; K = (degree+1)².
/// @param degree  0..3 (values above 3 are treated as 3).
/// Summation order follows 3DGS: DC, then the degree-1 terms one by one, then each higher degree summed
/// on its own and added as a group, then the 0.5 offset.
RGS_HOST_DEVICE void sh_to_colour(const float* sh, int degree, float x, float y, float z, float rgb[3]) {
  if (degree > kMaxShDegree) degree = kMaxShDegree;
  float Y[kMaxShCoefficients];
  sh_basis(x, y, z, degree, Y);
  for (int c = 0; c < 3; ++c) {
    float result = Y[0] * sh[0 * 3 + c];
    if (degree > 0) {
      result = result + Y[1] * sh[1 * 3 + c] + Y[2] * sh[2 * 3 + c] + Y[3] * sh[3 * 3 + c];
    }
    if (degree > 1) {
      result = result + (Y[4] * sh[4 * 3 + c] + Y[5] * sh[5 * 3 + c] + Y[6] * sh[6 * 3 + c] +
                         Y[7] * sh[7 * 3 + c] + Y[8] * sh[8 * 3 + c]);
    }
    if (degree > 2) {
      result = result + (Y[9] * sh[9 * 3 + c] + Y[10] * sh[10 * 3 + c] + Y[11] * sh[11 * 3 + c] +
                         Y[12] * sh[12 * 3 + c] + Y[13] * sh[13 * 3 + c] + Y[14] * sh[14 * 3 + c] +
                         Y[15] * sh[15 * 3 + c]);
    }
    result += kShColourOffset;
    rgb[c] = fmaxf(result, 0.f);
  }
}

}  // namespace rgs::kernels
