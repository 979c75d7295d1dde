// CPU image metrics (runtime/image_metrics.h) on hand-made images: identical images, constant images (closed form), clamping,
// a direct (non-separable, per-window) evaluation of the SSIM definition, RGBA input and the difference map.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "rgs/runtime/image_metrics.h"

namespace {

using rgs::runtime::psnr_rgb;
using rgs::runtime::ssim_rgb;

std::vector<float> random_image(uint32_t w, uint32_t h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<float> img(size_t{w} * h * 3);
  for (float& v : img) v = u(rng);
  return img;
}

/// SSIM straight from the definition: every valid 11×11 window, 2D Gaussian weights, per channel.
double direct_ssim(const std::vector<float>& a, const std::vector<float>& b, int w, int h) {
  double g[11], sum = 0;
  for (int i = -5; i <= 5; ++i) sum += g[i + 5] = std::exp(-(i * i) / (2 * 1.5 * 1.5));
  for (double& v : g) v /= sum;
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    double acc = 0;
    int windows = 0;
    for (int y0 = 0; y0 + 11 <= h; ++y0) {
      for (int x0 = 0; x0 + 11 <= w; ++x0) {
        double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
        for (int j = 0; j < 11; ++j) {
          for (int i = 0; i < 11; ++i) {
            const double wt = g[i] * g[j];
            const size_t k = (size_t(y0 + j) * w + x0 + i) * 3 + c;
            const double x = a[k], y = b[k];
            mx += wt * x; my += wt * y; xx += wt * x * x; yy += wt * y * y; xy += wt * x * y;
          }
        }
        const double vx = xx - mx * mx, vy = yy - my * my, cxy = xy - mx * my;
        acc += (2 * mx * my + 1e-4) * (2 * cxy + 9e-4) / ((mx * mx + my * my + 1e-4) * (vx + vy + 9e-4));
        ++windows;
      }
    }
    total += acc / windows;
  }
  return total / 3;
}

