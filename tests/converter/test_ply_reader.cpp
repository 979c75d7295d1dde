// PLY reader: real scenes, every storage format and property type decoding to identical clouds,
// activations against an independent raw parse, header errors and input hygiene.
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>

#include "ply_test_util.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/quantize.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::InvalidPolicy;
using converter::PlyReadOptions;
using converter::PlyScene;
using converter::read_ply;
using converter::read_ply_bytes;

PlyScene read_ok(const std::vector<uint8_t>& bytes, const PlyReadOptions& options = {}) {
  auto r = read_ply_bytes(bytes.data(), bytes.size(), "test.ply", options);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

Status read_status(const std::vector<uint8_t>& bytes, const PlyReadOptions& options = {}) {
  auto r = read_ply_bytes(bytes.data(), bytes.size(), "test.ply", options);
  return r.status();
}

Status read_status(const std::string& text) {
  return read_status(std::vector<uint8_t>(text.begin(), text.end()));
}

/// Checks the activations of `scene` against the raw values of the same file, Gaussian by Gaussian.
void check_against_raw(const PlyScene& scene, const RawPly& raw) {
  const auto& cloud = scene.cloud;
  REQUIRE(cloud.size() == raw.count);
  const uint32_t k_count = cloud.sh_coefficients();
  uint64_t bad = 0;
  for (uint64_t i = 0; i < raw.count; ++i) {
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) bad += cloud.means[i * 3 + a] != raw.get(i, axes[a]);
    for (int c = 0; c < 3; ++c) bad += cloud.sh[(i * k_count) * 3 + c] != raw.get(i, "f_dc_" + std::to_string(c));
    for (uint32_t k = 1; k < k_count; ++k) {
      for (uint32_t c = 0; c < 3; ++c) {
        bad += cloud.sh[(i * k_count + k) * 3 + c] != raw.get(i, "f_rest_" + std::to_string(c * (k_count - 1) + k - 1));
      }
    }
    for (int a = 0; a < 3; ++a) {
      const double s = std::exp(static_cast<double>(raw.get(i, "scale_" + std::to_string(a))));
      bad += cloud.scales[i * 3 + a] != static_cast<float>(s);
    }
    const double o = 1.0 / (1.0 + std::exp(-static_cast<double>(raw.get(i, "opacity"))));
    bad += cloud.opacities[i] != static_cast<float>(o);
    double n2 = 0;
    for (int a = 0; a < 4; ++a) n2 += std::pow(static_cast<double>(raw.get(i, "rot_" + std::to_string(a))), 2);
    for (int a = 0; a < 4; ++a) {
      bad += cloud.rotations[i * 4 + a] != static_cast<float>(raw.get(i, "rot_" + std::to_string(a)) / std::sqrt(n2));
    }
  }
  CHECK(bad == 0);
}

TEST_CASE("read_ply: shipped guitar sample (SH0, 90,854 Gaussians) matches an independent raw parse") {
  const std::string path = repo_path("samples/guitar.ply");
  auto r = read_ply(path);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  CHECK(r->cloud.size() == 90854);
  CHECK(r->cloud.sh_degree == 0);
  CHECK(r->cloud.is_consistent());
  CHECK(r->declared_vertices == 90854);
  CHECK(r->storage_format == "binary_little_endian");
  CHECK(r->file_bytes == std::filesystem::file_size(path));
  CHECK(r->hygiene.nonfinite_values == 0);
  CHECK(r->hygiene.zero_norm_quaternions == 0);
  CHECK(r->hygiene.infinite_opacity_logits == 0);
  CHECK(r->hygiene.first_invalid_index == -1);
  const auto bytes = load_bytes(path);
  check_against_raw(*r, parse_raw_ply(bytes));
  // The in-memory entry point decodes identically.
  CHECK(same_cloud(read_ok(bytes).cloud, r->cloud));
}

struct SharedScene {
  const char* file;
  uint64_t count;
  uint32_t degree;
};

