// INRIA 3DGS cameras.json loader (camera.h). nlohmann::json exceptions are caught here and never leave the
// library; every value is type- and range-checked before use.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "rgs/runtime/camera.h"

namespace rgs::runtime {
namespace {

using nlohmann::json;

constexpr uint64_t kMaxCamerasFileBytes = uint64_t{256} << 20;
constexpr int64_t kMaxImageSide = 32768;

Status corrupt(const std::string& name, const std::string& what) {
  return Status(StatusCode::kCorruptData, name + ": " + what);
}

/// Reads a finite number field of `cam` into *out.
Status get_number(const json& cam, const char* key, const std::string& where, double* out) {
  const auto it = cam.find(key);
  RGS_RETURN_ERROR_IF(it == cam.end(), StatusCode::kCorruptData, where + ": missing '" + key + "'");
  RGS_RETURN_ERROR_IF(!it->is_number(), StatusCode::kCorruptData, where + ": '" + key + "' is not a number");
  const double v = it->get<double>();
  RGS_RETURN_ERROR_IF(!std::isfinite(v), StatusCode::kCorruptData, where + ": '" + key + "' is not finite");
  *out = v;
  return Status::ok_status();
}

/// Reads an integer image side in [1, kMaxImageSide].
Status get_side(const json& cam, const char* key, const std::string& where, uint32_t* out) {
  const auto it = cam.find(key);
  RGS_RETURN_ERROR_IF(it == cam.end(), StatusCode::kCorruptData, where + ": missing '" + key + "'");
  RGS_RETURN_ERROR_IF(!it->is_number_integer(), StatusCode::kCorruptData,
                      where + ": '" + key + "' is not an integer");
  const int64_t v = it->get<int64_t>();
  RGS_RETURN_ERROR_IF(v < 1 || v > kMaxImageSide, StatusCode::kCorruptData,
                      where + ": '" + key + "' = " + std::to_string(v) + " outside [1, " +
                          std::to_string(kMaxImageSide) + "]");
  *out = static_cast<uint32_t>(v);
  return Status::ok_status();
}

/// Reads an array of `n` finite numbers.
Status get_vector(const json& v, size_t n, const std::string& what, double* out) {
  RGS_RETURN_ERROR_IF(!v.is_array() || v.size() != n, StatusCode::kCorruptData,
                      what + " is not an array of " + std::to_string(n) + " numbers");
  for (size_t i = 0; i < n; ++i) {
    RGS_RETURN_ERROR_IF(!v[i].is_number(), StatusCode::kCorruptData,
                        what + "[" + std::to_string(i) + "] is not a number");
    out[i] = v[i].get<double>();
    RGS_RETURN_ERROR_IF(!std::isfinite(out[i]), StatusCode::kCorruptData,
                        what + "[" + std::to_string(i) + "] is not finite");
  }
  return Status::ok_status();
}

/// Output resolution for a camera of the file's size under `options`.
void output_size(uint32_t w, uint32_t h, const InriaCameraOptions& options, uint32_t* out_w, uint32_t* out_h) {
  // Clamped so that the cast stays defined for any downscale > 0; validate_camera() refuses sides over the limit.
  auto at_least_one = [](double v) { return uint32_t(std::clamp(std::round(v), 1.0, kMaxImageSide + 1.0)); };
  if (options.width != 0 && options.height != 0) {
    *out_w = options.width;
    *out_h = options.height;
  } else if (options.width != 0) {
    *out_w = options.width;
    *out_h = at_least_one(double(h) * options.width / w);
  } else if (options.height != 0) {
    *out_h = options.height;
    *out_w = at_least_one(double(w) * options.height / h);
  } else {
    *out_w = at_least_one(w / options.downscale);
    *out_h = at_least_one(h / options.downscale);
  }
}

/// Parses camera `index` of the array.
Result<Camera> parse_camera(const json& cam, size_t index, const std::string& name,
                            const InriaCameraOptions& options) {
  const std::string where = name + ": camera " + std::to_string(index);
  RGS_RETURN_ERROR_IF(!cam.is_object(), StatusCode::kCorruptData, where + " is not a JSON object");
  uint32_t width = 0, height = 0;
  RGS_RETURN_IF_ERROR(get_side(cam, "width", where, &width));
  RGS_RETURN_IF_ERROR(get_side(cam, "height", where, &height));
  double fx = 0, fy = 0;
  RGS_RETURN_IF_ERROR(get_number(cam, "fx", where, &fx));
  RGS_RETURN_IF_ERROR(get_number(cam, "fy", where, &fy));
  RGS_RETURN_ERROR_IF(!(fx > 0) || !(fy > 0), StatusCode::kCorruptData,
                      where + ": focal lengths must be > 0 (fx=" + std::to_string(fx) +
                          ", fy=" + std::to_string(fy) + ")");
  const auto pos_it = cam.find("position");
  RGS_RETURN_ERROR_IF(pos_it == cam.end(), StatusCode::kCorruptData, where + ": missing 'position'");
  double position[3];
  RGS_RETURN_IF_ERROR(get_vector(*pos_it, 3, where + ": 'position'", position));
  const auto rot_it = cam.find("rotation");
  RGS_RETURN_ERROR_IF(rot_it == cam.end(), StatusCode::kCorruptData, where + ": missing 'rotation'");
  RGS_RETURN_ERROR_IF(!rot_it->is_array() || rot_it->size() != 3, StatusCode::kCorruptData,
                      where + ": 'rotation' is not a 3x3 array");
  double c2w[3][3];  // camera-to-world, c2w[i] = JSON row i
  for (size_t i = 0; i < 3; ++i) {
    RGS_RETURN_IF_ERROR(get_vector((*rot_it)[i], 3, where + ": 'rotation'[" + std::to_string(i) + "]", c2w[i]));
  }

  Camera camera;
  // R (world-to-camera) = c2wᵀ; t = −R·position.
  for (int i = 0; i < 3; ++i) {
    double t = 0;
    for (int j = 0; j < 3; ++j) {
      camera.rotation[i * 3 + j] = static_cast<float>(c2w[j][i]);
      t -= c2w[j][i] * position[j];
    }
    camera.translation[i] = static_cast<float>(t);
  }
  uint32_t out_w = 0, out_h = 0;
  output_size(width, height, options, &out_w, &out_h);
  // Keep the field of view: fx' = fx·W'/W.
  camera.fx = static_cast<float>(fx * out_w / width);
  camera.fy = static_cast<float>(fy * out_h / height);
  camera.cx = static_cast<float>(out_w / 2.0);
  camera.cy = static_cast<float>(out_h / 2.0);
  camera.width = out_w;
  camera.height = out_h;
  camera.near_plane = options.near_plane;
  const auto name_it = cam.find("img_name");
  camera.name = (name_it != cam.end() && name_it->is_string()) ? name_it->get<std::string>()
                                                               : "camera_" + std::to_string(index);
  Status valid = validate_camera(camera);
  if (!valid.ok()) {
    // The rotation, or a size above the limit from a tiny downscale, fails here (focals were checked).
    return corrupt(where, valid.message());
  }
  return camera;
}

}  // namespace

Result<std::vector<Camera>> parse_inria_cameras(const std::string& json_text, const std::string& name,
                                                const InriaCameraOptions& options) {
  RGS_RETURN_ERROR_IF(options.every_kth < 1, StatusCode::kInvalidArgument,
                      name + ": every_kth must be >= 1");
  RGS_RETURN_ERROR_IF(!options.indices.empty() && options.every_kth != 1, StatusCode::kInvalidArgument,
                      name + ": give either indices or every_kth, not both");
  RGS_RETURN_ERROR_IF(!std::isfinite(options.downscale) || !(options.downscale > 0), StatusCode::kInvalidArgument,
                      name + ": downscale must be finite and > 0");
  RGS_RETURN_ERROR_IF(options.width > uint32_t(kMaxImageSide) || options.height > uint32_t(kMaxImageSide),
                      StatusCode::kInvalidArgument, name + ": requested size above 32768");
  RGS_RETURN_ERROR_IF(!std::isfinite(options.near_plane) || !(options.near_plane > 0),
                      StatusCode::kInvalidArgument, name + ": near_plane must be finite and > 0");

  json root;
  try {
    root = json::parse(json_text);
  } catch (const json::exception& e) {
    return corrupt(name, std::string("not valid JSON (") + e.what() + ")");
  }
  RGS_RETURN_ERROR_IF(!root.is_array(), StatusCode::kCorruptData,
                      name + ": expected a JSON array of cameras, found " + root.type_name());
  RGS_RETURN_ERROR_IF(root.empty(), StatusCode::kCorruptData, name + ": the camera array is empty");

  std::vector<size_t> selected;
  if (!options.indices.empty()) {
    for (uint32_t index : options.indices) {
      RGS_RETURN_ERROR_IF(index >= root.size(), StatusCode::kInvalidArgument,
                          name + ": camera index " + std::to_string(index) + " >= camera count " +
                              std::to_string(root.size()));
      selected.push_back(index);
    }
  } else {
    for (size_t i = 0; i < root.size(); i += options.every_kth) selected.push_back(i);
  }

  std::vector<Camera> cameras;
  cameras.reserve(selected.size());
  try {
    for (size_t index : selected) {
      RGS_ASSIGN_OR_RETURN(Camera camera, parse_camera(root[index], index, name, options));
      cameras.push_back(std::move(camera));
    }
  } catch (const json::exception& e) {  // defensive: every access above is type-checked first
    return corrupt(name, std::string("unexpected JSON content (") + e.what() + ")");
  }
  return cameras;
}

Result<std::vector<Camera>> load_inria_cameras(const std::string& path, const InriaCameraOptions& options) {
  std::ifstream in(path, std::ios::binary);
  RGS_RETURN_ERROR_IF(!in, StatusCode::kIoError, path + ": cannot open for reading");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  RGS_RETURN_ERROR_IF(size < 0, StatusCode::kIoError, path + ": cannot determine the file size");
  RGS_RETURN_ERROR_IF(uint64_t(size) > kMaxCamerasFileBytes, StatusCode::kLimitExceeded,
                      path + ": " + std::to_string(size) + " bytes exceeds the cameras.json limit of " +
                          std::to_string(kMaxCamerasFileBytes));
  in.seekg(0, std::ios::beg);
  std::string text(static_cast<size_t>(size), '\0');
  in.read(text.data(), size);
  RGS_RETURN_ERROR_IF(!in || in.gcount() != size, StatusCode::kIoError,
                      path + ": read failed after " + std::to_string(in.gcount()) + " of " + std::to_string(size) +
                          " bytes");
  return parse_inria_cameras(text, path, options);
}

}  // namespace rgs::runtime
