// Scene metadata stored in the .rgs metadata section (SPEC.md §4.1) and the provenance section (§4.2).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace rgs::format {

/// World frame of means, rotations and cameras. kColmap: the frame the scene was trained in, with
/// COLMAP/INRIA cameras (x right, y down, z forward).
enum class CoordinateFrame : uint8_t { kColmap = 1 };
/// Component order of the rotation quaternions. kWxyz: PLY rot_0..rot_3 = (w, x, y, z).
enum class QuaternionOrder : uint8_t { kWxyz = 1 };
/// How the scales section encodes a scale. kLinear: exp(PLY scale) (FP16 underflows below ~6e-8 and
/// loses relative precision below ~6e-5); kLog: the PLY's natural-log scale as is.
enum class ScaleEncoding : uint8_t { kLinear = 1, kLog = 2 };
/// How the opacities section encodes opacity. kSigmoid: activated, sigmoid(PLY opacity) in [0, 1].
enum class OpacityEncoding : uint8_t { kSigmoid = 1 };
/// Order of SH coefficients. kCoefficientMajor: [N, K, 3], channel fastest, k = l^2 + l + m with the
/// 3DGS basis signs (docs/DESIGN.md#spherical-harmonics), k = 0 the DC term.
enum class ShLayout : uint8_t { kCoefficientMajor = 1 };

/// Symmetric INT8 SH quantization (paper Eq. quant): q = round(SH / s[d][c]), SH^ = s[d][c] * q, with
/// one scale per SH degree d (0..3; d = 0 is the DC term) and colour channel c (R, G, B).
struct ShQuantization {
  /// Bits per quantized coefficient; version 1.0 knows only 8 (q in [-127, 127]).
  uint32_t bits = 8;
  /// Percentile of |SH| that maps to 127: 100 means the maximum (the paper's rule); below 100 clips the
  /// tail to ±127. In (0, 100].
  float clip_percentile = 100.0f;
  /// s[d][c], finite and >= 0; 0 when every coefficient of (d, c) is 0; rows d > sh_degree are 0.
  float scales[4][3] = {};
};

/// Axis-aligned box and bounding sphere of the Gaussian means, world units. The renderer derives a
/// camera's depth range [z_near, z_far] for the 32-bit depth key from the sphere (SPEC.md §4.1.2).
struct SceneBounds {
  float aabb_min[3] = {0, 0, 0};
  float aabb_max[3] = {0, 0, 0};
  float sphere_center[3] = {0, 0, 0};
  /// Contains every mean: |mean - center| <= radius holds in float32 for all Gaussians.
  float sphere_radius = 0;
};

/// Sets bounds->sphere_center to the midpoint of its AABB, computed in double and rounded to float32
/// (SPEC §4.1.1), and writes the stored centre as double into `center`: the point the radius is measured
/// from (sphere_radius_for).
void set_sphere_center(SceneBounds* bounds, double center[3]);

/// The bounding sphere's radius for the largest squared distance (double) of a mean from the stored centre:
/// sqrt(max_squared_distance) · (1 + 1e-6), rounded up to float32 (+inf beyond its range), so that
/// |mean − centre| ≤ radius also holds when a consumer evaluates the distance in float32.
float sphere_radius_for(double max_squared_distance);

/// The float32 at or above v (v ≥ 0 finite).
float round_up_float(double v);

/// The box of `n` ≥ 1 means ([n, 3] float32): lo[a] and hi[a] the smallest and largest coordinate on axis a.
void box_of_means(const float* means, uint64_t n, float lo[3], float hi[3]);

/// The largest squared distance, in double, of `n` means ([n, 3] float32) from `center` (sphere_radius_for's
/// argument); 0 for none.
double max_squared_distance(const float* means, uint64_t n, const double center[3]);

/// Content of the metadata section.
struct SceneMetadata {
  uint32_t sh_degree = 0;  ///< 0..3
  CoordinateFrame frame = CoordinateFrame::kColmap;
  QuaternionOrder quaternion_order = QuaternionOrder::kWxyz;
  ScaleEncoding scale_encoding = ScaleEncoding::kLinear;
  OpacityEncoding opacity_encoding = OpacityEncoding::kSigmoid;
  ShLayout sh_layout = ShLayout::kCoefficientMajor;
  SceneBounds bounds;
  ShQuantization sh_quantization;
  /// The scene was trained with the 2D Mip filter (Mip-Splatting, Yu et al. CVPR 2024; gsplat's
  /// rasterize_mode="antialiased"): every renderer scales each opacity by the filter's compensation
  /// sqrt(det Σ₂ / det(Σ₂ + 0.3·I)) of its projected covariance Σ₂ (kernels::antialias_compensation). Stored as
  /// the header's required flag kRequiredFlagAntialiased (SPEC §2.2), not in the metadata record.
  bool antialiased = false;
};

/// Ordered key/value strings (UTF-8) saying where a file came from: source file name, size and hash,
/// converter version, options. Never a timestamp or host name, so conversions stay deterministic.
using Provenance = std::vector<std::pair<std::string, std::string>>;

/// Shared by writer and reader (CONTRIBUTING.md#format-changes): true when `q` is a valid quantization for `sh_degree`.
/// On false, `why` (if not null) receives the reason.
bool is_valid_quantization(const ShQuantization& q, uint32_t sh_degree, std::string* why);

/// Short names for tools ("colmap", "wxyz", "linear", "log", "sigmoid", "coefficient-major").
const char* to_string(CoordinateFrame v);
const char* to_string(QuaternionOrder v);
const char* to_string(ScaleEncoding v);
const char* to_string(OpacityEncoding v);
const char* to_string(ShLayout v);

}  // namespace rgs::format
