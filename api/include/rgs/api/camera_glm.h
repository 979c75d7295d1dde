// GLM overloads of the camera builders of camera.h. Header-only: include it where GLM is available (the
// RoofGS libraries themselves do not need GLM). GLM matrices are column-major, as camera.h's
// Mat4ColumnMajor; glm::mat3 K and R are read mathematically (m[c][r] is row r, column c).
#pragma once

#include <glm/glm.hpp>

#include "rgs/api/camera.h"

namespace rgs::api {

namespace detail {
inline Mat4ColumnMajor to_array(const glm::mat4& m) {
  Mat4ColumnMajor a{};
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) a[size_t(4 * c + r)] = m[c][r];
  }
  return a;
}
inline std::array<double, 9> to_row_major(const glm::mat3& m) {
  std::array<double, 9> a{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) a[size_t(3 * r + c)] = m[c][r];
  }
  return a;
}
}  // namespace detail

/// camera_from_opengl with GLM matrices (e.g. glm::lookAt and glm::perspective).
inline Result<Camera> camera_from_opengl(const glm::mat4& view, const glm::mat4& projection, uint32_t width,
                                         uint32_t height, const CameraOptions& options = {}) {
  return camera_from_opengl(detail::to_array(view), detail::to_array(projection), width, height, options);
}

/// camera_from_vulkan with GLM matrices (e.g. glm::perspectiveRH_ZO with projection[1][1] *= −1).
inline Result<Camera> camera_from_vulkan(const glm::mat4& view, const glm::mat4& projection, uint32_t width,
                                         uint32_t height, const CameraOptions& options = {}) {
  return camera_from_vulkan(detail::to_array(view), detail::to_array(projection), width, height, options);
}

/// camera_from_opencv with GLM types: K and R as mathematical 3×3 matrices, t the translation.
inline Result<Camera> camera_from_opencv(const glm::mat3& K, const glm::mat3& R, const glm::vec3& t, uint32_t width,
                                         uint32_t height, const CameraOptions& options = {}) {
  return camera_from_opencv(detail::to_row_major(K), detail::to_row_major(R), {double(t.x), double(t.y), double(t.z)},
                            width, height, options);
}

}  // namespace rgs::api
