// What the image of one frame needs, counted pixel by pixel with the CPU reference's 3DGS rules: how many
// Gaussians each pixel blends, how many it tests in vain, and how many (cell, Gaussian) pairs a renderer
// needs at 16×16, 8×8 and 4×4 cells. These counts give the true floor of a frame (floor_work in
// roofline_model.h; docs/lab/ROOFLINE.md#the-true-floor): the work any algorithm must do for this image, as
// opposed to the work of the pipeline rgs-bench times.
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"

namespace rgs::lab {

/// Cell sizes of FrameCensus's pair counts: 16×16 tiles, 8×8 sub-tiles, 4×4 blocks.
enum class CensusCell : int { k16 = 0, k8 = 1, k4 = 2 };
inline constexpr int kCensusCells = 3;

/// Counts of one frame under the 3DGS conventions (docs/DESIGN.md#conventions): per pixel, front to back over
/// its tile's depth-sorted list, a Gaussian *blends* when power ≤ 0, α = min(0.99, o·exp(power)) ≥ 1/255 and
/// T·(1 − α) ≥ 10⁻⁴; the walk ends at the first Gaussian that would take T below 10⁻⁴.
struct FrameCensus {
  uint32_t width = 0, height = 0;
  uint64_t gaussians = 0;  ///< N, Gaussians in the scene
  uint64_t visible = 0;    ///< Gaussians with at least one tile of their 3DGS rectangle (3DGS preprocess)
  /// Gaussians that blend at one pixel or more: the only ones whose attributes the image needs.
  uint64_t contributing = 0;
  /// (tile, Gaussian) pairs of the 3DGS rectangles (3σ, 16×16 tiles): what the 3DGS rasterizer sorts.
  uint64_t rect_pairs = 0;
  /// Σ over pixels of the Gaussians blended. With `pixels`, the mean depth complexity of the image.
  uint64_t blended = 0;
  /// Σ over pixels of the Gaussians tested before the pixel's walk ends that do not blend (power > 0 or
  /// α < 1/255): the 3DGS rasterizer's evaluations that change nothing.
  uint64_t skipped = 0;
  /// Most Gaussians blended by one pixel.
  uint32_t max_blended = 0;
  /// [CensusCell] (cell, Gaussian) pairs where the Gaussian blends at one pixel of the cell or more: what a
  /// renderer with exact per-cell lists would sort and load.
  uint64_t blending_pairs[kCensusCells] = {0, 0, 0};
  /// [CensusCell] (cell, Gaussian) pairs where α ≥ 1/255 at one pixel of the cell or more, whatever the
  /// transmittance there: what exact culling without knowledge of the image emits (≥ blending_pairs).
  uint64_t reaching_pairs[kCensusCells] = {0, 0, 0};
  /// 16×16 tiles where every pixel's walk ended (T would fall below 10⁻⁴) before the end of the tile's list.
  uint64_t saturated_tiles = 0;
  /// 3DGS pairs at or beyond their tile's saturation position (the largest index at which a pixel of the tile
  /// ended its walk): no pixel of the tile tests them, so an exact occlusion cull could skip emitting, sorting and
  /// ranging them (docs/lab/OCCLUSION.md).
  uint64_t hidden_rect_pairs = 0;
  /// The reaching 16×16 pairs (reaching_pairs[k16]) among hidden_rect_pairs: the hidden share of what an exact
  /// emission keeps.
  uint64_t hidden_reaching_pairs = 0;

  uint64_t pixels() const { return uint64_t(width) * height; }
};

/// Counts `cloud` seen from `camera` (any size up to 32768², validate_camera). Multithreaded over tile rows
/// (`num_threads`, 0 = every CPU); the counts do not depend on the thread count. Memory: the 3DGS pairs of
/// the frame (13 bytes each) and the projected Gaussians.
/// @param blended_map  when not null: [H, W] uint16, row-major, the Gaussians each pixel blends (at most
///                     2,344: each blend leaves T ≤ 254/255 of what it was, and T stays ≥ 10⁻⁴).
/// @return kInvalidArgument (inconsistent cloud or camera), kLimitExceeded, kOutOfMemory: those of render_cpu.
Result<FrameCensus> census_frame(const format::GaussianCloud& cloud, const runtime::Camera& camera, unsigned num_threads = 0,
                                 std::vector<uint16_t>* blended_map = nullptr);

}  // namespace rgs::lab