TEST_CASE("read_ply: real scenes from $RGS_DATA_DIR") {
  const SharedScene scenes[] = {
      {"mipnerf360_flowers_c3dgs.ply", 38347, 3}, {"tiny_unknown_inria_sh3_it7000.ply", 9080, 3},
      {"guitar.ply", 90854, 0},                   {"biker.ply", 152746, 0},
      {"playcanvas_flowers_lod0.ply", 542104, 2},
  };
  for (const SharedScene& s : scenes) {
    const std::string path = shared_scene(s.file);
    if (path.empty()) continue;
    CAPTURE(s.file);
    auto r = read_ply(path);
    REQUIRE_MESSAGE(r.ok(), r.status().to_string());
    CHECK(r->cloud.size() == s.count);
    CHECK(r->cloud.sh_degree == s.degree);
    CHECK(r->hygiene.gaussians_with_nonfinite == 0);
    CHECK(r->hygiene.zero_norm_quaternions == 0);
    if (s.count < 200000) check_against_raw(*r, parse_raw_ply(load_bytes(path)));  // includes nx ny nz files
  }
}

/// Raw values of an SH3 scene built from guitar's real geometry: f_rest values derived from f_dc with
/// fixed factors (deterministic, no random numbers), plus extra properties the reader must skip.
struct Sh3FromGuitar {
  RawPly raw;
  uint64_t count;

  explicit Sh3FromGuitar(uint64_t max_count) {
    raw = parse_raw_ply(load_bytes(repo_path("samples/guitar.ply")));
    count = std::min<uint64_t>(raw.count, max_count);
  }
  double operator()(uint64_t i, const std::string& name) const {
    if (name.rfind("f_rest_", 0) == 0) {
      const int r = std::stoi(name.substr(7));
      const int c = r / 15, k = r % 15 + 1;
      const float factor = static_cast<float>((k * 37) % 17 - 8) / 32.0f;  // in [-0.25, 0.25]
      return static_cast<double>(raw.get(i, "f_dc_" + std::to_string(c)) * factor);
    }
    if (name == "red" || name == "green" || name == "blue") return static_cast<double>((i * 7 + name.size()) % 256);
    if (name == "flags") return static_cast<double>(static_cast<int64_t>(i % 1000) - 500);
    return static_cast<double>(raw.get(i, name));
  }
};

TEST_CASE("read_ply: an SH3 scene decodes identically from LE, BE, ascii, CRLF and mixed types in any order") {
  const Sh3FromGuitar src(3000);
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const auto reference_bytes = build_ply("binary_little_endian", inria_props(3), src.count, value);
  const PlyScene reference = read_ok(reference_bytes);
  REQUIRE(reference.cloud.sh_degree == 3);
  REQUIRE(reference.cloud.size() == src.count);

  // splat-transform order (x y z rot scale opacity f_dc f_rest), shuffled further, with extra uchar/short
  // properties and doubles for some needed values.
  std::vector<PropSpec> shuffled = {{"red", "uchar"}, {"x", "double"}, {"y", "float"}, {"z", "double"},
                                    {"rot_2", "float"}, {"rot_0", "double"}, {"rot_3", "float"}, {"rot_1", "float"},
                                    {"flags", "short"}, {"scale_1", "double"}, {"scale_0", "float"},
                                    {"scale_2", "float"}, {"opacity", "double"}, {"green", "uchar"}};
  for (int c = 2; c >= 0; --c) shuffled.push_back({"f_dc_" + std::to_string(c), c == 1 ? "double" : "float"});
  for (int r = 44; r >= 0; --r) shuffled.push_back({"f_rest_" + std::to_string(r), r % 3 == 0 ? "double" : "float"});
  shuffled.push_back({"blue", "uchar"});

  for (const char* storage : {"binary_little_endian", "binary_big_endian", "ascii"}) {
    CAPTURE(storage);
    const PlyScene inria = read_ok(build_ply(storage, inria_props(3), src.count, value));
    CHECK(same_cloud(inria.cloud, reference.cloud));
    CHECK(inria.storage_format == storage);
    const PlyScene mixed = read_ok(build_ply(storage, shuffled, src.count, value));
    CHECK(same_cloud(mixed.cloud, reference.cloud));
    const PlyScene crlf = read_ok(build_ply(storage, shuffled, src.count, value, "\r\n"));
    CHECK(same_cloud(crlf.cloud, reference.cloud));
  }
  // SH layout: coefficient k of channel c is f_rest[c·15 + k − 1].
  const auto& cloud = reference.cloud;
  CHECK(cloud.sh[(7 * 16 + 5) * 3 + 2] == static_cast<float>(src(7, "f_rest_" + std::to_string(2 * 15 + 4))));
  CHECK(cloud.sh[(7 * 16 + 0) * 3 + 1] == static_cast<float>(src(7, "f_dc_1")));
}

