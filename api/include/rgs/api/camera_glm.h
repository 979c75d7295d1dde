// GLM overloads of the camera builders of camera.h. Header-only: include it where GLM is available (the
// RoofGS libraries themselves do not need GLM). GLM matrices are column-major, as camera.h's
// Mat4ColumnMajor; glm::mat3 K and R are read mathematically (m[c][r] is row r, column c).
#pragma once

#include <glm/glm.hpp>

#include "rgs/api/camera.h"

namespace rgs::api {

// The overloads are templates over GLM's scalar type and qualifier so that a call with braced lists, e.g.
// camera_from_opencv({...}, {...}, {...}, w, h), still picks the plain-array overload of camera.h.

namespace detail {
template <typename T, glm::qualifier Q>
Mat4ColumnMajor to_array(const glm::mat<4, 4, T, Q>& m) {
  Mat4ColumnMajor a{};
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) a[size_t(4 * c + r)] = float(m[c][r]);
  }
  return a;
}
template <typename T, glm::qualifier Q>
std::array<double, 9> to_row_major(const glm::mat<3, 3, T, Q>& m) {
  std::array<double, 9> a{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) a[size_t(3 * r + c)] = double(m[c][r]);
  }
  return a;
}
}  // namespace detail

/// camera_from_opengl with GLM matrices (e.g. glm::lookAt and glm::perspective).
template <typename T, glm::qualifier Q>
Result<Camera> camera_from_opengl(const glm::mat<4, 4, T, Q>& view, const glm::mat<4, 4, T, Q>& projection,
                                  uint32_t width, uint32_t height, const CameraOptions& options = {}) {
  return camera_from_opengl(detail::to_array(view), detail::to_array(projection), width, height, options);
}

/// camera_from_vulkan with GLM matrices (e.g. glm::perspectiveRH_ZO with projection[1][1] *= −1).
template <typename T, glm::qualifier Q>
Result<Camera> camera_from_vulkan(const glm::mat<4, 4, T, Q>& view, const glm::mat<4, 4, T, Q>& projection,
                                  uint32_t width, uint32_t height, const CameraOptions& options = {}) {
  return camera_from_vulkan(detail::to_array(view), detail::to_array(projection), width, height, options);
}

/// camera_from_opencv with GLM types: K and R as mathematical 3×3 matrices, t the translation.
template <typename T, glm::qualifier Q>
Result<Camera> camera_from_opencv(const glm::mat<3, 3, T, Q>& K, const glm::mat<3, 3, T, Q>& R,
                                  const glm::vec<3, T, Q>& t, uint32_t width, uint32_t height,
                                  const CameraOptions& options = {}) {
  return camera_from_opencv(detail::to_row_major(K), detail::to_row_major(R), {double(t.x), double(t.y), double(t.z)},
                            width, height, options);
}

}  // namespace rgs::api
