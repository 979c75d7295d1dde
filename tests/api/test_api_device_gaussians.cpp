// Gaussians from a caller's device memory (api::load_device_gaussians) against the host path of the same arrays
// (converter::scene_from_cloud, then api::load_cloud), and write_planar against the frame it splits; on the GPU
// when there is one (skipped visibly otherwise).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/api/device_gaussians.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#include "rgs/runtime/camera.h"
#include "test_data.h"

#if RGS_HAS_CUDA
#include <cuda_runtime_api.h>

#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_scene.h"
#endif

namespace {

using namespace rgs;

#if RGS_HAS_CUDA
/// Device copies of a cloud's arrays (colours: `colors`, [N, K, 3] or [N, 3]), freed on destruction.
struct DeviceCopy {
  std::vector<float*> buffers;
  api::DeviceGaussians gaussians;

  DeviceCopy(const format::GaussianCloud& cloud, const std::vector<float>& colors, uint32_t k, bool rgb) {
    auto upload = [&](const std::vector<float>& host) {
      float* d = nullptr;
      REQUIRE(cudaMalloc(reinterpret_cast<void**>(&d), std::max<size_t>(host.size(), 1) * 4) == cudaSuccess);
      REQUIRE(cudaMemcpy(d, host.data(), host.size() * 4, cudaMemcpyHostToDevice) == cudaSuccess);
      buffers.push_back(d);
      return d;
    };
    gaussians.means = upload(cloud.means);
    gaussians.quats = upload(cloud.rotations);
    gaussians.scales = upload(cloud.scales);
    gaussians.opacities = upload(cloud.opacities);
    gaussians.colors = upload(colors);
    gaussians.count = cloud.size();
    gaussians.sh_coefficients = k;
    gaussians.rgb = rgb;
  }
  ~DeviceCopy() {
    for (float* b : buffers) cudaFree(b);
  }
};

std::vector<float> download(const float* d, size_t count) {
  std::vector<float> host(count);
  if (count > 0) REQUIRE(cudaMemcpy(host.data(), d, count * 4, cudaMemcpyDeviceToHost) == cudaSuccess);
  return host;
}

/// Both scenes' FP32 device arrays and bounds are equal bit for bit.
void check_same_scene(const api::Scene& a, const api::Scene& b) {
  const runtime::GpuScene& ga = *a.gpu_scene();
  const runtime::GpuScene& gb = *b.gpu_scene();
  REQUIRE(ga.size() == gb.size());
  REQUIRE(ga.sh_degree() == gb.sh_degree());
  const size_t n = ga.size(), k = format::sh_coefficient_count(ga.sh_degree());
  const kernels::Fp32GaussiansView va = ga.fp32(), vb = gb.fp32();
  CHECK(download(va.means, n * 3) == download(vb.means, n * 3));
  CHECK(download(va.rotations, n * 4) == download(vb.rotations, n * 4));
  CHECK(download(va.scales, n * 3) == download(vb.scales, n * 3));
  CHECK(download(va.opacities, n) == download(vb.opacities, n));
  CHECK(download(va.sh, n * k * 3) == download(vb.sh, n * k * 3));
  const format::SceneBounds& ba = a.info().bounds;
  const format::SceneBounds& bb = b.info().bounds;
  for (int i = 0; i < 3; ++i) {
    CHECK(ba.aabb_min[i] == bb.aabb_min[i]);
    CHECK(ba.aabb_max[i] == bb.aabb_max[i]);
    CHECK(ba.sphere_center[i] == bb.sphere_center[i]);
  }
  CHECK(ba.sphere_radius == bb.sphere_radius);
}

/// The host path: scene_from_cloud's rules, then load_cloud onto the GPU.
Result<api::Scene> host_scene(format::GaussianCloud cloud, converter::InvalidPolicy policy) {
  converter::SceneReadOptions read;
  read.invalid_policy = policy;
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::scene_from_cloud(std::move(cloud), "arrays", read));
  api::LoadOptions options;
  options.device = api::Device::kCuda;
  return api::load_cloud(std::move(input.cloud), input.bounds, "arrays", options);
}
#endif

}  // namespace