TEST_CASE("read_ply: read_ply streams a large file in chunks and equals read_ply_bytes") {
  // ~22 MB SH3 PLY (more than two 8 MB read chunks), written to a temporary file.
  const Sh3FromGuitar src(std::numeric_limits<uint64_t>::max());
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const auto bytes = build_ply("binary_little_endian", inria_props(3), src.count, value);
  const auto path = (std::filesystem::temp_directory_path() / "rgs_test_converter_sh3.ply").string();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  auto from_file = read_ply(path);
  std::filesystem::remove(path);
  REQUIRE_MESSAGE(from_file.ok(), from_file.status().to_string());
  CHECK(from_file->cloud.size() == 90854);
  CHECK(same_cloud(from_file->cloud, read_ok(bytes).cloud));
}

TEST_CASE("read_ply: ascii streaming across window boundaries equals binary") {
  // Ascii larger than the 1 MB tokenizer window, read from a file.
  const Sh3FromGuitar src(6000);
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const auto ascii = build_ply("ascii", inria_props(3), src.count, value);
  REQUIRE(ascii.size() > (size_t{1} << 21));
  const auto path = (std::filesystem::temp_directory_path() / "rgs_test_converter_ascii.ply").string();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(ascii.data()), static_cast<std::streamsize>(ascii.size()));
  }
  auto from_file = read_ply(path);
  std::filesystem::remove(path);
  REQUIRE_MESSAGE(from_file.ok(), from_file.status().to_string());
  CHECK(same_cloud(from_file->cloud, read_ok(build_ply("binary_little_endian", inria_props(3), src.count, value)).cloud));
}

TEST_CASE("read_ply: hash_file gives the same XXH64 from a file (chunked, in the read pass) as from memory") {
  // Binary with data after the vertex element (hashed after the chunks) and larger than one 1 MB chunk per
  // worker, plus ascii (hashed in a separate pass); the in-memory path hashes the whole buffer at once.
  const Sh3FromGuitar src(20000);
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const std::string face_header = "element face 1\nproperty list uchar int vertex_indices\n";
  const std::string faces("\x03\0\0\0\0\x01\0\0\0\x02\0\0\0", 13);
  for (const char* storage : {"binary_little_endian", "binary_big_endian", "ascii"}) {
    const auto bytes = build_ply(storage, inria_props(3), src.count, value, "\n",
                                 std::string(storage) == "ascii" ? std::string() : face_header,
                                 std::string(storage) == "ascii" ? std::string() : faces);
    const auto path = (std::filesystem::temp_directory_path() / "rgs_test_converter_hash.ply").string();
    {
      std::ofstream out(path, std::ios::binary);
      out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }
    PlyReadOptions options;
    options.hash_file = true;
    auto from_file = read_ply(path, options);
    std::filesystem::remove(path);
    REQUIRE_MESSAGE(from_file.ok(), from_file.status().to_string());
    auto from_memory = read_ply_bytes(bytes.data(), bytes.size(), "hash.ply", options);
    REQUIRE(from_memory.ok());
    INFO(storage);
    REQUIRE(from_file->file_xxh64.has_value());
    REQUIRE(from_memory->file_xxh64.has_value());
    CHECK(*from_file->file_xxh64 == *from_memory->file_xxh64);
    CHECK(same_cloud(from_file->cloud, from_memory->cloud));
    CHECK_FALSE(read_ok(bytes).file_xxh64.has_value());  // only on request
    // A one-byte change anywhere (here: the last byte) changes the hash.
    auto changed = bytes;
    changed.back() ^= 1;
    auto other = read_ply_bytes(changed.data(), changed.size(), "hash.ply", options);
    if (other.ok()) CHECK(*other->file_xxh64 != *from_memory->file_xxh64);
  }
}

