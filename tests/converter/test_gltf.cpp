// KHR_gaussian_splatting glTF: GLB round trip (bit exact), the GLB splat-transform wrote, a .gltf with a
// data: URI and a node transform, and inputs that must fail.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "interop_test_util.h"
#include "ply_test_util.h"
#include "rgs/converter/gltf.h"
#include "rgs/converter/ply_reader.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::InteropReadOptions;
using nlohmann::json;

std::vector<uint8_t> to_glb(const format::GaussianCloud& c, const converter::GltfWriteOptions& o = {}) {
  auto r = converter::serialize_glb(c, o);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

StatusCode read_code(const std::vector<uint8_t>& b) {
  auto r = converter::read_gltf_bytes(b.data(), b.size(), "test.glb");
  if (!r.ok()) MESSAGE(r.status().to_string());
  return r.status().code();
}

/// The JSON and BIN chunks of a GLB we wrote.
void split_glb(const std::vector<uint8_t>& glb, json* doc, std::vector<uint8_t>* bin) {
  uint32_t json_len;
  std::memcpy(&json_len, glb.data() + 12, 4);
  *doc = json::parse(glb.begin() + 20, glb.begin() + 20 + json_len);
  bin->assign(glb.begin() + 20 + json_len + 8, glb.end());
}

std::vector<uint8_t> join_glb(const json& doc, const std::vector<uint8_t>& bin) {
  std::string text = doc.dump();
  while (text.size() % 4) text += ' ';
  std::vector<uint8_t> out(12 + 8 + text.size() + 8 + bin.size());
  auto put = [&](size_t at, uint32_t v) { std::memcpy(out.data() + at, &v, 4); };
  put(0, 0x46546C67u);
  put(4, 2);
  put(8, static_cast<uint32_t>(out.size()));
  put(12, static_cast<uint32_t>(text.size()));
  put(16, 0x4E4F534Au);
  std::memcpy(out.data() + 20, text.data(), text.size());
  put(20 + text.size(), static_cast<uint32_t>(bin.size()));
  put(24 + text.size(), 0x004E4942u);
  std::memcpy(out.data() + 28 + text.size(), bin.data(), bin.size());
  return out;
}

std::string base64(const std::vector<uint8_t>& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < in.size(); i += 3) {
    uint32_t v = in[i] << 16;
    if (i + 1 < in.size()) v |= in[i + 1] << 8;
    if (i + 2 < in.size()) v |= in[i + 2];
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < in.size() ? k[v & 63] : '=';
  }
  return out;
}

TEST_CASE("gltf: GLB round trip is exact for SH degrees 0-3, frame conversion") {
  for (uint32_t degree = 0; degree <= 3; ++degree) {
    CAPTURE(degree);
    const format::GaussianCloud in = make_interop_cloud(300, degree);
    converter::GltfWriteSummary summary;
    auto bytes = converter::serialize_glb(in, {}, &summary);
    REQUIRE(bytes.ok());
    CHECK(summary.bytes == bytes->size());
    CHECK(summary.sh_degree == degree);
    CHECK(converter::looks_like_gltf(bytes->data(), 64));
    auto r = converter::read_gltf_bytes(bytes->data(), bytes->size(), "test.glb");
    REQUIRE_MESSAGE(r.ok(), r.status().to_string());
    CHECK(r->format == "glb");
    CHECK(r->cloud.means == in.means);
    CHECK(r->cloud.scales == in.scales);
    CHECK(r->cloud.opacities == in.opacities);
    CHECK(r->cloud.sh == in.sh);
    CHECK(diff_clouds(in, r->cloud).rotation_deg < 1e-3);
    CHECK(to_glb(in) == *bytes);  // deterministic
    // Stored axes are glTF's: x and y negated, z kept; SH degree-1 coefficient k = 2 (z) keeps its sign,
    // k = 1 (y) and k = 3 (x) flip.
    InteropReadOptions raw;
    raw.convert_frame = false;
    auto stored = converter::read_gltf_bytes(bytes->data(), bytes->size(), "test.glb", raw);
    REQUIRE(stored.ok());
    CHECK(stored->cloud.means[0] == -in.means[0]);
    CHECK(stored->cloud.means[1] == -in.means[1]);
    CHECK(stored->cloud.means[2] == in.means[2]);
    if (degree >= 1) {
      const uint32_t k = in.sh_coefficients();
      CHECK(stored->cloud.sh[(0 * k + 1) * 3] == -in.sh[(0 * k + 1) * 3]);
      CHECK(stored->cloud.sh[(0 * k + 2) * 3] == in.sh[(0 * k + 2) * 3]);
      CHECK(stored->cloud.sh[(0 * k + 3) * 3] == -in.sh[(0 * k + 3) * 3]);
    }
  }
}

TEST_CASE("gltf: the GLB splat-transform 3.7.0 wrote from guitar_256.ply") {
  auto ply = converter::read_ply(repo_path("tests/data/interop/guitar_256.ply"));
  REQUIRE(ply.ok());
  auto r = converter::read_gltf(repo_path("tests/data/interop/guitar_256_splat_transform.glb"));
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  const CloudDiff d = diff_clouds(ply->cloud, r->cloud);
  MESSAGE("splat-transform GLB vs PLY: " << describe(d));
  CHECK(d.position == 0);
  CHECK(d.log_scale <= 1e-6);
  CHECK(d.opacity <= 1e-6);
  CHECK(d.dc == 0);
  // splat-transform turns rotations by left-multiplying the frame's quaternion, we conjugate: the
  // quaternions then differ by a 180° turn about a scale axis, which leaves every covariance unchanged.
  CHECK(max_covariance_error(ply->cloud, r->cloud) <= 1e-5);
}

