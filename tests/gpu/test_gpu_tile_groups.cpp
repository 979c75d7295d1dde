// Bounded pair memory on the GPU: a frame whose pairs exceed what a pass holds (a scratch budget, or the sort's
// 32-bit counts) is rendered in groups of tile rows, and must be the one-pass frame bit for bit; the sort's
// counters zeroed ahead for more pairs than one onesweep portion (a scene of over 134M Gaussians asks for that).
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/runtime/device_buffer.h"
#include "rgs/runtime/frame_plan.h"

namespace rgs::test {
namespace {

using runtime::Camera;
using runtime::GpuRenderOptions;

struct Config {
  std::string name;
  GpuRenderOptions options;
};

/// The presets, the fused kernel's separate-stage twin and the paper's AccuTile (not limited to the 3DGS
/// rectangle, so its walks reach tiles that rectangle does not).
std::vector<Config> configs(bool compact) {
  std::vector<Config> c;
  c.push_back({"fastest", preset_options(runtime::Preset::kFastest)});
  c.push_back({"faithful", preset_options(runtime::Preset::kFaithful)});
  c.push_back({"paper", preset_options(runtime::Preset::kPaper)});
  GpuRenderOptions separate = preset_techniques_options(runtime::Preset::kFastest, compact);
  separate.lab_techniques->roofgs.fused_preprocess = false;
  if (use_lab_stages(&separate)) c.push_back({"fastest, separate stages", separate});
  return c;
}

/// Renders into NaN-poisoned planes with depth; the status when the renderer refuses.
Result<GpuFrame> try_render(runtime::GpuRenderer& renderer, const runtime::GpuScene& scene, const Camera& camera,
                            const GpuRenderOptions& options) {
  runtime::DeviceImage image;
  REQUIRE(image.resize(camera.width, camera.height, true).ok());
  const size_t pixels = size_t(camera.width) * camera.height;
  REQUIRE(cudaMemset(image.rgba(), 0xff, pixels * 4 * sizeof(float)) == cudaSuccess);
  REQUIRE(cudaMemset(image.depth(), 0xff, pixels * sizeof(float)) == cudaSuccess);
  RGS_ASSIGN_OR_RETURN(const runtime::GpuRenderStats stats, renderer.render(scene, camera, options, &image));
  RGS_ASSIGN_OR_RETURN(runtime::HostImage host, runtime::download(image));
  return GpuFrame{std::move(host.rgba), std::move(host.depth), stats};
}

/// For budgets from the one-pass frame's scratch down in 1/64 steps until the renderer refuses one: every frame
/// is the one-pass frame bit for bit (colour, alpha and depth) with the scratch within the budget, and the
/// smaller budgets take three groups or more.
void check_budgets(const runtime::GpuScene& scene, const Camera& camera, const Config& config) {
  CAPTURE(config.name);
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  const GpuFrame whole = render_gpu(*renderer, scene, camera, config.options, true);
  REQUIRE(whole.stats.tile_groups == 1);
  REQUIRE(whole.stats.pairs > 0);
  const uint64_t one_pass = renderer->scratch_bytes();
  uint32_t most_groups = 1;
  int refused = 0;
  for (int step = 1; step < 64 && refused == 0; ++step) {
    GpuRenderOptions options = config.options;
    options.scratch_budget = one_pass - one_pass * uint64_t(step) / 64;
    CAPTURE(options.scratch_budget);
    const Result<GpuFrame> frame = try_render(*renderer, scene, camera, options);
    if (!frame.ok()) {
      CHECK_MESSAGE(frame.status().code() == StatusCode::kLimitExceeded, frame.status().to_string());
      refused = step;
      continue;
    }
    CHECK(frame->stats.pairs == whole.stats.pairs);
    CHECK(renderer->scratch_bytes() <= options.scratch_budget);
    CHECK(same_bits(frame->rgba, whole.rgba));
    CHECK(same_bits(frame->depth, whole.depth));
    most_groups = std::max(most_groups, frame->stats.tile_groups);
  }
  MESSAGE(config.name << ": " << whole.stats.pairs << " pairs, one pass in " << one_pass << " scratch bytes; up to "
                      << most_groups << " tile groups; budget refused at step " << refused << "/64");
  CHECK(refused > 0);
  CHECK(most_groups >= 3);
  // The renderer is still usable without a budget, and the frame is the same.
  const GpuFrame again = render_gpu(*renderer, scene, camera, config.options, true);
  CHECK(again.stats.tile_groups == 1);
  CHECK(same_bits(again.rgba, whole.rgba));
}

TEST_CASE("tile groups under a scratch budget render the one-pass image bit for bit (guitar, every preset)") {
  if (!have_gpu()) return;
  const GpuScenePair& guitar_pair = guitar();
  REQUIRE(guitar_pair.available);
  auto cameras = runtime::orbit_cameras(guitar_pair.bounds, 2, 1920, 1080);
  REQUIRE(cameras.ok());
  for (const Config& config : configs(false)) check_budgets(*guitar_pair.gpu, cameras->front(), config);
}

TEST_CASE("tile groups under a scratch budget render the one-pass image bit for bit (flowers .rgs, 4K)") {
  if (!have_gpu()) return;
  const GpuScenePair& flowers = flowers_rgs();
  if (!flowers.available) {
    MESSAGE("skipped: flowers is not in RGS_DATA_DIR");
    return;
  }
  const std::string cameras = shared_scene("mipnerf360_flowers_cameras.json");
  REQUIRE_FALSE(cameras.empty());
  const Camera camera = flowers_cameras(cameras, 1, 3840, 2160).front();
  for (const Config& config : configs(true)) {
    if (config.name == "faithful") continue;  // reads FP32 attributes, which the .rgs upload leaves out
    check_budgets(*flowers.gpu, camera, config);
  }
}

/// `count` Gaussians covering every tile of an identity camera, one behind the other (z = 2 + i/1000), nearly
/// opaque: every pixel stops within its first few. Colours differ from one to the next.
format::GaussianCloud opaque_layers(int count) {
  format::GaussianCloud cloud;
  for (int i = 0; i < count; ++i) {
    const float r = float((i * 37) % 17) / 8.f - 1.f, g = float((i * 11) % 13) / 6.f - 1.f;
    add_gaussian(&cloud, 0.f, 0.f, 2.f + float(i) / 1000.f, 50.f, 0.999f, r, g, -r);
  }
  return cloud;
}

TEST_CASE("a frame of more than 2^31 pairs renders as the frame of its front Gaussians and as its quarters alone") {
  // 17,000 Gaussians × 480 × 270 tiles = 2,203,200,000 pairs: more than a pass sorts (runtime::kMaxPassPairs).
  // Every pixel stops within its front Gaussians, so the frame must equal, bit for bit, the frame of the
  // front 64 alone (8.3M pairs, one pass): the same pairs of each tile in the same order up to the stop,
  // blended by the same kernel variant (both frames' pairs are all from large Gaussians).
  if (!have_gpu()) return;
  size_t free_bytes = 0, total_bytes = 0;
  REQUIRE(cudaMemGetInfo(&free_bytes, &total_bytes) == cudaSuccess);
  if (free_bytes < (uint64_t{40} << 30)) {
    MESSAGE("skipped: needs 40 GiB of free GPU memory, the device has " << free_bytes);
    return;
  }
  const format::GaussianCloud all = opaque_layers(17000);
  const format::GaussianCloud front = opaque_layers(64);
  auto all_scene = runtime::GpuScene::from_cloud(all, converter::compute_bounds(all));
  auto front_scene = runtime::GpuScene::from_cloud(front, converter::compute_bounds(front));
  REQUIRE(all_scene.ok());
  REQUIRE(front_scene.ok());
  const Camera camera = identity_camera(7680, 4320, 4000.f);
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  struct Case {
    std::string name;
    GpuRenderOptions options;
  };
  std::vector<Case> cases;
  for (const Config& c : configs(false)) {
    if (c.name == "fastest" || c.name == "faithful") cases.push_back({c.name + ", 8 GiB budget", c.options});
  }
  for (Case& c : cases) c.options.scratch_budget = uint64_t{8} << 30;
  cases.push_back({"fastest, no budget (the sort's limit alone)", configs(false).front().options});
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const GpuFrame reference = render_gpu(*renderer, *front_scene, camera, c.options, true);
    CHECK(reference.stats.tile_groups == 1);
    const GpuFrame frame = render_gpu(*renderer, *all_scene, camera, c.options, true);
    MESSAGE(c.name << ": " << frame.stats.pairs << " pairs in " << frame.stats.tile_groups << " tile groups of at most "
                   << frame.stats.pass_pair_limit << " pairs, " << renderer->scratch_bytes() << " scratch bytes");
    CHECK(frame.stats.pairs == uint64_t(17000) * 480 * 270);
    CHECK(frame.stats.tile_groups >= 2);
    if (c.options.scratch_budget != 0) CHECK(renderer->scratch_bytes() <= c.options.scratch_budget);
    CHECK(same_bits(frame.rgba, reference.rgba));
    CHECK(same_bits(frame.depth, reference.depth));
    if (c.options.scratch_budget == 0) continue;
    // Each quarter of the frame equals the quarter rendered alone, in one pass (550,800,000 pairs): a camera with
    // the same focal length and the principal point moved by the quarter's corner (tile-aligned, and exact in
    // float here, so every pixel sees the same numbers).
    GpuRenderOptions whole = c.options;
    whole.scratch_budget = 0;
    auto unbounded = runtime::GpuRenderer::create();  // its buffers grow beyond the budget of the next case
    REQUIRE(unbounded.ok());
    for (uint32_t q = 0; q < 4; ++q) {
      CAPTURE(q);
      const uint32_t x0 = (q % 2) * camera.width / 2, y0 = (q / 2) * camera.height / 2;
      Camera quarter = camera;
      quarter.width = camera.width / 2;
      quarter.height = camera.height / 2;
      quarter.cx = camera.cx - float(x0);
      quarter.cy = camera.cy - float(y0);
      const GpuFrame alone = render_gpu(*unbounded, *all_scene, quarter, whole, true);
      CHECK(alone.stats.tile_groups == 1);
      CHECK(alone.stats.pairs == uint64_t(17000) * 240 * 135);
      std::vector<float> rgba, depth;
      for (uint32_t y = 0; y < quarter.height; ++y) {
        const size_t row = size_t(y0 + y) * camera.width + x0;
        rgba.insert(rgba.end(), frame.rgba.begin() + ptrdiff_t(row * 4),
                    frame.rgba.begin() + ptrdiff_t((row + quarter.width) * 4));
        depth.insert(depth.end(), frame.depth.begin() + ptrdiff_t(row), frame.depth.begin() + ptrdiff_t(row + quarter.width));
      }
      CHECK(same_bits(alone.rgba, rgba));
      CHECK(same_bits(alone.depth, depth));
    }
  }
}

TEST_CASE("32-bit pair sort: counters zeroed ahead for more pairs than one onesweep portion") {
  // The fused kernel clears the counters for its pair capacity, 2 pairs a Gaussian at least: over 2^28 pairs
  // for scenes of more than 134M Gaussians, beyond the single portion the tuned sort runs. Sorts of fewer
  // pairs on those counters, and of more (CUB's own portions), must both succeed and be stable.
  if (!have_gpu()) return;
  const uint64_t capacity = (uint64_t{1} << 28) + (uint64_t{1} << 22);
  SortBuffers buffers(capacity);
  auto& [keys, values, temp, temp_bytes, key_buffers, value_buffers] = buffers;
  int sorted = 0;
  for (const uint64_t count : {uint64_t{3000000}, capacity}) {
    CAPTURE(count);
    std::vector<uint32_t> key(count), value(count);
    uint32_t hash = 2463534242u;
    for (uint64_t i = 0; i < count; ++i) {
      hash ^= hash << 13;
      hash ^= hash >> 17;
      hash ^= hash << 5;
      key[i] = (hash % 1000u) * 4294967u;
      value[i] = uint32_t(i);
    }
    REQUIRE(cudaMemcpy(keys[0].data(), key.data(), count * 4, cudaMemcpyHostToDevice) == cudaSuccess);
    REQUIRE(cudaMemcpy(values[0].data(), value.data(), count * 4, cudaMemcpyHostToDevice) == cudaSuccess);
    REQUIRE(kernels::clear_sort_counters(temp.data(), temp_bytes, capacity, 0, 32, nullptr) == cudaSuccess);
    size_t bytes = temp_bytes;
    REQUIRE(kernels::sort_pairs_ping_pong(temp.data(), &bytes, key_buffers, value_buffers, count, capacity, 0, 32,
                                          true, &sorted, nullptr) == cudaSuccess);
    REQUIRE(cudaDeviceSynchronize() == cudaSuccess);
    std::vector<uint32_t> got_keys(count), got_values(count);
    REQUIRE(cudaMemcpy(got_keys.data(), key_buffers[sorted], count * 4, cudaMemcpyDeviceToHost) == cudaSuccess);
    REQUIRE(cudaMemcpy(got_values.data(), value_buffers[sorted], count * 4, cudaMemcpyDeviceToHost) == cudaSuccess);
    // Sorted, stable (values are the input positions, so equal keys keep increasing values), and a permutation:
    // each output pair is an input pair, and no position appears twice.
    bool in_order = true, pairs_kept = true;
    std::vector<bool> seen(count, false);
    for (uint64_t i = 0; i < count; ++i) {
      const uint32_t v = got_values[i];
      pairs_kept = pairs_kept && v < count && !seen[v] && key[v] == got_keys[i];
      if (v < count) seen[v] = true;
      if (i > 0) {
        in_order = in_order && (got_keys[i - 1] < got_keys[i] ||
                                (got_keys[i - 1] == got_keys[i] && got_values[i - 1] < got_values[i]));
      }
    }
    CHECK(in_order);
    CHECK(pairs_kept);
  }
}

}  // namespace
}  // namespace rgs::test
