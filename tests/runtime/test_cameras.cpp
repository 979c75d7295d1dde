// Cameras: INRIA cameras.json loading (real flowers file, subsets, resolution scaling, errors), orbits, paths
// and fly-throughs.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "render_test_util.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/runtime/camera.h"

namespace rgs::test {
namespace {

using runtime::Camera;
using runtime::InriaCameraOptions;

/// Pixel position of world point p in camera cam.
std::pair<float, float> project(const Camera& cam, const float p[3]) {
  float pc[3], px, py;
  kernels::world_to_camera(cam.rotation.data(), cam.translation.data(), p, pc);
  kernels::project_to_pixel(pc, cam.fx, cam.fy, cam.cx, cam.cy, &px, &py);
  return {px, py};
}

TEST_CASE("cameras.json: the flowers cameras (rotation is camera-to-world, position the centre)") {
  const std::string path = shared_scene("mipnerf360_flowers_cameras.json");
  if (path.empty()) return;
  auto all = runtime::load_inria_cameras(path);
  REQUIRE_MESSAGE(all.ok(), all.status().to_string());
  REQUIRE(all->size() == 173);
  const Camera& c0 = (*all)[0];
  CHECK(c0.name == "_DSC9040");
  CHECK(c0.width == 5025);
  CHECK(c0.height == 3312);
  CHECK(c0.fx == doctest::Approx(4328.590804346088));
  CHECK(c0.fy == doctest::Approx(4285.457130435278));
  CHECK(c0.cx == 2512.5f);
  CHECK(c0.cy == 1656.f);
  // R = rotationᵀ: JSON rotation[0][1] = -0.010911420501731165 is R[1][0].
  CHECK(c0.rotation[1 * 3 + 0] == doctest::Approx(-0.010911420501731165));
  CHECK(c0.rotation[0 * 3 + 1] == doctest::Approx(-0.023242959401519596));
  // The centre −Rᵀ·t is the JSON position.
  const auto centre = runtime::camera_centre(c0);
  CHECK(centre[0] == doctest::Approx(-0.04455056000361698).epsilon(1e-5));
  CHECK(centre[1] == doctest::Approx(1.4236172811064223).epsilon(1e-5));
  CHECK(centre[2] == doctest::Approx(2.9266059657391703).epsilon(1e-5));
  // A point 5 units along the camera's forward axis (third column of the camera-to-world rotation) lands on the
  // principal point minus the half-pixel offset.
  const float ahead[3] = {centre[0] + 5.f * 0.05793089468482287f, centre[1] + 5.f * -0.21669617569047375f,
                          centre[2] + 5.f * -0.9745187421913132f};
  const auto [px, py] = project(c0, ahead);
  CHECK(px == doctest::Approx(2512.0).epsilon(1e-4));
  CHECK(py == doctest::Approx(1655.5).epsilon(1e-4));
  for (const Camera& c : *all) CHECK(runtime::validate_camera(c).ok());
}

TEST_CASE("cameras.json: subsets and resolution scaling keep the field of view") {
  const std::string path = shared_scene("mipnerf360_flowers_cameras.json");
  if (path.empty()) return;
  InriaCameraOptions every20;
  every20.every_kth = 20;
  auto nine = runtime::load_inria_cameras(path, every20);
  REQUIRE(nine.ok());
  REQUIRE(nine->size() == 9);  // 0, 20, ..., 160
  auto all = runtime::load_inria_cameras(path);
  REQUIRE(all.ok());
  CHECK((*nine)[8].name == (*all)[160].name);

  InriaCameraOptions picked;
  picked.indices = {5, 0};
  auto two = runtime::load_inria_cameras(path, picked);
  REQUIRE(two.ok());
  REQUIRE(two->size() == 2);
  CHECK((*two)[0].name == (*all)[5].name);
  CHECK((*two)[1].name == "_DSC9040");

  InriaCameraOptions eighth;
  eighth.downscale = 8;
  auto small = runtime::load_inria_cameras(path, eighth);
  REQUIRE(small.ok());
  const Camera& s0 = (*small)[0];
  const Camera& f0 = (*all)[0];
  CHECK(s0.width == 628);  // round(5025/8 = 628.1)
  CHECK(s0.height == 414);
  CHECK(s0.cx == 314.f);
  CHECK(s0.cy == 207.f);
  CHECK(runtime::fov_from_focal(s0.fx, s0.width) == doctest::Approx(runtime::fov_from_focal(f0.fx, f0.width)));
  CHECK(runtime::fov_from_focal(s0.fy, s0.height) == doctest::Approx(runtime::fov_from_focal(f0.fy, f0.height)));
  CHECK(s0.fx == doctest::Approx(4328.590804346088 * 628 / 5025));

  InriaCameraOptions hd;
  hd.width = 1920;
  hd.height = 1080;
  auto full_hd = runtime::load_inria_cameras(path, hd);
  REQUIRE(full_hd.ok());
  CHECK((*full_hd)[0].width == 1920);
  CHECK((*full_hd)[0].height == 1080);
  CHECK((*full_hd)[0].fy == doctest::Approx(4285.457130435278 * 1080 / 3312));
  InriaCameraOptions width_only;
  width_only.width = 1920;
  auto keep_aspect = runtime::load_inria_cameras(path, width_only);
  REQUIRE(keep_aspect.ok());
  CHECK((*keep_aspect)[0].height == 1265);  // round(3312·1920/5025 = 1265.4)

  // resize_camera does the same on an already loaded camera.
  const Camera r = runtime::resize_camera(f0, 628, 414);
  CHECK(r.fx == doctest::Approx(s0.fx));
  CHECK(r.cy == doctest::Approx(s0.cy));
}

TEST_CASE("cameras.json: errors name the file, the camera and the cause") {
  const std::string name = "cams.json";
  auto parse = [&](const std::string& text, const InriaCameraOptions& o = {}) {
    return runtime::parse_inria_cameras(text, name, o).status();
  };
  const std::string good =
      R"({"id": 0, "img_name": "a", "width": 64, "height": 48, "position": [0, 0, 0],
          "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "fx": 50, "fy": 50})";
  CHECK(parse("[" + good + "]").ok());
  Status s = parse("[" + good + ",");
  CHECK(s.code() == StatusCode::kCorruptData);
  CHECK(s.message().find("cams.json: not valid JSON") == 0);
  CHECK(parse("{}").code() == StatusCode::kCorruptData);
  CHECK(parse("[]").code() == StatusCode::kCorruptData);
  CHECK(parse("[1]").code() == StatusCode::kCorruptData);

  auto with = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    const size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
    return parse("[" + good + ", " + text + "]");
  };
  s = with(R"("fx": 50)", R"("fx": -50)");
  CHECK(s.code() == StatusCode::kCorruptData);
  CHECK(s.message().find("cams.json: camera 1") == 0);
  CHECK(with(R"("fx": 50, )", "").code() == StatusCode::kCorruptData);  // missing
  CHECK(with(R"("width": 64)", R"("width": "64")").code() == StatusCode::kCorruptData);
  CHECK(with(R"("width": 64)", R"("width": 0)").code() == StatusCode::kCorruptData);
  CHECK(with(R"("width": 64)", R"("width": 64.5)").code() == StatusCode::kCorruptData);
  CHECK(with(R"("position": [0, 0, 0])", R"("position": [0, 0])").code() == StatusCode::kCorruptData);
  CHECK(with(R"([0, 1, 0])", R"([0, 2, 0])").code() == StatusCode::kCorruptData);   // not orthonormal
  CHECK(with(R"([0, 0, 1]])", R"([0, 0, -1]])").code() == StatusCode::kCorruptData);  // reflection
  CHECK(with(R"([0, 1, 0])", R"([0, "x", 0])").code() == StatusCode::kCorruptData);
  CHECK(with(R"("fx": 50)", R"("fx": 1000001)").code() == StatusCode::kCorruptData);  // focal above 1e6
  CHECK(with(R"("position": [0, 0, 0])", R"("position": [0, -2e9, 0])").code() == StatusCode::kCorruptData);

