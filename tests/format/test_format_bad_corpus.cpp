// The must-fail corpus tests/data/bad/*.rgs (CONTRIBUTING.md#tests): each file fails with its named code, at the
// stage SPEC §5 puts its check, with a message naming the file and the cause. The corpus, its manifest
// (bad_rgs_corpus.md) and the table below must agree.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "rgs/format/reader.h"

namespace {

using namespace rgs;
using namespace rgs::format;

enum class Stage { kOpen, kValidate };

struct BadFile {
  const char* name;
  StatusCode code;
  Stage stage;
  const char* fragment;  ///< a piece of the expected message
};

constexpr Stage kOpen = Stage::kOpen;
constexpr Stage kValidate = Stage::kValidate;
using C = StatusCode;

const BadFile kBadFiles[] = {
    {"bad_magic", C::kNotRgsFile, kOpen, "not an .rgs file: first bytes are 89 72 47 53"},
    {"empty", C::kNotRgsFile, kOpen, "it is empty"},
    {"ply_text", C::kNotRgsFile, kOpen, "first bytes are 70 6c 79"},
    {"truncated_header", C::kCorruptData, kOpen, "truncated: 40 bytes, shorter than the 64-byte header"},
    {"future_major", C::kUnsupportedVersion, kOpen, "format version 2.0 is newer than this reader (1.x)"},
    {"major_zero", C::kUnsupportedVersion, kOpen, "format version 0.0 was never released"},
    {"unknown_required_flag", C::kUnsupportedFeature, kOpen,
     "unknown required flag bits 0x00000100 (this reader knows 0x0000001f)"},
    {"header_size_mismatch", C::kCorruptData, kOpen, "header_size is 72, must be 64"},
    {"header_reserved_nonzero", C::kCorruptData, kOpen, "header reserved field (bytes 36..39) is 1"},
    {"table_offset_mismatch", C::kCorruptData, kOpen, "table_offset is 128, must be 64"},
    {"truncated", C::kCorruptData, kOpen, "header says the file is 3056 bytes but it is 2956 (truncated)"},
    {"trailing_bytes", C::kCorruptData, kOpen, "3056 bytes but it is 3072 (trailing bytes)"},
    {"trailing_after_last_section", C::kCorruptData, kOpen, "the last section ends at 3056 but the file is 3072"},
    {"too_many_sections", C::kLimitExceeded, kOpen, "65 sections exceed the limit of 64"},
    {"table_past_eof", C::kCorruptData, kOpen, "section table of 47 entries ends at 3072 > file size 3056"},
    {"header_checksum", C::kChecksumMismatch, kOpen, "header checksum"},
    {"header_checksum_count", C::kChecksumMismatch, kOpen, "does not match the computed"},
    {"gaussian_count_over_limit", C::kLimitExceeded, kOpen, "1099511627776 Gaussians exceed the limit of 268435456"},
    {"table_reserved_nonzero", C::kCorruptData, kOpen, "section 2 (means): reserved table fields are 1 and 0"},
    {"duplicate_section", C::kCorruptData, kOpen, "section 2 (means) repeats the id of section 1"},
    {"missing_required_section", C::kCorruptData, kOpen, "required section opacities (id 19) is missing"},
    {"misaligned_section", C::kCorruptData, kOpen, "section 2 (means): offset 1028 is not a multiple of 256"},
    {"overlapping_sections", C::kCorruptData, kOpen,
     "section 3 (rotations) starts at 1024, inside section 2 (means), which ends at 1276"},
    {"section_gap", C::kCorruptData, kOpen, "section 6 (sh) starts at 2304, expected 2048"},
    {"section_past_eof", C::kCorruptData, kOpen, "section 6 (sh) ends at 3312 > file size 3056"},
    {"padding_nonzero", C::kCorruptData, kOpen, "padding byte at 640 before section 1 (provenance) is 90"},
    {"raw_size_mismatch", C::kCorruptData, kOpen,
     "section 3 (rotations): raw_size 176 != element_count 21 x components 4 x 2 bytes = 168"},
    {"stored_size_mismatch", C::kCorruptData, kOpen, "codec none but stored_size 124 != raw_size 128"},
    {"element_count_mismatch", C::kCorruptData, kOpen, "section 2 (means): element_count 21 != gaussian_count 20"},
    {"wrong_element_type", C::kCorruptData, kOpen, "section 2 (means): element type f16 x 6, expected f32 x 3"},
    {"unknown_codec", C::kUnsupportedFeature, kOpen, "section 3 (rotations): codec 7 is unknown"},
    {"unknown_scale_encoding", C::kUnsupportedFeature, kOpen, "section 0 (metadata): scale encoding 9 is unknown"},
    {"metadata_reserved_nonzero", C::kCorruptData, kOpen,
     "section 0 (metadata): reserved byte 120 of the metadata record is 1, must be 0"},
    {"metadata_bad_quantization", C::kCorruptData, kOpen, "SH quantization bits 7"},
    {"sh_degree_mismatch", C::kCorruptData, kOpen,
     "section 6 (sh): element type i8 x 48, expected i8 x 27 for SH degree 2"},
    {"sh_degree_unsupported", C::kUnsupportedFeature, kOpen, "SH degree 4 is above 3"},
    {"metadata_nan_radius", C::kCorruptData, kOpen, "bounding sphere radius nan"},
    {"metadata_checksum", C::kChecksumMismatch, kOpen, "section 0 (metadata): checksum"},
    {"provenance_overrun", C::kCorruptData, kOpen,
     "section 1 (provenance): entry 0: key of 65535 bytes runs past the record (183 bytes left)"},
    {"provenance_count_overrun", C::kCorruptData, kOpen,
     "section 1 (provenance): the record declares 1073741824 entries but only 187 bytes follow"},
    {"section_checksum", C::kChecksumMismatch, kValidate, "section 2 (means): checksum"},
    {"nan_mean", C::kCorruptData, kValidate, "section 2 (means): Gaussian 5: mean (1, nan, 2.625) is not finite"},
    {"mean_outside_bounds", C::kCorruptData, kValidate, "Gaussian 0: mean (-1.5, -0.5, 100) lies outside the AABB"},
    {"zero_rotation", C::kCorruptData, kValidate, "section 3 (rotations): Gaussian 2: rotation quaternion is zero"},
    {"negative_linear_scale", C::kCorruptData, kValidate, "Gaussian 1: linear scale component 0 is -0.125, negative"},
    {"opacity_above_one", C::kCorruptData, kValidate, "Gaussian 4: opacity 1.00097656 is outside [0, 1]"},
    {"sh_minus_128", C::kCorruptData, kValidate, "Gaussian 0: SH value -128 (coefficient 2, channel 1)"},
    {"zstd_no_checksum_flag", C::kCorruptData, kOpen, "section 2 (means): zstd frame has no content checksum"},
    {"zstd_content_size", C::kCorruptData, kOpen, "zstd frame content size 1024 != raw_size 768"},
    {"zstd_bad_magic", C::kCorruptData, kOpen, "not a zstd frame: magic 0xfd2fb5d7, expected 0xfd2fb528"},
    {"zstd_window_too_large", C::kCorruptData, kOpen,
     "section 2 (means): zstd frame window of 268435456 bytes exceeds the 134217728 SPEC §3.1 allows"},
    {"zstd_reserved_block", C::kCorruptData, kValidate, "section 2 (means): zstd frame: zstd:"},
    {"zstd_content_checksum", C::kChecksumMismatch, kValidate, "zstd content checksum does not match"},
    {"zstd_checksum_field", C::kChecksumMismatch, kValidate, "zstd content checksum does not match"},
    {"dc_residual_in_1_1", C::kCorruptData, kOpen, "section 7 (sh_dc_residual) in a version 1.1 file"},
    {"dc_residual_components", C::kCorruptData, kOpen,
     "section 7 (sh_dc_residual): element type i8 x 1, expected i8 x 3"},
    {"dc_residual_count", C::kCorruptData, kOpen, "section 7 (sh_dc_residual): element_count 63 != gaussian_count 64"},
    // SPEC §4.9 the level-of-detail index: damaged copies of v1.3/small_sh1_lod.rgs (§5.3 #24, #26; §5.4 ranges).
    {"lod_without_flag", C::kCorruptData, kOpen, "section 8 (lod) without the level-of-detail required flag"},
    {"lod_flag_without_section", C::kCorruptData, kOpen, "the level-of-detail flag is set but there is no lod section"},
    {"lod_in_1_2", C::kCorruptData, kOpen, "section 8 (lod) in a version 1.2 file"},
    {"lod_zstd_section", C::kCorruptData, kOpen, "section 5 (opacities): codec zstd in a level-of-detail file"},
    {"lod_element_type", C::kCorruptData, kOpen, "section 8 (lod): element type i8 x 1, expected bytes x 1"},
    {"lod_raw_size", C::kCorruptData, kOpen, "section 8 (lod): lod: 200 bytes, 2 chunks of 3 levels take 192"},
    {"lod_head_reserved", C::kCorruptData, kOpen, "section 8 (lod): lod: reserved head bytes are not 0"},
    {"lod_record_reserved", C::kCorruptData, kOpen, "section 8 (lod): lod chunk 0 level 1: reserved bytes are not 0"},
    {"lod_chunks_over_n", C::kCorruptData, kOpen, "section 8 (lod): lod: 25 chunks of 1 levels (1..24 chunks"},
    {"lod_levels_17", C::kCorruptData, kOpen,
     "section 8 (lod): lod: 2 chunks of 17 levels (1..24 chunks, 1..16 levels)"},
    {"lod_nan_radius", C::kCorruptData, kOpen, "section 8 (lod): lod chunk 1: centre (1, 0, 2) or radius nan"},
    {"lod_count_zero", C::kCorruptData, kOpen, "section 8 (lod): lod chunk 1 level 2: no Gaussians"},
    {"lod_tiling_short", C::kCorruptData, kOpen, "section 8 (lod): lod: the levels hold 23 Gaussians, the file 24"},
    {"lod_tiling_over", C::kCorruptData, kOpen,
     "section 8 (lod): lod chunk 1 level 2: 2 Gaussians from 23 pass the file's 24"},
    {"lod_count_increasing", C::kCorruptData, kOpen,
     "section 8 (lod): lod chunk 0 level 1: 9 Gaussians, more than level 0's 3"},
    {"lod_level0_error", C::kCorruptData, kOpen,
     "section 8 (lod): lod chunk 1 level 0: error 0.125, level 0 (the full detail) must have 0"},
    {"lod_error_decreasing", C::kCorruptData, kOpen,
     "section 8 (lod): lod chunk 0 level 2: error 0.0625 below level 1's 0.125"},
    {"lod_range_checksum", C::kChecksumMismatch, kValidate, "lod chunk 1 level 1: checksum"},
    {"lod_range_data", C::kChecksumMismatch, kValidate, "lod chunk 0 level 2: checksum"},
    {"lod_outside_chunk", C::kCorruptData, kValidate,
     "lod chunk 0 level 1: Gaussian 15 reaches 2.24957275 from the chunk centre, outside its radius 1"},
};

const BadFile* find_bad(const std::string& name) {
  for (const BadFile& b : kBadFiles) {
    if (name == b.name) return &b;
  }
  return nullptr;
}

std::string bad_path(const std::string& name) { return test::data_path("bad/" + name + ".rgs"); }

/// Opens through the mapping and from memory, validates, and checks code, stage and message.
void check_bad_file(const char* name) {
  const BadFile* bad = find_bad(name);
  REQUIRE_MESSAGE(bad != nullptr, "no table row for " << name);
  const std::string path = bad_path(name);
  const std::vector<uint8_t> bytes = test::read_file_bytes(path);
  auto opened = RgsFile::open(path);
  auto from_memory = RgsFile::from_bytes(bytes.data(), bytes.size(), {}, path);
  CHECK(opened.ok() == from_memory.ok());
  const Status validated = validate(bytes.data(), bytes.size(), ReadLimits{}, path);
  if (bad->stage == Stage::kOpen) {
    REQUIRE_FALSE(opened.ok());
    CHECK_MESSAGE(opened.status().code() == bad->code, opened.status().to_string());
    CHECK(from_memory.status().to_string() == opened.status().to_string());
  } else {
    REQUIRE_MESSAGE(opened.ok(), opened.status().to_string());
  }
  REQUIRE_FALSE(validated.ok());
  CHECK_MESSAGE(validated.code() == bad->code, validated.to_string());
  CHECK_MESSAGE(validated.message().rfind(path + ": ", 0) == 0,
                "message does not name the file: " << validated.message());
  CHECK_MESSAGE(validated.message().find(bad->fragment) != std::string::npos,
                "expected \"" << bad->fragment << "\" in: " << validated.message());
  if (opened.ok()) {
    // What open() accepted must not crash the payload paths either.
    (void)opened->read_scene();
  }
}

/// A level-of-detail file that fails only validate(): open() succeeds and decodes the index, and exactly the
/// damaged range (`level`, `chunk`) fails lod_range() and read_lod_range() with the file's code, the others still
/// read: a reader checks one range without the others (SPEC §5.4).
void check_bad_lod_range(const char* name, uint32_t level, uint32_t chunk) {
  check_bad_file(name);
  const BadFile* bad = find_bad(name);
  REQUIRE(bad != nullptr);
  CHECK(bad->stage == Stage::kValidate);
  const std::string path = bad_path(name);
  auto file = RgsFile::open(path);
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  const LodIndex* lod = file->lod();
  REQUIRE(lod != nullptr);
  REQUIRE(lod->chunk_count == 2);
  REQUIRE(lod->level_count == 3);
  const uint64_t sh_bytes = 3 * sh_coefficient_count(file->metadata().sh_degree);
  for (uint32_t l = 0; l < lod->level_count; ++l) {
    for (uint32_t c = 0; c < lod->chunk_count; ++c) {
      // read_lod_range() checks its copy with the same rules, so it fails the same way.
      const uint64_t n = lod->at(l, c).count;
      std::vector<uint8_t> means(n * 12), rotations(n * 8), scales(n * 6), opacities(n * 2), sh(n * sh_bytes),
          residual(n * 3);
      const LodRangeTarget target{means.data(), rotations.data(), scales.data(),
                                  opacities.data(), sh.data(), residual.data()};
      for (const Result<LodRangeView>& range : {file->lod_range(l, c), file->read_lod_range(l, c, target)}) {
        if (l == level && c == chunk) {
          REQUIRE_FALSE(range.ok());
          CHECK_MESSAGE(range.status().code() == bad->code, range.status().to_string());
          CHECK_MESSAGE(range.status().message().find(bad->fragment) != std::string::npos,
                        range.status().to_string());
        } else {
          CHECK_MESSAGE(range.ok(), "level " << l << " chunk " << c << ": " << range.status().to_string());
        }
      }
    }
  }
}

}  // namespace

