// GLB writer for KHR_gaussian_splatting: one float accessor per attribute, one buffer in the BIN chunk.
#include "rgs/converter/gltf.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "../internal_gltf.h"
#include "../internal_interop.h"
#include "rgs/format/file_io.h"
#include "rgs/format/metadata.h"

namespace rgs::converter {

namespace {

// ordered_json keeps "asset" first, where content sniffers look for it.
using json = nlohmann::ordered_json;

uint64_t align4(uint64_t n) { return (n + 3) & ~uint64_t{3}; }

/// One accessor's data, already little-endian.
struct Segment {
  std::string semantic;
  std::vector<uint8_t> data;
  int component_type = detail::kGltfFloat;
  const char* type = "VEC3";
  bool normalized = false;
  uint64_t count = 0;
  json min, max;
};

/// A float accessor of `count` elements of `width` values each, value a of element i being get(i, a).
template <typename Get>
Segment float_segment(std::string semantic, const char* type, uint64_t count, int width, Get&& get) {
  Segment s;
  s.semantic = std::move(semantic);
  s.type = type;
  s.count = count;
  s.data.resize(static_cast<size_t>(count * width * 4));
  for (uint64_t i = 0; i < count; ++i) {
    for (int a = 0; a < width; ++a) format::store_f32_le(s.data.data() + (i * width + a) * 4, get(i, a));
  }
  return s;
}

/// sRGB transfer function decoded to linear (IEC 61966-2-1).
double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

/// One segment per attribute of `cloud` (already in the file's frame), in accessor order: POSITION (with the
/// min and max glTF requires), COLOR_0 when asked (linear RGB of the SH DC colour, opacity as alpha), the
/// extension's ROTATION, SCALE, OPACITY and SH coefficients.
std::vector<Segment> attribute_segments(const format::GaussianCloud& cloud, bool color_fallback) {
  const uint64_t n = cloud.size();
  const uint32_t k_count = cloud.sh_coefficients();
  std::vector<Segment> segs;
  segs.push_back(float_segment("POSITION", "VEC3", n, 3, [&](uint64_t i, int a) { return cloud.means[i * 3 + a]; }));
  if (n > 0) {
    float lo[3], hi[3];
    format::box_of_means(cloud.means.data(), n, lo, hi);
    segs.back().min = json::array({lo[0], lo[1], lo[2]});
    segs.back().max = json::array({hi[0], hi[1], hi[2]});
  }
  if (color_fallback) {
    Segment s;
    s.semantic = "COLOR_0";
    s.type = "VEC4";
    s.component_type = detail::kGltfUnsignedByte;
    s.normalized = true;
    s.count = n;
    s.data.resize(static_cast<size_t>(n * 4));
    for (uint64_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        const double srgb = std::clamp(0.5 + detail::kShC0 * cloud.sh[i * k_count * 3 + c], 0.0, 1.0);
        s.data[i * 4 + c] = static_cast<uint8_t>(std::lround(srgb_to_linear(srgb) * 255.0));
      }
      s.data[i * 4 + 3] = static_cast<uint8_t>(std::lround(std::clamp<double>(cloud.opacities[i], 0.0, 1.0) * 255.0));
    }
    segs.push_back(std::move(s));
  }
  // (w, x, y, z) → glTF's (x, y, z, w)
  segs.push_back(float_segment("KHR_gaussian_splatting:ROTATION", "VEC4", n, 4,
                               [&](uint64_t i, int a) { return cloud.rotations[i * 4 + (a + 1) % 4]; }));
  segs.push_back(float_segment("KHR_gaussian_splatting:SCALE", "VEC3", n, 3,
                               [&](uint64_t i, int a) { return cloud.scales[i * 3 + a]; }));
  segs.push_back(float_segment("KHR_gaussian_splatting:OPACITY", "SCALAR", n, 1,
                               [&](uint64_t i, int) { return cloud.opacities[i]; }));
  uint32_t k = 0;
  for (uint32_t l = 0; l <= cloud.sh_degree; ++l) {
    for (int m = 0; m < detail::kGltfShCoefs[l]; ++m, ++k) {
      segs.push_back(float_segment(
          "KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(l) + "_COEF_" + std::to_string(m), "VEC3", n, 3,
          [&](uint64_t i, int c) { return cloud.sh[(i * k_count + k) * 3 + c]; }));
    }
  }
  return segs;
}

/// The glTF JSON of one splat primitive whose accessors are `segs`, each in a buffer view of its own, laid
/// out one after the other (4-byte aligned) in buffer 0; `*bin_bytes`: that buffer's length. Padded with
/// spaces to a multiple of 4 bytes, as the GLB JSON chunk is.
std::string gltf_json(const std::vector<Segment>& segs, const std::string& generator, uint64_t* bin_bytes) {
  json buffer_views = json::array(), accessors = json::array(), attributes = json::object();
  *bin_bytes = 0;
  for (size_t v = 0; v < segs.size(); ++v) {
    const Segment& s = segs[v];
    buffer_views.push_back({{"buffer", 0},
                            {"byteOffset", *bin_bytes},
                            {"byteLength", s.data.size()},
                            {"target", detail::kGltfArrayBuffer}});
    json acc = {{"bufferView", v}, {"componentType", s.component_type}, {"count", s.count}, {"type", s.type}};
    if (s.normalized) acc["normalized"] = true;
    if (!s.min.is_null()) {
      acc["min"] = s.min;
      acc["max"] = s.max;
    }
    accessors.push_back(std::move(acc));
    attributes[s.semantic] = v;
    *bin_bytes += align4(s.data.size());
  }
  json ext = {{"kernel", "ellipse"},
              {"colorSpace", "srgb_rec709_display"},
              {"projection", "perspective"},
              {"sortingMethod", "cameraDistance"}};
  json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", generator}}},
      {"extensionsUsed", json::array({detail::kKhrGaussianSplatting})},
      {"scene", 0},
      {"scenes", json::array({{{"nodes", json::array({0})}}})},
      {"nodes", json::array({{{"mesh", 0}}})},
      {"meshes",
       json::array({{{"primitives", json::array({{{"attributes", attributes},
                                                  {"mode", 0},
                                                  {"extensions", {{detail::kKhrGaussianSplatting, ext}}}}})}}})},
      {"buffers", json::array({{{"byteLength", *bin_bytes}}})},
      {"bufferViews", buffer_views},
      {"accessors", accessors},
  };
  std::string text = gltf.dump();
  while (text.size() % 4 != 0) text += ' ';  // the JSON chunk is padded with spaces
  return text;
}

