// Several inputs merged into one scene (api::convert of a list, converter::merge_scenes), and the decimation edit
// (converter::EditKind::kDecimate): counts, SH degrees, the first input's Gaussians kept bit for bit, the outputs of
// every float format, the anti-aliasing rule, an output that is an input refused, the limits held by the merged
// scene, each input's edits (ConvertOptions::input_edits) and the merged scene's, the out-of-core merge equal to the
// one in memory, and what decimation keeps of the scene.
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/converter/cloud_edits.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

converter::InputScene read(const std::string& path) {
  auto scene = converter::read_scene(path);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  return std::move(scene).value();
}

converter::EditAction edit(const std::string& name, const std::string& value) {
  auto parsed = converter::parse_edit_action(name, value);
  REQUIRE_MESSAGE(parsed.ok(), parsed.status().to_string());
  return std::move(parsed).value();
}

/// Gaussians [first, first + n) of `cloud` as a cloud of their own.
format::GaussianCloud slice(const format::GaussianCloud& cloud, size_t first, size_t n) {
  format::GaussianCloud out;
  out.sh_degree = cloud.sh_degree;
  const size_t sh = cloud.sh_coefficients() * 3;
  out.means.assign(cloud.means.begin() + first * 3, cloud.means.begin() + (first + n) * 3);
  out.rotations.assign(cloud.rotations.begin() + first * 4, cloud.rotations.begin() + (first + n) * 4);
  out.scales.assign(cloud.scales.begin() + first * 3, cloud.scales.begin() + (first + n) * 3);
  out.opacities.assign(cloud.opacities.begin() + first, cloud.opacities.begin() + first + n);
  out.sh.assign(cloud.sh.begin() + first * sh, cloud.sh.begin() + (first + n) * sh);
  return out;
}

void check_same(const format::GaussianCloud& a, const format::GaussianCloud& b) {
  REQUIRE(a.size() == b.size());
  CHECK(a.sh_degree == b.sh_degree);
  CHECK(a.means == b.means);
  CHECK(a.rotations == b.rotations);
  CHECK(a.scales == b.scales);
  CHECK(a.opacities == b.opacities);
  CHECK(a.sh == b.sh);
}

/// Σ α·(s1 s2 + s1 s3 + s2 s3) (what the level-of-detail merge weighs a Gaussian by, without the low-pass), and the
/// centroid of the means weighted by that, and by α alone.
struct Mass {
  double area = 0, opacity = 0, centroid[3] = {0, 0, 0}, opacity_centroid[3] = {0, 0, 0};
};
Mass mass_of(const format::GaussianCloud& c) {
  Mass m;
  for (size_t i = 0; i < c.size(); ++i) {
    const float* s = &c.scales[i * 3];
    const double a = c.opacities[i];
    const double w = a * (double(s[0]) * s[1] + double(s[0]) * s[2] + double(s[1]) * s[2]);
    m.area += w;
    m.opacity += a;
    for (int k = 0; k < 3; ++k) m.centroid[k] += w * c.means[i * 3 + k];
    for (int k = 0; k < 3; ++k) m.opacity_centroid[k] += a * c.means[i * 3 + k];
  }
  for (double& v : m.centroid) v /= m.area;
  for (double& v : m.opacity_centroid) v /= m.opacity;
  return m;
}

double distance(const double a[3], const double b[3]) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }

}  // namespace

