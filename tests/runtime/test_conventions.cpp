// The 3DGS baseline conventions (docs/DESIGN.md#conventions) on hand-computed cases:
// pixel-centre projection, EWA 2D covariance with clamp and 0.3 dilation, radius, the truncating tile
// rectangle, SH basis signs, the blending stop rule, alpha skip and background composition.
#include <cmath>
#include <vector>

#include "render_test_util.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#include "rgs/runtime/cpu_renderer.h"

namespace rgs::test {
namespace {

namespace k = rgs::kernels;
using runtime::Camera;
using runtime::RenderOptions;

/// Preprocesses a cloud and returns Gaussian `index`.
runtime::ProjectedGaussian preprocess_one(const format::GaussianCloud& cloud, const Camera& cam, size_t index,
                                          const RenderOptions& options = {}) {
  auto frame = runtime::setup_frame(cloud, cam, options);
  REQUIRE_MESSAGE(frame.ok(), frame.status().to_string());
  const auto g = runtime::preprocess_cpu(cloud, cam, *frame, options, nullptr);
  REQUIRE(g.size() > index);
  return g[index];
}

TEST_CASE("projection: pixel = fx*x/z + cx - 0.5, pixel centres at integers") {
  // W=100, H=80, fx=fy=100, principal point at the centre (50, 40): the 3DGS case.
  const Camera cam = identity_camera(100, 80, 100.f);
  const float p[3] = {1.f, 2.f, 10.f};
  float px = 0, py = 0;
  k::project_to_pixel(p, cam.fx, cam.fy, cam.cx, cam.cy, &px, &py);
  CHECK(px == 59.5f);  // 100·1/10 + 50 − 0.5
  CHECK(py == 59.5f);  // 100·2/10 + 40 − 0.5
  // A point on the optical axis lands between the two middle pixels (W even): 49.5, 39.5.
  const float axis[3] = {0.f, 0.f, 3.f};
  k::project_to_pixel(axis, cam.fx, cam.fy, cam.cx, cam.cy, &px, &py);
  CHECK(px == 49.5f);
  CHECK(py == 39.5f);

  // Through the renderer's preprocess, with a translated, rotated camera: R = 90° about z (x→y), t = (0,0,5).
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 2.f, -1.f, 5.f, 0.05f, 0.9f, 0.f, 0.f, 0.f);
  Camera moved = cam;
  moved.rotation = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  moved.translation = {0, 0, 5};
  const auto g = preprocess_one(cloud, moved, 0);
  REQUIRE(g.tiles_touched > 0);
  // p_cam = R·p + t = (1, 2, 10) → (59.5, 59.5), depth 10.
  CHECK(g.depth == 10.f);
  CHECK(g.mean[0] == 59.5f);
  CHECK(g.mean[1] == 59.5f);
  // The camera centre is −Rᵀ·t = (0, 0, −5).
  const auto c = runtime::camera_centre(moved);
  CHECK(c[0] == 0.f);
  CHECK(c[1] == 0.f);
  CHECK(c[2] == -5.f);
}

TEST_CASE("near plane: z <= 0.2 is culled, z just above is kept") {
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.f, 0.f, 0.2f, 0.01f, 0.9f, 0.f, 0.f, 0.f);
  add_gaussian(&cloud, 0.f, 0.f, 0.21f, 0.01f, 0.9f, 0.f, 0.f, 0.f);
  const Camera cam = identity_camera(64, 64, 50.f);
  auto frame = runtime::setup_frame(cloud, cam, {});
  REQUIRE(frame.ok());
  runtime::RenderStats stats;
  const auto g = runtime::preprocess_cpu(cloud, cam, *frame, {}, &stats);
  CHECK(g[0].tiles_touched == 0);
  CHECK(g[1].tiles_touched > 0);
  CHECK(stats.culled_near == 1);
}