TEST_CASE("read_ply: elements after vertex are ignored, empty ones before it are allowed") {
  const Sh3FromGuitar src(10);
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const PlyScene plain = read_ok(build_ply("binary_little_endian", inria_props(0), 10, value));
  const std::string face_header = "element face 2\nproperty list uchar int vertex_indices\n";
  const std::string faces("\x03\0\0\0\0\x01\0\0\0\x02\0\0\0\x03\0\0\0\0\x02\0\0\0\x03\0\0\0", 26);
  CHECK(same_cloud(read_ok(build_ply("binary_little_endian", inria_props(0), 10, value, "\n", face_header, faces)).cloud,
                   plain.cloud));
  CHECK(same_cloud(read_ok(build_ply("ascii", inria_props(0), 10, value, "\n", face_header, "3 0 1 2\n3 0 2 3\n")).cloud,
                   plain.cloud));
  // An element with count 0 before vertex carries no data.
  auto bytes = build_ply("binary_little_endian", inria_props(0), 10, value);
  const std::string text(bytes.begin(), bytes.end());
  const std::string with_empty = std::string(text).insert(text.find("element vertex"), "element material 0\nproperty uchar id\n");
  CHECK(same_cloud(read_ok(std::vector<uint8_t>(with_empty.begin(), with_empty.end())).cloud, plain.cloud));
  // Extra bytes after the vertex data are ignored too.
  bytes.insert(bytes.end(), 5, 0xff);
  CHECK(same_cloud(read_ok(bytes).cloud, plain.cloud));
}

TEST_CASE("read_ply: zero vertices give an empty cloud") {
  const auto bytes = build_ply("binary_little_endian", inria_props(1), 0, [](uint64_t, const std::string&) { return 0.0; });
  const PlyScene s = read_ok(bytes);
  CHECK(s.cloud.size() == 0);
  CHECK(s.cloud.sh_degree == 1);
  CHECK(s.cloud.is_consistent());
}

