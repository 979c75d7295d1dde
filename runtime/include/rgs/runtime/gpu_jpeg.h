// Baseline JPEG encoding of 8-bit RGBA images in device memory with nvJPEG (CUDA builds only: rgs/config.h
// RGS_HAS_CUDA). nvJPEG is loaded at run time (dlopen), never linked, so every binary still runs where it is
// absent; the libraries tried are listed in docs/VIEWER.md#frames-encoded-on-the-gpu.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/runtime/device_buffer.h"

namespace rgs::runtime {

/// One thread's nvJPEG encoder: its handle, encoder state and parameters, and a packed-RGB scratch image kept
/// (and grown) between calls. Not thread-safe; move-only.
class GpuJpegEncoder {
 public:
  /// An encoder on the current CUDA device. Errors: kUnsupportedFeature (no libnvjpeg could be loaded, or it
  /// lacks an encoder entry point: the message names the libraries tried), kCudaError (nvJPEG's own setup).
  static Result<GpuJpegEncoder> create();

  GpuJpegEncoder(GpuJpegEncoder&&) noexcept;
  GpuJpegEncoder& operator=(GpuJpegEncoder&&) noexcept;
  ~GpuJpegEncoder();

  /// The library in use, e.g. "nvJPEG 13.0.1 (libnvjpeg.so.13)".
  const std::string& name() const;

  /// Encodes `rgba` ([H, W, 4] uint8 R, G, B, A in device memory, row y at rgba + y·pitch bytes; alpha
  /// ignored) as a baseline YCbCr JPEG with the standard tables scaled to `quality` (1..100), chroma at half
  /// resolution in both directions (4:2:0) when `subsample_chroma`, else 4:4:4. Enqueued on `stream` after the work already there; waits on the host
  /// for the bitstream, which replaces `jpeg`'s contents.
  /// Errors: kInvalidArgument (null, zero or over-65535 size, pitch < 4·width, quality out of range),
  /// kOutOfMemory, kCudaError (a CUDA or nvJPEG call failed, named with its status code).
  Status encode(const uint8_t* rgba, size_t pitch, uint32_t width, uint32_t height, int quality,
                bool subsample_chroma, cudaStream_t stream, std::vector<uint8_t>* jpeg);

  struct State;

 private:
  explicit GpuJpegEncoder(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace rgs::runtime
