// Geometry of the 3DGS preprocess: 3D covariance, view transform, pixel projection, EWA 2D covariance,
// conic, screen radius and the tile rectangle, exactly as docs/DESIGN.md#cameras-and-projection
// lists them (the public 3DGS rasterizer, forward.cu / auxiliary.h). Shared by the CPU reference and the
// CUDA kernels.
#pragma once

#include "rgs/kernels/shared/host_device.h"

namespace rgs::kernels {

/// Cameras cull every Gaussian whose view-space depth z satisfies z <= this (3DGS in_frustum()).
constexpr float kDefaultNearPlane = 0.2f;
/// The EWA Jacobian is evaluated at x/z, y/z clamped to this factor times the image half-extent in
/// normalized coordinates (3DGS: ±1.3·tan(fov/2)).
constexpr float kEwaClampFactor = 1.3f;
/// Added to both diagonal entries of the 2D covariance (3DGS low-pass filter), in pixels².
constexpr float kCovarianceDilation = 0.3f;

/// Symmetric 2x2 covariance in pixels²: [[xx, xy], [xy, yy]].
struct Cov2 {
  float xx, xy, yy;
};

/// Inverse of a Cov2 as the 3DGS rasterizer stores it (float3 conic): [[a, b], [b, c]] =
/// (yy, -xy, xx) / det. The Gaussian's quadratic form at offset (dx, dy) is a·dx² + 2b·dx·dy + c·dy².
struct Conic {
  float a, b, c;
};

/// Half-open rectangle of tiles [x_min, x_max) × [y_min, y_max); empty when either side has no tile.
struct TileRect {
  int x_min, y_min, x_max, y_max;
};

/// True when `r` covers no tile.
RGS_HOST_DEVICE bool is_empty(const TileRect& r) { return r.x_max <= r.x_min || r.y_max <= r.y_min; }

/// Number of tiles in `r` (0 when empty).
RGS_HOST_DEVICE int tile_area(const TileRect& r) {
  return is_empty(r) ? 0 : (r.x_max - r.x_min) * (r.y_max - r.y_min);
}

/// Rotation matrix R (row-major [3, 3]) of the unit quaternion (w, x, y, z); the standard right-handed
/// formula (3DGS computeCov3D builds its transpose in column-major glm, which is the same matrix).
RGS_HOST_DEVICE void quaternion_to_rotation(float w, float x, float y, float z, float R[9]) {
  R[0] = 1.f - 2.f * (y * y + z * z);
  R[1] = 2.f * (x * y - w * z);
  R[2] = 2.f * (x * z + w * y);
  R[3] = 2.f * (x * y + w * z);
  R[4] = 1.f - 2.f * (x * x + z * z);
  R[5] = 2.f * (y * z - w * x);
  R[6] = 2.f * (x * z - w * y);
  R[7] = 2.f * (y * z + w * x);
  R[8] = 1.f - 2.f * (x * x + y * y);
}

/// World-space 3D covariance Σ = R·S·Sᵀ·Rᵀ of a Gaussian with linear scales `scale` (world units) and unit
/// quaternion `q` = (w, x, y, z). Output: the upper triangle (xx, xy, xz, yy, yz, zz), as 3DGS stores it.
RGS_HOST_DEVICE void covariance_3d(const float scale[3], const float q[4], float cov[6]) {
  float R[9];
  quaternion_to_rotation(q[0], q[1], q[2], q[3], R);
  float M[9];  // M = R·S: column j of R scaled by scale[j]
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) M[i * 3 + j] = R[i * 3 + j] * scale[j];
  }
  // Σ = M·Mᵀ
  auto dot_rows = [&M](int i, int k) {
    return M[i * 3 + 0] * M[k * 3 + 0] + M[i * 3 + 1] * M[k * 3 + 1] + M[i * 3 + 2] * M[k * 3 + 2];
  };
  cov[0] = dot_rows(0, 0);
  cov[1] = dot_rows(0, 1);
  cov[2] = dot_rows(0, 2);
  cov[3] = dot_rows(1, 1);
  cov[4] = dot_rows(1, 2);
  cov[5] = dot_rows(2, 2);
}