TEST_CASE("EWA covariance: J·W·Σ·Wᵀ·Jᵀ + 0.3, quaternion (w,x,y,z), conic and radius") {
  // Gaussian at (0,0,10), scales (0.1, 0.2, 0.3), camera identity with fx = fy = 100:
  // J = diag(10, 10) on x, y (the mean is on the axis, so the z column is 0); Σ = diag(0.01, 0.04, 0.09);
  // cov2D = diag(100·0.01, 100·0.04) + 0.3 = diag(1.3, 4.3).
  const float scale[3] = {0.1f, 0.2f, 0.3f};
  const float identity_q[4] = {1.f, 0.f, 0.f, 0.f};
  float cov3d[6];
  k::covariance_3d(scale, identity_q, cov3d);
  const float W[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const float p_cam[3] = {0.f, 0.f, 10.f};
  const Camera cam = identity_camera(100, 100, 100.f);
  const k::EwaClamp clamp = k::ewa_clamp_for(cam.fx, cam.fy, cam.cx, cam.cy, 100.f, 100.f);
  k::Cov2 cov = k::ewa_covariance_2d(cov3d, W, p_cam, cam.fx, cam.fy, clamp);
  CHECK(cov.xx == doctest::Approx(1.3).epsilon(1e-6));
  CHECK(cov.yy == doctest::Approx(4.3).epsilon(1e-6));
  CHECK(cov.xy == 0.f);
  // det = 1.3·4.3 = 5.59; conic = (4.3, 0, 1.3)/5.59.
  const float det = k::determinant(cov);
  CHECK(det == doctest::Approx(5.59).epsilon(1e-6));
  const k::Conic conic = k::conic_from_covariance(cov, det);
  CHECK(conic.a == doctest::Approx(4.3 / 5.59).epsilon(1e-6));
  CHECK(conic.b == doctest::Approx(0.0));
  CHECK(conic.c == doctest::Approx(1.3 / 5.59).epsilon(1e-6));
  // mid = 2.8, sqrt(max(0.1, 2.8² − 5.59)) = 1.5, λ = 4.3 and 1.3, r = ceil(3·sqrt(4.3)) = ceil(6.22) = 7.
  CHECK(k::screen_radius(cov, det) == 7);
  // Isotropic-ish: λmax barely above a square: cov = diag(4, 4) → mid² − det = 0 → max(0.1, 0) = 0.1,
  // λ = 4 + sqrt(0.1) = 4.316, r = ceil(3·2.0776) = 7.
  CHECK(k::screen_radius(k::Cov2{4.f, 0.f, 4.f}, 16.f) == 7);

  // Quaternion order (w, x, y, z): 90° about z maps the x scale onto y, so cov2D = diag(4.3, 1.3).
  const float s = std::sqrt(0.5f);
  const float qz[4] = {s, 0.f, 0.f, s};
  k::covariance_3d(scale, qz, cov3d);
  cov = k::ewa_covariance_2d(cov3d, W, p_cam, cam.fx, cam.fy, clamp);
  CHECK(cov.xx == doctest::Approx(4.3).epsilon(1e-5));
  CHECK(cov.yy == doctest::Approx(1.3).epsilon(1e-5));
  CHECK(std::fabs(cov.xy) < 1e-6f);
}

TEST_CASE("EWA clamp: ±1.3·tan(fov/2), and per side for an off-centre principal point") {
  // W = 100, fx = 100: tan(fov_x/2) = 0.5, limit 0.65. Mean at (10, 0, 10), x/z = 1 → clamped to 0.65:
  // x = 6.5, J = [[10, 0, −100·6.5/100], [0, 10, 0]] = [[10, 0, −6.5], [0, 10, 0]],
  // cov.xx = 100·0.01 + 6.5²·0.09 + 0.3 = 1 + 3.8025 + 0.3 = 5.1025 (unclamped it would be 10.3).
  const float scale[3] = {0.1f, 0.2f, 0.3f};
  const float q[4] = {1.f, 0.f, 0.f, 0.f};
  float cov3d[6];
  k::covariance_3d(scale, q, cov3d);
  const float W[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const float right[3] = {10.f, 0.f, 10.f};
  const float left[3] = {-10.f, 0.f, 10.f};
  const k::EwaClamp centred = k::ewa_clamp_for(100.f, 100.f, 50.f, 50.f, 100.f, 100.f);
  CHECK(centred.left == doctest::Approx(0.65));
  CHECK(centred.right == doctest::Approx(0.65));
  CHECK(k::ewa_covariance_2d(cov3d, W, right, 100.f, 100.f, centred).xx == doctest::Approx(5.1025).epsilon(1e-5));
  CHECK(k::ewa_covariance_2d(cov3d, W, left, 100.f, 100.f, centred).xx == doctest::Approx(5.1025).epsilon(1e-5));
  // Principal point at cx = 20: left limit 1.3·20/100 = 0.26, right 1.3·80/100 = 1.04.
  // Right point (x/z = 1 < 1.04): unclamped, 1 + 100·0.09 + 0.3 = 10.3.
  // Left point (x/z = −1 → −0.26): x = −2.6, J02 = 2.6: 1 + 6.76·0.09 + 0.3 = 1.9084.
  const k::EwaClamp off = k::ewa_clamp_for(100.f, 100.f, 20.f, 50.f, 100.f, 100.f);
  CHECK(off.left == doctest::Approx(0.26));
  CHECK(off.right == doctest::Approx(1.04));
  CHECK(k::ewa_covariance_2d(cov3d, W, right, 100.f, 100.f, off).xx == doctest::Approx(10.3).epsilon(1e-5));
  CHECK(k::ewa_covariance_2d(cov3d, W, left, 100.f, 100.f, off).xx == doctest::Approx(1.9084).epsilon(1e-5));
}

TEST_CASE("tile rect: (int) truncation, exclusive max, clamped to the grid") {
  // px = 25.5, r = 7: x_min = (int)(18.5/16) = 1, x_max = (int)((25.5 + 7 + 15)/16) = (int)(2.97) = 2.
  // The floor((px ± r)/16)-inclusive reading would give tiles 1..2 (x_max = 3): pixel 32 is within 6.5 < r
  // of the mean but its tile 2 is NOT in the rectangle. That is what 3DGS does, so the reference does it.
  k::TileRect r = k::tile_rect(25.5f, 25.5f, 7, 10, 10);
  CHECK(r.x_min == 1);
  CHECK(r.x_max == 2);
  CHECK(r.y_min == 1);
  CHECK(r.y_max == 2);
  CHECK(std::floor((25.5 + 7) / 16) + 1 == 3);  // the wrong reading, for contrast
  // px + r = 33 reaches into tile 2: (33 + 15)/16 = 3 → x_max = 3.
  r = k::tile_rect(26.f, 26.f, 7, 10, 10);
  CHECK(r.x_max == 3);
  // Negative side: (int)(−5/16) = 0 (truncation toward zero), (int)(−20/16) = −1 → clamped to 0.
  CHECK(k::tile_rect(2.f, 2.f, 7, 10, 10).x_min == 0);
  CHECK(k::tile_rect(-13.f, 2.f, 7, 10, 10).x_min == 0);
  // Entirely left of the image: x_max = (int)((−40 + 7 + 15)/16) = (int)(−1.125) = −1 → 0: empty.
  CHECK(k::is_empty(k::tile_rect(-40.f, 20.f, 7, 10, 10)));
  // Clamped to the grid on the far side; huge and non-finite inputs stay defined.
  CHECK(k::tile_rect(150.f, 20.f, 7, 10, 10).x_max == 10);
  CHECK(k::tile_rect(1e30f, 20.f, 7, 10, 10).x_min == 10);
  CHECK(k::tile_rect(NAN, 20.f, 7, 10, 10).x_max == 0);
}

TEST_CASE("SH basis: the 3DGS constants and odd-m minus signs at dir = (2, 3, 6)/7") {
  const float x = 2.f / 7.f, y = 3.f / 7.f, z = 6.f / 7.f;
  float Y[16];
  k::sh_basis(x, y, z, 3, Y);
  // Expected values worked out from docs/DESIGN.md's basis table with x² = 4/49, y² = 9/49, z² = 36/49:
  const double C1 = 0.4886025119029199;
  const double expected[16] = {
      0.28209479177387814,                   // Y0  = C0
      -C1 * 3 / 7,                           // Y1  = −C1·y
      C1 * 6 / 7,                            // Y2  = +C1·z
      -C1 * 2 / 7,                           // Y3  = −C1·x
      1.0925484305920792 * 6 / 49,           // Y4  = +·xy
      -1.0925484305920792 * 18 / 49,         // Y5  = −·yz
      0.31539156525252005 * 59 / 49,         // Y6  = (2·36 − 4 − 9)/49
      -1.0925484305920792 * 12 / 49,         // Y7  = −·xz
      0.5462742152960396 * -5 / 49,          // Y8  = (4 − 9)/49
      -0.5900435899266435 * 9 / 343,         // Y9  = −·y(3x² − y²) = (3/7)(3/49)
      2.890611442640554 * 36 / 343,          // Y10 = +·xyz = (6/49)(6/7)
      -0.4570457994644658 * 393 / 343,       // Y11 = −·y(4z² − x² − y²) = (3/7)(131/49)
      0.3731763325901154 * 198 / 343,        // Y12 = +·z(2z² − 3x² − 3y²) = (6/7)(33/49)
      -0.4570457994644658 * 262 / 343,       // Y13 = −·x(4z² − x² − y²) = (2/7)(131/49)
      1.445305721320277 * -30 / 343,         // Y14 = +·z(x² − y²) = (6/7)(−5/49)
      0.5900435899266435 * 46 / 343,         // Y15 = −·x(x² − 3y²) = −(2/7)(−23/49)
  };
  for (int i = 0; i < 16; ++i) {
    CAPTURE(i);
    CHECK(Y[i] == doctest::Approx(expected[i]).epsilon(1e-6));
  }
  // Lower degrees zero the rest.
  k::sh_basis(x, y, z, 1, Y);
  CHECK(Y[3] == doctest::Approx(expected[3]).epsilon(1e-6));
  CHECK(Y[4] == 0.f);

  // Colour: channel c uses coefficient k·3 + c; +0.5, then max(·, 0).
  float sh[16 * 3] = {};
  for (int i = 0; i < 16; ++i) sh[i * 3 + 0] = 1.f;  // R: sum of all basis values
  sh[0 * 3 + 1] = -10.f;                             // G: strongly negative → clamped to 0
  sh[9 * 3 + 2] = 2.f;                               // B: 2·Y9 + 0.5
  float rgb[3];
  k::sh_to_colour(sh, 3, x, y, z, rgb);
  double sum = 0;
  for (double e : expected) sum += e;
  CHECK(rgb[0] == doctest::Approx(sum + 0.5).epsilon(1e-6));
  CHECK(rgb[1] == 0.f);
  CHECK(rgb[2] == doctest::Approx(2 * expected[9] + 0.5).epsilon(1e-6));
}

/// A stack of Gaussians on one pixel's line of sight: every one has alpha exactly 0.5 at pixel (16, 16).
/// Index order is the reverse of depth order, so the sort matters.
format::GaussianCloud opaque_stack(int count, int red_front_count) {
  format::GaussianCloud cloud;
  for (int i = 0; i < count; ++i) {
    const int rank = count - 1 - i;  // depth rank: 0 = front
    const float z = 1.f + float(rank);
    // x = z/128 with fx = 64: fx·x/z = 0.5 exactly, so px = 0.5 + 16 − 0.5 = 16 (a pixel centre, power = 0).
    const float x = z / 128.f;
    const bool red = rank < red_front_count;
    // DC 0 → colour 0.5; DC −10 → max(C0·(−10) + 0.5, 0) = 0.
    add_gaussian(&cloud, x, x, z, 0.002f * z, 0.5f, red ? 0.f : -10.f, red ? -10.f : 0.f, -10.f);
  }
  return cloud;
}

TEST_CASE("blending: front-to-back order and the T < 1e-4 stop rule (that Gaussian not added)") {
  // Twenty Gaussians with alpha 0.5: T goes 1, 1/2, ..., 2^-13 after 13 of them; the 14th would give
  // 2^-14 = 6.1e-5 < 1e-4, so the pixel stops there and exactly the 13 front Gaussians contribute.
  const format::GaussianCloud cloud = opaque_stack(20, 13);
  const Camera cam = identity_camera(32, 32, 64.f);
  RenderOptions options;
  options.background = {0.f, 0.f, 1.f};
  for (unsigned threads : {1u, 2u}) {
    options.num_threads = threads;
    const auto out = render_ok(cloud, cam, options);
    const size_t p = 16 * 32 + 16;
    // R: Σ_{k<13} 0.5·0.5·2^-k = 0.5·(1 − 2^-13), exact in float.
    CHECK(out.rgb[p * 3 + 0] == 0.5f * (1.f - std::ldexp(1.f, -13)));
    // G: the green Gaussians (depth rank ≥ 13) never contribute.
    CHECK(out.rgb[p * 3 + 1] == 0.f);
    // B: T·bg = 2^-13.
    CHECK(out.rgb[p * 3 + 2] == std::ldexp(1.f, -13));
    CHECK(out.alpha[p] == 1.f - std::ldexp(1.f, -13));
    // Expected depth Σ w·z / Σ w with w_k = 2^-(k+1), z_k = 1 + k.
    double wz = 0, w = 0;
    for (int k = 0; k < 13; ++k) {
      wz += std::ldexp(1.0, -(k + 1)) * (1 + k);
      w += std::ldexp(1.0, -(k + 1));
    }
    CHECK(out.depth[p] == doctest::Approx(wz / w).epsilon(1e-6));
  }
  // With 14 red in front the 14th is still cut: the result is the same image.
  const auto a = render_ok(opaque_stack(20, 13), cam, options);
  const auto b = render_ok(opaque_stack(20, 14), cam, options);
  CHECK(a.rgb[(16 * 32 + 16) * 3 + 0] == b.rgb[(16 * 32 + 16) * 3 + 0]);
}

TEST_CASE("blending: alpha < 1/255 is skipped, alpha is clamped to 0.99, out = C + T·bg") {
  const Camera cam = identity_camera(32, 32, 64.f);
  RenderOptions options;
  options.background = {0.25f, 0.5f, 1.f};
  const size_t p = 16 * 32 + 16;
  const size_t far = 2 * 32 + 2;  // a pixel far from the Gaussian

  // Opacity 0.0035 < 1/255 at the exact centre: skipped, the pixel is pure background.
  format::GaussianCloud faint;
  add_gaussian(&faint, 1.f / 128.f, 1.f / 128.f, 1.f, 0.001f, 0.0035f, 0.f, 0.f, 0.f);
  auto out = render_ok(faint, cam, options);
  CHECK(out.rgb[p * 3 + 0] == 0.25f);
  CHECK(out.rgb[p * 3 + 1] == 0.5f);
  CHECK(out.rgb[p * 3 + 2] == 1.f);
  CHECK(out.alpha[p] == 0.f);
  CHECK(out.depth[p] == 0.f);

  // Opacity 0.5, colour 0.5 (DC 0): out = 0.5·0.5·1 + 0.5·bg.
  format::GaussianCloud half;
  add_gaussian(&half, 1.f / 128.f, 1.f / 128.f, 1.f, 0.001f, 0.5f, 0.f, 0.f, 0.f);
  out = render_ok(half, cam, options);
  CHECK(out.rgb[p * 3 + 0] == 0.25f + 0.5f * 0.25f);
  CHECK(out.rgb[p * 3 + 1] == 0.25f + 0.5f * 0.5f);
  CHECK(out.rgb[p * 3 + 2] == 0.25f + 0.5f * 1.f);
  CHECK(out.alpha[p] == 0.5f);
  CHECK(out.depth[p] == 1.f);
  // Far pixel: background exactly, alpha 0.
  CHECK(out.rgb[far * 3 + 0] == 0.25f);
  CHECK(out.alpha[far] == 0.f);

  // Opacity 1 → alpha clamped to 0.99: T = 1 − 0.99 = 0.01 (then a second such Gaussian behind would make
  // T = 1e-4·(1 − tiny) < 1e-4 and is not added).
  format::GaussianCloud opaque;
  add_gaussian(&opaque, 1.f / 128.f, 1.f / 128.f, 1.f, 0.001f, 1.f, 0.f, 0.f, 0.f);
  add_gaussian(&opaque, 2.f / 128.f, 2.f / 128.f, 2.f, 0.002f, 1.f, 10.f, 10.f, 10.f);
  out = render_ok(opaque, cam, options);
  CHECK(out.alpha[p] == 1.f - (1.f - 0.99f));
  CHECK(out.rgb[p * 3 + 0] == 0.5f * 0.99f + (1.f - 0.99f) * 0.25f);
}

TEST_CASE("any image size: non-multiples of 16 and one-pixel images") {
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.f, 0.f, 2.f, 0.3f, 0.8f, 0.5f, 0.f, -0.5f);
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{1, 1}, {17, 5}, {33, 47}, {100, 16}}) {
    CAPTURE(w);
    CAPTURE(h);
    const Camera cam = identity_camera(w, h, float(w));
    const auto out = render_ok(cloud, cam);
    CHECK(out.rgb.size() == size_t(w) * h * 3);
    CHECK(out.alpha.size() == size_t(w) * h);
    // The Gaussian covers the image centre.
    const size_t c = size_t(h / 2) * w + w / 2;
    CHECK(out.alpha[c] > 0.5f);
  }
}

