// PLY writer: the exact layout of the INRIA 3DGS `GaussianModel.save_ply` (plyfile, binary little endian).
#include "rgs/converter/ply_writer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "../internal_interop.h"
#include "rgs/format/file_io.h"

namespace rgs::converter {

namespace {

/// Gaussians serialized per chunk handed to the file sink.
constexpr uint64_t kRowsPerChunk = 16384;

/// Floats per row: x y z nx ny nz f_dc×3 f_rest×(3K−3) opacity scale×3 rot×4.
uint64_t row_floats(uint32_t k_count) { return 3 + 3 + 3 + 3 * (uint64_t{k_count} - 1) + 1 + 3 + 4; }

/// The header text INRIA's save_ply (through plyfile) writes, byte for byte.
std::string header_text(const format::GaussianCloud& cloud) {
  const uint32_t k_count = cloud.sh_coefficients();
  std::string h = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(cloud.size()) + "\n";
  auto prop = [&h](const std::string& name) { h += "property float " + name + "\n"; };
  for (const char* name : {"x", "y", "z", "nx", "ny", "nz"}) prop(name);
  for (int c = 0; c < 3; ++c) prop("f_dc_" + std::to_string(c));
  for (uint32_t r = 0; r < 3 * (k_count - 1); ++r) prop("f_rest_" + std::to_string(r));
  prop("opacity");
  for (int a = 0; a < 3; ++a) prop("scale_" + std::to_string(a));
  for (int a = 0; a < 4; ++a) prop("rot_" + std::to_string(a));
  h += "end_header\n";
  return h;
}

inline uint8_t* put_f32_le(uint8_t* out, float v) {
  format::store_f32_le(out, v);
  return out + 4;
}

/// Inverse sigmoid with the clamp that keeps opacity 1 (exact in FP16) finite: ±13.8155.
inline float opacity_logit(float o) {
  const double c = std::clamp(static_cast<double>(o), 1e-6, 1.0 - 1e-6);
  return static_cast<float>(std::log(c / (1.0 - c)));
}

/// Serializes Gaussians [first, first + n) into `out` (n · row_floats · 4 bytes), counting zero scales in
/// `report`. Fails on the first Gaussian with a value a PLY reader would reject (non-finite, or a negative
/// scale, whose log is NaN), before its row is written.
Status serialize_rows(const format::GaussianCloud& cloud, uint64_t first, uint64_t n, uint8_t* out,
                      PlyWriteReport* report) {
  const uint32_t k_count = cloud.sh_coefficients();
  const uint64_t sh_values = uint64_t{k_count} * 3;
  const bool pre_activation = cloud.pre_activation.size() == cloud.size() * 4;
  for (uint64_t i = first; i < first + n; ++i) {
    bool finite = true;
    for (int a = 0; a < 3; ++a) finite = finite && std::isfinite(cloud.means[i * 3 + a]);
    for (int a = 0; a < 4; ++a) finite = finite && std::isfinite(cloud.rotations[i * 4 + a]);
    for (int a = 0; a < 3; ++a) {
      finite = finite && std::isfinite(cloud.scales[i * 3 + a]) && cloud.scales[i * 3 + a] >= 0;
    }
    finite = finite && !std::isnan(cloud.opacities[i]);
    for (uint64_t j = 0; j < sh_values; ++j) finite = finite && std::isfinite(cloud.sh[i * sh_values + j]);
    if (!finite) {
      return Status(StatusCode::kInvalidArgument,
                    "Gaussian " + std::to_string(i) + " has a non-finite value or a negative scale; a PLY holds "
                    "only finite values");
    }
    for (int a = 0; a < 3; ++a) out = put_f32_le(out, cloud.means[i * 3 + a]);
    for (int a = 0; a < 3; ++a) out = put_f32_le(out, 0.0f);
    const float* sh = cloud.sh.data() + i * k_count * 3;
    for (int c = 0; c < 3; ++c) out = put_f32_le(out, sh[c]);
    // f_rest channel-major: f_rest[c·(K−1) + k−1] = SH coefficient k of channel c.
    for (int c = 0; c < 3; ++c) {
      for (uint32_t k = 1; k < k_count; ++k) out = put_f32_le(out, sh[k * 3 + c]);
    }
    // The source PLY's logit and log scales where they still activate to this Gaussian's values: bit for bit.
    const float* raw = pre_activation ? &cloud.pre_activation[i * 4] : nullptr;
    const auto kept = [raw](int j, float value, float (*activate)(float)) {
      return raw != nullptr && std::isfinite(raw[j]) && activate(raw[j]) == value;
    };
    const float o = cloud.opacities[i];
    out = put_f32_le(out, kept(0, o, detail::activate_opacity) ? raw[0] : opacity_logit(o));
    for (int a = 0; a < 3; ++a) {
      const float s = cloud.scales[i * 3 + a];
      const bool as_read = kept(1 + a, s, detail::activate_scale);
      if (s == 0.0f && !as_read) ++report->zero_scales;
      out = put_f32_le(out, as_read ? raw[1 + a]
                            : s == 0.0f ? kZeroScaleLog
                                        : static_cast<float>(std::log(static_cast<double>(s))));
    }
    for (int a = 0; a < 4; ++a) out = put_f32_le(out, cloud.rotations[i * 4 + a]);
  }
  return Status();
}

}  // namespace

Result<std::vector<uint8_t>> serialize_ply(const format::GaussianCloud& cloud, PlyWriteReport* report) {
  RGS_RETURN_IF_ERROR(detail::check_cloud_shape(cloud));
  return catch_bad_alloc([&]() -> Result<std::vector<uint8_t>> {
    const std::string header = header_text(cloud);
    const uint64_t row_bytes = row_floats(cloud.sh_coefficients()) * 4;
    std::vector<uint8_t> bytes(header.size() + cloud.size() * row_bytes);
    std::memcpy(bytes.data(), header.data(), header.size());
    PlyWriteReport counts;
    RGS_RETURN_IF_ERROR(serialize_rows(cloud, 0, cloud.size(), bytes.data() + header.size(), &counts));
    if (report != nullptr) *report = counts;
    return bytes;
  }, [&] { return "out of memory serializing " + std::to_string(cloud.size()) + " Gaussians to PLY"; });
}

Result<uint64_t> write_ply(const std::string& path, const format::GaussianCloud& cloud, PlyWriteReport* report,
                           format::FileSink& files) {
  Status valid = detail::check_cloud_shape(cloud);
  if (!valid.ok()) return std::move(valid.prepend(path));
  uint64_t written = 0;
  PlyWriteReport counts;
  const Status s = catch_bad_alloc([&] {
    const std::string header = header_text(cloud);
    const uint64_t row_bytes = row_floats(cloud.sh_coefficients()) * 4;
    std::vector<uint8_t> chunk(static_cast<size_t>(std::min<uint64_t>(cloud.size(), kRowsPerChunk) * row_bytes));
    return files.write(path, [&](const format::ChunkSink& sink) -> Status {
      RGS_RETURN_IF_ERROR(sink(header.data(), header.size()));
      written = header.size();
      for (uint64_t first = 0; first < cloud.size(); first += kRowsPerChunk) {
        const uint64_t n = std::min(kRowsPerChunk, cloud.size() - first);
        Status rows = serialize_rows(cloud, first, n, chunk.data(), &counts);
        if (!rows.ok()) return rows.prepend(path);
        RGS_RETURN_IF_ERROR(sink(chunk.data(), static_cast<size_t>(n * row_bytes)));
        written += n * row_bytes;
      }
      return Status();
    });
  }, [&] { return path + ": out of memory writing the PLY"; });
  RGS_RETURN_IF_ERROR(s);
  if (report != nullptr) *report = counts;
  return written;
}

}  // namespace rgs::converter
