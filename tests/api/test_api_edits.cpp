// The edit chain of a conversion (ConvertOptions::edits): a rotated, translated or scaled scene seen from the
// camera moved with it renders as the scene did (CPU reference, and the GPU when there is one), the edits run in
// the order given through convert(), an out-of-core build edits its batches to the bytes of the build in memory,
// and edits that empty the scene give the empty-scene error.
#include <doctest/doctest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"
#include "rgs/converter/cloud_edits.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/image_metrics.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

/// The floor the edited renders must reach against the originals: what float32 rounding of the moved means,
/// rotations, SH and cameras leaves (docs/DESIGN.md#the-scene-pipeline).
constexpr double kMinPsnrDb = 60.0;

format::GaussianCloud guitar_sh3() {
  auto read = converter::read_scene(test::repo_path(test::kGuitarSh3));
  REQUIRE_MESSAGE(read.ok(), read.status().to_string());
  return std::move(read->cloud);
}

converter::EditAction edit(const std::string& name, const std::string& value) {
  auto parsed = converter::parse_edit_action(name, value);
  REQUIRE_MESSAGE(parsed.ok(), parsed.status().to_string());
  return std::move(parsed).value();
}

format::GaussianCloud edited(format::GaussianCloud cloud, const std::string& name, const std::string& value) {
  auto removed = converter::apply_edit(&cloud, edit(name, value));
  REQUIRE_MESSAGE(removed.ok(), removed.status().to_string());
  return cloud;
}

/// The faithful render (the 3DGS rules, FP32 attributes) of `cloud` from `camera` on `device`, RGBA float.
std::vector<float> render(const format::GaussianCloud& cloud, const runtime::Camera& camera, api::Device device) {
  api::LoadOptions load;
  load.device = device;
  auto scene = api::load_cloud(cloud, converter::compute_bounds(cloud), "guitar_sh3", load);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto renderer = api::Renderer::create(device);
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  api::RenderSettings settings;
  settings.preset = api::Preset::kFaithful;
  auto image = renderer->render_image(*scene, camera, settings);
  REQUIRE_MESSAGE(image.ok(), image.status().to_string());
  std::vector<float> rgba(size_t{camera.width} * camera.height * 4);
  REQUIRE(image->copy_to_host(rgba.data(), nullptr).ok());
  return rgba;
}

double psnr(const std::vector<float>& a, const std::vector<float>& b, const runtime::Camera& camera) {
  auto m = runtime::compare_images({a.data(), camera.width, camera.height, 4}, {b.data(), camera.width, camera.height, 4});
  REQUIRE_MESSAGE(m.ok(), m.status().to_string());
  return m->psnr_db;
}

/// The camera that sees R·p where `camera` saw p: world-to-camera rotation Rc·Rᵀ, the same translation.
runtime::Camera rotated(runtime::Camera camera, const std::array<double, 9>& r) {
  std::array<float, 9> out{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double v = 0;
      for (int k = 0; k < 3; ++k) v += double(camera.rotation[i * 3 + k]) * r[j * 3 + k];
      out[i * 3 + j] = float(v);
    }
  }
  camera.rotation = out;
  return camera;
}

