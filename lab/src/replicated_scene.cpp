// A scene file tiled K times as .rgs bytes.
#include "rgs/lab/replicated_scene.h"

#include <string>
#include <utility>

#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/writer.h"
#include "rgs/lab/replicate.h"

namespace rgs::lab {

namespace {
Status check_replicated_count(const std::string& path, uint64_t count, uint32_t copies) {
  RGS_RETURN_ERROR_IF(copies == 0, StatusCode::kInvalidArgument, "replicate: the number of copies must be >= 1");
  const uint64_t total = count * uint64_t(copies);  // < 2^64: count < 2^63 from any reader, copies < 2^32
  RGS_RETURN_ERROR_IF(count > kMaxGpuGaussians || total > kMaxGpuGaussians, StatusCode::kLimitExceeded,
                      path + ": " + std::to_string(copies) + " copies of " + std::to_string(count) + " Gaussians = " +
                          std::to_string(total) + " exceed the 32-bit Gaussian count limit of " +
                          std::to_string(kMaxGpuGaussians));
  return Status();
}
}  // namespace

Result<ReplicatedScene> replicate_scene_file(const std::string& path, uint32_t copies,
                                             const converter::SceneReadOptions& options) {
  ReplicatedScene out;
  out.copies = copies;
  format::EncodedScene source;
  converter::SceneReadOptions read_options = options;
  read_options.keep_encoded = true;  // a .rgs source is replicated as stored
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(path, read_options));
  RGS_RETURN_IF_ERROR(check_replicated_count(path, input.cloud.size(), copies));
  out.source_file_bytes = input.file_bytes;
  out.notes = std::move(input.notes);
  if (input.encoded) {
    source = std::move(*input.encoded);
    out.source_is_rgs = true;
    out.quantization = "as stored in the source .rgs (attributes copied unchanged)";
  } else {
    auto encoded = converter::quantize(input.cloud, converter::QuantizeOptions{});
    if (!encoded.ok()) return Status(encoded.status()).prepend(path);
    source = std::move(encoded).value();
    out.quantization = "rgs-convert defaults (linear FP16 scales, SH scale = max |SH| / 127)";
  }
  input.cloud = format::GaussianCloud{};
  out.source_gaussians = source.count;
  auto replicated = replicate(source, copies);
  if (!replicated.ok()) return Status(replicated.status()).prepend(path);
  source = format::EncodedScene{};  // free the single copy before serializing the K copies
  out.gaussians = replicated->count;
  out.sh_degree = replicated->metadata.sh_degree;
  out.bounds = replicated->metadata.bounds;
  auto bytes = format::serialize_scene(*replicated);
  if (!bytes.ok()) return Status(bytes.status()).prepend(path + " x" + std::to_string(copies));
  out.rgs_bytes = std::move(bytes).value();
  return out;
}

}  // namespace rgs::lab