/// The GLB file: header, JSON chunk `text` (padded), BIN chunk of `bin_bytes` holding `segs`.
Result<std::vector<uint8_t>> assemble_glb(const std::string& text, const std::vector<Segment>& segs,
                                          uint64_t bin_bytes) {
  const uint64_t total = detail::kGlbHeaderBytes + 8 + text.size() + 8 + bin_bytes;
  if (total > UINT32_MAX) {
    return Status(StatusCode::kInvalidArgument, "GLB of " + std::to_string(total) + " bytes exceeds the 4 GiB the "
                                                "format's 32-bit length field allows");
  }
  std::vector<uint8_t> bytes(static_cast<size_t>(total), 0);
  uint8_t* p = bytes.data();
  format::store_u32_le(p, detail::kGlbMagic);
  format::store_u32_le(p + 4, 2);
  format::store_u32_le(p + 8, static_cast<uint32_t>(total));
  format::store_u32_le(p + 12, static_cast<uint32_t>(text.size()));
  format::store_u32_le(p + 16, detail::kGlbChunkJson);
  std::memcpy(p + 20, text.data(), text.size());
  uint8_t* bin = p + 20 + text.size();
  format::store_u32_le(bin, static_cast<uint32_t>(bin_bytes));
  format::store_u32_le(bin + 4, detail::kGlbChunkBin);
  uint64_t at = 8;
  for (const Segment& s : segs) {
    if (!s.data.empty()) std::memcpy(bin + at, s.data.data(), s.data.size());
    at += align4(s.data.size());  // padding stays zero
  }
  return bytes;
}

Result<std::vector<uint8_t>> serialize(const format::GaussianCloud& cloud, const GltfWriteOptions& o,
                                       GltfWriteSummary* summary) {
  RGS_RETURN_IF_ERROR(detail::check_writable_cloud(cloud));
  const uint64_t n = cloud.size();
  if (n > UINT32_MAX) {
    return Status(StatusCode::kInvalidArgument, std::to_string(n) + " Gaussians exceed a glTF accessor's count");
  }
  detail::AxisFlip flip;
  if (o.convert_frame) detail::flip_to_rdf("LUF", &flip);  // LUF ↔ RDF is one self-inverse 180° turn about z
  format::GaussianCloud out = cloud;
  detail::apply_axis_flip(flip, &out);
  const std::vector<Segment> segs = attribute_segments(out, o.color_fallback);
  uint64_t bin_bytes = 0;
  const std::string text = gltf_json(segs, o.generator, &bin_bytes);
  RGS_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, assemble_glb(text, segs, bin_bytes));
  *summary = GltfWriteSummary{};
  summary->sh_degree = cloud.sh_degree;
  summary->gaussians = n;
  summary->bytes = bytes.size();
  summary->limitations.push_back("all attributes stored as float32: nothing is quantized");
  summary->limitations.push_back(o.convert_frame
                                     ? "frame: converted to glTF's y-up axes (x and y negated)"
                                     : "frame: stored unconverted (RDF, y down), which glTF viewers show upside down");
  summary->limitations.push_back("colorSpace declared srgb_rec709_display, as 3DGS training assumes");
  return bytes;
}

}  // namespace

Result<std::vector<uint8_t>> serialize_glb(const format::GaussianCloud& cloud, const GltfWriteOptions& options,
                                           GltfWriteSummary* summary) {
  return detail::serialize_guarded("encoding GLB", summary, [&](auto* s) { return serialize(cloud, options, s); });
}

Result<GltfWriteSummary> write_glb(const std::string& path, const format::GaussianCloud& cloud,
                                   const GltfWriteOptions& options, format::FileSink& files) {
  return detail::write_serialized<GltfWriteSummary>(path, "encoding GLB", files,
                                                    [&](auto* s) { return serialize(cloud, options, s); });
}

}  // namespace rgs::converter