/// View transform p_cam = R·p + t with R row-major [3, 3] world-to-camera (COLMAP camera frame: x right,
/// y down, z forward). Summation order as 3DGS transformPoint4x3: ((R0·x + R1·y) + R2·z) + t.
RGS_HOST_DEVICE void world_to_camera(const float R[9], const float t[3], const float p[3], float out[3]) {
  for (int i = 0; i < 3; ++i) out[i] = R[i * 3 + 0] * p[0] + R[i * 3 + 1] * p[1] + R[i * 3 + 2] * p[2] + t[i];
}

/// Pixel coordinates of a camera-space point: px = fx·x/z + cx − 0.5, py = fy·y/z + cy − 0.5, evaluated as
/// ((fx·x)/z + cx) − 0.5. Pixel centres are at integers: pixel (i, j) covers [i − 0.5, i + 0.5]. With
/// cx = W/2, cy = H/2 this is the 3DGS ndc2Pix convention. Requires z > 0.
RGS_HOST_DEVICE void project_to_pixel(const float p_cam[3], float fx, float fy, float cx, float cy,
                                      float* px, float* py) {
  *px = fx * p_cam[0] / p_cam[2] + cx - 0.5f;
  *py = fy * p_cam[1] / p_cam[2] + cy - 0.5f;
}

/// Limits of x/z and y/z at which the EWA Jacobian is clamped: x/z ∈ [−left, right], y/z ∈ [−top, bottom].
/// All four are positive for a principal point inside the image.
struct EwaClamp {
  float left, right, top, bottom;
};

/// EWA clamp of a camera with focal lengths fx, fy and principal point (cx, cy) for a width × height
/// image: 1.3 times the normalized distance from the principal point to each image edge, taken per side:
/// left = 1.3·cx/fx, right = 1.3·(W − cx)/fx, top = 1.3·cy/fy, bottom = 1.3·(H − cy)/fy. With cx = W/2 and
/// cy = H/2 both sides equal 1.3·tan(fov/2), the 3DGS rule (tan_fovx = W / (2 fx)).
RGS_HOST_DEVICE EwaClamp ewa_clamp_for(float fx, float fy, float cx, float cy, float width, float height) {
  return EwaClamp{kEwaClampFactor * (cx / fx), kEwaClampFactor * ((width - cx) / fx),
                  kEwaClampFactor * (cy / fy), kEwaClampFactor * ((height - cy) / fy)};
}

/// EWA splatting (Zwicker et al. 2002, 3DGS computeCov2D): cov2D = J·W·Σ·Wᵀ·Jᵀ + 0.3·I in pixels², with W
/// the world-to-camera rotation (row-major), Σ the world covariance (upper triangle, covariance_3d) and J
/// the Jacobian of the perspective projection evaluated at the camera-space mean whose x/z and y/z are
/// first clamped to `clamp` (so Gaussians far outside the view do not get exploding footprints).
RGS_HOST_DEVICE Cov2 ewa_covariance_2d(const float cov3d[6], const float W[9], const float p_cam[3], float fx,
                                       float fy, const EwaClamp& clamp) {
  const float z = p_cam[2];
  const float txtz = p_cam[0] / z;
  const float tytz = p_cam[1] / z;
  const float x = fminf(clamp.right, fmaxf(-clamp.left, txtz)) * z;
  const float y = fminf(clamp.bottom, fmaxf(-clamp.top, tytz)) * z;

  // Jacobian rows: J0 = (fx/z, 0, −fx·x/z²), J1 = (0, fy/z, −fy·y/z²).
  const float j00 = fx / z;
  const float j02 = -(fx * x) / (z * z);
  const float j11 = fy / z;
  const float j12 = -(fy * y) / (z * z);

  // T = J·W (2 x 3).
  float T[6];
  for (int c = 0; c < 3; ++c) {
    T[c] = j00 * W[0 * 3 + c] + j02 * W[2 * 3 + c];
    T[3 + c] = j11 * W[1 * 3 + c] + j12 * W[2 * 3 + c];
  }
  const float S[9] = {cov3d[0], cov3d[1], cov3d[2], cov3d[1], cov3d[3], cov3d[4], cov3d[2], cov3d[4], cov3d[5]};
  // U = T·Σ (2 x 3), then cov = U·Tᵀ.
  float U[6];
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 3; ++c) {
      U[r * 3 + c] = T[r * 3 + 0] * S[0 * 3 + c] + T[r * 3 + 1] * S[1 * 3 + c] + T[r * 3 + 2] * S[2 * 3 + c];
    }
  }
  Cov2 cov;
  cov.xx = U[0] * T[0] + U[1] * T[1] + U[2] * T[2];
  cov.xy = U[0] * T[3] + U[1] * T[4] + U[2] * T[5];
  cov.yy = U[3] * T[3] + U[4] * T[4] + U[5] * T[5];
  cov.xx += kCovarianceDilation;
  cov.yy += kCovarianceDilation;
  return cov;
}