TEST_CASE("bad/bad_magic.rgs") { check_bad_file("bad_magic"); }
TEST_CASE("bad/empty.rgs") { check_bad_file("empty"); }
TEST_CASE("bad/ply_text.rgs") { check_bad_file("ply_text"); }
TEST_CASE("bad/truncated_header.rgs") { check_bad_file("truncated_header"); }
TEST_CASE("bad/future_major.rgs") { check_bad_file("future_major"); }
TEST_CASE("bad/major_zero.rgs") { check_bad_file("major_zero"); }
TEST_CASE("bad/unknown_required_flag.rgs") { check_bad_file("unknown_required_flag"); }
TEST_CASE("bad/header_size_mismatch.rgs") { check_bad_file("header_size_mismatch"); }
TEST_CASE("bad/header_reserved_nonzero.rgs") { check_bad_file("header_reserved_nonzero"); }
TEST_CASE("bad/table_offset_mismatch.rgs") { check_bad_file("table_offset_mismatch"); }
TEST_CASE("bad/truncated.rgs") { check_bad_file("truncated"); }
TEST_CASE("bad/trailing_bytes.rgs") { check_bad_file("trailing_bytes"); }
TEST_CASE("bad/trailing_after_last_section.rgs") { check_bad_file("trailing_after_last_section"); }
TEST_CASE("bad/too_many_sections.rgs") { check_bad_file("too_many_sections"); }
TEST_CASE("bad/table_past_eof.rgs") { check_bad_file("table_past_eof"); }
TEST_CASE("bad/header_checksum.rgs") { check_bad_file("header_checksum"); }
TEST_CASE("bad/header_checksum_count.rgs") { check_bad_file("header_checksum_count"); }
TEST_CASE("bad/gaussian_count_over_limit.rgs") { check_bad_file("gaussian_count_over_limit"); }
TEST_CASE("bad/table_reserved_nonzero.rgs") { check_bad_file("table_reserved_nonzero"); }
TEST_CASE("bad/duplicate_section.rgs") { check_bad_file("duplicate_section"); }
TEST_CASE("bad/missing_required_section.rgs") { check_bad_file("missing_required_section"); }
TEST_CASE("bad/misaligned_section.rgs") { check_bad_file("misaligned_section"); }
TEST_CASE("bad/overlapping_sections.rgs") { check_bad_file("overlapping_sections"); }
TEST_CASE("bad/section_gap.rgs") { check_bad_file("section_gap"); }
TEST_CASE("bad/section_past_eof.rgs") { check_bad_file("section_past_eof"); }
TEST_CASE("bad/padding_nonzero.rgs") { check_bad_file("padding_nonzero"); }
TEST_CASE("bad/raw_size_mismatch.rgs") { check_bad_file("raw_size_mismatch"); }
TEST_CASE("bad/stored_size_mismatch.rgs") { check_bad_file("stored_size_mismatch"); }
TEST_CASE("bad/element_count_mismatch.rgs") { check_bad_file("element_count_mismatch"); }
TEST_CASE("bad/wrong_element_type.rgs") { check_bad_file("wrong_element_type"); }
TEST_CASE("bad/unknown_codec.rgs") { check_bad_file("unknown_codec"); }
TEST_CASE("bad/unknown_scale_encoding.rgs") { check_bad_file("unknown_scale_encoding"); }
TEST_CASE("bad/metadata_reserved_nonzero.rgs") { check_bad_file("metadata_reserved_nonzero"); }
TEST_CASE("bad/metadata_bad_quantization.rgs") { check_bad_file("metadata_bad_quantization"); }
TEST_CASE("bad/sh_degree_mismatch.rgs") { check_bad_file("sh_degree_mismatch"); }
TEST_CASE("bad/sh_degree_unsupported.rgs") { check_bad_file("sh_degree_unsupported"); }
TEST_CASE("bad/metadata_nan_radius.rgs") { check_bad_file("metadata_nan_radius"); }
TEST_CASE("bad/metadata_checksum.rgs") { check_bad_file("metadata_checksum"); }
TEST_CASE("bad/provenance_overrun.rgs") { check_bad_file("provenance_overrun"); }
TEST_CASE("bad/provenance_count_overrun.rgs") { check_bad_file("provenance_count_overrun"); }
TEST_CASE("bad/section_checksum.rgs") { check_bad_file("section_checksum"); }
TEST_CASE("bad/nan_mean.rgs") { check_bad_file("nan_mean"); }
TEST_CASE("bad/mean_outside_bounds.rgs") { check_bad_file("mean_outside_bounds"); }
TEST_CASE("bad/zero_rotation.rgs") { check_bad_file("zero_rotation"); }
TEST_CASE("bad/negative_linear_scale.rgs") { check_bad_file("negative_linear_scale"); }
TEST_CASE("bad/opacity_above_one.rgs") { check_bad_file("opacity_above_one"); }
TEST_CASE("bad/sh_minus_128.rgs") { check_bad_file("sh_minus_128"); }
TEST_CASE("bad/zstd_no_checksum_flag.rgs") { check_bad_file("zstd_no_checksum_flag"); }
TEST_CASE("bad/zstd_content_size.rgs") { check_bad_file("zstd_content_size"); }
TEST_CASE("bad/zstd_bad_magic.rgs") { check_bad_file("zstd_bad_magic"); }
TEST_CASE("bad/zstd_window_too_large.rgs") { check_bad_file("zstd_window_too_large"); }
TEST_CASE("bad/zstd_reserved_block.rgs") { check_bad_file("zstd_reserved_block"); }
TEST_CASE("bad/zstd_content_checksum.rgs") { check_bad_file("zstd_content_checksum"); }
TEST_CASE("bad/zstd_checksum_field.rgs") { check_bad_file("zstd_checksum_field"); }
TEST_CASE("bad/dc_residual_in_1_1.rgs") { check_bad_file("dc_residual_in_1_1"); }
TEST_CASE("bad/dc_residual_components.rgs") { check_bad_file("dc_residual_components"); }
TEST_CASE("bad/dc_residual_count.rgs") { check_bad_file("dc_residual_count"); }
TEST_CASE("bad/lod_without_flag.rgs") { check_bad_file("lod_without_flag"); }
TEST_CASE("bad/lod_flag_without_section.rgs") { check_bad_file("lod_flag_without_section"); }
TEST_CASE("bad/lod_in_1_2.rgs") { check_bad_file("lod_in_1_2"); }
TEST_CASE("bad/lod_zstd_section.rgs") { check_bad_file("lod_zstd_section"); }
TEST_CASE("bad/lod_element_type.rgs") { check_bad_file("lod_element_type"); }
TEST_CASE("bad/lod_raw_size.rgs") { check_bad_file("lod_raw_size"); }
TEST_CASE("bad/lod_head_reserved.rgs") { check_bad_file("lod_head_reserved"); }
TEST_CASE("bad/lod_record_reserved.rgs") { check_bad_file("lod_record_reserved"); }
TEST_CASE("bad/lod_chunks_over_n.rgs") { check_bad_file("lod_chunks_over_n"); }
TEST_CASE("bad/lod_levels_17.rgs") { check_bad_file("lod_levels_17"); }
TEST_CASE("bad/lod_nan_radius.rgs") { check_bad_file("lod_nan_radius"); }
TEST_CASE("bad/lod_count_zero.rgs") { check_bad_file("lod_count_zero"); }
TEST_CASE("bad/lod_tiling_short.rgs") { check_bad_file("lod_tiling_short"); }
TEST_CASE("bad/lod_tiling_over.rgs") { check_bad_file("lod_tiling_over"); }
TEST_CASE("bad/lod_count_increasing.rgs") { check_bad_file("lod_count_increasing"); }
TEST_CASE("bad/lod_level0_error.rgs") { check_bad_file("lod_level0_error"); }
TEST_CASE("bad/lod_error_decreasing.rgs") { check_bad_file("lod_error_decreasing"); }
TEST_CASE("bad/lod_range_checksum.rgs") { check_bad_lod_range("lod_range_checksum", 1, 1); }
TEST_CASE("bad/lod_range_data.rgs") { check_bad_lod_range("lod_range_data", 2, 0); }
TEST_CASE("bad/lod_outside_chunk.rgs") { check_bad_lod_range("lod_outside_chunk", 1, 0); }

