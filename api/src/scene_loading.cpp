// Host scene loading, replication and camera choice (shared by the tools and the front door).
#include "rgs/api/scene_loading.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/replicate.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace rgs::api {

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


Result<HostScene> load_host_scene(const std::string& path, const converter::SceneReadOptions& options) {
  HostScene scene;
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(path, options));
  scene.cloud = std::move(input.cloud);
  scene.bounds = input.bounds;
  scene.is_rgs = input.format_id == "rgs";
  scene.file_bytes = input.file_bytes;
  scene.format_id = std::move(input.format_id);
  scene.description = std::move(input.description);
  scene.notes = std::move(input.notes);
  return scene;
}

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
  auto replicated = converter::replicate(source, copies);
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

Result<std::vector<runtime::Camera>> make_cameras(const CameraChoice& choice, const format::SceneBounds& bounds) {
  std::vector<runtime::Camera> cameras;
  RGS_RETURN_ERROR_IF(choice.fly > 0 && choice.cameras_path.empty(), StatusCode::kInvalidArgument,
                      "--fly " + std::to_string(choice.fly) +
                          " needs --cameras: the views are flown through the cameras of that file");
  if (!choice.cameras_path.empty()) {
    runtime::InriaCameraOptions options;
    options.every_kth = choice.every;
    options.width = choice.width;
    options.height = choice.height;
    RGS_ASSIGN_OR_RETURN(cameras, runtime::load_inria_cameras(choice.cameras_path, options));
    if (choice.limit > 0 && cameras.size() > choice.limit) cameras.resize(choice.limit);
    if (choice.fly > 0) {
      // A file may mix image sizes; the views take the first key's intrinsics, so the keys share its size.
      for (runtime::Camera& key : cameras) {
        if (key.width != cameras[0].width || key.height != cameras[0].height) {
          key = runtime::resize_camera(key, cameras[0].width, cameras[0].height);
        }
      }
      Result<std::vector<runtime::Camera>> flown = runtime::fly_through_cameras(cameras, choice.fly);
      if (!flown.ok()) return Status(flown.status()).prepend(choice.cameras_path);
      return flown;
    }
  } else {
    RGS_RETURN_ERROR_IF(choice.orbit == 0 && choice.path == 0, StatusCode::kInvalidArgument,
                        "--orbit needs at least 1 camera");
    uint32_t w = choice.width, h = choice.height;
    if (w == 0 && h == 0) {
      w = choice.orbit_width;
      h = choice.orbit_height;
    } else if (h == 0) {
      h = static_cast<uint32_t>(std::max(1.0, std::round(double(w) * choice.orbit_height / choice.orbit_width)));
    } else if (w == 0) {
      w = static_cast<uint32_t>(std::max(1.0, std::round(double(h) * choice.orbit_width / choice.orbit_height)));
    }
    if (choice.path > 0) {
      RGS_ASSIGN_OR_RETURN(cameras, runtime::path_cameras(bounds, choice.path, w, h));
    } else {
      RGS_ASSIGN_OR_RETURN(cameras, runtime::orbit_cameras(bounds, choice.orbit, w, h));
    }
  }
  if (choice.limit > 0 && cameras.size() > choice.limit) cameras.resize(choice.limit);
  return cameras;
}


}  // namespace rgs::api