TEST_CASE("load_device_gaussians: the host path's scene bit for bit, its errors, and planar outputs") {
#if !RGS_HAS_CUDA
  MESSAGE("skipped: this build has no CUDA support");
  CHECK(api::load_device_gaussians({}).status().code() == StatusCode::kUnsupportedFeature);
#else
  std::string why;
  if (runtime::cuda_device_count(&why) == 0) {
    MESSAGE("skipped: no CUDA device (" << why << ")");
    CHECK(api::load_device_gaussians({}).status().code() == StatusCode::kUnsupportedFeature);
    return;
  }
  converter::SceneReadOptions exact;
  auto input = converter::read_scene(test::repo_path(test::kGuitarSh3), exact);
  REQUIRE(input.ok());
  format::GaussianCloud cloud = std::move(input->cloud);
  REQUIRE(cloud.sh_degree == 3);
  for (size_t i = 0; i < cloud.size(); ++i) {  // unnormalized quaternions: both paths normalize them
    for (int a = 0; a < 4; ++a) cloud.rotations[i * 4 + a] *= 1.5f + float(i % 7);
  }

  SUBCASE("SH at every degree the arrays allow") {
    for (uint32_t degree = 0; degree <= 3; ++degree) {
      CAPTURE(degree);
      DeviceCopy copy(cloud, cloud.sh, 16, false);
      copy.gaussians.sh_degree = degree;
      auto device = api::load_device_gaussians(copy.gaussians);
      REQUIRE(device.ok());
      CHECK(device->info().description == "float Gaussians in device memory");
      format::GaussianCloud reduced = cloud;
      REQUIRE(converter::reduce_sh_degree(&reduced, degree).ok());
      auto host = host_scene(std::move(reduced), converter::InvalidPolicy::kReject);
      REQUIRE(host.ok());
      check_same_scene(*device, *host);
    }
  }

  SUBCASE("RGB colours become the DC coefficient") {
    std::vector<float> rgb(cloud.size() * 3);
    for (size_t i = 0; i < cloud.size(); ++i) {
      for (int c = 0; c < 3; ++c) rgb[i * 3 + c] = 0.5f + kernels::kShC0 * cloud.sh[i * 48 + c];
    }
    DeviceCopy copy(cloud, rgb, 1, true);
    auto device = api::load_device_gaussians(copy.gaussians);
    REQUIRE(device.ok());
    format::GaussianCloud dc = cloud;
    dc.sh_degree = 0;
    dc.sh = rgb;
    for (float& v : dc.sh) v = (v - 0.5f) / kernels::kShC0;
    auto host = host_scene(std::move(dc), converter::InvalidPolicy::kReject);
    REQUIRE(host.ok());
    check_same_scene(*device, *host);
  }

  SUBCASE("the value rules: messages as the host's, sanitize drops the same Gaussians") {
    format::GaussianCloud bad = cloud;
    bad.means[7 * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
    bad.sh[20 * 48 + 5] = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 4; ++a) bad.rotations[11 * 4 + a] = 0;
    DeviceCopy copy(bad, bad.sh, 16, false);
    copy.gaussians.sh_degree = 3;
    auto rejected = api::load_device_gaussians(copy.gaussians);
    auto host_rejected = host_scene(bad, converter::InvalidPolicy::kReject);
    REQUIRE(rejected.status().code() == StatusCode::kCorruptData);
    CHECK(rejected.status().message() == host_rejected.status().message());
    api::DeviceLoadOptions sanitize;
    sanitize.invalid_policy = converter::InvalidPolicy::kSanitize;
    auto device = api::load_device_gaussians(copy.gaussians, sanitize);
    REQUIRE(device.ok());
    CHECK(device->size() == cloud.size() - 3);
    auto host = host_scene(bad, converter::InvalidPolicy::kSanitize);
    REQUIRE(host.ok());
    check_same_scene(*device, *host);

    format::GaussianCloud negative = cloud;
    negative.scales[40 * 3 + 2] = -0.5f;
    negative.opacities[30] = 1.5f;
    DeviceCopy neg(negative, negative.sh, 16, false);
    auto refused = api::load_device_gaussians(neg.gaussians);
    REQUIRE(refused.status().code() == StatusCode::kInvalidArgument);
    CHECK(refused.status().message() == host_scene(negative, converter::InvalidPolicy::kReject).status().message());
    CHECK(refused.status().message().find("Gaussian 30 has an opacity outside [0, 1]") != std::string::npos);
  }

  SUBCASE("layouts and pointers the import refuses") {
    DeviceCopy copy(cloud, cloud.sh, 16, false);
    api::DeviceGaussians g = copy.gaussians;
    g.sh_coefficients = 5;
    CHECK(api::load_device_gaussians(g).status().code() == StatusCode::kInvalidArgument);
    g = copy.gaussians;
    g.sh_coefficients = 4;
    g.sh_degree = 2;
    CHECK(api::load_device_gaussians(g).status().code() == StatusCode::kInvalidArgument);
    g = copy.gaussians;
    g.means = cloud.means.data();  // host memory
    auto host_pointer = api::load_device_gaussians(g);
    CHECK(host_pointer.status().code() == StatusCode::kInvalidArgument);
    CHECK(host_pointer.status().message().find("means") != std::string::npos);
    g = copy.gaussians;
    g.scales = nullptr;
    CHECK(api::load_device_gaussians(g).status().code() == StatusCode::kInvalidArgument);
  }

  SUBCASE("write_planar: the frame's values, depth as expected or accumulated") {
    DeviceCopy copy(cloud, cloud.sh, 16, false);
    copy.gaussians.sh_degree = 3;
    auto scene = api::load_device_gaussians(copy.gaussians);
    REQUIRE(scene.ok());
    auto cameras = runtime::orbit_cameras(scene->info().bounds, 1, 96, 64);
    REQUIRE(cameras.ok());
    auto renderer = api::Renderer::create();
    REQUIRE(renderer.ok());
    api::RenderSettings faithful;
    faithful.preset = api::Preset::kFaithful;
    auto frame = renderer->render_image(*scene, (*cameras)[0], faithful, api::PixelFormat::kRgba32f, true);
    REQUIRE(frame.ok());
    const size_t pixels = 96 * 64;
    std::vector<float> rgba(pixels * 4), depth(pixels);
    REQUIRE(frame->copy_to_host(rgba.data(), depth.data()).ok());
    float* colors = nullptr;
    float* alphas = nullptr;
    REQUIRE(cudaMalloc(reinterpret_cast<void**>(&colors), pixels * 16) == cudaSuccess);
    REQUIRE(cudaMalloc(reinterpret_cast<void**>(&alphas), pixels * 4) == cudaSuccess);
    for (api::DepthOutput mode : {api::DepthOutput::kNone, api::DepthOutput::kExpected, api::DepthOutput::kAccumulated}) {
      CAPTURE(int(mode));
      REQUIRE(cudaMemset(colors, 0xff, pixels * 16) == cudaSuccess);  // NaN: a value never written fails
      REQUIRE(cudaMemset(alphas, 0xff, pixels * 4) == cudaSuccess);
      api::PlanarTarget target{colors, true, mode, alphas};
      REQUIRE(api::write_planar(*frame, target).ok());
      const size_t channels = mode == api::DepthOutput::kNone ? 3 : 4;
      const std::vector<float> c = download(colors, pixels * channels), a = download(alphas, pixels);
      size_t mismatches = 0;
      for (size_t p = 0; p < pixels; ++p) {
        for (int k = 0; k < 3; ++k) mismatches += std::memcmp(&c[p * channels + k], &rgba[p * 4 + k], 4) != 0;
        mismatches += std::memcmp(&a[p], &rgba[p * 4 + 3], 4) != 0;
        if (channels == 4) {
          const float want = mode == api::DepthOutput::kAccumulated ? depth[p] * rgba[p * 4 + 3] : depth[p];
          mismatches += std::memcmp(&c[p * 4 + 3], &want, 4) != 0;
        }
      }
      CHECK(mismatches == 0);
    }
    api::PlanarTarget depth_only{colors, false, api::DepthOutput::kNone, alphas};
    CHECK(api::write_planar(*frame, depth_only).code() == StatusCode::kInvalidArgument);
    auto no_depth = renderer->render_image(*scene, (*cameras)[0], faithful, api::PixelFormat::kRgba32f, false);
    REQUIRE(no_depth.ok());
    api::PlanarTarget wants_depth{colors, true, api::DepthOutput::kExpected, alphas};
    CHECK(api::write_planar(*no_depth, wants_depth).code() == StatusCode::kInvalidArgument);
    cudaFree(colors);
    cudaFree(alphas);
  }
#endif
}
