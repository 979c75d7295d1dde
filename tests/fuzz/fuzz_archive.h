// What the fuzz targets that end with a valid runtime-profile scene (fuzz_rgs_read.cpp, and through
// fuzz_sanitized_cloud.h fuzz_ply_read.cpp and fuzz_interop_read.cpp) assert about its archive profile: the archive
// keeps any scene the runtime profile keeps.
#pragma once

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "fuzz_check.h"
#include "rgs/format/archive.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/half.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace rgs::fuzz {

/// Scenes up to this many Gaussians are also archived (Draco and the section coders are slow next to the rest).
inline constexpr uint64_t kFuzzArchiveGaussians = 4096;

/// `scene` (a valid runtime-profile scene whose means span less than float32's largest value: wider ones are
/// refused with kInvalidArgument) encodes to the archive profile, the file validates and decodes to
/// encode_archive's scene, and a scale axis of one value in every kept Gaussian (a flat axis of zero scales, one
/// size for all, a scene of one Gaussian: a quantizer step of 0) decodes to exactly that value.
inline void check_archive(const format::EncodedScene& scene) {
  if (scene.count > kFuzzArchiveGaussians) return;
  format::WriteOptions write;
  write.profile = format::StorageProfile::kArchive;
  write.archive.zstd_level = 1;
  write.archive.xz = false;
  write.archive.threads = 1;
  auto archive = format::encode_archive(scene, write.archive);
  double extent = 0;  // means beyond the float32 position grid's reach are refused, and only those
  for (int a = 0; a < 3; ++a) {
    extent = std::max(extent, double(scene.metadata.bounds.aabb_max[a]) - scene.metadata.bounds.aabb_min[a]);
  }
  if (!(extent < double(std::numeric_limits<float>::max()))) {
    RGS_FUZZ_CHECK(!archive.ok() && archive.status().code() == StatusCode::kInvalidArgument,
                   "means of extent " + std::to_string(extent) + " archived");
    return;
  }
  // Means too close together for Draco's float32 grid are refused, by name (format/src/archive_encoder.cpp).
  if (!archive.ok() && archive.status().message().find("too close together") != std::string::npos) return;
  RGS_FUZZ_CHECK(archive.ok(), archive.status().to_string());
  auto bytes = format::serialize_scene(scene, write);
  RGS_FUZZ_CHECK(bytes.ok(), bytes.status().to_string());
  const Status valid = format::validate(bytes->data(), bytes->size());
  RGS_FUZZ_CHECK(valid.ok(), valid.to_string());
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  RGS_FUZZ_CHECK(file.ok(), file.status().to_string());
  auto read = file->read_scene();
  RGS_FUZZ_CHECK(read.ok(), read.status().to_string());
  const format::EncodedScene& d = archive->decoded;
  RGS_FUZZ_CHECK(read->scales == d.scales && read->opacities == d.opacities && read->rotations == d.rotations &&
                     read->sh == d.sh && read->means.size() == d.means.size(),
                 "the archive file does not decode to encode_archive's scene");
  if (d.count == 0) return;
  for (uint32_t a = 0; a < 3; ++a) {
    const uint16_t first = scene.scales[archive->source_index[0] * 3 + a];
    bool constant = true;
    for (uint64_t i = 1; i < d.count && constant; ++i) constant = scene.scales[archive->source_index[i] * 3 + a] == first;
    for (uint64_t i = 0; i < d.count && constant; ++i) {
      // The value, not the bits: −0 and +0 are one scale (a log scale of 0, or a linear scale of 0).
      RGS_FUZZ_CHECK(format::half_bits_to_float(d.scales[i * 3 + a]) == format::half_bits_to_float(first),
                     "scale axis " + std::to_string(a) + " of one value in every Gaussian decodes to another");
    }
  }
}

}  // namespace rgs::fuzz
