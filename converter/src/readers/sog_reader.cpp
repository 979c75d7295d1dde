// PlayCanvas SOG readers: meta.json + WebP images (a folder or a bundled .sog ZIP), and streamed SOG
// (lod-meta.json over chunk folders). Layout as written by PlayCanvas splat-transform (its README's SOG
// section and its SOG writer): every attribute image holds one Gaussian per pixel in row-major order.
//
// Decoding goes straight into the output cloud: per chunk the images are decoded (libwebp) and each
// Gaussian is expanded through small lookup tables (65,536 mean values per axis, 256 per codebook,
// the SH palette expanded once), so a chunk costs its image decode plus a few table reads per value.
#include <xxhash.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../internal_huge_pages.h"
#include "../internal_input_file.h"
#include "../internal_interop.h"
#include "../internal_json.h"
#include "../internal_parallel.h"
#include "../internal_sog.h"
#include "../internal_webp.h"
#include "../internal_zip.h"
#include "rgs/converter/playcanvas_readers.h"

namespace rgs::converter {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

constexpr uint64_t kMaxMetaBytes = uint64_t{64} << 20;
constexpr uint64_t kMaxImageFileBytes = uint64_t{1} << 30;
constexpr uint64_t kMaxBundleBytes = uint64_t{4} << 30;
using detail::kCodebookSize;
using detail::kMaxPaletteEntries;
using detail::kPaletteColumns;
/// Gaussians per worker below which a single SOG's expansion stays on one thread.
constexpr uint64_t kMinGaussiansPerWorker = 65536;
/// Deepest lod-meta.json tree accepted (guards the traversal against hostile nesting).
constexpr size_t kMaxTreeDepth = 256;

// ---------------------------------------------------------------------------------------------------
// meta.json

enum ImageSlot : size_t { kMeansLow, kMeansHigh, kQuats, kScales, kSh0, kCentroids, kLabels, kImageSlots };
const char* const kSlotNames[kImageSlots] = {"means.files[0]", "means.files[1]", "quats.files[0]", "scales.files[0]",
                                             "sh0.files[0]",   "shN.files[0]",   "shN.files[1]"};

/// The fields of one meta.json that decoding needs.
struct SogMeta {
  /// 2, or 1 for the earlier layout without a "version" field.
  int version = 2;
  uint64_t count = 0;
  double means_min[3] = {}, means_max[3] = {};
  /// Image file names by ImageSlot; the shN ones are empty without SH bands.
  std::string files[kImageSlots];
  // v2 codebooks, as float32 (what the writer quantized to).
  std::vector<float> scales_codebook, sh0_codebook, shn_codebook;
  // Earlier layout: per-channel ranges (sh0 channel 3 is the opacity logit) and one SH range.
  double scales_min[3] = {}, scales_max[3] = {}, sh0_min[4] = {}, sh0_max[4] = {};
  double shn_min = 0, shn_max = 0;
  /// SH bands beyond DC (0..3). For the earlier layout known only once the centroids image is decoded.
  uint32_t sh_bands = 0;
  bool has_shn = false;
  /// v2: palette entries (shN.count).
  uint64_t palette_count = 0;
};

Status corrupt(const std::string& where, const std::string& what) {
  return Status(StatusCode::kCorruptData, where + ": " + what);
}

std::string type_name(const json& j) { return j.type_name(); }

Result<const json*> member(const json& obj, const std::string& key, const std::string& where, const std::string& path) {
  auto it = obj.find(key);
  if (it == obj.end()) return corrupt(where, "missing field '" + path + key + "'");
  return &*it;
}

Result<const json*> object_member(const json& obj, const std::string& key, const std::string& where) {
  RGS_ASSIGN_OR_RETURN(const json* v, member(obj, key, where, ""));
  if (!v->is_object()) return corrupt(where, "field '" + key + "' is a " + type_name(*v) + ", not an object");
  return v;
}

/// A finite number field of `obj` (named `name` in messages).
Result<double> finite_number(const json& v, const std::string& where, const std::string& name) {
  if (!v.is_number()) return corrupt(where, "field '" + name + "' is a " + type_name(v) + ", not a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) return corrupt(where, "field '" + name + "' is not finite");
  return d;
}

/// A non-negative integer field below 2^53.
Result<uint64_t> count_value(const json& v, const std::string& where, const std::string& name) {
  if (v.is_number_unsigned()) return v.get<uint64_t>();
  if (v.is_number_integer() && v.get<int64_t>() >= 0) return static_cast<uint64_t>(v.get<int64_t>());
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (d >= 0 && d < 9007199254740992.0 && std::floor(d) == d) return static_cast<uint64_t>(d);
  }
  return corrupt(where, "field '" + name + "' is not a non-negative integer");
}

/// Exactly `expected` finite numbers into out[0, expected).
Status number_array(const json& obj, const std::string& key, size_t expected, const std::string& where,
                    const std::string& prefix, double* out) {
  RGS_ASSIGN_OR_RETURN(const json* v, member(obj, key, where, prefix));
  const std::string name = prefix + key;
  if (!v->is_array()) return corrupt(where, "field '" + name + "' is a " + type_name(*v) + ", not an array");
  if (v->size() != expected) {
    return corrupt(where, "field '" + name + "' has " + std::to_string(v->size()) + " entries, expected " +
                              std::to_string(expected));
  }
  for (size_t i = 0; i < v->size(); ++i) {
    RGS_ASSIGN_OR_RETURN(out[i], finite_number((*v)[i], where, name + "[" + std::to_string(i) + "]"));
  }
  return Status();
}

/// A codebook: exactly 256 finite numbers, kept as float32.
Status codebook(const json& obj, const std::string& where, const std::string& prefix, std::vector<float>* out) {
  double values[kCodebookSize];
  RGS_RETURN_IF_ERROR(number_array(obj, "codebook", kCodebookSize, where, prefix, values));
  out->resize(kCodebookSize);
  for (size_t i = 0; i < kCodebookSize; ++i) {
    if (std::fabs(values[i]) > static_cast<double>(std::numeric_limits<float>::max())) {
      return corrupt(where, "field '" + prefix + "codebook[" + std::to_string(i) + "]' overflows float32");
    }
    (*out)[i] = static_cast<float>(values[i]);
  }
  return Status();
}

Status file_names(const json& obj, const std::string& group, size_t expected, const std::string& where,
                  std::string* out) {
  RGS_ASSIGN_OR_RETURN(const json* v, member(obj, "files", where, group + "."));
  const std::string name = group + ".files";
  if (!v->is_array() || v->size() < expected) {
    return corrupt(where,
                   "field '" + name + "' must be an array of at least " + std::to_string(expected) + " file names");
  }
  for (size_t i = 0; i < expected; ++i) {
    const json& f = (*v)[i];
    const std::string field = name + "[" + std::to_string(i) + "]";
    if (!f.is_string()) return corrupt(where, "field '" + field + "' is a " + type_name(f) + ", not a string");
    out[i] = f.get<std::string>();
  }
  return Status();
}

/// `bytes` of the file `where` as JSON; errors name the file and `what` it is (a SOG meta.json, a streamed SOG's
/// lod-meta.json), as the reader's other messages do not say which format it took the file for.
Result<json> parse_json(const std::vector<uint8_t>& bytes, const std::string& where, const char* what) {
  return detail::parse_scene_json(bytes.data(), bytes.size(), where + ": " + what);
}

/// Parses the meta.json `bytes` (the file `where`, `what` in JSON errors) into `meta`.
Status parse_sog_meta(const std::vector<uint8_t>& bytes, const std::string& where, const char* what, SogMeta* meta) {
  RGS_ASSIGN_OR_RETURN(const json root, parse_json(bytes, where, what));
  if (!root.is_object()) return corrupt(where, "top level is a " + type_name(root) + ", not an object");
  auto version_it = root.find("version");
  if (version_it == root.end()) {
    meta->version = 1;
  } else {
    RGS_ASSIGN_OR_RETURN(uint64_t version, count_value(*version_it, where, "version"));
    if (version != 2) {
      return Status(StatusCode::kUnsupportedVersion, where + ": SOG meta version " + std::to_string(version) +
                                                         " (supported: 2 and the unversioned layout)");
    }
    meta->version = 2;
  }
  RGS_ASSIGN_OR_RETURN(const json* means, object_member(root, "means", where));
  RGS_ASSIGN_OR_RETURN(const json* scales, object_member(root, "scales", where));
  RGS_ASSIGN_OR_RETURN(const json* quats, object_member(root, "quats", where));
  RGS_ASSIGN_OR_RETURN(const json* sh0, object_member(root, "sh0", where));
  if (meta->version == 2) {
    RGS_ASSIGN_OR_RETURN(const json* count, member(root, "count", where, ""));
    RGS_ASSIGN_OR_RETURN(meta->count, count_value(*count, where, "count"));
  } else {
    double shape[2];
    RGS_RETURN_IF_ERROR(number_array(*means, "shape", 2, where, "means.", shape));
    if (shape[0] < 0 || shape[0] >= 9007199254740992.0 || std::floor(shape[0]) != shape[0]) {
      return corrupt(where, "field 'means.shape[0]' is not a Gaussian count");
    }
    meta->count = static_cast<uint64_t>(shape[0]);
  }
  RGS_RETURN_IF_ERROR(number_array(*means, "mins", 3, where, "means.", meta->means_min));
  RGS_RETURN_IF_ERROR(number_array(*means, "maxs", 3, where, "means.", meta->means_max));
  RGS_RETURN_IF_ERROR(file_names(*means, "means", 2, where, &meta->files[kMeansLow]));
  RGS_RETURN_IF_ERROR(file_names(*quats, "quats", 1, where, &meta->files[kQuats]));
  RGS_RETURN_IF_ERROR(file_names(*scales, "scales", 1, where, &meta->files[kScales]));
  RGS_RETURN_IF_ERROR(file_names(*sh0, "sh0", 1, where, &meta->files[kSh0]));
  if (meta->version == 2) {
    RGS_RETURN_IF_ERROR(codebook(*scales, where, "scales.", &meta->scales_codebook));
    RGS_RETURN_IF_ERROR(codebook(*sh0, where, "sh0.", &meta->sh0_codebook));
  } else {
    RGS_RETURN_IF_ERROR(number_array(*scales, "mins", 3, where, "scales.", meta->scales_min));
    RGS_RETURN_IF_ERROR(number_array(*scales, "maxs", 3, where, "scales.", meta->scales_max));
    RGS_RETURN_IF_ERROR(number_array(*sh0, "mins", 4, where, "sh0.", meta->sh0_min));
    RGS_RETURN_IF_ERROR(number_array(*sh0, "maxs", 4, where, "sh0.", meta->sh0_max));
  }
  auto shn_it = root.find("shN");
  if (shn_it != root.end() && !shn_it->is_null()) {
    const json& shn = *shn_it;
    if (!shn.is_object()) return corrupt(where, "field 'shN' is a " + type_name(shn) + ", not an object");
    if (meta->version == 2) {
      RGS_ASSIGN_OR_RETURN(const json* bands, member(shn, "bands", where, "shN."));
      RGS_ASSIGN_OR_RETURN(uint64_t b, count_value(*bands, where, "shN.bands"));
      if (b > 3) return corrupt(where, "field 'shN.bands' is " + std::to_string(b) + " (SH bands are 0..3)");
      meta->sh_bands = static_cast<uint32_t>(b);
      meta->has_shn = b > 0;
      if (meta->has_shn) {
        RGS_ASSIGN_OR_RETURN(const json* count, member(shn, "count", where, "shN."));
        RGS_ASSIGN_OR_RETURN(meta->palette_count, count_value(*count, where, "shN.count"));
        if (meta->palette_count == 0 || meta->palette_count > kMaxPaletteEntries) {
          return corrupt(where, "field 'shN.count' is " + std::to_string(meta->palette_count) +
                                    "; SH palettes have 1.." + std::to_string(kMaxPaletteEntries) +
                                    " entries (16-bit labels)");
        }
        RGS_RETURN_IF_ERROR(codebook(shn, where, "shN.", &meta->shn_codebook));
      }
    } else {
      meta->has_shn = true;
      RGS_ASSIGN_OR_RETURN(const json* mins, member(shn, "mins", where, "shN."));
      RGS_ASSIGN_OR_RETURN(meta->shn_min, finite_number(*mins, where, "shN.mins"));
      RGS_ASSIGN_OR_RETURN(const json* maxs, member(shn, "maxs", where, "shN."));
      RGS_ASSIGN_OR_RETURN(meta->shn_max, finite_number(*maxs, where, "shN.maxs"));
    }
    if (meta->has_shn) RGS_RETURN_IF_ERROR(file_names(shn, "shN", 2, where, &meta->files[kCentroids]));
  }
  return Status();
}

// ---------------------------------------------------------------------------------------------------
// Where a chunk's files come from: a folder, or a ZIP archive in memory.

class SogFiles {
 public:
  virtual ~SogFiles() = default;
  /// Reads file `name` (relative to the meta file), named by the meta file's field `field`, into `out`, at
  /// most `max_bytes`; errors name it.
  virtual Status read(const std::string& name, const std::string& field, uint64_t max_bytes,
                      std::vector<uint8_t>* out) const = 0;
  /// How `name` appears in messages.
  virtual std::string display(const std::string& name) const = 0;
};

/// Files of a folder, opened through the scene's file-access policy (detail::SceneFolder).
class FolderFiles final : public SogFiles {
 public:
  /// `base`: the meta file's folder relative to the scene's folder ("" or "0_0"); `meta`: its name in
  /// messages.
  FolderFiles(const detail::SceneFolder* folder, std::string base, std::string meta)
      : folder_(folder), base_(std::move(base)), meta_(std::move(meta)) {}
  Status read(const std::string& name, const std::string& field, uint64_t max_bytes,
              std::vector<uint8_t>* out) const override {
    RGS_ASSIGN_OR_RETURN(std::string relative, folder_->resolve(name, base_, meta_, field));
    Status s = folder_->read(relative, max_bytes, out);
    return s.ok() ? s : s.prepend(meta_ + ": field '" + field + "'");
  }
  std::string display(const std::string& name) const override {
    return folder_->display((base_.empty() ? "" : base_ + "/") + detail::bounded_text(name, 96));
  }

