// Image output of rgs-render and rgs-audit. PPM/PGM (8-bit) and PFM (float) are written here without any
// library, so they exist in every build; PNG and EXR go through OpenImageIO and exist only when the build has
// it (CMake option RGS_WITH_OPENIMAGEIO; GPU-host builds leave it OFF: CONTRIBUTING.md#one-build-two-hosts). Every
// writer writes into the sink it is given: the run's format::OutputTransaction, which stages the file and commits it with the
// run's other outputs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/file_io.h"
#include "rgs/format/status.h"

namespace rgs::tools {

/// True when this build writes PNG and EXR (linked with OpenImageIO).
bool have_openimageio();

/// Writes a float32 RGBA OpenEXR file: linear RGB as rendered (not clamped) and alpha = 1 − T. Needs
/// OpenImageIO.
/// @param rgba  [H, W, 4] float32.
/// @return kInvalidArgument on a size mismatch; kIoError naming `path`; kUnsupportedFeature in a build
///         without OpenImageIO.
Status write_exr_rgba(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                      const std::vector<float>& rgba);

/// Writes a colour PFM ("PF", scale −1.0 = little-endian): float32 RGB, linear, not clamped. PFM stores the
/// bottom row first; `rgb` is top row first as everywhere else and is flipped on writing. No alpha channel.
/// @param rgb  [H, W, 3] float32.
/// @return kInvalidArgument on a size mismatch; kIoError naming `path`.
Status write_pfm_rgb(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                     const std::vector<float>& rgb);

/// Checks, before any work, that write_image8 can write `path` with `channels` channels in this build.
/// @return kInvalidArgument for an unknown extension or .pgm with 3 channels; kUnsupportedFeature for .png
///         without OpenImageIO.
Status check_image8_path(const std::string& path, uint32_t channels);

/// Writes an 8-bit image in the format its extension names: .png (OpenImageIO), .ppm (P6; grey is repeated
/// into RGB) or .pgm (P5, 1 channel only); Netpbm files through audit::write_netpbm.
/// @return kInvalidArgument for another extension or .pgm with 3 channels; the writer's errors otherwise.
Status write_image8(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                    uint32_t channels, const std::vector<uint8_t>& pixels);

}  // namespace rgs::tools
