// Golden files of format versions 1.0, 1.2 and 1.3 (tests/data/v1.*/), written by tests/data/make_rgs_corpus.py, an
// independent implementation of SPEC.md. They must keep reading the same forever (CONTRIBUTING.md#tests).
#include <doctest/doctest.h>

#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

using namespace rgs;
using namespace rgs::format;
using rgs::test::data_path;
using rgs::test::range_checksum;
using rgs::test::read_file_bytes;

RgsFile must_open_path(const std::string& path) {
  auto file = RgsFile::open(path);
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  return std::move(file).value();
}

/// The scene and level-of-detail index of tests/data/v1.3/small_sh1_lod.rgs (make_rgs_corpus.py small_sh1_lod();
/// keep them in step): 2 chunks x 3 levels, level-major, every level of every chunk in the arrays (N = 24).
/// The index's checksums are left 0: the writer computes them.
struct SmallLod {
  EncodedScene scene;
  LodIndex index;
};

SmallLod make_small_sh1_lod() {
  const float centers[2][3] = {{-1.0f, 0.0f, 2.0f}, {1.0f, 0.0f, 2.0f}};
  const uint64_t counts[3][2] = {{8, 6}, {4, 3}, {2, 1}};
  const float errors[3][2] = {{0.0f, 0.0f}, {0.125f, 0.25f}, {0.5f, 0.75f}};
  const uint32_t degree = 1, k = 4;
  SmallLod out;
  LodIndex& index = out.index;
  index.chunk_count = 2;
  index.level_count = 3;
  for (const auto& c : centers) index.chunks.push_back(LodChunk{{c[0], c[1], c[2]}, 1.0f});
  EncodedScene& s = out.scene;
  uint64_t i = 0;
  for (int l = 0; l < 3; ++l) {
    for (int c = 0; c < 2; ++c) {
      LodLevel& v = index.levels.emplace_back();
      v.first = i;
      v.count = counts[l][c];
      v.error = errors[l][c];
      for (int j = 0; j < static_cast<int>(v.count); ++j) {
        const float offset[3] = {static_cast<float>((j * 3 + l) % 7 - 3) * 0.125f,
                                 static_cast<float>((j * 2 + c) % 5 - 2) * 0.125f,
                                 static_cast<float>((j + 2 * l) % 3 - 1) * 0.25f};
        for (int a = 0; a < 3; ++a) s.means.push_back(centers[c][a] + offset[a]);
        for (uint16_t q : test::kQuats[(i + l) % 4]) s.rotations.push_back(q);
        for (uint64_t a = 0; a < 3; ++a) {
          uint16_t bits = l == 0 ? static_cast<uint16_t>(0x2000 + ((i * 3 + a) * 37) % 0x0C00)
                                 : static_cast<uint16_t>(0x2C00 + (l - 1) * 0x0200 + ((i * 3 + a) * 29) % 0x0200);
          if (i == 3 && a == 1) bits = 0x0000;
          s.scales.push_back(bits);
        }
        s.opacities.push_back(static_cast<uint16_t>(i == 0 ? 0x3C00 : (i * 677) % 0x3C01));
        for (uint64_t kk = 0; kk < k; ++kk) {
          for (uint64_t ch = 0; ch < 3; ++ch) {
            s.sh.push_back(static_cast<int8_t>(static_cast<int>((i * 37 + kk * 11 + ch * 5) % 255) - 127));
          }
        }
        for (uint64_t ch = 0; ch < 3; ++ch) {
          s.sh_dc_residual.push_back(static_cast<int8_t>(static_cast<int>((i * 3 + ch) * 11 % 256) - 128));
        }
        ++i;
      }
    }
  }
  s.count = i;
  auto& m = s.metadata;
  m.sh_degree = degree;
  m.scale_encoding = ScaleEncoding::kLinear;
  const float lo[3] = {-1.375f, -0.25f, 1.75f}, hi[3] = {1.375f, 0.25f, 2.25f}, center[3] = {0.0f, 0.0f, 2.0f};
  for (int a = 0; a < 3; ++a) {
    m.bounds.aabb_min[a] = lo[a];
    m.bounds.aabb_max[a] = hi[a];
    m.bounds.sphere_center[a] = center[a];
  }
  m.bounds.sphere_radius = 1.5f;
  for (uint32_t d = 0; d < 4; ++d) {
    for (uint32_t ch = 0; ch < 3; ++ch) {
      m.sh_quantization.scales[d][ch] =
          d <= degree ? static_cast<float>(ch + 1) * std::ldexp(1.0f, -static_cast<int>(d + 3)) : 0.0f;
    }
  }
  s.provenance = {{"source", "synthetic small_sh1_lod (tests/data/make_rgs_corpus.py)"},
                  {"options", "sh_degree=1 scale_encoding=linear codec=none sh_dc_residual lod=2x3"}};
  return out;
}

}  // namespace