TEST_CASE("bad corpus: table, manifest and files agree, and each file has its TEST_CASE") {
  // Every .rgs in tests/data/bad is listed in the table (other libraries keep *.ply there).
  std::set<std::string> on_disk;
  for (const auto& entry : std::filesystem::directory_iterator(test::data_path("bad"))) {
    if (entry.path().extension() == ".rgs") on_disk.insert(entry.path().stem().string());
  }
  std::set<std::string> in_table;
  for (const BadFile& b : kBadFiles) CHECK_MESSAGE(in_table.insert(b.name).second, "duplicate row " << b.name);
  CHECK(on_disk == in_table);

  // The generator's manifest states the same code and stage for each file.
  std::ifstream manifest(test::repo_path("tests/format/bad_rgs_corpus.md"));
  REQUIRE(manifest.good());
  std::string line;
  size_t rows = 0;
  while (std::getline(manifest, line)) {
    if (line.rfind("| ", 0) != 0 || line.find(".rgs |") == std::string::npos) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(2));
    std::string cell;
    while (std::getline(ss, cell, '|')) {
      const size_t a = cell.find_first_not_of(' '), b = cell.find_last_not_of(' ');
      cells.push_back(a == std::string::npos ? "" : cell.substr(a, b - a + 1));
    }
    REQUIRE(cells.size() >= 3);
    const std::string name = cells[0].substr(0, cells[0].size() - 4);
    const BadFile* bad = find_bad(name);
    REQUIRE_MESSAGE(bad != nullptr, "manifest row without a table row: " << name);
    CHECK_MESSAGE(cells[1] == status_code_name(bad->code), name);
    CHECK_MESSAGE(cells[2] == (bad->stage == Stage::kOpen ? "open" : "validate"), name);
    ++rows;
  }
  CHECK(rows == std::size(kBadFiles));

  // And this file has a TEST_CASE line for each table row.
  std::ifstream self(test::repo_path("tests/format/test_format_bad_corpus.cpp"));
  std::stringstream source;
  source << self.rdbuf();
  for (const BadFile& b : kBadFiles) {
    CHECK_MESSAGE(source.str().find("TEST_CASE(\"bad/" + std::string(b.name) + ".rgs\")") != std::string::npos,
                  "no TEST_CASE for " << b.name);
  }
}
