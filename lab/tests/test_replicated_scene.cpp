// replicate_scene_file (rgs-bench --replicate): K copies as .rgs bytes that open and validate, from a PLY
// (quantized with the defaults) and from a .rgs (as stored), any input format, the read limits and the Gaussian
// count limit.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/format/reader.h"
#include "rgs/lab/replicated_scene.h"
#include "test_data.h"

namespace {

using namespace rgs;

TEST_CASE("replicate_scene_file: a PLY tiled twice, quantized with the defaults, opens and validates") {
  auto r = lab::replicate_scene_file(test::repo_path("samples/guitar.ply"), 2);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  CHECK(r->source_gaussians == 90854);
  CHECK(r->gaussians == 2 * 90854);
  CHECK(r->copies == 2);
  CHECK_FALSE(r->source_is_rgs);
  CHECK(r->quantization.find("defaults") != std::string::npos);
  CHECK(format::validate(r->rgs_bytes.data(), r->rgs_bytes.size()).ok());
  auto file = format::RgsFile::from_bytes(r->rgs_bytes.data(), r->rgs_bytes.size());
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  CHECK(file->gaussian_count() == 2 * 90854);
  CHECK(file->metadata().sh_degree == 0);
  // The bounds handed to the orbit cameras are the file's, and cover both copies (side by side along x).
  const format::SceneBounds& b = file->metadata().bounds;
  CHECK(r->bounds.sphere_radius == b.sphere_radius);
  auto single = converter::read_scene(test::repo_path("samples/guitar.ply"));
  REQUIRE(single.ok());
  CHECK(b.aabb_max[0] - b.aabb_min[0] > single->bounds.aabb_max[0] - single->bounds.aabb_min[0]);
  bool replicated = false;
  for (const auto& [key, value] : file->provenance()) replicated |= key == "replicated" && value == "2";
  CHECK(replicated);
}

TEST_CASE("replicate_scene_file: a .rgs tiled three times keeps its sections' values") {
  const std::string path = test::repo_path("tests/data/v1.0/small_sh3.rgs");
  auto source = format::RgsFile::open(path);
  REQUIRE_MESSAGE(source.ok(), source.status().to_string());
  auto original = source->read_scene();
  REQUIRE(original.ok());
  auto r = lab::replicate_scene_file(path, 3);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  CHECK(r->source_is_rgs);
  CHECK(r->gaussians == 3 * original->count);
  auto file = format::RgsFile::from_bytes(r->rgs_bytes.data(), r->rgs_bytes.size());
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  auto copy = file->read_scene();
  REQUIRE(copy.ok());
  CHECK(copy->metadata.sh_quantization.scales[1][2] == original->metadata.sh_quantization.scales[1][2]);
  const size_t sh = original->sh.size();
  REQUIRE(copy->sh.size() == 3 * sh);
  CHECK(std::equal(original->sh.begin(), original->sh.end(), copy->sh.begin() + std::ptrdiff_t(2 * sh)));
}

TEST_CASE("replicate_scene_file: zero copies and the 32-bit Gaussian count limit") {
  const std::string path = test::repo_path("tests/data/v1.0/small_sh3.rgs");
  auto zero = lab::replicate_scene_file(path, 0);
  REQUIRE_FALSE(zero.ok());
  CHECK(zero.status().code() == StatusCode::kInvalidArgument);
  auto source = format::RgsFile::open(path);
  REQUIRE(source.ok());
  const uint64_t n = source->gaussian_count();
  const uint32_t too_many = uint32_t(lab::kMaxGpuGaussians / n + 1);
  auto over = lab::replicate_scene_file(path, too_many);
  REQUIRE_FALSE(over.ok());
  CHECK(over.status().code() == StatusCode::kLimitExceeded);
  CHECK(over.status().message().find("exceed the 32-bit Gaussian count limit of 2147483647") != std::string::npos);
  CHECK(over.status().message().find("small_sh3.rgs") != std::string::npos);
  auto missing = lab::replicate_scene_file(test::repo_path("tests/data/v1.0/nope.rgs"), 2);
  REQUIRE_FALSE(missing.ok());
  CHECK(missing.status().message().find("nope.rgs") != std::string::npos);
}

TEST_CASE("replicate_scene_file: any input format, and the read limits") {
  auto r = lab::replicate_scene_file(test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz"), 2);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  CHECK(r->gaussians == 512);
  converter::SceneReadOptions tight;
  tight.max_gaussians = 100;
  auto refused = lab::replicate_scene_file(test::repo_path("samples/guitar.ply"), 2, tight);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
}

}  // namespace
