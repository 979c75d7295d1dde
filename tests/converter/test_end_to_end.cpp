// End to end through real .rgs bytes: PLY -> quantize -> serialize -> validate -> parse -> dequantize -> PLY,
// on the shipped sample and on every real scene of $RGS_DATA_DIR.
#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "test_data.h"

namespace {

using namespace rgs;

/// Runs the whole pipeline on one PLY and checks every property the format promises.
void check_end_to_end(const std::string& path, uint64_t expected_count, uint32_t expected_degree) {
  auto ply = converter::read_ply(path);
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  CHECK(ply->cloud.size() == expected_count);
  CHECK(ply->cloud.sh_degree == expected_degree);
  auto encoded = converter::quantize(ply->cloud, {});
  REQUIRE(encoded.ok());

  format::WriteOptions zstd_all;
  for (auto id : {format::SectionId::kMetadata, format::SectionId::kProvenance, format::SectionId::kMeans,
                  format::SectionId::kRotations, format::SectionId::kScales, format::SectionId::kOpacities,
                  format::SectionId::kSh, format::SectionId::kShDcResidual}) {
    zstd_all.codecs[id] = format::Codec::kZstd;
  }
  zstd_all.zstd_level = 3;
  for (const auto& options : {format::WriteOptions{}, zstd_all}) {
    const bool zstd = !options.codecs.empty();
    CAPTURE(zstd);
    auto bytes = format::serialize_scene(*encoded, options);
    REQUIRE(bytes.ok());
    // Deterministic: a second serialization gives identical bytes.
    auto again = format::serialize_scene(*encoded, options);
    REQUIRE(again.ok());
    CHECK(*bytes == *again);

    CHECK(format::validate(bytes->data(), bytes->size()).ok());
    auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
    REQUIRE_MESSAGE(file.ok(), file.status().to_string());
    CHECK(file->gaussian_count() == expected_count);
    for (const auto& section : file->sections()) CHECK(section.offset % format::kSectionAlignment == 0);
    if (!zstd) {  // runtime profile: 12 + 8 + 6 + 2 + 3K + 3 (DC residual) bytes per Gaussian of section payload
      uint64_t payload = 0;
      for (const auto& section : file->sections()) {
        if (section.element_count == expected_count) payload += section.raw_size;
      }
      CHECK(payload == expected_count * (31 + 3 * format::sh_coefficient_count(expected_degree)));
      CHECK(file->find(format::SectionId::kShDcResidual) != nullptr);
      CHECK(file->header().minor == 2);
    }

    // What the file holds is exactly what was quantized, and within every bound of the source.
    auto decoded = file->read_scene();
    REQUIRE(decoded.ok());
    CHECK(test::same_encoded(*decoded, *encoded));
    CHECK(test::check_quantization_bounds(ply->cloud, *decoded) == 0);
  }

  // Back to a standard INRIA PLY: it reads as the dequantized cloud, at the same count and degree.
  auto dequantized = format::dequantize(*encoded);
  REQUIRE(dequantized.ok());
  auto ply_bytes = converter::serialize_ply(*dequantized);
  REQUIRE(ply_bytes.ok());
  auto restored = converter::read_ply_bytes(ply_bytes->data(), ply_bytes->size(), "restored.ply");
  REQUIRE_MESSAGE(restored.ok(), restored.status().to_string());
  CHECK(restored->cloud.size() == expected_count);
  CHECK(restored->cloud.sh_degree == expected_degree);
  CHECK(test::same_floats(restored->cloud.means, dequantized->means));
}

}  // namespace

TEST_CASE("end to end: shipped guitar sample through .rgs bytes and back to PLY") {
  check_end_to_end(test::repo_path("samples/guitar.ply"), 90854, 0);
}

TEST_CASE("end to end: every real scene of $RGS_DATA_DIR through .rgs bytes and back to PLY") {
  struct Scene {
    const char* file;
    uint64_t count;
    uint32_t degree;
  };
  for (const Scene& s : {Scene{"mipnerf360_flowers_c3dgs.ply", 38347, 3},
                         Scene{"tiny_unknown_inria_sh3_it7000.ply", 9080, 3}, Scene{"guitar.ply", 90854, 0},
                         Scene{"biker.ply", 152746, 0}, Scene{"playcanvas_flowers_lod0.ply", 542104, 2}}) {
    const std::string file = s.file;
    CAPTURE(file);
    const std::string path = test::shared_scene(file);
    if (path.empty()) continue;
    check_end_to_end(path, s.count, s.degree);
  }
}