  // Hostile files are bounded while parsing: nesting deeper than a cameras.json has, too many cameras, too many
  // bytes (kLimitExceeded, not the tree they would build).
  s = parse("[" + good + ", " + std::string(1 << 20, '[') + std::string(1 << 20, ']') + "]");
  CHECK(s.code() == StatusCode::kLimitExceeded);
  CHECK(s.message().find("cams.json: nested deeper than 8 levels") == 0);
  CHECK(parse("[" + good + ", [[[[[[[1]]]]]]]]").code() == StatusCode::kCorruptData);  // 8 levels: parsed, then refused
  std::string many = "[" + good;
  for (int i = 0; i < 100000; ++i) many += ",0";
  s = parse(many + "]");
  CHECK(s.code() == StatusCode::kLimitExceeded);
  CHECK(s.message().find("more than 100000 cameras") != std::string::npos);
  CHECK(parse("[" + good + "]" + std::string((64 << 20) - good.size(), ' ')).code() == StatusCode::kLimitExceeded);

  // Every entry is checked, whichever is selected: the viewer and the renderers refuse the same files.
  InriaCameraOptions first;
  first.indices = {0};
  CHECK(parse("[" + good + ", 1]", first).code() == StatusCode::kCorruptData);

  InriaCameraOptions bad;
  bad.indices = {1};
  s = parse("[" + good + "]", bad);
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find("camera index 1 >= camera count 1") != std::string::npos);
  bad = {};
  bad.every_kth = 0;
  CHECK(parse("[" + good + "]", bad).code() == StatusCode::kInvalidArgument);
  bad = {};
  bad.downscale = 0;
  CHECK(parse("[" + good + "]", bad).code() == StatusCode::kInvalidArgument);

