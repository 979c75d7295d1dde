// PlayCanvas SOG writer (meta.json version 2 + lossless WebP images, as a folder or a bundled .sog), the
// layout read_sog reads and PlayCanvas splat-transform 3.7 writes (converter/INTEROP.md "SOG output").
#include "rgs/converter/sog_writer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../internal_interop.h"
#include "internal_kmeans.h"
#include "../internal_parallel.h"
#include "../internal_sog.h"
#include "../internal_webp.h"
#include "../internal_zip.h"
#include "rgs/converter/ply_writer.h"

namespace rgs::converter {

namespace {

using nlohmann::json;

using detail::kCodebookSize;
using detail::kMaxPaletteEntries;
using detail::kPaletteColumns;
/// Gaussians per worker of the per-Gaussian passes.
constexpr uint64_t kMinGaussiansPerWorker = 65536;

enum Image : size_t { kMeansLow, kMeansHigh, kQuats, kScales, kSh0, kCentroids, kLabels, kImages };
const char* const kImageNames[kImages] = {"means_l.webp", "means_u.webp",       "quats.webp",     "scales.webp",
                                          "sh0.webp",     "shN_centroids.webp", "shN_labels.webp"};

/// fn(i) for every Gaussian i in [0, n), in slices over the per-Gaussian passes' workers.
template <typename Fn>
Status for_each_gaussian(uint64_t n, Fn&& fn) {
  return detail::parallel_slices(n, detail::worker_count(n, kMinGaussiansPerWorker),
                                 [&](unsigned, uint64_t begin, uint64_t end) {
                                   for (uint64_t i = begin; i < end; ++i) fn(i);
                                 });
}

uint8_t to_byte(double v) { return static_cast<uint8_t>(std::lround(std::min(255.0, std::max(0.0, v)))); }

/// sign(x)·ln(|x| + 1): SOG's transform of positions before their 16-bit quantization.
double log_transform(double x) { return x < 0 ? -std::log1p(-x) : std::log1p(x); }

/// The SH palette size splat-transform chooses for n Gaussians: 1,024 per power of two of n / 1,024, at most
/// 65,536, and at most n.
uint32_t palette_size(size_t n) {
  uint64_t k = 1024;
  while (k < kMaxPaletteEntries && k * 2 <= n) k *= 2;
  return static_cast<uint32_t>(std::min<uint64_t>(k, n));
}

struct Images {
  detail::RgbaImage image[kImages];
};

void init_image(detail::RgbaImage* image, uint32_t width, uint32_t height) {
  image->width = width;
  image->height = height;
  image->rgba.assign(image->pixels() * 4, 0);
  for (size_t p = 3; p < image->rgba.size(); p += 4) image->rgba[p] = 255;
}

/// means_l / means_u and the meta's "means" group.
Status encode_means(const format::GaussianCloud& cloud, Images* img, json* meta) {
  const size_t n = cloud.size();
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = n ? log_transform(cloud.means[a]) : 0.0;
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      const double t = log_transform(cloud.means[i * 3 + a]);
      lo[a] = std::min(lo[a], t);
      hi[a] = std::max(hi[a], t);
    }
  }
  // Readers decode sign(v)·(exp|v| − 1): an axis whose span is below double's epsilon there reads as one point.
  for (int a = 0; a < 3; ++a) {
    auto decoded = [](double v) { return std::copysign(std::exp(std::fabs(v)) - 1, v); };
    char span[64];
    std::snprintf(span, sizeof span, "[%g, %g]", lo[a], hi[a]);
    RGS_RETURN_ERROR_IF(lo[a] != hi[a] && decoded(lo[a]) == decoded(hi[a]), StatusCode::kInvalidArgument,
                        "means along axis " + std::to_string(a) + " span " + span +
                            ", which SOG's log-encoded positions read back as one point");
  }
  uint8_t* l = img->image[kMeansLow].rgba.data();
  uint8_t* u = img->image[kMeansHigh].rgba.data();
  RGS_RETURN_IF_ERROR(for_each_gaussian(n, [&](uint64_t i) {
    for (int a = 0; a < 3; ++a) {
      const double span = hi[a] - lo[a];
      const double unit = span > 0 ? (log_transform(cloud.means[i * 3 + a]) - lo[a]) / span : 0.0;
      const auto q = static_cast<uint32_t>(std::lround(std::min(1.0, std::max(0.0, unit)) * 65535.0));
      l[i * 4 + a] = static_cast<uint8_t>(q & 0xff);
      u[i * 4 + a] = static_cast<uint8_t>(q >> 8);
    }
  }));
  (*meta)["means"] = {{"mins", {lo[0], lo[1], lo[2]}},
                      {"maxs", {hi[0], hi[1], hi[2]}},
                      {"files", {kImageNames[kMeansLow], kImageNames[kMeansHigh]}}};
  return Status();
}

