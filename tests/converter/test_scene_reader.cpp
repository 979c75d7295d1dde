// read_scene: format detection by content, the PlayCanvas readers (compressed PLY, SOG folder / bundle /
// streamed) against reference decodes made once with PlayCanvas splat-transform 3.7.0
// (tests/data/sog/make_sog_reference.py), and inputs that must fail with a named code.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "ply_test_util.h"
#include "rgs/converter/playcanvas_readers.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/spz.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include "rgs/format/writer.h"
#include "test_data.h"

namespace rgs::test {
namespace {

namespace fs = std::filesystem;
using converter::InputScene;
using converter::read_scene;
using converter::SceneReadOptions;
using converter::SpzFrame;
using converter::spz_frame_note;

std::string sog_data(const std::string& name) { return repo_path("tests/data/sog/" + name); }

format::GaussianCloud read_reference(const std::string& path) {
  auto r = converter::read_ply(path);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r->cloud);
}

InputScene read_ok(const std::string& path, const SceneReadOptions& options = {}) {
  auto r = read_scene(path, options);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

Status read_status(const std::string& path, const SceneReadOptions& options = {}) {
  auto r = read_scene(path, options);
  return r.status();
}

/// Largest |a − b| / (atol + rtol·|b|) over two arrays of the same length (≤ 1 means within tolerance).
double worst_ratio(const std::vector<float>& a, const std::vector<float>& b, double atol, double rtol) {
  REQUIRE(a.size() == b.size());
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = std::fabs(double(a[i]) - double(b[i]));
    worst = std::max(worst, d / (atol + rtol * std::fabs(double(b[i]))));
  }
  return worst;
}

/// The same decode as the reference up to float32 rounding of the same formulas (the reference stores
/// log scales, logits and unnormalized quaternions as float32; read_ply activates them).
/// `opacity_atol` covers opacities of exactly 1 in a reference that keeps the logit +inf of 8-bit alpha 255
/// (splat-transform's compressed PLY decode), where this reader clamps the logit to 13.8155: 1 − 1e-6.
void check_same_decode(const format::GaussianCloud& got, const format::GaussianCloud& ref, double opacity_atol = 1e-6) {
  REQUIRE(got.size() == ref.size());
  REQUIRE(got.sh_degree == ref.sh_degree);
  CHECK(worst_ratio(got.means, ref.means, 1e-7, 1e-6) <= 1.0);
  CHECK(worst_ratio(got.rotations, ref.rotations, 1e-6, 0) <= 1.0);
  CHECK(worst_ratio(got.scales, ref.scales, 0, 1e-6) <= 1.0);
  CHECK(worst_ratio(got.opacities, ref.opacities, opacity_atol, 0) <= 1.0);
  CHECK(worst_ratio(got.sh, ref.sh, 1e-6, 1e-6) <= 1.0);
}

/// A scratch directory removed at the end of the test.
struct TempDir {
  fs::path path;
  TempDir() {
    std::random_device rd;
    path = fs::temp_directory_path() / ("rgs_scene_reader_" + std::to_string(rd()) + std::to_string(rd()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  REQUIRE(out.good());
}
void write_text(const std::string& path, const std::string& text) {
  write_bytes(path, std::vector<uint8_t>(text.begin(), text.end()));
}
std::string read_text(const std::string& path) {
  const auto bytes = load_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}
/// Replaces the first `from` in `text` (which must contain it).
std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  REQUIRE_MESSAGE(at != std::string::npos, from);
  return text.replace(at, from.size(), to);
}

/// A copy of tests/data/sog/guitar_crop/ in a scratch folder, to break.
struct SogFolderCopy {
  TempDir dir;
  std::string meta;
  SogFolderCopy() {
    for (const auto& e : fs::directory_iterator(sog_data("guitar_crop"))) {
      fs::copy_file(e.path(), dir.path / e.path().filename());
    }
    meta = dir.file("meta.json");
  }
};

TEST_CASE("read_scene detects every format by content, not by extension") {
  struct Case {
    std::string path, id;
  };
  const std::vector<Case> cases = {
      {repo_path("samples/guitar.ply"), "ply"},           {sog_data("guitar_crop.compressed.ply"), "compressed_ply"},
      {sog_data("guitar_crop.sog"), "sog_bundle"},        {sog_data("guitar_crop_deflate.sog"), "sog_bundle"},
      {sog_data("guitar_crop/meta.json"), "sog"},         {sog_data("guitar_crop"), "sog"},
      {sog_data("guitar_crop_lod-meta.json"), "sog_lod"},
  };
  TempDir tmp;
  size_t index = 0;
  for (const Case& c : cases) {
    auto id = converter::detect_scene_format(c.path);
    REQUIRE_MESSAGE(id.ok(), id.status().to_string());
    CHECK_MESSAGE(*id == c.id, c.path);
    // Misleading names change nothing: the content decides.
    if (!fs::is_directory(c.path)) {
      const std::string renamed = tmp.file("scene_" + std::to_string(index++) + ".rgs");
      fs::copy_file(c.path, renamed);
      auto again = converter::detect_scene_format(renamed);
      REQUIRE(again.ok());
      CHECK(*again == c.id);
    }
  }
  // A folder holding a lod-meta.json is read through it.
  fs::create_directories(tmp.path / "streamed" / "guitar_crop");
  for (const auto& e : fs::directory_iterator(sog_data("guitar_crop"))) {
    fs::copy_file(e.path(), tmp.path / "streamed" / "guitar_crop" / e.path().filename());
  }
  fs::copy_file(sog_data("guitar_crop_lod-meta.json"), tmp.path / "streamed" / "lod-meta.json");
  auto id = converter::detect_scene_format((tmp.path / "streamed").string());
  REQUIRE(id.ok());
  CHECK(*id == "sog_lod");
  CHECK(read_ok((tmp.path / "streamed").string()).cloud.size() == 877);
}

TEST_CASE("read_scene_bytes describes a PLY in memory as read_scene describes the file") {
  const std::string path = repo_path("samples/guitar.ply");
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(!bytes.empty());
  SceneReadOptions options;
  options.hash_file = true;
  const InputScene from_file = read_ok(path, options);
  auto from_memory = converter::read_scene_bytes(bytes.data(), bytes.size(), "-", options);
  REQUIRE_MESSAGE(from_memory.ok(), from_memory.status().to_string());
  CHECK(from_memory->format_id == from_file.format_id);
  CHECK(from_memory->description == from_file.description);
  CHECK(from_memory->storage_format == from_file.storage_format);
  CHECK(from_memory->file_bytes == from_file.file_bytes);
  CHECK(from_memory->file_count == 1);
  CHECK(from_memory->declared_vertices == from_file.declared_vertices);
  CHECK(from_memory->file_xxh64 == from_file.file_xxh64);
  CHECK(from_memory->cloud.means == from_file.cloud.means);
  CHECK(from_memory->cloud.sh == from_file.cloud.sh);

  // A level of detail is refused, as for a PLY file, never ignored.
  options.lod = 1;
  auto with_lod = converter::read_scene_bytes(bytes.data(), bytes.size(), "-", options);
  REQUIRE_FALSE(with_lod.ok());
  CHECK(with_lod.status().code() == StatusCode::kInvalidArgument);
  CHECK(with_lod.status().message().find("-: a level of detail applies only to streamed SOG") == 0);
}

TEST_CASE("read_scene reads a .rgs file as its dequantized scene, from a file and from memory") {
  TempDir tmp;
  const InputScene ply = read_ok(repo_path("samples/guitar.ply"));
  auto encoded = converter::quantize(ply.cloud, converter::QuantizeOptions{});
  REQUIRE(encoded.ok());
  auto bytes = format::serialize_scene(*encoded);
  REQUIRE(bytes.ok());
  write_bytes(tmp.file("guitar.bin"), *bytes);  // content, not the name, decides
  SceneReadOptions options;
  options.hash_file = true;
  options.keep_encoded = true;
  const InputScene from_file = read_ok(tmp.file("guitar.bin"), options);
  auto dequantized = format::dequantize(*encoded);
  REQUIRE(dequantized.ok());
  CHECK(from_file.format_id == "rgs");
  CHECK(from_file.cloud.means == dequantized->means);
  CHECK(from_file.cloud.sh == dequantized->sh);
  CHECK(from_file.cloud.opacities == dequantized->opacities);
  for (int a = 0; a < 3; ++a) CHECK(from_file.bounds.aabb_min[a] == encoded->metadata.bounds.aabb_min[a]);
  CHECK(from_file.bounds.sphere_radius == encoded->metadata.bounds.sphere_radius);
  REQUIRE(from_file.encoded.has_value());
  CHECK(from_file.encoded->count == encoded->count);
  CHECK(from_file.files == std::vector<std::string>{tmp.file("guitar.bin")});
  auto from_memory = converter::read_scene_bytes(bytes->data(), bytes->size(), "-", options);
  REQUIRE_MESSAGE(from_memory.ok(), from_memory.status().to_string());
  CHECK(from_memory->cloud.means == from_file.cloud.means);
  CHECK(from_memory->file_xxh64 == from_file.file_xxh64);
  // The .rgs limits apply: a count over max_gaussians is refused before anything is decoded.
  options.max_gaussians = 1000;
  CHECK(read_status(tmp.file("guitar.bin"), options).code() == StatusCode::kLimitExceeded);
}

TEST_CASE("read_scene names the format of a SOG meta.json or lod-meta.json nested too deep, not 'unsupported format'") {
  TempDir tmp;
  const std::string deep = std::string(100, '[') + std::string(100, ']');
  const struct {
    const char* name;
    std::string json;
    const char* format;
  } cases[] = {
      {"lod-meta.json", "{\"lodLevels\": 1, \"filenames\": [\"0/meta.json\"], \"tree\": " + deep + "}",
       "streamed SOG lod-meta.json"},
      {"meta.json", "{\"means\": {\"shape\": " + deep + "}, \"quats\": {}, \"scales\": {}}", "SOG meta.json"},
  };
  for (const auto& c : cases) {
    CAPTURE(c.name);
    const std::string path = tmp.file(c.name);
    write_bytes(path, std::vector<uint8_t>(c.json.begin(), c.json.end()));
    const Status s = read_status(path);
    CHECK(s.code() == StatusCode::kCorruptData);
    CHECK_MESSAGE(s.message() == path + ": " + c.format + ": JSON nested deeper than 64 levels", s.message());
  }
}

TEST_CASE("read_scene names what an unsupported input looks like and lists the supported formats") {
  TempDir tmp;
  struct Case {
    std::string name;
    std::vector<uint8_t> bytes;
    std::string looks_like;
  };
  auto bytes = [](const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); };
  const std::vector<Case> cases = {
      {"empty.ply", {}, "an empty file"},
      {"image.ply", bytes("\x89PNG\r\n\x1a\n\0\0"), "a PNG image"},
      {"keys.json", bytes("{\"camera\": 1, \"frames\": []}"), "a JSON object with keys {camera, frames}"},
      {"broken.json", bytes("{\"means\": "), "starts like JSON but does not parse"},
      {"noise.ply",
       {0xde, 0xad, 0xbe, 0xef, 1, 2, 3, 4, 5},
       "unrecognized data (first bytes: de ad be ef 01 02 03 04)"},
  };
  for (const Case& c : cases) {
    const std::string path = tmp.file(c.name);
    write_bytes(path, c.bytes);
    const Status s = read_status(path);
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(s.message().find(path + ": unsupported format: ") == 0, s.message());
    CHECK_MESSAGE(s.message().find(c.looks_like) != std::string::npos, s.message());
    CHECK_MESSAGE(s.message().find("; supported: ") != std::string::npos, s.message());
    CHECK_MESSAGE(s.message().find("PlayCanvas streamed SOG") != std::string::npos, s.message());
  }
  {
    // A ZIP archive without meta.json: guitar_crop.sog with that entry renamed (its name appears twice).
    auto zip = load_bytes(sog_data("guitar_crop.sog"));
    std::string text(zip.begin(), zip.end());
    for (size_t at = text.find("meta.json"); at != std::string::npos; at = text.find("meta.json", at + 1)) {
      zip[at + 2] = 'x';
    }
    write_bytes(tmp.file("archive.sog"), zip);
    const Status s = read_status(tmp.file("archive.sog"));
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(
        s.message().find("a ZIP archive without meta.json (entries: means_l.webp, means_u.webp") != std::string::npos,
        s.message());
  }
  fs::create_directories(tmp.path / "empty_dir");
  const Status dir = read_status((tmp.path / "empty_dir").string());
  CHECK(dir.code() == StatusCode::kInvalidArgument);
  CHECK(dir.message().find("a directory without lod-meta.json or meta.json") != std::string::npos);
  const Status missing = read_status(tmp.file("missing.ply"));
  CHECK(missing.code() == StatusCode::kIoError);
  CHECK(converter::supported_scene_formats().size() >= 8);
}

TEST_CASE("read_scene detects and reads SPZ, glTF/GLB and .splat files") {
  struct Case {
    std::string file, id, storage;
  };
  const std::vector<Case> cases = {
      {"guitar_256_splat_transform_v3.spz", "spz", "spz v3"},
      {"guitar_256_splat_transform_v4.spz", "spz", "spz v4"},
      {"guitar_256_splat_transform.glb", "glb", "glb v2"},
      {"guitar_256_splat_transform.splat", "splat", "splat"},
  };
  const uint64_t expected = read_reference(repo_path("tests/data/interop/guitar_256.ply")).size();
  REQUIRE(expected == 256);
  TempDir tmp;
  size_t index = 0;
  for (const Case& c : cases) {
    CAPTURE(c.file);
    const std::string path = repo_path("tests/data/interop/" + c.file);
    auto id = converter::detect_scene_format(path);
    REQUIRE_MESSAGE(id.ok(), id.status().to_string());
    CHECK(*id == c.id);
    SceneReadOptions options;
    options.hash_file = true;
    const InputScene scene = read_ok(path, options);
    CHECK(scene.format_id == c.id);
    CHECK(scene.storage_format == c.storage);
    CHECK(scene.cloud.size() == expected);
    CHECK(scene.declared_vertices == expected);
    CHECK(scene.file_bytes == fs::file_size(path));
    CHECK(scene.file_xxh64.has_value());
    // The content decides, whatever the name says.
    const std::string renamed = tmp.file("scene_" + std::to_string(index++) + ".ply.txt");
    fs::copy_file(path, renamed);
    auto again = converter::detect_scene_format(renamed);
    REQUIRE(again.ok());
    CHECK(*again == c.id);
    // A level of detail is refused for these formats.
    SceneReadOptions lod;
    lod.lod = 1;
    CHECK(read_status(path, lod).code() == StatusCode::kInvalidArgument);
  }
  // The SPZ axes (converter/INTEROP.md "SPZ axes"): splat-transform stores the PLY's axes, so only
  // spz_frame kAsStored gives back its source's means; kRub turns y and z over. Each read says which.
  const std::string spz = repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz");
  SceneReadOptions keep;
  keep.spz_frame = SpzFrame::kAsStored;
  const InputScene turned = read_ok(spz), kept = read_ok(spz, keep);
  const InputScene source = read_ok(repo_path("tests/data/interop/guitar_256.ply"));
  REQUIRE(turned.cloud.size() == source.cloud.size());
  REQUIRE(kept.cloud.size() == source.cloud.size());
  float kept_error = 0.0f, turned_error = 0.0f;
  for (size_t i = 0; i < source.cloud.means.size(); ++i) {
    kept_error = std::max(kept_error, std::fabs(kept.cloud.means[i] - source.cloud.means[i]));
    turned_error = std::max(turned_error, std::fabs(turned.cloud.means[i] - source.cloud.means[i]));
  }
  CHECK(kept_error <= 0.5f / 4096.0f + 1e-6f);  // half the 12-fractional-bit position step
  CHECK(turned_error > 0.1f);
  CHECK(kept.cloud.means[1] == -turned.cloud.means[1]);
  CHECK(kept.cloud.means[2] == -turned.cloud.means[2]);
  REQUIRE_FALSE(kept.notes.empty());
  REQUIRE_FALSE(turned.notes.empty());
  CHECK(kept.notes.front() == spz_frame_note(SpzFrame::kAsStored, false));
  CHECK(turned.notes.front() == spz_frame_note(SpzFrame::kRub, false));
  CHECK(turned.notes.front().find("as-stored") != std::string::npos);
  // One read set, two writers: the splat-transform file named as stored, every other SPZ as RUB.
  {
    TempDir dir;
    const std::string ours = dir.file("ours.spz");
    converter::SpzWriteOptions rub;
    REQUIRE(converter::write_spz(ours, source.cloud, rub).ok());
    SceneReadOptions both;
    both.spz_frame_by_path[spz] = SpzFrame::kAsStored;
    CHECK(converter::spz_frame_for(both, spz) == SpzFrame::kAsStored);
    CHECK(converter::spz_frame_for(both, ours) == SpzFrame::kRub);
    const InputScene theirs_read = read_ok(spz, both), ours_read = read_ok(ours, both);
    CHECK(theirs_read.cloud.means == kept.cloud.means);
    CHECK(theirs_read.notes.front() == spz_frame_note(SpzFrame::kAsStored, false));
    CHECK(ours_read.notes.front() == spz_frame_note(SpzFrame::kRub, false));
    float ours_error = 0.0f;
    for (size_t i = 0; i < source.cloud.means.size(); ++i) {
      ours_error = std::max(ours_error, std::fabs(ours_read.cloud.means[i] - source.cloud.means[i]));
    }
    CHECK(ours_error <= 0.5f / 4096.0f + 1e-6f);
    // Paths are compared after lexical normalization; a path not listed takes spz_frame.
    SceneReadOptions dotted;
    dotted.spz_frame_by_path[dir.file("./sub/../ours.spz")] = SpzFrame::kAsStored;
    CHECK(converter::spz_frame_for(dotted, ours) == SpzFrame::kAsStored);
    CHECK(converter::spz_frame_for(dotted, spz) == SpzFrame::kRub);
    dotted.spz_frame = SpzFrame::kAsStored;
    dotted.spz_frame_by_path.clear();
    dotted.spz_frame_by_path[ours] = SpzFrame::kRub;
    CHECK(converter::spz_frame_for(dotted, spz) == SpzFrame::kAsStored);
    CHECK(read_ok(ours, dotted).cloud.means == ours_read.cloud.means);
  }
  // A file of 32-byte records that are not plausible Gaussians is not taken for .splat...
  std::vector<uint8_t> noise(64, 0xff);
  write_bytes(tmp.file("noise.bin"), noise);
  const Status s = read_status(tmp.file("noise.bin"));
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find("unsupported format") != std::string::npos);
  // ...but a file named .splat gets the .splat reader's reason, naming the format.
  write_bytes(tmp.file("noise.splat"), noise);
  const Status named = read_status(tmp.file("noise.splat"));
  CHECK(named.code() == StatusCode::kCorruptData);
  CHECK(named.message().find("noise.splat") != std::string::npos);
  const std::vector<uint8_t> splat = load_bytes(repo_path("tests/data/interop/guitar_256_splat_transform.splat"));
  write_bytes(tmp.file("cut.splat"), std::vector<uint8_t>(splat.begin(), splat.end() - 5));
  const Status cut = read_status(tmp.file("cut.splat"));
  CHECK(cut.code() == StatusCode::kCorruptData);
  CHECK(cut.message().find("antimatter15 .splat: the format holds 32-byte records") != std::string::npos);
  CHECK(cut.message().find("27 left over") != std::string::npos);
  std::vector<uint8_t> negative = splat;
  const float minus = -1.0f;
  std::memcpy(negative.data() + 5 * 32 + 16, &minus, 4);
  write_bytes(tmp.file("negative.splat"), negative);
  const Status bad_record = read_status(tmp.file("negative.splat"));
  CHECK(bad_record.code() == StatusCode::kCorruptData);
  CHECK(bad_record.message().find("Gaussian 5 has a negative scale (-1.000000; negative scale values: 1 of 768)") !=
        std::string::npos);
  // A file named .ksplat that its detector refuses gets the .ksplat reader's reason.
  write_bytes(tmp.file("scene.ksplat"), std::vector<uint8_t>(4096, 0));
  const Status ksplat = read_status(tmp.file("scene.ksplat"));
  CHECK(ksplat.code() == StatusCode::kUnsupportedVersion);
  CHECK(ksplat.message().find("scene.ksplat: GaussianSplats3D .ksplat: version 0.0 (0.1 is read)") != std::string::npos);
  // A damaged .rgs gets the .rgs reader's error even when its size would suit .splat.
  std::vector<uint8_t> rgs(64, 0);
  std::copy(format::kMagic, format::kMagic + 8, rgs.begin());
  write_bytes(tmp.file("scene.splat"), rgs);
  const Status r = read_status(tmp.file("scene.splat"));
  CHECK_FALSE(r.ok());
  CHECK(r.code() != StatusCode::kInvalidArgument);
  CHECK(r.message().find("unsupported format") == std::string::npos);
  // A v3 SPZ (a gzip member) damaged right after its gzip header gets the SPZ reader's error, naming the file,
  // the format and the damage; a whole gzip member of something else stays an unsupported format.
  std::vector<uint8_t> v3 = load_bytes(repo_path("tests/data/interop/guitar_256_splat_transform_v3.spz"));
  for (size_t i = 10; i < 30; ++i) v3[i] ^= 0x5a;
  write_bytes(tmp.file("damaged_v3.spz"), v3);
  const Status damaged = read_status(tmp.file("damaged_v3.spz"));
  CHECK(damaged.code() == StatusCode::kCorruptData);
  CHECK_MESSAGE(damaged.message().find(tmp.file("damaged_v3.spz") + ": gzip-wrapped SPZ (v2/v3): bad gzip data") == 0,
                damaged.message());
  // gzip -n of "hi\n": a complete member that inflates to 3 bytes.
  write_bytes(tmp.file("hi.gz"), {0x1f, 0x8b, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x03, 0xcb, 0xc8, 0xe4,
                                  0x02, 0x00, 0x7a, 0x7a, 0x6f, 0xed, 0x03, 0x00, 0x00, 0x00});
  const Status other = read_status(tmp.file("hi.gz"));
  CHECK(other.code() == StatusCode::kInvalidArgument);
  CHECK_MESSAGE(other.message().find("unsupported format: gzip data") != std::string::npos, other.message());
}

TEST_CASE("read_scene reads biker.spz (real scene)") {
  const std::string path = shared_scene("biker.spz");
  if (path.empty()) return;
  auto id = converter::detect_scene_format(path);
  REQUIRE(id.ok());
  CHECK(*id == "spz");
  const InputScene scene = read_ok(path);
  CHECK(scene.cloud.size() == 152746);
  CHECK(scene.format_id == "spz");
}

TEST_CASE("SOG: bundled (stored and deflated), folder and streamed forms decode like splat-transform") {
  const format::GaussianCloud ref = read_reference(sog_data("guitar_crop_sog_reference.ply"));
  REQUIRE(ref.size() == 877);
  const InputScene bundle = read_ok(sog_data("guitar_crop.sog"));
  CHECK(bundle.format_id == "sog_bundle");
  CHECK(bundle.declared_vertices == 877);
  CHECK(bundle.file_count == 1);
  check_same_decode(bundle.cloud, ref);
  for (const std::string& other : {sog_data("guitar_crop_deflate.sog"), sog_data("guitar_crop/meta.json"),
                                   sog_data("guitar_crop"), sog_data("guitar_crop_lod-meta.json")}) {
    CAPTURE(other);
    const InputScene scene = read_ok(other);
    CHECK(same_cloud(scene.cloud, bundle.cloud));
  }
  const InputScene folder = read_ok(sog_data("guitar_crop"));
  CHECK(folder.format_id == "sog");
  CHECK(folder.file_count == 6);  // meta.json + 5 images
  const InputScene streamed = read_ok(sog_data("guitar_crop_lod-meta.json"));
  CHECK(streamed.format_id == "sog_lod");
  CHECK(streamed.file_count == 7);
  CHECK(streamed.description == "PlayCanvas streamed SOG, LOD 0 of 1 (1 chunk)");
  // Activations: unit quaternions, opacities inside (0, 1) even for 8-bit alpha 0 and 255.
  for (size_t i = 0; i < bundle.cloud.size(); ++i) {
    const float* q = &bundle.cloud.rotations[i * 4];
    REQUIRE(std::fabs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0f) < 1e-5f);
    REQUIRE(bundle.cloud.opacities[i] > 0.0f);
    REQUIRE(bundle.cloud.opacities[i] < 1.0f);
  }
}