  const std::string missing = (std::filesystem::temp_directory_path() / "rgs_no_such_cameras.json").string();
  s = runtime::load_inria_cameras(missing).status();
  CHECK(s.code() == StatusCode::kIoError);
  CHECK(s.message().find(missing) == 0);
}

TEST_CASE("orbit cameras: look at the sphere centre from a ring, up = -y, deterministic") {
  format::SceneBounds bounds;
  bounds.sphere_center[0] = 1.f;
  bounds.sphere_center[1] = -2.f;
  bounds.sphere_center[2] = 3.f;
  bounds.sphere_radius = 2.f;
  runtime::OrbitOptions options;
  auto ring = runtime::orbit_cameras(bounds, 4, 320, 240, options);
  REQUIRE_MESSAGE(ring.ok(), ring.status().to_string());
  REQUIRE(ring->size() == 4);
  const double fov_min = std::min(runtime::fov_from_focal((*ring)[0].fx, 320), 50.0 * M_PI / 180.0);
  const double distance = 2.0 / std::sin(fov_min / 2);
  for (size_t i = 0; i < ring->size(); ++i) {
    CAPTURE(i);
    const Camera& cam = (*ring)[i];
    CHECK(runtime::validate_camera(cam).ok());
    CHECK(cam.fx == cam.fy);
    CHECK(cam.cx == 160.f);
    CHECK(cam.cy == 120.f);
    CHECK(runtime::fov_from_focal(cam.fy, 240) == doctest::Approx(50.0 * M_PI / 180.0));
    const auto c = runtime::camera_centre(cam);
    const double d = std::sqrt(std::pow(c[0] - 1.0, 2) + std::pow(c[1] + 2.0, 2) + std::pow(c[2] - 3.0, 2));
    CHECK(d == doctest::Approx(distance).epsilon(1e-5));
    CHECK(c[1] < -2.f);  // 20° above the target, and "above" is −y
    // The target projects to the image centre; a point above it (−y) projects higher (smaller row).
    const float target[3] = {1.f, -2.f, 3.f};
    const float above[3] = {1.f, -2.5f, 3.f};
    const auto [tx, ty] = project(cam, target);
    CHECK(tx == doctest::Approx(159.5).epsilon(1e-4));
    CHECK(ty == doctest::Approx(119.5).epsilon(1e-4));
    CHECK(project(cam, above).second < ty - 10.f);
  }
  // Azimuth 0 sits on the −z side; consecutive cameras are 90° apart.
  CHECK(runtime::camera_centre((*ring)[0])[2] < 3.f);
  CHECK(runtime::camera_centre((*ring)[1])[0] > 1.f);
  auto again = runtime::orbit_cameras(bounds, 4, 320, 240, options);
  REQUIRE(again.ok());
  for (size_t i = 0; i < 4; ++i) {
    CHECK((*again)[i].rotation == (*ring)[i].rotation);
    CHECK((*again)[i].translation == (*ring)[i].translation);
  }
  CHECK((*ring)[3].name == "orbit_003");

  CHECK(runtime::orbit_cameras(bounds, 0, 320, 240).status().code() == StatusCode::kInvalidArgument);
  CHECK(runtime::orbit_cameras(bounds, 4, 0, 240).status().code() == StatusCode::kInvalidArgument);
  format::SceneBounds point = bounds;
  point.sphere_radius = 0.f;
  CHECK(runtime::orbit_cameras(point, 4, 320, 240).status().code() == StatusCode::kInvalidArgument);
  runtime::OrbitOptions steep;
  steep.elevation_deg = 90;
  CHECK(runtime::orbit_cameras(bounds, 4, 320, 240, steep).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("path cameras: a spiral that rises, swings near and far, and always looks at the centre") {
  format::SceneBounds bounds;
  bounds.sphere_center[0] = 1.f;
  bounds.sphere_center[1] = -2.f;
  bounds.sphere_center[2] = 3.f;
  bounds.sphere_radius = 2.f;
  runtime::PathOptions path;
  auto views = runtime::path_cameras(bounds, 12, 320, 240, path);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  REQUIRE(views->size() == 12);
  const double fit = 2.0 / std::sin(std::min(runtime::fov_from_focal((*views)[0].fx, 320), 50.0 * M_PI / 180.0) / 2);
  double previous_elevation = 0;
  for (size_t i = 0; i < views->size(); ++i) {
    CAPTURE(i);
    const Camera& cam = (*views)[i];
    const double t = double(i) / 12.0;
    const auto c = runtime::camera_centre(cam);
    const double dx = c[0] - 1.0, dy = c[1] + 2.0, dz = c[2] - 3.0;
    const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double factor = 1.0 + (0.3 - 1.0) * (1.0 - std::cos(6.0 * M_PI * t)) / 2.0;
    CHECK(d == doctest::Approx(factor * fit).epsilon(1e-5));
    // Elevation from 5° to 60°: the height above the target (−y) over the distance is its sine.
    const double elevation = std::asin(-dy / d) * 180.0 / M_PI;
    CHECK(elevation == doctest::Approx(5.0 + 55.0 * t).epsilon(1e-4));
    CHECK(elevation > previous_elevation);
    previous_elevation = elevation;
    const float target[3] = {1.f, -2.f, 3.f};
    const auto [tx, ty] = project(cam, target);
    CHECK(tx == doctest::Approx(159.5).epsilon(1e-4));
    CHECK(ty == doctest::Approx(119.5).epsilon(1e-4));
  }
  CHECK((*views)[11].name == "path_011");
  // Two turns: views 0 and 6 sit at the same azimuth (the −z side of the target).
  CHECK(runtime::camera_centre((*views)[0])[2] < 3.f);
  CHECK(runtime::camera_centre((*views)[6])[2] < 3.f);
  CHECK(runtime::camera_centre((*views)[3])[2] > 3.f);
  runtime::PathOptions inverted = path;
  inverted.distance_near = 0;
  CHECK(runtime::path_cameras(bounds, 12, 320, 240, inverted).status().code() == StatusCode::kInvalidArgument);
  CHECK(runtime::path_cameras(bounds, 0, 320, 240).status().code() == StatusCode::kInvalidArgument);
}

/// A fly-through key at `centre` (world units) turned `yaw_deg` about world −y (up), 320×240, 60° wide.
Camera fly_key(std::array<double, 3> centre, double yaw_deg, const std::string& name) {
  Camera cam;
  const double a = yaw_deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
  // World-to-camera rotation about the y axis; rows are the camera axes in world coordinates.
  const double r[9] = {c, 0, -s, 0, 1, 0, s, 0, c};
  for (int i = 0; i < 9; ++i) cam.rotation[i] = float(r[i]);
  for (int i = 0; i < 3; ++i) {
    cam.translation[i] = float(-(r[3 * i] * centre[0] + r[3 * i + 1] * centre[1] + r[3 * i + 2] * centre[2]));
  }
  cam.width = 320;
  cam.height = 240;
  cam.fx = cam.fy = float(runtime::focal_from_fov(M_PI / 3, 320));
  cam.cx = 160;
  cam.cy = 120;
  cam.name = name;
  return cam;
}

double distance(const std::array<float, 3>& a, const std::array<float, 3>& b) {
  double d = 0;
  for (int k = 0; k < 3; ++k) d += double(a[k] - b[k]) * double(a[k] - b[k]);
  return std::sqrt(d);
}

/// Longest and shortest distance between consecutive view centres.
std::pair<double, double> step_range(const std::vector<Camera>& views) {
  double shortest = 1e30, longest = 0;
  for (size_t i = 1; i < views.size(); ++i) {
    const double step = distance(runtime::camera_centre(views[i - 1]), runtime::camera_centre(views[i]));
    shortest = std::min(shortest, step);
    longest = std::max(longest, step);
  }
  return {longest, shortest};
}

/// R·Rᵀ = I to `tolerance` and every value finite.
bool orthonormal(const Camera& cam, double tolerance) {
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(cam.translation[i])) return false;
    for (int j = 0; j < 3; ++j) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += double(cam.rotation[3 * i + k]) * double(cam.rotation[3 * j + k]);
      if (!(std::abs(dot - (i == j ? 1.0 : 0.0)) <= tolerance)) return false;
    }
  }
  return true;
}

