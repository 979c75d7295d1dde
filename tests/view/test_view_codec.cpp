// Frame images: lossless WebP decodes (libwebp) to exactly the RGB encoded; lossy JPEG and WebP decode to the
// frame's size close to it; compare_rgb's PSNR, largest difference and heatmap on constructed images.
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <turbojpeg.h>
#include <webp/decode.h>

#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/parallel/worker_pool.h"
#include "rgs/view/image_codec.h"
#include "test_data.h"
#include "view_test_util.h"

namespace {

using namespace rgs;
using test::decode_jpeg;
using test::decode_webp;

// A real frame: the guitar sample rendered by the CPU reference, 8-bit RGB.
std::vector<uint8_t> guitar_rgb(uint32_t w, uint32_t h) {
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  auto scene = api::load(test::repo_path("samples/guitar.ply"), cpu);
  REQUIRE(scene.ok());
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(renderer.ok());
  auto cams = runtime::orbit_cameras(scene->info().bounds, 1, w, h);
  REQUIRE(cams.ok());
  api::RenderSettings settings;
  settings.background = {0.1f, 0.2f, 0.3f};
  auto image = renderer->render_image(*scene, (*cams)[0], settings, api::PixelFormat::kRgba8);
  REQUIRE(image.ok());
  std::vector<uint8_t> rgba(size_t(w) * h * 4), rgb(size_t(w) * h * 3);
  REQUIRE(image->copy_to_host(rgba.data(), nullptr).ok());
  for (size_t p = 0; p < size_t(w) * h; ++p) {
    for (int c = 0; c < 3; ++c) rgb[p * 3 + c] = rgba[p * 4 + c];
  }
  return rgb;
}

double psnr(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
  return 10 * std::log10(255.0 * 255.0 / (sum / double(a.size())));
}

}  // namespace

TEST_CASE("encode_rgb: lossless WebP decodes to the same bytes, lossy codecs to a close image of the same size") {
  const uint32_t W = 333, H = 197;  // odd sizes: no alignment assumed
  const std::vector<uint8_t> rgb = guitar_rgb(W, H);
  size_t distinct = 0;
  for (size_t i = 3; i < rgb.size(); i += 3) distinct += rgb[i] != rgb[i - 3];
  REQUIRE(distinct > 1000);  // the frame is not flat

  auto lossless = view::encode_rgb(rgb.data(), W, H, view::Encoding::kLossless, 1);
  REQUIRE(lossless.ok());
  int w = 0, h = 0;
  CHECK(decode_webp(*lossless, &w, &h) == rgb);
  CHECK(w == int(W));
  CHECK(h == int(H));

  auto webp = view::encode_rgb(rgb.data(), W, H, view::Encoding::kWebp, 90);
  REQUIRE(webp.ok());
  const std::vector<uint8_t> webp_rgb = decode_webp(*webp, &w, &h);
  CHECK(w == int(W));
  CHECK(webp_rgb != rgb);
  CHECK(psnr(rgb, webp_rgb) > 30.0);

  for (int quality : {50, 95}) {
    CAPTURE(quality);
    auto jpeg = view::encode_rgb(rgb.data(), W, H, view::Encoding::kJpeg, quality);
    REQUIRE(jpeg.ok());
    CHECK((*jpeg)[0] == 0xFF);
    CHECK((*jpeg)[1] == 0xD8);
    tjhandle d = tjInitDecompress();
    int jw = 0, jh = 0, sub = 0, space = 0;
    REQUIRE(tjDecompressHeader3(d, jpeg->data(), jpeg->size(), &jw, &jh, &sub, &space) == 0);
    CHECK(jw == int(W));
    CHECK(jh == int(H));
    CHECK(sub == (quality >= 90 ? TJSAMP_444 : TJSAMP_420));
    std::vector<uint8_t> out(size_t(W) * H * 3);
    REQUIRE(tjDecompress2(d, jpeg->data(), jpeg->size(), out.data(), jw, jw * 3, jh, TJPF_RGB, 0) == 0);
    tjDestroy(d);
    CHECK(psnr(rgb, out) > (quality >= 90 ? 35.0 : 28.0));
  }
  // Deterministic.
  CHECK(*view::encode_rgb(rgb.data(), W, H, view::Encoding::kLossless, 1) == *lossless);

  CHECK(view::encode_rgb(rgb.data(), 0, H, view::Encoding::kJpeg, 80).status().code() ==
        StatusCode::kInvalidArgument);
  CHECK(view::encode_rgb(rgb.data(), W, H, view::Encoding::kJpeg, 0).status().code() == StatusCode::kInvalidArgument);
  CHECK(view::encode_rgb(nullptr, W, H, view::Encoding::kWebp, 80).status().code() == StatusCode::kInvalidArgument);
}