TEST_CASE("read_ply: header and layout errors carry the right code and a useful message") {
  const Sh3FromGuitar src(4);
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const auto good = build_ply("binary_little_endian", inria_props(0), 4, value);
  std::string text(good.begin(), good.end());
  auto with = [&text](const std::string& from, const std::string& to) {
    std::string t = text;
    const size_t at = t.find(from);
    REQUIRE(at != std::string::npos);
    return t.replace(at, from.size(), to);
  };
  struct Case {
    std::string name;
    std::string bytes;
    StatusCode code;
    std::string needle;
  };
  const std::vector<Case> cases = {
      {"empty file", "", StatusCode::kCorruptData, "not a PLY"},
      {"just ply", "ply\n", StatusCode::kCorruptData, "end_header"},
      {"second format", with("comment", "format ascii 1.0\ncomment"), StatusCode::kCorruptData, "second 'format'"},
      {"unknown storage", with("binary_little_endian", "binary_middle_endian"), StatusCode::kCorruptData,
       "binary_middle_endian"},
      {"version 2", with("binary_little_endian 1.0", "binary_little_endian 2.0"), StatusCode::kUnsupportedFeature,
       "version"},
      {"property before element", with("element vertex 4\n", "property float q\nelement vertex 4\n"),
       StatusCode::kCorruptData, "before any 'element'"},
      {"duplicate property", with("property float nz\n", "property float nz\nproperty float nx\n"),
       StatusCode::kCorruptData, "duplicate property 'nx'"},
      {"bad count", with("element vertex 4", "element vertex four"), StatusCode::kCorruptData, "'four'"},
      {"negative count", with("element vertex 4", "element vertex -4"), StatusCode::kCorruptData, "count"},
      {"unknown keyword", with("comment", "colour"), StatusCode::kCorruptData, "unknown keyword 'colour'"},
      {"no vertex", with("element vertex 4", "element points 4"), StatusCode::kCorruptData, "no 'vertex'"},
      {"two vertex elements", with("end_header", "element vertex 0\nend_header"), StatusCode::kCorruptData,
       "second 'vertex'"},
      {"missing opacity", with("property float opacity\n", ""), StatusCode::kUnsupportedFeature, "'opacity'"},
      {"gap in f_rest", with("property float opacity\n",
                             "property float f_rest_0\nproperty float f_rest_1\nproperty float f_rest_2\n"
                             "property float f_rest_3\nproperty float f_rest_4\nproperty float f_rest_5\n"
                             "property float f_rest_6\nproperty float f_rest_7\nproperty float f_rest_10\n"
                             "property float opacity\n"),
       StatusCode::kUnsupportedFeature, "f_rest_8"},
      {"f_rest with leading zero", with("property float opacity\n",
                                        "property float f_rest_0\nproperty float f_rest_1\nproperty float f_rest_2\n"
                                        "property float f_rest_3\nproperty float f_rest_4\nproperty float f_rest_5\n"
                                        "property float f_rest_6\nproperty float f_rest_7\nproperty float f_rest_08\n"
                                        "property float opacity\n"),
       StatusCode::kUnsupportedFeature, "f_rest_8"},
      {"limit", text, StatusCode::kLimitExceeded, "limit of 3"},
      {"one byte short", text.substr(0, text.size() - 1), StatusCode::kIoError, "need 272"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    PlyReadOptions options;
    if (c.name == "limit") options.max_gaussians = 3;
    const Status s = read_status(std::vector<uint8_t>(c.bytes.begin(), c.bytes.end()), options);
    CHECK(s.code() == c.code);
    CHECK_MESSAGE(s.message().find(c.needle) != std::string::npos, s.message());
    CHECK_MESSAGE(s.message().rfind("test.ply: ", 0) == 0, s.message());
  }
  CHECK(read_ok(std::vector<uint8_t>(text.begin(), text.end())).cloud.size() == 4);
}

TEST_CASE("read_ply: ascii tokens") {
  const Sh3FromGuitar src(3);
  auto value = [&src](uint64_t i, const std::string& n) { return src(i, n); };
  const auto good = build_ply("ascii", inria_props(0), 3, value);
  const std::string text(good.begin(), good.end());
  const size_t data = text.find("end_header\n") + 11;
  const size_t header_lines = static_cast<size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(data), '\n'));
  // Truncated ascii: file ends in vertex 2.
  {
    const std::string cut = text.substr(0, text.size() - 20);
    const Status s = read_status(cut);
    CHECK(s.code() == StatusCode::kIoError);
    CHECK_MESSAGE(s.message().find("vertex 2 of 3") != std::string::npos, s.message());
  }
  // A bad token names its line: vertex 1 is on line header_lines + 2.
  {
    std::string bad = text;
    const size_t line2 = bad.find('\n', data) + 1;
    bad.replace(line2, bad.find(' ', line2) - line2, "0x1p3");
    const Status s = read_status(bad);
    CHECK(s.code() == StatusCode::kCorruptData);
    CHECK_MESSAGE(s.message().find("line " + std::to_string(header_lines + 2) + ": bad value '0x1p3' for property 'x'") !=
                      std::string::npos,
                  s.message());
  }
  // '+' signs, inf/nan spellings and integers are accepted for floats; an int property refuses "1.5".
  {
    auto values = [](uint64_t, const std::string& n) { return n == "rot_0" ? 1.0 : 0.0; };
    const auto bytes = build_ply("ascii", inria_props(0), 1, values);
    const std::string head(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(data));
    const std::string ok_line = head + "+1.5 -2 3e0 0 0 0 0.25 -0.5 +0 Infinity -1 -1 -1 +1 0 0 0\n";
    const PlyScene scene = read_ok(std::vector<uint8_t>(ok_line.begin(), ok_line.end()));
    CHECK(scene.cloud.means[0] == 1.5f);
    CHECK(scene.cloud.means[1] == -2.0f);
    CHECK(scene.cloud.means[2] == 3.0f);
    CHECK(scene.cloud.opacities[0] == 1.0f);
    CHECK(scene.hygiene.infinite_opacity_logits == 1);
    CHECK(scene.hygiene.nonfinite_values == 0);

    const std::string bad_line = head + "1 2 3 0 0 0 0.25 -inf NaN -inf -1 -1 -1 1 0 0 0\n";
    const Status rejected = read_status(bad_line);
    CHECK(rejected.code() == StatusCode::kCorruptData);
    CHECK_MESSAGE(rejected.message().find("1 Gaussians have non-finite values (2 values)") != std::string::npos,
                  rejected.message());
    PlyReadOptions sanitize;
    sanitize.invalid_policy = InvalidPolicy::kSanitize;
    const auto sanitized =
        read_ply_bytes(reinterpret_cast<const uint8_t*>(bad_line.data()), bad_line.size(), "t.ply", sanitize);
    REQUIRE(sanitized.ok());
    CHECK(sanitized->cloud.size() == 0);
    CHECK(sanitized->hygiene.dropped_gaussians == 1);
    CHECK(sanitized->hygiene.infinite_opacity_logits == 1);

    auto props = inria_props(0);
    props.push_back({"count", "int"});
    const auto with_int = build_ply("ascii", props, 1, values);
    std::string u(with_int.begin(), with_int.end());
    CHECK(read_ok(with_int).cloud.size() == 1);
    u = u.substr(0, u.rfind(' ')) + " 1.5\n";
    CHECK(read_status(u).code() == StatusCode::kCorruptData);
  }
}

