// Level-of-detail scenes through the front door on the GPU (api::load with LoadOptions::lod, api::Renderer):
// every frame along a camera path is the frame of runtime::LodStreamer + runtime::GpuRenderer driven directly,
// bit for bit, with the same counts; once the wanted levels are resident a frame agrees with the CPU reference
// of the same selection within the front door's GPU-vs-CPU bound (tests/api/test_api_render.cpp: PSNR > 50 dB);
// a scene shared by renderers on two threads and two streams draws the frames of one; presets reading FP32 are
// refused with the way out.
#include <cuda_runtime_api.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/runtime/lod_streamer.h"
#include "temp_dir.h"

namespace rgs::test {
namespace {

/// guitar_lod_bytes() written to `dir`: the file's path.
std::string write_guitar_lod(const TempDir& dir) {
  const std::vector<uint8_t>& bytes = guitar_lod_bytes();
  const std::string path = dir.file("guitar_lod.rgs");
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  REQUIRE(out.good());
  return path;
}

/// A front-door frame: RGBA32F and depth on the host, and its counts.
struct ApiFrame {
  std::vector<float> rgba, depth;
  api::FrameStats stats;
};

ApiFrame render_api(api::Renderer& renderer, const api::Scene& scene, const api::Camera& camera,
                    api::Preset preset = api::Preset::kFastest, cudaStream_t stream = nullptr, bool settle = false) {
  api::RenderSettings settings;
  settings.preset = preset;
  settings.lod_settle = settle;
  auto image = renderer.render_image(scene, camera, settings, api::PixelFormat::kRgba32f, true, stream);
  REQUIRE_MESSAGE(image.ok(), image.status().to_string());
  ApiFrame f;
  f.rgba.resize(size_t(camera.width) * camera.height * 4);
  f.depth.resize(size_t(camera.width) * camera.height);
  REQUIRE(image->copy_to_host(f.rgba.data(), f.depth.data()).ok());
  f.stats = image->frame_stats();
  return f;
}

api::LoadOptions lod_options(api::Device device, uint64_t splat_budget, float pixel_error, uint64_t memory_budget,
                             uint64_t stream_bytes) {
  api::LoadOptions o;
  o.device = device;
  o.lod.splat_budget = splat_budget;
  o.lod.pixel_error = pixel_error;
  o.lod.memory_budget = memory_budget;
  o.lod.stream_bytes_per_frame = stream_bytes;
  return o;
}

TEST_CASE("API LOD GPU scene: a camera path's frames equal LodStreamer + GpuRenderer driven directly") {
  if (!have_gpu()) return;
  TempDir dir;
  const std::string path = write_guitar_lod(dir);
  auto file = format::RgsFile::open(path);
  REQUIRE(file.ok());
  const uint64_t n0 = file->lod()->full_detail_count();
  // The budgets of test_gpu_lod.cpp's path: half the Gaussians, a pool that must evict, 4096 Gaussians a frame.
  const uint64_t bpg = 12 + 8 + 6 + 2 + 3 + 3;
  runtime::LodStreamOptions direct_options;
  direct_options.budget = {n0 / 2, 1.0f};
  direct_options.stream_bytes_per_frame = 4096 * bpg;
  direct_options.memory_budget = (n0 / 2 + 4096) * bpg + file->gaussian_count() * bpg * 3 / 4;

  auto scene = api::load(path, lod_options(api::Device::kCuda, n0 / 2, 1.0f, direct_options.memory_budget,
                                           direct_options.stream_bytes_per_frame));
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  const api::SceneInfo& info = scene->info();
  CHECK(info.lod.active);
  CHECK(info.lod.chunks == file->lod()->chunk_count);
  CHECK(info.lod.stored_gaussians == file->gaussian_count());
  CHECK(info.gaussians == n0);
  CHECK(info.has_compact);
  CHECK_FALSE(info.has_fp32);
  CHECK(scene->gpu_scene() == nullptr);
  CHECK(info.lod.pool_bytes > 0);
  CHECK(info.memory_bytes >= info.lod.pool_bytes);
  CHECK(info.memory_bytes <= direct_options.memory_budget + 65536);

  auto streamer = runtime::LodStreamer::open(*file, direct_options);
  REQUIRE(streamer.ok());
  CHECK(streamer->pool_bytes() == info.lod.pool_bytes);
  auto gpu_renderer = runtime::GpuRenderer::create();
  REQUIRE(gpu_renderer.ok());
  auto renderer = api::Renderer::create();
  REQUIRE(renderer.ok());
  auto cameras = runtime::path_cameras(file->metadata().bounds, 16, 480, 270);
  REQUIRE(cameras.ok());
  const runtime::GpuRenderOptions fastest = preset_options(runtime::Preset::kFastest);
  uint64_t streamed = 0, behind = 0;
  for (const runtime::Camera& camera : *cameras) {
    CAPTURE(camera.name);
    const ApiFrame door = render_api(*renderer, *scene, camera);
    auto s = streamer->prepare(camera);
    REQUIRE(s.ok());
    const GpuFrame expected = render_gpu(*gpu_renderer, streamer->scene(), camera, fastest, true);
    CHECK(door.stats.lod.splats == s->splats);
    CHECK(door.stats.lod.splats <= n0 / 2);
    CHECK(door.stats.gaussians == s->splats);
    CHECK(door.stats.lod.chunks_drawn == s->chunks_drawn);
    CHECK(door.stats.lod.chunks_culled == s->chunks_culled);
    CHECK(door.stats.lod.chunks_coarsened == s->chunks_coarsened);
    CHECK(door.stats.lod.chunks_not_resident == s->chunks_not_resident);
    CHECK(door.stats.lod.ranges_streamed == s->ranges_streamed);
    CHECK(door.stats.lod.bytes_streamed == s->bytes_streamed);
    CHECK(door.stats.lod.bytes_resident == s->bytes_resident);
    CHECK(door.stats.pairs == expected.stats.pairs);
    CHECK(same_bits(door.rgba, expected.rgba));
    CHECK(same_bits(door.depth, expected.depth));
    streamed += s->bytes_streamed;
    behind += s->chunks_not_resident;
  }
  CHECK(streamed > 0);
  CHECK(behind > 0);  // the path streams: some frames draw coarser stand-ins
}

TEST_CASE("API LOD GPU scene: resident frames agree with the CPU reference of the same selection") {
  if (!have_gpu()) return;
  TempDir dir;
  const std::string path = write_guitar_lod(dir);
  auto file = format::RgsFile::open(path);
  REQUIRE(file.ok());
  const uint64_t n0 = file->lod()->full_detail_count();
  for (const uint64_t budget : {uint64_t{0}, n0 / 3}) {
    CAPTURE(budget);
    const float pixel_error = budget == 0 ? 0.0f : 1.0f;
    const api::LoadOptions gpu_options = lod_options(api::Device::kCuda, budget, pixel_error, 0, 64 << 20);
    auto gpu_scene = api::load(path, gpu_options);
    REQUIRE_MESSAGE(gpu_scene.ok(), gpu_scene.status().to_string());
    auto cpu_scene = api::load(path, lod_options(api::Device::kCpu, budget, pixel_error, 0, 64 << 20));
    REQUIRE(cpu_scene.ok());
    auto renderer = api::Renderer::create();
    REQUIRE(renderer.ok());
    auto cpu_renderer = api::Renderer::create(api::Device::kCpu);
    REQUIRE(cpu_renderer.ok());
    auto cameras = runtime::orbit_cameras(file->metadata().bounds, 3, 320, 180);
    REQUIRE(cameras.ok());
    for (const runtime::Camera& camera : *cameras) {
      for (const api::Preset preset : {api::Preset::kFastest, api::Preset::kPaper}) {
        CAPTURE(camera.name);
        CAPTURE(api::preset_name(preset));
        // A still camera: the wanted levels arrive two frames after they are requested.
        ApiFrame gpu = render_api(*renderer, *gpu_scene, camera, preset);
        for (int frame = 0; frame < 8 && gpu.stats.lod.chunks_not_resident > 0; ++frame) {
          gpu = render_api(*renderer, *gpu_scene, camera, preset);
        }
        REQUIRE(gpu.stats.lod.chunks_not_resident == 0);
        const ApiFrame cpu = render_api(*cpu_renderer, *cpu_scene, camera, preset);
        CHECK(gpu.stats.lod.splats == cpu.stats.lod.splats);
        CHECK(gpu.stats.lod.chunks_drawn == cpu.stats.lod.chunks_drawn);
        CHECK(gpu.stats.lod.chunks_coarsened == cpu.stats.lod.chunks_coarsened);
        if (budget == 0) CHECK(gpu.stats.lod.splats == n0);
        const double psnr = compare_rgb(gpu.rgba, rgb_of(cpu.rgba)).psnr;
        MESSAGE(std::string(api::preset_name(preset)) << ", budget " << budget << ", " << camera.name << ": GPU vs CPU PSNR "
                                         << psnr << " dB");
        CHECK(psnr > 50);
      }
    }
  }
}

TEST_CASE("API LOD GPU scene: a settled frame from a cold pool is the frame its still camera reaches") {
  // RenderSettings::lod_settle (rgs-render's offline images): the first frame of a fresh scene draws what it
  // selects, where a plain first frame draws the coarser levels resident at open and streams the rest.
  if (!have_gpu()) return;
  TempDir dir;
  const std::string path = write_guitar_lod(dir);
  auto file = format::RgsFile::open(path);
  REQUIRE(file.ok());
  const uint64_t n0 = file->lod()->full_detail_count();
  // 4096 Gaussians a frame: a settled frame needs several requests.
  const api::LoadOptions options = lod_options(api::Device::kCuda, n0 / 3, 1.0f, 0, 4096 * (12 + 8 + 6 + 2 + 3 + 3));
  auto renderer = api::Renderer::create();
  REQUIRE(renderer.ok());
  auto cameras = runtime::orbit_cameras(file->metadata().bounds, 3, 320, 180);
  REQUIRE(cameras.ok());
  for (const runtime::Camera& camera : *cameras) {
    CAPTURE(camera.name);
    auto settled_scene = api::load(path, options);
    REQUIRE_MESSAGE(settled_scene.ok(), settled_scene.status().to_string());
    const ApiFrame settled = render_api(*renderer, *settled_scene, camera, api::Preset::kFastest, nullptr, true);
    CHECK(settled.stats.lod.chunks_not_resident == 0);
    CHECK(settled.stats.lod.bytes_streamed > 4096 * (12 + 8 + 6 + 2 + 3 + 3));
    auto still_scene = api::load(path, options);
    REQUIRE(still_scene.ok());
    ApiFrame still = render_api(*renderer, *still_scene, camera);
    CHECK(still.stats.lod.chunks_not_resident > 0);
    for (int frame = 0; frame < 64 && still.stats.lod.chunks_not_resident > 0; ++frame) {
      still = render_api(*renderer, *still_scene, camera);
    }
    REQUIRE(still.stats.lod.chunks_not_resident == 0);
    CHECK(settled.stats.lod.splats == still.stats.lod.splats);
    CHECK(settled.rgba == still.rgba);
  }
}

TEST_CASE("API LOD GPU scene: shared by two renderers on two threads and streams, it draws one scene's frames") {
  if (!have_gpu()) return;
  TempDir dir;
  const std::string path = write_guitar_lod(dir);
  auto file = format::RgsFile::open(path);
  REQUIRE(file.ok());
  const uint64_t n0 = file->lod()->full_detail_count();
  const api::LoadOptions options = lod_options(api::Device::kCuda, n0 / 2, 1.0f, 0, 64 << 20);
  auto cameras = runtime::orbit_cameras(file->metadata().bounds, 2, 320, 180);
  REQUIRE(cameras.ok());
  const runtime::Camera& camera = (*cameras)[1];

  // The reference: one renderer, one still camera, until every wanted level is resident.
  auto alone = api::load(path, options);
  REQUIRE(alone.ok());
  auto renderer = api::Renderer::create();
  REQUIRE(renderer.ok());
  ApiFrame reference = render_api(*renderer, *alone, camera);
  for (int frame = 0; frame < 8 && reference.stats.lod.chunks_not_resident > 0; ++frame) {
    reference = render_api(*renderer, *alone, camera);
  }
  REQUIRE(reference.stats.lod.chunks_not_resident == 0);

  auto shared = api::load(path, options);
  REQUIRE(shared.ok());
  std::vector<ApiFrame> frames[2];
  std::string errors[2];
  auto work = [&](int t) {
    auto r = api::Renderer::create();
    if (!r.ok()) {
      errors[t] = r.status().to_string();
      return;
    }
    cudaStream_t stream = nullptr;
    if (cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking) != cudaSuccess) {
      errors[t] = "cudaStreamCreate";
      return;
    }
    api::RenderSettings settings;
    for (int i = 0; i < 12; ++i) {
      auto image = r->render_image(*shared, camera, settings, api::PixelFormat::kRgba32f, true, stream);
      if (!image.ok()) {
        errors[t] = image.status().to_string();
        break;
      }
      ApiFrame f;
      f.rgba.resize(size_t(camera.width) * camera.height * 4);
      f.depth.resize(size_t(camera.width) * camera.height);
      if (!image->copy_to_host(f.rgba.data(), f.depth.data()).ok()) {
        errors[t] = "copy_to_host";
        break;
      }
      f.stats = image->frame_stats();
      frames[t].push_back(std::move(f));
    }
    cudaStreamDestroy(stream);
  };
  std::thread a(work, 0), b(work, 1);
  a.join();
  b.join();
  size_t resident = 0;
  for (int t = 0; t < 2; ++t) {
    CAPTURE(t);
    CHECK(errors[t].empty());
    CHECK(frames[t].size() == 12);
    for (const ApiFrame& f : frames[t]) {
      if (f.stats.lod.chunks_not_resident != 0) continue;
      ++resident;
      CHECK(f.stats.lod.splats == reference.stats.lod.splats);
      CHECK(same_bits(f.rgba, reference.rgba));
      CHECK(same_bits(f.depth, reference.depth));
    }
  }
  CHECK(resident >= 12);
}

TEST_CASE("API LOD GPU scene: a preset reading FP32 is refused, the full detail loads on request") {
  if (!have_gpu()) return;
  TempDir dir;
  const std::string path = write_guitar_lod(dir);
  api::LoadOptions faithful;
  faithful.presets = {api::Preset::kFastest, api::Preset::kFaithful};
  const Status refused = api::load(path, faithful).status();
  CHECK(refused.code() == StatusCode::kInvalidArgument);
  CHECK(refused.message().find("lod.enabled = false") != std::string::npos);
  faithful.lod.enabled = false;
  auto full = api::load(path, faithful);
  REQUIRE_MESSAGE(full.ok(), full.status().to_string());
  CHECK_FALSE(full->info().lod.active);
  CHECK(full->info().has_fp32);
  CHECK(full->gpu_scene() != nullptr);
  CHECK(full->info().lod.stored_gaussians > full->info().gaussians);

  // A scene loaded for fastest: faithful at render time gets the same way out.
  auto streamed = api::load(path);
  REQUIRE(streamed.ok());
  auto renderer = api::Renderer::create();
  REQUIRE(renderer.ok());
  auto cameras = runtime::orbit_cameras(streamed->info().bounds, 1, 64, 36);
  REQUIRE(cameras.ok());
  api::RenderSettings settings;
  settings.preset = api::Preset::kFaithful;
  const Status at_render = renderer->render_image(*streamed, (*cameras)[0], settings).status();
  CHECK(at_render.code() == StatusCode::kInvalidArgument);
  CHECK(at_render.message().find("lod.enabled = false") != std::string::npos);
  // A memory budget below the coarsest levels: the streamer's error, naming the file.
  api::LoadOptions tiny;
  tiny.lod.memory_budget = 1 << 16;
  const Status small = api::load(path, tiny).status();
  CHECK(small.code() == StatusCode::kLimitExceeded);
  CHECK(small.message().find(path) != std::string::npos);
}

}  // namespace
}  // namespace rgs::test
