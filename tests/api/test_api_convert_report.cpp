// What api::convert reports besides the output: the progress of its stages (ConvertOptions::progress), the
// errors of an archive .rgs as readers decode it (and that its zstd level changes its bytes only), and whether
// the input was in a compact format.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/archive.h"
#include "rgs/format/reader.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

struct Call {
  std::string stage;
  double fraction;
};

/// The progress calls of converting `src` to `dst` with `options`, and whether the conversion succeeded.
std::vector<Call> progress_calls(const std::string& src, const std::string& dst, api::ConvertOptions options,
                                 bool* ok) {
  std::vector<Call> calls;
  options.progress = [&calls](const api::ConvertProgress& p) { calls.push_back({p.stage, p.fraction}); };
  auto report = api::convert(src, dst, options);
  *ok = report.ok();
  return calls;
}

std::vector<std::string> stages(const std::vector<Call>& calls) {
  std::vector<std::string> names;
  for (const Call& c : calls) names.push_back(c.stage);
  return names;
}

void check_fractions(const std::vector<Call>& calls) {
  REQUIRE(!calls.empty());
  CHECK(calls.front().fraction == 0.0);
  for (size_t i = 1; i < calls.size(); ++i) CHECK(calls[i].fraction >= calls[i - 1].fraction);
  for (size_t i = 0; i + 1 < calls.size(); ++i) CHECK(calls[i].fraction < 1.0);
  CHECK(calls.back().fraction == 1.0);
}

/// Longest side of the means' AABB.
double extent_of(const format::GaussianCloud& cloud) {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(cloud.means[i * 3 + a]));
      hi[a] = std::max(hi[a], double(cloud.means[i * 3 + a]));
    }
  }
  return std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
}

void check_same(const converter::ErrorStats& got, const converter::ErrorStats& want) {
  CHECK(got.samples == want.samples);
  CHECK(got.max == doctest::Approx(want.max).epsilon(1e-9));
  CHECK(got.rms == doctest::Approx(want.rms).epsilon(1e-9));
}

TEST_CASE("convert: progress goes through each output's stages with non-decreasing fractions ending at 1") {
  const std::string guitar = test::repo_path("samples/guitar.ply");
  test::TempDir dir;
  bool ok = false;

  auto runtime = progress_calls(guitar, dir.file("runtime.rgs"), {}, &ok);
  CHECK(ok);
  check_fractions(runtime);
  CHECK(stages(runtime) == std::vector<std::string>{"reading", "quantizing", "writing", "done"});

  api::ConvertOptions archive_options;
  archive_options.profile = format::StorageProfile::kArchive;
  auto archive = progress_calls(guitar, dir.file("archive.rgs"), archive_options, &ok);
  CHECK(ok);
  check_fractions(archive);
  CHECK(stages(archive) ==
        std::vector<std::string>{"reading", "quantizing", "encoding the archive", "writing", "done"});
  // Encoding the archive takes most of the time: the stage before writing has the largest share.
  REQUIRE(archive.size() == 5);
  CHECK(archive[3].fraction - archive[2].fraction > archive[2].fraction - archive[0].fraction);

  for (const char* name : {"float.ply", "float.spz", "float.glb"}) {
    CAPTURE(name);
    auto floats = progress_calls(guitar, dir.file(name), {}, &ok);
    CHECK(ok);
    check_fractions(floats);
    CHECK(stages(floats) == std::vector<std::string>{"reading", "writing", "done"});
  }

  // Each stage starts at the share of the whole it measured on real scenes, so that the first estimate of the time
  // left, extrapolated from reading, is not off tenfold: reading is 0.1-0.8 % of a SOG output's time (k-means),
  // 1-2 % of a .rgs whose sections zstd compresses at level 19, and with quantizing 2 % of an archive trying .xz.
  auto sog = progress_calls(guitar, dir.file("float.sog"), {}, &ok);
  CHECK(ok);
  REQUIRE(stages(sog) == std::vector<std::string>{"reading", "writing", "done"});
  CHECK(sog[1].fraction <= 0.01);
  api::ConvertOptions zstd;
  zstd.zstd_sections = {"sh"};
  auto compressed = progress_calls(guitar, dir.file("zstd.rgs"), zstd, &ok);
  CHECK(ok);
  REQUIRE(stages(compressed) == std::vector<std::string>{"reading", "quantizing", "writing", "done"});
  CHECK(compressed[1].fraction <= 0.05);
  archive_options.zstd_level = 19;
  auto xz = progress_calls(test::repo_path(test::kGuitarSh3), dir.file("xz.rgs"), archive_options, &ok);
  CHECK(ok);
  REQUIRE(xz.size() == 5);
  CHECK(xz[2].fraction <= 0.02);

  // A failed conversion never reports "done".
  auto failed = progress_calls(dir.file("missing.ply"), dir.file("never.rgs"), {}, &ok);
  CHECK(!ok);
  CHECK(stages(failed) == std::vector<std::string>{"reading"});
}

