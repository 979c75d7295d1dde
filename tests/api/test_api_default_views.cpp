// The default views: a cameras.json of the standard 3DGS layout is found beside the scene and nowhere else, read
// as hostile input; without one, the guessed views frame the dense content, not the floaters around it, and stand
// inside a capture's content when it surrounds a core.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/converter/quantize.h"
#include "rgs/runtime/camera.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;
namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

/// `cameras` as an INRIA cameras.json: rotation camera-to-world (Rᵀ), position the camera centre.
std::string inria_json(const std::vector<runtime::Camera>& cameras) {
  std::string out = "[";
  for (size_t i = 0; i < cameras.size(); ++i) {
    const runtime::Camera& c = cameras[i];
    const std::array<float, 3> p = runtime::camera_centre(c);
    const auto& r = c.rotation;
    char text[1024];
    std::snprintf(text, sizeof(text),
                  "%s{\"id\": %zu, \"img_name\": \"cam_%zu\", \"width\": %u, \"height\": %u, "
                  "\"position\": [%.9g, %.9g, %.9g], \"rotation\": [[%.9g, %.9g, %.9g], [%.9g, %.9g, %.9g], "
                  "[%.9g, %.9g, %.9g]], \"fx\": %.9g, \"fy\": %.9g}",
                  i ? ", " : "", i, i, c.width, c.height, p[0], p[1], p[2], r[0], r[3], r[6], r[1], r[4], r[7], r[2],
                  r[5], r[8], c.fx, c.fy);
    out += text;
  }
  return out + "]";
}

/// Three views of a 640x480 orbit around the unit sphere.
std::string three_cameras_json() {
  format::SceneBounds bounds;
  bounds.sphere_radius = 1;
  auto cameras = runtime::orbit_cameras(bounds, 3, 640, 480);
  REQUIRE(cameras.ok());
  return inria_json(*cameras);
}

/// A point `p` in camera `c`'s frame: {x, y, depth}.
std::array<double, 3> in_camera(const runtime::Camera& c, const float p[3]) {
  std::array<double, 3> out{};
  for (int row = 0; row < 3; ++row) {
    out[row] = c.translation[row];
    for (int j = 0; j < 3; ++j) out[row] += double(c.rotation[row * 3 + j]) * p[j];
  }
  return out;
}

/// Adds `count` Gaussians of opacity `opacity` at `centre` + a direction uniform on the sphere × a radius uniform
/// in [r0, r1].
void add_shell(format::GaussianCloud* cloud, std::mt19937* rng, const float centre[3], double r0, double r1,
               size_t count, float opacity) {
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> radius(r0, r1);
  const size_t first = cloud->size();
  cloud->resize(first + count);
  for (size_t i = first; i < first + count; ++i) {
    double d[3] = {normal(*rng), normal(*rng), normal(*rng)};
    const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 1e-12;
    const double r = radius(*rng);
    for (int a = 0; a < 3; ++a) {
      cloud->means[3 * i + a] = float(centre[a] + d[a] / n * r);
      cloud->scales[3 * i + a] = 0.01f;
    }
    cloud->rotations[4 * i] = 1;
    cloud->opacities[i] = opacity;
  }
}

/// How many image heights the sphere of radius `r` around `p` spans in `c` (0 when behind it), and whether `p`
/// projects into the middle half of the image.
std::pair<double, bool> framing(const runtime::Camera& c, const float p[3], double r) {
  const std::array<double, 3> v = in_camera(c, p);
  if (!(v[2] > 0)) return {0, false};
  const double x = c.fx * v[0] / v[2] + c.cx, y = c.fy * v[1] / v[2] + c.cy;
  const bool middle = x > 0.25 * c.width && x < 0.75 * c.width && y > 0.25 * c.height && y < 0.75 * c.height;
  return {2 * r * c.fy / v[2] / c.height, middle};
}

}  // namespace

