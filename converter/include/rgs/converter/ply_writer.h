// Writes float Gaussians as a standard INRIA 3DGS PLY that other 3DGS tools load.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/file_io.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Natural-log scale written for a scale of 0: ln(2^-25) ≈ -17.33, the log of the largest scale that
/// linear FP16 stores as 0 (SPEC §4.5). Converting such a PLY back with linear scales gives 0 again; every
/// other 3DGS tool reads a finite, vanishingly thin axis (the rasterizer's 0.3 px² dilation covers it).
inline constexpr float kZeroScaleLog = -17.328679513998633f;

/// What writing a PLY changed, for the tools' summaries.
struct PlyWriteReport {
  /// Scale values that were 0 (linear FP16 underflow of scales below 2^-25) and were written as
  /// kZeroScaleLog instead of log(0) = -inf.
  uint64_t zero_scales = 0;
};

/// Serializes `cloud` in the exact INRIA `save_ply` layout: binary_little_endian float properties
/// x y z nx ny nz f_dc_0..2 f_rest_0..(3K-4) opacity scale_0..2 rot_0..3, normals 0, f_rest channel-major.
/// Every value written is finite. Inverse activations: opacity = logit(clamp(o, 1e-6, 1 - 1e-6)) (so
/// opacity 1 from FP16 stays finite: ±13.8155), scale = log(s) with s = 0 written as kZeroScaleLog
/// (counted in `report`), rotation as given; but where the cloud holds GaussianCloud::pre_activation, each of
/// those that is finite and still activates to the Gaussian's opacity or scale is written as it is, so a PLY
/// read and written again with no edit keeps its opacity logits and log scales bit for bit.
/// Errors: kInvalidArgument when the cloud is inconsistent, or holds a non-finite or negative value
/// (naming the Gaussian), kOutOfMemory.
Result<std::vector<uint8_t>> serialize_ply(const format::GaussianCloud& cloud, PlyWriteReport* report = nullptr);

/// serialize_ply() written atomically to `path` (no partial file, existing file untouched on failure).
/// Returns bytes written. Errors: as serialize_ply, kIoError naming `path`.
Result<uint64_t> write_ply(const std::string& path, const format::GaussianCloud& cloud,
                           PlyWriteReport* report = nullptr, format::FileSink& files = format::atomic_files());

}  // namespace rgs::converter
