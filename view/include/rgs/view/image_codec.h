// Frame images of rgs-view: 8-bit RGB encoded as JPEG (libturbojpeg) or WebP (libwebp, lossy or lossless), and
// the comparison of two frames (PSNR, difference heatmap) of its compare mode (view/PROTOCOL.md).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/view/protocol.h"

namespace rgs::parallel {
class WorkerPool;
}

namespace rgs::view {

/// Encodes an 8-bit RGB image. `rgb` [height, width, channels] uint8, row-major, tightly packed (channels·width
/// bytes a row), top row first, R, G, B first in each pixel; `channels` 3 or 4 (the fourth byte is ignored: the
/// front door's kRgba8 images as they are read back); width, height 1..16383 (WebP's limit; JPEG allows more). `quality` 1..100 (ignored for
/// kLossless). Deterministic for given input and options. Reentrant (each call has its own codec state).
/// With `workers` (JPEG only), a frame of enough rows is encoded by the pool's workers in strips joined into one
/// baseline JPEG with restart markers (encode_jpeg_strips in image_codec.cpp); it decodes to exactly the pixels
/// of the one-thread encoding. The pool must not be running another call.
/// @return the file bytes (a JPEG or a RIFF WebP); kInvalidArgument (size or quality out of range),
/// kOutOfMemory or kInvalidArgument with the codec's message when it fails.
Result<std::vector<uint8_t>> encode_rgb(const uint8_t* rgb, uint32_t width, uint32_t height, Encoding encoding,
                                        int quality, uint32_t channels = 3, parallel::WorkerPool* workers = nullptr);

/// Whether encode_rgb's JPEG at `quality` halves the chroma resolution (4:2:0, below 90) or keeps it (4:4:4).
bool jpeg_subsamples_chroma(int quality);

/// What encode_rgb's JPEG with `workers` threads is, for display: "JPEG: libjpeg-turbo on N threads, in strips
/// joined by restart markers" (or "in one thread").
std::string jpeg_encoder_name(unsigned workers);

/// How two 8-bit RGB images of one size differ.
struct ImageDifference {
  double mse = 0;  ///< mean over pixels and R, G, B of (a − b)², in 8-bit levels²
  /// 10·log10(255² / mse) dB; empty when the images are identical (mse 0).
  std::optional<double> psnr_db;
  uint32_t max_abs = 0;  ///< largest |a − b| over pixels and channels, 0..255
};

/// Compares `a` and `b`, both [height, width, channels] uint8 packed (`channels` 3 or 4, the fourth ignored). When `heatmap` is given it receives
/// [height, width, 3] uint8: per pixel the "turbo" colour map (Google, 2019; its 256-entry table's polynomial
/// approximation) at min(max_c |a_c − b_c| / diff_scale, 1): nearly black at 0, through blue, green and
/// yellow, to dark red at 1. diff_scale > 0.
ImageDifference compare_rgb(const uint8_t* a, const uint8_t* b, uint32_t width, uint32_t height, float diff_scale,
                            std::vector<uint8_t>* heatmap, uint32_t channels = 3);

}  // namespace rgs::view