TEST_CASE("merge: two samples of different SH degrees give the sum, the higher degree, each input as read alone") {
  const std::string sh0 = test::repo_path("samples/guitar.ply"), sh3 = test::repo_path(test::kGuitarSh3);
  const converter::InputScene a = read(sh0), b = read(sh3);
  REQUIRE(a.cloud.sh_degree == 0);
  REQUIRE(b.cloud.sh_degree == 3);
  auto merged = converter::merge_scenes({read(sh0), read(sh3)});
  REQUIRE_MESSAGE(merged.ok(), merged.status().to_string());
  const format::GaussianCloud& m = merged->cloud;
  CHECK(m.size() == a.cloud.size() + b.cloud.size());
  CHECK(m.sh_degree == 3);
  CHECK(merged->files == std::vector<std::string>{sh0, sh3});
  CHECK(merged->declared_vertices == a.declared_vertices + b.declared_vertices);
  CHECK(merged->file_bytes == a.file_bytes + b.file_bytes);
  format::GaussianCloud padded = a.cloud;
  REQUIRE(converter::raise_sh_degree(&padded, 3).ok());
  check_same(slice(m, 0, a.cloud.size()), padded);
  check_same(slice(m, a.cloud.size(), b.cloud.size()), b.cloud);
  for (size_t i = 0; i < a.cloud.size(); ++i) {
    for (size_t k = 3; k < 48; ++k) REQUIRE(m.sh[i * 48 + k] == 0.0f);
  }

  // Through convert(): the report counts them, the PLY written holds the first input as its own conversion does.
  test::TempDir dir;
  const api::ConvertOptions defaults;  // named: GCC 12 warns (falsely) of a map in the default argument's temporary
  auto report = api::convert(std::vector<std::string>{sh0, sh3}, dir.file("merged.ply"), defaults);
  REQUIRE_MESSAGE(report.ok(), report.status().to_string());
  CHECK(report->gaussians == m.size());
  CHECK(report->sh_degree == 3);
  CHECK(report->declared_gaussians == m.size());
  auto alone = api::convert(sh0, dir.file("alone.ply"));
  REQUIRE(alone.ok());
  format::GaussianCloud alone_back = read(dir.file("alone.ply")).cloud;
  REQUIRE(converter::raise_sh_degree(&alone_back, 3).ok());
  check_same(slice(read(dir.file("merged.ply")).cloud, 0, a.cloud.size()), alone_back);
}

TEST_CASE("merge: merged, rotated and cropped, the scene round-trips through .rgs, .ply, .spz and .glb") {
  test::TempDir dir;
  const std::vector<std::string> srcs = {test::repo_path("samples/guitar.ply"), test::repo_path(test::kGuitarSh3)};
  api::ConvertOptions options;
  options.edits = {edit("rotate", "0,0,90"), edit("crop-box", "-2,-2,-2,2,2,2")};
  auto expected_scene = converter::merge_scenes({read(srcs[0]), read(srcs[1])});
  REQUIRE(expected_scene.ok());
  format::GaussianCloud expected = std::move(expected_scene->cloud);
  for (const converter::EditAction& e : options.edits) REQUIRE(converter::apply_edit(&expected, e).ok());
  REQUIRE(expected.size() > 0);
  REQUIRE(expected.size() < 98854);
  // Not SOG: its SH palette's k-means takes minutes on an SH-3 scene of this size (SOG has its own tests).
  for (const char* name : {"merged.rgs", "merged.ply", "merged.spz", "merged.glb"}) {
    CAPTURE(name);
    auto report = api::convert(srcs, dir.file(name), options);
    REQUIRE_MESSAGE(report.ok(), report.status().to_string());
    CHECK(report->gaussians == expected.size());
    const format::GaussianCloud back = read(dir.file(name)).cloud;
    REQUIRE(back.size() == expected.size());
    CHECK(back.sh_degree == 3);
    // FP32 means in .rgs, PLY and GLB; SPZ stores 24-bit fixed point with 12 fractional bits (2.4e-4 a step).
    const double tolerance = std::string(name) == "merged.spz" ? 2.5e-4 : 0.0;
    double worst = 0;
    for (size_t i = 0; i < expected.means.size(); ++i) {
      worst = std::max(worst, std::fabs(double(back.means[i]) - expected.means[i]));
    }
    CHECK(worst <= tolerance);
  }
  // An SPZ input is turned from its RUB axes by its reader, before the merge: merged with a PLY, its Gaussians sit
  // where they were written from, not mirrored.
  auto with_spz = api::convert(std::vector<std::string>{dir.file("merged.spz"), srcs[1]}, dir.file("again.ply"));
  REQUIRE_MESSAGE(with_spz.ok(), with_spz.status().to_string());
  const format::GaussianCloud again = read(dir.file("again.ply")).cloud;
  REQUIRE(again.size() == expected.size() + 8000);
  double worst = 0;
  for (size_t i = 0; i < expected.means.size(); ++i) {
    worst = std::max(worst, std::fabs(double(again.means[i]) - expected.means[i]));
  }
  CHECK(worst <= 2.5e-4);
}

