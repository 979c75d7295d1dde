// The supersampled reference of level-of-detail quality (docs/LOD.md#measuring-quality): the 2×2 area downsample,
// the pixel-centre convention of a camera at twice the resolution, and the frame-to-frame change behind the
// popping measure.
#include <cmath>
#include <vector>

#include "render_test_util.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/lab/lod_quality.h"

namespace rgs::test {
namespace {

using runtime::Camera;
using runtime::ImageRef;

ImageRef rgb_ref(const runtime::RenderResult& r) { return {r.rgb.data(), r.width, r.height, 3}; }

/// One large, opaque Gaussian off the axis (σ about 2.5 px at 64×48), and a small one near it.
format::GaussianCloud two_gaussians() {
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.3f, -0.2f, 10.f, 0.5f, 0.9f, 1.0f, 0.2f, -0.5f);
  add_gaussian(&cloud, -1.5f, 0.8f, 10.f, 0.3f, 0.8f, -0.6f, 0.9f, 0.4f);
  return cloud;
}

TEST_CASE("area downsample: a constant image stays identical, a 2x2 block becomes its mean") {
  std::vector<float> constant(size_t{8} * 6 * 4, 0.37f);
  auto down = lab::area_downsample_2x({constant.data(), 8, 6, 4});
  REQUIRE(down.ok());
  CHECK(down->size() == size_t{4} * 3 * 4);
  for (float v : *down) CHECK(v == 0.37f);

  // 4×2 image, 1 channel: blocks {1, 2, 5, 6} and {3, 4, 7, 8}.
  const std::vector<float> ramp = {1, 2, 3, 4, 5, 6, 7, 8};
  down = lab::area_downsample_2x({ramp.data(), 4, 2, 1});
  REQUIRE(down.ok());
  REQUIRE(down->size() == 2);
  CHECK((*down)[0] == 3.5f);
  CHECK((*down)[1] == 5.5f);

  CHECK(lab::area_downsample_2x({ramp.data(), 3, 2, 1}).status().code() == StatusCode::kInvalidArgument);
  CHECK(lab::area_downsample_2x({nullptr, 4, 2, 1}).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("the 2x2 supersampled render of large Gaussians matches the 1x render, a half-pixel shift does not") {
  const format::GaussianCloud cloud = two_gaussians();
  const Camera cam = identity_camera(64, 48, 50.f);
  const runtime::RenderResult plain = render_ok(cloud, cam);
  // resize_camera doubles width, height, fx, fy, cx and cy: pixel (2i + a) of the 2× camera has its centre at
  // i + (2a − 1)/4 of the 1× camera, so each 2×2 block is centred on its 1× pixel.
  const Camera twice = runtime::resize_camera(cam, 128, 96);
  CHECK(twice.fx == 2 * cam.fx);
  CHECK(twice.cx == 2 * cam.cx);
  CHECK(twice.cy == 2 * cam.cy);
  const runtime::RenderResult fine = render_ok(cloud, twice);
  auto down = lab::area_downsample_2x(rgb_ref(fine));
  REQUIRE(down.ok());
  auto m = runtime::compare_images(rgb_ref(plain), {down->data(), 64, 48, 3});
  REQUIRE(m.ok());
  MESSAGE("supersampled vs 1x: PSNR " << m->psnr_db << " dB, max diff " << m->max_abs_diff);
  CHECK(m->psnr_db > 40.0);

  // The same camera with the principal point moved by half a 1x pixel (one 2x pixel), as a centre convention
  // that put the 2×2 block's corner on the 1x pixel centre would: far from the 1x render.
  Camera shifted = twice;
  shifted.cx += 1.f;
  shifted.cy += 1.f;
  const runtime::RenderResult off = render_ok(cloud, shifted);
  auto down_off = lab::area_downsample_2x(rgb_ref(off));
  REQUIRE(down_off.ok());
  auto m_off = runtime::compare_images(rgb_ref(plain), {down_off->data(), 64, 48, 3});
  REQUIRE(m_off.ok());
  MESSAGE("half-pixel shift: PSNR " << m_off->psnr_db << " dB");
  CHECK(m_off->psnr_db < m->psnr_db - 10.0);
}

TEST_CASE("mean absolute difference: 0 for a static camera, else |a - b| of clamped values") {
  const format::GaussianCloud cloud = two_gaussians();
  const Camera cam = identity_camera(64, 48, 50.f);
  const runtime::RenderResult first = render_ok(cloud, cam);
  const runtime::RenderResult second = render_ok(cloud, cam);
  auto still = lab::mean_abs_difference(rgb_ref(first), rgb_ref(second));
  REQUIRE(still.ok());
  CHECK(*still == 0.0);

  Camera moved = cam;
  moved.cx += 0.5f;
  const runtime::RenderResult third = render_ok(cloud, moved);
  auto change = lab::mean_abs_difference(rgb_ref(first), rgb_ref(third));
  REQUIRE(change.ok());
  CHECK(*change > 0.0);

  // RGBA against RGB; 1.5 clamps to 1 and −0.2 to 0.
  const std::vector<float> a = {0.25f, 1.5f, -0.2f, 0.9f, 0.5f, 0.5f, 0.5f, 0.1f};
  const std::vector<float> b = {0.75f, 1.0f, 0.1f, 0.5f, 0.5f, 0.5f};
  auto d = lab::mean_abs_difference({a.data(), 2, 1, 4}, {b.data(), 2, 1, 3});
  REQUIRE(d.ok());
  CHECK(*d == doctest::Approx((0.5 + 0.0 + 0.1 + 0.0 + 0.0 + 0.0) / 6));
  CHECK(lab::mean_abs_difference({a.data(), 2, 1, 4}, {b.data(), 1, 2, 3}).status().code() ==
        StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgs::test