/// The matrix of the rotation an edit holds (its unit quaternion w, x, y, z).
std::array<double, 9> matrix_of(const converter::EditAction& rotate) {
  const double w = rotate.values[0], x = rotate.values[1], y = rotate.values[2], z = rotate.values[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

std::vector<runtime::Camera> views(const format::GaussianCloud& cloud) {
  auto cameras = runtime::orbit_cameras(converter::compute_bounds(cloud), 3, 192, 144);
  REQUIRE_MESSAGE(cameras.ok(), cameras.status().to_string());
  return std::move(cameras).value();
}

/// render(edit(scene), moved(camera)) against render(scene, camera) over three orbit views, for rotations (axis
/// aligned, Euler, a quaternion), a translation and a scale, each PSNR at least kMinPsnrDb.
void check_invariance(api::Device device) {
  const format::GaussianCloud scene = guitar_sh3();
  REQUIRE(scene.sh_degree == 3);
  const std::vector<runtime::Camera> cameras = views(scene);
  std::vector<std::vector<float>> reference;
  for (const runtime::Camera& camera : cameras) reference.push_back(render(scene, camera, device));
  const auto check = [&](const std::string& what, const format::GaussianCloud& moved_scene, auto move_camera) {
    double worst = 1e9;
    for (size_t v = 0; v < cameras.size(); ++v) {
      const runtime::Camera camera = move_camera(cameras[v]);
      worst = std::min(worst, psnr(reference[v], render(moved_scene, camera, device), camera));
    }
    MESSAGE(std::string(api::device_name(device)) << ": " << what << ": lowest PSNR " << worst << " dB over " << cameras.size() << " views");
    CHECK_MESSAGE(worst >= kMinPsnrDb, what);
  };
  for (const auto& [name, value] : std::vector<std::pair<std::string, std::string>>{
           {"rotate", "0,90,0"}, {"rotate", "30,-40,125"}, {"rotate", "0.5,0.5,-0.5,0.5"}, {"rotate", "0.8,0.2,-0.4,0.4"}}) {
    const std::array<double, 9> r = matrix_of(edit(name, value));
    check(name + " " + value, edited(scene, name, value), [&](const runtime::Camera& c) { return rotated(c, r); });
  }
  // Without the SH rotation the colour of the rotated scene is wrong where it depends on the view: the check above
  // would fail for it (the bands 1-3 of guitar_sh3 have a real scene's RMS).
  {
    format::GaussianCloud unrotated_sh = edited(scene, "rotate", "30,-40,125");
    unrotated_sh.sh = scene.sh;
    const std::array<double, 9> r = matrix_of(edit("rotate", "30,-40,125"));
    const runtime::Camera camera = rotated(cameras[0], r);
    const double without = psnr(reference[0], render(unrotated_sh, camera, device), camera);
    MESSAGE(std::string(api::device_name(device)) << ": the same rotation with the SH left unrotated: " << without << " dB");
    CHECK(without < 45);
  }
  const double t[3] = {0.7, -1.3, 2.1};
  check("translate 0.7,-1.3,2.1", edited(scene, "translate", "0.7,-1.3,2.1"), [&](runtime::Camera c) {
    for (int i = 0; i < 3; ++i) {
      c.translation[i] = float(double(c.translation[i]) - (c.rotation[i * 3] * t[0] + c.rotation[i * 3 + 1] * t[1] +
                                                           c.rotation[i * 3 + 2] * t[2]));
    }
    return c;
  });
  check("scale 2.5", edited(scene, "scale", "2.5"), [&](runtime::Camera c) {
    for (float& v : c.translation) v = float(double(v) * 2.5);
    c.near_plane = float(double(c.near_plane) * 2.5);  // depths scale too: the same Gaussians culled
    return c;
  });
}

uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, pages = 0;
  statm >> size >> pages;
  return pages * uint64_t(sysconf(_SC_PAGE_SIZE));
}

}  // namespace

TEST_CASE("edits: a rotated, translated or scaled scene seen by the camera moved with it renders the same (CPU reference)") {
  check_invariance(api::Device::kCpu);
}

TEST_CASE("edits: a rotated, translated or scaled scene seen by the camera moved with it renders the same (GPU)") {
#if !RGS_HAS_CUDA
  MESSAGE("skipped: this build has no CUDA support");
#else
  std::string why;
  if (!api::cuda_available(&why)) {
    MESSAGE("skipped: no CUDA device (" << why << ")");
    return;
  }
  check_invariance(api::Device::kCuda);
#endif
}