/// quats: the smallest three of each normalized (w, x, y, z), the largest made positive, its index + 252 in alpha.
Status encode_quats(const format::GaussianCloud& cloud, Images* img, json* meta) {
  const size_t n = cloud.size();
  uint8_t* px = img->image[kQuats].rgba.data();
  RGS_RETURN_IF_ERROR(for_each_gaussian(n, [&](uint64_t i) {
    double q[4], norm = 0;
    for (int c = 0; c < 4; ++c) {
      q[c] = cloud.rotations[i * 4 + c];
      norm += q[c] * q[c];
    }
    norm = norm > 0 ? std::sqrt(norm) : 1.0;
    int largest = 0;
    for (int c = 1; c < 4; ++c) {
      if (std::fabs(q[c]) > std::fabs(q[largest])) largest = c;
    }
    const double sign = q[largest] < 0 ? -1.0 : 1.0;
    int next = 0;
    for (int c = 0; c < 4; ++c) {
      if (c == largest) continue;
      px[i * 4 + next++] = to_byte((sign * q[c] / norm * std::sqrt(2.0) * 0.5 + 0.5) * 255.0);
    }
    px[i * 4 + 3] = static_cast<uint8_t>(252 + largest);
  }));
  (*meta)["quats"] = {{"files", {kImageNames[kQuats]}}};
  return Status();
}

/// Codes of `values` ([n, channels] with `stride` floats per Gaussian) through a k-means codebook, into the
/// first `channels` bytes of each pixel of `image`; returns the codebook.
Result<std::vector<float>> encode_codebook(const std::vector<float>& values, size_t n, uint32_t channels,
                                           uint32_t iterations, detail::RgbaImage* image) {
  std::vector<float> codebook = detail::kmeans_codebook(values.data(), values.size(), kCodebookSize, iterations);
  uint8_t* px = image->rgba.data();
  RGS_RETURN_IF_ERROR(for_each_gaussian(n, [&](uint64_t i) {
    for (uint32_t c = 0; c < channels; ++c) px[i * 4 + c] = detail::nearest_code(codebook, values[i * channels + c]);
  }));
  return codebook;
}

/// scales (log scales through a codebook) and sh0 (SH DC through a codebook, opacity in alpha).
Status encode_scales_and_sh0(const format::GaussianCloud& cloud, uint32_t iterations, Images* img, json* meta) {
  const size_t n = cloud.size();
  const uint32_t k_count = cloud.sh_coefficients();
  std::vector<float> values(n * 3);
  for (size_t j = 0; j < n * 3; ++j) {
    values[j] = cloud.scales[j] > 0 ? std::log(cloud.scales[j]) : kZeroScaleLog;
  }
  RGS_ASSIGN_OR_RETURN(std::vector<float> scales, encode_codebook(values, n, 3, iterations, &img->image[kScales]));
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) values[i * 3 + c] = cloud.sh[i * k_count * 3 + c];
  }
  RGS_ASSIGN_OR_RETURN(std::vector<float> sh0, encode_codebook(values, n, 3, iterations, &img->image[kSh0]));
  uint8_t* px = img->image[kSh0].rgba.data();
  for (size_t i = 0; i < n; ++i) px[i * 4 + 3] = to_byte(static_cast<double>(cloud.opacities[i]) * 255.0);
  (*meta)["scales"] = {{"codebook", scales}, {"files", {kImageNames[kScales]}}};
  (*meta)["sh0"] = {{"codebook", sh0}, {"files", {kImageNames[kSh0]}}};
  return Status();
}

