// Camera conventions of the front door on hand-computed cases: each builder must put a known world point at
// the pixel worked out by hand from that API's own rules.
#include <array>
#include <cmath>

#include <doctest/doctest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "rgs/api/camera.h"
#include "rgs/api/camera_glm.h"

namespace {

using rgs::api::Camera;

/// Pixel (centre-based, runtime/camera.h: px = fx·x/z + cx − 0.5) and depth of world point p.
std::array<double, 3> project(const Camera& c, std::array<double, 3> p) {
  double q[3];
  for (int r = 0; r < 3; ++r) {
    q[r] = c.translation[r];
    for (int k = 0; k < 3; ++k) q[r] += double(c.rotation[size_t(3 * r + k)]) * p[size_t(k)];
  }
  return {c.fx * q[0] / q[2] + c.cx - 0.5, c.fy * q[1] / q[2] + c.cy - 0.5, q[2]};
}

void check_pixel(const Camera& c, std::array<double, 3> world, double px, double py, double z) {
  const auto p = project(c, world);
  CHECK(p[0] == doctest::Approx(px).epsilon(1e-5));
  CHECK(p[1] == doctest::Approx(py).epsilon(1e-5));
  CHECK(p[2] == doctest::Approx(z).epsilon(1e-5));
}

rgs::api::Mat4ColumnMajor column_major(const double (&rows)[4][4]) {
  rgs::api::Mat4ColumnMajor m{};
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m[size_t(4 * c + r)] = float(rows[r][c]);
  }
  return m;
}

// View of an eye at (0, 0, 5) looking at the origin, y up (glm::lookAt((0,0,5), 0, (0,1,0))): translate(0,0,-5).
const double kView[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, -5}, {0, 0, 0, 1}};
// glm::perspective(90°, aspect 2, 0.1, 100): P00 = 1/(2·tan 45°) = 0.5, P11 = 1.
const double kPerspective[4][4] = {
    {0.5, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, -100.1 / 99.9, -20.0 / 99.9}, {0, 0, -1, 0}};

}  // namespace

TEST_CASE("INRIA: camera-to-world rotation and centre, principal point at the image centre") {
  // Identity orientation at (1, 2, 3): the point (1, 2, 13) is 10 units straight ahead.
  auto c = rgs::api::camera_from_inria({1, 0, 0, 0, 1, 0, 0, 0, 1}, {1, 2, 3}, 100, 100, 200, 100);
  REQUIRE(c.ok());
  CHECK(c->cx == 100.f);
  CHECK(c->cy == 50.f);
  check_pixel(*c, {1, 2, 13}, 99.5, 49.5, 10);
  // Camera axes as columns: camera z (forward) = world +x, camera x = world −z, y = world +y.
  auto turned = rgs::api::camera_from_inria({0, 0, 1, 0, 1, 0, -1, 0, 0}, {0, 0, 0}, 100, 100, 200, 100);
  REQUIRE(turned.ok());
  check_pixel(*turned, {5, 0, 0}, 99.5, 49.5, 5);
  // 1 unit along world −z is 1 unit along camera +x: 100·1/5 pixels right of centre.
  check_pixel(*turned, {5, 0, -1}, 119.5, 49.5, 5);
}