TEST_CASE("render_cpu rejects bad input with named errors") {
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.f, 0.f, 2.f, 0.3f, 0.8f, 0.f, 0.f, 0.f);
  Camera cam = identity_camera(16, 16, 16.f);
  cam.fx = 0.f;
  auto r = runtime::render_cpu(cloud, cam);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  cam = identity_camera(16, 16, 16.f);
  cam.rotation = {1, 0, 0, 0, 1, 0, 0, 0, -1};  // a reflection
  CHECK(runtime::render_cpu(cloud, cam).status().code() == StatusCode::kInvalidArgument);
  cam = identity_camera(16, 16, 16.f);
  format::GaussianCloud broken = cloud;
  broken.opacities.push_back(1.f);
  CHECK(runtime::render_cpu(broken, cam).status().code() == StatusCode::kInvalidArgument);
  RenderOptions options;
  options.roofgs.key32 = true;  // without scene bounds
  r = runtime::render_cpu(cloud, cam, options);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("scene bounds") != std::string::npos);
  // An empty cloud renders the background.
  format::GaussianCloud empty;
  RenderOptions bg;
  bg.background = {0.1f, 0.2f, 0.3f};
  const auto out = render_ok(empty, cam, bg);
  CHECK(out.rgb[0] == 0.1f);
  CHECK(out.stats.pairs == 0);
}

}  // namespace
}  // namespace rgs::test
