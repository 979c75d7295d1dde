// PlayCanvas SOG output: meta.json (version 2) with lossless WebP attribute images, written as a folder or
// bundled into one .sog (ZIP) file, laid out as PlayCanvas splat-transform 3.7 writes them and as
// read_sog (playcanvas_readers.h) reads them back (converter/INTEROP.md "SOG output").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/lod_builder.h"
#include "rgs/format/file_io.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// The two containers of a single-scene SOG.
enum class SogContainer : uint8_t {
  /// One ZIP file (stored entries) holding meta.json and the images.
  kBundle = 0,
  /// meta.json written at the given path, its images next to it in the same folder.
  kFolder = 1,
};

struct SogWriteOptions {
  SogContainer container = SogContainer::kBundle;
  /// Lloyd iterations of the k-means behind the scale, DC colour and SH codebooks and the SH palette.
  uint32_t kmeans_iterations = 10;
};

/// What the SOG output keeps and loses, for the conversion summary.
struct SogWriteSummary {
  uint32_t sh_degree = 0;
  /// SH palette entries (shN.count); 0 at SH degree 0.
  uint32_t palette_entries = 0;
  /// Width and height of every per-Gaussian image.
  uint32_t image_width = 0, image_height = 0;
  /// Bytes written: the .sog, or meta.json plus the images.
  uint64_t bytes = 0;
  /// Paths written (the .sog, or the images then meta.json).
  std::vector<std::string> files;
  /// What the format cannot carry, one sentence each.
  std::vector<std::string> limitations;
};

/// One SOG file in memory: its name inside the scene (e.g. "means_l.webp") and its bytes.
struct SogFile {
  std::string name;
  std::vector<uint8_t> bytes;
};

/// Encodes `cloud` (consistent and finite; SH degree 0..3) as SOG version 2 files: meta.json then
/// means_l.webp / means_u.webp (per axis the 16-bit lerp between mins and maxs of sign(x)·ln(|x| + 1), low
/// and high bytes in R, G, B), quats.webp (smallest three of the normalized (w, x, y, z) with the largest
/// made positive, each (v·√2 + 1)/2·255 rounded; alpha = 252 + the largest's index), scales.webp (codes into
/// a 256-entry codebook of log scales; a zero scale counts as log-scale kZeroScaleLog), sh0.webp (codes into a 256-entry codebook of SH DC coefficients;
/// alpha = round(opacity·255)) and, with SH bands, shN_centroids.webp (a palette of at most 65,536 SH rest
/// vectors, 64 entries per row, coefficient by coefficient, each value a code into a 256-entry codebook)
/// and shN_labels.webp (16-bit palette index, low byte in R, high in G). Pixel i of a per-Gaussian image is
/// Gaussian i (the input order is kept), images are W × H with W = 4·ceil(√N / 4), H = 4·ceil(N / W / 4).
/// Codebooks and palette come from a k-means of our own (converter/INTEROP.md "SOG output"), deterministic:
/// the same cloud and options give the same bytes. Errors: kInvalidArgument (inconsistent or non-finite
/// cloud, more than 2^32 − 1 Gaussians, zero iterations), kOutOfMemory, kIoError (WebP encoding failed).
Result<std::vector<SogFile>> encode_sog(const format::GaussianCloud& cloud, const SogWriteOptions& options = {},
                                       SogWriteSummary* summary = nullptr);

/// The files of encode_sog() as one ZIP archive (stored entries, meta.json first, no timestamps).
std::vector<uint8_t> bundle_sog(const std::vector<SogFile>& files);

/// True when `path` names a SOG folder's entry: its last component is "meta.json" (any case).
bool is_sog_folder_path(const std::string& path);

/// The files a SOG folder output with entry `meta_path` may write: its seven images next to it (the two shN
/// ones only with SH bands), then `meta_path`.
std::vector<std::string> sog_folder_files(const std::string& meta_path);

/// Writes `cloud` to `path`: a .sog bundle, or (SogContainer::kFolder) `path` is the meta.json and the images
/// go next to it, all declared to `files` first, then each written through it (an output transaction commits
/// or drops them together). The folder must exist. Errors: as encode_sog, kIoError naming the file.
Result<SogWriteSummary> write_sog(const std::string& path, const format::GaussianCloud& cloud,
                                  const SogWriteOptions& options = {},
                                  format::FileSink& files = format::atomic_files());

/// True when `path` names a streamed SOG's entry: its last component is "lod-meta.json" (any case).
bool is_sog_lod_path(const std::string& path);

/// Most Gaussians of one chunk file of a streamed SOG: consecutive chunks of a level share a file up to it.
inline constexpr uint64_t kSogLodFileGaussians = 524288;

/// Writes the levels of detail `levels` (converter::build_lod's, or build_lod_out_of_core's: the same bytes) as a
/// PlayCanvas streamed SOG, one file's Gaussians read at a time:
/// `lod_meta_path` (lod-meta.json: `lodLevels`, `lodErrors` true, `environment` null, `filenames`
/// "L_K/meta.json", and a binary `tree` over the chunks in their Morton order, each node with its `bound`
/// {min, max} of the chunk's level-0 means, each leaf with `lods` {level: {file, offset, count}} and `errors`,
/// one per level: (level error / half the bound's diagonal, or the chunk radius for a point bound)², docs/LOD.md)
/// and, next to it, one folder "L_K" per file: SOG v2 (encode_sog) of consecutive chunks of level L, up to
/// kSogLodFileGaussians Gaussians. The Gaussians are the dequantized runtime-profile values of `levels`.
/// Every file is declared to `files` before the first is written, the folders are created through it
/// (FileSink::create_folder), lod-meta.json is written last; given an output transaction, a failure or an
/// interrupt leaves nothing new and changes nothing that existed. read_sog_lod reads level l back in chunk
/// order. Errors: as encode_sog, kIoError naming the file or folder, kCorruptData (an inconsistent `lod`, or a
/// level error that gives no finite table entry).
Result<SogWriteSummary> write_sog_lod(const std::string& lod_meta_path, const Levels& levels,
                                      const SogWriteOptions& options = {},
                                      format::FileSink& files = format::atomic_files());

}  // namespace rgs::converter