TEST_CASE("fly-through cameras: through every key at steady speed, rotations orthonormal") {
  format::SceneBounds bounds;
  bounds.sphere_radius = 5.f;
  // Keys of an orbit, unevenly spaced: the first two close together, the rest far apart.
  auto ring = runtime::orbit_cameras(bounds, 16, 320, 240);
  REQUIRE(ring.ok());
  const std::vector<Camera> keys = {(*ring)[0], (*ring)[1], (*ring)[5], (*ring)[9], (*ring)[12]};
  auto views = runtime::fly_through_cameras(keys, 400);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  REQUIRE(views->size() == 400);
  CHECK((*views)[0].name == "fly_000");
  CHECK((*views)[399].name == "fly_399");
  // The first view is the first key, the last view has the last key's pose; all take the first key's intrinsics.
  CHECK((*views)[0].rotation == keys[0].rotation);
  CHECK((*views)[0].translation == keys[0].translation);
  CHECK((*views)[399].rotation == keys.back().rotation);
  CHECK((*views)[399].translation == keys.back().translation);
  for (const Camera& v : *views) {
    CHECK(v.fx == keys[0].fx);
    CHECK(v.cy == keys[0].cy);
    CHECK(v.width == keys[0].width);
    CHECK(v.near_plane == keys[0].near_plane);
  }
  // Steady speed: consecutive centres are equally far apart, whatever the key spacing (1 : 4 : 4 : 3 here).
  const auto [longest, shortest] = step_range(*views);
  CHECK(longest / shortest < 1.02);
  // The path passes through every key: the nearest view lies within half a step of each key centre, and
  // there the view's rotation is the key's.
  for (const Camera& key : keys) {
    CAPTURE(key.name);
    const auto k = runtime::camera_centre(key);
    size_t nearest = 0;
    for (size_t i = 1; i < views->size(); ++i) {
      if (distance(runtime::camera_centre((*views)[i]), k) < distance(runtime::camera_centre((*views)[nearest]), k)) {
        nearest = i;
      }
    }
    CHECK(distance(runtime::camera_centre((*views)[nearest]), k) <= 0.51 * longest);
    for (int i = 0; i < 9; ++i) CHECK(std::abs((*views)[nearest].rotation[i] - key.rotation[i]) < 0.02f);
  }
  for (const Camera& v : *views) {
    CHECK(orthonormal(v, 1e-5));
    CHECK(runtime::validate_camera(v).ok());
  }
  // Deterministic.
  auto again = runtime::fly_through_cameras(keys, 400);
  REQUIRE(again.ok());
  for (size_t i = 0; i < views->size(); ++i) {
    CHECK((*again)[i].rotation == (*views)[i].rotation);
    CHECK((*again)[i].translation == (*views)[i].translation);
  }
  // One view: the first key.
  auto one = runtime::fly_through_cameras(keys, 1);
  REQUIRE(one.ok());
  REQUIRE(one->size() == 1);
  CHECK((*one)[0].translation == keys[0].translation);
}