 private:
  const detail::SceneFolder* folder_;
  std::string base_;
  std::string meta_;
};

/// Entries of a bundled .sog. Every entry is held to the decompression-ratio limit of the archive's bytes
/// before it is inflated (a deflated entry may expand 1032-fold; SPEC 5.5's limit is far lower).
class ZipFiles final : public SogFiles {
 public:
  ZipFiles(const detail::ZipArchive* zip, std::string archive, uint64_t archive_bytes, uint32_t ratio)
      : zip_(zip), archive_(std::move(archive)), archive_bytes_(archive_bytes), ratio_(ratio) {}
  Status read(const std::string& name, const std::string& field, uint64_t max_bytes,
              std::vector<uint8_t>* out) const override {
    // Entries are looked up, not opened, but a name that would leave a folder is refused as it is there.
    RGS_RETURN_IF_ERROR(detail::resolve_scene_reference(name, "", archive_ + ":meta.json", field).status());
    const detail::ZipEntry* entry = zip_->find(name);
    if (entry == nullptr) {
      return Status(StatusCode::kIoError,
                    archive_ + ": the archive has no entry '" + detail::bounded_text(name, 96) + "'");
    }
    return extract(*entry, max_bytes, out);
  }
  /// Inflates `entry` (at most `max_bytes`) once its declared size is within the archive's limit.
  Status extract(const detail::ZipEntry& entry, uint64_t max_bytes, std::vector<uint8_t>* out) const {
    RGS_RETURN_IF_ERROR(detail::check_decode_budget(
        entry.uncompressed_size, archive_bytes_, ratio_, archive_,
        "the deflated bytes of ZIP entry '" + detail::bounded_text(entry.name, 96) + "'"));
    return zip_->extract(entry, max_bytes, out);
  }
  std::string display(const std::string& name) const override {
    return archive_ + ":" + detail::bounded_text(name, 96);
  }