TEST_CASE("a cameras.json of the 3DGS output layout is found beside the scene, and nowhere else") {
  test::TempDir dir;
  const fs::path model = dir.path() / "model";
  const fs::path ply = model / "point_cloud" / "iteration_30000" / "point_cloud.ply";
  write_text(ply, "not read");
  auto found = api::find_scene_cameras(ply.string());
  REQUIRE_MESSAGE(found.ok(), found.status().to_string());
  CHECK(found->empty());  // absent

  write_text(model / "cameras.json", three_cameras_json());
  found = api::find_scene_cameras(ply.string());
  REQUIRE_MESSAGE(found.ok(), found.status().to_string());
  CHECK(fs::equivalent(*found, model / "cameras.json"));

  // In the scene's own folder, which comes first.
  write_text(ply.parent_path() / "cameras.json", three_cameras_json());
  found = api::find_scene_cameras(ply.string());
  REQUIRE(found.ok());
  CHECK(fs::equivalent(*found, ply.parent_path() / "cameras.json"));

  // Two levels up only from point_cloud/iteration_<digits>: elsewhere the folder above is never looked at.
  for (const fs::path& other : {dir.path() / "a" / "b" / "scene.ply", dir.path() / "point_cloud" / "iteration_x" /
                                                                              "scene.ply",
                                dir.path() / "x" / "iteration_7" / "scene.ply"}) {
    CAPTURE(other);
    write_text(other, "not read");
    write_text(other.parent_path().parent_path().parent_path() / "cameras.json", "garbage that must not be read");
    write_text(other.parent_path().parent_path() / "cameras.json", "garbage that must not be read");
    auto none = api::find_scene_cameras(other.string());
    REQUIRE_MESSAGE(none.ok(), none.status().to_string());
    CHECK(none->empty());
  }
}

TEST_CASE("a capture's cameras named after the scene are found beside it: PREFIX_cameras.json") {
  // As mipnerf360_flowers_cameras.json lies beside mipnerf360_flowers_c3dgs.ply.
  test::TempDir dir;
  const fs::path ply = dir.path() / "capture_flowers_c3dgs.ply";
  write_text(ply, "not read");
  write_text(dir.path() / "flowers_cameras.json", "not a prefix of the scene's name: never read");
  write_text(dir.path() / "capture_flowers_c3dgs_cameras.json", "the whole name is no prefix: never read");
  auto found = api::find_scene_cameras(ply.string());
  REQUIRE_MESSAGE(found.ok(), found.status().to_string());
  CHECK(found->empty());
  write_text(dir.path() / "capture_cameras.json", three_cameras_json());
  found = api::find_scene_cameras(ply.string());
  REQUIRE(found.ok());
  CHECK(fs::equivalent(*found, dir.path() / "capture_cameras.json"));
  // The longest prefix first; a cameras.json in the folder before either.
  write_text(dir.path() / "capture_flowers_cameras.json", three_cameras_json());
  found = api::find_scene_cameras(ply.string());
  REQUIRE(found.ok());
  CHECK(fs::equivalent(*found, dir.path() / "capture_flowers_cameras.json"));
  write_text(dir.path() / "cameras.json", three_cameras_json());
  found = api::find_scene_cameras(ply.string());
  REQUIRE(found.ok());
  CHECK(fs::equivalent(*found, dir.path() / "cameras.json"));
}