TEST_CASE("fly-through cameras: the centripetal spline keeps going forward where key steps are uneven") {
  // Keys on the x axis at 0, 10, 10.5 and 20: any Catmull–Rom spline stays on the line, but the uniform one
  // overshoots 10.5 and comes back (a reversal of the camera), the centripetal one moves forward throughout.
  const std::vector<Camera> keys = {fly_key({0, 0, 0}, 0, "a"), fly_key({10, 0, 0}, 10, "b"),
                                    fly_key({10.5, 0, 0}, 20, "c"), fly_key({20, 0, 0}, 30, "d")};
  auto views = runtime::fly_through_cameras(keys, 200);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  float previous_x = -1;
  bool forward = true;
  for (const Camera& v : *views) {
    const auto c = runtime::camera_centre(v);
    CHECK(std::abs(c[1]) < 1e-4f);
    CHECK(std::abs(c[2]) < 1e-4f);
    forward &= c[0] > previous_x && c[0] <= 20.0001f;
    previous_x = c[0];
  }
  CHECK(forward);
  const auto [longest, shortest] = step_range(*views);
  CHECK(longest / shortest < 1.02);
  runtime::FlyThroughOptions uniform;
  uniform.spline_alpha = 0;
  auto overshooting = runtime::fly_through_cameras(keys, 200, uniform);
  REQUIRE(overshooting.ok());
  bool reverses = false;
  for (size_t i = 1; i < overshooting->size(); ++i) {
    reverses |= runtime::camera_centre((*overshooting)[i])[0] < runtime::camera_centre((*overshooting)[i - 1])[0];
  }
  CHECK(reverses);
  // Evenly spaced keys (steps of 5): every knot exponent gives the same curve.
  const std::vector<Camera> evenly = {fly_key({0, 0, 0}, 0, "a"), fly_key({4, 0, 3}, 40, "b"),
                                      fly_key({8, 0, 0}, 80, "c"), fly_key({8, 3, 4}, 120, "d")};
  auto centripetal = runtime::fly_through_cameras(evenly, 50);
  auto flat = runtime::fly_through_cameras(evenly, 50, uniform);
  REQUIRE(centripetal.ok());
  REQUIRE(flat.ok());
  for (size_t i = 0; i < 50; ++i) {
    CHECK(distance(runtime::camera_centre((*centripetal)[i]), runtime::camera_centre((*flat)[i])) < 1e-4);
  }
}

