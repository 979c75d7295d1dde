// Camera model helpers and the orbit generator (camera.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "rgs/runtime/camera.h"

namespace rgs::runtime {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr uint32_t kMaxImageSide = 32768;

bool finite(double v) { return std::isfinite(v); }

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

}  // namespace

std::array<float, 3> camera_centre(const Camera& camera) {
  const auto& R = camera.rotation;
  const auto& t = camera.translation;
  std::array<float, 3> c{};
  for (int j = 0; j < 3; ++j) {
    const double v = -(double(R[0 * 3 + j]) * t[0] + double(R[1 * 3 + j]) * t[1] + double(R[2 * 3 + j]) * t[2]);
    c[j] = static_cast<float>(v);
  }
  return c;
}

void set_pose(Camera* camera, const std::array<double, 9>& rows, const std::array<double, 3>& eye) {
  for (int row = 0; row < 3; ++row) {
    double t = 0;
    for (int j = 0; j < 3; ++j) {
      camera->rotation[row * 3 + j] = static_cast<float>(rows[row * 3 + j]);
      t -= rows[row * 3 + j] * eye[j];
    }
    camera->translation[row] = static_cast<float>(t);
  }
}

void move_camera(Camera* camera, const std::array<double, 9>& rotation, double scale,
                 const std::array<double, 3>& offset) {
  const std::array<float, 3> c = camera_centre(*camera);
  std::array<double, 3> eye;
  std::array<double, 9> rows;  // the camera's rotation times the motion's inverse (transposed) one
  for (int i = 0; i < 3; ++i) {
    eye[i] = offset[i] + scale * (rotation[i * 3] * c[0] + rotation[i * 3 + 1] * c[1] + rotation[i * 3 + 2] * c[2]);
    for (int j = 0; j < 3; ++j) {
      rows[i * 3 + j] = double(camera->rotation[i * 3]) * rotation[j * 3] +
                        double(camera->rotation[i * 3 + 1]) * rotation[j * 3 + 1] +
                        double(camera->rotation[i * 3 + 2]) * rotation[j * 3 + 2];
    }
  }
  set_pose(camera, rows, eye);
  camera->near_plane = float(camera->near_plane * scale);
}

std::array<uint32_t, 2> keep_aspect(uint32_t width, uint32_t height, uint32_t ref_width, uint32_t ref_height) {
  auto side = [](double v) { return uint32_t(std::clamp(std::round(v), 1.0, kMaxImageSide + 1.0)); };
  if (width == 0 && height == 0) return {ref_width, ref_height};
  if (height == 0) return {width, side(double(width) * ref_height / ref_width)};
  if (width == 0) return {side(double(height) * ref_width / ref_height), height};
  return {width, height};
}

double fov_from_focal(double focal, double pixels) { return 2.0 * std::atan(pixels / (2.0 * focal)); }

double focal_from_fov(double fov_rad, double pixels) { return pixels / (2.0 * std::tan(fov_rad / 2.0)); }