TEST_CASE("SOG: SH palettes (shN) expand channel-major f_rest into [N, K, 3]") {
  // guitar_crop_sh3 = guitar_crop + a synthetic 3-band palette (make_sog_sh_fixture.cpp states the rule).
  // splat-transform 3.7.0 decodes it to the same values (checked once when the fixture was made).
  const InputScene plain = read_ok(sog_data("guitar_crop"));
  const InputScene scene = read_ok(sog_data("guitar_crop_sh3"));
  const format::GaussianCloud& cloud = scene.cloud;
  REQUIRE(cloud.size() == 877);
  REQUIRE(cloud.sh_degree == 3);
  CHECK(cloud.means == plain.cloud.means);
  CHECK(cloud.rotations == plain.cloud.rotations);
  CHECK(cloud.opacities == plain.cloud.opacities);
  uint64_t wrong = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const size_t label = (i * 37) % 100;
    for (size_t c = 0; c < 3; ++c) {
      wrong += cloud.sh[(i * 16) * 3 + c] != plain.cloud.sh[i * 3 + c];
      for (size_t j = 0; j < 15; ++j) {
        const size_t code = (31 * label + 7 * j + 101 * c) % 256;
        wrong += cloud.sh[(i * 16 + j + 1) * 3 + c] != static_cast<float>((double(code) - 127.5) / 64);
      }
    }
  }
  CHECK(wrong == 0);
  // A palette larger than the centroids image holds, and a label past the palette, are corrupt.
  SogFolderCopy copy;
  for (const char* f : {"shN_centroids.webp", "shN_labels.webp"}) {
    fs::copy_file(sog_data(std::string("guitar_crop_sh3/") + f), copy.dir.file(f));
  }
  const std::string meta = read_text(sog_data("guitar_crop_sh3/meta.json"));
  write_text(copy.meta, replace_once(meta, "\"count\":100,", "\"count\":129,"));
  Status s = read_status(copy.meta);
  CHECK(s.code() == StatusCode::kCorruptData);
  CHECK_MESSAGE(s.message().find("129 palette entries need 3") != std::string::npos, s.to_string());
  write_text(copy.meta, replace_once(meta, "\"count\":100,", "\"count\":50,"));
  s = read_status(copy.meta);
  CHECK(s.code() == StatusCode::kCorruptData);
  CHECK_MESSAGE(s.message().find("but the palette has 50 entries") != std::string::npos, s.to_string());
  write_text(copy.meta, replace_once(meta, "\"bands\":3,", "\"bands\":2,"));
  s = read_status(copy.meta);
  CHECK(s.code() == StatusCode::kCorruptData);
  CHECK_MESSAGE(s.message().find("2 SH bands need 512") != std::string::npos, s.to_string());
}

