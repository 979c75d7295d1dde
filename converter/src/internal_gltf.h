// glTF constants shared by the reader and the writer (private to rgs_converter).
#pragma once

#include <cstdint>

namespace rgs::converter::detail {

constexpr uint32_t kGlbMagic = 0x46546C67u;      // "glTF"
constexpr uint32_t kGlbChunkJson = 0x4E4F534Au;  // "JSON"
constexpr uint32_t kGlbChunkBin = 0x004E4942u;   // "BIN\0"
constexpr uint32_t kGlbHeaderBytes = 12;

constexpr int kGltfByte = 5120;
constexpr int kGltfUnsignedByte = 5121;
constexpr int kGltfShort = 5122;
constexpr int kGltfUnsignedShort = 5123;
constexpr int kGltfUnsignedInt = 5125;
constexpr int kGltfFloat = 5126;
constexpr int kGltfArrayBuffer = 34962;

constexpr const char* kKhrGaussianSplatting = "KHR_gaussian_splatting";
/// Coefficients per SH degree 1..3 in the extension's attribute names (m = −l..l).
constexpr int kGltfShCoefs[4] = {1, 3, 5, 7};

}  // namespace rgs::converter::detail