TEST_CASE("COLMAP: world-to-camera quaternion (w, x, y, z) and translation, principal point as given") {
  const double s = std::sqrt(0.5);
  // 90° about camera z: R = [[0, -1, 0], [1, 0, 0], [0, 0, 1]].
  auto c = rgs::api::camera_from_colmap({s, 0, 0, s}, {0, 0, 4}, 50, 60, 30, 20, 64, 48);
  REQUIRE(c.ok());
  CHECK(c->rotation[1] == doctest::Approx(-1));
  CHECK(c->rotation[3] == doctest::Approx(1));
  // World (1, 0, 0) → camera (0, 1, 4): px = 50·0/4 + 30 − 0.5, py = 60·1/4 + 20 − 0.5.
  check_pixel(*c, {1, 0, 0}, 29.5, 34.5, 4);
  // Unnormalized quaternions are normalized; a zero one is an error.
  auto scaled = rgs::api::camera_from_colmap({2 * s, 0, 0, 2 * s}, {0, 0, 4}, 50, 60, 30, 20, 64, 48);
  REQUIRE(scaled.ok());
  CHECK(scaled->rotation[1] == doctest::Approx(-1));
  auto zero = rgs::api::camera_from_colmap({0, 0, 0, 0}, {0, 0, 4}, 50, 60, 30, 20, 64, 48);
  CHECK(zero.status().code() == rgs::StatusCode::kInvalidArgument);
}

TEST_CASE("OpenCV: K + [R|t], pixel centres at integers") {
  // K's principal point (319.5, 239.5) is the centre of a 640×480 image in OpenCV's convention.
  auto c = rgs::api::camera_from_opencv({500, 0, 319.5, 0, 400, 239.5, 0, 0, 1}, {1, 0, 0, 0, 1, 0, 0, 0, 1},
                                        {0, 0, 2}, 640, 480);
  REQUIRE(c.ok());
  CHECK(c->cx == 320.f);
  CHECK(c->cy == 240.f);
  // OpenCV: u = fx·x/z + cx = 500·0.2/2 + 319.5 = 369.5, v = 400·(−0.1)/2 + 239.5 = 219.5 (y down).
  check_pixel(*c, {0.2, -0.1, 0}, 369.5, 219.5, 2);
  auto skew = rgs::api::camera_from_opencv({500, 1, 319.5, 0, 400, 239.5, 0, 0, 1}, {1, 0, 0, 0, 1, 0, 0, 0, 1},
                                           {0, 0, 2}, 640, 480);
  CHECK(skew.status().code() == rgs::StatusCode::kInvalidArgument);
  // GLM: K and R as mathematical matrices (glm is column-major: K[2][0] is row 0, column 2).
  glm::mat3 K(1.f);
  K[0][0] = 500;
  K[1][1] = 400;
  K[2][0] = 319.5f;
  K[2][1] = 239.5f;
  auto g = rgs::api::camera_from_opencv(K, glm::mat3(1.f), glm::vec3(0, 0, 2), 640, 480);
  REQUIRE(g.ok());
  check_pixel(*g, {0.2, -0.1, 0}, 369.5, 219.5, 2);
}

