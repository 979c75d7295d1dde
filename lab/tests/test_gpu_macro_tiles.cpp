// The lab's macro-tile binning (rgs-bench's fastest-macro-bins): it builds every tile's list in the order the
// pair sort and the depth order pass give (view depth, then Gaussian id), so its frames must be fastest's bit
// for bit — at 1080p, 4K and 8K (8, 10 and 12 macro-tile bits), with Gaussians at equal depths (the ties its
// block sort puts in id order), with a bucket over its capacity (the frame falls back to the pair sort), and in
// groups of tile rows.
#include <doctest/doctest.h>

#include <array>
#include <string>
#include <vector>

#include "gpu_test_util.h"
#include "rgs/lab/gpu_modes.h"

namespace rgs::test {
namespace {

using runtime::Camera;
using runtime::GpuRenderOptions;

GpuRenderOptions mode(const std::string& name) {
  auto options = lab::gpu_mode_options(name, true);
  REQUIRE_MESSAGE(options.ok(), options.status().to_string());
  return *options;
}

/// Renders `cloud` (quantized into the .rgs runtime profile) with fastest and with the macro-tile binning from
/// each camera, with depth, and checks the two frames have the same bits.
void check_same_frames(const format::GaussianCloud& cloud, const std::vector<Camera>& cameras,
                       uint64_t scratch_budget = 0) {
  const CompactScene compact = make_compact(cloud, false);
  auto scene = runtime::GpuScene::from_rgs(*compact.file);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE(renderer.ok());
  GpuRenderOptions fastest = mode("fastest");
  GpuRenderOptions binned = mode("fastest-macro-bins");
  fastest.scratch_budget = binned.scratch_budget = scratch_budget;
  for (const Camera& cam : cameras) {
    CAPTURE(cam.width);
    const GpuFrame expected = render_gpu(*renderer, *scene, cam, fastest, true);
    const GpuFrame frame = render_gpu(*renderer, *scene, cam, binned, true);
    CHECK(frame.stats.pairs == expected.stats.pairs);
    CHECK(same_bits(frame.rgba, expected.rgba));
    CHECK(same_bits(frame.depth, expected.depth));
    if (scratch_budget != 0) CHECK((expected.stats.tile_groups > 1 && frame.stats.tile_groups > 1));
  }
}

/// Appends `copies` copies of Gaussian `g` of `cloud`, moved to `mean` when given.
void append_copies(format::GaussianCloud* cloud, size_t g, size_t copies, const float* mean = nullptr) {
  const size_t n = cloud->size(), k = cloud->sh_coefficients();
  cloud->resize(n + copies);
  for (size_t c = n; c < n + copies; ++c) {
    for (int i = 0; i < 3; ++i) cloud->means[3 * c + i] = mean != nullptr ? mean[i] : cloud->means[3 * g + i];
    for (int i = 0; i < 4; ++i) cloud->rotations[4 * c + i] = cloud->rotations[4 * g + i];
    for (int i = 0; i < 3; ++i) cloud->scales[3 * c + i] = cloud->scales[3 * g + i];
    cloud->opacities[c] = cloud->opacities[g];
    for (size_t i = 0; i < 3 * k; ++i) cloud->sh[3 * k * c + i] = cloud->sh[3 * k * g + i];
  }
}

TEST_CASE("macro-tile binning renders fastest's frames bit for bit (flowers at 1080p, 4K and 8K)") {
  if (!have_gpu()) return;
  const GpuScenePair& flowers = flowers_fp32();
  if (!flowers.available) return;
  const uint32_t sizes[3][2] = {{1920, 1080}, {3840, 2160}, {7680, 4320}};
  std::vector<Camera> cameras;
  for (const auto& size : sizes) {
    for (const Camera& cam : flowers_cameras(flowers.cameras_path, 60, size[0], size[1])) cameras.push_back(cam);
  }
  check_same_frames(flowers.cloud, cameras);
}

TEST_CASE("macro-tile binning: equal depths in id order, a bucket over capacity, groups of tile rows") {
  if (!have_gpu()) return;
  const GpuScenePair& flowers = flowers_fp32();
  if (!flowers.available) return;
  const std::vector<Camera> cameras = flowers_cameras(flowers.cameras_path, 100, 1920, 1080);
  REQUIRE(!cameras.empty());
  SUBCASE("every 7th Gaussian twice more: runs of three equal depths") {
    format::GaussianCloud cloud = flowers.cloud;
    const size_t n = cloud.size();
    for (size_t g = 0; g < n; g += 7) append_copies(&cloud, g, 2);
    check_same_frames(cloud, cameras);
  }
  SUBCASE("5,000 copies of one Gaussian 2 units ahead of the first camera: one bucket over capacity") {
    format::GaussianCloud cloud = flowers.cloud;
    const Camera& cam = cameras.front();
    const std::array<float, 3> centre = runtime::camera_centre(cam);
    float ahead[3];
    for (int i = 0; i < 3; ++i) ahead[i] = centre[i] + 2.f * cam.rotation[6 + i];  // the view's +z in the world
    append_copies(&cloud, 0, 5000, ahead);
    check_same_frames(cloud, {cam});
  }
  SUBCASE("a scratch budget that splits the frames into groups of tile rows") {
    check_same_frames(flowers.cloud, cameras, uint64_t{8} << 20);
  }
}

}  // namespace
}  // namespace rgs::test