 private:
  const detail::ZipArchive* zip_;
  std::string archive_;
  uint64_t archive_bytes_;
  uint32_t ratio_;
};

// ---------------------------------------------------------------------------------------------------
// Decoding one SOG (one chunk of a streamed SOG) into the cloud.

/// Gaussians [src, src + count) of a chunk go to cloud indices [dst, dst + count).
struct Range {
  uint64_t src = 0;
  uint64_t count = 0;
  uint64_t dst = 0;
};

struct ChunkJob {
  std::string meta_name;  ///< for messages
  SogMeta meta;
  const SogFiles* files = nullptr;
  std::vector<Range> ranges;
  bool hash = false;
  /// Filled by load_chunk_images: each image file's bytes (released once decoded), the bytes and XXH64 of
  /// the files read, in ImageSlot order, and what their pixels decode to (RGBA8).
  std::vector<uint8_t> image_bytes[kImageSlots];
  uint64_t bytes_read = 0;
  uint64_t files_read = 0;
  uint64_t decoded_bytes = 0;
  std::vector<uint64_t> file_hashes;
};

/// Inverse of the writer's log transform sign(x)·ln(|x| + 1).
inline double inverse_log_transform(double v) {
  const double e = std::exp(std::fabs(v)) - 1.0;
  return v < 0 ? -e : e;
}

/// Everything per-value decoding reads, precomputed per chunk.
struct Tables {
  std::vector<float> means[3];  ///< 65,536 per axis
  float scales[3][256];         ///< linear
  float dc[3][256];
  float opacity[256];
  float quat[256];    ///< (v/255·2 − 1)/√2
  uint32_t rest = 0;  ///< SH coefficients beyond DC (K − 1)
  uint64_t palette_count = 0;
  std::vector<float> palette;  ///< [palette_count, rest, 3], channel fastest
};

inline float sigmoid_of_logit(double logit) {
  // Through float32, as a reader of the logit stored in a float PLY would see it.
  const float stored = static_cast<float>(logit);
  return static_cast<float>(1.0 / (1.0 + std::exp(-static_cast<double>(stored))));
}

Status build_tables(const SogMeta& meta, const std::string& where, Tables* t) {
  for (int a = 0; a < 3; ++a) {
    const double lo = meta.means_min[a];
    const double span = meta.means_max[a] - meta.means_min[a];  // lerp(min, max, code / 65535), as PlayCanvas reads
    t->means[a].resize(65536);
    for (uint32_t v = 0; v < 65536; ++v) {
      t->means[a][v] = static_cast<float>(inverse_log_transform(lo + span * (static_cast<double>(v) / 65535.0)));
    }
    if (!std::isfinite(t->means[a][0]) || !std::isfinite(t->means[a][65535])) {
      return corrupt(where, std::string("means range of axis ") + "xyz"[a] + " [" + std::to_string(meta.means_min[a]) +
                                ", " + std::to_string(meta.means_max[a]) + "] overflows float32 positions");
    }
  }
  for (uint32_t v = 0; v < 256; ++v) {
    const double unit = static_cast<double>(v) / 255.0;
    t->quat[v] = static_cast<float>((unit * 2.0 - 1.0) / std::sqrt(2.0));
    if (meta.version == 2) {
      const double log_scale = static_cast<double>(meta.scales_codebook[v]);
      for (int a = 0; a < 3; ++a) t->scales[a][v] = static_cast<float>(std::exp(log_scale));
      for (int c = 0; c < 3; ++c) t->dc[c][v] = meta.sh0_codebook[v];
      const double e = std::min(1.0 - 1e-6, std::max(1e-6, unit));
      t->opacity[v] = sigmoid_of_logit(std::log(e / (1.0 - e)));
    } else {
      for (int a = 0; a < 3; ++a) {
        const float log_scale =
            static_cast<float>(meta.scales_min[a] + (meta.scales_max[a] - meta.scales_min[a]) * unit);
        t->scales[a][v] = static_cast<float>(std::exp(static_cast<double>(log_scale)));
      }
      for (int c = 0; c < 3; ++c) {
        t->dc[c][v] = static_cast<float>(meta.sh0_min[c] + (meta.sh0_max[c] - meta.sh0_min[c]) * unit);
      }
      const double logit = meta.sh0_min[3] + (meta.sh0_max[3] - meta.sh0_min[3]) * unit;
      t->opacity[v] = sigmoid_of_logit(std::max(-detail::kMaxOpacityLogit, std::min(detail::kMaxOpacityLogit, logit)));
    }
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(t->scales[a][v])) {
        return corrupt(where, "scale code " + std::to_string(v) + " gives a scale that overflows float32");
      }
      if (!std::isfinite(t->dc[a][v])) return corrupt(where, "sh0 code " + std::to_string(v) + " overflows float32");
    }
  }
  return Status();
}