Status validate_camera(const Camera& camera) {
  const std::string who = camera.name.empty() ? std::string("camera") : "camera '" + camera.name + "'";
  RGS_RETURN_ERROR_IF(camera.width < 1 || camera.width > kMaxImageSide || camera.height < 1 ||
                          camera.height > kMaxImageSide,
                      StatusCode::kInvalidArgument,
                      who + ": image size " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                          " outside [1, " + std::to_string(kMaxImageSide) + "]");
  RGS_RETURN_ERROR_IF(!finite(camera.fx) || !finite(camera.fy) || !(camera.fx > 0) || !(camera.fy > 0),
                      StatusCode::kInvalidArgument,
                      who + ": focal lengths fx=" + num(camera.fx) + " fy=" + num(camera.fy) +
                          " must be finite and > 0");
  RGS_RETURN_ERROR_IF(!finite(camera.cx) || !finite(camera.cy), StatusCode::kInvalidArgument,
                      who + ": principal point (" + num(camera.cx) + ", " + num(camera.cy) + ") is not finite");
  RGS_RETURN_ERROR_IF(!finite(camera.near_plane) || !(camera.near_plane > 0), StatusCode::kInvalidArgument,
                      who + ": near_plane " + num(camera.near_plane) + " must be finite and > 0");
  for (int i = 0; i < 3; ++i) {
    RGS_RETURN_ERROR_IF(!finite(camera.translation[i]), StatusCode::kInvalidArgument,
                        who + ": translation[" + std::to_string(i) + "] is not finite");
  }
  const auto& R = camera.rotation;
  for (int i = 0; i < 9; ++i) {
    RGS_RETURN_ERROR_IF(!finite(R[i]), StatusCode::kInvalidArgument,
                        who + ": rotation[" + std::to_string(i) + "] is not finite");
  }
  double worst = 0;
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) {
      double dot = 0;
      for (int j = 0; j < 3; ++j) dot += double(R[i * 3 + j]) * R[k * 3 + j];
      worst = std::max(worst, std::fabs(dot - (i == k ? 1.0 : 0.0)));
    }
  }
  const double det = double(R[0]) * (double(R[4]) * R[8] - double(R[5]) * R[7]) -
                     double(R[1]) * (double(R[3]) * R[8] - double(R[5]) * R[6]) +
                     double(R[2]) * (double(R[3]) * R[7] - double(R[4]) * R[6]);
  RGS_RETURN_ERROR_IF(worst > 1e-3 || det < 0, StatusCode::kInvalidArgument,
                      who + ": rotation is not a proper rotation (max |R·Rᵀ − I| = " + num(worst) +
                          ", det = " + num(det) + ")");
  return Status::ok_status();
}

Camera resize_camera(const Camera& camera, uint32_t width, uint32_t height) {
  Camera out = camera;
  const double sx = double(width) / double(camera.width);
  const double sy = double(height) / double(camera.height);
  out.width = width;
  out.height = height;
  out.fx = static_cast<float>(camera.fx * sx);
  out.fy = static_cast<float>(camera.fy * sy);
  out.cx = static_cast<float>(camera.cx * sx);
  out.cy = static_cast<float>(camera.cy * sy);
  return out;
}