TEST_CASE("golden v1.0/small_sh3.rgs: known values, and the writer reproduces it byte for byte") {
  const std::string path = data_path("v1.0/small_sh3.rgs");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  REQUIRE(bytes.size() == 3056);
  const RgsFile file = must_open_path(path);
  CHECK(file.name() == path);
  const FileHeader& h = file.header();
  CHECK(h.major == 1);
  CHECK(h.minor == 0);
  CHECK(h.required_flags == 0);
  CHECK(h.optional_flags == 0);
  CHECK(h.gaussian_count == 21);
  CHECK(h.section_count == 7);
  CHECK(h.table_offset == 64);
  CHECK(h.file_size == 3056);

  // §3 Offsets: the table ends at 64 + 7 * 64 = 512; each section starts at the next multiple of 256.
  const std::vector<std::pair<SectionId, uint64_t>> offsets = {
      {SectionId::kMetadata, 512}, {SectionId::kProvenance, 768}, {SectionId::kMeans, 1024},
      {SectionId::kRotations, 1280}, {SectionId::kScales, 1536}, {SectionId::kOpacities, 1792},
      {SectionId::kSh, 2048}};
  REQUIRE(file.sections().size() == offsets.size());
  for (size_t i = 0; i < offsets.size(); ++i) {
    CHECK(file.sections()[i].id == offsets[i].first);
    CHECK(file.sections()[i].offset == offsets[i].second);
  }
  CHECK(file.find(SectionId::kSh)->components == 48);
  CHECK(file.find(SectionId::kSh)->stored_size == 21 * 48);

  const SceneMetadata& m = file.metadata();
  CHECK(m.sh_degree == 3);
  CHECK(m.frame == CoordinateFrame::kColmap);
  CHECK(m.quaternion_order == QuaternionOrder::kWxyz);
  CHECK(m.scale_encoding == ScaleEncoding::kLinear);
  CHECK(m.opacity_encoding == OpacityEncoding::kSigmoid);
  CHECK(m.sh_layout == ShLayout::kCoefficientMajor);
  CHECK(m.bounds.aabb_min[0] == -1.5f);
  CHECK(m.bounds.aabb_max[2] == 4.5f);
  CHECK(m.bounds.sphere_center[2] == 3.25f);
  CHECK(m.bounds.sphere_radius == 2.125f);
  CHECK(m.sh_quantization.bits == 8);
  CHECK(m.sh_quantization.clip_percentile == 100.0f);
  CHECK(m.sh_quantization.scales[0][0] == 0.125f);
  CHECK(m.sh_quantization.scales[3][2] == 0.046875f);
  REQUIRE(file.provenance().size() == 4);
  CHECK(file.provenance()[0].first == "source");
  CHECK(file.provenance()[3].second == "Gau\xc3\x9f" "ian \xe2\x9c\x93");

  auto scene = file.read_scene();
  REQUIRE(scene.ok());
  CHECK(scene->means[0] == -1.5f);
  CHECK(scene->means[1] == -0.5f);
  CHECK(scene->means[2] == 2.0f);
  CHECK(scene->means[20 * 3 + 2] == 4.5f);
  CHECK(scene->rotations[2 * 4] == 0x3800);
  CHECK(scene->scales[5 * 3 + 2] == 0x0000);
  CHECK(scene->scales[6 * 3 + 0] == 0x0001);
  CHECK(scene->opacities[20] == 0x3c00);
  CHECK(scene->sh[0] == -127);
  CHECK(scene->sh[1] == -124);
  test::check_same_scene(*scene, test::make_small_sh3());

  auto cloud = dequantize(*scene);
  REQUIRE(cloud.ok());
  CHECK(cloud->opacities[20] == 1.0f);
  CHECK(cloud->sh[0] == -127 * 0.125f);

  const Status valid = validate(bytes.data(), bytes.size(), ReadLimits{}, path);
  CHECK_MESSAGE(valid.ok(), valid.to_string());
  // Two independent writers, one spec: the C++ writer reproduces the Python-written file exactly.
  auto rewritten = serialize_scene(test::make_small_sh3());
  REQUIRE(rewritten.ok());
  CHECK(*rewritten == bytes);
  auto again = serialize_scene(*scene);
  REQUIRE(again.ok());
  CHECK(*again == bytes);
}

