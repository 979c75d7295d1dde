// The memory a conversion may use (ConvertOptions::memory_limit) and the estimate of what it needs, checked
// before the input is read (docs/LOD.md#scenes-larger-than-memory).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "internal_pipeline.h"
#include "rgs/api/convert.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/gaussian_cloud.h"

namespace rgs::api {

namespace {

/// Peak RSS over input bytes, by converter::detect_scene_format's id, rounded up from conversions to a .rgs
/// with levels of detail (docs/LOD.md#scenes-larger-than-memory): a float PLY needs about its own size,
/// a .rgs about three times its own, the compact formats seven to ten times theirs.
struct MemoryFactor {
  const char* format_id;
  double peak_per_input_byte;
};
constexpr MemoryFactor kMemoryFactors[] = {{"ply", 1.5}, {"rgs", 4.0}};
/// Every other format: compact encodings (SPZ, SOG, compressed PLY, glTF, .ksplat, .splat).
constexpr double kCompactPeakPerInputByte = 8.0;
/// What a conversion holds whatever its input: the program, its libraries and the writer's buffers.
constexpr uint64_t kBaseBytes = uint64_t{64} << 20;

double peak_per_input_byte(const std::string& format_id) {
  for (const MemoryFactor& f : kMemoryFactors) {
    if (format_id == f.format_id) return f.peak_per_input_byte;
  }
  return kCompactPeakPerInputByte;
}

/// The estimated peak of reading `input_bytes` of a format whole.
uint64_t estimate_bytes(uint64_t input_bytes, double factor) {
  return kBaseBytes + uint64_t(double(input_bytes) * factor);
}

std::string bytes_text(uint64_t bytes) {
  char text[32];
  const bool gib = bytes >= (uint64_t{1} << 30);
  std::snprintf(text, sizeof(text), gib ? "%.2f GiB" : "%.1f MiB",
                double(bytes) / double(uint64_t{1} << (gib ? 30 : 20)));
  return text;
}

}  // namespace

uint64_t convert_memory_limit(const ConvertOptions& options) {
  if (options.memory_limit != 0) return options.memory_limit;
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page_size <= 0) return 0;
  return uint64_t(pages) * uint64_t(page_size) / 2;
}

Result<uint64_t> estimate_convert_memory(const std::string& src) {
  RGS_ASSIGN_OR_RETURN(std::string format_id, converter::detect_scene_format(src));
  RGS_ASSIGN_OR_RETURN(std::vector<std::string> files, converter::list_scene_files(src));
  uint64_t input_bytes = 0;
  for (const std::string& file : files) {
    // A streamed SOG lists the files of every level, and a folder may hold only some: the reader reports those
    // it needs and cannot find.
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(file, ec);
    if (!ec) input_bytes += uint64_t(size);
  }
  return estimate_bytes(input_bytes, peak_per_input_byte(format_id));
}

Result<uint64_t> estimate_convert_memory(const std::vector<std::string>& srcs) {
  uint64_t estimate = kBaseBytes;
  for (const std::string& src : srcs) {
    RGS_ASSIGN_OR_RETURN(const uint64_t one, estimate_convert_memory(src));
    estimate += one - kBaseBytes;
  }
  return estimate;
}

uint64_t estimate_merged_memory(uint64_t gaussians, uint32_t sh_degree) {
  // An INRIA PLY holds 14 floats a Gaussian (normals included) and 3 per SH coefficient.
  const uint64_t ply_bytes = sizeof(float) * (14 + 3 * uint64_t{format::sh_coefficient_count(sh_degree)});
  return estimate_bytes(gaussians * ply_bytes, peak_per_input_byte("ply"));
}

uint64_t max_whole_input_bytes(const std::string& format_id, const ConvertOptions& options) {
  const uint64_t limit = convert_memory_limit(options);
  if (limit == 0) return UINT64_MAX;
  if (limit <= kBaseBytes) return 0;
  // A PLY file's reader does not keep the file resident; a stream held whole is, for the whole conversion
  // (daffodils, 88.9 MB: 100 MB peak from the file, 179 MB from standard input). A .rgs file is held either way.
  const double factor = peak_per_input_byte(format_id) + (format_id == "ply" ? 1.0 : 0.0);
  uint64_t most = uint64_t(double(limit - kBaseBytes) / factor);
  while (estimate_bytes(most + 1, factor) <= limit) ++most;  // the estimate rounds down
  return most;
}

namespace detail {

Status check_convert_memory(const std::string& src, uint64_t estimate, const ConvertOptions& options,
                            const std::string& what) {
  const uint64_t limit = convert_memory_limit(options);
  RGS_RETURN_ERROR_IF(limit != 0 && estimate > limit, StatusCode::kLimitExceeded,
                      src + ": " + what + " is estimated to need " + bytes_text(estimate) +
                          " of memory, above the memory limit of " + bytes_text(limit) +
                          " (the input is read whole: only a binary PLY converted with levels of detail is read in batches); "
                          "raise it with memory_limit (--memory-limit)");
  return Status();
}

}  // namespace detail

}  // namespace rgs::api
