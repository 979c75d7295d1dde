// taebak-scale GPU cases: the real 4,249,286-Gaussian scene at 3840x2160 with the fastest preset (RoofGS
// pipeline on the compact attributes, all four techniques, depth order, half-precision blending with α from
// the device's FP32 exp2 rounded to binary16: api::Preset).
// - Sorted pairs of one view equal the CPU reference's TileBins term by term. The whole scene is binned on the
//   CPU, no subset: preprocess is threaded, and the two sorts (4.25M Gaussians by depth, 8.25M pairs by key)
//   took 2.2-3.0 s in all on the 16-core H100 host (the MESSAGE lines give the time).
// - The GPU image equals the CPU reference's RoofGS render, with the tolerances of test_gpu_roofgs.cpp (pair
//   counts equal, max |Δ| ≤ 0.02 per channel, PSNR ≥ 70 dB), on a 512x512 window of each 4K view: a camera with
//   the view's focal lengths and its principal point shifted by the window's corner. The CPU renders a window
//   (~1.1M pairs) in 2.0-3.6 s (the 4K frame has 8.25M pairs over 32 times the pixels). Measured with
//   half-precision blending and colour windows: 108.1-112.9 dB, max |Δ| ≤ 0.00098 (binary16 units of a colour: α
//   differs by a unit where 2^v lies within the device's exp2 error of a rounding boundary,
//   lab/tests/test_gpu_half_alpha.cpp); with FP32 blending 162 dB, ≤ 1.2e-6.
// - Long tiles in chunks (the fastest preset): two 1080p views against whole tiles, and a 256x256 window around
//   the longest tiles against the CPU reference.
// - Quality against the GPU FP32 baseline (preset faithful) of the same .rgs over the 8 views at 4K: mean
//   PSNR ≥ 72 dB, min ≥ 70 dB (measured 76.1 / 75.8 with colour windows, 64.2 / 63.6 without).
// Cameras are built as rgs-bench's --cameras with --resolution 3840x2160 builds them: the file's views at their
// native 1920x1080, then runtime::resize_camera.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/api/preset.h"
#include "rgs/api/camera.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/tile_chunks.h"