TEST_CASE("read_ply: input hygiene counts, rejects and sanitizes") {
  const Sh3FromGuitar src(40);
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto value = [&](uint64_t i, const std::string& n) -> double {
    if (i == 3 && n == "opacity") return inf;             // kept: sigmoid gives 1
    if (i == 4 && n == "opacity") return -inf;            // kept: sigmoid gives 0
    if (i == 5 && n == "opacity") return nan;             // non-finite
    if (i == 7 && n == "y") return nan;                   // non-finite mean
    if (i == 7 && n == "f_rest_3") return -inf;           // second non-finite value of the same Gaussian
    if (i == 9 && n.rfind("rot_", 0) == 0) return 0.0;    // zero-norm quaternion
    if (i == 11 && n.rfind("rot_", 0) == 0) return 1e-20;  // norm² 4e-40: subnormal in float32
    if (i == 13 && n == "scale_1") return -inf;           // scale exactly 0: valid
    if (i == 15 && n == "scale_2") return 100.0;          // exp overflows float32: non-finite scale
    if (i == 17 && n == "rot_2") return inf;              // non-finite rotation
    return src(i, n);
  };
  const auto bytes = build_ply("binary_little_endian", inria_props(1), 40, value);
  const Status rejected = read_status(bytes);
  CHECK(rejected.code() == StatusCode::kCorruptData);
  CHECK_MESSAGE(rejected.message() ==
                    "test.ply: 4 Gaussians have non-finite values (5 values) and 2 have zero-norm quaternions "
                    "(first: vertex 5); rerun with --sanitize to drop them",
                rejected.message());

  PlyReadOptions sanitize;
  sanitize.invalid_policy = InvalidPolicy::kSanitize;
  const PlyScene s = read_ok(bytes, sanitize);
  CHECK(s.hygiene.nonfinite_values == 5);
  CHECK(s.hygiene.gaussians_with_nonfinite == 4);
  CHECK(s.hygiene.zero_norm_quaternions == 2);
  CHECK(s.hygiene.infinite_opacity_logits == 2);
  CHECK(s.hygiene.dropped_gaussians == 6);
  CHECK(s.hygiene.first_invalid_index == 5);
  CHECK(s.declared_vertices == 40);
  REQUIRE(s.cloud.size() == 34);
  CHECK(s.cloud.is_consistent());
  // Survivors keep their order: file vertices 0..4, 6, 8, 10, 12, 13, 14, 16, 18, ...
  const PlyScene all = read_ok(build_ply("binary_little_endian", inria_props(1), 40,
                                         [&](uint64_t i, const std::string& n) { return src(i, n); }));
  const uint64_t kept[] = {0, 1, 2, 3, 4, 6, 8, 10, 12, 13, 14, 16, 18, 19, 39};
  const uint64_t at[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 33};
  for (size_t j = 0; j < std::size(kept); ++j) {
    CAPTURE(kept[j]);
    CHECK(s.cloud.means[at[j] * 3] == all.cloud.means[kept[j] * 3]);
    CHECK(s.cloud.sh[at[j] * 12 + 11] == all.cloud.sh[kept[j] * 12 + 11]);
  }
  CHECK(s.cloud.opacities[3] == 1.0f);
  CHECK(s.cloud.opacities[4] == 0.0f);
  CHECK(s.cloud.scales[9 * 3 + 1] == 0.0f);  // file vertex 13
  // A sanitized cloud quantizes.
  CHECK(converter::quantize(s.cloud, {}).ok());
}

TEST_CASE("read_ply: missing file, directory") {
  const auto missing = read_ply("/nonexistent_dir/nope.ply");
  CHECK(missing.status().code() == StatusCode::kIoError);
  CHECK_MESSAGE(missing.status().message().find("nope.ply: ") != std::string::npos, missing.status().message());
  CHECK(missing.status().message().find("no such file") != std::string::npos);
  const auto dir = read_ply(repo_path("samples"));
  CHECK(dir.status().code() == StatusCode::kIoError);
  CHECK(dir.status().message().find("directory") != std::string::npos);
}

