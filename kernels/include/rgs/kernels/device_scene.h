// Device-memory views of a scene and of a camera, as the CUDA kernels take them (plain pointers and PODs:
// the runtime owns the memory, kernels only read and write through these views).
#pragma once

#include <cstdint>

#include "rgs/kernels/shared/projection.h"

namespace rgs::kernels {

/// FP32 Gaussians in device memory, the layout of format::GaussianCloud (structure of arrays, N = count):
/// - means      [N, 3] float32, world units;
/// - rotations  [N, 4] float32 quaternions (w, x, y, z), unit norm;
/// - scales     [N, 3] float32 linear scales, world units;
/// - opacities  [N]    float32 activated opacities (sigmoid applied), [0, 1];
/// - sh         [N, K, 3] float32 SH coefficients, K = (sh_degree + 1)², colour channel fastest.
/// What the 3DGS baseline pipeline reads (docs/DESIGN.md#baseline).
struct Fp32GaussiansView {
  const float* means = nullptr;
  const float* rotations = nullptr;
  const float* scales = nullptr;
  const float* opacities = nullptr;
  const float* sh = nullptr;
  uint32_t sh_degree = 0;
  uint32_t count = 0;
};

/// How the compact scales section encodes a scale (format/SPEC.md §4.5).
enum class CompactScaleEncoding : uint32_t { kLinear = 1, kLog = 2 };

/// Bytes to which the compact SH array's allocation is padded (CompactGaussiansView::sh).
constexpr uint64_t kCompactShPadding = 16;

/// The .rgs runtime profile in device memory, each array the raw bytes of its section (format/SPEC.md §4):
/// - means      [N, 3] float32;
/// - rotations  [N, 4] binary16 bits, (w, x, y, z), normalized before rounding;
/// - scales     [N, 3] binary16 bits, `scale_encoding` (linear, or natural log of the linear scale);
/// - opacities  [N]    binary16 bits of the activated opacity;
/// - sh         [N, K, 3] int8, value = sh_scales[d][c]·q (paper Eq. quant), d the degree of coefficient k;
///   its allocation is padded with zeros to a multiple of kCompactShPadding bytes, so that a kernel may read
///   a Gaussian's block with the aligned words that cover it;
/// - sh_dc_residual [N, 3] int8 or null: DC value = sh_scales[0][c]·(q + r/256) (SPEC §4.8), padded as `sh`.
struct CompactGaussiansView {
  const float* means = nullptr;
  const uint16_t* rotations = nullptr;
  const uint16_t* scales = nullptr;
  const uint16_t* opacities = nullptr;
  const int8_t* sh = nullptr;
  const int8_t* sh_dc_residual = nullptr;
  float sh_scales[4][3] = {};
  CompactScaleEncoding scale_encoding = CompactScaleEncoding::kLinear;
  uint32_t sh_degree = 0;
  uint32_t count = 0;
};

/// Per-frame camera and image parameters, passed to kernels by value. Conventions of runtime::Camera
/// (COLMAP frame; px = fx·x/z + cx − 0.5).
struct FrameParams {
  float view_rotation[9];   ///< world-to-camera R, row-major [3, 3]
  float view_translation[3];///< world-to-camera t
  float camera_centre[3];   ///< −Rᵀ·t, world units (SH view direction)
  float fx, fy, cx, cy;     ///< pixels
  float near_plane;         ///< cull view depth z ≤ near_plane
  EwaClamp ewa_clamp;       ///< ewa_clamp_for() of the camera
  float background[3];      ///< out = C + T·bg
  uint32_t width, height;   ///< pixels
  uint32_t tiles_x, tiles_y;///< ceil(W/16), ceil(H/16)
  /// The tile rows this pass emits pairs for and blends, [tile_row_begin, tile_row_end) ⊆ [0, tiles_y): the
  /// whole grid, or one group of rows of a frame rendered in groups (docs/RENDERER.md#bounded-pair-memory).
  /// Tile ids, keys and ranges stay those of the whole grid, so each tile's pairs are those of the whole frame.
  uint32_t tile_row_begin, tile_row_end;
  /// Nonzero for a scene trained with the 2D Mip filter: each opacity is scaled by antialias_compensation()
  /// of its projected covariance (format::SceneMetadata::antialiased).
  uint32_t antialiased;
};

/// `rect` without the tile rows outside the frame's rows [tile_row_begin, tile_row_end) (empty if none is left).
RGS_HOST_DEVICE TileRect rows_of_pass(const TileRect& rect, const FrameParams& frame) {
  TileRect r = rect;
  r.y_min = r.y_min > int(frame.tile_row_begin) ? r.y_min : int(frame.tile_row_begin);
  r.y_max = r.y_max < int(frame.tile_row_end) ? r.y_max : int(frame.tile_row_end);
  return r;
}

}  // namespace rgs::kernels