/// shN: a palette of SH rest vectors (labels image) whose values go through a codebook (centroids image).
Status encode_shn(const format::GaussianCloud& cloud, uint32_t iterations, Images* img, json* meta,
                  uint32_t* palette_entries) {
  const size_t n = cloud.size();
  const uint32_t k_count = cloud.sh_coefficients();
  const uint32_t rest = k_count - 1;
  const uint32_t dim = rest * 3;
  std::vector<float> palette;
  std::vector<uint32_t> labels;
  RGS_RETURN_IF_ERROR(detail::kmeans_palette(cloud.sh.data() + 3, n, size_t{k_count} * 3, dim, palette_size(n),
                                             iterations, &palette, &labels));
  const auto entries = static_cast<uint32_t>(palette.size() / dim);
  *palette_entries = entries;
  const std::vector<float> codebook =
      detail::kmeans_codebook(palette.data(), palette.size(), kCodebookSize, iterations);
  init_image(&img->image[kCentroids], kPaletteColumns * rest, (entries + kPaletteColumns - 1) / kPaletteColumns);
  uint8_t* cp = img->image[kCentroids].rgba.data();
  const size_t width = img->image[kCentroids].width;
  for (uint32_t p = 0; p < entries; ++p) {
    for (uint32_t j = 0; j < rest; ++j) {
      uint8_t* px = cp + ((p / kPaletteColumns) * width + (p % kPaletteColumns) * rest + j) * 4;
      for (int c = 0; c < 3; ++c) px[c] = detail::nearest_code(codebook, palette[size_t{p} * dim + j * 3 + c]);
    }
  }
  uint8_t* lp = img->image[kLabels].rgba.data();
  for (size_t i = 0; i < n; ++i) {
    lp[i * 4] = static_cast<uint8_t>(labels[i] & 0xff);
    lp[i * 4 + 1] = static_cast<uint8_t>(labels[i] >> 8);
  }
  (*meta)["shN"] = {{"count", entries},
                    {"bands", cloud.sh_degree},
                    {"codebook", codebook},
                    {"files", {kImageNames[kCentroids], kImageNames[kLabels]}}};
  return Status();
}

Status check_sog_input(const format::GaussianCloud& cloud, const SogWriteOptions& options) {
  RGS_RETURN_IF_ERROR(detail::check_writable_cloud(cloud));
  RGS_RETURN_ERROR_IF(cloud.size() > 0xffffffffull, StatusCode::kInvalidArgument,
                      "SOG holds at most 2^32 - 1 Gaussians; the cloud has " + std::to_string(cloud.size()));
  RGS_RETURN_ERROR_IF(options.kmeans_iterations == 0, StatusCode::kInvalidArgument,
                      "SOG k-means needs at least one iteration");
  return Status();
}

Result<std::vector<SogFile>> encode_sog_checked(const format::GaussianCloud& cloud, const SogWriteOptions& options,
                                                SogWriteSummary* summary) {
  RGS_RETURN_IF_ERROR(check_sog_input(cloud, options));
  const size_t n = cloud.size();
  const uint32_t width = std::max<uint32_t>(4, 4 * static_cast<uint32_t>(std::ceil(std::sqrt(double(n)) / 4)));
  const uint32_t height = std::max<uint32_t>(4, 4 * static_cast<uint32_t>((n + size_t{width} * 4 - 1) / (size_t{width} * 4)));
  Images img;
  const bool has_shn = cloud.sh_degree > 0;
  for (size_t s = 0; s < kImages; ++s) {
    if (s != kCentroids && (has_shn || s != kLabels)) init_image(&img.image[s], width, height);
  }
  json meta = {{"version", 2}, {"asset", {{"generator", "RoofGS"}}}, {"count", n}};
  RGS_RETURN_IF_ERROR(encode_means(cloud, &img, &meta));
  RGS_RETURN_IF_ERROR(encode_quats(cloud, &img, &meta));
  RGS_RETURN_IF_ERROR(encode_scales_and_sh0(cloud, options.kmeans_iterations, &img, &meta));
  uint32_t palette_entries = 0;
  if (has_shn) RGS_RETURN_IF_ERROR(encode_shn(cloud, options.kmeans_iterations, &img, &meta, &palette_entries));
  const size_t images = has_shn ? kImages : kCentroids;
  std::vector<SogFile> files(1 + images);
  std::vector<Status> errors(images);
  RGS_RETURN_IF_ERROR(detail::parallel_items(images, detail::worker_count(images, 1), [&](unsigned, uint64_t s) {
    files[1 + s].name = kImageNames[s];
    auto webp = detail::encode_webp_lossless(img.image[s], kImageNames[s]);
    if (webp.ok()) files[1 + s].bytes = std::move(webp).value();
    errors[s] = webp.status();
  }));
  for (Status& s : errors) RGS_RETURN_IF_ERROR(s);
  const std::string text = meta.dump();
  files[0] = {"meta.json", std::vector<uint8_t>(text.begin(), text.end())};
  if (summary != nullptr) {
    summary->sh_degree = cloud.sh_degree;
    summary->palette_entries = palette_entries;
    summary->image_width = width;
    summary->image_height = height;
    summary->limitations = {
        "positions: 16 bits per axis of sign(x)·ln(|x| + 1) over the scene's range",
        "rotations: smallest three, 8 bits per component",
        "scales and SH DC colours: 256-entry k-means codebooks; opacity: 8 bits",
    };
    if (has_shn) {
      summary->limitations.push_back("SH rest: a palette of " + std::to_string(palette_entries) +
                                     " k-means vectors, their values through a 256-entry codebook");
    }
  }
  return files;
}