/// Determinant xx·yy − xy² of a 2D covariance (3DGS: cull the Gaussian only when it is exactly 0).
RGS_HOST_DEVICE float determinant(const Cov2& cov) { return cov.xx * cov.yy - cov.xy * cov.xy; }

/// The opacity factor of a scene trained with the 2D Mip filter (Mip-Splatting, Yu et al. CVPR 2024, Eq. 9;
/// gsplat's rasterize_mode="antialiased" `compensations`): sqrt(det Σ₂ / det(Σ₂ + s·I)), with `cov` = Σ₂ + s·I the
/// dilated covariance (ewa_covariance_2d, s = kCovarianceDilation) and `det` its determinant (≠ 0). Σ₂'s own
/// determinant is (xx − s)(yy − s) − xy², taken as 0 where rounding makes it negative. In [0, 1]: 1 for a
/// Gaussian much larger than a pixel, → 0 for one much smaller, which the dilation would otherwise draw as a
/// pixel-sized blob at full opacity.
RGS_HOST_DEVICE float antialias_compensation(const Cov2& cov, float det) {
  const float undilated = (cov.xx - kCovarianceDilation) * (cov.yy - kCovarianceDilation) - cov.xy * cov.xy;
  return sqrtf(fmaxf(undilated, 0.f) / det);
}

/// Conic (inverse covariance) (yy, −xy, xx) / det, computed as 3DGS does with det_inv = 1/det. det ≠ 0.
RGS_HOST_DEVICE Conic conic_from_covariance(const Cov2& cov, float det) {
  const float det_inv = 1.f / det;
  return Conic{cov.yy * det_inv, -cov.xy * det_inv, cov.xx * det_inv};
}

/// Screen-space radius in pixels: ceil(3·sqrt(λmax)) with λ = mid ± sqrt(max(0.1, mid² − det)),
/// mid = (xx + yy)/2 (3DGS). Returned as an int, clamped to 2^30 so absurd footprints cannot overflow.
RGS_HOST_DEVICE int screen_radius(const Cov2& cov, float det) {
  const float mid = 0.5f * (cov.xx + cov.yy);
  const float root = sqrtf(fmaxf(0.1f, mid * mid - det));
  const float lambda1 = mid + root;
  const float lambda2 = mid - root;
  const float radius = ceilf(3.f * sqrtf(fmaxf(lambda1, lambda2)));
  return static_cast<int>(fminf(radius, 1073741824.f));
}

/// Truncates v/16 toward zero like the C cast (int)(v / 16) and clamps to [0, grid]. `v` is first limited to
/// [−16, 16·grid + 16], which changes no result (all those values clamp the same) but keeps the cast
/// defined for huge or non-finite inputs (NaN maps to −16, hence 0).
RGS_HOST_DEVICE int truncate_to_tile(float v, int grid) {
  const float limited = fminf(fmaxf(v, -16.f), 16.f * static_cast<float>(grid) + 16.f);
  return clamp_int(static_cast<int>(limited / static_cast<float>(kTileSize)), 0, grid);
}

/// The 3DGS tile rectangle getRect(): with radius r (int) and the float mean (px, py),
/// x_min = clamp((int)((px − r)/16), 0, gx), x_max = clamp((int)((px + r + 15)/16), 0, gx) (exclusive), the
/// same in y. The (int) cast truncates toward zero. Note this is not floor((px ± r)/16) inclusive: for
/// px + r = 32.5 it gives x_max = 2 and leaves out tile 2, which holds pixel 32 (docs/DESIGN.md#conventions).
RGS_HOST_DEVICE TileRect tile_rect(float px, float py, int radius, int grid_x, int grid_y) {
  const float r = static_cast<float>(radius);
  TileRect rect;
  rect.x_min = truncate_to_tile(px - r, grid_x);
  rect.y_min = truncate_to_tile(py - r, grid_y);
  rect.x_max = truncate_to_tile(px + r + static_cast<float>(kTileSize - 1), grid_x);
  rect.y_max = truncate_to_tile(py + r + static_cast<float>(kTileSize - 1), grid_y);
  return rect;
}

}  // namespace rgs::kernels
