// Gaussians from memory: converter::scene_from_cloud's value rules and api::convert_cloud into every output
// format, read back equal to what convert() writes from the same Gaussians in a file.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/converter/cloud_edits.h"
#include "rgs/converter/scene_reader.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

format::GaussianCloud guitar_cloud() {
  converter::SceneReadOptions exact;
  auto input = converter::read_scene(test::repo_path(test::kGuitarSh3), exact);
  REQUIRE_MESSAGE(input.ok(), input.status().to_string());
  return std::move(input->cloud);
}

float max_abs_difference(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float most = 0;
  for (size_t i = 0; i < a.size(); ++i) most = std::max(most, std::abs(a[i] - b[i]));
  return most;
}

TEST_CASE("scene_from_cloud: a file's value rules for arrays in memory") {
  const format::GaussianCloud cloud = guitar_cloud();
  auto scene = converter::scene_from_cloud(cloud, "arrays");
  REQUIRE(scene.ok());
  CHECK(scene->cloud.size() == cloud.size());
  CHECK(scene->format_id == "arrays");
  CHECK(scene->bounds.sphere_radius > 0);

  format::GaussianCloud bad = cloud;
  bad.scales[3 * 5 + 1] = -0.1f;
  auto negative = converter::scene_from_cloud(bad, "arrays");
  CHECK(negative.status().code() == StatusCode::kInvalidArgument);
  CHECK(negative.status().message().find("Gaussian 5 has a negative scale") != std::string::npos);

  bad = cloud;
  bad.opacities[9] = 1.5f;
  CHECK(converter::scene_from_cloud(bad, "arrays").status().message().find("Gaussian 9 has an opacity") !=
        std::string::npos);

  bad = cloud;
  bad.means[3 * 2] = std::numeric_limits<float>::quiet_NaN();
  bad.rotations[4 * 7 + 0] = bad.rotations[4 * 7 + 1] = bad.rotations[4 * 7 + 2] = bad.rotations[4 * 7 + 3] = 0;
  CHECK(converter::scene_from_cloud(bad, "arrays").status().code() == StatusCode::kCorruptData);
  converter::SceneReadOptions sanitize;
  sanitize.invalid_policy = converter::InvalidPolicy::kSanitize;
  auto dropped = converter::scene_from_cloud(bad, "arrays", sanitize);
  REQUIRE(dropped.ok());
  CHECK(dropped->cloud.size() == cloud.size() - 2);
  CHECK(dropped->hygiene.dropped_gaussians == 2);

  bad = cloud;
  bad.sh.pop_back();
  CHECK(converter::scene_from_cloud(bad, "arrays").status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("convert_cloud: every output format, the bytes convert() writes from the same Gaussians in a PLY") {
  test::TempDir dir;
  const format::GaussianCloud cloud = guitar_cloud();
  for (const char* ext : {"rgs", "ply", "spz", "glb"}) {
    CAPTURE(ext);
    const std::string from_arrays = dir.file(std::string("arrays.") + ext);
    const std::string from_file = dir.file(std::string("file.") + ext);
    api::ConvertOptions options;
    options.converter_name = "test";  // the provenance then differs only in the source's name, size and hash
    auto written = api::convert_cloud(cloud, "arrays", from_arrays, options);
    REQUIRE_MESSAGE(written.ok(), written.status().to_string());
    CHECK(written->input_format == "arrays");
    CHECK(written->gaussians == cloud.size());
    REQUIRE(api::convert(test::repo_path(test::kGuitarSh3), from_file, options).ok());
    if (std::string(ext) != "rgs") CHECK(test::slurp(from_arrays).size() == test::slurp(from_file).size());
    // The same Gaussians, up to the last bit of the quaternions (normalized once more from the arrays).
    auto a = converter::read_scene(from_arrays), b = converter::read_scene(from_file);
    REQUIRE((a.ok() && b.ok()));
    CHECK(a->cloud.size() == cloud.size());
    CHECK(a->cloud.means == b->cloud.means);
    CHECK(a->cloud.sh == b->cloud.sh);
    CHECK(max_abs_difference(a->cloud.rotations, b->cloud.rotations) <= 1e-6f);
    CHECK(max_abs_difference(a->cloud.scales, b->cloud.scales) <= 1e-6f * 4);
    CHECK(max_abs_difference(a->cloud.opacities, b->cloud.opacities) <= 1e-6f);
  }
}

TEST_CASE("convert_scene: the bytes convert() writes, and no output onto a file the scene read") {
  test::TempDir dir;
  const std::string src = dir.file("guitar.ply");
  std::filesystem::copy_file(test::repo_path(test::kGuitarSh3), src);
  api::ConvertOptions options;
  options.converter_name = "test";
  REQUIRE(api::convert(src, dir.file("convert.rgs"), options).ok());
  auto scene = converter::read_scene(src, api::scene_read_options(options));
  REQUIRE(scene.ok());
  auto written = api::convert_scene(*scene, src, dir.file("scene.rgs"), options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(test::slurp(dir.file("scene.rgs")) == test::slurp(dir.file("convert.rgs")));
  // The source itself, in another spelling, as the output: refused, the source untouched.
  const std::string before = test::slurp(src);
  const auto onto_source = api::convert_scene(*scene, src, dir.file("./guitar.ply"), options);
  CHECK_FALSE(onto_source.ok());
  CHECK(test::slurp(src) == before);
}

/// The bytes of the float property `name` of every vertex of a binary little-endian all-float PLY.
std::vector<uint32_t> ply_column(const std::string& bytes, const std::string& name) {
  const size_t end = bytes.find("end_header\n") + 11;
  std::vector<std::string> names;
  for (size_t at = bytes.find("property float "); at < end; at = bytes.find("property float ", at + 1)) {
    names.push_back(bytes.substr(at + 15, bytes.find('\n', at) - at - 15));
  }
  const size_t column = std::find(names.begin(), names.end(), name) - names.begin();
  REQUIRE(column < names.size());
  std::vector<uint32_t> out((bytes.size() - end) / (4 * names.size()));
  for (size_t i = 0; i < out.size(); ++i) std::memcpy(&out[i], &bytes[end + (i * names.size() + column) * 4], 4);
  return out;
}

TEST_CASE("convert: a PLY written from a PLY with no edit keeps its opacity logits and log scales bit for bit") {
  test::TempDir dir;
  // Logits at the 8-bit clamp (±13.8155, whose sigmoid float32 cannot invert) and beyond, scales from 2^-144 to
  // 2^115: the float32 activations give none of them back.
  std::string edge = test::slurp(test::repo_path("samples/guitar.ply"));
  const float logits[] = {13.815509f, -13.815509f, 20.0f, -30.0f, 9.5f, 0.0f};
  const float log_scales[] = {80.0f, -100.0f, 10.5f, -30.0f, 0.01f, -17.4f};
  const size_t end = edge.find("end_header\n") + 11;
  for (size_t i = 0; i < 6; ++i) {  // guitar.ply's rows: x y z nx ny nz f_dc×3 opacity scale×3 rot×4
    std::memcpy(&edge[end + (i * 17 + 9) * 4], &logits[i], 4);
    for (int a = 0; a < 3; ++a) std::memcpy(&edge[end + (i * 17 + 10 + a) * 4], &log_scales[(i + a) % 6], 4);
  }
  std::ofstream(dir.file("edge.ply"), std::ios::binary) << edge;
  for (const std::string src : {test::repo_path("samples/guitar.ply"), dir.file("edge.ply")}) {
    CAPTURE(src);
    REQUIRE(api::convert(src, dir.file("out.ply"), {}).ok());
    const std::string in = test::slurp(src), out = test::slurp(dir.file("out.ply"));
    for (const std::string name : {"opacity", "scale_0", "scale_1", "scale_2"}) {
      CAPTURE(name);
      CHECK(ply_column(out, name) == ply_column(in, name));
    }
  }
  // An edit that changes a value writes it from the activated one again: --scale 2 adds ln 2 to the log scales.
  api::ConvertOptions scaled;
  scaled.edits = {*converter::parse_edit_action("scale", "2")};
  REQUIRE(api::convert(dir.file("edge.ply"), dir.file("scaled.ply"), scaled).ok());
  uint32_t bits = ply_column(test::slurp(dir.file("scaled.ply")), "scale_0")[2];
  float scale_0;
  std::memcpy(&scale_0, &bits, 4);
  CHECK(scale_0 == doctest::Approx(10.5 + std::log(2.0)));
}

}  // namespace