TEST_CASE("fly-through cameras: coincident key centres give finite views") {
  // Keys 0-1 and 3-4 share their centres (a camera turning on the spot), with other rotations.
  const std::vector<Camera> keys = {fly_key({0, 0, 0}, 0, "a"), fly_key({0, 0, 0}, 30, "b"),
                                    fly_key({5, -1, 2}, 60, "c"), fly_key({9, 0, 0}, 90, "d"),
                                    fly_key({9, 0, 0}, 120, "e")};
  auto views = runtime::fly_through_cameras(keys, 60);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  for (const Camera& v : *views) {
    CAPTURE(v.name);
    CHECK(orthonormal(v, 1e-5));
    CHECK(runtime::validate_camera(v).ok());
  }
  CHECK((*views)[0].rotation == keys[0].rotation);
  CHECK((*views)[59].rotation == keys[4].rotation);
  CHECK((*views)[59].translation == keys[4].translation);
  const auto [longest, shortest] = step_range(*views);
  CHECK(longest / shortest < 1.02);
  // Every key at one centre: finite views spaced by key index, turning from the first key to the last.
  auto turning = runtime::fly_through_cameras({keys[0], keys[1], keys[1]}, 7);
  REQUIRE_MESSAGE(turning.ok(), turning.status().to_string());
  for (const Camera& v : *turning) {
    CHECK(orthonormal(v, 1e-5));
    CHECK(distance(runtime::camera_centre(v), runtime::camera_centre(keys[0])) < 1e-5);
  }
  CHECK((*turning)[6].rotation == keys[1].rotation);
}