/// True when the last component of `path` is `entry` in any case (a SOG folder's or streamed SOG's entry file).
bool names_entry(const std::string& path, const char* entry) {
  std::string name = std::filesystem::path(path).filename().string();
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name == entry;
}

}  // namespace

Result<std::vector<SogFile>> encode_sog(const format::GaussianCloud& cloud, const SogWriteOptions& options,
                                       SogWriteSummary* summary) {
  return detail::guarded<std::vector<SogFile>>("", "encoding SOG",
                                               [&] { return encode_sog_checked(cloud, options, summary); });
}

std::vector<uint8_t> bundle_sog(const std::vector<SogFile>& files) {
  std::vector<detail::ZipSource> sources;
  for (const SogFile& f : files) sources.push_back({f.name, &f.bytes});
  return detail::write_stored_zip(sources);
}

bool is_sog_folder_path(const std::string& path) { return names_entry(path, "meta.json"); }
bool is_sog_lod_path(const std::string& path) { return names_entry(path, "lod-meta.json"); }

std::vector<std::string> sog_folder_files(const std::string& meta_path) {
  const std::filesystem::path folder = std::filesystem::path(meta_path).parent_path();
  std::vector<std::string> out;
  for (const char* name : kImageNames) out.push_back((folder / name).string());
  out.push_back(meta_path);
  return out;
}

Result<SogWriteSummary> write_sog(const std::string& path, const format::GaussianCloud& cloud,
                                  const SogWriteOptions& options, format::FileSink& sink) {
  SogWriteSummary summary;
  auto encoded = encode_sog(cloud, options, &summary);
  if (!encoded.ok()) return Status(encoded.status()).prepend(path);
  const std::vector<SogFile> files = std::move(encoded).value();
  if (options.container == SogContainer::kBundle) {
    const std::vector<uint8_t> zip = bundle_sog(files);
    RGS_RETURN_IF_ERROR(sink.write(path, zip.data(), zip.size()));
    summary.bytes = zip.size();
    summary.files = {path};
    return summary;
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  // Images first, meta.json last: a reader that finds meta.json finds its images.
  std::vector<std::string> targets;
  for (size_t f = 1; f <= files.size(); ++f) {
    targets.push_back(f % files.size() == 0 ? path : (folder / files[f].name).string());
  }
  RGS_RETURN_IF_ERROR(sink.declare(targets));
  for (size_t f = 1; f <= files.size(); ++f) {
    const SogFile& file = files[f % files.size()];
    const std::string& target = targets[f - 1];
    RGS_RETURN_IF_ERROR(sink.write(target, file.bytes.data(), file.bytes.size()));
    summary.bytes += file.bytes.size();
    summary.files.push_back(target);
  }
  return summary;
}

}  // namespace rgs::converter
