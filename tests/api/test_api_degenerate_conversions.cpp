// Scenes that leave a quantizer or the views nothing to span, converted through every path api::convert offers
// (the runtime profile, the archive profile, a PSNR target, a byte target, levels of detail) and rendered by the
// CPU reference on their default views: each output renders as the runtime profile's file does within the path's
// stated error, or the conversion fails with a clear error naming the input. The corpus is made from the first
// Gaussians of the SH-degree-3 guitar excerpt: one scale axis constant at several log-scales (2D-Gaussian and surfel
// exports write -inf; linear FP16 flushes the smaller ones to 0), all scales equal, one Gaussian, one Gaussian
// repeated, constant opacity, constant colour, no SH rest, and every mean at one point (a scene of no extent).
// The errors each path promises: docs/AUDITS.md#degenerate-scenes.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/api/convert.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/runtime/image_metrics.h"
#include "gaussian_subset.h"
#include "sanitized.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;
using test::first_gaussians;

constexpr size_t kCorpusGaussians = 3000;
/// The views every output is rendered on (and rate control measures on): the default views at this size.
constexpr uint32_t kViewWidth = 160, kViewHeight = 90;
/// The PSNR target of the corpus's rate-control conversions, dB.
constexpr double kTargetDb = 40;
/// The archive profile's default settings on the corpus, against the runtime profile: at least this, dB
/// (docs/AUDITS.md#degenerate-scenes); its SH steps are half SPZ's (format::kSpzShSteps).
constexpr double kArchiveDb = 45;
/// The rate-control conversions (a PSNR and a byte target) run on every corpus scene, or under the sanitizers,
/// where their searches take over twenty minutes, on every fourth.
constexpr size_t kTargetsEvery = test::kSanitized ? 4 : 1;

struct Case {
  std::string name;
  format::GaussianCloud cloud;
};

/// `base` with `edit` applied to each Gaussian i.
format::GaussianCloud edited(const format::GaussianCloud& base, const std::function<void(format::GaussianCloud&, size_t)>& edit) {
  format::GaussianCloud c = base;
  for (size_t i = 0; i < c.size(); ++i) edit(c, i);
  return c;
}

std::vector<Case> degenerate_corpus() {
  converter::SceneReadOptions exact;
  auto input = converter::read_scene(test::repo_path(test::kGuitarSh3), exact);
  REQUIRE_MESSAGE(input.ok(), input.status().to_string());
  const format::GaussianCloud base = first_gaussians(input->cloud, kCorpusGaussians);
  const size_t sh = size_t{base.sh_coefficients()} * 3;
  std::vector<Case> corpus;
  for (const double log_scale : {-std::numeric_limits<double>::infinity(), -30.0, -20.0, -17.0, -13.8155, -3.3}) {
    corpus.push_back({"flat axis at log-scale " + std::to_string(log_scale),
                      edited(base, [&](format::GaussianCloud& c, size_t i) {
                        c.scales[i * 3 + 2] = static_cast<float>(std::exp(log_scale));
                      })});
  }
  corpus.push_back({"all scales equal", edited(base, [&](format::GaussianCloud& c, size_t i) {
                      std::fill_n(&c.scales[i * 3], 3, base.scales[0]);
                    })});
  corpus.push_back({"one Gaussian", first_gaussians(base, 1)});
  corpus.push_back({"one Gaussian repeated", first_gaussians(base, kCorpusGaussians, true)});
  corpus.push_back({"constant opacity", edited(base, [&](format::GaussianCloud& c, size_t i) {
                      c.opacities[i] = base.opacities[0];
                    })});
  corpus.push_back({"constant colour", edited(base, [&](format::GaussianCloud& c, size_t i) {
                      std::copy_n(&base.sh[0], 3, &c.sh[i * sh]);
                    })});
  corpus.push_back({"no SH rest", edited(base, [&](format::GaussianCloud& c, size_t i) {
                      std::fill(c.sh.begin() + i * sh + 3, c.sh.begin() + (i + 1) * sh, 0.0f);
                    })});
  corpus.push_back({"every mean at one point", edited(base, [&](format::GaussianCloud& c, size_t i) {
                      std::copy_n(&base.means[0], 3, &c.means[i * 3]);
                    })});
  return corpus;
}

/// The CPU reference's renders of the file at `path` (full detail) on `cameras`, faithful preset, RGBA float32.
std::vector<std::vector<float>> render_file(const std::string& path, const std::vector<runtime::Camera>& cameras) {
  api::LoadOptions load;
  load.device = api::Device::kCpu;
  load.lod.enabled = false;  // a level-of-detail file's full detail
  auto scene = api::load(path, load);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  api::RenderSettings settings;
  settings.preset = api::Preset::kFaithful;
  std::vector<std::vector<float>> images;
  for (const runtime::Camera& cam : cameras) {
    auto image = renderer->render_image(*scene, cam, settings);
    REQUIRE_MESSAGE(image.ok(), image.status().to_string());
    const float* rgba = static_cast<const float*>(image->color());
    images.emplace_back(rgba, rgba + size_t{cam.width} * cam.height * 4);
    for (const float v : images.back()) REQUIRE(std::isfinite(v));
  }
  return images;
}

