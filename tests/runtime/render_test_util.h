// Helpers of the runtime suite: image metrics, hand-built Gaussian clouds, and the flowers scene (read with
// rgs::converter::read_ply, which only the tests may link).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cpu_renderer.h"
#include "test_data.h"

namespace rgs::test {

/// PSNR in dB of two float images with values clamped to [0, 1] (peak 1); +inf when identical after clamping.
inline double psnr(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  double se = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = double(std::clamp(a[i], 0.f, 1.f)) - double(std::clamp(b[i], 0.f, 1.f));
    se += d * d;
  }
  if (se == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(double(a.size()) / se);
}

/// Writes `rgb8` ([H, W, 3] uint8, row-major, top row first) as a binary PPM (P6) to look at; false when the
/// size does not match or the file cannot be written.
inline bool write_ppm(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgb8) {
  if (rgb8.size() != size_t{width} * height * 3) return false;
  std::ofstream out(path, std::ios::binary);
  out << "P6\n" << width << " " << height << "\n255\n";
  out.write(reinterpret_cast<const char*>(rgb8.data()), std::streamsize(rgb8.size()));
  return bool(out);
}

/// Largest |a − b| over all values.
inline double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(double(a[i]) - double(b[i])));
  return m;
}

/// Pinhole camera at the origin looking along +z (identity pose), principal point at the image centre.
inline runtime::Camera identity_camera(uint32_t width, uint32_t height, float focal) {
  runtime::Camera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = focal;
  cam.cx = float(width) / 2.f;
  cam.cy = float(height) / 2.f;
  cam.name = "test";
  return cam;
}

/// Appends an isotropic, unrotated Gaussian with SH degree 0 and DC coefficients `dc` (colour = C0·dc + 0.5).
inline void add_gaussian(format::GaussianCloud* cloud, float x, float y, float z, float scale, float opacity,
                         float dc_r, float dc_g, float dc_b) {
  REQUIRE(cloud->sh_degree == 0);
  cloud->means.insert(cloud->means.end(), {x, y, z});
  cloud->rotations.insert(cloud->rotations.end(), {1.f, 0.f, 0.f, 0.f});
  cloud->scales.insert(cloud->scales.end(), {scale, scale, scale});
  cloud->opacities.push_back(opacity);
  cloud->sh.insert(cloud->sh.end(), {dc_r, dc_g, dc_b});
}

/// Renders or fails the test.
inline runtime::RenderResult render_ok(const format::GaussianCloud& cloud, const runtime::Camera& camera,
                                       const runtime::RenderOptions& options = {}) {
  auto r = runtime::render_cpu(cloud, camera, options);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

/// The Mip-NeRF 360 flowers scene with its bounds and cameras, loaded once.
struct FlowersScene {
  bool available = false;
  format::GaussianCloud cloud;
  format::SceneBounds bounds;
  std::string cameras_path;
};

inline const FlowersScene& flowers() {
  static const FlowersScene scene = [] {
    FlowersScene s;
    const std::string ply = shared_scene("mipnerf360_flowers_c3dgs.ply");
    const std::string cams = shared_scene("mipnerf360_flowers_cameras.json");
    if (ply.empty() || cams.empty()) return s;
    auto r = converter::read_ply(ply);
    REQUIRE_MESSAGE(r.ok(), r.status().to_string());
    s.cloud = std::move(r).value().cloud;
    s.bounds = converter::compute_bounds(s.cloud);
    s.cameras_path = cams;
    s.available = true;
    return s;
  }();
  if (!scene.available) MESSAGE("skipped: flowers scene not available");
  return scene;
}

}  // namespace rgs::test