TEST_CASE("SOG: the earlier unversioned layout (per-channel ranges, logit in sh0) decodes like splat-transform") {
  // guitar_crop's images under a hand-written unversioned meta.json (make_sog_reference.py says how the
  // reference was made).
  SogFolderCopy copy;
  write_text(copy.meta, read_text(sog_data("guitar_crop_v1_meta.json")));
  const InputScene scene = read_ok(copy.meta);
  CHECK(scene.description == "PlayCanvas SOG unversioned (v1) (meta.json + 5 WebP images)");
  check_same_decode(scene.cloud, read_reference(sog_data("guitar_crop_v1_reference.ply")));
  CHECK(scene.cloud.means == read_ok(sog_data("guitar_crop")).cloud.means);  // same means encoding as v2
}

TEST_CASE("SOG: file hashes are deterministic and cover every file read") {
  SceneReadOptions options;
  options.hash_file = true;
  const InputScene a = read_ok(sog_data("guitar_crop"), options);
  const InputScene b = read_ok(sog_data("guitar_crop/meta.json"), options);
  REQUIRE(a.file_xxh64.has_value());
  CHECK(a.file_xxh64 == b.file_xxh64);
  SogFolderCopy copy;
  auto image = load_bytes(copy.dir.file("sh0.webp"));
  image.push_back(0);  // a trailing byte after the RIFF data: still decodes, but the hash must change
  write_bytes(copy.dir.file("sh0.webp"), image);
  const InputScene c = read_ok(copy.meta, options);
  CHECK(c.file_xxh64 != a.file_xxh64);
  CHECK(same_cloud(c.cloud, a.cloud));
}