/// Expands the SH palette from the centroids image (after checking its size).
Status build_palette(const SogMeta& meta, const detail::RgbaImage& centroids, const std::string& where, Tables* t) {
  // The earlier layout's bands come from this image's width (resolve_earlier_bands), its entries from the rows.
  const uint32_t bands = meta.sh_bands;
  const uint64_t entries = meta.version == 2 ? meta.palette_count : uint64_t{kPaletteColumns} * centroids.height;
  const uint32_t rest = format::sh_coefficient_count(bands) - 1;
  if (centroids.width != kPaletteColumns * rest) {
    return corrupt(where, "shN centroids image is " + std::to_string(centroids.width) + " pixels wide; " +
                              std::to_string(bands) + " SH bands need " + std::to_string(kPaletteColumns * rest));
  }
  const uint64_t rows_needed = (entries + kPaletteColumns - 1) / kPaletteColumns;
  if (centroids.height < rows_needed) {
    return corrupt(where, "shN centroids image has " + std::to_string(centroids.height) + " rows; " +
                              std::to_string(entries) + " palette entries need " + std::to_string(rows_needed));
  }
  t->rest = rest;
  t->palette_count = entries;
  t->palette.resize(static_cast<size_t>(entries) * rest * 3);
  for (uint64_t p = 0; p < entries; ++p) {
    const uint64_t row = p / kPaletteColumns;
    const uint64_t column0 = (p % kPaletteColumns) * rest;
    for (uint32_t j = 0; j < rest; ++j) {
      const uint8_t* px = centroids.rgba.data() + (row * centroids.width + column0 + j) * 4;
      for (uint32_t c = 0; c < 3; ++c) {
        const float v = meta.version == 2
                            ? meta.shn_codebook[px[c]]
                            : static_cast<float>(meta.shn_min + (meta.shn_max - meta.shn_min) * (px[c] / 255.0));
        t->palette[(p * rest + j) * 3 + c] = v;
      }
    }
  }
  return Status();
}

struct DecodedImages {
  detail::RgbaImage image[kImageSlots];
};

/// Expands Gaussians [begin, end) of the chunk's concatenated ranges. Returns the first bad one's message.
Status expand_gaussians(const ChunkJob& job, const DecodedImages& img, const Tables& t, uint64_t begin, uint64_t end,
                        format::GaussianCloud* cloud) {
  const uint32_t k_count = cloud->sh_coefficients();
  const uint32_t rest = k_count - 1;
  const uint8_t* lo = img.image[kMeansLow].rgba.data();
  const uint8_t* hi = img.image[kMeansHigh].rgba.data();
  const uint8_t* qt = img.image[kQuats].rgba.data();
  const uint8_t* sc = img.image[kScales].rgba.data();
  const uint8_t* c0 = img.image[kSh0].rgba.data();
  const uint8_t* lb = rest ? img.image[kLabels].rgba.data() : nullptr;
  float* means = cloud->means.data();
  float* rotations = cloud->rotations.data();
  float* scales = cloud->scales.data();
  float* opacities = cloud->opacities.data();
  float* sh = cloud->sh.data();
  uint64_t offset = 0;  // position in the concatenated ranges
  for (const Range& range : job.ranges) {
    const uint64_t r_begin = std::max(begin, offset), r_end = std::min(end, offset + range.count);
    for (uint64_t at = r_begin; at < r_end; ++at) {
      const uint64_t s = range.src + (at - offset);
      const uint64_t d = range.dst + (at - offset);
      const size_t p = static_cast<size_t>(s) * 4;
      for (int a = 0; a < 3; ++a) means[d * 3 + a] = t.means[a][lo[p + a] | (hi[p + a] << 8)];
      const uint8_t tag = qt[p + 3];
      if (tag < 252) {
        return corrupt(job.files->display(job.meta.files[kQuats]),
                       "Gaussian " + std::to_string(s) + " has quaternion tag " + std::to_string(tag) +
                           " (valid: 252..255, the index of the largest component + 252)");
      }
      detail::decode_smallest_three(
          tag - 252, [&](int k) { return static_cast<double>(t.quat[qt[p + k]]); }, rotations + d * 4);
      for (int a = 0; a < 3; ++a) scales[d * 3 + a] = t.scales[a][sc[p + a]];
      float* g_sh = sh + d * k_count * 3;
      for (int c = 0; c < 3; ++c) g_sh[c] = t.dc[c][c0[p + c]];
      opacities[d] = t.opacity[c0[p + 3]];
      if (rest) {
        const uint32_t label = lb[p] | (uint32_t{lb[p + 1]} << 8);
        if (label >= t.palette_count) {
          return corrupt(job.files->display(job.meta.files[kLabels]),
                         "Gaussian " + std::to_string(s) + " has SH palette label " + std::to_string(label) +
                             ", but the palette has " + std::to_string(t.palette_count) + " entries");
        }
        std::memcpy(g_sh + 3, &t.palette[static_cast<size_t>(label) * rest * 3], sizeof(float) * rest * 3);
      }
    }
    offset += range.count;
  }
  return Status();
}

uint64_t total_count(const std::vector<Range>& ranges) {
  uint64_t n = 0;
  for (const Range& r : ranges) n += r.count;
  return n;
}

/// The image slots a chunk reads.
std::vector<size_t> image_slots(const SogMeta& meta) {
  std::vector<size_t> slots = {kMeansLow, kMeansHigh, kQuats, kScales, kSh0};
  if (meta.has_shn) {
    slots.push_back(kCentroids);
    slots.push_back(kLabels);
  }
  return slots;
}

/// Reads the chunk's image files (at most `max_file_bytes` each) and checks their sizes from their headers:
/// every per-Gaussian image must hold the chunk's Gaussians. Nothing is decoded, so the whole scene's decoded
/// size is known (ChunkJob::decoded_bytes) before any pixel or Gaussian is allocated.
Status load_chunk_images(ChunkJob* job, uint64_t max_file_bytes) {
  const SogMeta& meta = job->meta;
  for (size_t slot : image_slots(meta)) {
    std::vector<uint8_t>& bytes = job->image_bytes[slot];
    RGS_RETURN_IF_ERROR(job->files->read(meta.files[slot], kSlotNames[slot], max_file_bytes, &bytes));
    job->bytes_read += bytes.size();
    ++job->files_read;
    if (job->hash) job->file_hashes.push_back(XXH64(bytes.data(), bytes.size(), 0));
    uint32_t width = 0, height = 0;
    const std::string name = job->files->display(meta.files[slot]);
    RGS_RETURN_IF_ERROR(detail::read_webp_size(bytes.data(), bytes.size(), name, &width, &height));
    const uint64_t pixels = uint64_t{width} * height;
    if (slot != kCentroids && pixels < meta.count) {
      return corrupt(name, std::string(kSlotNames[slot]) + " image is " + std::to_string(width) + " x " +
                               std::to_string(height) + " = " + std::to_string(pixels) + " pixels, fewer than the " +
                               std::to_string(meta.count) + " Gaussians of " + job->meta_name);
    }
    job->decoded_bytes += pixels * 4;
  }
  return Status();
}