TEST_CASE("gltf: .gltf with a data: URI, interleaved accessors untouched, node translation and uniform scale") {
  const format::GaussianCloud in = make_interop_cloud(20, 0);
  json doc;
  std::vector<uint8_t> bin;
  split_glb(to_glb(in), &doc, &bin);
  doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
  doc["nodes"][0]["translation"] = {1.0, 2.0, 3.0};
  doc["nodes"][0]["scale"] = {2.0, 2.0, 2.0};
  const std::string text = doc.dump();
  CHECK(converter::looks_like_gltf(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
  auto r = converter::read_gltf_bytes(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "t.gltf");
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  CHECK(r->format == "gltf");
  // In glTF axes the node maps p to 2p + t; back in RDF that is 2p + (−1, −2, 3).
  CHECK(std::fabs(r->cloud.means[0] - (2 * in.means[0] - 1)) < 1e-4);
  CHECK(std::fabs(r->cloud.means[1] - (2 * in.means[1] - 2)) < 1e-4);
  CHECK(std::fabs(r->cloud.means[2] - (2 * in.means[2] + 3)) < 1e-4);
  CHECK(std::fabs(r->cloud.scales[0] - 2 * in.scales[0]) < 1e-5);
  // A non-uniform scale cannot be carried by the cloud.
  doc["nodes"][0]["scale"] = {1.0, 2.0, 1.0};
  const std::string t2 = doc.dump();
  auto bad = converter::read_gltf_bytes(reinterpret_cast<const uint8_t*>(t2.data()), t2.size(), "t.gltf");
  CHECK(bad.status().code() == StatusCode::kUnsupportedFeature);
}

TEST_CASE("gltf: inputs that must fail") {
  const format::GaussianCloud in = make_interop_cloud(30, 1);
  const std::vector<uint8_t> glb = to_glb(in);
  json doc;
  std::vector<uint8_t> bin;
  split_glb(glb, &doc, &bin);
  auto with = [&](const std::function<void(json&)>& edit) {
    json d = doc;
    edit(d);
    return join_glb(d, bin);
  };
  CHECK(read_code(join_glb(doc, bin)) == StatusCode::kOk);
  CHECK(read_code(std::vector<uint8_t>(glb.begin(), glb.begin() + glb.size() / 2)) == StatusCode::kIoError);
  std::vector<uint8_t> v1 = glb;
  v1[4] = 1;
  CHECK(read_code(v1) == StatusCode::kUnsupportedVersion);
  CHECK(read_code(with([](json& d) { d["asset"]["version"] = "3.0"; })) == StatusCode::kUnsupportedVersion);
  CHECK(read_code(with([](json& d) { d["extensionsRequired"] = {"KHR_draco_mesh_compression"}; })) ==
        StatusCode::kUnsupportedFeature);
  CHECK(read_code(with([](json& d) {
          d["meshes"][0]["primitives"][0]["extensions"]["KHR_gaussian_splatting"]["kernel"] = "customShape";
        })) == StatusCode::kUnsupportedFeature);
  CHECK(read_code(with([](json& d) { d["meshes"][0]["primitives"][0]["extensions"] = json::object(); })) ==
        StatusCode::kUnsupportedFeature);
  CHECK(read_code(with([](json& d) { d["meshes"][0]["primitives"][0]["mode"] = 4; })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["accessors"][0]["count"] = 1u << 30; })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["accessors"][2]["count"] = 29; })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["bufferViews"][0]["byteOffset"] = 1u << 31; })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["accessors"][2]["componentType"] = 5121; })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["accessors"][4]["sparse"] = json::object(); })) ==
        StatusCode::kUnsupportedFeature);
  CHECK(read_code(with([](json& d) {
          d["meshes"][0]["primitives"][0]["attributes"].erase("KHR_gaussian_splatting:SH_DEGREE_1_COEF_2");
        })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["buffers"][0]["byteLength"] = 1u << 30; })) == StatusCode::kCorruptData);
  CHECK(read_code(with([](json& d) { d["buffers"][0]["uri"] = "other.bin"; })) == StatusCode::kUnsupportedFeature);
  std::vector<uint8_t> not_json = {'{', 'x'};
  CHECK(read_code(not_json) == StatusCode::kCorruptData);
  InteropReadOptions small;
  small.max_gaussians = 29;
  CHECK(converter::read_gltf_bytes(glb.data(), glb.size(), "t.glb", small).status().code() ==
        StatusCode::kLimitExceeded);
  // Opacity outside [0, 1] is invalid in the extension.
  std::vector<uint8_t> op = glb;
  const uint64_t opacity_view = doc["bufferViews"][doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]
                                                                       ["KHR_gaussian_splatting:OPACITY"].get<int>()]
                                                       ["bufferView"].get<int>()]["byteOffset"];
  const float two = 2.0f;
  const size_t bin_start = glb.size() - bin.size();
  std::memcpy(op.data() + bin_start + opacity_view, &two, 4);
  CHECK(read_code(op) == StatusCode::kCorruptData);
}

}  // namespace
}  // namespace rgs::test