TEST_CASE("compressed PLY: the guitar crop decodes like splat-transform") {
  const format::GaussianCloud ref = read_reference(sog_data("guitar_crop_compressed_reference.ply"));
  const InputScene scene = read_ok(sog_data("guitar_crop.compressed.ply"));
  CHECK(scene.format_id == "compressed_ply");
  CHECK(scene.description == "PlayCanvas compressed PLY");
  check_same_decode(scene.cloud, ref, 1.5e-6);
  size_t saturated = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    if (ref.opacities[i] == 1.0f) {
      ++saturated;
      CHECK(scene.cloud.opacities[i] == doctest::Approx(1.0 - 1e-6).epsilon(1e-7));
    }
  }
  MESSAGE(saturated << " Gaussians of the crop have 8-bit alpha 255");
}

/// Per-chunk (256 Gaussians) extent of a value in the reference, divided by the quantization levels.
std::vector<double> chunk_steps(const format::GaussianCloud& ref, int levels,
                                double (*value)(const format::GaussianCloud&, size_t, int), int channel) {
  std::vector<double> steps;
  for (size_t begin = 0; begin < ref.size(); begin += 256) {
    double lo = 1e300, hi = -1e300;
    for (size_t i = begin; i < std::min(ref.size(), begin + 256); ++i) {
      lo = std::min(lo, value(ref, i, channel));
      hi = std::max(hi, value(ref, i, channel));
    }
    steps.push_back((hi - lo) / levels);
  }
  return steps;
}

