// build_lod_out_of_core(): the same levels and file as build_lod() written in memory, whatever the partitions the memory
// limit cuts the scene into, with nothing left on disk after success or failure.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <iterator>
#include <string>
#include <vector>

#include "rgs/converter/lod_builder.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "temp_dir.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::EncodedBatches;
using converter::OutOfCoreLodOptions;

format::EncodedScene quantized(const std::string& path, format::ScaleEncoding encoding) {
  auto ply = converter::read_ply(path.front() == '/' ? path : repo_path(path));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  converter::QuantizeOptions options;
  options.scale_encoding = encoding;
  auto encoded = converter::quantize(ply->cloud, options);
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  encoded->provenance = {{"source_file", path}};
  return std::move(encoded).value();
}

/// Gaussians [first, first + n) of `s` as a scene of their own.
format::EncodedScene slice(const format::EncodedScene& s, uint64_t first, uint64_t n) {
  const uint64_t k3 = uint64_t{3} * format::sh_coefficient_count(s.metadata.sh_degree);
  format::EncodedScene out;
  out.count = n;
  auto copy = [&](const auto& from, auto* to, uint64_t width) {
    to->assign(from.begin() + first * width, from.begin() + (first + n) * width);
  };
  copy(s.means, &out.means, 3);
  copy(s.rotations, &out.rotations, 4);
  copy(s.scales, &out.scales, 3);
  copy(s.opacities, &out.opacities, 1);
  copy(s.sh, &out.sh, k3);
  if (!s.sh_dc_residual.empty()) copy(s.sh_dc_residual, &out.sh_dc_residual, 3);
  return out;
}

/// A scene in memory read in batches of `batch` Gaussians; from pass `change_in_pass` on, one Gaussian fewer, or
/// (move_mean) one Gaussian's mean elsewhere. The build's passes are 1 (counts) and 2 (partitions).
class SceneBatches final : public EncodedBatches {
 public:
  SceneBatches(const format::EncodedScene& scene, uint64_t batch, int change_in_pass = 0)
      : scene_(scene), batch_(batch), change_in_pass_(change_in_pass) {}
  /// From pass `pass` on, Gaussian `index` has the mean `mean` (the count stays).
  void move_mean(uint64_t index, const std::array<float, 3>& mean, int pass) {
    moved_index_ = index;
    moved_mean_ = mean;
    change_in_pass_ = pass;
  }
  Status rewind() override {
    next_ = 0;
    ++pass_;
    return Status();
  }
  Result<bool> next(format::EncodedScene* batch) override {
    const bool changed = change_in_pass_ != 0 && pass_ >= change_in_pass_;
    const uint64_t end = scene_.count - (changed && moved_index_ == kNone ? 1 : 0);
    if (next_ >= end) return false;
    const uint64_t n = std::min(batch_, end - next_);
    *batch = slice(scene_, next_, n);
    if (changed && moved_index_ >= next_ && moved_index_ < next_ + n) {
      std::copy(moved_mean_.begin(), moved_mean_.end(), &batch->means[(moved_index_ - next_) * 3]);
    }
    next_ += n;
    return true;
  }
  int passes() const { return pass_; }

 private:
  static constexpr uint64_t kNone = UINT64_MAX;
  const format::EncodedScene& scene_;
  uint64_t batch_;
  int change_in_pass_;
  uint64_t moved_index_ = kNone;
  std::array<float, 3> moved_mean_{};
  uint64_t next_ = 0;
  int pass_ = 0;
};

/// The scene without its arrays, as build_lod_out_of_core() takes it.
format::EncodedScene head_of(const format::EncodedScene& s) {
  format::EncodedScene head;
  head.count = s.count;
  head.metadata = s.metadata;
  head.provenance = s.provenance;
  return head;
}

std::vector<uint8_t> file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// `levels` written as a .rgs at `path`, their sections streamed (as the .rgs sink of a conversion writes them).
Result<uint64_t> write_levels(const std::filesystem::path& path, const converter::Levels& levels,
                              format::WriteOptions write) {
  write.lod = &levels.index();
  return format::write_streamed_scene_file(path.string(), levels.streamed(), write);
}