TEST_CASE("a cameras.json found beside the scene is hostile input: garbled, not a file, or a link out") {
  test::TempDir dir;
  const fs::path model = dir.path() / "model";
  const fs::path ply = model / "point_cloud" / "iteration_7" / "point_cloud.ply";
  write_text(ply, "");
  format::GaussianCloud cloud;
  std::mt19937 rng(3);
  const float origin[3] = {0, 0, 0};
  add_shell(&cloud, &rng, origin, 0, 1, 200, 0.5f);

  SUBCASE("garbled JSON: an error that names the file and says it was found beside the scene") {
    write_text(model / "cameras.json", "[{\"id\": 0, \"width\": 640, \"height\": ");
    auto views = api::default_views(ply.string(), cloud);
    REQUIRE_FALSE(views.ok());
    CHECK(views.status().code() == StatusCode::kCorruptData);
    const std::string message = views.status().message();
    CHECK_MESSAGE(message.find((model / "cameras.json").string()) != std::string::npos, message);
    CHECK_MESSAGE(message.find("found beside the scene") != std::string::npos, message);
  }
  SUBCASE("valid JSON, invalid cameras: a rotation that is not one") {
    std::string json = three_cameras_json();
    json.replace(json.find("\"rotation\": [[") + 14, 1, "7");
    write_text(model / "cameras.json", json);
    auto views = api::default_views(ply.string(), cloud);
    REQUIRE_FALSE(views.ok());
    CHECK(views.status().code() == StatusCode::kCorruptData);
  }
  SUBCASE("a directory named cameras.json") {
    fs::create_directories(model / "cameras.json");
    auto found = api::find_scene_cameras(ply.string());
    REQUIRE_FALSE(found.ok());
    CHECK(found.status().code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(std::string(found.status().message()).find("not a regular file") != std::string::npos,
                  found.status().message());
  }
  SUBCASE("a link that leaves the scene's folder tree is not read") {
    const fs::path outside = dir.path() / "elsewhere" / "secret.json";
    write_text(outside, three_cameras_json());
    fs::create_symlink(outside, model / "cameras.json");
    auto found = api::find_scene_cameras(ply.string());
    REQUIRE_FALSE(found.ok());
    CHECK(found.status().code() == StatusCode::kInvalidArgument);
    const std::string message = found.status().message();
    CHECK_MESSAGE(message.find("outside the scene's folder") != std::string::npos, message);
    auto views = api::default_views(ply.string(), cloud);
    CHECK_FALSE(views.ok());
  }
  SUBCASE("a link that stays inside it is read") {
    write_text(model / "cams" / "all.json", three_cameras_json());
    fs::create_symlink(model / "cams" / "all.json", model / "cameras.json");
    auto views = api::default_views(ply.string(), cloud);
    REQUIRE_MESSAGE(views.ok(), views.status().to_string());
    CHECK(views->cameras.size() == 3);
  }
  SUBCASE("a dangling link") {
    fs::create_symlink(model / "missing.json", model / "cameras.json");
    auto found = api::find_scene_cameras(ply.string());
    REQUIRE_FALSE(found.ok());
    CHECK(found.status().code() == StatusCode::kInvalidArgument);
  }
}

TEST_CASE("the default views are the scene's own cameras when found, each resized to 960 wide, and say so") {
  test::TempDir dir;
  const fs::path ply = dir.path() / "scene.ply";
  write_text(ply, "");
  write_text(dir.path() / "cameras.json", three_cameras_json());
  format::GaussianCloud cloud;
  std::mt19937 rng(5);
  const float origin[3] = {0, 0, 0};
  add_shell(&cloud, &rng, origin, 0, 1, 100, 0.5f);
  api::CameraChoice choice;
  auto views = api::default_views(ply.string(), cloud, choice);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  REQUIRE(views->cameras.size() == 3);
  CHECK(views->cameras[0].name == "cam_0");
  CHECK(views->cameras[0].width == 640);  // never enlarged
  CHECK(views->note.find("the scene's own cameras") != std::string::npos);
  CHECK(!views->cameras_path.empty());
  choice.limit = 2;  // every 2nd
  choice.width = 320;
  views = api::default_views(ply.string(), cloud, choice);
  REQUIRE(views.ok());
  REQUIRE(views->cameras.size() == 2);
  CHECK(views->cameras[1].name == "cam_2");
  CHECK(views->cameras[1].width == 320);
  CHECK(views->cameras[1].height == 240);

  fs::remove(dir.path() / "cameras.json");
  views = api::default_views(ply.string(), cloud, {});
  REQUIRE(views.ok());
  CHECK(views->cameras_path.empty());
  CHECK(views->cameras.size() == 6);
  CHECK(views->cameras[0].width == 960);
  CHECK(views->note.find("guessed") != std::string::npos);
}

TEST_CASE("guessed views frame the dense content of a scene with far floaters, which a bounding sphere does not") {
  // One object (a ball of radius 1) and 5 % of the weight in floaters 200-2000 units away on every side.
  const float object[3] = {5, -2, 3};
  for (uint32_t seed : {1u, 2u, 3u}) {
    CAPTURE(seed);
    std::mt19937 rng(seed);
    format::GaussianCloud cloud;
    add_shell(&cloud, &rng, object, 0, 1, 3800, 0.8f);
    add_shell(&cloud, &rng, object, 200, 2000, 160, 0.95f);
    api::ContentViewsInfo info;
    auto views = api::content_views(cloud, 960, 540, &info);
    REQUIRE_MESSAGE(views.ok(), views.status().to_string());
    CHECK_FALSE(info.surrounds);
    REQUIRE(views->size() == 6);
    for (const runtime::Camera& cam : *views) {
      CAPTURE(cam.name);
      CHECK(runtime::validate_camera(cam).ok());
      const auto [span, middle] = framing(cam, object, 1.0);
      CHECK(middle);
      CHECK(span > 0.5);  // the object fills a good part of the frame
      CHECK(span < 1.5);  // and all of it is in view
    }
    // The bounding sphere (floaters included) puts the object at a few pixels.
    auto orbit = runtime::orbit_cameras(converter::compute_bounds(cloud), 4, 960, 540);
    REQUIRE(orbit.ok());
    CHECK(framing((*orbit)[0], object, 1.0).first < 0.01);
  }
}

TEST_CASE("guessed views of content that surrounds a core stand inside it, looking at the core and outward") {
  // A capture's shape: a dense core (a third of the weight) and content all around at 10-40 units.
  const float core[3] = {-1, 0.5f, 2};
  std::mt19937 rng(11);
  format::GaussianCloud cloud;
  add_shell(&cloud, &rng, core, 0, 1, 3000, 0.9f);
  add_shell(&cloud, &rng, core, 10, 40, 6000, 0.9f);
  api::ContentViewsInfo info;
  auto views = api::content_views(cloud, 960, 540, &info);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  CHECK(info.surrounds);
  REQUIRE(views->size() == 6);
  size_t outward = 0;
  for (const runtime::Camera& cam : *views) {
    CAPTURE(cam.name);
    const std::array<float, 3> eye = runtime::camera_centre(cam);
    const double distance = std::hypot(eye[0] - core[0], eye[1] - core[1], eye[2] - core[2]);
    CHECK(distance > info.radius_25);  // outside the quarter-weight core
    CHECK(distance < 10);   // inside the content around it
    const auto [span, middle] = framing(cam, core, 1.0);
    if (cam.name.find("out") != std::string::npos) {
      ++outward;
      CHECK(span == 0);  // the core is behind it
    } else {
      CHECK(middle);
      CHECK(span > 0.5);
    }
  }
  CHECK(outward == 1);
}

TEST_CASE("guessed views of one Gaussian, or of Gaussians without opacity, are still valid cameras") {
  format::GaussianCloud cloud;
  cloud.resize(1);
  cloud.means = {1, 2, 3};
  cloud.scales = {0.5f, 0.5f, 0.5f};
  cloud.rotations = {1, 0, 0, 0};
  cloud.opacities = {0};
  auto views = api::content_views(cloud, 64, 64);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  for (const runtime::Camera& cam : *views) {
    CHECK(runtime::validate_camera(cam).ok());
    const float mean[3] = {1, 2, 3};
    CHECK(framing(cam, mean, 0.5).second);
  }
  cloud.means = {NAN, 0, 0};
  CHECK(api::content_views(cloud, 64, 64).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("the default orbit of a 360 capture stands where its cameras stood, not outside its floaters") {
  const std::string ply = test::shared_scene("mipnerf360_flowers_c3dgs.ply");
  const std::string json = test::shared_scene("mipnerf360_flowers_cameras.json");
  if (ply.empty() || json.empty()) return;
  api::LoadOptions load;
  load.device = api::Device::kCpu;
  auto scene = api::load(ply, load);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto capture = runtime::load_inria_cameras(json);
  REQUIRE_MESSAGE(capture.ok(), capture.status().to_string());
  // The capture's cameras: their centroid, and how far from it they stand.
  double centroid[3] = {0, 0, 0}, spread = 0;
  for (const runtime::Camera& c : *capture) {
    const auto p = runtime::camera_centre(c);
    for (int a = 0; a < 3; ++a) centroid[a] += p[a] / double(capture->size());
  }
  const auto distance = [&](const runtime::Camera& c) {
    const auto p = runtime::camera_centre(c);
    return std::hypot(p[0] - centroid[0], p[1] - centroid[1], p[2] - centroid[2]);
  };
  for (const runtime::Camera& c : *capture) spread += distance(c) / double(capture->size());
  // Fraction of the opacity-weighted means that a view sees in its image, in front of it.
  const format::GaussianCloud* cloud = scene->cloud();
  const auto seen = [&](const runtime::Camera& c) {
    double in = 0, all = 0;
    for (size_t i = 0; i < cloud->size(); ++i) {
      const auto v = in_camera(c, &cloud->means[3 * i]);
      const double x = c.fx * v[0] / v[2] + c.cx, y = c.fy * v[1] / v[2] + c.cy;
      all += cloud->opacities[i];
      if (v[2] > c.near_plane && x >= 0 && x < c.width && y >= 0 && y < c.height) in += cloud->opacities[i];
    }
    return in / all;
  };
  // The frame of the Gaussians loaded, a 360 capture's: the same as the guessed views' of the cloud.
  const api::ContentFrame& frame = scene->info().content;
  CHECK(frame.surrounds);
  CHECK(frame.weighed == std::min<uint64_t>(cloud->size(), api::kContentFrameSamples));
  const api::ContentFrame of_cloud = api::content_frame(*cloud);
  CHECK(frame.frame_radius == of_cloud.frame_radius);
  for (int a = 0; a < 3; ++a) CHECK(frame.target[a] == of_cloud.target[a]);
  api::CameraChoice choice;
  choice.orbit = 8;
  auto orbit = api::make_cameras(choice, frame);
  REQUIRE_MESSAGE(orbit.ok(), orbit.status().to_string());
  auto sphere = api::make_cameras(choice, api::ContentFrame::of_sphere(scene->info().bounds));
  REQUIRE(sphere.ok());
  double capture_seen = 0;
  for (const runtime::Camera& c : *capture) capture_seen += seen(c) / double(capture->size());
  CHECK(spread == doctest::Approx(3.78).epsilon(0.01));
  CHECK(capture_seen == doctest::Approx(0.45).epsilon(0.05));
  for (size_t v = 0; v < 8; ++v) {
    CAPTURE(v);
    // Among the capture's cameras (4.4 units from their centroid), seeing as much of the content as they do
    // (40-58 %); the bounding sphere's orbit stands 150-175 units out, where every Gaussian is a speck in view.
    CHECK(distance((*orbit)[v]) < 1.25 * spread);
    CHECK(seen((*orbit)[v]) > 0.5 * capture_seen);
    CHECK(seen((*orbit)[v]) < 0.8);
    CHECK(distance((*sphere)[v]) > 30 * spread);
    CHECK(seen((*sphere)[v]) > 0.99);
  }
}