TEST_CASE("golden v1.0/small_sh0_zstd.rgs: zstd frames of raw and RLE blocks decode to known values") {
  const std::string path = data_path("v1.0/small_sh0_zstd.rgs");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  const RgsFile file = must_open_path(path);
  CHECK(file.gaussian_count() == 64);
  CHECK(file.metadata().sh_degree == 0);
  CHECK(file.metadata().scale_encoding == ScaleEncoding::kLog);
  for (const SectionEntry& e : file.sections()) {
    CHECK(e.codec == Codec::kZstd);
    CHECK(e.offset % kSectionAlignment == 0);
  }
  // The scales of Gaussians 32..63 are 192 zero bytes, stored as one RLE block: 64*6 raw bytes in far
  // fewer stored ones.
  CHECK(file.find(SectionId::kScales)->raw_size == 384);
  CHECK(file.find(SectionId::kScales)->stored_size < 300);
  auto scene = file.read_scene();
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  test::check_same_scene(*scene, test::make_small_sh0_zstd());
  const Status valid = validate(bytes.data(), bytes.size(), ReadLimits{}, path);
  CHECK_MESSAGE(valid.ok(), valid.to_string());

  // Our zstd writer makes different (smaller) frames of the same content; both decode the same.
  WriteOptions zstd;
  for (const SectionEntry& e : file.sections()) zstd.codecs[e.id] = Codec::kZstd;
  auto rewritten = serialize_scene(*scene, zstd);
  REQUIRE(rewritten.ok());
  auto reread = RgsFile::from_bytes(rewritten->data(), rewritten->size());
  REQUIRE(reread.ok());
  test::check_same_scene(reread->read_scene().value(), *scene);
  // Log scales dequantize through exp().
  auto cloud = dequantize(*scene);
  REQUIRE(cloud.ok());
  CHECK(cloud->scales[40 * 3] == 1.0f);
}