TEST_CASE("compressed PLY: guitar.compressed.ply matches guitar.ply within each quantity's quantization step") {
  const std::string compressed = shared_scene("guitar.compressed.ply");
  const std::string expanded = shared_scene("guitar.ply");
  if (compressed.empty() || expanded.empty()) return;
  const InputScene scene = read_ok(compressed);
  const format::GaussianCloud ref = read_reference(expanded);
  const format::GaussianCloud& got = scene.cloud;
  REQUIRE(got.size() == 90854);
  REQUIRE(ref.size() == 90854);
  REQUIRE(got.sh_degree == 0);
  // The chunk bounds are the min/max of each chunk's values, so the decoded extremes span them.
  auto mean = [](const format::GaussianCloud& c, size_t i, int a) { return double(c.means[i * 3 + a]); };
  auto log_scale = [](const format::GaussianCloud& c, size_t i, int a) {
    return std::log(double(c.scales[i * 3 + a]));
  };
  auto dc = [](const format::GaussianCloud& c, size_t i, int ch) { return double(c.sh[i * 3 + ch]); };
  const int bits_of_axis[3] = {2047, 1023, 2047};  // 11-10-11
  uint64_t outside = 0;
  for (int a = 0; a < 3; ++a) {
    const auto mean_steps = chunk_steps(ref, bits_of_axis[a], mean, a);
    const auto scale_steps = chunk_steps(ref, bits_of_axis[a], log_scale, a);
    const auto dc_steps = chunk_steps(ref, 255, dc, a);
    for (size_t i = 0; i < ref.size(); ++i) {
      const size_t c = i / 256;
      outside += std::fabs(mean(got, i, a) - mean(ref, i, a)) > mean_steps[c] + 1e-6;
      outside += std::fabs(log_scale(got, i, a) - log_scale(ref, i, a)) > scale_steps[c] + 1e-5;
      outside += std::fabs(dc(got, i, a) - dc(ref, i, a)) > dc_steps[c] + 1e-5;
    }
  }
  double worst_rotation = 0, worst_opacity = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    for (int c = 0; c < 4; ++c) {
      worst_rotation = std::max(worst_rotation, std::fabs(double(got.rotations[i * 4 + c]) - ref.rotations[i * 4 + c]));
    }
    worst_opacity = std::max(worst_opacity, std::fabs(double(got.opacities[i]) - ref.opacities[i]));
  }
  CHECK(outside == 0);
  CHECK(worst_rotation <= std::sqrt(2.0) / 1023);  // one step of the 10-bit smallest-three components
  CHECK(worst_opacity <= 1.0 / 255);               // one step of 8-bit alpha
  // In fact the same formulas: float32 rounding only. 8-bit alpha 255 becomes the clamped logit 13.8155 in
  // both, so their opacities agree too.
  check_same_decode(got, ref);
}

