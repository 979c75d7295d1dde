// KHR_gaussian_splatting glTF: reads GLB and .gltf files, writes float Gaussians as binary glTF (GLB).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/interop.h"
#include "rgs/format/file_io.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Largest glTF JSON accepted (kLimitExceeded above it): splat assets keep their data in buffers.
constexpr uint64_t kMaxGltfJsonBytes = uint64_t{64} << 20;

/// True when `head` (the first `n` bytes; pass at least 64) starts a GLB ("glTF" magic, version 2), or
/// a JSON object (after optional UTF-8 BOM and whitespace) whose head mentions "asset" or
/// "KHR_gaussian_splatting". Whether it holds splats is known only after reading it.
bool looks_like_gltf(const uint8_t* head, size_t n);

/// Reads every KHR_gaussian_splatting primitive of the default scene (or of every mesh when the asset
/// has no scene), in node order, into one cloud (KHR_gaussian_splatting README; converter/INTEROP.md).
/// Attributes, found by semantic: POSITION (VEC3), KHR_gaussian_splatting:ROTATION (VEC4, x y z w;
/// float or normalized byte/short), :SCALE (VEC3 linear; float, byte or short, normalized or not),
/// :OPACITY (SCALAR in [0, 1]; float or normalized unsigned byte/short), :SH_DEGREE_0_COEF_0 and
/// :SH_DEGREE_l_COEF_n (VEC3 float, n = m + l) with every degree complete up to the highest present.
/// Accessors may be interleaved (byteStride); sparse accessors are kUnsupportedFeature. A node's world
/// transform is applied when it is a rotation, a uniform positive scale and a translation (means
/// transformed, scales multiplied, rotation composed); a shear or non-uniform scale, or any rotation
/// of a cloud with SH degree >= 1 (its coefficients would need a Wigner-D rotation), is
/// kUnsupportedFeature.
///
/// Frame: glTF is right-handed with +y up, +z forward and −x right ("LUF"); with convert_frame the
/// reader applies the 180° rotation about z into RDF: x → −x, y → −y, quaternion (w, x, y, z) →
/// (w, −x, −y, z), SH signs of that rotation. Buffers: the GLB BIN chunk, base64 data: URIs, and
/// relative file URIs next to a .gltf file (not for read_gltf_bytes).
///
/// Errors name `path`: kIoError (unreadable file or buffer, GLB shorter than its header says),
/// kCorruptData (not glTF, bad JSON, missing or mistyped attribute, accessor outside its buffer,
/// counts differing between attributes, mode not POINTS, partial SH degree, invalid values under
/// kReject), kUnsupportedVersion (GLB or asset version other than 2), kUnsupportedFeature (no
/// KHR_gaussian_splatting primitive, kernel other than "ellipse", an unknown extension in
/// extensionsRequired, sparse accessors, external URIs in memory, node transforms as above),
/// kLimitExceeded (more than max_gaussians, JSON over kMaxGltfJsonBytes), kOutOfMemory.
Result<InteropScene> read_gltf(const std::string& path, const InteropReadOptions& options = {});

/// Same as read_gltf on a GLB or self-contained .gltf in memory. `name` is used in error messages.
Result<InteropScene> read_gltf_bytes(const uint8_t* data, size_t size, const std::string& name,
                                     const InteropReadOptions& options = {});

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