TEST_CASE("merge: an output that is any input is refused before anything is read, and the input stays") {
  test::TempDir dir;
  const std::string second = dir.file("second.ply");
  auto copy = api::convert(test::repo_path(test::kGuitarSh3), second);
  REQUIRE(copy.ok());
  const std::string before = test::slurp(second);
  auto refused = api::convert(std::vector<std::string>{test::repo_path("samples/guitar.ply"), second}, second);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
  CHECK(test::slurp(second) == before);
  auto none = api::convert(std::vector<std::string>{}, dir.file("none.ply"));
  CHECK(none.status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("merge: inputs whose anti-aliasing flags differ are refused, naming both") {
  test::TempDir dir;
  api::ConvertOptions aa;
  aa.read.antialiased = true;
  REQUIRE(api::convert(test::repo_path(test::kGuitarSh3), dir.file("aa.rgs"), aa).ok());
  const std::string plain = test::repo_path("samples/guitar.ply");
  auto refused = api::convert(std::vector<std::string>{dir.file("aa.rgs"), plain}, dir.file("out.rgs"));
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
  CHECK(refused.status().message().find(dir.file("aa.rgs") + " is anti-aliased") != std::string::npos);
  CHECK(refused.status().message().find(plain + " is not") != std::string::npos);
  // Both anti-aliased: merged, the flag kept.
  auto both = api::convert(std::vector<std::string>{dir.file("aa.rgs"), plain}, dir.file("both.rgs"), aa);
  REQUIRE_MESSAGE(both.ok(), both.status().to_string());
  CHECK(read(dir.file("both.rgs")).cloud.antialiased);
}

TEST_CASE("merge: --max-gaussians and the memory limit hold for the merged scene, not input by input") {
  test::TempDir dir;
  const std::string sample = test::repo_path("samples/guitar.ply"), sh3 = test::repo_path(test::kGuitarSh3);
  // Two guitars of 90,854 Gaussians each: under a limit of 100,000 each, not together.
  api::ConvertOptions options;
  options.read.max_gaussians = 100000;
  for (const bool out_of_core : {false, true}) {
    CAPTURE(out_of_core);
    if (out_of_core) {
      options.lod_levels = 0;
      options.memory_limit = 64 << 20;  // below the guitars' estimate: read in batches
    }
    auto refused = api::convert(std::vector<std::string>{sample, sample}, dir.file("two.rgs"), options);
    REQUIRE_FALSE(refused.ok());
    CHECK(refused.status().code() == StatusCode::kLimitExceeded);
    CHECK(refused.status().message().find(sample + " + " + sample + ": the ") == 0);
    CHECK(refused.status().message().find("100,000") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(dir.file("two.rgs")));
  }
  api::ConvertOptions both;
  both.read.max_gaussians = 2 * 90854;
  CHECK(api::convert(std::vector<std::string>{sample, sample}, dir.file("two.rgs"), both).ok());

  // Six guitars in one SH-0 PLY (545,124 Gaussians, 37 MB) merged with the SH-3 scene: every Gaussian widened to
  // SH 3 (56 bytes to 236), which the inputs' estimates, file by file, do not see.
  const std::string big = dir.file("six.ply");
  REQUIRE(api::convert(std::vector<std::string>(6, sample), big).ok());
  const std::vector<std::string> srcs = {big, sh3};
  const uint64_t inputs = api::estimate_convert_memory(srcs).value();
  const uint64_t merged = api::estimate_merged_memory(6 * 90854 + 8000, 3);
  REQUIRE(merged > inputs);
  api::ConvertOptions limited;
  limited.memory_limit = inputs;
  auto refused = api::convert(srcs, dir.file("merged.ply"), limited);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  CHECK(refused.status().message().find("the merged scene (553,124 Gaussians at SH degree 3, every input widened "
                                        "to it) is estimated to need") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir.file("merged.ply")));
  limited.memory_limit = merged;
  CHECK(api::convert(srcs, dir.file("merged.ply"), limited).ok());
}

TEST_CASE("merge: the inputs' estimate counts the program's own memory once, not once an input") {
  // Twelve copies of the SH-3 scene: a sum of their estimates would hold 12 x 64 MiB for the program alone, and
  // a tiled capture of 200 parts 12.5 GiB.
  const std::string sh3 = test::repo_path(test::kGuitarSh3);
  const std::vector<std::string> srcs(12, sh3);
  const uint64_t one = api::estimate_convert_memory(sh3).value();
  const uint64_t together = api::estimate_convert_memory(srcs).value();
  CHECK(together == one + 11 * (one - (uint64_t{64} << 20)));
  api::ConvertOptions options;
  options.memory_limit = std::max(together, api::estimate_merged_memory(12 * 8000, 3));
  REQUIRE(options.memory_limit < 2 * one);
  test::TempDir dir;
  auto merged = api::convert(srcs, dir.file("twelve.ply"), options);
  REQUIRE_MESSAGE(merged.ok(), merged.status().to_string());
  CHECK(merged->gaussians == 12 * 8000);
}

TEST_CASE("merge: edits written for an input act on it alone, before the merge and the merged scene's edits") {
  test::TempDir dir;
  const std::vector<std::string> srcs = {test::repo_path("samples/guitar.ply"), test::repo_path(test::kGuitarSh3)};
  api::ConvertOptions options;
  options.input_edits = {{edit("rotate", "0,0,90"), edit("crop-box", "-1,-1,-1,1,1,1")}, {edit("translate", "3,0,0")}};
  options.edits = {edit("filter", "opacity ge 0.05")};
  // Expected: each input read, widened to SH 3 and edited alone, then merged and filtered.
  std::vector<converter::InputScene> scenes = {read(srcs[0]), read(srcs[1])};
  std::vector<uint64_t> kept;
  for (size_t i = 0; i < 2; ++i) {
    REQUIRE(converter::raise_sh_degree(&scenes[i].cloud, 3).ok());
    for (const converter::EditAction& e : options.input_edits[i]) {
      REQUIRE(converter::apply_edit(&scenes[i].cloud, e).ok());
    }
    kept.push_back(scenes[i].cloud.size());
  }
  REQUIRE(kept[0] < 90854);
  auto merged = converter::merge_scenes(std::move(scenes));
  REQUIRE(merged.ok());
  format::GaussianCloud expected = std::move(merged->cloud);
  const uint64_t before_filter = expected.size();
  REQUIRE(converter::apply_edit(&expected, options.edits[0]).ok());
  REQUIRE(expected.size() < before_filter);

  auto report = api::convert(srcs, dir.file("edited.ply"), options);
  REQUIRE_MESSAGE(report.ok(), report.status().to_string());
  const format::GaussianCloud back = read(dir.file("edited.ply")).cloud;
  REQUIRE(back.size() == expected.size());
  CHECK(back.means == expected.means);
  CHECK(back.sh == expected.sh);
  float worst = 0;  // the reader normalizes the quaternions again
  for (size_t i = 0; i < back.rotations.size(); ++i) {
    worst = std::max(worst, std::fabs(back.rotations[i] - expected.rotations[i]));
  }
  CHECK(worst < 1e-6f);
  REQUIRE(report->merge_inputs.size() == 2);
  CHECK(report->merge_inputs[0].path == srcs[0]);
  CHECK(report->merge_inputs[0].gaussians == 90854);
  CHECK(report->merge_inputs[0].kept == kept[0]);
  CHECK(report->merge_inputs[0].edits ==
        std::vector<std::string>{"rotate '0,0,90'",
                                 "crop-box '-1,-1,-1,1,1,1' removed " + group_digits(90854 - kept[0]) + " Gaussians"});
  CHECK(report->merge_inputs[1].gaussians == 8000);
  CHECK(report->merge_inputs[1].kept == 8000);
  CHECK(report->merge_inputs[1].edits == std::vector<std::string>{"translate '3,0,0'"});
  const std::string json = api::convert_report_json(*report, "a + b", "edited.ply", options);
  CHECK(json.find("\"kept\": " + std::to_string(kept[0])) != std::string::npos);
  CHECK(json.find("\"edits\": [\n      \"filter 'opacity ge 0.05'\"") != std::string::npos);

  // A .rgs records which input each edit acted on, by its place among the inputs.
  REQUIRE(api::convert(srcs, dir.file("edited.rgs"), options).ok());
  auto file = format::RgsFile::open(dir.file("edited.rgs"));
  REQUIRE(file.ok());
  std::string recorded;
  for (const auto& [key, value] : file->provenance()) recorded += key == "options" ? value : "";
  CHECK(recorded.find(" edits=input 1: rotate '0,0,90'; input 1: crop-box '-1,-1,-1,1,1,1'; input 2: "
                      "translate '3,0,0'; filter 'opacity ge 0.05' ") != std::string::npos);

  // One input: its edits act as the scene's, before them (the same file); edits of more inputs than given refused.
  api::ConvertOptions one;
  one.input_edits = {options.input_edits[1]};
  one.edits = options.edits;
  REQUIRE(api::convert(srcs[1], dir.file("one_input.rgs"), one).ok());
  one.edits.insert(one.edits.begin(), options.input_edits[1][0]);
  one.input_edits.clear();
  REQUIRE(api::convert(srcs[1], dir.file("one_scene.rgs"), one).ok());
  CHECK(test::slurp(dir.file("one_input.rgs")) == test::slurp(dir.file("one_scene.rgs")));
  options.input_edits.resize(3);
  CHECK(api::convert(srcs, dir.file("three.ply"), options).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("merge: an out-of-core merge of two PLYs gives the bytes of the merge in memory") {
  test::TempDir dir;
  const std::vector<std::string> srcs = {test::repo_path("samples/guitar.ply"), test::repo_path(test::kGuitarSh3)};
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.lod_chunk_gaussians = 4096;
  options.edits = {edit("rotate", "10,20,30"), edit("filter", "opacity ge 0.05")};
  options.input_edits = {{edit("crop-box-outside", "-0.2,-10,-10,0,10,10")}, {edit("translate", "0.5,0,0")}};
  auto memory = api::convert(srcs, dir.file("in_memory.rgs"), options);
  REQUIRE_MESSAGE(memory.ok(), memory.status().to_string());
  CHECK(memory->rgs->out_of_core_partitions == 0);
  const uint64_t estimate = api::estimate_convert_memory(srcs).value();
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, pages = 0;
  statm >> size >> pages;
  if (pages * uint64_t(sysconf(_SC_PAGE_SIZE)) + (uint64_t{40} << 20) > estimate) {
    MESSAGE("skipped: this process already holds " << pages << " pages, too many for a limit of " << estimate - 1);
    return;
  }
  options.memory_limit = estimate - 1;
  auto streamed = api::convert(srcs, dir.file("out_of_core.rgs"), options);
  REQUIRE_MESSAGE(streamed.ok(), streamed.status().to_string());
  CHECK(streamed->rgs->out_of_core_partitions >= 1);
  CHECK(streamed->gaussians == memory->gaussians);
  CHECK(streamed->sh_degree == 3);
  REQUIRE(streamed->merge_inputs.size() == 2);
  for (size_t i = 0; i < 2; ++i) {
    CHECK(streamed->merge_inputs[i].kept == memory->merge_inputs[i].kept);
    CHECK(streamed->merge_inputs[i].edits == memory->merge_inputs[i].edits);
  }
  CHECK(memory->merge_inputs[0].kept < memory->merge_inputs[0].gaussians);
  CHECK(test::slurp(dir.file("out_of_core.rgs")) == test::slurp(dir.file("in_memory.rgs")));
  // The second input changed after the first pass: the next pass finds it, naming that file, and nothing is written.
  const std::string second = dir.file("second.ply");
  {
    std::ofstream copy(second, std::ios::binary);
    copy << test::slurp(srcs[1]);
  }
  bool changed = false;
  options.progress = [&](const api::ConvertProgress& p) {
    if (changed || std::string(p.stage) == "reading") return;
    std::ofstream(second, std::ios::binary | std::ios::app) << "more";
    changed = true;
  };
  auto disturbed = api::convert(std::vector<std::string>{srcs[0], second}, dir.file("disturbed.rgs"), options);
  REQUIRE_FALSE(disturbed.ok());
  CHECK(changed);
  CHECK(disturbed.status().code() == StatusCode::kIoError);
  CHECK(disturbed.status().message().find(second + ": the file changed during the passes") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir.file("disturbed.rgs")));
  options.progress = nullptr;
  // Decimation needs the whole scene, or input: refused out of core, with the reason.
  options.input_edits[1].push_back(edit("decimate", "1000"));
  auto decimated = api::convert(srcs, dir.file("decimated.rgs"), options);
  REQUIRE_FALSE(decimated.ok());
  CHECK(decimated.status().message().find("decimate needs the whole scene (or input) in memory") != std::string::npos);
  options.input_edits[1].pop_back();
  options.edits.push_back(edit("decimate", "1000"));
  decimated = api::convert(srcs, dir.file("decimated.rgs"), options);
  CHECK(decimated.status().message().find("decimate needs the whole scene (or input) in memory") != std::string::npos);
}

TEST_CASE("decimate: at most N Gaussians, more than N minus one chunk, the weighted centroid kept") {
  const format::GaussianCloud scene = read(test::repo_path("samples/guitar.ply")).cloud;
  const Mass before = mass_of(scene);
  double extent = 0;
  for (int a = 0; a < 3; ++a) {
    float lo = scene.means[a], hi = scene.means[a];
    for (size_t i = 0; i < scene.size(); ++i) {
      lo = std::min(lo, scene.means[i * 3 + a]);
      hi = std::max(hi, scene.means[i * 3 + a]);
    }
    extent = std::max(extent, double(hi) - lo);
  }
  for (const uint64_t n : {uint64_t{10000}, uint64_t{1000}}) {
    CAPTURE(n);
    format::GaussianCloud cloud = scene;
    auto removed = converter::apply_edit(&cloud, edit("decimate", std::to_string(n)));
    REQUIRE_MESSAGE(removed.ok(), removed.status().to_string());
    CHECK(*removed == scene.size() - cloud.size());
    // The cut stops at the first step that reaches N: a step removes at most one chunk's Gaussians, and chunks
    // hold at most max(N / 16, 64).
    CHECK(cloud.size() <= n);
    CHECK(cloud.size() > n - std::max<uint64_t>(n / 16, 64));
    // Opaque, overlapping Gaussians saturate the merge's coverage rule (it keeps what a pixel sees, not the sum of
    // α·S), so the mass falls as the cells grow: reported, not checked. Each parent stays at its children's
    // weighted mean, inside their cell, so the α·S-weighted centroid moves only by the weight the saturation takes
    // from dense regions: 4.4% and 3.0% of the extent here, bounded at 5% as a regression check.
    const Mass after = mass_of(cloud);
    MESSAGE("area mass " << after.area / before.area << ", opacity " << after.opacity / before.opacity
                         << ", area centroid moved by " << distance(after.centroid, before.centroid) / extent
                         << ", opacity centroid " << distance(after.opacity_centroid, before.opacity_centroid) / extent
                         << " of the extent " << extent);
    CHECK(distance(after.centroid, before.centroid) < 0.05 * extent);
  }
  // A fraction: rounded; a scene already small enough is left as it is.
  format::GaussianCloud quarter = scene;
  REQUIRE(converter::apply_edit(&quarter, edit("decimate", "0.25")).ok());
  CHECK(quarter.size() <= (scene.size() + 2) / 4);
  format::GaussianCloud kept = scene;
  CHECK(converter::apply_edit(&kept, edit("decimate", "100000")).value() == 0);
  check_same(kept, scene);
}

TEST_CASE("decimate: faint Gaussians keep their opacity-weighted area and its centroid") {
  // 20,000 faint isotropic Gaussians in the unit cube. A parent's mean is the α·S-weighted mean of its children
  // (S the drawn area), and its coverage rule gives α_p·S_p = Σ α_i·S_i·(1 − O(Σ α_i)): overlapping children occlude
  // each other. With α = 0.001 and about ten children to a parent over the levels a 10x reduction takes, that is 1%;
  // the low-pass dilation δ² = 0.3·error² changes S by a few % of s² = 0.04 alike for children and parent; FP16
  // rounds by 5e-4. So Σ α·S stays within 3%, and with 1% of the weight moved within a unit cube the α·S-weighted
  // centroid within 0.01.
  format::GaussianCloud cloud;
  const size_t n = 20000;
  cloud.resize(n);
  uint64_t state = 12345;
  const auto uniform = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return double(state >> 11) * 0x1p-53;
  };
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) cloud.means[i * 3 + a] = float(uniform());
    for (int a = 0; a < 3; ++a) cloud.scales[i * 3 + a] = 0.2f;
    cloud.rotations[i * 4] = 1.0f;
    cloud.opacities[i] = 0.001f;
    for (int c = 0; c < 3; ++c) cloud.sh[i * 3 + c] = float(uniform() - 0.5);
  }
  const Mass before = mass_of(cloud);
  REQUIRE(converter::apply_edit(&cloud, edit("decimate", "2000")).ok());
  CHECK(cloud.size() <= 2000);
  CHECK(cloud.size() > 2000 - 125);
  const Mass after = mass_of(cloud);
  MESSAGE("area mass " << after.area / before.area << ", centroid moved by " << distance(after.centroid, before.centroid));
  CHECK(std::fabs(after.area / before.area - 1) < 0.03);
  CHECK(distance(after.centroid, before.centroid) < 0.01);
}

TEST_CASE("decimate: values that are neither a count nor a fraction are refused") {
  for (const char* value : {"0", "-3", "1.5", "1", "nan", "inf", "", "0.5,2"}) {
    CAPTURE(value);
    auto parsed = converter::parse_edit_action("decimate", value);
    if (std::string(value) == "1") {
      CHECK(parsed.ok());
      continue;
    }
    REQUIRE_FALSE(parsed.ok());
    CHECK(parsed.status().code() == StatusCode::kInvalidArgument);
    CHECK(parsed.status().message().find("decimate") == 0);
  }
}