namespace rgs::test {
namespace {

using runtime::Camera;
using runtime::GpuRenderOptions;

/// The 8 taebak views at width × height.
std::vector<Camera> taebak_cameras(const GpuScenePair& scene, uint32_t width, uint32_t height) {
  api::CameraChoice choice;
  choice.cameras_path = scene.cameras_path;
  auto native = api::make_cameras(choice, api::ContentFrame::of_sphere(scene.bounds));
  REQUIRE_MESSAGE(native.ok(), native.status().to_string());
  REQUIRE(native->size() == 8);
  std::vector<Camera> cams;
  for (const Camera& c : *native) cams.push_back(runtime::resize_camera(c, width, height));
  return cams;
}

/// The width × height window of `view` whose top-left pixel is (x0, y0): pixel (i, j) of the window sees what
/// pixel (x0 + i, y0 + j) of the view sees (px = fx·x/z + cx − 0.5, runtime/camera.h). The EWA clamp follows
/// the window's own extents, so the window is compared against the CPU rendering the same window, never
/// against a cut of the full frame.
Camera window_of(const Camera& view, uint32_t x0, uint32_t y0, uint32_t width, uint32_t height) {
  Camera c = view;
  c.cx = view.cx - float(x0);
  c.cy = view.cy - float(y0);
  c.width = width;
  c.height = height;
  c.name = view.name + " window (" + std::to_string(x0) + ", " + std::to_string(y0) + ") " + std::to_string(width) +
           "x" + std::to_string(height);
  return c;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Index of the first element where `a` and `b` differ (the shorter size when one is a prefix of the other).
template <typename T>
size_t first_difference(const std::vector<T>& a, const std::vector<T>& b) {
  return size_t(std::mismatch(a.begin(), a.end(), b.begin(), b.end()).first - a.begin());
}

bool any_nan(const std::vector<float>& values) {
  return std::any_of(values.begin(), values.end(), [](float v) { return std::isnan(v); });
}

TEST_CASE("taebak at 4K: sorted pairs of the fastest preset equal the CPU reference's, term by term") {
  // As "sorted pairs equal the CPU reference's, term by term, ..." (test_gpu_roofgs.cpp) on a real
  // multi-million-Gaussian view: the fused and the separate preprocess, warp-balanced emission of the large
  // Gaussians, the 32-bit key sort and the depth-order pass must give the CPU's stable sort exactly.
  if (!have_gpu()) return;
  const GpuScenePair& scene = taebak();
  if (!scene.available) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const Camera cam = taebak_cameras(scene, 3840, 2160)[0];
  CAPTURE(cam.name);
  const runtime::RenderOptions cpu_options = runtime::cpu_render_options(runtime::Preset::kFastest, scene.bounds);
  auto start = std::chrono::steady_clock::now();
  auto setup = runtime::setup_frame(scene.cloud, cam, cpu_options);
  REQUIRE_MESSAGE(setup.ok(), setup.status().to_string());
  runtime::RenderStats cpu_stats;
  const auto projected = runtime::preprocess_cpu(scene.cloud, cam, *setup, cpu_options, &cpu_stats);
  const double preprocess_s = seconds_since(start);
  start = std::chrono::steady_clock::now();
  auto bins = runtime::bin_and_sort_cpu(projected, *setup, cpu_options);
  REQUIRE_MESSAGE(bins.ok(), bins.status().to_string());
  const double bin_s = seconds_since(start);
  uint32_t largest = 0;
  uint64_t large_pairs = 0;  // what the preprocess counts for SubtileCulling::kAuto
  for (const auto& g : projected) {
    largest = std::max(largest, g.tiles_touched);
    if (g.tiles_touched > kernels::kSubtileLargeTiles) large_pairs += g.tiles_touched;
  }
  const double pairs = double(bins->keys.size());
  const bool auto_subtile = double(large_pairs) <= kernels::kSubtileMaxLargePairFraction * pairs;
  MESSAGE("taebak " << cam.name << " at " << cam.width << "x" << cam.height << ", CPU reference over "
                    << scene.cloud.size() << " Gaussians: " << bins->keys.size() << " pairs (" << cpu_stats.visible
                    << " visible Gaussians, largest " << largest << " tiles, " << large_pairs
                    << " pairs from large Gaussians); preprocess " << preprocess_s << " s, bin and sort " << bin_s
                    << " s");
  CHECK(bins->keys.size() > 1000000);  // a dense view, not a corner of the scene
  CHECK(largest > kernels::kSerialTileLimit);  // warps emitted the pairs of the large Gaussians
  for (bool fused : {true, false}) {
    CAPTURE(fused);
    GpuRenderOptions options = preset_techniques_options(runtime::Preset::kFastest, scene.gpu->has_compact());
    options.lab_techniques->roofgs.fused_preprocess = fused;
    if (!fused && !use_lab_stages(&options)) continue;
    const runtime::RoofgsOptions& t = options.lab_techniques->roofgs.techniques;
    REQUIRE(t.key32);  // the preset's techniques are the CPU's
    REQUIRE(t.depth_order);
    REQUIRE(t.folded_coefficients == cpu_options.roofgs.folded_coefficients);
    start = std::chrono::steady_clock::now();
    const GpuFrame frame = render_gpu(*renderer, *scene.gpu, cam, options, false);
    std::vector<uint64_t> keys;
    std::vector<uint32_t> values;
    const Status downloaded = renderer->download_sorted_pairs(&keys, &values);
    REQUIRE_MESSAGE(downloaded.ok(), downloaded.to_string());
    const double gpu_s = seconds_since(start);
    MESSAGE("taebak " << cam.name << std::string(fused ? " fused" : " separate") << ": GPU " << keys.size()
                      << " pairs, frame and download " << gpu_s << " s, sub-tile culling "
                      << std::string(frame.stats.subtile_culling ? "on" : "off"));
    CHECK(frame.stats.pairs == bins->keys.size());
    CHECK(frame.stats.large_pairs == large_pairs);
    CHECK(frame.stats.subtile_culling == (t.folded_coefficients && (!t.snugbox_accutile || auto_subtile)));
    REQUIRE(keys.size() == bins->keys.size());
    const size_t first_key = first_difference(keys, bins->keys);
    const size_t first_value = first_difference(values, bins->values);
    CAPTURE(first_key);  // equal to the pair count when the lists agree
    CAPTURE(first_value);
    CHECK(keys == bins->keys);
    CHECK(values == bins->values);
  }
}

TEST_CASE("taebak at 4K: the fastest preset's image equals the CPU reference's on a 512x512 window of each view") {
  // The tolerances of "GPU RoofGS agrees with the CPU reference's RoofGS mode" (test_gpu_roofgs.cpp, top):
  // before blending the arithmetic is the CPU's bit for bit, so pair counts are equal; a last-bit change of α
  // (device logf and exp2) may flip a 1/255 skip or the T < 1e-4 stop, ≤ 0.02 per channel, PSNR ≥ 70 dB.
  // The window sits in the middle of the view, where the orbit looks, on tile boundaries (x0, y0 multiples of 16)
  // so that its tiles are tiles of the 4K frame.
  if (!have_gpu()) return;
  const GpuScenePair& scene = taebak();
  if (!scene.available) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const runtime::RenderOptions cpu_options = runtime::cpu_render_options(runtime::Preset::kFastest, scene.bounds);
  const GpuRenderOptions gpu_options = preset_options(runtime::Preset::kFastest);
  constexpr uint32_t kSide = 512;
  for (const Camera& view : taebak_cameras(scene, 3840, 2160)) {
    const uint32_t x0 = (view.width - kSide) / 2 / 16 * 16, y0 = (view.height - kSide) / 2 / 16 * 16;
    const Camera cam = window_of(view, x0, y0, kSide, kSide);
    CAPTURE(cam.name);
    const auto start = std::chrono::steady_clock::now();
    auto cpu = runtime::render_cpu(scene.cloud, cam, cpu_options);
    REQUIRE_MESSAGE(cpu.ok(), cpu.status().to_string());
    const double cpu_s = seconds_since(start);
    const GpuFrame gpu = render_gpu(*renderer, *scene.gpu, cam, gpu_options, false);
    const Diff d = compare_rgb(gpu.rgba, cpu->rgb);
    size_t covered = 0;  // pixels the scene covers (alpha ≥ 0.5): the window must not be empty sky
    for (float a : cpu->alpha) covered += a >= 0.5f;
    const double covered_fraction = double(covered) / double(cpu->alpha.size());
    MESSAGE("taebak " << cam.name << ": PSNR " << d.psnr << " dB, max |diff| " << d.max_abs << ", pairs "
                      << gpu.stats.pairs << ", " << covered_fraction * 100 << " % covered; CPU " << cpu_s << " s");
    CHECK_FALSE(d.any_nan);
    CHECK(gpu.stats.pairs == cpu->stats.pairs);
    CHECK(d.max_abs <= 0.02);
    CHECK(d.psnr >= 70.0);
    CHECK(covered_fraction >= 0.5);
  }
}

TEST_CASE("taebak at 1080p: long tiles in chunks agree with the CPU reference and stay near whole tiles") {
  // The fastest preset blends the long tiles in chunks (kernels/shared/tile_chunks.h: of more than
  // max(1024, pairs / 2048) pairs, about 3,200 for these frames). taebak's horizon puts up to ~20,000 pairs in a
  // 1080p tile. (1) Two full views, chunked against whole tiles on the GPU, colour and depth: chunk blocks ran,
  // and the change stays within the bound of kernels/shared/tile_chunks.h (measured max |diff| 0.0047, 85.1 dB;
  // the CPU test "long tiles in chunks" on flowers, with many more chunks: 0.0182, 78.3 dB). (2) A 256x256
  // window of view 0 around its longest tiles (14,116 pairs in tile (65, 26)) against the CPU reference, which
  // chunks the same lists: the tolerances of the 4K window test (measured 107.9 dB, max |diff| 0.00059).
  if (!have_gpu()) return;
  const GpuScenePair& scene = taebak();
  if (!scene.available) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  GpuRenderOptions chunked = preset_options(runtime::Preset::kFastest);
  chunked.time_stages = true;  // reads back the chunk count
  GpuRenderOptions whole = preset_techniques_options(runtime::Preset::kFastest, scene.gpu->has_compact());
  whole.time_stages = true;
  REQUIRE(whole.lab_techniques->roofgs.techniques.tile_chunk_pairs == kernels::kTileChunkPairs);
  whole.lab_techniques->roofgs.techniques.tile_chunk_pairs = 0;
  const std::vector<Camera> cams = taebak_cameras(scene, 1920, 1080);
  for (const Camera& cam : {cams[0], cams[5]}) {
    CAPTURE(cam.name);
    const GpuFrame a = render_gpu(*renderer, *scene.gpu, cam, chunked, true);
    const GpuFrame b = render_gpu(*renderer, *scene.gpu, cam, whole, true);
    const Diff d = compare_rgb(a.rgba, rgb_of(b.rgba));
    double depth_diff = 0;
    for (size_t i = 0; i < a.depth.size(); ++i) {
      depth_diff = std::max(depth_diff, double(std::fabs(a.depth[i] - b.depth[i])));
    }
    MESSAGE("taebak " << cam.name << " at 1920x1080: " << a.stats.tile_chunks << " chunk blocks; chunked vs whole "
                      << "tiles PSNR " << d.psnr << " dB, max |diff| " << d.max_abs << ", depth max |diff| "
                      << depth_diff);
    CHECK(a.stats.tile_chunks_listed);
    CHECK(a.stats.tile_chunks > 0);
    CHECK_FALSE(b.stats.tile_chunks_listed);
    CHECK(a.stats.pairs == b.stats.pairs);
    CHECK_FALSE(d.any_nan);
    CHECK_FALSE(any_nan(a.depth));
    CHECK(d.max_abs <= 0.02);
    CHECK(d.psnr >= 65.0);
  }
  const Camera window = window_of(cams[0], 960, 320, 256, 256);
  CAPTURE(window.name);
  const auto start = std::chrono::steady_clock::now();
  auto cpu = runtime::render_cpu(scene.cloud, window, runtime::cpu_render_options(runtime::Preset::kFastest, scene.bounds));
  REQUIRE_MESSAGE(cpu.ok(), cpu.status().to_string());
  const double cpu_s = seconds_since(start);
  const GpuFrame gpu = render_gpu(*renderer, *scene.gpu, window, chunked, false);
  const Diff d = compare_rgb(gpu.rgba, cpu->rgb);
  MESSAGE("taebak " << window.name << ": " << gpu.stats.tile_chunks << " chunk blocks, PSNR " << d.psnr
                    << " dB against the CPU, max |diff| " << d.max_abs << ", pairs " << gpu.stats.pairs << "; CPU "
                    << cpu_s << " s");
  CHECK(gpu.stats.tile_chunks > 0);
  CHECK(gpu.stats.pairs == cpu->stats.pairs);
  CHECK_FALSE(d.any_nan);
  CHECK(d.max_abs <= 0.02);
  CHECK(d.psnr >= 70.0);
}

TEST_CASE("taebak at 4K: fastest preset quality against the GPU FP32 baseline over the 8 views") {
  // The quality target of the dense-scene work: mean PSNR ≥ 50 dB and min ≥ 48 dB against the baseline 3DGS
  // rasterizer (preset faithful: FP32 attributes widened on the GPU from the same .rgs, 64-bit keys, 3σ
  // rectangles, expf), so that only the RoofGS techniques differ.
  if (!have_gpu()) return;
  const GpuScenePair& scene = taebak();
  if (!scene.available) return;
  REQUIRE(scene.gpu->has_fp32());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const GpuRenderOptions baseline = preset_options(runtime::Preset::kFaithful);
  const GpuRenderOptions fastest = preset_options(runtime::Preset::kFastest);
  const std::vector<Camera> cams = taebak_cameras(scene, 3840, 2160);
  double sum = 0, min = std::numeric_limits<double>::infinity();
  for (const Camera& cam : cams) {
    CAPTURE(cam.name);
    const GpuFrame base = render_gpu(*renderer, *scene.gpu, cam, baseline, false);
    const GpuFrame fast = render_gpu(*renderer, *scene.gpu, cam, fastest, false);
    const Diff d = compare_rgb(fast.rgba, rgb_of(base.rgba));
    MESSAGE("taebak " << cam.name << " at " << cam.width << "x" << cam.height << ": fastest vs FP32 baseline PSNR "
                      << d.psnr << " dB, max |diff| " << d.max_abs << "; pairs " << fast.stats.pairs
                      << " (baseline " << base.stats.pairs << ")");
    CHECK_FALSE(any_nan(base.rgba));
    CHECK_FALSE(d.any_nan);
    CHECK(base.stats.pairs > 0);
    sum += d.psnr;
    min = std::min(min, d.psnr);
  }
  const double mean = sum / double(cams.size());
  MESSAGE("taebak at 4K, fastest vs FP32 baseline over " << cams.size() << " views: mean PSNR " << mean
                                                          << " dB, min " << min << " dB");
  CHECK(mean >= 72.0);
  CHECK(min >= 70.0);
}

}  // namespace
}  // namespace rgs::test