/// Decodes the chunk's images (read by load_chunk_images) and expands its ranges into `cloud`. `workers` > 1
/// decodes the images and expands the Gaussians in parallel (used when there is a single chunk).
Status decode_chunk(ChunkJob* job, unsigned workers, format::GaussianCloud* cloud) {
  const SogMeta& meta = job->meta;
  const std::string& where = job->meta_name;
  Tables tables;
  RGS_RETURN_IF_ERROR(build_tables(meta, where, &tables));

  const std::vector<size_t> slots = image_slots(meta);
  DecodedImages images;
  std::vector<Status> errors(kImageSlots);
  const unsigned image_workers = std::min<unsigned>(workers, static_cast<unsigned>(slots.size()));
  RGS_RETURN_IF_ERROR(detail::parallel_items(slots.size(), image_workers, [&](unsigned, uint64_t item) {
    const size_t slot = slots[item];
    std::vector<uint8_t>& bytes = job->image_bytes[slot];
    // The sizes were checked against the decompression-ratio limit by load_chunk_images' caller.
    errors[slot] = detail::decode_webp_rgba(bytes.data(), bytes.size(), UINT64_MAX,
                                            job->files->display(meta.files[slot]), &images.image[slot]);
    std::vector<uint8_t>().swap(bytes);
  }));
  for (size_t slot : slots) RGS_RETURN_IF_ERROR(errors[slot]);
  if (meta.has_shn) {
    RGS_RETURN_IF_ERROR(
        build_palette(meta, images.image[kCentroids], job->files->display(meta.files[kCentroids]), &tables));
  }
  if (tables.rest + 1 != cloud->sh_coefficients()) {
    return corrupt(where, "has " + std::to_string(tables.rest) +
                              " SH coefficients beyond DC per channel, but the "
                              "scene has " +
                              std::to_string(cloud->sh_coefficients() - 1));
  }

  const uint64_t n = total_count(job->ranges);
  const unsigned expand_workers = std::min(workers, detail::worker_count(n, kMinGaussiansPerWorker));
  std::vector<Status> slice_errors(std::max(1u, expand_workers));
  RGS_RETURN_IF_ERROR(detail::parallel_slices(n, expand_workers, [&](unsigned slice, uint64_t begin, uint64_t end) {
    slice_errors[slice] = expand_gaussians(*job, images, tables, begin, end, cloud);
  }));
  for (Status& s : slice_errors) RGS_RETURN_IF_ERROR(s);
  return Status();
}

// ---------------------------------------------------------------------------------------------------
// Whole reads.

/// SH degree a meta file implies; the earlier layout names it only through its centroids image, so its
/// scenes report the degree decode_chunk checks against (`bands` from the image, see resolve_earlier_bands).
uint32_t declared_degree(const SogMeta& meta) { return meta.has_shn ? meta.sh_bands : 0; }

/// Reads the earlier layout's centroids image header to learn its SH bands before the cloud is allocated.
Status resolve_earlier_bands(SogMeta* meta, const SogFiles& files) {
  if (meta->version == 2 || !meta->has_shn) return Status();
  std::vector<uint8_t> bytes;
  RGS_RETURN_IF_ERROR(files.read(meta->files[kCentroids], kSlotNames[kCentroids], kMaxImageFileBytes, &bytes));
  detail::RgbaImage image;
  RGS_RETURN_IF_ERROR(detail::decode_webp_rgba(bytes.data(), bytes.size(), uint64_t{1} << 24,
                                               files.display(meta->files[kCentroids]), &image));
  // The earlier layout names no band count: the image holds 64 entries of (coefficients − 1) pixels per row.
  for (uint32_t bands = 1; bands <= 3; ++bands) {
    if (image.width == kPaletteColumns * (format::sh_coefficient_count(bands) - 1)) {
      meta->sh_bands = bands;
      return Status();
    }
  }
  return corrupt(files.display(meta->files[kCentroids]),
                 "shN centroids image is " + std::to_string(image.width) +
                     " pixels wide; expected 192, 512 or 960 (SH bands 1, 2, 3)");
}

template <typename Fn>
Result<InputScene> guarded(const std::string& path, Fn&& fn) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, path + ": out of memory while decoding");
  } catch (const std::length_error&) {
    return Status(StatusCode::kOutOfMemory, path + ": out of memory while decoding");
  } catch (const json::exception& e) {
    return Status(StatusCode::kCorruptData, path + ": malformed JSON field: " + e.what());
  }
}

/// The scene's folder and its entry file: `path` names a folder (its `entry_name` is read through the
/// file-access policy) or the entry file itself (read as named).
struct SceneEntry {
  std::unique_ptr<detail::SceneFolder> folder;
  std::string path;  ///< the entry file, as named in messages
  std::vector<uint8_t> bytes;
};

Status read_entry(const std::string& path, const char* entry_name, uint64_t max_bytes, SceneEntry* entry) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    entry->folder = std::make_unique<detail::SceneFolder>(path, std::string());
    entry->path = entry->folder->display(entry_name);
    return entry->folder->read(entry_name, max_bytes, &entry->bytes);
  }
  entry->folder = std::make_unique<detail::SceneFolder>(fs::path(path).parent_path().string(), path);
  entry->path = path;
  return detail::read_whole_file(path, max_bytes, &entry->bytes);
}

/// Reads every chunk's images and checks what they decode to against the decompression-ratio limit, before
/// anything is allocated for pixels or Gaussians. The limit's basis is the scene's distinct files: those
/// `folder` has read, each counted once however many chunks or fields name it (SceneFolder::distinct_bytes),
/// or, for a bundle (`folder` null), the archive's `file_bytes`, which holds its entries. The image bytes held
/// until decoding (a file named again is held again) stay within the limit of the distinct files read so far.
Status load_images(std::vector<ChunkJob>& jobs, const detail::SceneFolder* folder, uint64_t file_bytes,
                   const SceneReadOptions& options, const std::string& where) {
  const uint32_t ratio = options.max_decompression_ratio;
  auto basis = [&] { return folder != nullptr ? folder->distinct_bytes() : file_bytes; };
  uint64_t decoded = 0, held = 0;
  for (ChunkJob& job : jobs) {
    // Each image file is bounded by what may still be decoded: an image never decodes to less than its size.
    RGS_RETURN_IF_ERROR(load_chunk_images(&job, std::min(kMaxImageFileBytes, detail::decode_budget(basis(), ratio))));
    held += job.bytes_read;
    if (held > detail::decode_budget(basis(), ratio)) {
      return Status(StatusCode::kLimitExceeded,
                    where + ": the chunks name " + std::to_string(held) + " bytes of images (a file named again " +
                        "counted again), more than the decompression-ratio limit of " + std::to_string(ratio) +
                        " x the " + std::to_string(basis()) + " bytes of distinct files read (files under 1 MiB " +
                        "count as 1 MiB; format/SPEC.md 5.5); raise --max-decompression-ratio to read it");
    }
    decoded += job.decoded_bytes;
  }
  return detail::check_decode_budget(decoded, basis(), ratio, where, "the WebP images (RGBA8)");
}

