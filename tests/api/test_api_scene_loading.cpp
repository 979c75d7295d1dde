// The scene loading the tools share (api/src/internal_scene_loading.h): every input format through load_host_scene
// with the caller's read limits; make_cameras' fly-through of a cameras.json.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "rgs/config.h"
#include "rgs/format/reader.h"
#include "rgs/api/scene.h"
#include "internal_scene_loading.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

TEST_CASE("load_host_scene: every input format through converter::read_scene, with the read limits") {
  struct Case {
    std::string path, format_id;
    uint64_t gaussians;
  };
  const std::vector<Case> cases = {
      {test::repo_path("samples/guitar.ply"), "ply", 90854},
      {test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz"), "spz", 256},
      {test::repo_path("tests/data/interop/guitar_256_splat_transform.glb"), "glb", 256},
      {test::repo_path("tests/data/interop/guitar_256_splat_transform.splat"), "splat", 256},
      {test::repo_path("tests/data/sog/guitar_crop.sog"), "sog_bundle", 0},
      {test::repo_path("tests/data/v1.0/small_sh3.rgs"), "rgs", 0},
  };
  for (const Case& c : cases) {
    CAPTURE(c.path);
    auto scene = api::load_host_scene(c.path);
    REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
    CHECK(scene->format_id == c.format_id);
    CHECK(scene->is_rgs == (c.format_id == "rgs"));
    CHECK_FALSE(scene->description.empty());
    if (c.gaussians != 0) CHECK(scene->cloud.size() == c.gaussians);
    CHECK(scene->cloud.size() > 0);
    CHECK(scene->bounds.sphere_radius > 0);
    // The limit is honoured for every format, before the cloud is built.
    converter::SceneReadOptions tight;
    tight.max_gaussians = scene->cloud.size() - 1;
    auto refused = api::load_host_scene(c.path, tight);
    REQUIRE_FALSE(refused.ok());
    CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  }
  auto unsupported = api::load_host_scene(test::repo_path("tests/data/sog/make_sog_reference.py"));
  REQUIRE_FALSE(unsupported.ok());
  CHECK(unsupported.status().code() == StatusCode::kInvalidArgument);
  CHECK(unsupported.status().message().find("unsupported format") != std::string::npos);
}

TEST_CASE("is_rgs_path: the .rgs magic or a name ending in .rgs") {
  CHECK(api::is_rgs_path(test::repo_path("tests/data/v1.0/small_sh3.rgs")));
  CHECK_FALSE(api::is_rgs_path(test::repo_path("samples/guitar.ply")));
  // A missing or unreadable file ending in .rgs (any case) still goes to the .rgs reader for its error.
  CHECK(api::is_rgs_path("/nonexistent/scene.RGS"));
  CHECK(api::is_rgs_path(".rgs"));
  CHECK_FALSE(api::is_rgs_path("/nonexistent/scene.ply"));
  CHECK_FALSE(api::is_rgs_path("rgs"));
}

TEST_CASE("parse_device: cpu, cuda (gpu), and auto following cuda_available") {
  CHECK(api::parse_device("cpu").value() == api::Device::kCpu);
  CHECK(api::parse_device("gpu").value() == api::Device::kCuda);
  std::string why;
  const bool available = api::cuda_available(&why);
  CHECK(api::parse_device("auto").value() == (available ? api::Device::kCuda : api::Device::kCpu));
  CHECK(available == why.empty());
#if !RGS_HAS_CUDA
  CHECK_FALSE(available);
  CHECK(why.find("RGS_WITH_CUDA=OFF") != std::string::npos);
#endif
  CHECK(api::parse_device("tpu").status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("make_cameras: --fly flies through the file's cameras at the requested size") {
  // Four cameras along x (camera-to-world rotations turning about y), the last one at half the size: the keys
  // are brought to the first one's size before flying.
  test::TempDir dir;
  const std::string path = dir.file("cameras.json");
  {
    std::ofstream json(path);
    json << "[";
    for (int i = 0; i < 4; ++i) {
      const double a = 0.2 * i, c = std::cos(a), s = std::sin(a);
      const int w = i == 3 ? 100 : 200, h = i == 3 ? 50 : 100;
      json << (i ? "," : "") << "{\"id\": " << i << ", \"img_name\": \"k" << i << "\", \"width\": " << w
           << ", \"height\": " << h << ", \"position\": [" << 3 * i << ", 0, " << (i % 2) << "], \"rotation\": [["
           << c << ", 0, " << s << "], [0, 1, 0], [" << -s << ", 0, " << c << "]], \"fx\": " << w
           << ", \"fy\": " << w << "}";
    }
    json << "]";
  }
  api::CameraChoice choice;
  choice.cameras_path = path;
  choice.fly = 25;
  choice.width = 100;
  format::SceneBounds bounds;
  auto views = api::make_cameras(choice, bounds);
  REQUIRE_MESSAGE(views.ok(), views.status().to_string());
  REQUIRE(views->size() == 25);
  for (const runtime::Camera& v : *views) {
    CHECK(v.width == 100);
    CHECK(v.height == 50);
    CHECK(v.fx == doctest::Approx(100.0));  // field of view kept: fx = W at either size
    CHECK(runtime::validate_camera(v).ok());
  }
  CHECK((*views)[0].name == "fly_000");
  auto first = runtime::camera_centre(views->front()), last = runtime::camera_centre(views->back());
  CHECK(first[0] == doctest::Approx(0.0).epsilon(1e-5).scale(1));
  CHECK(last[0] == doctest::Approx(9.0).epsilon(1e-5));
  // Native size: the first camera's, the last one resized to it.
  choice.width = 0;
  auto native = api::make_cameras(choice, bounds);
  REQUIRE_MESSAGE(native.ok(), native.status().to_string());
  CHECK(native->back().width == 200);
  CHECK(native->back().height == 100);
  CHECK(native->back().fx == doctest::Approx(200.0));
  CHECK(runtime::camera_centre(native->back())[0] == doctest::Approx(9.0).epsilon(1e-5));
  // --limit counts key cameras: two keys, so the flight ends at the second camera.
  choice.limit = 2;
  auto two = api::make_cameras(choice, bounds);
  REQUIRE_MESSAGE(two.ok(), two.status().to_string());
  CHECK(two->size() == 25);
  CHECK(runtime::camera_centre(two->back())[0] == doctest::Approx(3.0).epsilon(1e-5));
  // Too few keys left, and --fly without a cameras file.
  choice.limit = 1;
  auto one = api::make_cameras(choice, bounds);
  CHECK(one.status().code() == StatusCode::kInvalidArgument);
  CHECK(one.status().message().find("cameras.json") != std::string::npos);
  CHECK(one.status().message().find("at least 2 key cameras, got 1") != std::string::npos);
  api::CameraChoice orbit;
  orbit.path = 8;
  orbit.fly = 8;
  bounds.sphere_radius = 1.f;
  auto refused = api::make_cameras(orbit, bounds);
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
  CHECK(refused.status().message().find("needs --cameras") != std::string::npos);
}

}  // namespace
