// The front door's device choice (parse_device) and make_cameras' fly-through of a cameras.json.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "rgs/config.h"
#include "rgs/format/reader.h"
#include "rgs/api/camera.h"
#include "rgs/api/scene.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

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
  const api::ContentFrame frame;
  auto views = api::make_cameras(choice, frame);
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
  auto native = api::make_cameras(choice, frame);
  REQUIRE_MESSAGE(native.ok(), native.status().to_string());
  CHECK(native->back().width == 200);
  CHECK(native->back().height == 100);
  CHECK(native->back().fx == doctest::Approx(200.0));
  CHECK(runtime::camera_centre(native->back())[0] == doctest::Approx(9.0).epsilon(1e-5));
  // --limit counts key cameras: two keys, so the flight ends at the second camera.
  choice.limit = 2;
  auto two = api::make_cameras(choice, frame);
  REQUIRE_MESSAGE(two.ok(), two.status().to_string());
  CHECK(two->size() == 25);
  CHECK(runtime::camera_centre(two->back())[0] == doctest::Approx(3.0).epsilon(1e-5));
  // Too few keys left, and --fly without a cameras file.
  choice.limit = 1;
  auto one = api::make_cameras(choice, frame);
  CHECK(one.status().code() == StatusCode::kInvalidArgument);
  CHECK(one.status().message().find("cameras.json") != std::string::npos);
  CHECK(one.status().message().find("at least 2 key cameras, got 1") != std::string::npos);
  api::CameraChoice orbit;
  orbit.path = 8;
  orbit.fly = 8;
  auto refused = api::make_cameras(orbit, frame);
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
  CHECK(refused.status().message().find("needs --cameras") != std::string::npos);
}

}  // namespace
