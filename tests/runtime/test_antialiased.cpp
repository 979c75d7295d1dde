// Anti-aliased scenes (docs/RENDERER.md#anti-aliased-scenes): the CPU reference scales each Gaussian's opacity by
// Mip-Splatting's compensation sqrt(det Σ₂ / det(Σ₂ + 0.3·I)), checked on single Gaussians against the analytic
// value, from footprints far below a pixel (factor << 1) to large ones (factor → 1).
#include <doctest/doctest.h>

#include <cmath>

#include "render_test_util.h"
#include "rgs/kernels/shared/projection.h"

namespace {

using namespace rgs;
using rgs::test::add_gaussian;
using rgs::test::identity_camera;
using rgs::test::render_ok;

constexpr uint32_t kSize = 33;  // odd: the mean at cx − 0.5 = 16 lies on pixel 16's centre
constexpr float kFocal = 100.f;
constexpr float kDepth = 5.f;
constexpr float kOpacity = 0.9f;

/// A cloud of one Gaussian on the optical axis with linear scales (sx, sy, sz), unrotated.
format::GaussianCloud one_gaussian(float sx, float sy, float sz, bool antialiased) {
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.f, 0.f, kDepth, 1.f, kOpacity, 0.f, 0.f, 0.f);
  cloud.scales = {sx, sy, sz};
  cloud.antialiased = antialiased;
  return cloud;
}

/// Accumulated opacity at the pixel under the mean, where the Gaussian's power is 0 (alpha = o').
float centre_alpha(const format::GaussianCloud& cloud, const runtime::RenderOptions& options = {}) {
  const runtime::RenderResult r = render_ok(cloud, identity_camera(kSize, kSize, kFocal), options);
  return r.alpha[size_t(kSize / 2) * kSize + kSize / 2];
}

/// The analytic factor for a Gaussian on the axis: Σ₂ = diag((f·sx/z)², (f·sy/z)²) px², s = 0.3 px².
double analytic_factor(double sx, double sy) {
  const double a = std::pow(kFocal * sx / kDepth, 2), b = std::pow(kFocal * sy / kDepth, 2), s = 0.3;
  return std::sqrt(a * b / ((a + s) * (b + s)));
}

}  // namespace

TEST_CASE("antialiased: the centre pixel's opacity is o·sqrt(det Σ₂ / det(Σ₂ + 0.3·I)), sub-pixel to large") {
  // Footprint standard deviations f·s/z from 0.05 px (factor 0.008) to 40 px (factor 0.9998).
  for (float sigma_px : {0.05f, 0.1f, 0.3f, 0.5477f, 1.f, 3.f, 40.f}) {
    CAPTURE(sigma_px);
    const float s = sigma_px * kDepth / kFocal;
    const double factor = analytic_factor(s, s);
    CHECK(centre_alpha(one_gaussian(s, s, s, true)) == doctest::Approx(kOpacity * factor).epsilon(5e-5));
    CHECK(centre_alpha(one_gaussian(s, s, s, false)) == doctest::Approx(kOpacity).epsilon(1e-6));
  }
  // sqrt(0.3) px: Σ₂ = s·I, so the factor is exactly 1/2.
  const float half = std::sqrt(0.3f) * kDepth / kFocal;
  CHECK(centre_alpha(one_gaussian(half, half, half, true)) == doctest::Approx(kOpacity * 0.5).epsilon(5e-5));
}

TEST_CASE("antialiased: anisotropic footprints take the product of both axes' factors") {
  // 0.05 px by 20 px: a needle, thin in x only; its factor is that of the thin axis times ~1.
  const float thin = 0.05f * kDepth / kFocal, wide = 20.f * kDepth / kFocal;
  const double factor = analytic_factor(thin, wide);
  CHECK(factor < 0.1);
  CHECK(centre_alpha(one_gaussian(thin, wide, thin, true)) == doctest::Approx(kOpacity * factor).epsilon(5e-5));
  CHECK(centre_alpha(one_gaussian(wide, thin, wide, true)) == doctest::Approx(kOpacity * factor).epsilon(5e-5));
}

TEST_CASE("antialiased: every RoofGS technique sees the compensated opacity") {
  runtime::RenderOptions options;
  options.roofgs.snugbox_accutile = true;
  options.roofgs.folded_coefficients = true;
  options.roofgs.fast_exp = true;
  options.roofgs.half_blend = true;
  options.roofgs.key32 = true;
  for (float sigma_px : {0.1f, 1.f, 10.f}) {
    CAPTURE(sigma_px);
    const float s = sigma_px * kDepth / kFocal;
    const format::GaussianCloud cloud = one_gaussian(s, s, s, true);
    options.scene_bounds = format::SceneBounds{{-1, -1, kDepth - 1}, {1, 1, kDepth + 1}, {0, 0, kDepth}, 2.f};
    // Fast exp and FP16 blending round the opacity (docs/DESIGN.md#fast-exponential): 1e-3 relative.
    CHECK(centre_alpha(cloud, options) == doctest::Approx(kOpacity * analytic_factor(s, s)).epsilon(1e-3));
  }
}

TEST_CASE("antialiased: the shared compensation recovers det Σ₂ from the dilated covariance") {
  namespace k = rgs::kernels;
  const k::Cov2 dilated{2.f + k::kCovarianceDilation, 0.5f, 1.f + k::kCovarianceDilation};
  const float det = k::determinant(dilated);
  CHECK(k::antialias_compensation(dilated, det) == doctest::Approx(std::sqrt((2.0 - 0.25) / det)).epsilon(1e-6));
  // A degenerate Σ₂ (det 0 before the low-pass) gets factor 0, never NaN.
  const k::Cov2 line{1.f + k::kCovarianceDilation, 1.f, 1.f + k::kCovarianceDilation};
  CHECK(k::antialias_compensation(line, k::determinant(line)) == doctest::Approx(0.0).epsilon(1e-3));
}

TEST_CASE("antialiased: the guitar at 160x96 (mostly sub-pixel Gaussians) loses opacity, never gains it") {
  auto ply = converter::read_ply(rgs::test::repo_path("samples/guitar.ply"));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  format::GaussianCloud plain = std::move(ply->cloud);
  format::GaussianCloud flagged = plain;
  flagged.antialiased = true;
  auto cams = runtime::orbit_cameras(converter::compute_bounds(plain), 2, 160, 96);
  REQUIRE(cams.ok());
  for (const runtime::Camera& cam : *cams) {
    CAPTURE(cam.name);
    const runtime::RenderResult a = render_ok(flagged, cam), b = render_ok(plain, cam);
    double lowered = 0;
    for (size_t p = 0; p < a.alpha.size(); ++p) {
      // Accumulated opacity is monotonic in each opacity except at saturation, where 3DGS's stop before
      // T < 1e-4 drops a larger alpha that a smaller one lets through.
      if (b.alpha[p] < 0.99f) CHECK(a.alpha[p] <= b.alpha[p] + 1e-3f);
      lowered += b.alpha[p] - a.alpha[p];
    }
    const double psnr = rgs::test::psnr(a.rgb, b.rgb);
    MESSAGE(cam.name << ": mean alpha lowered by " << lowered / double(a.alpha.size()) << ", " << psnr << " dB");
    CHECK(lowered > 0);
    CHECK(psnr < 45.0);  // the GPU suite's antialiased case relies on this gap
    CHECK(a.stats.pairs == b.stats.pairs);  // the footprints are unchanged; only the opacities are scaled
  }
}
