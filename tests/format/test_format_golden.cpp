// Golden files of format versions 1.0 and 1.2 (tests/data/v1.*/), written by tests/data/make_rgs_corpus.py, an
// independent implementation of SPEC.md. They must keep reading the same forever (CONTRIBUTING.md#tests).
#include <doctest/doctest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

using namespace rgs;
using namespace rgs::format;
using rgs::test::data_path;
using rgs::test::read_file_bytes;

RgsFile must_open_path(const std::string& path) {
  auto file = RgsFile::open(path);
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  return std::move(file).value();
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
