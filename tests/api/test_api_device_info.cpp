// The front door's monitoring additions: query_device (device name, memory in use) and per-stage GPU frame
// times (RenderSettings::time_stages → FrameStats::times), on the CPU and, when there is one, on the GPU.
#include <algorithm>
#include <thread>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/api/camera.h"
#include "rgs/api/scene.h"
#include "rgs/api/renderer.h"
#include "rgs/config.h"
#include "test_data.h"

namespace {

using namespace rgs;

api::Camera orbit_camera(const api::Scene& scene, uint32_t w, uint32_t h) {
  auto cams = runtime::orbit_cameras(scene.info().bounds, 1, w, h);
  REQUIRE(cams.ok());
  return (*cams)[0];
}

}  // namespace

TEST_CASE("query_device: the CPU reports its hardware threads and no device memory") {
  auto info = api::query_device(api::Device::kCpu);
  REQUIRE(info.ok());
  CHECK(info->device == api::Device::kCpu);
  CHECK(info->host_threads == std::max(1u, std::thread::hardware_concurrency()));
  CHECK(info->name == "CPU, " + std::to_string(info->host_threads) + " hardware thread" +
                          (info->host_threads == 1 ? "" : "s"));
  CHECK(info->memory_total_bytes == 0);
  CHECK(info->memory_free_bytes == 0);
}

TEST_CASE("time_stages: CPU frames are not timed, and the image does not depend on the flag") {
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  auto scene = api::load(test::repo_path("samples/guitar.ply"), cpu);
  REQUIRE(scene.ok());
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(renderer.ok());
  const api::Camera camera = orbit_camera(*scene, 96, 54);
  api::RenderSettings timed;
  timed.time_stages = true;
  auto a = renderer->render_image(*scene, camera, {}, api::PixelFormat::kRgba8);
  auto b = renderer->render_image(*scene, camera, timed, api::PixelFormat::kRgba8);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  CHECK_FALSE(b->frame_stats().times.timed);
  CHECK(b->frame_stats().times.total_ms == 0.f);
  CHECK(b->frame_stats().pairs > 0);
  std::vector<uint8_t> pa(size_t(camera.width) * camera.height * 4), pb(pa.size());
  REQUIRE(a->copy_to_host(pa.data(), nullptr).ok());
  REQUIRE(b->copy_to_host(pb.data(), nullptr).ok());
  CHECK(pa == pb);
}

TEST_CASE("GPU: query_device reports the device memory, time_stages fills the stage times") {
#if !RGS_HAS_CUDA
  MESSAGE("skipped: this build has no CUDA support");
  CHECK(api::query_device(api::Device::kCuda).status().code() == StatusCode::kUnsupportedFeature);
#else
  std::string why;
  if (!api::cuda_available(&why)) {
    MESSAGE("skipped: no CUDA device (" << why << ")");
    CHECK(api::query_device(api::Device::kCuda).status().code() == StatusCode::kUnsupportedFeature);
    return;
  }
  auto before = api::query_device(api::Device::kCuda);
  REQUIRE(before.ok());
  CHECK_FALSE(before->name.empty());
  CHECK(before->compute_major >= 7);
  CHECK(before->memory_total_bytes >= (uint64_t{1} << 30));
  CHECK(before->memory_free_bytes <= before->memory_total_bytes);
  CHECK(api::query_device(api::Device::kCuda, 1 << 20).status().code() == StatusCode::kUnsupportedFeature);

  auto scene = api::load(test::repo_path("samples/guitar.ply"));
  REQUIRE(scene.ok());
  auto renderer = api::Renderer::create();
  REQUIRE(renderer.ok());
  const api::Camera camera = orbit_camera(*scene, 640, 360);
  api::RenderSettings timed;
  timed.time_stages = true;
  auto untimed_image = renderer->render_image(*scene, camera, {}, api::PixelFormat::kRgba8);
  REQUIRE(untimed_image.ok());
  CHECK_FALSE(untimed_image->frame_stats().times.timed);
  auto image = renderer->render_image(*scene, camera, timed, api::PixelFormat::kRgba8);
  REQUIRE(image.ok());
  const api::StageTimes& t = image->frame_stats().times;
  CHECK(t.timed);
  CHECK(t.total_ms > 0.f);
  CHECK(t.render_ms > 0.f);
  CHECK(t.preprocess_ms > 0.f);
  CHECK(t.preprocess_ms + t.sort_ms + t.ranges_ms + t.render_ms <= t.total_ms * 1.05f + 0.01f);
  // The image is the same with and without timing.
  std::vector<uint8_t> pa(size_t(camera.width) * camera.height * 4), pb(pa.size());
  REQUIRE(untimed_image->copy_to_host(pa.data(), nullptr).ok());
  REQUIRE(image->copy_to_host(pb.data(), nullptr).ok());
  CHECK(pa == pb);
  // The scene and the renderer's buffers are device memory in use.
  auto after = api::query_device(api::Device::kCuda);
  REQUIRE(after.ok());
  CHECK(after->memory_total_bytes == before->memory_total_bytes);
  CHECK(after->memory_total_bytes - after->memory_free_bytes >= scene->info().memory_bytes);
#endif
}
