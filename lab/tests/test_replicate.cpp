// replicate(): K offset copies of a real scene (rgs-bench --replicate).
#include <doctest/doctest.h>

#include <cmath>

#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/lab/replicate.h"
#include "test_data.h"

namespace rgs::test {
namespace {

format::EncodedScene guitar_scene() {
  auto ply = converter::read_ply(repo_path("samples/guitar.ply"));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  auto encoded = converter::quantize(ply->cloud, converter::QuantizeOptions{});
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  return std::move(encoded).value();
}

TEST_CASE("replicate: K copies on an x-z grid, attributes repeated, bounds containing every mean") {
  const format::EncodedScene scene = guitar_scene();
  const uint64_t n = scene.count;
  auto r = lab::replicate(scene, 5);  // 3 columns, 2 rows
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  const format::EncodedScene& out = *r;
  CHECK(out.is_consistent());
  CHECK(out.count == 5 * n);
  CHECK(out.provenance.back() == std::make_pair(std::string("replicated"), std::string("5")));
  // Attributes repeat exactly; y is never offset; x and z move by a constant per copy.
  for (uint64_t c = 0; c < 5; ++c) {
    CAPTURE(c);
    CHECK(std::equal(scene.sh.begin(), scene.sh.end(), out.sh.begin() + std::ptrdiff_t(c * scene.sh.size())));
    CHECK(out.opacities[c * n + 7] == scene.opacities[7]);
    const float dx = out.means[(c * n) * 3] - scene.means[0];
    const float dz = out.means[(c * n) * 3 + 2] - scene.means[2];
    CHECK(out.means[(c * n + n - 1) * 3] - scene.means[(n - 1) * 3] == doctest::Approx(dx).epsilon(1e-4));
    CHECK(out.means[(c * n + n - 1) * 3 + 2] - scene.means[(n - 1) * 3 + 2] == doctest::Approx(dz).epsilon(1e-4));
    CHECK(out.means[(c * n + 3) * 3 + 1] == scene.means[3 * 3 + 1]);
  }
  // Copies 0 and 1 sit side by side along x, copies 0 and 3 along z.
  CHECK(out.means[n * 3] > out.means[0]);
  CHECK(out.means[(3 * n) * 3 + 2] > out.means[2]);
  const format::SceneBounds& b = out.metadata.bounds;
  for (uint64_t i = 0; i < out.count; ++i) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const float v = out.means[i * 3 + a];
      REQUIRE(v >= b.aabb_min[a]);
      REQUIRE(v <= b.aabb_max[a]);
      d2 += std::pow(double(v) - b.sphere_center[a], 2);
    }
    REQUIRE(std::sqrt(d2) <= double(b.sphere_radius) * (1 + 1e-6));
  }
}

TEST_CASE("replicate: one copy keeps the scene, zero copies fail") {
  const format::EncodedScene scene = guitar_scene();
  auto one = lab::replicate(scene, 1);
  REQUIRE(one.ok());
  CHECK(one->means == scene.means);
  CHECK(one->rotations == scene.rotations);
  CHECK(lab::replicate(scene, 0).status().code() == StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgs::test
