// Conversion of a rendered float RGBA frame into a caller's image: pixel format, row pitch, alpha and depth;
// and of an 8-bit RGBA image into packed RGB for an encoder.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>

namespace rgs::kernels {

/// Pixel formats of a caller's colour image; 4 channels R, G, B, A in that order in memory.
enum class OutputPixelFormat : uint32_t {
  kRgba32f = 0,  ///< 4 × float32 (16 B/pixel), values as rendered (not clamped)
  kRgba16f = 1,  ///< 4 × IEEE binary16 (8 B/pixel), round to nearest even (values above 65504 become inf)
  kRgba8 = 2,    ///< 4 × uint8 (4 B/pixel), floor(clamp(v, 0, 1)·255 + 0.5) (the 3DGS 8-bit rule)
};

/// Inputs of launch_convert_output(). All pointers are device memory.
struct OutputConvertParams {
  /// [H, W, 4] float32 RGBA as the render kernels write it (row-major, top row first, tightly packed).
  const float* rgba = nullptr;
  /// [H, W] float32 expected depth, or null (then no depth is written).
  const float* depth = nullptr;
  uint32_t width = 0, height = 0;
  /// Colour destination: row y starts at color + y·color_pitch bytes; pitch ≥ width·bytes per pixel.
  void* color = nullptr;
  size_t color_pitch = 0;
  OutputPixelFormat format = OutputPixelFormat::kRgba32f;
  /// False: the A channel is written as 1 (opaque) instead of the rendered 1 − T.
  bool write_alpha = true;
  /// Depth destination (float32, row y at depth_out + y·depth_pitch bytes), or null.
  float* depth_out = nullptr;
  size_t depth_pitch = 0;
};

/// Writes the frame in `params.rgba` (and depth) to the caller's image with format conversion, one thread
/// per pixel, on `stream`. No-op for a zero size. Returns the launch error (cudaGetLastError folded in).
cudaError_t launch_convert_output(const OutputConvertParams& params, cudaStream_t stream);

/// Packs an 8-bit RGBA image (row y at rgba + y·rgba_pitch bytes) into tightly packed [H, W, 3] RGB at `rgb`
/// (the interleaved input of a JPEG encoder), alpha dropped, on `stream`. Device pointers; no-op for a zero
/// size. Returns the launch error.
cudaError_t launch_pack_rgb8(const uint8_t* rgba, size_t rgba_pitch, uint32_t width, uint32_t height, uint8_t* rgb,
                             cudaStream_t stream);

}  // namespace rgs::kernels