/// Indices of taebak_lod0_reference_sample.ply (make_sog_reference.py: sample_indices).
std::vector<size_t> sample_indices(size_t n) {
  std::set<size_t> picked;
  for (size_t i = 0; i < std::min<size_t>(100, n); ++i) picked.insert(i);
  for (size_t i = n > 100 ? n - 100 : 0; i < n; ++i) picked.insert(i);
  for (size_t k = 0; k < 300; ++k) picked.insert(k * n / 300);
  return {picked.begin(), picked.end()};
}

TEST_CASE("streamed SOG: taebak LOD 0 (4,249,286 Gaussians) against a sample of splat-transform's decode") {
  const std::string path = shared_scene("taebak_lod0_sog/lod-meta.json");
  if (path.empty()) return;
  SceneReadOptions options;
  options.hash_file = true;
  const InputScene scene = read_ok(path, options);
  const format::GaussianCloud& cloud = scene.cloud;
  REQUIRE(cloud.size() == 4249286);
  CHECK(cloud.sh_degree == 0);
  CHECK(scene.declared_vertices == 4249286);
  CHECK(scene.file_count == 1 + 8 * 6);
  CHECK(scene.description == "PlayCanvas streamed SOG, LOD 0 of 5 (8 chunks)");
  REQUIRE(scene.file_xxh64.has_value());

  const format::GaussianCloud ref = read_reference(sog_data("taebak_lod0_reference_sample.ply"));
  const std::vector<size_t> rows = sample_indices(cloud.size());
  REQUIRE(ref.size() == rows.size());
  format::GaussianCloud picked;
  picked.sh_degree = 0;
  picked.resize(rows.size());
  for (size_t r = 0; r < rows.size(); ++r) {
    const size_t i = rows[r];
    std::copy_n(&cloud.means[i * 3], 3, &picked.means[r * 3]);
    std::copy_n(&cloud.rotations[i * 4], 4, &picked.rotations[r * 4]);
    std::copy_n(&cloud.scales[i * 3], 3, &picked.scales[r * 3]);
    picked.opacities[r] = cloud.opacities[i];
    std::copy_n(&cloud.sh[i * 3], 3, &picked.sh[r * 3]);
  }
  check_same_decode(picked, ref);

  // Whole-scene means printed by make_sog_reference.py from the full reference decode.
  double sum[6] = {};
  for (size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) sum[a] += cloud.means[i * 3 + a];
    sum[3] += (double(cloud.scales[i * 3]) + cloud.scales[i * 3 + 1] + cloud.scales[i * 3 + 2]) / 3;
    sum[4] += cloud.opacities[i];
    sum[5] += (double(cloud.sh[i * 3]) + cloud.sh[i * 3 + 1] + cloud.sh[i * 3 + 2]) / 3;
  }
  const double expected[6] = {0.184482122, -0.395341927, -0.482763791, 0.0141648639, 0.639834312, -0.0121877957};
  for (int k = 0; k < 6; ++k) {
    CAPTURE(k);
    CHECK(sum[k] / double(cloud.size()) == doctest::Approx(expected[k]).epsilon(1e-6));
  }

  SceneReadOptions lod1;
  lod1.lod = 1;  // referenced, but this copy holds LOD 0 only: the missing chunk is named
  const Status missing = read_status(path, lod1);
  CHECK(missing.code() == StatusCode::kIoError);
  CHECK_MESSAGE(missing.message().find("LOD 1 chunk '1_0/meta.json'") != std::string::npos, missing.message());
  SceneReadOptions lod9;
  lod9.lod = 9;
  const Status beyond = read_status(path, lod9);
  CHECK(beyond.code() == StatusCode::kInvalidArgument);
  CHECK(beyond.message().find("LOD 9 requested, but the scene has 5 levels") != std::string::npos);
}

TEST_CASE("SOG: broken folders, metas and images fail with a named code") {
  const std::string base_meta = read_text(sog_data("guitar_crop/meta.json"));
  struct Case {
    const char* what;
    std::string meta;           // replacement meta.json ("" keeps it)
    const char* truncate_file;  // image to cut in half, or null
    const char* remove_file;    // image to delete, or null
    StatusCode code;
    const char* message_part;
  };
  const std::vector<Case> cases = {
      {"count above the images", replace_once(base_meta, "\"count\":877", "\"count\":1000000"), nullptr, nullptr,
       StatusCode::kCorruptData, "fewer than the 1000000 Gaussians"},
      {"truncated image", "", "quats.webp", nullptr, StatusCode::kCorruptData, "truncated"},
      {"missing image", "", nullptr, "scales.webp", StatusCode::kIoError, "scales.webp"},
      {"short codebook", replace_once(base_meta, "\"codebook\":[", "\"codebook\":[0,"), nullptr, nullptr,
       StatusCode::kCorruptData, "entries, expected 256"},
      {"missing field", replace_once(base_meta, "\"quats\"", "\"quaternions\""), nullptr, nullptr,
       StatusCode::kCorruptData, "missing field 'quats'"},
      {"newer version", replace_once(base_meta, "\"version\":2", "\"version\":3"), nullptr, nullptr,
       StatusCode::kUnsupportedVersion, "version 3"},
      {"file outside the folder", replace_once(base_meta, "\"sh0.webp\"", "\"../sh0.webp\""), nullptr, nullptr,
       StatusCode::kCorruptData, "outside the scene's folder"},
      {"means.mins with 4 entries", replace_once(base_meta, "\"mins\":[", "\"mins\":[-1000,"), nullptr, nullptr,
       StatusCode::kCorruptData, "field 'means.mins' has 4 entries"},
      {"means range overflowing float32", replace_once(base_meta, "\"mins\":[0.14195467716396362", "\"mins\":[-1000"),
       nullptr, nullptr, StatusCode::kCorruptData, "overflows float32 positions"},
      {"not JSON", "{\"means\": [", nullptr, nullptr, StatusCode::kInvalidArgument, "unsupported format"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.what);
    SogFolderCopy copy;
    if (!c.meta.empty()) write_text(copy.meta, c.meta);
    if (c.truncate_file) {
      auto b = load_bytes(copy.dir.file(c.truncate_file));
      b.resize(b.size() / 2);
      write_bytes(copy.dir.file(c.truncate_file), b);
    }
    if (c.remove_file) fs::remove(copy.dir.file(c.remove_file));
    const Status s = read_status(copy.meta);
    CHECK_MESSAGE(s.code() == c.code, s.to_string());
    CHECK_MESSAGE(s.message().find(c.message_part) != std::string::npos, s.to_string());
  }
  {
    SogFolderCopy copy;
    SceneReadOptions options;
    options.max_gaussians = 876;
    const Status s = read_status(copy.meta, options);
    CHECK(s.code() == StatusCode::kLimitExceeded);
    CHECK(s.message().find("877 Gaussians, above the limit of 876") != std::string::npos);
    options = {};
    options.lod = 0;
    CHECK(read_status(copy.meta, options).code() == StatusCode::kInvalidArgument);
    CHECK(read_status(repo_path("samples/guitar.ply"), options).code() == StatusCode::kInvalidArgument);
  }
  {
    // The sh0 image (alpha = opacity) in place of the quaternions: most tags fall below 252.
    SogFolderCopy copy;
    write_bytes(copy.dir.file("quats.webp"), load_bytes(copy.dir.file("sh0.webp")));
    const Status s = read_status(copy.meta);
    CHECK(s.code() == StatusCode::kCorruptData);
    CHECK_MESSAGE(s.message().find("quaternion tag") != std::string::npos, s.to_string());
  }
}

