// The GPU side of the audit against the CPU reference: the GPU metrics on the same real renders (per-window
// SSIM bits equal, so only the order of the final sums differs), a whole audit of flowers on both
// backends (the GPU renders differ from the CPU reference's through the device's expf/logf only), and rate
// control on the GPU, which compares its renders on the device. Each case prints "skipped: no CUDA device"
// without a GPU, and "skipped: ..." without the real scenes.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>

#include "audit_test_util.h"
#include "rgs/api/convert.h"
#include "rgs/api/scene.h"
#include "rgs/audit/audit.h"
#include "rgs/runtime/image_metrics.h"
#include "rgs/config.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cpu_renderer.h"
#include "temp_dir.h"

#if RGS_HAS_CUDA
#include <cuda_runtime_api.h>

#include "rgs/runtime/gpu_image_metrics.h"
#include "rgs/runtime/device_buffer.h"
#endif

namespace {

using namespace rgs;

/// Tolerance of the CPU/GPU audit agreement: per-view PSNR within this many dB. The two backends' renders
/// differ by the device's expf against the host's (a few ulps per α), on both the source and the candidate.
constexpr double kAgreementPsnrDb = 0.05;
/// Per-view SSIM agreement of the two backends.
constexpr double kAgreementSsim = 1e-5;

bool have_cuda() {
  std::string why;
  if (api::cuda_available(&why)) return true;
  MESSAGE("skipped: no CUDA device (" << why << ")");
  return false;
}

struct Flowers {
  bool available = false;
  audit::AuditScene source;
  std::vector<audit::AuditScene> candidates;
  std::string cameras_path;
};

const Flowers& flowers() {
  static const Flowers f = [] {
    Flowers out;
    const std::string ply = test::shared_scene("mipnerf360_flowers_c3dgs.ply");
    const std::string cams = test::shared_scene("mipnerf360_flowers_cameras.json");
    if (ply.empty() || cams.empty()) return out;
    out.source = test::audit_scene(ply);
    out.candidates.push_back(test::converted_scene(out.source, "rgs_test_gpu_audit_flowers.rgs"));
    out.cameras_path = cams;
    out.available = true;
    return out;
  }();
  return f;
}

std::vector<runtime::Camera> flowers_cameras(uint32_t every, uint32_t width) {
  runtime::InriaCameraOptions options;
  options.every_kth = every;
  options.width = width;
  auto cams = runtime::load_inria_cameras(flowers().cameras_path, options);
  REQUIRE_MESSAGE(cams.ok(), cams.status().to_string());
  return std::move(cams).value();
}

TEST_CASE("GPU metrics equal the CPU metrics on real renders, foreground PSNR included") {
  if (!have_cuda()) return;
  if (!flowers().available) return;
#if RGS_HAS_CUDA
  const Flowers& f = flowers();
  // Odd sizes: partial SSIM tiles and pixel blocks at the right and bottom edges.
  for (uint32_t width : {1256u, 333u}) {
    const auto cams = flowers_cameras(40, width);
    for (const runtime::Camera& cam : cams) {
      CAPTURE(cam.name);
      CAPTURE(width);
      auto a = runtime::render_cpu(f.source.cloud, cam);
      auto b = runtime::render_cpu(f.candidates[0].cloud, cam);
      REQUIRE(a.ok());
      REQUIRE(b.ok());
      std::vector<float> cpu_diff;
      auto cpu = runtime::compare_images({a->rgb.data(), cam.width, cam.height, 3},
                                       {b->rgb.data(), cam.width, cam.height, 3}, &cpu_diff);
      REQUIRE(cpu.ok());
      const size_t pixels = size_t(cam.width) * cam.height;
      runtime::DeviceBuffer<float> da, db, ddiff;
      REQUIRE(da.allocate_exactly(pixels * 3, "a").ok());
      REQUIRE(db.allocate_exactly(pixels * 3, "b").ok());
      REQUIRE(ddiff.allocate_exactly(pixels, "diff").ok());
      REQUIRE(cudaMemcpy(da.data(), a->rgb.data(), pixels * 3 * 4, cudaMemcpyHostToDevice) == cudaSuccess);
      REQUIRE(cudaMemcpy(db.data(), b->rgb.data(), pixels * 3 * 4, cudaMemcpyHostToDevice) == cudaSuccess);
      REQUIRE(cudaMemset(ddiff.data(), 0xff, pixels * 4) == cudaSuccess);  // NaN poison
      runtime::GpuImageComparer comparer;
      auto gpu = comparer.compare(da.data(), db.data(), cam.width, cam.height, 3, ddiff.data());
      REQUIRE_MESSAGE(gpu.ok(), gpu.status().to_string());
      CHECK(std::fabs(gpu->psnr_db - cpu->psnr_db) <= 1e-9);
      CHECK(std::fabs(gpu->ssim - cpu->ssim) <= 1e-12);
      CHECK(gpu->max_abs_diff == cpu->max_abs_diff);
      CHECK(gpu->foreground.pixels == cpu->foreground.pixels);
      CHECK(gpu->foreground.pixels > 0);
      CHECK(std::fabs(gpu->foreground.psnr_db - cpu->foreground.psnr_db) <= 1e-9);
      std::vector<float> gpu_diff(pixels);
      REQUIRE(cudaMemcpy(gpu_diff.data(), ddiff.data(), pixels * 4, cudaMemcpyDeviceToHost) == cudaSuccess);
      CHECK(std::memcmp(gpu_diff.data(), cpu_diff.data(), pixels * 4) == 0);
      // Deterministic: a second run gives the same bits.
      auto again = comparer.compare(da.data(), db.data(), cam.width, cam.height, 3);
      REQUIRE(again.ok());
      CHECK(again->psnr_db == gpu->psnr_db);
      CHECK(again->ssim == gpu->ssim);
      MESSAGE(cam.name << " " << cam.width << "x" << cam.height << ": CPU PSNR " << cpu->psnr_db << " SSIM "
                       << cpu->ssim << ", GPU - CPU: " << gpu->psnr_db - cpu->psnr_db << " dB, "
                       << gpu->ssim - cpu->ssim);
    }
  }
#endif
}

TEST_CASE("CPU and CUDA audits of flowers agree") {
  if (!have_cuda()) return;
  if (!flowers().available) return;
  const Flowers& f = flowers();
  const auto cams = flowers_cameras(20, 628);  // 9 views at the scene's training resolution
  audit::AuditOptions options;
  options.worst_views = 1;
  options.backend = audit::Backend::kCpu;
  auto cpu = audit::run_audit(f.source, f.candidates, cams, options);
  REQUIRE_MESSAGE(cpu.ok(), cpu.status().to_string());
  options.backend = audit::Backend::kCuda;
  auto gpu = audit::run_audit(f.source, f.candidates, cams, options);
  REQUIRE_MESSAGE(gpu.ok(), gpu.status().to_string());
  CHECK(gpu->backend == audit::Backend::kCuda);
  double worst_psnr = 0, worst_ssim = 0;
  for (size_t v = 0; v < cams.size(); ++v) {
    const audit::ViewMetrics& c = cpu->candidates[0].views[v];
    const audit::ViewMetrics& g = gpu->candidates[0].views[v];
    CAPTURE(cams[v].name);
    CHECK(std::isfinite(g.psnr_db));
    CHECK(std::fabs(g.psnr_db - c.psnr_db) <= kAgreementPsnrDb);
    CHECK(std::fabs(g.ssim - c.ssim) <= kAgreementSsim);
    worst_psnr = std::max(worst_psnr, std::fabs(g.psnr_db - c.psnr_db));
    worst_ssim = std::max(worst_ssim, std::fabs(g.ssim - c.ssim));
  }
  MESSAGE("flowers, " << cams.size() << " views at 628 px on " << gpu->device << ": largest |PSNR_gpu - PSNR_cpu| "
                      << worst_psnr << " dB (tolerance " << kAgreementPsnrDb << "), |SSIM| " << worst_ssim
                      << "; CPU " << cpu->render_seconds << " s, GPU " << gpu->render_seconds << " s");
}

TEST_CASE("CUDA rate control meets a 40 dB target on guitar, measured by a CUDA audit of the written file") {
  if (!have_cuda()) return;
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  const std::string out = dir.file("guitar_40db_cuda.rgs");
  api::ConvertOptions fit;
  fit.target.psnr_db = 40;
  fit.target.views = test::small_orbit();
  fit.target.device = api::Device::kCuda;
  auto fitted = api::convert(source, out, fit);
  REQUIRE_MESSAGE(fitted.ok(), fitted.status().to_string());
  REQUIRE(fitted->rate_control.has_value());
  CHECK(fitted->rate_control->device_name.find("CUDA") != std::string::npos);
  const double psnr = test::measured_psnr(source, out, test::small_orbit(), audit::Backend::kCuda);
  CHECK(psnr >= 40);
  CHECK(psnr <= 40.5);
  CHECK(fitted->rate_control->psnr_mean_db == doctest::Approx(psnr).epsilon(1e-9));
  MESSAGE("guitar at 40 dB on the GPU: " << fitted->output_bytes << " bytes, " << psnr << " dB");
}

TEST_CASE("CUDA rate control takes views smaller than SSIM's window, as the CPU does") {
  if (!have_cuda()) return;
  test::TempDir dir;
  const std::string source = test::repo_path("samples/guitar.ply");
  api::ConvertOptions fit;
  fit.target.psnr_db = 30;
  fit.target.views.orbit = 2;
  fit.target.views.orbit_width = 16;  // 16x9: below the 11x11 that SSIM, and so the GPU comparer, needs
  fit.target.views.orbit_height = 9;
  double psnr[2] = {};
  for (const api::Device device : {api::Device::kCpu, api::Device::kCuda}) {
    fit.target.device = device;
    auto fitted = api::convert(source, dir.file(device == api::Device::kCuda ? "cuda.rgs" : "cpu.rgs"), fit);
    REQUIRE_MESSAGE(fitted.ok(), fitted.status().to_string());
    REQUIRE(fitted->rate_control.has_value());
    psnr[device == api::Device::kCuda] = fitted->rate_control->psnr_mean_db;
  }
  CHECK(psnr[0] >= 30);
  CHECK(psnr[1] >= 30);
  MESSAGE("guitar at 30 dB on 16x9 views: " << psnr[0] << " dB (CPU), " << psnr[1] << " dB (CUDA)");
}

TEST_CASE("the CUDA backend without a device or CUDA build is kUnsupportedFeature") {
  std::string why;
  if (api::cuda_available(&why)) {
    MESSAGE("skipped: a CUDA device is present");
    return;
  }
  std::vector<audit::AuditScene> one;
  one.push_back(test::audit_scene(test::repo_path("samples/guitar.ply")));
  auto cams = runtime::orbit_cameras(one[0].bounds, 1, 32, 32);
  REQUIRE(cams.ok());
  audit::AuditOptions options;
  options.backend = audit::Backend::kCuda;
  CHECK(audit::run_audit(one[0], one, *cams, options).status().code() == StatusCode::kUnsupportedFeature);
}

}  // namespace