TEST_CASE("golden v1.2/small_sh0_dc_residual.rgs: the DC residual decodes as s(q + r/256), written byte for byte") {
  const std::string path = data_path("v1.2/small_sh0_dc_residual.rgs");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  const RgsFile file = must_open_path(path);
  CHECK(file.header().minor == 2);
  REQUIRE(file.find(SectionId::kShDcResidual) != nullptr);
  CHECK(file.find(SectionId::kShDcResidual)->components == 3);
  auto scene = file.read_scene();
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  const EncodedScene expected = test::make_small_sh0_dc_residual();
  test::check_same_scene(*scene, expected);
  const Status valid = validate(bytes.data(), bytes.size(), ReadLimits{}, path);
  CHECK_MESSAGE(valid.ok(), valid.to_string());
  // The writer stamps 1.2 (the residual's gate) and reproduces the file.
  auto rewritten = serialize_scene(expected);
  REQUIRE(rewritten.ok());
  CHECK(*rewritten == bytes);

  // §4.8 DC = s[0][c] (q + r/256), computed here in double: q + r/256 and its product with s (a multiple of
  // 1/8 here) are exact in float32, so the decoded value equals it exactly. Every i8 residual, -128 included.
  auto cloud = dequantize(*scene);
  REQUIRE(cloud.ok());
  int seen_min = 0, seen_max = 0;
  for (uint64_t i = 0; i < scene->count; ++i) {
    for (int c = 0; c < 3; ++c) {
      const int q = scene->sh[i * 3 + c], r = scene->sh_dc_residual[i * 3 + c];
      const double want = (c + 1) * 0.125 * (q + r / 256.0);
      CHECK(cloud->sh[i * 3 + c] == static_cast<float>(want));
      CHECK(static_cast<double>(static_cast<float>(want)) == want);
      seen_min = std::min(seen_min, r), seen_max = std::max(seen_max, r);
    }
  }
  CHECK(seen_min == -128);
  CHECK(seen_max == 127);

  // A 1.1 reader skips the unknown section and renders the INT8 DC: the file without it is a valid 1.0 file.
  EncodedScene coarse = expected;
  coarse.sh_dc_residual.clear();
  auto coarse_bytes = serialize_scene(coarse);
  REQUIRE(coarse_bytes.ok());
  CHECK(RgsFile::from_bytes(coarse_bytes->data(), coarse_bytes->size())->header().minor == 0);
  // A residual array of the wrong length is refused by the writer.
  coarse.sh_dc_residual.assign(5, 0);
  CHECK(serialize_scene(coarse).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("golden v1.3/small_sh1_lod.rgs: the level-of-detail index, its ranges, and the writer byte for byte") {
  const std::string path = data_path("v1.3/small_sh1_lod.rgs");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  REQUIRE(bytes.size() == 3520);
  const SmallLod expected = make_small_sh1_lod();
  const EncodedScene& all = expected.scene;
  REQUIRE(all.count == 24);
  const RgsFile file = must_open_path(path);
  const FileHeader& h = file.header();
  CHECK(h.major == 1);
  CHECK(h.minor == 3);
  CHECK(h.required_flags == kRequiredFlagLod);
  CHECK(h.required_flags == 2);
  CHECK(h.optional_flags == 0);
  CHECK(h.gaussian_count == 24);  // every level of every chunk
  CHECK(h.section_count == 9);

  // §3 Sections in the writer's order, lod last; the table ends at 64 + 9 * 64 = 640.
  const std::vector<std::pair<SectionId, uint64_t>> offsets = {
      {SectionId::kMetadata, 768},   {SectionId::kProvenance, 1024}, {SectionId::kMeans, 1280},
      {SectionId::kRotations, 1792}, {SectionId::kScales, 2048},     {SectionId::kOpacities, 2304},
      {SectionId::kSh, 2560},        {SectionId::kShDcResidual, 3072}, {SectionId::kLod, 3328}};
  REQUIRE(file.sections().size() == offsets.size());
  for (size_t i = 0; i < offsets.size(); ++i) {
    CHECK(file.sections()[i].id == offsets[i].first);
    CHECK(file.sections()[i].offset == offsets[i].second);
    CHECK(file.sections()[i].codec == Codec::kNone);  // §4.9 every per-Gaussian section raw
  }
  const SectionEntry* lod_entry = file.find(SectionId::kLod);
  REQUIRE(lod_entry != nullptr);
  CHECK(lod_entry->element_type == ElementType::kBytes);
  CHECK(lod_entry->components == 1);
  CHECK(lod_entry->raw_size == 16 + 16 * 2 + 24 * 3 * 2);
  CHECK(lod_entry->element_count == lod_entry->raw_size);
  CHECK(file.find(SectionId::kSh)->components == 12);
  CHECK(file.metadata().sh_degree == 1);
  CHECK(file.metadata().bounds.sphere_radius == 1.5f);
  CHECK(file.metadata().bounds.aabb_min[0] == -1.375f);
  CHECK(file.metadata().bounds.aabb_max[0] == 1.375f);

  // §4.9 The index: counts, tiling, errors, spheres, and the range checksums of the Python writer, recomputed
  // here from the scene's arrays.
  const LodIndex* lod = file.lod();
  REQUIRE(lod != nullptr);
  REQUIRE(lod->chunk_count == 2);
  REQUIRE(lod->level_count == 3);
  REQUIRE(lod->chunks.size() == 2);
  REQUIRE(lod->levels.size() == 6);
  CHECK(lod->section_bytes() == lod_entry->raw_size);
  const uint64_t counts[6] = {8, 6, 4, 3, 2, 1};
  const uint64_t firsts[6] = {0, 8, 14, 18, 21, 23};
  const float errors[6] = {0.0f, 0.0f, 0.125f, 0.25f, 0.5f, 0.75f};
  for (size_t r = 0; r < 6; ++r) {
    CAPTURE(r);
    CHECK(lod->levels[r].count == counts[r]);
    CHECK(lod->levels[r].first == firsts[r]);
    CHECK(lod->levels[r].error == errors[r]);
    CHECK(lod->levels[r].checksum == range_checksum(all, firsts[r], counts[r]));
  }
  CHECK(&lod->at(1, 1) == &lod->levels[3]);  // level-major
  for (uint32_t c = 0; c < 2; ++c) {
    CHECK(lod->chunks[c].center[0] == (c == 0 ? -1.0f : 1.0f));
    CHECK(lod->chunks[c].center[1] == 0.0f);
    CHECK(lod->chunks[c].center[2] == 2.0f);
    CHECK(lod->chunks[c].radius == 1.0f);
  }
  CHECK(lod->full_detail_count() == 14);
  CHECK(file.full_detail_count() == 14);

  // The per-Gaussian sections hold all 24 Gaussians, as the generator wrote them.
  std::vector<float> means(24 * 3);
  REQUIRE(file.decode_section(SectionId::kMeans, means.data(), means.size() * 4).ok());
  CHECK(std::memcmp(means.data(), all.means.data(), means.size() * 4) == 0);
  std::vector<int8_t> sh(24 * 12);
  REQUIRE(file.decode_section(SectionId::kSh, sh.data(), sh.size()).ok());
  CHECK(sh == all.sh);

  // read_scene() returns the full detail only: level 0 of both chunks, the prefix [0, 14) of every section.
  auto scene = file.read_scene();
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  CHECK(scene->count == 14);
  REQUIRE(scene->means.size() == 14 * 3);
  CHECK(std::memcmp(scene->means.data(), all.means.data(), 14 * 3 * 4) == 0);
  CHECK(scene->rotations == std::vector<uint16_t>(all.rotations.begin(), all.rotations.begin() + 14 * 4));
  CHECK(scene->scales == std::vector<uint16_t>(all.scales.begin(), all.scales.begin() + 14 * 3));
  CHECK(scene->opacities == std::vector<uint16_t>(all.opacities.begin(), all.opacities.begin() + 14));
  CHECK(scene->sh == std::vector<int8_t>(all.sh.begin(), all.sh.begin() + 14 * 12));
  CHECK(scene->sh_dc_residual == std::vector<int8_t>(all.sh_dc_residual.begin(), all.sh_dc_residual.begin() + 14 * 3));
  CHECK(scene->provenance == all.provenance);
  CHECK(scene->scales[3 * 3 + 1] == 0x0000);
  CHECK(scene->opacities[0] == 0x3C00);
  CHECK(scene->means[0] == -1.375f);  // Gaussian 0: chunk 0 centre + (-3/8, -1/4, -1/4)
  CHECK(scene->means[1] == -0.25f);
  CHECK(scene->means[2] == 1.75f);

  // lod_range(): zero-copy views into the mapped sections, checked range by range.
  const uint8_t* base[6] = {file.stored_bytes(SectionId::kMeans)->data, file.stored_bytes(SectionId::kRotations)->data,
                            file.stored_bytes(SectionId::kScales)->data, file.stored_bytes(SectionId::kOpacities)->data,
                            file.stored_bytes(SectionId::kSh)->data, file.stored_bytes(SectionId::kShDcResidual)->data};
  const size_t record[6] = {12, 8, 6, 2, 12, 3};
  for (uint32_t l = 0; l < 3; ++l) {
    for (uint32_t c = 0; c < 2; ++c) {
      CAPTURE(l);
      CAPTURE(c);
      auto range = file.lod_range(l, c);
      REQUIRE_MESSAGE(range.ok(), range.status().to_string());
      const uint64_t first = firsts[l * 2 + c], count = counts[l * 2 + c];
      CHECK(range->first == first);
      CHECK(range->count == count);
      const ByteView views[6] = {range->means, range->rotations, range->scales,
                                 range->opacities, range->sh, range->sh_dc_residual};
      const void* want[6] = {all.means.data() + first * 3, all.rotations.data() + first * 4,
                             all.scales.data() + first * 3, all.opacities.data() + first, all.sh.data() + first * 12,
                             all.sh_dc_residual.data() + first * 3};
      XXH64_state_t* state = XXH64_createState();
      XXH64_reset(state, 0);
      for (int p = 0; p < 6; ++p) {
        CHECK(views[p].data == base[p] + first * record[p]);
        CHECK(views[p].size == count * record[p]);
        CHECK(std::memcmp(views[p].data, want[p], views[p].size) == 0);
        XXH64_update(state, views[p].data, views[p].size);
      }
      CHECK(XXH64_digest(state) == lod->at(l, c).checksum);
      XXH64_freeState(state);
      // §4.9 Every Gaussian's 3-sigma extent lies inside its chunk's sphere (here with room to spare).
      for (uint64_t j = first; j < first + count; ++j) {
        double d2 = 0, largest = 0;
        for (int a = 0; a < 3; ++a) {
          const double d = static_cast<double>(all.means[j * 3 + a]) - lod->chunks[c].center[a];
          d2 += d * d;
          largest = std::max<double>(largest, half_bits_to_float(all.scales[j * 3 + a]));
        }
        CHECK(std::sqrt(d2) + 3 * largest <= 0.9 * lod->chunks[c].radius);
      }
    }
  }

  const Status valid = validate(bytes.data(), bytes.size(), ReadLimits{}, path);
  CHECK_MESSAGE(valid.ok(), valid.to_string());

  // Two independent writers, one spec: the C++ writer, given every level's Gaussians and the same index, writes the
  // Python file exactly (its checksums computed, whatever the index held).
  LodIndex index = expected.index;
  for (LodLevel& v : index.levels) v.checksum = 0x0123456789abcdefull;
  WriteOptions options;
  options.lod = &index;
  auto rewritten = serialize_scene(all, options);
  REQUIRE_MESSAGE(rewritten.ok(), rewritten.status().to_string());
  CHECK(rewritten->size() == bytes.size());
  CHECK(*rewritten == bytes);
  // And from what the file itself holds: all sections decoded, the index as read.
  EncodedScene decoded = *scene;
  decoded.count = 24;
  decoded.means = means;
  decoded.sh = sh;
  decoded.rotations.resize(24 * 4);
  decoded.scales.resize(24 * 3);
  decoded.opacities.resize(24);
  decoded.sh_dc_residual.resize(24 * 3);
  REQUIRE(file.decode_section(SectionId::kRotations, decoded.rotations.data(), 24 * 8).ok());
  REQUIRE(file.decode_section(SectionId::kScales, decoded.scales.data(), 24 * 6).ok());
  REQUIRE(file.decode_section(SectionId::kOpacities, decoded.opacities.data(), 24 * 2).ok());
  REQUIRE(file.decode_section(SectionId::kShDcResidual, decoded.sh_dc_residual.data(), 24 * 3).ok());
  test::check_same_scene(decoded, all);
  WriteOptions from_file;
  from_file.lod = lod;
  auto again = serialize_scene(decoded, from_file);
  REQUIRE_MESSAGE(again.ok(), again.status().to_string());
  CHECK(*again == bytes);
  // Without the index the same Gaussians make an ordinary 1.2 file (the residual's gate) of 24 Gaussians.
  auto plain = serialize_scene(all);
  REQUIRE(plain.ok());
  auto plain_file = RgsFile::from_bytes(plain->data(), plain->size());
  REQUIRE(plain_file.ok());
  CHECK(plain_file->header().minor == 2);
  CHECK(plain_file->header().required_flags == 0);
  CHECK(plain_file->lod() == nullptr);
  CHECK(plain_file->full_detail_count() == 24);
}

TEST_CASE("golden v1.0/forward_compat.rgs: a newer minor with unknown sections and flags opens") {
  const std::string path = data_path("v1.0/forward_compat.rgs");
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  const RgsFile file = must_open_path(path);
  CHECK(file.header().minor == 7);
  CHECK(file.header().optional_flags == 1);
  REQUIRE(file.sections().size() == 10);
  CHECK(file.sections()[2].id == static_cast<SectionId>(0x8001));
  CHECK(std::string(section_name(file.sections()[2].id)) == "unknown");
  test::check_same_scene(file.read_scene().value(), test::make_small_sh3());
  const Status valid = validate(bytes.data(), bytes.size(), ReadLimits{}, path);
  CHECK_MESSAGE(valid.ok(), valid.to_string());

  std::vector<uint8_t> future(16);
  REQUIRE(file.decode_section(static_cast<SectionId>(0x8002), future.data(), future.size()).ok());
  for (size_t i = 0; i < future.size(); ++i) CHECK(future[i] == i);
  std::vector<uint8_t> opaque(1000);
  const Status unknown_codec = file.decode_section(static_cast<SectionId>(0x8003), opaque.data(), opaque.size());
  CHECK(unknown_codec.code() == StatusCode::kUnsupportedFeature);
  CHECK(file.stored_bytes(static_cast<SectionId>(0x8003)).ok());
}

TEST_CASE("golden files open through the memory mapping with 256-byte aligned sections") {
  const RgsFile file = must_open_path(data_path("v1.0/small_sh3.rgs"));
  for (SectionId id : {SectionId::kMeans, SectionId::kRotations, SectionId::kScales, SectionId::kOpacities,
                       SectionId::kSh}) {
    auto view = file.stored_bytes(id);
    REQUIRE(view.ok());
    CHECK(reinterpret_cast<uintptr_t>(view->data) % kSectionAlignment == 0);  // mmap is page aligned
  }
  // Copies share the mapping and stay valid after the original is gone.
  std::vector<RgsFile> copies;
  {
    const RgsFile original = must_open_path(data_path("v1.0/small_sh3.rgs"));
    copies.push_back(original);
  }
  CHECK(copies[0].read_scene().ok());
}
