// Camera builders: every convention is turned into the COLMAP frame of runtime::Camera.
#include "rgs/api/camera.h"

#include <cmath>

namespace rgs::api {
namespace {

Result<Camera> finish(const std::array<double, 9>& R, const std::array<double, 3>& t, double fx, double fy,
                      double cx, double cy, uint32_t width, uint32_t height, const CameraOptions& options,
                      const char* who) {
  // Values that are not finite, or overflow a float, are refused by validate_camera.
  Camera c;
  for (int i = 0; i < 9; ++i) c.rotation[size_t(i)] = float(R[size_t(i)]);
  for (int i = 0; i < 3; ++i) c.translation[size_t(i)] = float(t[size_t(i)]);
  c.fx = float(fx);
  c.fy = float(fy);
  c.cx = float(cx);
  c.cy = float(cy);
  c.width = width;
  c.height = height;
  c.near_plane = options.near_plane;
  c.name = options.name;
  Status valid = runtime::validate_camera(c);
  if (!valid.ok()) return valid.prepend(who);
  return c;
}

/// P[r][c] of a column-major matrix.
float at(const Mat4ColumnMajor& m, int r, int c) { return m[size_t(4 * c + r)]; }

}  // namespace

Result<Camera> camera_from_inria(const std::array<double, 9>& rotation_c2w, const std::array<double, 3>& position,
                                 double fx, double fy, uint32_t width, uint32_t height, const CameraOptions& options) {
  Camera c =
      runtime::camera_from_inria({rotation_c2w, position, fx, fy, width, height}, width, height, options.near_plane);
  c.name = options.name;
  Status valid = runtime::validate_camera(c);
  if (!valid.ok()) return valid.prepend("camera_from_inria");
  return c;
}

Result<Camera> camera_from_colmap(const std::array<double, 4>& q, const std::array<double, 3>& tvec, double fx,
                                  double fy, double cx, double cy, uint32_t width, uint32_t height,
                                  const CameraOptions& options) {
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  RGS_RETURN_ERROR_IF(!(norm > 0) || !std::isfinite(norm), StatusCode::kInvalidArgument,
                      "camera_from_colmap: quaternion has zero or non-finite norm");
  const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
  const std::array<double, 9> R = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                                   2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                                   2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  return finish(R, tvec, fx, fy, cx, cy, width, height, options, "camera_from_colmap");
}

Result<Camera> camera_from_opencv(const std::array<double, 9>& K, const std::array<double, 9>& R,
                                  const std::array<double, 3>& t, uint32_t width, uint32_t height,
                                  const CameraOptions& options) {
  RGS_RETURN_ERROR_IF(K[1] != 0.0 || K[3] != 0.0, StatusCode::kInvalidArgument,
                      "camera_from_opencv: K has skew (K[0][1] = " + std::to_string(K[1]) + ", K[1][0] = " +
                          std::to_string(K[3]) + "); only zero skew is supported");
  RGS_RETURN_ERROR_IF(K[6] != 0.0 || K[7] != 0.0 || K[8] != 1.0, StatusCode::kInvalidArgument,
                      "camera_from_opencv: K's last row is not (0, 0, 1)");
  // OpenCV's pixel centres are at integers, COLMAP's (and Camera::cx's) at +0.5.
  return finish(R, t, K[0], K[4], K[2] + 0.5, K[5] + 0.5, width, height, options, "camera_from_opencv");
}

Result<Camera> camera_from_view_projection(const Mat4ColumnMajor& view, const Mat4ColumnMajor& projection,
                                           uint32_t width, uint32_t height, ClipConvention convention,
                                           const CameraOptions& options) {
  const char* who = convention == ClipConvention::kOpenGL ? "camera_from_opengl" : "camera_from_vulkan";
  for (float v : projection) {
    RGS_RETURN_ERROR_IF(!std::isfinite(v), StatusCode::kInvalidArgument, std::string(who) + ": projection not finite");
  }
  for (float v : view) {
    RGS_RETURN_ERROR_IF(!std::isfinite(v), StatusCode::kInvalidArgument, std::string(who) + ": view not finite");
  }
  const Mat4ColumnMajor& P = projection;
  RGS_RETURN_ERROR_IF(at(P, 3, 0) != 0.f || at(P, 3, 1) != 0.f || at(P, 3, 2) != -1.f || at(P, 3, 3) != 0.f,
                      StatusCode::kInvalidArgument,
                      std::string(who) + ": projection's last row is (" + std::to_string(at(P, 3, 0)) + ", " +
                          std::to_string(at(P, 3, 1)) + ", " + std::to_string(at(P, 3, 2)) + ", " +
                          std::to_string(at(P, 3, 3)) +
                          "), not (0, 0, -1, 0): only right-handed perspective projections are supported");
  RGS_RETURN_ERROR_IF(at(P, 0, 1) != 0.f || at(P, 1, 0) != 0.f, StatusCode::kInvalidArgument,
                      std::string(who) + ": projection has skew (P[0][1] or P[1][0] non-zero)");
  RGS_RETURN_ERROR_IF(at(view, 3, 0) != 0.f || at(view, 3, 1) != 0.f || at(view, 3, 2) != 0.f || at(view, 3, 3) != 1.f,
                      StatusCode::kInvalidArgument, std::string(who) + ": view matrix's last row is not (0, 0, 0, 1)");
  const double W = width, H = height;
  const double fx = double(at(P, 0, 0)) * W / 2;
  const double cx = W / 2 * (1 - double(at(P, 0, 2)));
  double fy = 0, cy = 0;
  if (convention == ClipConvention::kOpenGL) {
    fy = double(at(P, 1, 1)) * H / 2;
    cy = H / 2 * (1 + double(at(P, 1, 2)));
  } else {
    fy = -double(at(P, 1, 1)) * H / 2;
    cy = H / 2 * (1 - double(at(P, 1, 2)));
  }
  RGS_RETURN_ERROR_IF(!(fx > 0) || !(fy > 0), StatusCode::kInvalidArgument,
                      std::string(who) + ": the projection gives focal lengths fx = " + std::to_string(fx) +
                          ", fy = " + std::to_string(fy) +
                          " pixels; both must be > 0 (a Vulkan matrix passed as OpenGL, or the reverse, flips fy)");
  // Eye frame (x right, y up, looking down −z) to COLMAP (x right, y down, z forward): negate rows 1 and 2.
  std::array<double, 9> R{};
  std::array<double, 3> t{};
  for (int r = 0; r < 3; ++r) {
    const double s = r == 0 ? 1.0 : -1.0;
    for (int c = 0; c < 3; ++c) R[size_t(3 * r + c)] = s * double(at(view, r, c));
    t[size_t(r)] = s * double(at(view, r, 3));
  }
  return finish(R, t, fx, fy, cx, cy, width, height, options, who);
}

Result<Camera> camera_from_opengl(const Mat4ColumnMajor& view, const Mat4ColumnMajor& projection, uint32_t width,
                                  uint32_t height, const CameraOptions& options) {
  return camera_from_view_projection(view, projection, width, height, ClipConvention::kOpenGL, options);
}

Result<Camera> camera_from_vulkan(const Mat4ColumnMajor& view, const Mat4ColumnMajor& projection, uint32_t width,
                                  uint32_t height, const CameraOptions& options) {
  return camera_from_view_projection(view, projection, width, height, ClipConvention::kVulkan, options);
}

Mat4ColumnMajor opengl_view_matrix(const Camera& camera) {
  Mat4ColumnMajor m{};
  for (int r = 0; r < 3; ++r) {
    const float s = r == 0 ? 1.f : -1.f;
    for (int c = 0; c < 3; ++c) m[size_t(4 * c + r)] = s * camera.rotation[size_t(3 * r + c)];
    m[size_t(12 + r)] = s * camera.translation[size_t(r)];
  }
  m[15] = 1.f;
  return m;
}

Mat4ColumnMajor opengl_projection_matrix(const Camera& camera, float z_near, float z_far) {
  Mat4ColumnMajor m{};
  const double W = camera.width, H = camera.height;
  m[0] = float(2.0 * camera.fx / W);                           // P[0][0]
  m[8] = float(1.0 - 2.0 * camera.cx / W);                     // P[0][2]
  m[5] = float(2.0 * camera.fy / H);                           // P[1][1]
  m[9] = float(2.0 * camera.cy / H - 1.0);                     // P[1][2]
  m[10] = -(z_far + z_near) / (z_far - z_near);                // P[2][2]
  m[14] = -2.f * z_far * z_near / (z_far - z_near);            // P[2][3]
  m[11] = -1.f;                                                // P[3][2]
  return m;
}

}  // namespace rgs::api