namespace {

/// How many restart markers (FF D0..D7) the entropy-coded data holds: byte-stuffed FF 00 is data, and no other
/// marker may appear there.
size_t restart_markers(const std::vector<uint8_t>& jpeg) {
  size_t sos = 0;
  for (size_t i = 2; i + 1 < jpeg.size(); ++i) {
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xDA) {
      sos = i;
      break;
    }
  }
  REQUIRE(sos != 0);
  size_t n = 0;
  for (size_t i = sos + 2 + (size_t(jpeg[sos + 2]) << 8 | jpeg[sos + 3]); i + 2 < jpeg.size(); ++i) {
    if (jpeg[i] != 0xFF || jpeg[i + 1] == 0x00) continue;
    CHECK(jpeg[i + 1] == uint8_t(0xD0 + n % 8));  // RST0..RST7 in turn
    ++n;
  }
  return n;
}

}  // namespace

TEST_CASE("encode_rgb on workers: strips joined by restart markers decode to exactly the one-thread JPEG's pixels") {
  parallel::WorkerPool workers(4);
  REQUIRE(workers.workers() == 4);
  // 4:2:0 (quality 85, 16-row MCUs) and 4:4:4 (95, 8-row MCUs); heights with a short last strip, and one too low
  // to split (fewer than 2 x 4 MCU rows), which is encoded in one thread.
  struct Case {
    uint32_t w, h;
    int quality;
    size_t markers;
  };
  for (const Case c : {Case{640, 360, 85, 3}, Case{333, 197, 85, 2}, Case{333, 197, 95, 3}, Case{1001, 100, 95, 2},
                       Case{320, 100, 85, 0}}) {
    CAPTURE(c.w);
    CAPTURE(c.h);
    CAPTURE(c.quality);
    const std::vector<uint8_t> rgb = guitar_rgb(c.w, c.h);
    auto one = view::encode_rgb(rgb.data(), c.w, c.h, view::Encoding::kJpeg, c.quality);
    auto strips = view::encode_rgb(rgb.data(), c.w, c.h, view::Encoding::kJpeg, c.quality, 3, &workers);
    REQUIRE(one.ok());
    REQUIRE(strips.ok());
    CHECK(restart_markers(*strips) == c.markers);
    if (c.markers == 0) CHECK(*strips == *one);
    // The same blocks: the decoded pixels are identical, not only close.
    CHECK(decode_jpeg(*strips, c.w, c.h) == decode_jpeg(*one, c.w, c.h));
    // Per strip the marker, a padded byte and the absolute DC of its first blocks; the DRI segment once.
    CHECK(strips->size() <= one->size() + (c.markers > 0 ? 6 : 0) + 8 * c.markers);
    // The same bytes on every run and for any scheduling of the strips.
    CHECK(*view::encode_rgb(rgb.data(), c.w, c.h, view::Encoding::kJpeg, c.quality, 3, &workers) == *strips);
  }
}

TEST_CASE("compare_rgb: PSNR, largest difference and the heatmap's scale") {
  const uint32_t W = 64, H = 32;
  std::vector<uint8_t> a(W * H * 3), b;
  std::mt19937 rng(7);
  for (auto& v : a) v = uint8_t(rng() % 200);
  b = a;
  auto same = view::compare_rgb(a.data(), b.data(), W, H, 32, nullptr);
  CHECK(same.mse == 0);
  CHECK_FALSE(same.psnr_db.has_value());
  CHECK(same.max_abs == 0);

  // One channel of every pixel off by 10: mse = 100/3, PSNR = 10 log10(255² · 3 / 100).
  for (size_t p = 0; p < W * H; ++p) b[p * 3 + 1] = uint8_t(b[p * 3 + 1] + 10);
  b[5 * 3 + 2] = uint8_t(a[5 * 3 + 2] + 40);  // and one pixel's blue off by 40
  std::vector<uint8_t> heat;
  auto diff = view::compare_rgb(a.data(), b.data(), W, H, 40, &heat);
  const double mse = (100.0 * W * H + 1600.0) / (3.0 * W * H);
  CHECK(diff.mse == doctest::Approx(mse));
  REQUIRE(diff.psnr_db.has_value());
  CHECK(*diff.psnr_db == doctest::Approx(10 * std::log10(255.0 * 255.0 / mse)));
  CHECK(diff.max_abs == 40);
  REQUIRE(heat.size() == W * H * 3);
  // Pixel 5 is at the top of the colour map (turbo's dark red), the others at a quarter (blue-cyan); a pixel
  // with no difference is turbo(0), nearly black.
  CHECK(heat[5 * 3 + 0] > heat[5 * 3 + 2]);
  CHECK(heat[0 * 3 + 2] > heat[0 * 3 + 0]);
  CHECK(heat[0] == heat[6 * 3]);
  std::vector<uint8_t> zero_heat;
  view::compare_rgb(a.data(), a.data(), W, H, 40, &zero_heat);
  CHECK(int(zero_heat[0]) + zero_heat[1] + zero_heat[2] < 100);
  CHECK(int(heat[0]) + heat[1] + heat[2] > 200);
}