Result<std::vector<Camera>> orbit_cameras(const format::SceneBounds& bounds, uint32_t count, uint32_t width,
                                          uint32_t height, const OrbitOptions& options) {
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kInvalidArgument, "orbit: camera count must be >= 1");
  const double r = bounds.sphere_radius;
  RGS_RETURN_ERROR_IF(!finite(r) || !(r > 0), StatusCode::kInvalidArgument,
                      "orbit: scene bounding sphere radius " + num(r) + " must be finite and > 0");
  for (int i = 0; i < 3; ++i) {
    RGS_RETURN_ERROR_IF(!finite(bounds.sphere_center[i]), StatusCode::kInvalidArgument,
                        "orbit: scene bounding sphere centre is not finite");
  }
  RGS_RETURN_ERROR_IF(!(options.fov_y_deg > 0 && options.fov_y_deg < 180), StatusCode::kInvalidArgument,
                      "orbit: fov_y_deg " + num(options.fov_y_deg) + " outside (0, 180)");
  RGS_RETURN_ERROR_IF(!(options.elevation_deg > -89 && options.elevation_deg < 89), StatusCode::kInvalidArgument,
                      "orbit: elevation_deg " + num(options.elevation_deg) + " outside (-89, 89)");
  RGS_RETURN_ERROR_IF(!finite(options.distance_factor) || !(options.distance_factor > 0),
                      StatusCode::kInvalidArgument,
                      "orbit: distance_factor " + num(options.distance_factor) + " must be finite and > 0");
  RGS_RETURN_ERROR_IF(!finite(options.start_azimuth_deg), StatusCode::kInvalidArgument,
                      "orbit: start_azimuth_deg is not finite");

  const double fov_y = options.fov_y_deg * kPi / 180.0;
  const double fy = focal_from_fov(fov_y, height);
  const double fx = fy;  // square pixels
  const double fov_x = fov_from_focal(fx, width);
  const double fov_min = std::min(fov_x, fov_y);
  const double distance = options.distance_factor * r / std::sin(fov_min / 2.0);
  const double el = options.elevation_deg * kPi / 180.0;
  const double c[3] = {bounds.sphere_center[0], bounds.sphere_center[1], bounds.sphere_center[2]};

  std::vector<Camera> cameras;
  cameras.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    const double az = (options.start_azimuth_deg + 360.0 * double(i) / double(count)) * kPi / 180.0;
    // Eye on a sphere around the target; world up is −y, so a positive elevation means a smaller y.
    const double dir[3] = {std::cos(el) * std::sin(az), -std::sin(el), -std::cos(el) * std::cos(az)};
    const std::array<double, 3> eye = {c[0] + distance * dir[0], c[1] + distance * dir[1], c[2] + distance * dir[2]};
    // Camera axes in world coordinates: z forward (towards the target), x right = z × up, y down = z × x.
    const double z_axis[3] = {-dir[0], -dir[1], -dir[2]};
    const double up[3] = {0.0, -1.0, 0.0};
    double x_axis[3] = {z_axis[1] * up[2] - z_axis[2] * up[1], z_axis[2] * up[0] - z_axis[0] * up[2],
                        z_axis[0] * up[1] - z_axis[1] * up[0]};
    const double xn = std::sqrt(x_axis[0] * x_axis[0] + x_axis[1] * x_axis[1] + x_axis[2] * x_axis[2]);
    for (double& v : x_axis) v /= xn;
    const double y_axis[3] = {z_axis[1] * x_axis[2] - z_axis[2] * x_axis[1],
                              z_axis[2] * x_axis[0] - z_axis[0] * x_axis[2],
                              z_axis[0] * x_axis[1] - z_axis[1] * x_axis[0]};
    Camera cam;
    set_pose(&cam, {x_axis[0], x_axis[1], x_axis[2], y_axis[0], y_axis[1], y_axis[2], z_axis[0], z_axis[1], z_axis[2]},
             eye);
    cam.fx = static_cast<float>(fx);
    cam.fy = static_cast<float>(fy);
    cam.cx = static_cast<float>(width / 2.0);
    cam.cy = static_cast<float>(height / 2.0);
    cam.width = width;
    cam.height = height;
    cam.near_plane = options.near_plane;
    char name[32];
    std::snprintf(name, sizeof name, "orbit_%03u", i);
    cam.name = name;
    // The image size and near_plane are checked here, and a sphere close to the float range, which puts the eye
    // beyond it: refused instead of returning an unusable camera.
    RGS_RETURN_IF_ERROR(validate_camera(cam));
    cameras.push_back(std::move(cam));
  }
  return cameras;
}

Result<std::vector<Camera>> path_cameras(const format::SceneBounds& bounds, uint32_t count, uint32_t width,
                                         uint32_t height, const PathOptions& path, const OrbitOptions& base) {
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kInvalidArgument, "path: camera count must be >= 1");
  std::vector<Camera> cameras;
  cameras.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    const double t = double(i) / double(count);
    OrbitOptions view = base;
    view.start_azimuth_deg = base.start_azimuth_deg + 360.0 * path.turns * t;
    view.elevation_deg = path.elevation_first_deg + (path.elevation_last_deg - path.elevation_first_deg) * t;
    view.distance_factor =
        path.distance_far + (path.distance_near - path.distance_far) * (1.0 - std::cos(6.0 * kPi * t)) / 2.0;
    auto one = orbit_cameras(bounds, 1, width, height, view);
    if (!one.ok()) {
      Status failed = one.status();
      return failed.prepend("path view " + std::to_string(i));
    }
    char name[32];
    std::snprintf(name, sizeof name, "path_%03u", i);
    (*one)[0].name = name;
    cameras.push_back(std::move((*one)[0]));
  }
  return cameras;
}

}  // namespace rgs::runtime
