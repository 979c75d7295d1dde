// The level-of-detail streamer on the GPU (runtime/lod_streamer.h): a level-of-detail .rgs of the guitar drawn
// at full detail is the ordinary full render bit for bit; under splat and memory budgets every frame keeps its
// budgets, the wanted levels stream in within a few frames, and the same camera path from the same state
// draws the same frames.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "rgs/runtime/lod_streamer.h"

namespace rgs::test {
namespace {

runtime::GpuRenderOptions fastest() { return preset_options(runtime::Preset::kFastest); }

TEST_CASE("LOD streamer at full detail draws the full render bit for bit, two frames after the request") {
  if (!have_gpu()) return;
  const std::vector<uint8_t>& bytes = guitar_lod_bytes();
  auto file = format::RgsFile::from_bytes(bytes.data(), bytes.size());
  REQUIRE(file.ok());
  const format::LodIndex& index = *file->lod();
  REQUIRE(index.chunk_count > 4);
  runtime::GpuSceneOptions compact_only;
  compact_only.fp32_attributes = false;
  auto full = runtime::GpuScene::from_rgs(*file, compact_only);
  REQUIRE(full.ok());
  CHECK(full->size() == index.full_detail_count());

  runtime::LodStreamOptions options;
  options.budget = {0, 0.0f};  // no splat budget, no error allowed: level 0 everywhere
  auto streamer = runtime::LodStreamer::open(*file, options);
  REQUIRE(streamer.ok());
  auto cameras = runtime::orbit_cameras(file->metadata().bounds, 3, 1280, 720);
  REQUIRE(cameras.ok());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  for (const runtime::Camera& camera : *cameras) {
    CAPTURE(camera.name);
    auto first = streamer->prepare(camera);  // requests level 0: read while this frame renders
    REQUIRE(first.ok());
    CHECK(first->chunks_culled == 0);  // the orbit frames the whole scene
    auto second = streamer->prepare(camera);  // uploads it
    REQUIRE(second.ok());
    CHECK(second->ranges_streamed == 0);
    if (first->ranges_streamed > 0) CHECK(second->chunks_not_resident > 0);
    auto third = streamer->prepare(camera);  // draws it
    REQUIRE(third.ok());
    CHECK(third->chunks_not_resident == 0);
    CHECK(third->ranges_streamed == 0);
    CHECK(third->splats == index.full_detail_count());
    const GpuFrame expected = render_gpu(*renderer, *full, camera, fastest(), true);
    const GpuFrame streamed = render_gpu(*renderer, streamer->scene(), camera, fastest(), true);
    CHECK(expected.stats.pairs == streamed.stats.pairs);
    CHECK(same_bits(expected.rgba, streamed.rgba));
    CHECK(same_bits(expected.depth, streamed.depth));
  }
}

TEST_CASE("LOD streamer under splat and memory budgets: budgets kept, levels stream in, frames reproducible") {
  if (!have_gpu()) return;
  const std::vector<uint8_t>& bytes = guitar_lod_bytes();
  auto file = format::RgsFile::from_bytes(bytes.data(), bytes.size());
  REQUIRE(file.ok());
  const format::LodIndex& index = *file->lod();
  const uint64_t n0 = index.full_detail_count();
  runtime::LodStreamOptions options;
  options.budget = {n0 / 2, 1.0f};
  // Room for the frame, the upload buffer and about three quarters of all levels: the path must evict.
  const uint64_t bpg = 12 + 8 + 6 + 2 + 3 + 3;
  options.stream_bytes_per_frame = 4096 * bpg;
  options.memory_budget = (n0 / 2 + 4096) * bpg + file->gaussian_count() * bpg * 3 / 4;
  auto path = runtime::path_cameras(file->metadata().bounds, 24, 960, 540);
  REQUIRE(path.ok());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());

  auto run = [&](std::vector<std::vector<float>>* images, std::vector<runtime::LodFrameStats>* stats) {
    auto streamer = runtime::LodStreamer::open(*file, options);
    REQUIRE(streamer.ok());
    // The budget covers the pool, frame and upload arrays; the run lists and SH padding are a few kB more.
    CHECK(streamer->device_bytes() <= options.memory_budget + 65536);
    for (const runtime::Camera& camera : *path) {
      auto s = streamer->prepare(camera);
      REQUIRE(s.ok());
      CHECK(s->splats <= options.budget.max_splats);
      CHECK(s->bytes_streamed <= options.stream_bytes_per_frame);
      CHECK(s->bytes_resident <= streamer->pool_bytes());
      stats->push_back(*s);
      images->push_back(render_gpu(*renderer, streamer->scene(), camera, fastest(), false).rgba);
    }
    // A still camera: the wanted levels are all resident within a few frames.
    uint32_t behind = 1;
    for (int frame = 0; frame < 16 && behind > 0; ++frame) {
      auto s = streamer->prepare(path->back());
      REQUIRE(s.ok());
      behind = s->chunks_not_resident;
    }
    CHECK(behind == 0);
  };
  std::vector<std::vector<float>> first, second;
  std::vector<runtime::LodFrameStats> first_stats, second_stats;
  run(&first, &first_stats);
  run(&second, &second_stats);
  uint64_t streamed = 0;
  for (size_t i = 0; i < first.size(); ++i) {
    CAPTURE(i);
    CHECK(first_stats[i].splats == second_stats[i].splats);
    CHECK(first_stats[i].bytes_streamed == second_stats[i].bytes_streamed);
    CHECK(same_bits(first[i], second[i]));
    streamed += first_stats[i].bytes_streamed;
  }
  CHECK(streamed > 0);
}

TEST_CASE("LOD streamer refuses a file without levels of detail and a memory budget below its coarsest levels") {
  if (!have_gpu()) return;
  const std::vector<uint8_t>& bytes = guitar_lod_bytes();
  auto file = format::RgsFile::from_bytes(bytes.data(), bytes.size());
  REQUIRE(file.ok());
  runtime::LodStreamOptions options;
  options.memory_budget = 1 << 16;
  auto small = runtime::LodStreamer::open(*file, options);
  REQUIRE_FALSE(small.ok());
  CHECK(small.status().code() == StatusCode::kLimitExceeded);
  auto input = converter::read_scene(repo_path("samples/guitar.ply"));
  REQUIRE(input.ok());
  auto encoded = converter::quantize(input->cloud, converter::QuantizeOptions{});
  REQUIRE(encoded.ok());
  auto plain_bytes = format::serialize_scene(*encoded);
  REQUIRE(plain_bytes.ok());
  auto plain_file = format::RgsFile::from_bytes(plain_bytes->data(), plain_bytes->size());
  REQUIRE(plain_file.ok());
  auto refused = runtime::LodStreamer::open(*plain_file, {});
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgs::test
