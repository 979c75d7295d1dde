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
constexpr int64_t kMaxImageSide = 32768;
constexpr double kMaxFocal = 1e6;
constexpr double kMaxCoordinate = 1e9;

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

/// The Camera of `c` rendered at out_w × out_h: R = rotation_c2wᵀ, t = −R·position (double, then float), the field
/// of view kept (fx' = fx·W'/W), principal point at the image centre. Not validated.
Camera camera_from_entry(const InriaCamera& c, uint32_t out_w, uint32_t out_h, float near_plane) {
  Camera camera;
  std::array<double, 9> rows;
  for (int i = 0; i < 9; ++i) rows[i] = c.rotation_c2w[(i % 3) * 3 + i / 3];
  set_pose(&camera, rows, c.position);
  camera.fx = static_cast<float>(c.fx * out_w / c.width);
  camera.fy = static_cast<float>(c.fy * out_h / c.height);
  camera.cx = static_cast<float>(out_w / 2.0);
  camera.cy = static_cast<float>(out_h / 2.0);
  camera.width = out_w;
  camera.height = out_h;
  camera.near_plane = near_plane;
  return camera;
}

/// Parses and checks camera `index` of the array.
Result<NamedInriaCamera> parse_entry(const json& cam, size_t index, const std::string& name) {
  const std::string where = name + ": camera " + std::to_string(index);
  RGS_RETURN_ERROR_IF(!cam.is_object(), StatusCode::kCorruptData, where + " is not a JSON object");
  NamedInriaCamera entry;
  InriaCamera& c = entry.camera;
  RGS_RETURN_IF_ERROR(get_side(cam, "width", where, &c.width));
  RGS_RETURN_IF_ERROR(get_side(cam, "height", where, &c.height));
  RGS_RETURN_IF_ERROR(get_number(cam, "fx", where, &c.fx));
  RGS_RETURN_IF_ERROR(get_number(cam, "fy", where, &c.fy));
  RGS_RETURN_ERROR_IF(!(c.fx > 0 && c.fx <= kMaxFocal && c.fy > 0 && c.fy <= kMaxFocal), StatusCode::kCorruptData,
                      where + ": focal lengths must be in (0, 1e6] (fx=" + std::to_string(c.fx) +
                          ", fy=" + std::to_string(c.fy) + ")");
  const auto pos_it = cam.find("position");
  RGS_RETURN_ERROR_IF(pos_it == cam.end(), StatusCode::kCorruptData, where + ": missing 'position'");
  RGS_RETURN_IF_ERROR(get_vector(*pos_it, 3, where + ": 'position'", c.position.data()));
  for (double v : c.position) {
    RGS_RETURN_ERROR_IF(std::fabs(v) > kMaxCoordinate, StatusCode::kCorruptData,
                        where + ": 'position' is outside ±1e9");
  }
  const auto rot_it = cam.find("rotation");
  RGS_RETURN_ERROR_IF(rot_it == cam.end(), StatusCode::kCorruptData, where + ": missing 'rotation'");
  RGS_RETURN_ERROR_IF(!rot_it->is_array() || rot_it->size() != 3, StatusCode::kCorruptData,
                      where + ": 'rotation' is not a 3x3 array");
  for (size_t i = 0; i < 3; ++i) {
    RGS_RETURN_IF_ERROR(get_vector((*rot_it)[i], 3, where + ": 'rotation'[" + std::to_string(i) + "]",
                                   c.rotation_c2w.data() + 3 * i));
  }
  const auto name_it = cam.find("img_name");
  entry.name = (name_it != cam.end() && name_it->is_string()) ? name_it->get<std::string>()
                                                              : "camera_" + std::to_string(index);
  // The rotation (orthonormal, det +1) is checked as every camera is, at the file's own size.
  const Status valid = validate_camera(camera_from_entry(c, c.width, c.height, Camera{}.near_plane));
  if (!valid.ok()) return corrupt(where, valid.message());
  return entry;
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
  RGS_RETURN_ERROR_IF(options.width > uint32_t(kMaxImageSide) || options.height > uint32_t(kMaxImageSide),
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
    Camera camera = camera_from_entry(c, size[0], size[1], options.near_plane);
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

/// read_inria_cameras() on JSON text in memory; `name` is used in error messages.
Result<std::vector<NamedInriaCamera>> parse_inria_camera_entries(const std::string& json_text,
                                                                 const std::string& name) {
  RGS_RETURN_ERROR_IF(json_text.size() > kMaxCamerasFileBytes, StatusCode::kLimitExceeded,
                      name + ": " + std::to_string(json_text.size()) + " bytes exceeds the cameras.json limit of " +
                          std::to_string(kMaxCamerasFileBytes));
  // Nesting and the camera count are bounded while the text is parsed, before the tree they would build.
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
  json root;
  try {
    root = json::parse(json_text, bounded);
  } catch (const Refused& refused) {
    return Status(StatusCode::kLimitExceeded, name + ": " + refused.why);
  } catch (const json::exception& e) {
    return corrupt(name, std::string("not valid JSON (") + e.what() + ")");
  }
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