TEST_CASE("SOG: broken bundles fail with a named code") {
  const auto good = load_bytes(sog_data("guitar_crop.sog"));
  TempDir tmp;
  {
    auto b = good;
    b.resize(b.size() - 30);  // cuts the end record
    write_bytes(tmp.file("cut.sog"), b);
    const Status s = read_status(tmp.file("cut.sog"));
    CHECK(s.code() == StatusCode::kCorruptData);
    CHECK_MESSAGE(s.message().find("end-of-central-directory") != std::string::npos, s.to_string());
  }
  {
    // Flip one byte inside the first stored entry's data (means_l.webp's pixels): the CRC catches it.
    auto b = good;
    b[30 + 12 + 200] ^= 0x55;
    write_bytes(tmp.file("flipped.sog"), b);
    const Status s = read_status(tmp.file("flipped.sog"));
    CHECK_MESSAGE(s.code() == StatusCode::kChecksumMismatch, s.to_string());
  }
  {
    // The deflated bundle with its compressed data damaged.
    auto b = load_bytes(sog_data("guitar_crop_deflate.sog"));
    for (size_t i = 60; i < 400; ++i) b[i] = static_cast<uint8_t>(i * 7);
    write_bytes(tmp.file("bad_deflate.sog"), b);
    const Status s = read_status(tmp.file("bad_deflate.sog"));
    CHECK_MESSAGE((s.code() == StatusCode::kCorruptData || s.code() == StatusCode::kChecksumMismatch), s.to_string());
  }
}

TEST_CASE("streamed SOG: broken lod-meta.json files fail with a named code") {
  const std::string base = read_text(sog_data("guitar_crop_lod-meta.json"));
  struct Case {
    const char* what;
    std::string text;
    StatusCode code;
    const char* message_part;
  };
  const std::vector<Case> cases = {
      {"range past the chunk",
       replace_once(replace_once(base, "\"count\":877}", "\"count\":878}"), "\"counts\":[877]", "\"counts\":[878]"),
       StatusCode::kCorruptData, "exceeds its 877 Gaussians"},
      {"counts disagree", replace_once(base, "\"counts\":[877]", "\"counts\":[900]"), StatusCode::kCorruptData,
       "references 877"},
      {"file index out of range", replace_once(base, "\"file\":0", "\"file\":3"), StatusCode::kCorruptData,
       "names file 3"},
      {"level key out of range", replace_once(base, "\"lods\":{\"0\"", "\"lods\":{\"7\""), StatusCode::kCorruptData,
       "not a level"},
      {"count over the limit", replace_once(base, "\"count\":877}", "\"count\":300000000}"), StatusCode::kLimitExceeded,
       "the limit"},
      {"newer version", replace_once(base, "\"version\":1", "\"version\":2"), StatusCode::kUnsupportedVersion,
       "version 2"},
      {"absolute chunk path", replace_once(base, "\"guitar_crop/meta.json\"", "\"/etc/meta.json\""),
       StatusCode::kCorruptData, "absolute path"},
  };
  TempDir tmp;
  fs::create_directories(tmp.path / "guitar_crop");
  for (const auto& e : fs::directory_iterator(sog_data("guitar_crop"))) {
    fs::copy_file(e.path(), tmp.path / "guitar_crop" / e.path().filename());
  }
  for (const Case& c : cases) {
    CAPTURE(c.what);
    write_text(tmp.file("lod-meta.json"), c.text);
    const Status s = read_status(tmp.file("lod-meta.json"));
    CHECK_MESSAGE(s.code() == c.code, s.to_string());
    CHECK_MESSAGE(s.message().find(c.message_part) != std::string::npos, s.to_string());
  }
  write_text(tmp.file("lod-meta.json"), base);
  SceneReadOptions lod1;
  lod1.lod = 1;
  CHECK(read_status(tmp.file("lod-meta.json"), lod1).code() == StatusCode::kInvalidArgument);
}