/// Reads the chunks' images (load_images), sizes `scene`'s cloud to `total` Gaussians of SH `degree` and decodes
/// every chunk into it. With `folder` (null for a bundle), also the scene's files, their bytes and, after
/// `hashes` (the meta files'), the XXH64 of every image in chunk order.
Status decode_scene(std::vector<ChunkJob>& jobs, const detail::SceneFolder* folder, uint64_t file_bytes,
                    const SceneReadOptions& options, const std::string& where, uint32_t degree, uint64_t total,
                    std::vector<uint64_t> hashes, InputScene* scene) {
  RGS_RETURN_IF_ERROR(load_images(jobs, folder, file_bytes, options, where));
  scene->cloud.sh_degree = degree;
  detail::resize_cloud_huge(&scene->cloud, static_cast<size_t>(total));
  std::vector<Status> errors(jobs.size());
  const unsigned threads = detail::worker_count(UINT64_MAX, 1);  // every CPU this process may use (≤ 16)
  const unsigned workers = detail::worker_count(jobs.size(), 1);
  // With fewer chunks than threads, each chunk also decodes its images and expands in parallel.
  const unsigned busy = static_cast<unsigned>(std::max<size_t>(1, std::min<size_t>(jobs.size(), threads)));
  const unsigned inner = std::max(1u, threads / busy);
  RGS_RETURN_IF_ERROR(detail::parallel_items(jobs.size(), workers, [&](unsigned, uint64_t item) {
    errors[item] = decode_chunk(&jobs[item], inner, &scene->cloud);
  }));
  for (Status& s : errors) RGS_RETURN_IF_ERROR(s);
  if (folder == nullptr) return Status();
  scene->file_bytes = folder->distinct_bytes();
  scene->file_count = folder->distinct_files();
  scene->files = folder->files();
  if (options.hash_file) {
    for (const ChunkJob& job : jobs) hashes.insert(hashes.end(), job.file_hashes.begin(), job.file_hashes.end());
    scene->file_xxh64 = detail::combine_hashes(hashes);
  }
  return Status();
}

Result<InputScene> read_sog_impl(const std::string& path, const SceneReadOptions& options) {
  SceneEntry entry;
  RGS_RETURN_IF_ERROR(read_entry(path, "meta.json", kMaxBundleBytes, &entry));
  InputScene scene;
  std::unique_ptr<SogFiles> files;
  detail::ZipArchive zip;
  std::vector<uint8_t> meta_bytes;
  const bool bundled = detail::has_zip_magic(entry.bytes.data(), entry.bytes.size());
  std::vector<uint64_t> hashes;
  scene.file_bytes = entry.bytes.size();
  scene.file_count = 1;
  if (bundled) {
    RGS_ASSIGN_OR_RETURN(zip, detail::ZipArchive::open(entry.bytes.data(), entry.bytes.size(), entry.path));
    const detail::ZipEntry* meta = zip.find("meta.json");
    if (meta == nullptr) {
      return Status(StatusCode::kCorruptData,
                    entry.path + ": ZIP archive has no meta.json, so it is not a bundled SOG");
    }
    auto zip_files =
        std::make_unique<ZipFiles>(&zip, entry.path, entry.bytes.size(), options.max_decompression_ratio);
    RGS_RETURN_IF_ERROR(zip_files->extract(*meta, kMaxMetaBytes, &meta_bytes));
    files = std::move(zip_files);
    scene.format_id = "sog_bundle";
    if (options.hash_file) scene.file_xxh64 = XXH64(entry.bytes.data(), entry.bytes.size(), 0);
  } else {
    RGS_RETURN_IF_ERROR(
        detail::check_limit(entry.path + ": meta file is ", entry.bytes.size(), "bytes", kMaxMetaBytes));
    meta_bytes = std::move(entry.bytes);
    files = std::make_unique<FolderFiles>(entry.folder.get(), "", entry.path);
    scene.format_id = "sog";
    if (options.hash_file) hashes.push_back(XXH64(meta_bytes.data(), meta_bytes.size(), 0));
  }
  const std::string meta_name = bundled ? entry.path + ":meta.json" : entry.path;
  std::vector<ChunkJob> jobs(1);
  ChunkJob& job = jobs[0];
  job.meta_name = meta_name;
  job.files = files.get();
  job.hash = options.hash_file && !bundled;
  RGS_RETURN_IF_ERROR(parse_sog_meta(meta_bytes, meta_name, "SOG meta.json", &job.meta));
  RGS_RETURN_IF_ERROR(
      detail::check_limit(meta_name + ": declares ", job.meta.count, "Gaussians", options.max_gaussians));
  RGS_RETURN_IF_ERROR(resolve_earlier_bands(&job.meta, *files));
  job.ranges.push_back(Range{0, job.meta.count, 0});
  RGS_RETURN_IF_ERROR(decode_scene(jobs, bundled ? nullptr : entry.folder.get(), scene.file_bytes, options, meta_name,
                                   declared_degree(job.meta), job.meta.count, std::move(hashes), &scene));
  if (bundled) scene.files = {entry.path};
  scene.storage_format = scene.format_id;
  scene.declared_vertices = job.meta.count;
  const std::string layout = job.meta.version == 2 ? "v2" : "unversioned (v1)";
  scene.description =
      bundled ? "PlayCanvas SOG " + layout + " (bundled .sog)"
              : "PlayCanvas SOG " + layout + " (meta.json + " + std::to_string(job.files_read) + " WebP images)";
  return scene;
}

// ---------------------------------------------------------------------------------------------------
// Streamed SOG.

struct LodReference {
  uint64_t file = 0, offset = 0, count = 0;
};

