// Real Wigner D-matrices of the 3DGS SH basis, found numerically: a band's rotated basis functions are linear
// combinations of the band's own, so sampling both at a few more directions than the band has functions and
// solving the least-squares system recovers the combination exactly (up to rounding) whatever the basis'
// normalization and signs.
#include "rgs/converter/sh_rotation.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace rgs::converter {

namespace {

/// Directions sampled per band: a Fibonacci lattice, well spread for every band up to 3 (7 functions).
constexpr int kDirections = 32;

/// The 3DGS basis of degrees 0..3 in double at a unit direction: the table of docs/DESIGN.md#spherical-harmonics,
/// as kernels/include/rgs/kernels/shared/spherical_harmonics.h evaluates it in float. The converter does not link
/// the kernels' headers (CONTRIBUTING.md#layering); tests/converter checks D against the kernels' basis, which
/// any difference between the two tables fails.
void sh_basis_double(const double d[3], double out[16]) {
  const double x = d[0], y = d[1], z = d[2];
  const double xx = x * x, yy = y * y, zz = z * z;
  out[0] = 0.28209479177387814;
  out[1] = -0.4886025119029199 * y;
  out[2] = 0.4886025119029199 * z;
  out[3] = -0.4886025119029199 * x;
  out[4] = 1.0925484305920792 * x * y;
  out[5] = -1.0925484305920792 * y * z;
  out[6] = 0.31539156525252005 * (2 * zz - xx - yy);
  out[7] = -1.0925484305920792 * x * z;
  out[8] = 0.5462742152960396 * (xx - yy);
  out[9] = -0.5900435899266435 * y * (3 * xx - yy);
  out[10] = 2.890611442640554 * x * y * z;
  out[11] = -0.4570457994644658 * y * (4 * zz - xx - yy);
  out[12] = 0.3731763325901154 * z * (2 * zz - 3 * xx - 3 * yy);
  out[13] = -0.4570457994644658 * x * (4 * zz - xx - yy);
  out[14] = 1.445305721320277 * z * (xx - yy);
  out[15] = -0.5900435899266435 * x * (xx - 3 * yy);
}

/// Direction j of the Fibonacci lattice of kDirections points.
void lattice_direction(int j, double d[3]) {
  const double golden_angle = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
  const double z = 1.0 - (2.0 * j + 1.0) / kDirections;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  d[0] = r * std::cos(golden_angle * j);
  d[1] = r * std::sin(golden_angle * j);
  d[2] = z;
}

/// Solves M·X = B in place for X (M [n, n], B [n, n], row-major; M symmetric positive definite here) by
/// Gauss-Jordan elimination with partial pivoting; B receives X.
void solve_in_place(int n, double* m, double* b) {
  for (int col = 0; col < n; ++col) {
    int pivot = col;
    for (int r = col + 1; r < n; ++r) {
      if (std::fabs(m[r * n + col]) > std::fabs(m[pivot * n + col])) pivot = r;
    }
    for (int c = 0; c < n; ++c) {
      std::swap(m[col * n + c], m[pivot * n + c]);
      std::swap(b[col * n + c], b[pivot * n + c]);
    }
    const double inv = 1.0 / m[col * n + col];
    for (int c = 0; c < n; ++c) {
      m[col * n + c] *= inv;
      b[col * n + c] *= inv;
    }
    for (int r = 0; r < n; ++r) {
      if (r == col) continue;
      const double f = m[r * n + col];
      if (f == 0) continue;
      for (int c = 0; c < n; ++c) {
        m[r * n + c] -= f * m[col * n + c];
        b[r * n + c] -= f * b[col * n + c];
      }
    }
  }
}

}  // namespace

ShRotation sh_rotation(const std::array<double, 9>& rotation) {
  // A[j][k] = Y_k(d_j), B[j][k] = Y_k(Rᵀ·d_j): the rotated colour towards d is the old colour towards Rᵀ·d, so
  // A·D = B per band, and D = (AᵀA)⁻¹·AᵀB.
  double a[kDirections][16], b[kDirections][16];
  for (int j = 0; j < kDirections; ++j) {
    double d[3], back[3];
    lattice_direction(j, d);
    for (int i = 0; i < 3; ++i) back[i] = rotation[i] * d[0] + rotation[3 + i] * d[1] + rotation[6 + i] * d[2];
    sh_basis_double(d, a[j]);
    sh_basis_double(back, b[j]);
  }
  ShRotation out;
  out.band[0][0] = 1.0;
  for (int l = 1; l <= 3; ++l) {
    const int n = 2 * l + 1, first = l * l;
    double ata[49] = {}, atb[49] = {};
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        for (int j = 0; j < kDirections; ++j) {
          ata[r * n + c] += a[j][first + r] * a[j][first + c];
          atb[r * n + c] += a[j][first + r] * b[j][first + c];
        }
      }
    }
    solve_in_place(n, ata, atb);
    std::copy(atb, atb + n * n, out.band[l].begin());
  }
  return out;
}

void rotate_sh(const ShRotation& rotation, uint32_t degree, size_t count, float* sh) {
  const int bands = static_cast<int>(std::min<uint32_t>(degree, 3));
  const size_t k_count = size_t(bands + 1) * size_t(bands + 1);
  for (size_t i = 0; i < count; ++i) {
    float* g = sh + i * k_count * 3;
    for (int l = 1; l <= bands; ++l) {
      const int n = 2 * l + 1, first = l * l;
      const double* d = rotation.band[l].data();
      for (int ch = 0; ch < 3; ++ch) {
        double in[7];
        for (int c = 0; c < n; ++c) in[c] = g[(first + c) * 3 + ch];
        for (int r = 0; r < n; ++r) {
          double sum = 0;
          for (int c = 0; c < n; ++c) sum += d[r * n + c] * in[c];
          g[(first + r) * 3 + ch] = static_cast<float>(sum);
        }
      }
    }
  }
}

}  // namespace rgs::converter
