// Anti-aliased scenes on the GPU (docs/RENDERER.md#anti-aliased-scenes): the guitar flagged as trained with
// Mip-Splatting's 2D filter, as a .rgs (compact and FP32 views), against the CPU reference of the same flagged
// scene. The baseline pipeline keeps the suite's bounds (test_gpu_baseline.cpp: max |Δ| ≤ 0.02, PSNR ≥ 70 dB);
// every preset must be far closer to the flagged reference than the flagged and unflagged references are to
// each other (at 160×96 most of the guitar's Gaussians are below a pixel, where the factor is << 1), and the
// flag may only lower the accumulated opacity.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"

namespace rgs::test {
namespace {

using runtime::Camera;

/// samples/guitar.ply quantized into an in-memory .rgs with the antialiased flag (or without): the GPU scene
/// from the file and the CPU reference's cloud, format::dequantize of what the file holds (flag included).
GpuScenePair guitar_rgs(bool antialiased, std::vector<uint8_t>* bytes) {
  auto ply = converter::read_ply(repo_path("samples/guitar.ply"));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  ply->cloud.antialiased = antialiased;
  auto encoded = converter::quantize(ply->cloud, converter::QuantizeOptions{});
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  auto serialized = format::serialize_scene(*encoded, format::WriteOptions{});
  REQUIRE_MESSAGE(serialized.ok(), serialized.status().to_string());
  *bytes = std::move(serialized).value();
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size(), {}, "guitar_antialiased.rgs");
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  REQUIRE(file->metadata().antialiased == antialiased);
  GpuScenePair pair = pair_from_rgs(*file);
  REQUIRE(pair.cloud.antialiased == antialiased);
  REQUIRE(pair.gpu->antialiased() == antialiased);
  return pair;
}

std::vector<float> rgba_of(const runtime::RenderResult& r) {
  std::vector<float> rgba(r.alpha.size() * 4);
  for (size_t p = 0; p < r.alpha.size(); ++p) {
    for (int c = 0; c < 3; ++c) rgba[p * 4 + c] = r.rgb[p * 3 + c];
    rgba[p * 4 + 3] = r.alpha[p];
  }
  return rgba;
}

runtime::RenderResult render_reference(const format::GaussianCloud& cloud, const Camera& cam) {
  auto r = runtime::render_cpu(cloud, cam);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

double max_alpha_diff(const std::vector<float>& rgba, const std::vector<float>& alpha) {
  double m = 0;
  for (size_t p = 0; p < alpha.size(); ++p) m = std::max(m, std::fabs(double(rgba[p * 4 + 3]) - alpha[p]));
  return m;
}

}  // namespace

TEST_CASE("antialiased guitar: every preset renders the flagged CPU reference, and the flag lowers opacity") {
  if (!have_gpu()) return;
  std::vector<uint8_t> flagged_bytes, plain_bytes;
  const GpuScenePair flagged = guitar_rgs(true, &flagged_bytes);
  const GpuScenePair plain = guitar_rgs(false, &plain_bytes);
  auto cams = runtime::orbit_cameras(flagged.bounds, 2, 160, 96);
  REQUIRE(cams.ok());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  for (const Camera& cam : *cams) {
    CAPTURE(cam.name);
    const runtime::RenderResult ref = render_reference(flagged.cloud, cam);
    const runtime::RenderResult ref_plain = render_reference(plain.cloud, cam);
    // The flag only lowers opacities, and accumulated opacity is monotonic in each except at saturation (the stop
    // before T < 1e-4 drops a larger alpha that a smaller one lets through).
    double lowered = 0;
    for (size_t p = 0; p < ref.alpha.size(); ++p) {
      if (ref_plain.alpha[p] < 0.99f) CHECK(ref.alpha[p] <= ref_plain.alpha[p] + 1e-3f);
      lowered += ref_plain.alpha[p] - ref.alpha[p];
    }
    const double effect = compare_rgb(rgba_of(ref_plain), ref.rgb).psnr;
    MESSAGE(cam.name << ": mean alpha lowered by " << lowered / double(ref.alpha.size()) << ", flagged vs unflagged "
                     << effect << " dB");
    CHECK(lowered > 0);
    CHECK(effect < 45.0);

    // The baseline pipeline (FP32 view): the suite's bounds against the CPU reference.
    const GpuFrame base = render_gpu(*renderer, *flagged.gpu, cam, runtime::GpuRenderOptions{}, false);
    const Diff base_diff = compare_rgb(base.rgba, ref.rgb);
    CHECK_FALSE(base_diff.any_nan);
    CHECK(base_diff.max_abs <= 0.02);
    CHECK(max_alpha_diff(base.rgba, ref.alpha) <= 0.02);
    CHECK(base_diff.psnr >= 70.0);
    CHECK(base.stats.pairs == ref.stats.pairs);

    // Every preset (compact and FP32 attributes): much nearer the flagged reference than the unflagged one is.
    for (runtime::Preset preset : {runtime::Preset::kFastest, runtime::Preset::kFaithful, runtime::Preset::kPaper}) {
      for (bool compact : {true, false}) {
        CAPTURE(int(preset));
        CAPTURE(compact);
        const GpuFrame f = render_gpu(*renderer, *flagged.gpu, cam, preset_techniques_options(preset, compact),
                                      false);
        const Diff d = compare_rgb(f.rgba, ref.rgb);
        const Diff d_plain = compare_rgb(f.rgba, ref_plain.rgb);
        MESSAGE(cam.name << " preset " << int(preset) << (compact ? " compact" : " fp32") << ": " << d.psnr
                         << " dB against the flagged reference, " << d_plain.psnr << " dB against the unflagged");
        CHECK_FALSE(d.any_nan);
        CHECK(d.psnr >= effect + 10.0);
        CHECK(d.psnr > d_plain.psnr + 10.0);
        // The unflagged scene renders as before: the same preset on it is far from the flagged reference.
        const GpuFrame g = render_gpu(*renderer, *plain.gpu, cam, preset_techniques_options(preset, compact),
                                      false);
        CHECK(compare_rgb(g.rgba, ref_plain.rgb).psnr > compare_rgb(g.rgba, ref.rgb).psnr + 10.0);
      }
    }
  }
}

}  // namespace rgs::test