TEST_CASE("convert: the archive's codes at zstd level 19 take fewer bytes than at 1, with .xz tried fewer still, "
          "the same scene") {
  const std::string source_path = test::repo_path(test::kGuitarSh3);
  test::TempDir dir;
  std::vector<format::EncodedScene> scenes;
  std::vector<uint64_t> sizes;
  for (auto [level, xz] : {std::pair{1, false}, std::pair{19, false}, std::pair{19, true}}) {
    api::ConvertOptions options;
    options.profile = format::StorageProfile::kArchive;
    options.zstd_level = level;
    options.archive.xz = xz;
    const std::string path = dir.file("archive_" + std::to_string(level) + (xz ? "_xz" : "") + ".rgs");
    REQUIRE(api::convert(source_path, path, options).ok());
    auto file = format::RgsFile::open(path);
    REQUIRE(file.ok());
    auto scene = file->read_scene();
    REQUIRE(scene.ok());
    scenes.push_back(std::move(scene).value());
    sizes.push_back(test::slurp(path).size());
  }
  CHECK(sizes[1] < sizes[0]);
  CHECK(sizes[2] < sizes[1]);  // LZMA's coding wins on some of guitar's sections (SPEC §3.3.2)
  // Below level 19 the .xz trials stay only for scenes under format::kArchiveDenseGaussians, such as this one.
  for (bool xz : {false, true}) {
    api::ConvertOptions quick;
    quick.profile = format::StorageProfile::kArchive;
    quick.zstd_level = 18;
    quick.archive.xz = xz;
    REQUIRE(api::convert(source_path, dir.file("archive_18.rgs"), quick).ok());
    auto file = format::RgsFile::open(dir.file("archive_18.rgs"));
    REQUIRE(file.ok());
    CHECK(((file->header().required_flags & format::kRequiredFlagXzCodes) != 0) == xz);
  }
  for (size_t i = 1; i < scenes.size(); ++i) {
    CHECK(scenes[0].means == scenes[i].means);
    CHECK(scenes[0].rotations == scenes[i].rotations);
    CHECK(scenes[0].scales == scenes[i].scales);
    CHECK(scenes[0].opacities == scenes[i].opacities);
    CHECK(scenes[0].sh == scenes[i].sh);
  }
}

TEST_CASE("convert: the default archive is the quick one (zstd level 9, .xz only under the dense size), level 19 "
          "decodes to the same scene in no more bytes") {
  api::ConvertOptions runtime;
  CHECK(api::zstd_level_for(runtime) == api::kDefaultZstdLevel);
  api::ConvertOptions archive;
  archive.profile = format::StorageProfile::kArchive;
  CHECK(api::zstd_level_for(archive) == api::kArchiveDefaultZstdLevel);
  CHECK(api::kArchiveDefaultZstdLevel < api::kArchiveXzMinZstdLevel);
  CHECK(archive.archive.xz);  // tried from kArchiveXzMinZstdLevel on, or below format::kArchiveDenseGaussians

  const std::string source_path = test::repo_path(test::kGuitarSh3);
  test::TempDir dir;
  api::ConvertOptions explicit_level = archive;
  explicit_level.zstd_level = api::kArchiveDefaultZstdLevel;
  api::ConvertOptions slow = archive;
  slow.zstd_level = api::kArchiveXzMinZstdLevel;
  std::vector<std::string> paths;
  for (const api::ConvertOptions* options : {&archive, &explicit_level, &slow}) {
    paths.push_back(dir.file("archive_" + std::to_string(paths.size()) + ".rgs"));
    REQUIRE(api::convert(source_path, paths.back(), *options).ok());
  }
  CHECK(test::slurp(paths[0]) == test::slurp(paths[1]));
  CHECK(test::slurp(paths[2]).size() <= test::slurp(paths[0]).size());
  std::vector<format::EncodedScene> scenes;
  for (size_t i : {size_t{0}, size_t{2}}) {
    auto file = format::RgsFile::open(paths[i]);
    REQUIRE(file.ok());
    CHECK((file->header().required_flags & format::kRequiredFlagXzCodes) != 0);  // 8,000 Gaussians: not dense
    auto scene = file->read_scene();
    REQUIRE(scene.ok());
    scenes.push_back(std::move(scene).value());
  }
  CHECK(scenes[0].means == scenes[1].means);
  CHECK(scenes[0].rotations == scenes[1].rotations);
  CHECK(scenes[0].scales == scenes[1].scales);
  CHECK(scenes[0].opacities == scenes[1].opacities);
  CHECK(scenes[0].sh == scenes[1].sh);
}