/// The references of level `lod` in `tree` into `out`; with `errors`, also every leaf's 'errors' table (the
/// header declared 'lodErrors'), in tree order. A table holds `levels` finite non-negative numbers.
Status collect_references(const json& tree, uint64_t levels, uint64_t files, uint32_t lod, const std::string& where,
                          std::vector<LodReference>* out, std::vector<std::vector<double>>* errors) {
  std::vector<std::pair<const json*, size_t>> stack = {{&tree, 0}};
  size_t leaves = 0;
  while (!stack.empty()) {
    const auto [node, depth] = stack.back();
    stack.pop_back();
    if (!node->is_object()) return corrupt(where, "a 'tree' node is a " + type_name(*node) + ", not an object");
    if (depth > kMaxTreeDepth) return corrupt(where, "'tree' is nested deeper than " + std::to_string(kMaxTreeDepth));
    auto lods = node->find("lods");
    if (lods != node->end()) {
      if (!lods->is_object()) return corrupt(where, "a node's 'lods' is a " + type_name(*lods) + ", not an object");
      if (errors != nullptr || node->contains("errors")) {  // a table is checked even where it is not asked for
        std::vector<double> table(levels);
        const std::string leaf = "tree leaf " + std::to_string(leaves) + ".";
        RGS_RETURN_IF_ERROR(number_array(*node, "errors", levels, where, leaf, table.data()));
        for (size_t l = 0; l < levels; ++l) {
          if (table[l] < 0) return corrupt(where, "field '" + leaf + "errors[" + std::to_string(l) + "]' is negative");
        }
        if (errors != nullptr) errors->push_back(std::move(table));
      }
      ++leaves;
      for (auto it = lods->begin(); it != lods->end(); ++it) {
        const std::string& key = it.key();
        uint64_t level = 0;
        bool numeric = !key.empty() && key.size() < 10;
        for (char ch : key) numeric = numeric && ch >= '0' && ch <= '9';
        if (numeric) level = std::stoull(key);
        if (!numeric || level >= levels) {
          return corrupt(where, "LOD reference key '" + key + "' is not a level in 0.." + std::to_string(levels - 1));
        }
        const json& ref = it.value();
        if (!ref.is_object()) return corrupt(where, "LOD reference '" + key + "' is not an object");
        LodReference r;
        const std::string field = "tree..lods." + key;
        for (const char* name : {"file", "offset", "count"}) {
          auto f = ref.find(name);
          if (f == ref.end()) return corrupt(where, "LOD reference '" + key + "' has no '" + name + "'");
          RGS_ASSIGN_OR_RETURN(uint64_t v, count_value(*f, where, field + "." + name));
          (name[0] == 'f' ? r.file : name[0] == 'o' ? r.offset : r.count) = v;
        }
        if (r.file >= files) {
          return corrupt(where, "LOD reference names file " + std::to_string(r.file) + ", but 'filenames' has " +
                                    std::to_string(files) + " entries");
        }
        if (level == lod) out->push_back(r);
      }
    }
    auto children = node->find("children");
    if (children != node->end()) {
      if (!children->is_array()) return corrupt(where, "a node's 'children' is not an array");
      for (auto c = children->rbegin(); c != children->rend(); ++c) stack.push_back({&*c, depth + 1});
    }
  }
  return Status();
}

/// The index part of a lod-meta.json: its level count, the level read and the chunk meta files it names
/// (relative to the scene's folder).
struct LodIndex {
  uint64_t levels = 0;
  uint32_t lod = 0;
  std::vector<std::string> names;
};

/// Reads 'version', 'lodLevels' and 'filenames' of the lod-meta.json `root` (the file `path`) and checks the
/// level `options` asks for.
Result<LodIndex> parse_lod_index(const json& root, const std::string& path, const detail::SceneFolder& folder,
                                 const SceneReadOptions& options) {
  if (auto v = root.find("version"); v != root.end()) {
    RGS_ASSIGN_OR_RETURN(uint64_t version, count_value(*v, path, "version"));
    if (version != 1) {
      return Status(StatusCode::kUnsupportedVersion,
                    path + ": lod-meta.json version " + std::to_string(version) + " (supported: 1 and unversioned)");
    }
  }
  LodIndex index;
  RGS_ASSIGN_OR_RETURN(const json* levels_json, member(root, "lodLevels", path, ""));
  RGS_ASSIGN_OR_RETURN(index.levels, count_value(*levels_json, path, "lodLevels"));
  const uint64_t levels = index.levels;
  if (levels == 0 || levels > 64) return corrupt(path, "'lodLevels' is " + std::to_string(levels) + " (valid: 1..64)");
  const uint32_t lod = index.lod = options.lod.value_or(0);
  if (lod >= levels) {
    return Status(StatusCode::kInvalidArgument, path + ": LOD " + std::to_string(lod) +
                                                    " requested, but the scene has " + std::to_string(levels) +
                                                    " levels (0.." + std::to_string(levels - 1) + ")");
  }
  RGS_ASSIGN_OR_RETURN(const json* names_json, member(root, "filenames", path, ""));
  if (!names_json->is_array()) return corrupt(path, "'filenames' is not an array");
  for (size_t i = 0; i < names_json->size(); ++i) {
    const json& n = (*names_json)[i];
    const std::string field = "filenames[" + std::to_string(i) + "]";
    if (!n.is_string()) return corrupt(path, "field '" + field + "' is not a string");
    RGS_ASSIGN_OR_RETURN(std::string relative,
                         folder.resolve(n.get<std::string>(), "", path, field));
    index.names.push_back(std::move(relative));
  }
  return index;
}

/// Adds the references `file_refs` into chunk file `name` (sorted by offset) to `job` as ranges that land at
/// `*next_dst` on; they must not overlap nor exceed the chunk's Gaussians.
Status add_lod_ranges(const std::vector<LodReference>& file_refs, const std::string& name, const std::string& path,
                      uint32_t lod, ChunkJob* job, uint64_t* next_dst) {
  uint64_t covered = 0;
  for (const LodReference& r : file_refs) {
    if (r.offset < covered) {
      return corrupt(path, "LOD " + std::to_string(lod) + " ranges of '" + name + "' overlap at offset " +
                               std::to_string(r.offset));
    }
    if (r.offset > job->meta.count || r.count > job->meta.count - r.offset) {
      return corrupt(path, "LOD " + std::to_string(lod) + " range [" + std::to_string(r.offset) + ", " +
                               std::to_string(r.offset + r.count) + ") of '" + name + "' exceeds its " +
                               std::to_string(job->meta.count) + " Gaussians");
    }
    job->ranges.push_back(Range{r.offset, r.count, *next_dst});
    *next_dst += r.count;
    covered = r.offset + r.count;
  }
  return Status();
}