/// build_lod() of `scene` written in memory, and build_lod_out_of_core() of it in batches: the same levels, read
/// back range by range, and the same bytes once written.
void check_same_file(const format::EncodedScene& scene, OutOfCoreLodOptions options, uint32_t min_partitions,
                     const format::WriteOptions& write = {}) {
  auto built = converter::build_lod(scene, options.lod);
  REQUIRE_MESSAGE(built.ok(), built.status().to_string());
  format::WriteOptions in_memory = write;
  in_memory.lod = &built->index;
  auto expected = format::serialize_scene(built->scene, in_memory);
  REQUIRE_MESSAGE(expected.ok(), expected.status().to_string());

  TempDir dir;
  const std::filesystem::path out = dir.path() / "out_of_core.rgs";
  SceneBatches batches(scene, 1000);
  options.spill_folder = dir.path().string();
  auto levels = converter::build_lod_out_of_core(batches, head_of(scene), options);
  REQUIRE_MESSAGE(levels.ok(), levels.status().to_string());
  CHECK(levels->partitions >= min_partitions);
  CHECK(levels->levels->index().chunk_count == built->index.chunk_count);
  CHECK(levels->levels->index().level_count == built->index.level_count);
  CHECK(batches.passes() == 2);
  // A range across two levels reads what the in-memory build holds there.
  const uint64_t first = built->index.at(0, built->index.chunk_count - 1).first;
  const uint64_t count = std::min<uint64_t>(built->scene.count - first, 2 * built->index.at(0, 0).count + 1);
  format::EncodedScene range;
  REQUIRE(levels->levels->read(first, count, &range).ok());
  CHECK(std::equal(range.means.begin(), range.means.end(), built->scene.means.begin() + first * 3));
  CHECK(std::equal(range.sh.begin(), range.sh.end(), built->scene.sh.begin() + first * (range.sh.size() / count)));
  CHECK(levels->levels->read(built->scene.count - 1, 2, &range).code() == StatusCode::kInvalidArgument);
  auto bytes = write_levels(out, *levels->levels, write);
  REQUIRE_MESSAGE(bytes.ok(), bytes.status().to_string());
  CHECK(*bytes == expected->size());
  CHECK(file_bytes(out) == *expected);
  levels->levels.reset();
  CHECK(dir.entries() == std::vector<std::string>{"out_of_core.rgs"});  // the partitions and spills are gone
  auto file = format::RgsFile::open(out.string());
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  CHECK(file->lod() != nullptr);
}

TEST_CASE("build_lod_out_of_core: guitar in several partitions is build_lod's file byte for byte") {
  const format::EncodedScene scene = quantized("samples/guitar.ply", format::ScaleEncoding::kLinear);
  OutOfCoreLodOptions options;
  options.lod.max_chunk_gaussians = 4096;
  options.sh_dc_residual = !scene.sh_dc_residual.empty();
  options.lod.threads = 2;  // the memory a build holds apart from its partitions grows with its threads
  options.memory_limit = uint64_t{9} << 20;  // about 10,000 Gaussians a partition
  SUBCASE("auto levels") { check_same_file(scene, options, 4); }
  SUBCASE("three levels, one thread") {
    options.lod.levels = 3;
    options.lod.threads = 1;
    check_same_file(scene, options, 2);
  }
  SUBCASE("one partition") {
    options.memory_limit = uint64_t{256} << 20;
    check_same_file(scene, options, 1);
  }
}

TEST_CASE("build_lod_out_of_core: SH 3 with log scales, DC residuals and zstd metadata is build_lod's file") {
  const format::EncodedScene scene = quantized(kGuitarSh3, format::ScaleEncoding::kLog);
  REQUIRE(!scene.sh_dc_residual.empty());
  OutOfCoreLodOptions options;
  options.lod.max_chunk_gaussians = 256;
  options.lod.threads = 2;
  options.sh_dc_residual = true;
  options.memory_limit = uint64_t{8} << 20;  // about 5,000 Gaussians a partition
  format::WriteOptions write;
  write.codecs[format::SectionId::kMetadata] = format::Codec::kZstd;
  write.codecs[format::SectionId::kProvenance] = format::Codec::kZstd;
  check_same_file(scene, options, 2, write);
}

TEST_CASE("build_lod_out_of_core: the PlayCanvas flowers (542,104 Gaussians, SH 3) in several partitions") {
  const std::string path = shared_scene("playcanvas_flowers_lod0.ply");
  if (path.empty()) return;
  const format::EncodedScene scene = quantized(path, format::ScaleEncoding::kLinear);
  OutOfCoreLodOptions options;
  options.lod.threads = 2;
  options.sh_dc_residual = !scene.sh_dc_residual.empty();
  options.memory_limit = uint64_t{48} << 20;  // about 150,000 Gaussians a partition
  check_same_file(scene, options, 3);
}

