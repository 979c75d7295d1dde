// SOG output: our writer read back by our SOG reader (bundle and folder), the bounds of each attribute, SH
// bands through the palette, the same bytes twice, and outputs that must fail without leaving anything behind;
// the streamed SOG's per-leaf error tables written, read back, and refused when malformed.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "ply_test_util.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/playcanvas_readers.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/sog_writer.h"
#include "rgs/format/encoded_scene.h"
#include "test_data.h"

namespace rgs::test {
namespace {

namespace fs = std::filesystem;
using converter::SogContainer;
using converter::SogWriteOptions;

format::GaussianCloud read_cloud(const std::string& path) {
  auto r = converter::read_scene(path);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value().cloud;
}

/// A fresh empty folder under the system temporary folder.
fs::path fresh_folder(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("rgs_sog_writer_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<uint8_t> file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

/// Writes `cloud` as SOG in `container` form under `dir` and reads it back with read_sog.
format::GaussianCloud round_trip(const format::GaussianCloud& cloud, SogContainer container, const fs::path& dir) {
  SogWriteOptions options;
  options.container = container;
  const fs::path path = dir / (container == SogContainer::kBundle ? "scene.sog" : "meta.json");
  auto written = converter::write_sog(path.string(), cloud, options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(written->bytes > 0);
  auto back = converter::read_sog(path.string());
  REQUIRE_MESSAGE(back.ok(), back.status().to_string());
  return std::move(back).value().cloud;
}

/// The largest position error SOG's quantization allows for `cloud`: half a 16-bit step of sign(x)·ln(|x| + 1)
/// on each axis, mapped back through exp at the largest |coordinate|, plus float32 rounding.
double position_bound(const format::GaussianCloud& cloud) {
  double bound2 = 0;
  for (int a = 0; a < 3; ++a) {
    double lo = 0, hi = 0, largest = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      const double x = cloud.means[i * 3 + a];
      const double t = x < 0 ? -std::log1p(-x) : std::log1p(x);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
      largest = std::max(largest, std::fabs(x));
    }
    const double half_step = (hi - lo) / 65535.0 / 2.0;
    const double e = (largest + 1) * std::expm1(half_step) + largest * 1e-6;
    bound2 += e * e;
  }
  return std::sqrt(bound2);
}

/// Bounds of what a k-means codebook or 8-bit field loses, stated per test (measured, with a margin).
struct Bounds {
  double rotation_deg_max;       ///< smallest three at 8 bits per component
  double scale_of_largest_rms;   ///< 256 log-scale codes
  double sh_dc_rms;              ///< 256 DC codes
  double sh_dc_max;
  double sh_rest_rms;            ///< palette, then 256 codes
};

void check_errors(const format::GaussianCloud& ref, const format::GaussianCloud& back, const Bounds& b) {
  REQUIRE(back.size() == ref.size());
  REQUIRE(back.sh_degree == ref.sh_degree);
  auto errors = converter::measure_attribute_errors(ref, back);
  REQUIRE_MESSAGE(errors.ok(), errors.status().to_string());
  const converter::AttributeErrors& e = *errors;
  MESSAGE("position max " << e.position.max << " (bound " << position_bound(ref) << "), rotation max "
                          << e.rotation_deg.max << " deg, scale of largest axis rms " << e.scale_of_largest_axis.rms << " max "
                          << e.scale_of_largest_axis.max << ", opacity max "
                          << e.opacity.max << ", SH DC rms " << e.sh[0].rms << " max " << e.sh[0].max
                          << ", SH rest rms " << e.sh[1].rms << " " << e.sh[2].rms << " " << e.sh[3].rms);
  CHECK(e.position.max <= position_bound(ref));
  CHECK(e.rotation_deg.max <= b.rotation_deg_max);
  CHECK(e.scale_of_largest_axis.rms <= b.scale_of_largest_rms);
  // Opacity is 8 bits: half a step, plus the reader's logit clamp at 1e-6.
  CHECK(e.opacity.max <= 0.5 / 255 + 2e-6);
  CHECK(e.sh[0].rms <= b.sh_dc_rms);
  CHECK(e.sh[0].max <= b.sh_dc_max);
  // No Gaussian loses its size: the codebook keeps codes for the sparse tail of huge background Gaussians.
  CHECK(e.scale_of_largest_axis.max <= 0.15);
  for (uint32_t d = 1; d <= ref.sh_degree; ++d) CHECK(e.sh[d].rms <= b.sh_rest_rms);
}

TEST_CASE("SOG output of guitar reads back within the bounds of its quantization, bundle and folder alike") {
  const format::GaussianCloud cloud = read_cloud(repo_path("samples/guitar.ply"));
  const fs::path dir = fresh_folder("guitar");
  const format::GaussianCloud bundle = round_trip(cloud, SogContainer::kBundle, dir);
  check_errors(cloud, bundle, {1.0, 0.02, 0.01, 0.1, 0});
  const format::GaussianCloud folder = round_trip(cloud, SogContainer::kFolder, dir);
  CHECK(folder.means == bundle.means);
  CHECK(folder.rotations == bundle.rotations);
  CHECK(folder.scales == bundle.scales);
  CHECK(folder.opacities == bundle.opacities);
  CHECK(folder.sh == bundle.sh);
  fs::remove_all(dir);
}

TEST_CASE("SOG output carries SH bands 1-3 through its palette") {
  const format::GaussianCloud cloud = read_cloud(repo_path(kGuitarSh3));
  REQUIRE(cloud.sh_degree == 3);
  const fs::path dir = fresh_folder("sh3");
  check_errors(cloud, round_trip(cloud, SogContainer::kBundle, dir), {1.0, 0.02, 0.01, 0.1, 0.01});
  fs::remove_all(dir);
}

TEST_CASE("SOG output of the real SH-3 flowers scene reads back within its bounds") {
  const std::string path = shared_scene("mipnerf360_flowers_c3dgs.ply");
  if (path.empty()) return;
  const format::GaussianCloud cloud = read_cloud(path);
  const fs::path dir = fresh_folder("flowers");
  check_errors(cloud, round_trip(cloud, SogContainer::kBundle, dir), {1.0, 0.02, 0.01, 0.1, 0.01});
  fs::remove_all(dir);
}

/// The distinct SH rest vectors of `cloud` (bands 1-3 of each Gaussian).
size_t distinct_sh_rest(const format::GaussianCloud& cloud) {
  const size_t per = size_t{cloud.sh_coefficients()} * 3;
  std::set<std::vector<float>> rests;
  for (size_t i = 0; i < cloud.size(); ++i) {
    rests.emplace(cloud.sh.begin() + i * per + 3, cloud.sh.begin() + (i + 1) * per);
  }
  return rests.size();
}

/// `cloud` as a .sog under `dir`, its summary, and the cloud read back.
format::GaussianCloud write_and_read(const format::GaussianCloud& cloud, const fs::path& dir,
                                     converter::SogWriteSummary* summary) {
  auto written = converter::write_sog((dir / "scene.sog").string(), cloud);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  *summary = *written;
  auto back = converter::read_sog((dir / "scene.sog").string());
  REQUIRE_MESSAGE(back.ok(), back.status().to_string());
  return std::move(back).value().cloud;
}

// The 90,854 SH-0 Gaussians of guitar all hold the zero SH rest vector after the merge: as 90,854 vectors they
// took ~60,000 fine palette entries and a k-means of 60,000 centroids over 90,000 samples (many minutes).
TEST_CASE("SOG output of SH-0 guitar merged with an SH-3 scene spends no palette entries on the shared zero vector") {
  std::vector<converter::InputScene> scenes;
  for (const char* file : {"samples/guitar.ply", kGuitarSh3}) {
    auto r = converter::read_scene(repo_path(file));
    REQUIRE(r.ok());
    scenes.push_back(std::move(r).value());
  }
  auto merged = converter::merge_scenes(std::move(scenes));
  REQUIRE(merged.ok());
  const format::GaussianCloud& cloud = merged->cloud;
  REQUIRE(cloud.sh_degree == 3);
  const fs::path dir = fresh_folder("merged");
  converter::SogWriteSummary summary;
  const format::GaussianCloud back = write_and_read(cloud, dir, &summary);
  // 8,000 distinct vectors and the zero one fit the palette (65,536 entries): it holds exactly those.
  CHECK(summary.palette_entries == distinct_sh_rest(cloud));
  CHECK(summary.palette_entries == 8001);
  check_errors(cloud, back, {1.0, 0.02, 0.01, 0.1, 0.01});
  fs::remove_all(dir);
}

TEST_CASE("SOG palette k-means spends its entries on distinct SH vectors when a quarter of the Gaussians share one") {
  format::GaussianCloud cloud = read_cloud(repo_path(kGuitarSh3));
  const size_t per = size_t{cloud.sh_coefficients()} * 3;
  for (size_t i = 6000; i < cloud.size(); ++i) std::fill_n(cloud.sh.begin() + i * per + 3, per - 3, 0.0f);
  REQUIRE(distinct_sh_rest(cloud) == 6001);  // more than the 4,096 palette entries: the k-means runs
  const fs::path dir = fresh_folder("shared_sh");
  converter::SogWriteSummary summary;
  const format::GaussianCloud back = write_and_read(cloud, dir, &summary);
  REQUIRE(summary.palette_entries <= 4096);
  // Nearly every entry is used: duplicates no longer start ~1,000 identical centroids of
  // which all but one stay empty (3,049 of 4,058 entries used before, SH rest rms 0.0021-0.0024; now all
  // 4,096, rms 0.0015-0.0017).
  MESSAGE("palette entries used: " << distinct_sh_rest(back) << " of " << summary.palette_entries);
  CHECK(distinct_sh_rest(back) >= 4096 * 95 / 100);
  check_errors(cloud, back, {1.0, 0.02, 0.01, 0.1, 0.01});
  fs::remove_all(dir);
}

TEST_CASE("SOG output is deterministic: the same cloud gives the same bytes") {
  const format::GaussianCloud cloud = read_cloud(repo_path(kGuitarSh3));
  auto a = converter::encode_sog(cloud);
  auto b = converter::encode_sog(cloud);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  REQUIRE(a->size() == b->size());
  for (size_t f = 0; f < a->size(); ++f) {
    CHECK((*a)[f].name == (*b)[f].name);
    CHECK((*a)[f].bytes == (*b)[f].bytes);
  }
  CHECK(converter::bundle_sog(*a) == converter::bundle_sog(*b));
}

TEST_CASE("SOG output that fails leaves nothing behind and an existing file unchanged") {
  format::GaussianCloud cloud = read_cloud(repo_path("samples/guitar.ply"));
  const fs::path dir = fresh_folder("fail");
  const fs::path existing = dir / "scene.sog";
  { std::ofstream(existing, std::ios::binary) << "earlier content"; }
  cloud.means[7] = std::nanf("");
  auto r = converter::write_sog(existing.string(), cloud);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(file_bytes(existing) == std::vector<uint8_t>{'e', 'a', 'r', 'l', 'i', 'e', 'r', ' ', 'c', 'o', 'n', 't', 'e',
                                                     'n', 't'});
  SogWriteOptions folder;
  folder.container = SogContainer::kFolder;
  r = converter::write_sog((dir / "meta.json").string(), cloud, folder);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  r = converter::write_sog((dir / "missing" / "scene.sog").string(), read_cloud(repo_path("samples/guitar.ply")));
  CHECK(r.status().code() == StatusCode::kIoError);
  size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    (void)e;
    ++entries;
  }
  CHECK(entries == 1);  // scene.sog as it was
  fs::remove_all(dir);
}

/// `cloud`'s levels of detail (runtime profile, build_lod with `levels`, 0 = auto, small chunks so there are
/// several) written as a streamed SOG under `dir`; checks every level reads back with its Gaussian count and
/// returns level 0 read back beside the runtime profile's level 0 it was written from.
std::pair<format::GaussianCloud, format::GaussianCloud> streamed_round_trip(const format::GaussianCloud& cloud,
                                                                           const fs::path& dir) {
  auto encoded = converter::quantize(cloud, {});
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  converter::LodBuildOptions lod_options;
  lod_options.max_chunk_gaussians = 16384;
  auto lod = converter::build_lod(*encoded, lod_options);
  REQUIRE_MESSAGE(lod.ok(), lod.status().to_string());
  const std::string path = (dir / "lod-meta.json").string();
  auto written = converter::write_sog_lod(path, *converter::held_levels(*lod));
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  const format::LodIndex& index = lod->index;
  REQUIRE(index.chunk_count > 1);
  REQUIRE(index.level_count > 1);
  for (uint32_t l = 0; l < index.level_count; ++l) {
    converter::SceneReadOptions o;
    o.lod = l;
    auto back = converter::read_sog_lod(path, o);
    REQUIRE_MESSAGE(back.ok(), back.status().to_string());
    uint64_t expected = 0;
    for (uint32_t c = 0; c < index.chunk_count; ++c) expected += index.at(l, c).count;
    CHECK(back->cloud.size() == expected);
  }
  auto level0 = converter::read_sog_lod(path);
  REQUIRE(level0.ok());
  format::GaussianCloud written0;
  REQUIRE(format::dequantize_range(lod->scene, 0, index.full_detail_count(), &written0).ok());
  return {std::move(written0), std::move(level0).value().cloud};
}

TEST_CASE("Streamed SOG output reads back every level, level 0 within SOG's bounds of the runtime profile") {
  const fs::path dir = fresh_folder("streamed");
  auto [written0, back0] = streamed_round_trip(read_cloud(repo_path("samples/guitar.ply")), dir);
  check_errors(written0, back0, {1.0, 0.02, 0.01, 0.1, 0});
  fs::remove_all(dir);
}

TEST_CASE("Streamed SOG output of the SH-3 flowers scene keeps level 0 within its bounds") {
  const std::string path = shared_scene("mipnerf360_flowers_c3dgs.ply");
  if (path.empty()) return;
  const fs::path dir = fresh_folder("streamed_flowers");
  auto [written0, back0] = streamed_round_trip(read_cloud(path), dir);
  check_errors(written0, back0, {1.0, 0.02, 0.01, 0.1, 0.01});
  fs::remove_all(dir);
}

TEST_CASE("Streamed SOG output of taebak (4.25M Gaussians, read from its streamed SOG) keeps level 0 within bounds") {
  const std::string path = shared_scene("taebak_lod0_sog/lod-meta.json");
  if (path.empty()) return;
  const fs::path dir = fresh_folder("streamed_taebak");
  auto [written0, back0] = streamed_round_trip(read_cloud(path), dir);
  check_errors(written0, back0, {1.0, 0.02, 0.01, 0.1, 0});
  fs::remove_all(dir);
}

/// The leaves of a lod-meta.json `tree`, in tree order (depth first, children in order).
void collect_leaves(nlohmann::json& node, std::vector<nlohmann::json*>* out) {
  if (node.contains("lods")) out->push_back(&node);
  if (node.contains("children")) {
    for (nlohmann::json& child : node["children"]) collect_leaves(child, out);
  }
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST_CASE("Streamed SOG output carries every leaf's error table in PlayCanvas's unit, read back as written") {
  auto encoded = converter::quantize(read_cloud(repo_path("samples/guitar.ply")), {});
  REQUIRE(encoded.ok());
  auto lod = converter::build_lod(*encoded, {});
  REQUIRE(lod.ok());
  const format::LodIndex& index = lod->index;
  REQUIRE(index.chunk_count > 1);
  REQUIRE(index.level_count > 2);
  const fs::path dir = fresh_folder("streamed_errors");
  const fs::path meta_path = dir / "lod-meta.json";
  REQUIRE(converter::write_sog_lod(meta_path.string(), *converter::held_levels(*lod)).ok());
  nlohmann::json meta = nlohmann::json::parse(read_text(meta_path));
  CHECK(meta["lodErrors"] == true);
  std::vector<nlohmann::json*> leaves;
  collect_leaves(meta["tree"], &leaves);
  REQUIRE(leaves.size() == index.chunk_count);  // one leaf per chunk, in the chunks' order
  double largest = 0;
  for (uint32_t c = 0; c < index.chunk_count; ++c) {
    const nlohmann::json& leaf = *leaves[c];
    REQUIRE(leaf["errors"].size() == index.level_count);
    double half_squared = 0;  // half the bound's diagonal, squared
    for (int a = 0; a < 3; ++a) {
      const double d = leaf["bound"]["max"][a].get<double>() - leaf["bound"]["min"][a].get<double>();
      half_squared += d * d / 4;
    }
    for (uint32_t l = 0; l < index.level_count; ++l) {
      const double e = index.at(l, c).error;
      CHECK(leaf["errors"][l].get<double>() == doctest::Approx(e * e / half_squared).epsilon(1e-9));
      if (l > 0) CHECK(leaf["errors"][l].get<double>() >= leaf["errors"][l - 1].get<double>());
      largest = std::max(largest, leaf["errors"][l].get<double>());
    }
    CHECK(leaf["errors"][0].get<double>() == 0);
  }
  CHECK(largest > 0);
  auto back = converter::read_sog_lod(meta_path.string());
  REQUIRE_MESSAGE(back.ok(), back.status().to_string());
  REQUIRE(back->lod_errors.size() == leaves.size());
  for (size_t k = 0; k < leaves.size(); ++k) {
    CHECK(back->lod_errors[k] == (*leaves[k])["errors"].get<std::vector<double>>());  // exact: JSON keeps 17 digits
  }

  // Malformed tables are refused, naming the file and the leaf.
  const nlohmann::json good = meta;
  auto refused = [&](const char* what, const std::function<void(nlohmann::json&)>& damage, const char* expect) {
    CAPTURE(what);
    nlohmann::json bad = good;
    damage(bad);
    std::ofstream(meta_path, std::ios::binary | std::ios::trunc) << bad.dump();
    auto r = converter::read_sog_lod(meta_path.string());
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kCorruptData);
    CHECK(r.status().message().find(meta_path.string()) != std::string::npos);
    CHECK_MESSAGE(r.status().message().find(expect) != std::string::npos, r.status().message());
  };
  auto second_leaf = [](nlohmann::json& m) -> nlohmann::json& {
    std::vector<nlohmann::json*> l;
    collect_leaves(m["tree"], &l);
    return *l[1];
  };
  refused("short", [&](nlohmann::json& m) { second_leaf(m)["errors"].erase(0); }, "tree leaf 1.errors' has");
  refused("negative", [&](nlohmann::json& m) { second_leaf(m)["errors"][2] = -0.5; }, "errors[2]' is negative");
  refused("not a number", [&](nlohmann::json& m) { second_leaf(m)["errors"][1] = "NaN"; }, "not a number");
  refused("missing", [&](nlohmann::json& m) { second_leaf(m).erase("errors"); }, "missing field 'tree leaf 1.errors'");
  refused("flag", [&](nlohmann::json& m) { m["lodErrors"] = "yes"; }, "'lodErrors' is not a boolean");
  refused("undeclared", [&](nlohmann::json& m) {
    m["lodErrors"] = false;
    second_leaf(m)["errors"] = {0};
  }, "tree leaf 1.errors' has 1 entries");
  for (const char* token : {"NaN", "1e999"}) {  // JSON has no NaN, and the parser refuses an overflow
    std::string text = good.dump();
    const size_t open = text.find("\"errors\":[") + 10;
    std::string table = "0";
    for (uint32_t l = 2; l < index.level_count; ++l) table += ",0";
    text.replace(open, text.find(']', open) - open, table + "," + token);
    std::ofstream(meta_path, std::ios::binary | std::ios::trunc) << text;
    auto r = converter::read_sog_lod(meta_path.string());
    REQUIRE_FALSE(r.ok());
    CHECK_MESSAGE(r.status().message().find(meta_path.string() + ": streamed SOG lod-meta.json: invalid JSON") == 0,
                  r.status().message());
  }
  fs::remove_all(dir);
}

TEST_CASE("Streamed SOG output that fails removes the folders it created") {
  format::GaussianCloud cloud = read_cloud(repo_path("samples/guitar.ply"));
  auto encoded = converter::quantize(cloud, {});
  REQUIRE(encoded.ok());
  auto lod = converter::build_lod(*encoded, {});
  REQUIRE(lod.ok());
  lod->index.at(0, 0).count = lod->scene.count + 1;  // a range outside the scene
  const fs::path dir = fresh_folder("streamed_fail");
  auto r = converter::write_sog_lod((dir / "lod-meta.json").string(), *converter::held_levels(*lod));
  CHECK(r.status().code() == StatusCode::kCorruptData);
  CHECK(fs::is_empty(dir));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rgs::test