TEST_CASE("identical images: PSNR inf, SSIM 1") {
  const auto a = random_image(32, 20, 1);
  auto p = psnr_rgb(a, a, 32, 20);
  REQUIRE(p.ok());
  CHECK(std::isinf(*p));
  CHECK(*p > 0);
  auto s = ssim_rgb(a, a, 32, 20);
  REQUIRE(s.ok());
  CHECK(*s == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("constant images: closed form") {
  // a = 0.5, b = 0.25 everywhere: MSE = 1/16 -> PSNR = 10·log10(16); variances 0, so SSIM is the luminance
  // term (2·0.5·0.25 + C1) / (0.25 + 0.0625 + C1) = 0.2501 / 0.3126.
  const std::vector<float> a(size_t{12} * 11 * 3, 0.5f), b(size_t{12} * 11 * 3, 0.25f);
  CHECK(*psnr_rgb(a, b, 12, 11) == doctest::Approx(10 * std::log10(16.0)).epsilon(1e-12));
  CHECK(*ssim_rgb(a, b, 12, 11) == doctest::Approx(0.2501 / 0.3126).epsilon(1e-12));
}

TEST_CASE("values are clamped to [0, 1] before comparing") {
  std::vector<float> a(size_t{11} * 11 * 3, 1.0f), b(size_t{11} * 11 * 3, 3.0f);
  a[0] = -2.f;  // clamps to 0; b's 3 clamps to 1: one value differs by 1
  CHECK(*psnr_rgb(a, b, 11, 11) == doctest::Approx(10 * std::log10(363.0)).epsilon(1e-12));
}

TEST_CASE("separable SSIM equals the per-window definition") {
  const auto a = random_image(23, 17, 2);
  auto b = a;
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.f, 0.1f);
  for (float& v : b) v = std::clamp(v + noise(rng), 0.f, 1.f);
  const double expected = direct_ssim(a, b, 23, 17);
  CHECK(*ssim_rgb(a, b, 23, 17) == doctest::Approx(expected).epsilon(1e-12));
  CHECK(expected < 0.95);
}

TEST_CASE("bad sizes are kInvalidArgument") {
  const auto a = random_image(10, 10, 4);
  CHECK(ssim_rgb(a, a, 10, 10).status().code() == rgs::StatusCode::kInvalidArgument);
  CHECK(psnr_rgb(a, a, 11, 10).status().code() == rgs::StatusCode::kInvalidArgument);
}

TEST_CASE("the SSIM window is normalized and symmetric") {
  const auto g = rgs::runtime::ssim_window_weights();
  double sum = 0;
  for (double v : g) sum += v;
  CHECK(sum == doctest::Approx(1.0).epsilon(1e-15));
  for (int i = 0; i < 5; ++i) CHECK(g[size_t(i)] == g[size_t(10 - i)]);
  CHECK(g[5] > g[4]);
}

TEST_CASE("compare_images: RGBA input, maximum difference and its map") {
  const uint32_t w = 16, h = 12;
  const auto rgb = random_image(w, h, 5);
  std::vector<float> rgba(size_t{w} * h * 4);
  for (size_t p = 0; p < size_t{w} * h; ++p) {
    for (int c = 0; c < 3; ++c) rgba[p * 4 + c] = rgb[p * 3 + c];
    rgba[p * 4 + 3] = 0.25f;  // alpha: ignored
  }
  auto other = rgb;
  other[(size_t{3} * w + 7) * 3 + 1] += 0.5f;  // pixel (7, 3), green
  other[(size_t{9} * w + 2) * 3 + 2] = 2.f;    // pixel (2, 9), blue: clamps to 1
  const float expected_blue = 1.f - rgb[(size_t{9} * w + 2) * 3 + 2];
  const float expected_green =
      std::min(1.f, rgb[(size_t{3} * w + 7) * 3 + 1] + 0.5f) - rgb[(size_t{3} * w + 7) * 3 + 1];
  std::vector<float> diff;
  auto m = rgs::runtime::compare_images({rgba.data(), w, h, 4}, {other.data(), w, h, 3}, &diff);
  REQUIRE(m.ok());
  CHECK(m->max_abs_diff == doctest::Approx(std::max(expected_blue, expected_green)));
  REQUIRE(diff.size() == size_t{w} * h);
  CHECK(diff[size_t{3} * w + 7] == doctest::Approx(expected_green));
  CHECK(diff[size_t{9} * w + 2] == doctest::Approx(expected_blue));
  CHECK(diff[0] == 0.f);
  CHECK(m->psnr_db == *psnr_rgb(rgb, other, w, h));
  CHECK(m->ssim == *ssim_rgb(rgb, other, w, h));
}

/// [H, W, 4] RGBA, black and transparent.
std::vector<float> black_rgba(uint32_t w, uint32_t h) { return std::vector<float>(size_t{w} * h * 4, 0.f); }

TEST_CASE("foreground PSNR: over the source's non-background pixels only") {
  const uint32_t w = 20, h = 12;
  auto ref = black_rgba(w, h);
  // Foreground: a 5x4 block of grey at alpha 0.5.
  for (uint32_t y = 2; y < 6; ++y) {
    for (uint32_t x = 3; x < 8; ++x) {
      float* p = &ref[(size_t{y} * w + x) * 4];
      p[0] = p[1] = p[2] = 0.5f;
      p[3] = 0.5f;
    }
  }
  auto cand = ref;
  for (size_t p = 0; p < size_t{w} * h; ++p) {
    if (ref[p * 4 + 3] > 0.f) cand[p * 4 + 1] += 0.1f;  // green off by 0.1 on the foreground
  }
  auto f = rgs::runtime::foreground_psnr({ref.data(), w, h, 4}, {cand.data(), w, h, 4});
  REQUIRE(f.ok());
  CHECK(f->pixels == 20);
  CHECK(f->total_pixels == w * h);
  // MSE over the foreground: one of three values off by d (0.1 in float arithmetic) -> d² / 3.
  const double d = double(0.5f + 0.1f) - 0.5;
  CHECK(f->psnr_db == doctest::Approx(10 * std::log10(3.0 / (d * d))).epsilon(1e-12));
  // The whole frame adds 220 black pixels with no error: inflated by exactly 10·log10(240 / 20) dB.
  auto whole = rgs::runtime::compare_images({ref.data(), w, h, 4}, {cand.data(), w, h, 4});
  REQUIRE(whole.ok());
  CHECK(whole->psnr_db - f->psnr_db == doctest::Approx(10 * std::log10(240.0 / 20.0)).epsilon(1e-9));

  // A pixel with alpha > 0 but black colour (a dark splat) and one with colour but alpha 0 both count.
  ref[(size_t{10} * w + 15) * 4 + 3] = 0.2f;
  ref[(size_t{0} * w + 0) * 4 + 2] = 0.3f;
  cand = ref;
  auto same = rgs::runtime::foreground_psnr({ref.data(), w, h, 4}, {cand.data(), w, h, 4});
  REQUIRE(same.ok());
  CHECK(same->pixels == 22);
  CHECK(std::isinf(same->psnr_db));

  // A candidate's stray colour on the source's background is not in the foreground PSNR.
  cand[(size_t{11} * w + 19) * 4 + 0] = 1.f;
  auto stray = rgs::runtime::foreground_psnr({ref.data(), w, h, 4}, {cand.data(), w, h, 4});
  REQUIRE(stray.ok());
  CHECK(std::isinf(stray->psnr_db));
  CHECK(std::isfinite(rgs::runtime::compare_images({ref.data(), w, h, 4}, {cand.data(), w, h, 4})->psnr_db));
}

TEST_CASE("foreground PSNR: RGB input (colour decides), no foreground, bad inputs") {
  const uint32_t w = 12, h = 11;
  std::vector<float> ref(size_t{w} * h * 3, 0.f), cand(size_t{w} * h * 3, 0.f);
  ref[(size_t{4} * w + 4) * 3 + 0] = 0.8f;     // one red pixel
  ref[(size_t{5} * w + 5) * 3 + 1] = -0.5f;    // clamps to 0: background
  ref[(size_t{6} * w + 6) * 3 + 2] = std::nanf("");  // NaN counts as 0: background
  cand[(size_t{4} * w + 4) * 3 + 0] = 0.6f;
  auto f = rgs::runtime::foreground_psnr({ref.data(), w, h, 3}, {cand.data(), w, h, 3});
  REQUIRE(f.ok());
  CHECK(f->pixels == 1);
  const double d = double(0.8f) - double(0.6f);
  CHECK(f->psnr_db == doctest::Approx(10 * std::log10(3.0 / (d * d))).epsilon(1e-12));

  const std::vector<float> black(size_t{w} * h * 3, 0.f);
  auto none = rgs::runtime::foreground_psnr({black.data(), w, h, 3}, {cand.data(), w, h, 3});
  REQUIRE(none.ok());
  CHECK(none->pixels == 0);
  CHECK(std::isnan(none->psnr_db));

  CHECK(rgs::runtime::foreground_psnr({ref.data(), w, h, 3}, {cand.data(), w, h - 1, 3}).status().code() ==
        rgs::StatusCode::kInvalidArgument);
  CHECK(rgs::runtime::foreground_psnr({nullptr, w, h, 3}, {cand.data(), w, h, 3}).status().code() ==
        rgs::StatusCode::kInvalidArgument);
}

TEST_CASE("compare_images: bad inputs are kInvalidArgument") {
  const auto a = random_image(12, 12, 6);
  CHECK(rgs::runtime::compare_images({a.data(), 12, 12, 3}, {a.data(), 12, 11, 3}).status().code() ==
        rgs::StatusCode::kInvalidArgument);
  CHECK(rgs::runtime::compare_images({a.data(), 12, 12, 2}, {a.data(), 12, 12, 3}).status().code() ==
        rgs::StatusCode::kInvalidArgument);
  CHECK(rgs::runtime::compare_images({nullptr, 12, 12, 3}, {a.data(), 12, 12, 3}).status().code() ==
        rgs::StatusCode::kInvalidArgument);
}

}  // namespace
