// GPU baseline pipeline (issue 4) against the CPU reference renderer on real scenes and edge cases.
//
// Tolerances. The kernels are compiled with --fmad=false, so the per-Gaussian results (depth, pixel mean,
// conic, radius, tile rectangle, SH colour) and hence the 64-bit keys and the sorted pair lists are bit for
// bit the CPU's: pair counts must be equal. Pixels differ only through expf (device, ≤ 2 ulp) vs std::exp
// (host). A last-bit change of α can flip the 1/255 skip (the pixel changes by ≤ α·T·|c| ≤ |c|/255, |c| ≤ ~1.5
// for SH colours: ≤ 0.006) or the T < 1e-4 stop (≤ 1e-4·|c|), and later Gaussians of that pixel then blend
// with a T changed by the same relative amount: max |Δ| ≤ 0.02 per channel. Without such flips the
// difference is a few ulp, so PSNR ≥ 70 dB (a flipped pixel in a few hundred thousand costs far less).
// Depth is a weighted mean Σwz/Σw: a flipped Gaussian of weight ≤ T/255 moves it by ≤ (w/Σw)·|z − z̄|,
// which is large only where Σw is small; 1 % of the depth bounds it (measured on H100: ≤ 0.2 %).
// Outputs are poisoned with NaN before each render, so an unwritten pixel fails every comparison.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"