TEST_CASE("timing: read + quantize of the 88 MB daffodils scene (printed, not asserted)") {
  const std::string path = shared_scene("playcanvas_flowers_lod0.ply");
  if (path.empty()) return;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto r = read_ply(path);
  const auto t1 = Clock::now();
  REQUIRE(r.ok());
  auto e = converter::quantize(r->cloud, {});
  const auto t2 = Clock::now();
  REQUIRE(e.ok());
  const double read_s = std::chrono::duration<double>(t1 - t0).count();
  const double quant_s = std::chrono::duration<double>(t2 - t1).count();
  const double mb = static_cast<double>(r->file_bytes) / 1e6;
  MESSAGE("daffodils " << mb << " MB: read " << read_s << " s (" << mb / read_s << " MB/s), quantize " << quant_s
                       << " s, total " << mb / (read_s + quant_s) << " MB/s");
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

/// Every batch of a PlyStream pass, appended into one cloud.
format::GaussianCloud stream_all(converter::PlyStream& stream, uint64_t batch) {
  format::GaussianCloud all, part;
  for (;;) {
    auto consumed = stream.read(batch, &part);
    REQUIRE_MESSAGE(consumed.ok(), consumed.status().to_string());
    if (*consumed == 0) break;
    all.sh_degree = part.sh_degree;
    all.means.insert(all.means.end(), part.means.begin(), part.means.end());
    all.rotations.insert(all.rotations.end(), part.rotations.begin(), part.rotations.end());
    all.scales.insert(all.scales.end(), part.scales.begin(), part.scales.end());
    all.opacities.insert(all.opacities.end(), part.opacities.begin(), part.opacities.end());
    all.sh.insert(all.sh.end(), part.sh.begin(), part.sh.end());
  }
  return all;
}

TEST_CASE("PlyStream: batches in every pass are read_ply's cloud, the first pass hashes the file") {
  const std::string path = repo_path(kGuitarSh3);
  PlyReadOptions options;
  options.hash_file = true;
  auto whole = read_ply(path, options);
  REQUIRE_MESSAGE(whole.ok(), whole.status().to_string());
  auto stream = converter::PlyStream::open(path, options);
  REQUIRE_MESSAGE(stream.ok(), stream.status().to_string());
  CHECK((*stream)->vertex_count() == whole->declared_vertices);
  CHECK((*stream)->sh_degree() == whole->cloud.sh_degree);
  CHECK((*stream)->storage_format() == whole->storage_format);
  CHECK(same_cloud(stream_all(**stream, 1000), whole->cloud));
  REQUIRE((*stream)->file_xxh64().has_value());
  CHECK(*(*stream)->file_xxh64() == *whole->file_xxh64);
  REQUIRE((*stream)->rewind().ok());
  CHECK(same_cloud(stream_all(**stream, 333), whole->cloud));  // a second pass, other batch sizes
}

TEST_CASE("PlyStream: invalid Gaussians fail the batch that holds them, or are dropped and counted") {
  const Sh3FromGuitar src(40);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto bytes = build_ply("binary_little_endian", inria_props(1), 40, [&](uint64_t i, const std::string& n) {
    if (i == 25 && n == "opacity") return double(nan);
    if (i == 31 && n.rfind("rot_", 0) == 0) return 0.0;
    return src(i, n);
  });
  const auto path = (std::filesystem::temp_directory_path() / "rgs_test_converter_stream_hygiene.ply").string();
  write_file(path, bytes);
  format::GaussianCloud batch;
  auto rejecting = converter::PlyStream::open(path);
  REQUIRE(rejecting.ok());
  auto first = (*rejecting)->read(20, &batch);
  REQUIRE(first.ok());
  CHECK(batch.size() == 20);
  auto failed = (*rejecting)->read(20, &batch);
  REQUIRE(!failed.ok());
  CHECK(failed.status().code() == StatusCode::kCorruptData);
  CHECK(failed.status().message().find("vertex 25 has non-finite values or a zero-norm quaternion") !=
        std::string::npos);

  PlyReadOptions sanitize;
  sanitize.invalid_policy = InvalidPolicy::kSanitize;
  auto sanitizing = converter::PlyStream::open(path, sanitize);
  REQUIRE(sanitizing.ok());
  const format::GaussianCloud kept = stream_all(**sanitizing, 16);
  CHECK(kept.size() == 38);
  CHECK((*sanitizing)->hygiene().dropped_gaussians == 2);
  CHECK((*sanitizing)->hygiene().first_invalid_index == 25);
  CHECK(same_cloud(kept, read_ok(bytes, sanitize).cloud));

  const auto ascii = (std::filesystem::temp_directory_path() / "rgs_test_converter_stream_ascii.ply").string();
  write_file(ascii, build_ply("ascii", inria_props(0), 2, [&](uint64_t i, const std::string& n) { return src(i, n); }));
  CHECK(converter::PlyStream::open(ascii).status().code() == StatusCode::kUnsupportedFeature);
  std::filesystem::remove(path);
  std::filesystem::remove(ascii);
}

TEST_CASE("PlyStream: a file that changes between or during its passes fails the pass that sees it, naming it") {
  const Sh3FromGuitar src(3000);
  auto value = [&](uint64_t i, const std::string& n) { return src(i, n); };
  const auto bytes = build_ply("binary_little_endian", inria_props(0), src.count, value);
  auto other = build_ply("binary_little_endian", inria_props(0), src.count, [&](uint64_t i, const std::string& n) {
    return n == "f_dc_0" ? src(i, n) + 0.25 : src(i, n);  // the same size, other colours
  });
  REQUIRE(other.size() == bytes.size());
  const auto path = (std::filesystem::temp_directory_path() / "rgs_test_converter_stream_changes.ply").string();
  const std::string changed = path + ": the file changed during the passes of the out-of-core build (";
  format::GaussianCloud batch;
  struct Change {
    const char* what;
    std::function<void()> apply;
    const char* why;
  };
  const std::string size = "size " + std::to_string(bytes.size()) + " → ";
  const std::string shorter = size + std::to_string(bytes.size() - 100) + " bytes";
  const std::string longer = size + std::to_string(bytes.size() + 1) + " bytes";
  const Change changes[] = {
      {"cut short", [&] { std::filesystem::resize_file(path, bytes.size() - 100); }, shorter.c_str()},
      {"grown", [&] { std::filesystem::resize_file(path, bytes.size() + 1); }, longer.c_str()},
      {"other bytes, the same size and time",
       [&] {
         const auto time = std::filesystem::last_write_time(path);
         write_file(path, other);
         std::filesystem::last_write_time(path, time);
       },
       "other bytes of the same size and time: XXH64 "},
      {"another file renamed over it",
       [&] {
         write_file(path + ".new", bytes);
         std::filesystem::rename(path + ".new", path);
       },
       "another file was put in its place: inode "},
      {"removed", [&] { std::filesystem::remove(path); }, "it can no longer be found: "},
  };
  for (const Change& change : changes) {
    for (const bool within_pass : {false, true}) {
      CAPTURE(std::string(change.what));
      CAPTURE(within_pass);
      write_file(path, bytes);
      auto stream = converter::PlyStream::open(path);
      REQUIRE(stream.ok());
      REQUIRE((*stream)->read(src.count, &batch).ok());  // the first pass, whole
      Status failed;
      if (within_pass) {
        REQUIRE((*stream)->rewind().ok());
        REQUIRE((*stream)->read(1000, &batch).ok());
        change.apply();
        auto rest = (*stream)->read(src.count, &batch);  // the read that ends the pass checks it
        failed = rest.status();
      } else {
        change.apply();
        failed = (*stream)->rewind();
        // Bytes of the same size and time are found by the hash of the pass they change, at its end.
        if (failed.ok()) failed = (*stream)->read(src.count, &batch).status();
      }
      REQUIRE(!failed.ok());
      CHECK(failed.code() == StatusCode::kIoError);
      CHECK_MESSAGE(failed.message().rfind(changed, 0) == 0, failed.message());
      CHECK_MESSAGE(failed.message().find(change.why) != std::string::npos, failed.message());
      // What the file's metadata tells without reading it; the same size and time take the hash of a pass.
      const bool same_metadata = std::string(change.what) == "other bytes, the same size and time";
      CHECK((*stream)->check_unchanged().ok() == same_metadata);
    }
  }
  // Unchanged, every pass ends well and check_unchanged() agrees.
  write_file(path, bytes);
  auto stream = converter::PlyStream::open(path);
  REQUIRE(stream.ok());
  for (int pass = 0; pass < 3; ++pass) {
    if (pass > 0) REQUIRE((*stream)->rewind().ok());
    CHECK(stream_all(**stream, 700).size() == src.count);
  }
  CHECK((*stream)->check_unchanged().ok());
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace rgs::test
