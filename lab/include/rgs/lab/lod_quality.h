// The level-of-detail quality measures of the benchmarks (docs/LOD.md#measuring-quality): the 2×2 supersampled
// reference and the frame-to-frame change behind the popping measure.
#pragma once

#include <vector>

#include "rgs/format/status.h"
#include "rgs/runtime/image_metrics.h"

namespace rgs::lab {

/// Area (box) downsample by 2 on each axis: output pixel (i, j) is the mean of input pixels (2i..2i+1, 2j..2j+1),
/// every channel, in float64, stored as float32. With a camera of twice the width, height, fx, fy, cx and cy
/// (resize_camera to 2W × 2H), whose pixel (2i + a, 2j + b) centre lies at (i + (2a − 1)/4, j + (2b − 1)/4) of
/// the 1× camera, this is the 2×2 supersampled render of the 1× view: the reference against which level-of-detail
/// renders are scored (docs/LOD.md#measuring-quality).
/// @param image  [2H, 2W, C] float32, row-major, top row first; width and height even and ≥ 2.
/// @return [H, W, C] float32, same channel order; kInvalidArgument for a null image or an odd or zero side.
/// Deterministic; single-threaded.
Result<std::vector<float>> area_downsample_2x(const runtime::ImageRef& image);

/// Mean absolute difference of two images of the same size over the H·W·3 clamped R, G, B values (each clamped to
/// [0, 1] first, NaN as 0), in [0, 1]; multiply by 255 for 8-bit levels. Along a camera path, its mean over
/// consecutive frames is the frame-to-frame change that the popping measure compares (docs/LOD.md#measuring-quality).
/// @return kInvalidArgument when sizes differ, a pointer is null, channels < 3 or the image is empty.
/// Deterministic; single-threaded; float64 accumulation.
Result<double> mean_abs_difference(const runtime::ImageRef& a, const runtime::ImageRef& b);

}  // namespace rgs::lab