namespace rgs::test {
namespace {

using runtime::Camera;

void check_against_cpu(const GpuScenePair& scene, const Camera& cam, const std::string& label,
                       double min_psnr = 70.0, double max_diff = 0.02) {
  CAPTURE(label);
  runtime::RenderOptions cpu_options;
  auto cpu = runtime::render_cpu(scene.cloud, cam, cpu_options);
  REQUIRE_MESSAGE(cpu.ok(), cpu.status().to_string());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  const GpuFrame gpu = render_gpu(*renderer, *scene.gpu, cam, runtime::GpuRenderOptions{}, true);
  const Diff rgb = compare_rgb(gpu.rgba, cpu->rgb);
  double alpha_diff = 0, depth_diff = 0;
  size_t equal = 0;
  const size_t pixels = size_t(cam.width) * cam.height;
  for (size_t p = 0; p < pixels; ++p) {
    alpha_diff = std::max(alpha_diff, std::fabs(double(gpu.rgba[p * 4 + 3]) - cpu->alpha[p]));
    const double dz = std::fabs(double(gpu.depth[p]) - cpu->depth[p]);
    depth_diff = std::max(depth_diff, std::isnan(dz) ? 1e30 : dz / std::max(1.0, double(cpu->depth[p])));
    bool same = true;
    for (int c = 0; c < 3; ++c) same = same && gpu.rgba[p * 4 + c] == cpu->rgb[p * 3 + c];
    equal += same ? 1 : 0;
  }
  MESSAGE(label << " " << cam.width << "x" << cam.height << ": PSNR " << rgb.psnr << " dB, max |diff| "
                << rgb.max_abs << ", alpha " << alpha_diff << ", depth (relative) " << depth_diff << ", "
                << 100.0 * double(equal) / double(pixels) << "% pixels identical, pairs " << gpu.stats.pairs);
  CHECK_FALSE(rgb.any_nan);
  CHECK(gpu.stats.pairs == cpu->stats.pairs);
  CHECK(rgb.psnr >= min_psnr);
  CHECK(rgb.max_abs <= max_diff);
  CHECK(alpha_diff <= max_diff);
  CHECK(depth_diff <= 1e-2);
}

TEST_CASE("baseline GPU vs CPU reference: guitar, orbit views, sizes including non-multiples of 16") {
  if (!have_gpu()) return;
  const GpuScenePair& scene = guitar();
  const uint32_t sizes[4][2] = {{17, 9}, {1000, 601}, {1920, 1080}, {628, 414}};
  for (const auto& size : sizes) {
    auto cams = runtime::orbit_cameras(scene.bounds, 2, size[0], size[1]);
    REQUIRE(cams.ok());
    for (const Camera& cam : *cams) check_against_cpu(scene, cam, "guitar " + cam.name);
  }
}

TEST_CASE("baseline GPU vs CPU reference: flowers from its cameras at 628x414 and 1920x1080") {
  if (!have_gpu()) return;
  const GpuScenePair& scene = flowers_fp32();
  if (!scene.available) return;
  for (uint32_t w : {628u, 1920u}) {
    runtime::InriaCameraOptions options;
    options.every_kth = 40;
    options.width = w;
    options.height = w == 628 ? 414 : 1080;
    auto cams = runtime::load_inria_cameras(scene.cameras_path, options);
    REQUIRE(cams.ok());
    for (const Camera& cam : *cams) check_against_cpu(scene, cam, "flowers " + cam.name);
  }
}

TEST_CASE("baseline GPU vs CPU reference: daffodils (542k) at 3840x2160") {
  if (!have_gpu()) return;
  const GpuScenePair& scene = daffodils();
  if (!scene.available) return;
  auto cams = runtime::orbit_cameras(scene.bounds, 4, 3840, 2160);
  REQUIRE(cams.ok());
  check_against_cpu(scene, (*cams)[1], "daffodils " + (*cams)[1].name);
}

TEST_CASE("edge cases: empty scene, everything behind the camera, one Gaussian covering the screen") {
  if (!have_gpu()) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  runtime::GpuRenderOptions options;
  options.background = {0.25f, 0.5f, 0.75f};
  const Camera cam = identity_camera(100, 37, 80.f);

  SUBCASE("empty scene: exactly the background, no pairs") {
    format::GaussianCloud empty;
    auto scene = runtime::GpuScene::from_cloud(empty);
    REQUIRE(scene.ok());
    const GpuFrame f = render_gpu(*renderer, *scene, cam, options, false);
    CHECK(f.stats.pairs == 0);
    CHECK(all_background(f.rgba, options.background));
  }
  SUBCASE("all Gaussians behind the camera: exactly the background, no pairs") {
    format::GaussianCloud cloud;
    for (int i = 0; i < 500; ++i) add_gaussian(&cloud, float(i % 7) - 3.f, float(i % 5) - 2.f, -1.f - float(i), 0.5f, 0.9f, 1.f, 0.f, 0.f);
    add_gaussian(&cloud, 0.f, 0.f, 0.1f, 0.5f, 0.9f, 1.f, 0.f, 0.f);  // in front of the camera but at z ≤ 0.2
    auto scene = runtime::GpuScene::from_cloud(cloud);
    REQUIRE(scene.ok());
    const GpuFrame f = render_gpu(*renderer, *scene, cam, options, false);
    CHECK(f.stats.pairs == 0);
    CHECK(all_background(f.rgba, options.background));
  }
  SUBCASE("one Gaussian covering the whole screen: every tile gets it, pixels as the CPU's") {
    format::GaussianCloud cloud;
    add_gaussian(&cloud, 0.f, 0.f, 2.f, 5.f, 0.8f, 0.5f, -0.2f, 1.f);
    GpuScenePair pair;
    pair.cloud = cloud;
    pair.bounds = converter::compute_bounds(cloud);
    auto scene = runtime::GpuScene::from_cloud(cloud);
    REQUIRE(scene.ok());
    pair.gpu = std::make_unique<runtime::GpuScene>(std::move(scene).value());
    const GpuFrame f = render_gpu(*renderer, *pair.gpu, cam, options, false);
    CHECK(f.stats.pairs == uint64_t(f.stats.tiles_x) * f.stats.tiles_y);
    check_against_cpu(pair, cam, "one large Gaussian", 90.0, 1e-5);
  }
}

TEST_CASE("the renderer reuses and grows its buffers; frames are deterministic") {
  if (!have_gpu()) return;
  const GpuScenePair& scene = guitar();
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  auto small = runtime::orbit_cameras(scene.bounds, 1, 64, 48);
  auto large = runtime::orbit_cameras(scene.bounds, 1, 2000, 1125);
  REQUIRE(small.ok());
  REQUIRE(large.ok());
  const GpuFrame a = render_gpu(*renderer, *scene.gpu, (*small)[0], {}, false);
  const GpuFrame b = render_gpu(*renderer, *scene.gpu, (*large)[0], {}, false);
  const GpuFrame c = render_gpu(*renderer, *scene.gpu, (*small)[0], {}, false);
  const GpuFrame d = render_gpu(*renderer, *scene.gpu, (*large)[0], {}, false);
  CHECK(std::memcmp(a.rgba.data(), c.rgba.data(), a.rgba.size() * sizeof(float)) == 0);
  CHECK(std::memcmp(b.rgba.data(), d.rgba.data(), b.rgba.size() * sizeof(float)) == 0);
  CHECK(b.stats.pairs > a.stats.pairs);
  // A fresh renderer gives the same bits.
  auto fresh = runtime::GpuRenderer::create();
  REQUIRE(fresh.ok());
  const GpuFrame e = render_gpu(*fresh, *scene.gpu, (*large)[0], {}, false);
  CHECK(std::memcmp(b.rgba.data(), e.rgba.data(), b.rgba.size() * sizeof(float)) == 0);
}

TEST_CASE(".rgs upload: device dequantization equals format::dequantize (guitar, zstd and raw sections)") {
  if (!have_gpu()) return;
  const GpuScenePair& scene = guitar();
  for (bool zstd : {false, true}) {
    CAPTURE(zstd);
    CompactScene compact = make_compact(scene.cloud, zstd);
    auto gpu = runtime::GpuScene::from_rgs(*compact.file);
    REQUIRE_MESSAGE(gpu.ok(), gpu.status().to_string());
    CHECK(gpu->has_compact());
    const kernels::Fp32GaussiansView v = gpu->fp32();
    const format::GaussianCloud& host = compact.dequantized;
    CHECK(download_floats(v.means, host.means.size()) == host.means);
    CHECK(download_floats(v.rotations, host.rotations.size()) == host.rotations);
    CHECK(download_floats(v.scales, host.scales.size()) == host.scales);
    CHECK(download_floats(v.opacities, host.opacities.size()) == host.opacities);
    CHECK(download_floats(v.sh, host.sh.size()) == host.sh);
  }
}

}  // namespace
}  // namespace rgs::test