/// Mean PSNR (dB, runtime::compare_images over the whole frame) of `b` against `a`.
double mean_psnr(const std::vector<std::vector<float>>& a, const std::vector<std::vector<float>>& b,
                 const std::vector<runtime::Camera>& cameras) {
  double sum = 0;
  for (size_t v = 0; v < cameras.size(); ++v) {
    auto m = runtime::compare_images({a[v].data(), cameras[v].width, cameras[v].height, 4},
                                     {b[v].data(), cameras[v].width, cameras[v].height, 4});
    REQUIRE_MESSAGE(m.ok(), m.status().to_string());
    sum += m->psnr_db;
  }
  return sum / double(cameras.size());
}

api::CameraChoice corpus_views() {
  api::CameraChoice choice;
  choice.width = kViewWidth;
  choice.height = kViewHeight;
  return choice;
}

}  // namespace

TEST_CASE("degenerate scenes: every profile, target and levels of detail render as the runtime profile, or fail naming the input" *
          doctest::test_suite("slow")) {
  test::TempDir dir;
  const std::vector<Case> corpus = degenerate_corpus();
  if (kTargetsEvery > 1) MESSAGE("skipped: the rate-control conversions of 3 in 4 degenerate scenes (sanitizers)");
  for (size_t index = 0; index < corpus.size(); ++index) {
    const Case& c = corpus[index];
    CAPTURE(c.name);
    const std::string name = dir.file("degenerate.ply");  // stands for the source; nothing is beside it
    api::ConvertOptions runtime_options;
    runtime_options.converter_name = "test";
    const std::string runtime_file = dir.file("runtime.rgs");
    auto runtime_written = api::convert_cloud(c.cloud, name, runtime_file, runtime_options);
    REQUIRE_MESSAGE(runtime_written.ok(), runtime_written.status().to_string());
    auto views = api::default_views(name, c.cloud, corpus_views());
    REQUIRE_MESSAGE(views.ok(), views.status().to_string());
    const std::vector<runtime::Camera>& cameras = views->cameras;
    const auto reference = render_file(runtime_file, cameras);
    auto psnr_of = [&](const std::string& file) { return mean_psnr(reference, render_file(file, cameras), cameras); };

    api::ConvertOptions archive = runtime_options;
    archive.profile = format::StorageProfile::kArchive;
    const std::string archive_file = dir.file("archive.rgs");
    auto archive_written = api::convert_cloud(c.cloud, name, archive_file, archive);
    REQUIRE_MESSAGE(archive_written.ok(), archive_written.status().to_string());
    CHECK(psnr_of(archive_file) >= kArchiveDb);

    api::ConvertOptions lod = runtime_options;
    lod.lod_levels = 0;
    const std::string lod_file = dir.file("lod.rgs");
    auto lod_written = api::convert_cloud(c.cloud, name, lod_file, lod);
    REQUIRE_MESSAGE(lod_written.ok(), lod_written.status().to_string());
    CHECK(psnr_of(lod_file) == std::numeric_limits<double>::infinity());  // the same Gaussians, in chunk order

    if (index % kTargetsEvery != 0) continue;
    api::ConvertOptions psnr = runtime_options;
    psnr.target.psnr_db = kTargetDb;
    psnr.target.views = corpus_views();
    const std::string psnr_file = dir.file("psnr.rgs");
    auto psnr_written = api::convert_cloud(c.cloud, name, psnr_file, psnr);
    REQUIRE_MESSAGE(psnr_written.ok(), psnr_written.status().to_string());
    CHECK(psnr_of(psnr_file) >= kTargetDb);

    // Half the bytes of an archive at the fixed fine settings (SH multipliers 1/3/5/6, position error 2^-17, no
    // floor): a file within them, or (a scene of a few hundred bytes of Gaussians, where the file's fixed part is
    // most of it) the smallest archive's size, naming the input.
    api::ConvertOptions fine = archive;
    fine.archive.sh_step_multipliers = format::kArchiveShMultipliers;
    fine.archive.position_error = format::kDefaultArchivePositionError;
    fine.archive.opacity_floor = 0;
    auto fine_written = api::convert_cloud(c.cloud, name, dir.file("fine.rgs"), fine);
    REQUIRE_MESSAGE(fine_written.ok(), fine_written.status().to_string());
    api::ConvertOptions bytes = runtime_options;
    bytes.target.bytes = fine_written->output_bytes / 2;
    bytes.target.views = corpus_views();
    const std::string bytes_file = dir.file("bytes.rgs");
    auto bytes_written = api::convert_cloud(c.cloud, name, bytes_file, bytes);
    if (bytes_written.ok()) {
      CHECK(bytes_written->output_bytes <= *bytes.target.bytes);
      CHECK(psnr_of(bytes_file) >= kTargetDb);
    } else {
      CHECK((c.cloud.size() == 1 || fine_written->output_bytes < 4096));
      CHECK(bytes_written.status().code() == StatusCode::kInvalidArgument);
      const std::string message = bytes_written.status().message();
      CHECK_MESSAGE(message.find(name + ": ") == 0, message);
      CHECK_MESSAGE(message.find("below the smallest archive") != std::string::npos, message);
    }
  }
}