TEST_CASE("build_lod_out_of_core: failures leave nothing behind, and a limit too small for a chunk is refused") {
  const format::EncodedScene scene = quantized("samples/guitar.ply", format::ScaleEncoding::kLinear);
  OutOfCoreLodOptions options;
  options.lod.max_chunk_gaussians = 4096;
  options.sh_dc_residual = !scene.sh_dc_residual.empty();
  options.lod.threads = 2;
  options.memory_limit = uint64_t{9} << 20;
  TempDir dir;
  options.spill_folder = dir.path().string();

  SUBCASE("an input that changes between passes") {
    SceneBatches changing(scene, 1000, 2);
    auto r = converter::build_lod_out_of_core(changing, head_of(scene), options);
    REQUIRE(!r.ok());
    CHECK(r.status().code() == StatusCode::kCorruptData);
    CHECK(r.status().message().find("did it change while it was read?") != std::string::npos);
  }
  SUBCASE("a memory limit below what one chunk needs") {
    options.memory_limit = uint64_t{1} << 20;
    SceneBatches batches(scene, 1000);
    auto r = converter::build_lod_out_of_core(batches, head_of(scene), options);
    REQUIRE(!r.ok());
    CHECK(r.status().code() == StatusCode::kLimitExceeded);
    CHECK(r.status().message().find("that chunks of 4096 Gaussians need") != std::string::npos);
  }
  SUBCASE("a spill folder that does not exist") {
    SceneBatches batches(scene, 1000);
    options.spill_folder = (dir.path() / "missing").string();
    auto r = converter::build_lod_out_of_core(batches, head_of(scene), options);
    REQUIRE(!r.ok());
    CHECK(r.status().code() == StatusCode::kIoError);
  }
  CHECK(dir.entries().empty());
}

/// A corner of the scene's box with no mean within 1/8 of the box's largest side of it (in every axis): its cell
/// of any count grid of 8 or more cells per axis is empty.
std::array<float, 3> empty_corner(const format::EncodedScene& scene) {
  const auto& b = scene.metadata.bounds;
  float edge = 0;
  for (int a = 0; a < 3; ++a) edge = std::max(edge, b.aabb_max[a] - b.aabb_min[a]);
  for (int corner = 0; corner < 8; ++corner) {
    std::array<float, 3> p;
    for (int a = 0; a < 3; ++a) p[a] = (corner >> a & 1) ? b.aabb_max[a] : b.aabb_min[a];
    bool empty = true;
    for (uint64_t i = 0; i < scene.count && empty; ++i) {
      bool near = true;
      for (int a = 0; a < 3; ++a) near = near && std::fabs(scene.means[i * 3 + a] - p[a]) < edge / 8;
      empty = !near;
    }
    if (empty) return p;
  }
  FAIL("no corner of the box without a mean near it");
  return {};
}

TEST_CASE("build_lod_out_of_core: a later pass's mean outside the box or in another cell is refused, nothing kept") {
  const format::EncodedScene scene = quantized("samples/guitar.ply", format::ScaleEncoding::kLinear);
  OutOfCoreLodOptions options;
  options.lod.max_chunk_gaussians = 4096;
  options.sh_dc_residual = !scene.sh_dc_residual.empty();
  options.lod.threads = 2;
  options.memory_limit = uint64_t{9} << 20;  // several partitions
  TempDir dir;
  options.spill_folder = dir.path().string();
  const auto& box = scene.metadata.bounds;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // The Gaussian farthest from Gaussian 0: another octree node of the counts whatever their depth.
  uint64_t far = 0;
  double far_distance = 0;
  for (uint64_t i = 1; i < scene.count; ++i) {
    double d = 0;
    for (int a = 0; a < 3; ++a) d += std::pow(double(scene.means[i * 3 + a]) - scene.means[a], 2);
    if (d > far_distance) far_distance = d, far = i;
  }
  const std::array<float, 3> far_mean = {scene.means[far * 3], scene.means[far * 3 + 1], scene.means[far * 3 + 2]};
  struct Case {
    const char* what;
    std::array<float, 3> mean;
    int pass;
    const char* message;
  };
  const Case cases[] = {
      {"beyond the box, counting", {box.aabb_max[0] + 1, box.aabb_min[1], box.aabb_min[2]}, 1,
       "outside the scene's box"},
      {"beyond the box, partitioning", {box.aabb_min[0], box.aabb_min[1] - 1e30f, box.aabb_min[2]}, 2,
       "outside the scene's box"},
      {"NaN, partitioning", {nan, box.aabb_min[1], box.aabb_min[2]}, 2, "outside the scene's box"},
      {"a cell the counts found empty, partitioning", empty_corner(scene), 2, "other Gaussians than in its first pass"},
      {"another node, partitioning", far_mean, 2, "other Gaussians than in its first pass"},
  };
  for (const uint64_t memory : {uint64_t{9} << 20, uint64_t{256} << 20}) {  // several partitions, then one
    options.memory_limit = memory;
    for (const Case& c : cases) {
      CAPTURE(memory);
      CAPTURE(std::string(c.what));
      SceneBatches changing(scene, 1000);
      changing.move_mean(0, c.mean, c.pass);
      auto r = converter::build_lod_out_of_core(changing, head_of(scene), options);
      REQUIRE(!r.ok());
      CHECK(r.status().code() == StatusCode::kCorruptData);
      CHECK_MESSAGE(r.status().message().find(c.message) != std::string::npos, r.status().message());
      CHECK(r.status().message().find("did it change while it was read?") != std::string::npos);
      CHECK(dir.entries().empty());
    }
  }
}

}  // namespace
}  // namespace rgs::test