TEST_CASE("edits: convert() applies them in the order given, before the SH reduction, and notes what filters removed") {
  test::TempDir dir;
  const std::string src = test::repo_path(test::kGuitarSh3);
  const format::GaussianCloud scene = guitar_sh3();
  api::ConvertOptions options;
  options.edits = {edit("translate", "1,0,0"), edit("rotate", "0,0,90"), edit("filter", "f_rest_44 gt 0"),
                   edit("crop-sphere-outside", "3.9,0.7,0.1,0.1")};
  options.sh_degree = 1;
  auto written = api::convert(src, dir.file("edited.ply"), options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  format::GaussianCloud expected = scene;
  for (const converter::EditAction& e : options.edits) REQUIRE(converter::apply_edit(&expected, e).ok());
  REQUIRE(converter::reduce_sh_degree(&expected, 1).ok());
  CHECK(written->gaussians == expected.size());
  CHECK(expected.size() < scene.size());
  bool noted = false;
  for (const std::string& note : written->input_notes) noted = noted || note.find("filter 'f_rest_44 gt 0' removed") == 0;
  CHECK(noted);
  auto read_back = converter::read_scene(dir.file("edited.ply"));
  REQUIRE(read_back.ok());
  const format::GaussianCloud& got = read_back->cloud;
  REQUIRE(got.size() == expected.size());
  CHECK(got.means == expected.means);
  CHECK(got.sh == expected.sh);
  // The other order gives another scene: rotation about the origin does not commute with the translation.
  api::ConvertOptions swapped = options;
  std::swap(swapped.edits[0], swapped.edits[1]);
  auto other = api::convert(src, dir.file("swapped.ply"), swapped);
  REQUIRE(other.ok());
  auto other_back = converter::read_scene(dir.file("swapped.ply"));
  REQUIRE(other_back.ok());
  CHECK(other_back->cloud.means != got.means);
}

TEST_CASE("edits: an out-of-core build edits each batch to the bytes of the build in memory") {
  test::TempDir dir;
  const std::string src = test::repo_path(test::kGuitarSh3);
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.lod_chunk_gaussians = 512;
  options.edits = {edit("rotate", "10,20,30"), edit("translate", "0,4,0"), edit("filter", "opacity ge 0.05"),
                   edit("crop-box-outside", "-0.3,-0.1,-1,0,0.2,1"), edit("scale", "1.5")};
  auto memory = api::convert(src, dir.file("in_memory.rgs"), options);
  REQUIRE_MESSAGE(memory.ok(), memory.status().to_string());
  CHECK(memory->rgs->out_of_core_partitions == 0);
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  if (resident_bytes() + (uint64_t{40} << 20) > *estimate) {
    MESSAGE("skipped: this process already holds " << resident_bytes() << " bytes, too many for a limit of "
                                                   << *estimate - 1);
    return;
  }
  options.memory_limit = *estimate - 1;
  auto streamed = api::convert(src, dir.file("out_of_core.rgs"), options);
  REQUIRE_MESSAGE(streamed.ok(), streamed.status().to_string());
  CHECK(streamed->rgs->out_of_core_partitions >= 1);
  CHECK(streamed->gaussians == memory->gaussians);
  CHECK(streamed->gaussians < 8000);
  CHECK(streamed->input_notes == memory->input_notes);
  CHECK(test::slurp(dir.file("out_of_core.rgs")) == test::slurp(dir.file("in_memory.rgs")));

  // Edits that remove everything: the empty-scene error, in memory and out of core alike.
  options.edits.push_back(edit("filter", "opacity gt 1"));
  auto empty = api::convert(src, dir.file("empty.rgs"), options);
  REQUIRE_FALSE(empty.ok());
  CHECK(empty.status().code() == StatusCode::kInvalidArgument);
  CHECK(empty.status().message().find("the edits (filter, crop) removed all") != std::string::npos);
  options.memory_limit = 0;
  auto empty_memory = api::convert(src, dir.file("empty.rgs"), options);
  REQUIRE_FALSE(empty_memory.ok());
  CHECK(empty_memory.status().message() == empty.status().message());
  options.allow_empty = true;
  options.lod_levels.reset();  // build_lod refuses an empty scene whatever allow_empty says
  auto allowed = api::convert(src, dir.file("empty.rgs"), options);
  CHECK_MESSAGE(allowed.ok(), allowed.status().to_string());
}