TEST_CASE("convert: the archive profile reports the errors of the decoded archive, not the runtime quantization") {
  const std::string source_path = test::repo_path(test::kGuitarSh3);
  auto source = converter::read_scene(source_path);
  REQUIRE(source.ok());
  test::TempDir dir;
  api::ConvertOptions options;
  options.profile = format::StorageProfile::kArchive;
  options.archive.opacity_bits = 4;  // opacities below 1/30 get code 0: the archive omits those Gaussians
  auto report = api::convert(source_path, dir.file("archive.rgs"), options);
  REQUIRE_MESSAGE(report.ok(), report.status().to_string());
  REQUIRE(report->rgs);
  const api::RgsOutputReport& rgs = *report->rgs;
  CHECK(rgs.extent == doctest::Approx(extent_of(source->cloud)).epsilon(1e-6));

  // The same archive built here step by step, its decoded scene put back in the source's order by hand.
  auto encoded = converter::quantize(source->cloud, {});
  REQUIRE(encoded.ok());
  const format::ArchiveOptions archive_options = options.archive;
  auto archive = format::encode_archive(*encoded, archive_options);
  REQUIRE(archive.ok());
  auto decoded = format::dequantize(archive->decoded);
  REQUIRE(decoded.ok());
  CHECK(rgs.archive_omitted == archive->omitted.size());
  CHECK(rgs.archive_omitted > 0);
  CHECK(decoded->size() + rgs.archive_omitted == source->cloud.size());
  // The errors cover the Gaussians the archive keeps: the source without the omitted ones, in its order.
  std::vector<bool> omitted(source->cloud.size(), false);
  for (uint64_t s : archive->omitted) omitted[s] = true;
  std::vector<size_t> rank(source->cloud.size(), 0);
  format::GaussianCloud kept = source->cloud;
  kept.resize(0);
  const size_t k = decoded->sh_coefficients() * 3;
  for (size_t s = 0; s < source->cloud.size(); ++s) {
    if (omitted[s]) continue;
    rank[s] = kept.size();
    kept.resize(kept.size() + 1);
    std::copy_n(&source->cloud.means[s * 3], 3, &kept.means[rank[s] * 3]);
    std::copy_n(&source->cloud.rotations[s * 4], 4, &kept.rotations[rank[s] * 4]);
    std::copy_n(&source->cloud.scales[s * 3], 3, &kept.scales[rank[s] * 3]);
    kept.opacities[rank[s]] = source->cloud.opacities[s];
    std::copy_n(&source->cloud.sh[s * k], k, &kept.sh[rank[s] * k]);
  }
  format::GaussianCloud in_order = *decoded;
  for (size_t i = 0; i < decoded->size(); ++i) {
    const size_t j = rank[archive->source_index[i]];
    std::copy_n(&decoded->means[i * 3], 3, &in_order.means[j * 3]);
    std::copy_n(&decoded->rotations[i * 4], 4, &in_order.rotations[j * 4]);
    std::copy_n(&decoded->scales[i * 3], 3, &in_order.scales[j * 3]);
    in_order.opacities[j] = decoded->opacities[i];
    std::copy_n(&decoded->sh[i * k], k, &in_order.sh[j * k]);
  }
  auto want = converter::measure_attribute_errors(kept, in_order);
  REQUIRE(want.ok());
  check_same(rgs.errors.position, want->position);
  check_same(rgs.errors.rotation_deg, want->rotation_deg);
  check_same(rgs.errors.scale_of_largest_axis, want->scale_of_largest_axis);
  check_same(rgs.errors.opacity, want->opacity);
  for (int d = 0; d <= 3; ++d) check_same(rgs.errors.sh[d], want->sh[d]);

  // Draco moves positions (the runtime profile keeps them exact), by at most half a step per coordinate.
  CHECK(rgs.position_step == doctest::Approx(archive->position.step));
  CHECK(rgs.errors.position.max > 0);
  CHECK(rgs.errors.position.max <= std::sqrt(3.0) * rgs.position_step / 2 * (1 + 1e-3));
  auto runtime = api::convert(source_path, dir.file("runtime.rgs"));
  REQUIRE(runtime.ok());
  CHECK(runtime->rgs->errors.position.max == 0);
  // The archive's coarser SH steps of degrees 1-3 show in its errors.
  CHECK(rgs.errors.sh[3].max > runtime->rgs->errors.sh[3].max);
}

TEST_CASE("convert: input_compact for SPZ and archive .rgs inputs, not for PLY or runtime .rgs") {
  test::TempDir dir;
  const std::string guitar = test::repo_path("samples/guitar.ply");
  auto ply = api::convert(guitar, dir.file("runtime.rgs"));
  REQUIRE(ply.ok());
  CHECK(!ply->input_compact);
  api::ConvertOptions archive_options;
  archive_options.profile = format::StorageProfile::kArchive;
  REQUIRE(api::convert(guitar, dir.file("archive.rgs"), archive_options).ok());

  auto from_runtime = api::convert(dir.file("runtime.rgs"), dir.file("a.ply"));
  REQUIRE(from_runtime.ok());
  CHECK(!from_runtime->input_compact);
  CHECK(from_runtime->input_storage == "rgs");
  auto from_archive = api::convert(dir.file("archive.rgs"), dir.file("b.ply"));
  REQUIRE(from_archive.ok());
  CHECK(from_archive->input_compact);
  CHECK(from_archive->input_storage == "rgs archive");
  auto spz = api::convert(test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz"), dir.file("c.rgs"));
  REQUIRE(spz.ok());
  CHECK(spz->input_compact);
  CHECK(spz->output_bytes > spz->input_bytes);  // what rgs-convert's note is about
}

}  // namespace
