// Writes float Gaussians as binary glTF (GLB) with the KHR_gaussian_splatting extension.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/file_io.h"
#include "rgs/format/status.h"

namespace rgs::converter {

struct GltfWriteOptions {
  /// Convert from RoofGS's PLY/COLMAP frame (RDF: y down, z forward) to glTF's right-handed y-up frame
  /// (+y up, +z forward, −x right: "LUF"), the 180° rotation about z: x → −x, y → −y; read_gltf
  /// documents it. False stores the axes unchanged.
  bool convert_frame = true;
  /// Also write COLOR_0 (RGBA8, linear) so viewers without the extension show a coloured point cloud.
  bool color_fallback = true;
  /// asset.generator string.
  std::string generator = "RoofGS rgs_converter";
};

/// What the GLB output keeps and loses, for the conversion summary.
struct GltfWriteSummary {
  uint32_t sh_degree = 0;
  uint64_t gaussians = 0;
  uint64_t bytes = 0;
  /// What the format cannot carry, one sentence each (empty apart from frame and colour-space notes:
  /// every attribute is stored as float32).
  std::vector<std::string> limitations;
};

/// Encodes `cloud` (consistent and finite) as one GLB: a point primitive (mode 0) with POSITION (VEC3
/// float, min/max), KHR_gaussian_splatting:ROTATION (VEC4 float, x y z w), :SCALE (VEC3 float, linear),
/// :OPACITY (SCALAR float, activated), :SH_DEGREE_0_COEF_0 and :SH_DEGREE_l_COEF_n for every degree of
/// the cloud (VEC3 float, coefficient m = n − l); kernel "ellipse", colorSpace "srgb_rec709_display"
/// (3DGS training fits display sRGB), one node without transform. Values are copied bit for bit apart
/// from the sign flips of the frame conversion, so read_gltf returns the cloud exactly. Deterministic.
/// Errors: kInvalidArgument (inconsistent or non-finite cloud, more than 2^32 − 1 Gaussians or a
/// buffer over 4 GiB, the GLB size limit).
Result<std::vector<uint8_t>> serialize_glb(const format::GaussianCloud& cloud, const GltfWriteOptions& options = {},
                                           GltfWriteSummary* summary = nullptr);

/// serialize_glb() written atomically to `path`. Errors: as serialize_glb, kIoError naming `path`.
Result<GltfWriteSummary> write_glb(const std::string& path, const format::GaussianCloud& cloud,
                                   const GltfWriteOptions& options = {},
                                   format::FileSink& files = format::atomic_files());

}  // namespace rgs::converter
