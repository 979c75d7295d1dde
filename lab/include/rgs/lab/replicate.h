// Larger test scenes from real ones: K offset copies of a scene (rgs-bench --replicate K).
#pragma once

#include <cstdint>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/status.h"

namespace rgs::lab {

/// `copies` copies of `scene` laid out on a grid in the horizontal x–z plane (y points down in 3DGS scenes):
/// ceil(sqrt(K)) columns along x, rows along z, copy i at column i % cols, row i / cols. The spacing on each
/// axis is the 2nd–98th percentile extent of the means on that axis (floaters would inflate the full AABB),
/// so the dense parts of neighbouring copies just touch. Every attribute is copied unchanged (same SH
/// quantization scales); means are offset in float32; bounds are recomputed; provenance gains
/// "replicated" = K. The grid is centred on the original scene's position.
/// Errors: kInvalidArgument (copies 0, inconsistent scene), kLimitExceeded (more than 2^31 − 1 Gaussians).
Result<format::EncodedScene> replicate(const format::EncodedScene& scene, uint32_t copies);

}  // namespace rgs::lab
