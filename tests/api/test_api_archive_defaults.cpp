// The default archive (--profile archive, no other option) against SPZ (rgs-convert's .spz output): no more
// bytes, and no lower mean PSNR over orbit views, each render on the CPU reference against the source's. On the
// shipped scenes (guitar, SH 0; the SH-3 excerpt) and the real scenes of $RGS_DATA_DIR when present (biker,
// flowers, daffodils); docs/AUDITS.md#the-default-archive-against-spz states the rule and the measured table.
#include <cmath>
#include <filesystem>
#include <string>

#include <doctest/doctest.h>

#include "rgs/api/convert.h"
#include "rgs/api/preset.h"
#include "rgs/api/scene.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/preset_techniques.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

/// Mean PSNR (dB, peak 1) of `candidate`'s renders against `src`'s over 4 orbit views at 160x90 (the source's
/// bounds frame both), on the CPU reference with the faithful preset.
double render_psnr(const std::string& src, const std::string& candidate) {
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  cpu.quantize_other_formats = false;
  auto a = api::load(src, cpu);
  auto b = api::load(candidate, cpu);
  REQUIRE_MESSAGE(a.ok(), a.status().to_string());
  REQUIRE_MESSAGE(b.ok(), b.status().to_string());
  const auto bounds = a->info().bounds;
  auto cameras = runtime::orbit_cameras(bounds, 4, 160, 90);
  REQUIRE(cameras.ok());
  const runtime::RenderOptions options = runtime::cpu_backend_options(api::Preset::kFaithful, bounds);
  double sum = 0;
  for (const api::Camera& camera : *cameras) {
    auto ra = runtime::render_cpu(*a->cloud(), camera, options);
    auto rb = runtime::render_cpu(*b->cloud(), camera, options);
    REQUIRE(ra.ok());
    REQUIRE(rb.ok());
    double se = 0;
    for (size_t i = 0; i < ra->rgb.size(); ++i) se += std::pow(double(ra->rgb[i]) - rb->rgb[i], 2);
    const double mse = se / double(ra->rgb.size());
    sum += mse == 0 ? 200 : 10 * std::log10(1.0 / mse);
  }
  return sum / double(cameras->size());
}

/// Converts `src` to SPZ and to the default archive and checks the archive is no larger at no lower PSNR.
void check_against_spz(const std::string& src, const std::string& name) {
  test::TempDir dir;
  const std::string spz = dir.file(name + ".spz"), archive = dir.file(name + ".rgs");
  api::ConvertOptions options;
  options.profile = format::StorageProfile::kArchive;
  auto s = api::convert(src, spz);
  auto r = api::convert(src, archive, options);
  REQUIRE_MESSAGE(s.ok(), s.status().to_string());
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  const uint64_t spz_bytes = std::filesystem::file_size(spz), archive_bytes = std::filesystem::file_size(archive);
  const double spz_db = render_psnr(src, spz), archive_db = render_psnr(src, archive);
  MESSAGE(name << ": archive " << archive_bytes << " bytes, " << archive_db << " dB; SPZ " << spz_bytes << " bytes, "
               << spz_db << " dB");
  CHECK(archive_bytes <= spz_bytes);
  CHECK(archive_db >= spz_db);
}

}  // namespace

TEST_CASE("default archive vs SPZ: no larger, no lower PSNR, on the shipped scenes") {
  check_against_spz(test::repo_path("samples/guitar.ply"), "guitar");
  check_against_spz(test::repo_path(test::kGuitarSh3), "guitar_sh3");
}

TEST_CASE("default archive vs SPZ: no larger, no lower PSNR, on the real scenes of RGS_DATA_DIR") {
  for (const char* file : {"biker.ply", "mipnerf360_flowers_c3dgs.ply", "playcanvas_flowers_lod0.ply"}) {
    const std::string path = test::shared_scene(file);
    if (!path.empty()) check_against_spz(path, std::filesystem::path(file).stem().string());
  }
}