TEST_CASE("compressed PLY: broken files fail with a named code") {
  const auto good = load_bytes(sog_data("guitar_crop.compressed.ply"));
  const std::string text(good.begin(), good.end());
  const size_t header_end = text.find("end_header\n") + 11;
  TempDir tmp;
  auto with_header = [&](const std::string& from, const std::string& to) {
    std::string header = replace_once(text.substr(0, header_end), from, to);
    std::vector<uint8_t> b(header.begin(), header.end());
    b.insert(b.end(), good.begin() + static_cast<std::ptrdiff_t>(header_end), good.end());
    return b;
  };
  struct Case {
    const char* what;
    std::vector<uint8_t> bytes;
    StatusCode code;
    const char* message_part;
  };
  std::vector<uint8_t> truncated(good.begin(), good.end() - 100);
  // Chunk 1's field f (0..17 in header order: min/max of x y z, of the log scales, of r g b) set to v.
  auto with_chunk_field = [&](int f, float v) {
    std::vector<uint8_t> b = good;
    std::memcpy(b.data() + header_end + (18 + f) * sizeof(float), &v, sizeof(float));
    return b;
  };
  const std::vector<Case> cases = {
      {"truncated", truncated, StatusCode::kIoError, "truncated file"},
      {"chunk count", with_header("element chunk 4", "element chunk 3"), StatusCode::kCorruptData,
       "expected 4 (one per 256)"},
      {"vertex count over the data", with_header("element vertex 877", "element vertex 1000000"), StatusCode::kIoError,
       "truncated file"},
      {"packed type", with_header("property uint packed_color", "property int packed_color"),
       StatusCode::kUnsupportedFeature, "packed_color"},
      {"NaN bound", with_chunk_field(0, std::nanf("")), StatusCode::kCorruptData, "chunk 1 has a non-finite min_x"},
      // Finite bounds whose decoded values overflow float32: exp(89) and (3e38 − 0.5) / C0 (SH DC, ~1.1e39;
      // fuzz_interop_read found the colour case).
      {"log-scale bound", with_chunk_field(9, 89.0f), StatusCode::kCorruptData, "chunk 1 has an overflowing max_scale_x"},
      {"colour bound", with_chunk_field(15, 3e38f), StatusCode::kCorruptData, "chunk 1 has an overflowing max_r"},
      {"negative colour bound", with_chunk_field(13, -3e38f), StatusCode::kCorruptData,
       "chunk 1 has an overflowing min_g"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.what);
    write_bytes(tmp.file("bad.compressed.ply"), c.bytes);
    const Status s = read_status(tmp.file("bad.compressed.ply"));
    CHECK_MESSAGE(s.code() == c.code, s.to_string());
    CHECK_MESSAGE(s.message().find(c.message_part) != std::string::npos, s.to_string());
  }
  SceneReadOptions limit;
  limit.max_gaussians = 100;
  const Status s = read_status(sog_data("guitar_crop.compressed.ply"), limit);
  CHECK(s.code() == StatusCode::kLimitExceeded);
  CHECK(s.message().find("877 vertices, above the limit of 100") != std::string::npos);
}

}  // namespace
}  // namespace rgs::test

namespace rgs::test {
namespace {

TEST_CASE("seeded corruption and truncation of PlayCanvas inputs give errors, never crashes") {
  TempDir tmp;
  std::mt19937 rng(20261122);
  struct Input {
    std::string source, name;
  };
  const std::vector<Input> inputs = {{sog_data("guitar_crop.sog"), "x.sog"},
                                     {sog_data("guitar_crop_deflate.sog"), "y.sog"},
                                     {sog_data("guitar_crop.compressed.ply"), "z.compressed.ply"},
                                     {sog_data("guitar_crop_sh3/meta.json"), "meta.json"},
                                     {sog_data("guitar_crop_sh3/shN_centroids.webp"), "shN_centroids.webp"}};
  // The SH3 folder's other files, so that a damaged meta.json or image is read with its images.
  for (const auto& e : fs::directory_iterator(sog_data("guitar_crop_sh3"))) {
    fs::copy_file(e.path(), tmp.path / e.path().filename());
  }
  uint64_t failures = 0, runs = 0;
  for (const Input& input : inputs) {
    const auto good = load_bytes(input.source);
    const std::string target = input.name == "shN_centroids.webp" ? tmp.file("meta.json") : tmp.file(input.name);
    for (int trial = 0; trial < 60; ++trial) {
      auto bytes = good;
      if (trial % 3 == 0) {
        bytes.resize(std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng));
      } else {
        const int flips = 1 + trial % 8;
        for (int f = 0; f < flips; ++f) {
          bytes[std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng)] ^=
              static_cast<uint8_t>(1u << std::uniform_int_distribution<int>(0, 7)(rng));
        }
      }
      write_bytes(tmp.file(input.name), bytes);
      auto r = read_scene(target);
      ++runs;
      failures += !r.ok();
      if (!r.ok()) {
        CHECK(r.status().code() != StatusCode::kOk);
        CHECK(!r.status().message().empty());
      } else {
        CHECK(r->cloud.is_consistent());
      }
    }
    write_bytes(tmp.file(input.name), good);
  }
  MESSAGE(failures << " of " << runs << " damaged inputs were rejected; the rest still decoded consistently");
}

TEST_CASE("read_scene: every input format, with the read limits") {
  struct Case {
    std::string path, format_id;
    uint64_t gaussians;
  };
  const std::vector<Case> cases = {
      {repo_path("samples/guitar.ply"), "ply", 90854},
      {repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz"), "spz", 256},
      {repo_path("tests/data/interop/guitar_256_splat_transform.glb"), "glb", 256},
      {repo_path("tests/data/interop/guitar_256_splat_transform.splat"), "splat", 256},
      {repo_path("tests/data/sog/guitar_crop.sog"), "sog_bundle", 0},
      {repo_path("tests/data/v1.0/small_sh3.rgs"), "rgs", 0},
  };
  for (const Case& c : cases) {
    CAPTURE(c.path);
    auto scene = read_scene(c.path);
    REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
    CHECK(scene->format_id == c.format_id);
    CHECK_FALSE(scene->description.empty());
    if (c.gaussians != 0) CHECK(scene->cloud.size() == c.gaussians);
    CHECK(scene->cloud.size() > 0);
    CHECK(scene->bounds.sphere_radius > 0);
    // The limit is honoured for every format, before the cloud is built.
    SceneReadOptions tight;
    tight.max_gaussians = scene->cloud.size() - 1;
    auto refused = read_scene(c.path, tight);
    REQUIRE_FALSE(refused.ok());
    CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  }
  auto unsupported = read_scene(repo_path("tests/data/sog/make_sog_reference.py"));
  REQUIRE_FALSE(unsupported.ok());
  CHECK(unsupported.status().code() == StatusCode::kInvalidArgument);
  CHECK(unsupported.status().message().find("unsupported format") != std::string::npos);
}

TEST_CASE("is_rgs_path: the .rgs magic or a name ending in .rgs") {
  CHECK(format::is_rgs_path(repo_path("tests/data/v1.0/small_sh3.rgs")));
  CHECK_FALSE(format::is_rgs_path(repo_path("samples/guitar.ply")));
  // A missing or unreadable file ending in .rgs (any case) still goes to the .rgs reader for its error.
  CHECK(format::is_rgs_path("/nonexistent/scene.RGS"));
  CHECK(format::is_rgs_path(".rgs"));
  CHECK_FALSE(format::is_rgs_path("/nonexistent/scene.ply"));
  CHECK_FALSE(format::is_rgs_path("rgs"));
}

}  // namespace
}  // namespace rgs::test