TEST_CASE("fly-through cameras: bad input refused with the reason") {
  const std::vector<Camera> keys = {fly_key({0, 0, 0}, 0, "a"), fly_key({3, 0, 0}, 10, "b"),
                                    fly_key({6, 0, 1}, 20, "c")};
  auto zero = runtime::fly_through_cameras(keys, 0);
  CHECK(zero.status().code() == StatusCode::kInvalidArgument);
  CHECK(zero.status().message().find("view count is 0") != std::string::npos);
  auto single = runtime::fly_through_cameras({keys[0]}, 8);
  CHECK(single.status().code() == StatusCode::kInvalidArgument);
  CHECK(single.status().message().find("at least 2 key cameras, got 1") != std::string::npos);
  CHECK(runtime::fly_through_cameras({}, 8).status().code() == StatusCode::kInvalidArgument);
  std::vector<Camera> sizes = keys;
  sizes[2] = runtime::resize_camera(sizes[2], 640, 480);
  auto mixed = runtime::fly_through_cameras(sizes, 8);
  CHECK(mixed.status().code() == StatusCode::kInvalidArgument);
  CHECK(mixed.status().message().find("key 2 (c) is 640x480, key 0 is 320x240") != std::string::npos);
  std::vector<Camera> skewed = keys;
  skewed[1].rotation[0] = 2;
  auto bad_key = runtime::fly_through_cameras(skewed, 8);
  CHECK(bad_key.status().code() == StatusCode::kInvalidArgument);
  CHECK(bad_key.status().message().find("key 1 (b)") != std::string::npos);
  for (double alpha : {-0.1, 1.5, std::nan("")}) {
    runtime::FlyThroughOptions options;
    options.spline_alpha = alpha;
    CHECK(runtime::fly_through_cameras(keys, 8, options).status().code() == StatusCode::kInvalidArgument);
  }
}

}  // namespace
}  // namespace rgs::test
