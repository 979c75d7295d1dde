// INRIA 3DGS cameras.json reader (camera.h): the one reader of the format, for the renderers (load_inria_cameras)
// and for the viewer, which sends the numbers as written (read_inria_cameras). nlohmann::json exceptions are caught
// here and never leave the library; every value is type- and range-checked before use.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "rgs/runtime/camera.h"

namespace rgs::runtime {
namespace {

using nlohmann::json;

constexpr uint64_t kMaxCamerasFileBytes = uint64_t{64} << 20;
constexpr size_t kMaxCameras = 100000;
/// A cameras.json nests four levels (array, camera, rotation, row); deeper input is refused while it is parsed.
constexpr int kMaxNesting = 8;
constexpr uint32_t kMaxImageSide = 32768;
constexpr double kMaxFocal = 1e6;
constexpr double kMaxCoordinate = 1e9;

Status corrupt(const std::string& name, const std::string& what) {
  return Status(StatusCode::kCorruptData, name + ": " + what);
}

/// Reads a finite number field of `cam` into *out.
Status get_number(const json& cam, const char* key, double* out) {
  const auto it = cam.find(key);
  RGS_RETURN_ERROR_IF(it == cam.end(), StatusCode::kCorruptData, std::string("missing \"") + key + "\"");
  RGS_RETURN_ERROR_IF(!it->is_number(), StatusCode::kCorruptData, std::string("\"") + key + "\" is not a number");
  *out = it->get<double>();
  RGS_RETURN_ERROR_IF(!std::isfinite(*out), StatusCode::kCorruptData, std::string("\"") + key + "\" is not finite");
  return Status::ok_status();
}

/// Reads an integer image side in [1, max] (a JSON integer: 640.0 is refused).
Status get_side(const json& cam, const char* key, uint32_t max, uint32_t* out) {
  const auto it = cam.find(key);
  RGS_RETURN_ERROR_IF(it == cam.end(), StatusCode::kCorruptData, std::string("missing \"") + key + "\"");
  const int64_t v = it->is_number_integer() ? it->get<int64_t>() : 0;
  RGS_RETURN_ERROR_IF(v < 1 || v > int64_t(max), StatusCode::kCorruptData,
                      std::string("\"") + key + "\" must be an integer in 1.." + std::to_string(max));
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

/// Reads and checks the camera object `cam` (parse_inria_camera); messages have no prefix.
Result<InriaCamera> read_camera(const json& cam, uint32_t max_width, uint32_t max_height,
                                const std::string& key_prefix) {
  RGS_RETURN_ERROR_IF(!cam.is_object(), StatusCode::kCorruptData, "not a JSON object");
  InriaCamera c;
  RGS_RETURN_IF_ERROR(get_side(cam, "width", max_width, &c.width));
  RGS_RETURN_IF_ERROR(get_side(cam, "height", max_height, &c.height));
  RGS_RETURN_IF_ERROR(get_number(cam, "fx", &c.fx));
  RGS_RETURN_IF_ERROR(get_number(cam, "fy", &c.fy));
  RGS_RETURN_ERROR_IF(!(c.fx > 0 && c.fx <= kMaxFocal && c.fy > 0 && c.fy <= kMaxFocal), StatusCode::kCorruptData,
                      "focal lengths must be in (0, 1e6] (fx=" + std::to_string(c.fx) +
                          ", fy=" + std::to_string(c.fy) + ")");
  const std::string position = "\"" + key_prefix + "position\"", rotation = "\"" + key_prefix + "rotation\"";
  const auto pos_it = cam.find("position");
  RGS_RETURN_ERROR_IF(pos_it == cam.end(), StatusCode::kCorruptData, "missing " + position);
  RGS_RETURN_IF_ERROR(get_vector(*pos_it, 3, position, c.position.data()));
  for (double v : c.position) {
    RGS_RETURN_ERROR_IF(std::fabs(v) > kMaxCoordinate, StatusCode::kCorruptData, position + " is outside ±1e9");
  }
  const auto rot_it = cam.find("rotation");
  RGS_RETURN_ERROR_IF(rot_it == cam.end(), StatusCode::kCorruptData, "missing " + rotation);
  RGS_RETURN_ERROR_IF(!rot_it->is_array() || rot_it->size() != 3, StatusCode::kCorruptData,
                      rotation + " is not a 3x3 array");
  for (size_t i = 0; i < 3; ++i) {
    RGS_RETURN_IF_ERROR(
        get_vector((*rot_it)[i], 3, rotation + "[" + std::to_string(i) + "]", c.rotation_c2w.data() + 3 * i));
  }
  // The rotation (orthonormal, det +1) is checked as every camera is, at the file's own size.
  const Status valid = validate_camera(camera_from_inria(c, c.width, c.height, Camera{}.near_plane));
  if (!valid.ok()) return Status(StatusCode::kCorruptData, valid.message());
  return c;
}

/// Parses and checks camera `index` of the array.
Result<NamedInriaCamera> parse_entry(const json& cam, size_t index, const std::string& name) {
  Result<InriaCamera> camera = read_camera(cam, kMaxImageSide, kMaxImageSide, "");
  if (!camera.ok()) return corrupt(name + ": camera " + std::to_string(index), camera.status().message());
  const auto name_it = cam.find("img_name");
  return NamedInriaCamera{
      (name_it != cam.end() && name_it->is_string()) ? name_it->get<std::string>() : "camera_" + std::to_string(index),
      *camera};
}

/// Output resolution for a camera of the file's size under `options`.
std::array<uint32_t, 2> output_size(uint32_t w, uint32_t h, const InriaCameraOptions& options) {
  if (options.width != 0 || options.height != 0) return keep_aspect(options.width, options.height, w, h);
  // Clamped so that the cast stays defined for any downscale > 0; validate_camera() refuses sides over the limit.
  auto at_least_one = [](double v) { return uint32_t(std::clamp(std::round(v), 1.0, kMaxImageSide + 1.0)); };
  return {at_least_one(w / options.downscale), at_least_one(h / options.downscale)};
}

Status check_options(const std::string& name, const InriaCameraOptions& options) {
  RGS_RETURN_ERROR_IF(options.every_kth < 1, StatusCode::kInvalidArgument, name + ": every_kth must be >= 1");
  RGS_RETURN_ERROR_IF(!options.indices.empty() && options.every_kth != 1, StatusCode::kInvalidArgument,
                      name + ": give either indices or every_kth, not both");
  RGS_RETURN_ERROR_IF(!std::isfinite(options.downscale) || !(options.downscale > 0), StatusCode::kInvalidArgument,
                      name + ": downscale must be finite and > 0");
  RGS_RETURN_ERROR_IF(options.width > kMaxImageSide || options.height > kMaxImageSide,
                      StatusCode::kInvalidArgument, name + ": requested size above 32768");
  RGS_RETURN_ERROR_IF(!std::isfinite(options.near_plane) || !(options.near_plane > 0),
                      StatusCode::kInvalidArgument, name + ": near_plane must be finite and > 0");
  return Status::ok_status();
}

/// The selected entries as cameras at the size `options` asks for.
Result<std::vector<Camera>> select_cameras(const std::vector<NamedInriaCamera>& entries, const std::string& name,
                                           const InriaCameraOptions& options) {
  std::vector<size_t> selected;
  if (!options.indices.empty()) {
    for (uint32_t index : options.indices) {
      RGS_RETURN_ERROR_IF(index >= entries.size(), StatusCode::kInvalidArgument,
                          name + ": camera index " + std::to_string(index) + " >= camera count " +
                              std::to_string(entries.size()));
      selected.push_back(index);
    }
  } else {
    for (size_t i = 0; i < entries.size(); i += options.every_kth) selected.push_back(i);
  }
  std::vector<Camera> cameras;
  cameras.reserve(selected.size());
  for (size_t index : selected) {
    const InriaCamera& c = entries[index].camera;
    const std::array<uint32_t, 2> size = output_size(c.width, c.height, options);
    Camera camera = camera_from_inria(c, size[0], size[1], options.near_plane);
    camera.name = entries[index].name;
    // A size above the limit from a tiny downscale fails here (the entry itself was checked).
    const Status valid = validate_camera(camera);
    if (!valid.ok()) return corrupt(name + ": camera " + std::to_string(index), valid.message());
    cameras.push_back(std::move(camera));
  }
  return cameras;
}

/// The whole file at `path`, refused above kMaxCamerasFileBytes before it is read.
Result<std::string> read_text(const std::string& path) {
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
  return text;
}

/// `json_text` parsed with the limits of a cameras.json: at most kMaxCamerasFileBytes, kMaxNesting levels and
/// kMaxCameras values at the top level, refused while parsing (before the tree they would build).
Result<json> parse_bounded(std::string_view json_text, const std::string& name) {
  RGS_RETURN_ERROR_IF(json_text.size() > kMaxCamerasFileBytes, StatusCode::kLimitExceeded,
                      name + ": " + std::to_string(json_text.size()) + " bytes exceeds the cameras.json limit of " +
                          std::to_string(kMaxCamerasFileBytes));
  struct Refused {
    std::string why;
  };
  size_t top_level = 0;
  const json::parser_callback_t bounded = [&top_level](int depth, json::parse_event_t event, json&) {
    const bool opens = event == json::parse_event_t::object_start || event == json::parse_event_t::array_start;
    if (opens && depth >= kMaxNesting) {
      throw Refused{"nested deeper than " + std::to_string(kMaxNesting) + " levels"};
    }
    if (depth == 1 && (opens || event == json::parse_event_t::value) && ++top_level > kMaxCameras) {
      throw Refused{"more than " + std::to_string(kMaxCameras) + " cameras"};
    }
    return true;
  };
  try {
    return json::parse(json_text, bounded);
  } catch (const Refused& refused) {
    return Status(StatusCode::kLimitExceeded, name + ": " + refused.why);
  } catch (const json::exception& e) {
    return corrupt(name, std::string("not valid JSON (") + e.what() + ")");
  }
}

/// read_inria_cameras() on JSON text in memory; `name` is used in error messages.
Result<std::vector<NamedInriaCamera>> parse_inria_camera_entries(const std::string& json_text,
                                                                 const std::string& name) {
  RGS_ASSIGN_OR_RETURN(const json root, parse_bounded(json_text, name));
  RGS_RETURN_ERROR_IF(!root.is_array(), StatusCode::kCorruptData,
                      name + ": expected a JSON array of cameras, found " + root.type_name());
  RGS_RETURN_ERROR_IF(root.empty(), StatusCode::kCorruptData, name + ": the camera array is empty");
  std::vector<NamedInriaCamera> entries;
  entries.reserve(root.size());
  try {
    for (size_t i = 0; i < root.size(); ++i) {
      RGS_ASSIGN_OR_RETURN(NamedInriaCamera entry, parse_entry(root[i], i, name));
      entries.push_back(std::move(entry));
    }
  } catch (const json::exception& e) {  // defensive: every access above is type-checked first
    return corrupt(name, std::string("unexpected JSON content (") + e.what() + ")");
  }
  return entries;
}

}  // namespace

Camera camera_from_inria(const InriaCamera& c, uint32_t out_width, uint32_t out_height, float near_plane) {
  Camera camera;
  std::array<double, 9> rows;
  for (int i = 0; i < 9; ++i) rows[i] = c.rotation_c2w[(i % 3) * 3 + i / 3];
  set_pose(&camera, rows, c.position);
  camera.fx = static_cast<float>(c.fx * out_width / c.width);
  camera.fy = static_cast<float>(c.fy * out_height / c.height);
  camera.cx = static_cast<float>(out_width / 2.0);
  camera.cy = static_cast<float>(out_height / 2.0);
  camera.width = out_width;
  camera.height = out_height;
  camera.near_plane = near_plane;
  return camera;
}

Result<InriaCamera> parse_inria_camera(std::string_view json_object, uint32_t max_width, uint32_t max_height,
                                       const std::string& key_prefix) {
  RGS_ASSIGN_OR_RETURN(const json cam, parse_bounded(json_object, "camera"));
  return read_camera(cam, max_width, max_height, key_prefix);
}

Result<std::vector<NamedInriaCamera>> read_inria_cameras(const std::string& path) {
  RGS_ASSIGN_OR_RETURN(const std::string text, read_text(path));
  return parse_inria_camera_entries(text, path);
}

Result<std::vector<Camera>> parse_inria_cameras(const std::string& json_text, const std::string& name,
                                                const InriaCameraOptions& options) {
  RGS_RETURN_IF_ERROR(check_options(name, options));
  RGS_ASSIGN_OR_RETURN(const std::vector<NamedInriaCamera> entries, parse_inria_camera_entries(json_text, name));
  return select_cameras(entries, name, options);
}

Result<std::vector<Camera>> load_inria_cameras(const std::string& path, const InriaCameraOptions& options) {
  RGS_ASSIGN_OR_RETURN(const std::string text, read_text(path));
  return parse_inria_cameras(text, path, options);
}

}  // namespace rgs::runtime