TEST_CASE("OpenGL: view + projection, y up, window origin bottom-left, image rows top first") {
  auto c = rgs::api::camera_from_opengl(column_major(kView), column_major(kPerspective), 200, 100);
  REQUIRE(c.ok());
  CHECK(c->fx == doctest::Approx(50));
  CHECK(c->fy == doctest::Approx(50));
  CHECK(c->cx == doctest::Approx(100));
  CHECK(c->cy == doctest::Approx(50));
  // World (1, 1, 0): eye (1, 1, −5), ndc (0.1, 0.2); window x = 1.1/2·200 = 110, y = 1.2/2·100 = 60 from the
  // bottom, i.e. 40 from the top; pixel centres at −0.5: (109.5, 39.5). Depth 5 in front of the camera.
  check_pixel(*c, {1, 1, 0}, 109.5, 39.5, 5);

  // The same through GLM.
  const glm::mat4 view = glm::lookAt(glm::vec3(0, 0, 5), glm::vec3(0, 0, 0), glm::vec3(0, 1, 0));
  const glm::mat4 proj = glm::perspective(glm::radians(90.f), 2.f, 0.1f, 100.f);
  auto g = rgs::api::camera_from_opengl(view, proj, 200, 100);
  REQUIRE(g.ok());
  check_pixel(*g, {1, 1, 0}, 109.5, 39.5, 5);

  // Off-centre frustum l = −0.1, r = 0.3, b = −0.1, t = 0.1, n = 0.1: P00 = 0.5, P02 = 0.5, P11 = 1.
  // The optical axis lands at ndc x = −0.5, window x = 50: cx = 50.
  auto off = rgs::api::camera_from_opengl(column_major(kView), rgs::api::detail::to_array(glm::frustum(
                                                                   -0.1f, 0.3f, -0.1f, 0.1f, 0.1f, 10.f)),
                                          200, 100);
  REQUIRE(off.ok());
  CHECK(off->cx == doctest::Approx(50));
  CHECK(off->fx == doctest::Approx(50));
  check_pixel(*off, {0, 0, 0}, 49.5, 49.5, 5);

  // Round trip through the matrices the library produces.
  const auto v2 = rgs::api::opengl_view_matrix(*c);
  const auto p2 = rgs::api::opengl_projection_matrix(*c, 0.1f, 100.f);
  auto back = rgs::api::camera_from_opengl(v2, p2, 200, 100);
  REQUIRE(back.ok());
  CHECK(back->fx == doctest::Approx(c->fx));
  CHECK(back->cy == doctest::Approx(c->cy));
  for (int i = 0; i < 9; ++i) CHECK(back->rotation[size_t(i)] == doctest::Approx(c->rotation[size_t(i)]));
  for (int i = 0; i < 3; ++i) CHECK(back->translation[size_t(i)] == doctest::Approx(c->translation[size_t(i)]));
}

TEST_CASE("Vulkan: clip y down (flipped P[1][1]), the same pixel as OpenGL for the same view") {
  double vk[4][4];
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) vk[r][c] = kPerspective[r][c];
  }
  vk[1][1] = -1;  // GLM's Vulkan recipe: projection[1][1] *= −1
  vk[2][2] = -100.0 / 99.9;  // depth 0..1 (glm::perspectiveRH_ZO); unused by the camera
  vk[2][3] = -10.0 / 99.9;
  auto c = rgs::api::camera_from_vulkan(column_major(kView), column_major(vk), 200, 100);
  REQUIRE(c.ok());
  // ndc y = −1·1/5 = −0.2 (down is +), row edge (−0.2 + 1)/2·100 = 40: pixel 39.5 as with OpenGL.
  check_pixel(*c, {1, 1, 0}, 109.5, 39.5, 5);
  // A Vulkan matrix read as OpenGL would flip the image: refused.
  auto wrong = rgs::api::camera_from_opengl(column_major(kView), column_major(vk), 200, 100);
  CHECK(wrong.status().code() == rgs::StatusCode::kInvalidArgument);
  CHECK(wrong.status().message().find("fy") != std::string::npos);
}

TEST_CASE("Projection and view matrices that are not pinhole cameras are refused") {
  const glm::mat4 ortho = glm::ortho(-1.f, 1.f, -1.f, 1.f, 0.1f, 10.f);
  auto o = rgs::api::camera_from_opengl(glm::mat4(1.f), ortho, 64, 64);
  CHECK(o.status().code() == rgs::StatusCode::kInvalidArgument);
  // A view with scale is not a rigid transform.
  glm::mat4 scaled = glm::scale(glm::mat4(1.f), glm::vec3(2.f));
  auto s = rgs::api::camera_from_opengl(scaled, glm::perspective(1.f, 1.f, 0.1f, 10.f), 64, 64);
  CHECK(s.status().code() == rgs::StatusCode::kInvalidArgument);
  // Near plane comes from the options, not from the projection.
  rgs::api::CameraOptions options;
  options.near_plane = 0.5f;
  options.name = "gl";
  auto n = rgs::api::camera_from_opengl(glm::mat4(1.f), glm::perspective(1.f, 1.f, 0.01f, 10.f), 64, 64, options);
  REQUIRE(n.ok());
  CHECK(n->near_plane == 0.5f);
  CHECK(n->name == "gl");
}
