// SOG output seen through renders: a scene converted to .sog renders on the CPU reference as its source does,
// within a stated PSNR (guitar from samples/, the SH-3 flowers scene from $RGS_DATA_DIR when present).
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/api/convert.h"
#include "rgs/api/preset.h"
#include "rgs/api/scene.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/preset_techniques.h"
#include "test_data.h"

namespace {

using namespace rgs;

/// Mean PSNR (dB, peak 1) over `views` orbit views at w x h of `src` and its SOG conversion, both on the CPU
/// reference with the faithful preset and the source's bounds; the smallest view's PSNR goes to `min_db`.
double sog_render_psnr(const std::string& src, const std::string& name, uint32_t views, double* min_db) {
  const auto sog = std::filesystem::temp_directory_path() / (name + ".sog");
  auto report = api::convert(src, sog.string());
  REQUIRE_MESSAGE(report.ok(), report.status().to_string());
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  cpu.quantize_other_formats = false;
  auto a = api::load(src, cpu);
  auto b = api::load(sog.string(), cpu);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  const auto bounds = a->info().bounds;
  auto cameras = runtime::orbit_cameras(bounds, views, 160, 90);
  REQUIRE(cameras.ok());
  const runtime::RenderOptions options = runtime::cpu_backend_options(api::Preset::kFaithful, bounds);
  double sum = 0;
  *min_db = 1e9;
  for (const api::Camera& camera : *cameras) {
    auto ra = runtime::render_cpu(*a->cloud(), camera, options);
    auto rb = runtime::render_cpu(*b->cloud(), camera, options);
    REQUIRE(ra.ok());
    REQUIRE(rb.ok());
    double se = 0;
    for (size_t i = 0; i < ra->rgb.size(); ++i) {
      const double d = static_cast<double>(ra->rgb[i]) - rb->rgb[i];
      se += d * d;
    }
    const double mse = se / static_cast<double>(ra->rgb.size());
    const double db = mse == 0 ? 200 : 10 * std::log10(1.0 / mse);
    sum += db;
    *min_db = std::min(*min_db, db);
  }
  std::filesystem::remove(sog);
  return sum / views;
}

}  // namespace

TEST_CASE("SOG output renders as its source: guitar within 60 dB mean, 55 dB worst view") {
  double min_db = 0;
  const double mean_db = sog_render_psnr(test::repo_path("samples/guitar.ply"), "rgs_test_api_guitar_sog", 4, &min_db);
  MESSAGE("guitar .sog: mean " << mean_db << " dB, worst view " << min_db << " dB");
  CHECK(mean_db > 60);
  CHECK(min_db > 55);
}

TEST_CASE("SOG output renders as its source: SH-3 flowers within 35 dB mean, 33 dB worst view") {
  const std::string path = test::shared_scene("mipnerf360_flowers_c3dgs.ply");
  if (path.empty()) return;
  double min_db = 0;
  const double mean_db = sog_render_psnr(path, "rgs_test_api_flowers_sog", 4, &min_db);
  MESSAGE("flowers .sog: mean " << mean_db << " dB, worst view " << min_db << " dB");
  CHECK(mean_db > 35);
  CHECK(min_db > 33);
}
