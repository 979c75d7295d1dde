// Writes float Gaussians as a standard INRIA 3DGS PLY that other 3DGS tools load.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Serializes `cloud` in the exact INRIA `save_ply` layout: binary_little_endian float properties
/// x y z nx ny nz f_dc_0..2 f_rest_0..(3K-4) opacity scale_0..2 rot_0..3, normals 0, f_rest channel-major.
/// Inverse activations: opacity = logit(clamp(o, 1e-6, 1 - 1e-6)) (so opacity 1 from FP16 stays finite:
/// ±13.8155), scale = log(s) (s = 0 gives -inf, as the PLY format allows), rotation as given.
/// Errors: kInvalidArgument when the cloud is inconsistent.
Result<std::vector<uint8_t>> serialize_ply(const format::GaussianCloud& cloud);

/// serialize_ply() written atomically to `path` (no partial file, existing file untouched on failure).
/// Returns bytes written. Errors: as serialize_ply, kIoError naming `path`.
Result<uint64_t> write_ply(const std::string& path, const format::GaussianCloud& cloud);

}  // namespace rgs::converter
