// Scenes trained with the 2D Mip filter (Mip-Splatting; gsplat's rasterize_mode="antialiased"): every renderer
// scales each opacity by sqrt(det Σ₂ / det(Σ₂ + 0.3·I)) (kernels::antialias_compensation), checked against that
// formula on single Gaussians for every preset on the CPU reference and, with a device, on the GPU; the flag
// survives every conversion that can hold it (.rgs runtime and archive profiles, levels of detail, SPZ) and
// --antialiased reads it into formats that cannot (PLY), whose outputs say they drop it.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/config.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

constexpr uint32_t kSide = 41;
constexpr float kFocal = 100.f, kDepth = 10.f, kOpacity = 0.9f;

/// One isotropic Gaussian of linear scale `scale` on the optical axis at depth kDepth, white, opacity kOpacity,
/// and one outside the view, so that the scene's bounds have depth (RoofGS's depth key quantizes over them).
format::GaussianCloud single_gaussian(float scale, bool antialiased) {
  format::GaussianCloud cloud;
  cloud.resize(2);
  cloud.means = {0.f, 0.f, kDepth, 0.f, 50.f, 2.f * kDepth};
  cloud.rotations = {1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f};
  cloud.scales = {scale, scale, scale, scale, scale, scale};
  cloud.opacities = {kOpacity, kOpacity};
  const float dc = (1.f - 0.5f) / 0.28209479177387814f;  // SH DC of colour 1
  cloud.sh = {dc, dc, dc, dc, dc, dc};
  cloud.antialiased = antialiased;
  return cloud;
}

/// A camera at the origin looking down +z whose centre pixel (20, 20) holds the Gaussian's mean (px = fx·x/z +
/// cx − 0.5): its projected covariance there is (fx·s/z)²·I.
runtime::Camera axis_camera() {
  runtime::Camera c;
  c.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.translation = {0, 0, 0};
  c.fx = c.fy = kFocal;
  c.cx = c.cy = 20.5f;
  c.width = c.height = kSide;
  return c;
}

/// The alpha (1 − T) of the centre pixel of a render of `cloud` with `preset` on `device`.
float centre_alpha(format::GaussianCloud cloud, api::Preset preset, api::Device device) {
  api::LoadOptions load;
  load.device = device;
  load.presets = {preset};
  const format::SceneBounds bounds = converter::compute_bounds(cloud);
  auto scene = api::load_cloud(std::move(cloud), bounds, "single", load);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto renderer = api::Renderer::create(device);
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  api::RenderSettings settings;
  settings.preset = preset;
  auto image = renderer->render_image(*scene, axis_camera(), settings);
  REQUIRE_MESSAGE(image.ok(), image.status().to_string());
  std::vector<float> rgba(size_t(kSide) * kSide * 4);
  REQUIRE(image->copy_to_host(rgba.data(), nullptr).ok());
  return rgba[(size_t(20) * kSide + 20) * 4 + 3];
}

/// The compensation of an isotropic projected Gaussian of standard deviation `sigma` pixels.
double expected_factor(double sigma) { return sigma * sigma / (sigma * sigma + 0.3); }

void check_formula(api::Device device) {
  for (api::Preset preset : {api::Preset::kFaithful, api::Preset::kFastest, api::Preset::kPaper}) {
    // paper's fast exponential is within 3.2 % (kernels/shared/fast_exp.h); binary16 alphas within 0.05 %.
    const double tolerance = preset == api::Preset::kPaper ? 0.035 : 2e-3;
    for (float scale : {0.004f, 0.01f, 0.05f, 0.5f}) {
      const double sigma = double(kFocal) * scale / kDepth;
      const double factor = expected_factor(sigma);
      CAPTURE(std::string(api::preset_name(preset)));
      CAPTURE(sigma);
      const float classic = centre_alpha(single_gaussian(scale, false), preset, device);
      const float antialiased = centre_alpha(single_gaussian(scale, true), preset, device);
      CHECK(classic == doctest::Approx(kOpacity).epsilon(tolerance));
      CHECK(antialiased == doctest::Approx(kOpacity * factor).epsilon(tolerance));
    }
  }
}