Result<InputScene> read_sog_lod_impl(const std::string& named_path, const SceneReadOptions& options) {
  SceneEntry entry;
  RGS_RETURN_IF_ERROR(read_entry(named_path, "lod-meta.json", kMaxMetaBytes, &entry));
  const std::string& path = entry.path;
  const std::vector<uint8_t>& bytes = entry.bytes;
  const detail::SceneFolder& folder = *entry.folder;
  RGS_ASSIGN_OR_RETURN(json root, parse_json(bytes, path, "streamed SOG lod-meta.json"));
  if (!root.is_object()) return corrupt(path, "top level is a " + type_name(root) + ", not an object");
  InputScene scene;
  std::vector<uint64_t> hashes;
  if (options.hash_file) hashes.push_back(XXH64(bytes.data(), bytes.size(), 0));

  RGS_ASSIGN_OR_RETURN(const LodIndex index, parse_lod_index(root, path, folder, options));
  const auto& [levels, lod, names] = index;
  RGS_ASSIGN_OR_RETURN(const json* tree, member(root, "tree", path, ""));
  std::vector<LodReference> refs;
  const auto flag = root.find("lodErrors");
  if (flag != root.end() && !flag->is_boolean()) return corrupt(path, "'lodErrors' is not a boolean");
  const bool with_errors = flag != root.end() && flag->get<bool>();
  RGS_RETURN_IF_ERROR(
      collect_references(*tree, levels, names.size(), lod, path, &refs, with_errors ? &scene.lod_errors : nullptr));

  // Group by file (ascending), ranges by offset; check totals before allocating anything for them.
  std::map<uint64_t, std::vector<LodReference>> by_file;
  uint64_t total = 0;
  for (const LodReference& r : refs) {
    if (r.count > options.max_gaussians || total > options.max_gaussians - r.count) {
      return Status(StatusCode::kLimitExceeded, path + ": LOD " + std::to_string(lod) + " references more than " +
                                                    std::to_string(options.max_gaussians) + " Gaussians (the limit)");
    }
    total += r.count;
    if (r.count > 0) by_file[r.file].push_back(r);
  }
  if (auto counts = root.find("counts"); counts != root.end()) {
    if (!counts->is_array() || counts->size() != levels) {
      return corrupt(path, "'counts' must be an array of " + std::to_string(levels) + " counts");
    }
    RGS_ASSIGN_OR_RETURN(uint64_t declared, count_value((*counts)[lod], path, "counts[" + std::to_string(lod) + "]"));
    if (declared != total) {
      return corrupt(path, "'counts[" + std::to_string(lod) + "]' is " + std::to_string(declared) +
                               ", but the tree references " + std::to_string(total) + " Gaussians for that level");
    }
  }

  std::vector<std::unique_ptr<FolderFiles>> folders;
  std::vector<ChunkJob> jobs;
  jobs.reserve(by_file.size());
  uint64_t next_dst = 0;
  uint32_t degree = 0;
  std::string degree_source;
  for (auto& [file, file_refs] : by_file) {
    std::sort(file_refs.begin(), file_refs.end(),
              [](const LodReference& a, const LodReference& b) { return a.offset < b.offset; });
    const std::string meta_path = folder.display(names[file]);
    std::vector<uint8_t> meta_bytes;
    Status read = folder.read(names[file], kMaxMetaBytes, &meta_bytes);
    if (!read.ok()) {
      return std::move(read.prepend(path + ": LOD " + std::to_string(lod) + " chunk '" +
                                    detail::bounded_text(names[file], 96) + "'"));
    }
    if (options.hash_file) hashes.push_back(XXH64(meta_bytes.data(), meta_bytes.size(), 0));
    ChunkJob job;
    job.meta_name = meta_path;
    RGS_RETURN_IF_ERROR(parse_sog_meta(meta_bytes, meta_path, "streamed SOG chunk meta.json", &job.meta));
    const size_t slash = names[file].rfind('/');
    folders.push_back(std::make_unique<FolderFiles>(
        &folder, slash == std::string::npos ? std::string() : names[file].substr(0, slash), meta_path));
    job.files = folders.back().get();
    job.hash = options.hash_file;
    RGS_RETURN_IF_ERROR(resolve_earlier_bands(&job.meta, *job.files));
    RGS_RETURN_IF_ERROR(add_lod_ranges(file_refs, names[file], path, lod, &job, &next_dst));
    const uint32_t d = declared_degree(job.meta);
    if (jobs.empty()) {
      degree = d;
      degree_source = names[file];
    } else if (d != degree) {
      return corrupt(path, "chunk '" + names[file] + "' has SH degree " + std::to_string(d) + ", chunk '" +
                               degree_source + "' has " + std::to_string(degree));
    }
    jobs.push_back(std::move(job));
  }

  // Hashed: the meta files first (read above, in file order), then each chunk's images in file order.
  RGS_RETURN_IF_ERROR(decode_scene(jobs, &folder, 0, options, path, degree, total, std::move(hashes), &scene));
  scene.format_id = "sog_lod";
  scene.storage_format = scene.format_id;
  scene.declared_vertices = total;
  scene.description = "PlayCanvas streamed SOG, LOD " + std::to_string(lod) + " of " + std::to_string(levels) + " (" +
                      std::to_string(jobs.size()) + (jobs.size() == 1 ? " chunk)" : " chunks)");
  return scene;
}

/// Adds the images named by the SOG meta.json in `bytes` (the file `where`, in the folder `base` of the scene's
/// folder) to `out`, as read_sog would name them.
Status list_meta_images(const std::vector<uint8_t>& bytes, const std::string& where,
                        const detail::SceneFolder& folder, const std::string& base, std::vector<std::string>* out) {
  SogMeta meta;
  RGS_RETURN_IF_ERROR(parse_sog_meta(bytes, where, "SOG meta.json", &meta));
  for (size_t slot : image_slots(meta)) {
    RGS_ASSIGN_OR_RETURN(std::string relative, folder.resolve(meta.files[slot], base, where, kSlotNames[slot]));
    out->push_back(folder.display(relative));
  }
  return Status();
}

}  // namespace

Result<InputScene> read_sog(const std::string& path, const SceneReadOptions& options) {
  return guarded(path, [&] { return read_sog_impl(path, options); });
}

Result<InputScene> read_sog_lod(const std::string& path, const SceneReadOptions& options) {
  return guarded(path, [&] { return read_sog_lod_impl(path, options); });
}

namespace detail {

Result<std::vector<std::string>> list_sog_files(const std::string& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    std::vector<uint8_t> head;
    uint64_t size = 0;
    RGS_RETURN_IF_ERROR(read_file_head(path, 4, &head, &size));
    if (has_zip_magic(head.data(), head.size())) return std::vector<std::string>{path};  // a bundle: one file
  }
  SceneEntry entry;
  RGS_RETURN_IF_ERROR(read_entry(path, "meta.json", kMaxMetaBytes, &entry));
  std::vector<std::string> files = {entry.path};
  RGS_RETURN_IF_ERROR(list_meta_images(entry.bytes, entry.path, *entry.folder, "", &files));
  return files;
}

Result<std::vector<std::string>> list_sog_lod_files(const std::string& path) {
  SceneEntry entry;
  RGS_RETURN_IF_ERROR(read_entry(path, "lod-meta.json", kMaxMetaBytes, &entry));
  RGS_ASSIGN_OR_RETURN(json root, parse_json(entry.bytes, entry.path, "streamed SOG lod-meta.json"));
  std::vector<std::string> files = {entry.path};
  const json* names = root.is_object() && root.contains("filenames") ? &root["filenames"] : nullptr;
  if (names == nullptr || !names->is_array()) return files;  // read_sog_lod names the problem
  for (size_t i = 0; i < names->size(); ++i) {
    const json& n = (*names)[i];
    if (!n.is_string()) continue;
    RGS_ASSIGN_OR_RETURN(std::string relative,
                         entry.folder->resolve(n.get<std::string>(), "", entry.path,
                                               "filenames[" + std::to_string(i) + "]"));
    files.push_back(entry.folder->display(relative));
    // A chunk the level read does not use may be missing or damaged: list what can be listed.
    std::vector<uint8_t> bytes;
    if (!entry.folder->read(relative, kMaxMetaBytes, &bytes).ok()) continue;
    const size_t slash = relative.rfind('/');
    const std::string base = slash == std::string::npos ? std::string() : relative.substr(0, slash);
    std::vector<std::string> images;
    if (list_meta_images(bytes, files.back(), *entry.folder, base, &images).ok()) {
      files.insert(files.end(), images.begin(), images.end());
    }
  }
  return files;
}

}  // namespace detail

}  // namespace rgs::converter