/// The .rgs flag of `path` (SPEC §2.2).
bool rgs_flag(const std::string& path) {
  auto file = format::RgsFile::open(path);
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  return file->metadata().antialiased;
}

}  // namespace

TEST_CASE("anti-aliased: the CPU reference scales each opacity by the 2D filter's compensation, every preset") {
  check_formula(api::Device::kCpu);
}

TEST_CASE("anti-aliased: the GPU scales each opacity by the 2D filter's compensation, every preset") {
#if !RGS_HAS_CUDA
  MESSAGE("skipped: this build has no CUDA support");
#else
  std::string why;
  if (!api::cuda_available(&why)) {
    MESSAGE("skipped: no CUDA device (" << why << ")");
    return;
  }
  check_formula(api::Device::kCuda);
#endif
}

TEST_CASE("anti-aliased: the flag survives .rgs (runtime, archive, levels of detail) and SPZ, and PLY outputs say they drop it") {
  test::TempDir dir;
  const std::string ply = test::repo_path("samples/guitar.ply");
  api::ConvertOptions read_aa;
  read_aa.read.antialiased = true;

  // Without the option a PLY is not anti-aliased, with it the .rgs carries the flag (in a 1.6 file).
  REQUIRE(api::convert(ply, dir.file("plain.rgs"), api::ConvertOptions{}).ok());
  CHECK_FALSE(rgs_flag(dir.file("plain.rgs")));
  REQUIRE(api::convert(ply, dir.file("aa.rgs"), read_aa).ok());
  CHECK(rgs_flag(dir.file("aa.rgs")));
  {
    auto file = format::RgsFile::open(dir.file("aa.rgs"));
    REQUIRE(file.ok());
    CHECK(file->header().minor >= 6);
    CHECK((file->header().required_flags & format::kRequiredFlagAntialiased) != 0);
  }
  // A .rgs carries it on to every output that can hold it, with no option.
  api::ConvertOptions archive;
  archive.profile = format::StorageProfile::kArchive;
  REQUIRE(api::convert(dir.file("aa.rgs"), dir.file("aa_archive.rgs"), archive).ok());
  CHECK(rgs_flag(dir.file("aa_archive.rgs")));
  api::ConvertOptions lod;
  lod.lod_levels = 0;  // auto
  REQUIRE(api::convert(dir.file("aa.rgs"), dir.file("aa_lod.rgs"), lod).ok());
  CHECK(rgs_flag(dir.file("aa_lod.rgs")));
  REQUIRE(api::convert(dir.file("aa.rgs"), dir.file("aa.spz"), api::ConvertOptions{}).ok());
  auto spz = converter::read_scene(dir.file("aa.spz"));
  REQUIRE(spz.ok());
  CHECK(spz->cloud.antialiased);
  REQUIRE(api::convert(dir.file("aa.spz"), dir.file("from_spz.rgs"), api::ConvertOptions{}).ok());
  CHECK(rgs_flag(dir.file("from_spz.rgs")));
  // An option does not unset what a .rgs says.
  auto rgs_read = converter::read_scene(dir.file("aa.rgs"));
  REQUIRE(rgs_read.ok());
  CHECK(rgs_read->cloud.antialiased);

  // PLY cannot hold it: the report says so, and the file reads back without it.
  auto to_ply = api::convert(dir.file("aa.rgs"), dir.file("back.ply"), api::ConvertOptions{});
  REQUIRE(to_ply.ok());
  bool noted = false;
  for (const std::string& note : to_ply->output_notes) noted |= note.find("--antialiased") != std::string::npos;
  CHECK(noted);
  auto back = converter::read_scene(dir.file("back.ply"));
  REQUIRE(back.ok());
  CHECK_FALSE(back->cloud.antialiased);

  // Loaded for rendering, the scene says it is anti-aliased, and its renders differ from the plain file's.
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  auto aa_scene = api::load(dir.file("aa.rgs"), cpu);
  auto plain_scene = api::load(dir.file("plain.rgs"), cpu);
  REQUIRE(aa_scene.ok());
  REQUIRE(plain_scene.ok());
  CHECK(aa_scene->info().antialiased);
  CHECK_FALSE(plain_scene->info().antialiased);
}
