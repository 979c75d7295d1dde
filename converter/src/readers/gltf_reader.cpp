// glTF reader for KHR_gaussian_splatting: GLB container or .gltf JSON, bounds-checked accessors, node
// transforms, frame conversion from glTF's y-up axes.
#include "rgs/converter/gltf.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "../internal_gltf.h"
#include "../internal_input_file.h"
#include "../internal_json.h"
#include "../internal_interop.h"

namespace rgs::converter {

namespace {

using nlohmann::json;

/// Most splat primitives a file may draw (a mesh drawn by several nodes counts once per node): real files
/// draw a handful; the bound keeps the per-primitive state small before any accessor is checked.
constexpr size_t kMaxSplatPrimitives = 4096;

/// Deepest node hierarchy followed (cycles are errors anyway; this bounds the recursion).
constexpr int kMaxNodeDepth = 64;

Status corrupt(const std::string& msg) { return Status(StatusCode::kCorruptData, msg); }

/// obj[key], or null when absent (const operator[] of a missing key is undefined behaviour).
const json& member(const json& obj, const char* key) {
  static const json kNull;
  if (!obj.is_object()) return kNull;
  auto it = obj.find(key);
  return it == obj.end() ? kNull : *it;
}

/// A non-negative integer member, or `fallback` when absent.
Status get_index(const json& obj, const char* key, uint64_t* out, bool required, const std::string& where,
                 uint64_t fallback = 0) {
  auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) return corrupt(where + " has no '" + key + "'");
    *out = fallback;
    return Status();
  }
  if (!it->is_number_unsigned() && !(it->is_number_integer() && it->get<int64_t>() >= 0)) {
    return corrupt(where + " '" + key + "' is not a non-negative integer");
  }
  *out = it->get<uint64_t>();
  return Status();
}

/// True for a primitive object whose extensions object names KHR_gaussian_splatting.
bool is_splat_primitive(const json& p) {
  const json& ext = member(p, "extensions");
  return ext.is_object() && ext.contains(detail::kKhrGaussianSplatting);
}

struct Accessor {
  const uint8_t* base = nullptr;  ///< null: no bufferView, every value is 0
  uint64_t stride = 0;
  uint64_t count = 0;
  int component_type = detail::kGltfFloat;
  int components = 0;
  bool normalized = false;

  float get(uint64_t i, int c) const {
    if (base == nullptr) return 0.0f;
    const uint8_t* p = base + i * stride;
    switch (component_type) {
      case detail::kGltfFloat: return format::load_f32_le(p + 4 * c);
      case detail::kGltfByte: {
        const float v = static_cast<int8_t>(p[c]);
        return normalized ? std::max(v / 127.0f, -1.0f) : v;
      }
      case detail::kGltfUnsignedByte: return normalized ? p[c] / 255.0f : static_cast<float>(p[c]);
      case detail::kGltfShort: {
        const float v = static_cast<int16_t>(format::load_u16_le(p + 2 * c));
        return normalized ? std::max(v / 32767.0f, -1.0f) : v;
      }
      case detail::kGltfUnsignedShort: {
        const float v = format::load_u16_le(p + 2 * c);
        return normalized ? v / 65535.0f : v;
      }
      default: return static_cast<float>(format::load_u32_le(p + 4 * c));
    }
  }
};

int component_bytes(int type) {
  switch (type) {
    case detail::kGltfByte:
    case detail::kGltfUnsignedByte: return 1;
    case detail::kGltfShort:
    case detail::kGltfUnsignedShort: return 2;
    case detail::kGltfUnsignedInt:
    case detail::kGltfFloat: return 4;
    default: return 0;
  }
}

/// Accepted (componentType, normalized) pairs of one attribute besides float (never normalized, always
/// accepted): one type_bit each for the four integer types.
using Allowed = uint32_t;
constexpr Allowed type_bit(int type, bool normalized) {
  return 1u << ((type - detail::kGltfByte) * 2 + (normalized ? 1 : 0));
}
bool allowed_type(Allowed allowed, int type, bool normalized) {
  if (type == detail::kGltfFloat) return !normalized;
  return type >= detail::kGltfByte && type <= detail::kGltfUnsignedShort && (allowed & type_bit(type, normalized));
}

std::string base64_error(const std::string& where) { return where + " has a malformed base64 data URI"; }

bool base64_decode(const std::string& in, size_t start, std::vector<uint8_t>* out) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+' || c == '-') return 62;
    if (c == '/' || c == '_') return 63;
    return -1;
  };
  uint32_t acc = 0;
  int bits = 0;
  for (size_t i = start; i < in.size(); ++i) {
    const char c = in[i];
    if (c == '=') break;
    const int v = value(c);
    if (v < 0) return false;
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out->push_back(static_cast<uint8_t>(acc >> bits));
    }
  }
  return true;
}

/// The accessors of one splat primitive (SH: one per coefficient k, all degrees up to `degree`) and the world
/// transform of the node that draws it.
struct PrimitiveAccessors {
  Accessor pos, rot, scale, opacity;
  std::vector<Accessor> sh;
  uint32_t degree = 0;
  const double* world = nullptr;
};

class Reader {
 public:
  /// `folder`: the scene's folder, for buffers in files of their own; null for data in memory.
  Reader(const json& doc, const uint8_t* bin, uint64_t bin_size, const detail::SceneFolder* folder,
         const InteropReadOptions& o)
      : doc_(doc), bin_(bin), bin_size_(bin_size), folder_(folder), options_(o) {}

  Result<InteropScene> read(const std::string& container, uint64_t file_bytes);

 private:
  struct Primitive {
    const json* prim;
    double world[16];  ///< column-major
  };

  Status check_asset();
  /// Splat primitives of the default scene, or of every mesh when there is no scene, into prims_.
  Status find_primitives();
  Status collect(const json& nodes_list);
  Status visit(uint64_t node, const double parent[16], int depth);
  Status buffer(uint64_t index, const uint8_t** data, uint64_t* size);
  Status accessor(const json& attributes, const std::string& semantic, const char* type, int components,
                  Allowed allowed, Accessor* out);
  /// Checks primitive `index`'s extension, mode and attributes and finds its accessors (counts all equal).
  Status primitive_accessors(size_t index, PrimitiveAccessors* d);
  /// The SH accessors of a primitive with attributes `attrs`: every coefficient of degrees 0..l, none above.
  Status sh_accessors(const json& attrs, const std::string& where, PrimitiveAccessors* d);

  const json& doc_;
  const uint8_t* bin_;
  uint64_t bin_size_;
  const detail::SceneFolder* folder_;
  const InteropReadOptions& options_;
  std::map<uint64_t, std::vector<uint8_t>> loaded_;
  /// The scene's input bytes: the glTF or GLB file (`file_bytes`) and its external buffers' files, each
  /// distinct file counted once however many buffers name it (SceneFolder::distinct_bytes).
  uint64_t input_bytes(uint64_t file_bytes) const {
    return folder_ != nullptr ? std::max(file_bytes, folder_->distinct_bytes()) : file_bytes;
  }
  /// Bytes of the external buffers held (a file that several buffers name held once per buffer) and bytes the
  /// accessors decode (repeats counted): both are held to the decompression-ratio limit of input_bytes(),
  /// since accessors without data and shared data decode to more than the files hold.
  uint64_t buffer_bytes_held_ = 0;
  uint64_t accessor_bytes_ = 0;
  /// The glTF or GLB file's bytes, for input_bytes().
  uint64_t file_bytes_ = 0;
  /// Nodes already visited: glTF nodes form disjoint trees, so a second visit is a cycle or a second parent.
  std::vector<bool> visited_;
  std::vector<Primitive> prims_;
  std::vector<std::string> notes_;
};

Status Reader::check_asset() {
  auto asset = doc_.find("asset");
  if (asset == doc_.end() || !asset->is_object()) return corrupt("glTF has no 'asset' object");
  auto version = asset->find("version");
  if (version == asset->end() || !version->is_string()) return corrupt("glTF asset has no 'version' string");
  const std::string v = version->get<std::string>();
  if (v.rfind("2.", 0) != 0) {
    return Status(StatusCode::kUnsupportedVersion,
                  "glTF asset version " + detail::describe_json_value(*version) + " is not supported (2.x)");
  }
  auto req = doc_.find("extensionsRequired");
  if (req != doc_.end()) {
    if (!req->is_array()) return corrupt("glTF 'extensionsRequired' is not an array");
    for (const json& e : *req) {
      if (!e.is_string() || e.get<std::string>() != detail::kKhrGaussianSplatting) {
        return Status(StatusCode::kUnsupportedFeature,
                      "glTF requires extension " + detail::describe_json_value(e) +
                          ", which this reader does not implement (only KHR_gaussian_splatting)");
      }
    }
  }
  return Status();
}

void identity(double m[16]) {
  for (int i = 0; i < 16; ++i) m[i] = (i % 5 == 0) ? 1.0 : 0.0;
}

void multiply(const double a[16], const double b[16], double out[16]) {
  double r[16];
  for (int c = 0; c < 4; ++c) {
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[c * 4 + k];
      r[c * 4 + row] = s;
    }
  }
  std::memcpy(out, r, sizeof(r));
}

Status numbers(const json& obj, const char* key, size_t n, double* out, const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end()) return Status();
  if (!it->is_array() || it->size() != n)
    return corrupt(where + " '" + key + "' is not an array of " + std::to_string(n));
  for (size_t i = 0; i < n; ++i) {
    if (!(*it)[i].is_number()) return corrupt(where + " '" + key + "' holds a non-number");
    out[i] = (*it)[i].get<double>();
  }
  return Status();
}

Status Reader::visit(uint64_t index, const double parent[16], int depth) {
  const json& nodes = member(doc_, "nodes");
  if (!nodes.is_array() || index >= nodes.size())
    return corrupt("glTF node " + std::to_string(index) + " does not exist");
  if (depth > kMaxNodeDepth)
    return corrupt("glTF node hierarchy deeper than " + std::to_string(kMaxNodeDepth) + " (cycle?)");
  const std::string where = "glTF node " + std::to_string(index);
  if (visited_.size() != nodes.size()) visited_.assign(nodes.size(), false);
  if (visited_[index]) {
    return corrupt(where + " is reached a second time: a cycle, or a node with two parents (glTF 2.0 nodes form "
                           "disjoint trees)");
  }
  visited_[index] = true;
  const json& node = nodes[index];
  if (!node.is_object()) return corrupt(where + " is not an object");
  double local[16];
  identity(local);
  if (node.contains("matrix")) {
    RGS_RETURN_IF_ERROR(numbers(node, "matrix", 16, local, where));
  } else {
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    RGS_RETURN_IF_ERROR(numbers(node, "translation", 3, t, where));
    RGS_RETURN_IF_ERROR(numbers(node, "rotation", 4, q, where));
    RGS_RETURN_IF_ERROR(numbers(node, "scale", 3, s, where));
    const double wxyz[4] = {q[3], q[0], q[1], q[2]};  // glTF stores x, y, z, w
    const std::array<double, 9> r = detail::quaternion_matrix(wxyz);
    for (int c = 0; c < 3; ++c) {
      for (int row = 0; row < 3; ++row) local[c * 4 + row] = r[row * 3 + c] * s[c];
    }
    for (int a = 0; a < 3; ++a) local[12 + a] = t[a];
  }
  double world[16];
  multiply(parent, local, world);
  if (node.contains("mesh")) {
    uint64_t mesh = 0;
    RGS_RETURN_IF_ERROR(get_index(node, "mesh", &mesh, true, where));
    const json& meshes = member(doc_, "meshes");
    if (!meshes.is_array() || mesh >= meshes.size())
      return corrupt(where + " names mesh " + std::to_string(mesh) + ", which does not exist");
    const json& prims = member(meshes[mesh], "primitives");  // a reference: primitives are kept by address
    if (!prims.is_array()) return corrupt("glTF mesh " + std::to_string(mesh) + " has no primitives array");
    for (const json& p : prims) {
      if (!is_splat_primitive(p)) continue;
      if (prims_.size() == kMaxSplatPrimitives) {
        return Status(StatusCode::kLimitExceeded, "glTF draws more than " + std::to_string(kMaxSplatPrimitives) +
                                                      " Gaussian splatting primitives (nodes x primitives)");
      }
      Primitive prim{&p, {}};
      std::memcpy(prim.world, world, sizeof(world));
      prims_.push_back(prim);
    }
  }
  if (node.contains("children")) {
    const json& children = node["children"];
    if (!children.is_array()) return corrupt(where + " 'children' is not an array");
    for (const json& c : children) {
      if (!c.is_number_unsigned()) return corrupt(where + " has a child that is not a node index");
      RGS_RETURN_IF_ERROR(visit(c.get<uint64_t>(), world, depth + 1));
    }
  }
  return Status();
}

Status Reader::collect(const json& scene_nodes) {
  double id[16];
  identity(id);
  for (const json& n : scene_nodes) {
    if (!n.is_number_unsigned()) return corrupt("glTF scene lists a node that is not an index");
    RGS_RETURN_IF_ERROR(visit(n.get<uint64_t>(), id, 0));
  }
  return Status();
}

Status Reader::buffer(uint64_t index, const uint8_t** data, uint64_t* size) {
  const json& buffers = member(doc_, "buffers");
  const std::string where = "glTF buffer " + std::to_string(index);
  if (!buffers.is_array() || index >= buffers.size()) return corrupt(where + " does not exist");
  const json& b = buffers[index];
  uint64_t length = 0;
  RGS_RETURN_IF_ERROR(get_index(b, "byteLength", &length, true, where));
  auto uri = b.find("uri");
  if (uri == b.end()) {
    if (index != 0 || bin_ == nullptr) return corrupt(where + " has no uri and there is no GLB BIN chunk");
    if (length > bin_size_) {
      return corrupt(where + " declares " + std::to_string(length) + " bytes but the BIN chunk has " +
                     std::to_string(bin_size_));
    }
    *data = bin_;
    *size = length;
    return Status();
  }
  if (!uri->is_string()) return corrupt(where + " uri is not a string");
  auto cached = loaded_.find(index);
  if (cached == loaded_.end()) {
    const std::string u = uri->get<std::string>();
    std::vector<uint8_t> bytes;
    if (u.rfind("data:", 0) == 0) {
      const size_t comma = u.find(',');
      if (comma == std::string::npos || u.substr(0, comma).find(";base64") == std::string::npos ||
          !base64_decode(u, comma + 1, &bytes)) {
        return corrupt(base64_error(where));
      }
    } else {
      if (folder_ == nullptr) {
        return Status(StatusCode::kUnsupportedFeature, where + " refers to an external file, which cannot be "
                                                           "resolved for data in memory");
      }
      RGS_ASSIGN_OR_RETURN(std::string file, folder_->resolve(u, "", "glTF",
                                                             "buffers[" + std::to_string(index) + "].uri"));
      Status read = folder_->read(file, length, &bytes, /*prefix=*/true);
      if (!read.ok()) return read.prepend(where);
      buffer_bytes_held_ += length;
      if (buffer_bytes_held_ > detail::decode_budget(input_bytes(file_bytes_), options_.max_decompression_ratio)) {
        return Status(StatusCode::kLimitExceeded,
                      where + ": the buffers name " + std::to_string(buffer_bytes_held_) + " bytes of files (a " +
                          "file named again counted again), more than the decompression-ratio limit of " +
                          std::to_string(options_.max_decompression_ratio) + " x the " +
                          std::to_string(input_bytes(file_bytes_)) + " bytes of distinct files read (files under " +
                          "1 MiB count as 1 MiB; format/SPEC.md 5.5); raise --max-decompression-ratio to read it");
      }
    }
    if (bytes.size() < length) {
      return corrupt(where + " declares " + std::to_string(length) + " bytes but its data has " +
                     std::to_string(bytes.size()));
    }
    cached = loaded_.emplace(index, std::move(bytes)).first;
  }
  *data = cached->second.data();
  *size = length;
  return Status();
}

Status Reader::accessor(const json& attributes, const std::string& semantic, const char* type, int components,
                        Allowed allowed, Accessor* out) {
  auto it = attributes.find(semantic);
  if (it == attributes.end()) return corrupt("glTF splat primitive has no '" + semantic + "' attribute");
  if (!it->is_number_unsigned()) return corrupt("glTF attribute '" + semantic + "' is not an accessor index");
  const uint64_t index = it->get<uint64_t>();
  const json& accessors = member(doc_, "accessors");
  const std::string where = "glTF accessor " + std::to_string(index) + " ('" + semantic + "')";
  if (!accessors.is_array() || index >= accessors.size()) return corrupt(where + " does not exist");
  const json& a = accessors[index];
  if (!a.is_object()) return corrupt(where + " is not an object");
  if (a.contains("sparse")) return Status(StatusCode::kUnsupportedFeature, where + " is sparse");
  if (!a.contains("type") || !a["type"].is_string() || a["type"].get<std::string>() != type) {
    return corrupt(where + " has type " +
                   (a.contains("type") ? detail::describe_json_value(a["type"]) : std::string("(none)")) +
                   ", expected " + type);
  }
  uint64_t ctype = 0, count = 0, offset = 0;
  RGS_RETURN_IF_ERROR(get_index(a, "componentType", &ctype, true, where));
  RGS_RETURN_IF_ERROR(get_index(a, "count", &count, true, where));
  RGS_RETURN_IF_ERROR(get_index(a, "byteOffset", &offset, false, where));
  const bool normalized = a.value("normalized", false);
  if (!allowed_type(allowed, static_cast<int>(ctype), normalized)) {
    return corrupt(where + " has componentType " + std::to_string(ctype) + (normalized ? " normalized" : "") +
                   ", which KHR_gaussian_splatting does not allow for this attribute");
  }
  out->component_type = static_cast<int>(ctype);
  out->components = components;
  out->normalized = normalized;
  out->count = count;
  out->base = nullptr;
  const uint64_t elem = uint64_t(component_bytes(out->component_type)) * components;
  uint64_t decoded = 0;
  if (!format::checked_mul(count, elem, &decoded) || !format::checked_add(accessor_bytes_, decoded, &accessor_bytes_)) {
    accessor_bytes_ = UINT64_MAX;
  }
  if (!a.contains("bufferView")) return Status();  // all zeros, as glTF defines
  uint64_t view_index = 0;
  RGS_RETURN_IF_ERROR(get_index(a, "bufferView", &view_index, true, where));
  const json& views = member(doc_, "bufferViews");
  if (!views.is_array() || view_index >= views.size()) {
    return corrupt(where + " names bufferView " + std::to_string(view_index) + ", which does not exist");
  }
  const json& v = views[view_index];
  const std::string vwhere = "glTF bufferView " + std::to_string(view_index);
  uint64_t buf = 0, voff = 0, vlen = 0, stride = 0;
  RGS_RETURN_IF_ERROR(get_index(v, "buffer", &buf, true, vwhere));
  RGS_RETURN_IF_ERROR(get_index(v, "byteOffset", &voff, false, vwhere));
  RGS_RETURN_IF_ERROR(get_index(v, "byteLength", &vlen, true, vwhere));
  RGS_RETURN_IF_ERROR(get_index(v, "byteStride", &stride, false, vwhere));
  if (stride != 0 && (stride < elem || stride > 252)) {
    return corrupt(vwhere + " byteStride " + std::to_string(stride) + " is below the element size " +
                   std::to_string(elem) + " or above 252");
  }
  if (stride == 0) stride = elem;
  const uint8_t* data = nullptr;
  uint64_t size = 0;
  RGS_RETURN_IF_ERROR(buffer(buf, &data, &size));
  uint64_t vend = 0;
  if (!format::checked_add(voff, vlen, &vend) || vend > size) {
    return corrupt(vwhere + " spans bytes " + std::to_string(voff) + "+" + std::to_string(vlen) +
                   ", beyond its buffer of " + std::to_string(size));
  }
  if (count > 0) {
    uint64_t last = 0, end = 0;
    if (!format::checked_mul(stride, count - 1, &last) || !format::checked_add(last, offset, &end) ||
        !format::checked_add(end, elem, &end) || end > vlen) {
      return corrupt(where + ": " + std::to_string(count) + " elements of " + std::to_string(elem) + " bytes every " +
                     std::to_string(stride) + " from offset " + std::to_string(offset) +
                     " do not fit bufferView " + std::to_string(view_index) + " of " + std::to_string(vlen) + " bytes");
    }
  }
  out->base = data + voff + offset;
  out->stride = stride;
  return Status();
}

Status Reader::find_primitives() {
  auto scenes = doc_.find("scenes");
  if (scenes != doc_.end() && scenes->is_array() && !scenes->empty()) {
    uint64_t s = 0;
    RGS_RETURN_IF_ERROR(get_index(doc_, "scene", &s, false, "glTF"));
    if (s >= scenes->size()) return corrupt("glTF default scene " + std::to_string(s) + " does not exist");
    const json& scene = (*scenes)[s];
    if (scene.contains("nodes")) {
      if (!scene["nodes"].is_array()) return corrupt("glTF scene 'nodes' is not an array");
      RGS_RETURN_IF_ERROR(collect(scene["nodes"]));
    }
  } else if (doc_.contains("meshes") && member(doc_, "meshes").is_array()) {
    for (const json& m : member(doc_, "meshes")) {
      const json& prims = member(m, "primitives");
      if (!prims.is_array()) continue;
      for (const json& p : prims) {
        if (is_splat_primitive(p)) {
          Primitive prim{&p, {}};
          identity(prim.world);
          prims_.push_back(prim);
        }
      }
    }
  }
  if (prims_.empty()) {
    return Status(StatusCode::kUnsupportedFeature,
                  "glTF has no mesh primitive with the KHR_gaussian_splatting extension");
  }
  return Status();
}

Status Reader::sh_accessors(const json& attrs, const std::string& where, PrimitiveAccessors* d) {
  const Allowed sh_types = 0;  // float only
  for (uint32_t l = 0; l <= 3; ++l) {
    int present = 0;
    for (int m = 0; m < detail::kGltfShCoefs[l]; ++m) {
      present +=
          attrs.contains("KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(l) + "_COEF_" + std::to_string(m));
    }
    if (present == 0) {
      if (l == 0) return corrupt(where + " has no KHR_gaussian_splatting:SH_DEGREE_0_COEF_0");
      for (uint32_t h = l + 1; h <= 3; ++h) {
        if (attrs.contains("KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(h) + "_COEF_0")) {
          return corrupt(where + " has SH degree " + std::to_string(h) + " without degree " + std::to_string(l));
        }
      }
      break;
    }
    if (present != detail::kGltfShCoefs[l]) {
      return corrupt(where + " defines " + std::to_string(present) + " of the " +
                     std::to_string(detail::kGltfShCoefs[l]) + " coefficients of SH degree " + std::to_string(l));
    }
    for (int m = 0; m < detail::kGltfShCoefs[l]; ++m) {
      Accessor a;
      RGS_RETURN_IF_ERROR(accessor(attrs, "KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(l) + "_COEF_" +
                                              std::to_string(m), "VEC3", 3, sh_types, &a));
      d->sh.push_back(a);
    }
    d->degree = l;
  }
  return Status();
}

Status Reader::primitive_accessors(size_t index, PrimitiveAccessors* d) {
  const json& p = *prims_[index].prim;
  const std::string where = "glTF splat primitive " + std::to_string(index);
  const json& ext = p["extensions"][detail::kKhrGaussianSplatting];
  if (!ext.is_object()) return corrupt(where + ": KHR_gaussian_splatting is not an object");
  const std::string kernel = ext.value("kernel", std::string());
  if (kernel != "ellipse") {
    return Status(StatusCode::kUnsupportedFeature,
                  where + " has kernel '" + detail::bounded_text(kernel, 64) + "' (supported: ellipse)");
  }
  const std::string color_space = ext.value("colorSpace", std::string());
  if (color_space != "srgb_rec709_display") {
    notes_.push_back(where + ": colorSpace '" + detail::bounded_text(color_space, 64) +
                     "' kept as stored; RoofGS renders colours as 3DGS "
                     "does (srgb_rec709_display)");
  }
  if (ext.value("projection", std::string("perspective")) != "perspective" ||
      ext.value("sortingMethod", std::string("cameraDistance")) != "cameraDistance") {
    notes_.push_back(where + ": projection/sortingMethod other than perspective/cameraDistance ignored");
  }
  uint64_t mode = 4;
  RGS_RETURN_IF_ERROR(get_index(p, "mode", &mode, false, where, 4));
  if (mode != 0) return corrupt(where + " has mode " + std::to_string(mode) + "; splats must be POINTS (0)");
  if (!p.contains("attributes") || !p["attributes"].is_object()) return corrupt(where + " has no attributes");
  const json& attrs = p["attributes"];
  const Allowed opacity_types = type_bit(detail::kGltfUnsignedByte, true) | type_bit(detail::kGltfUnsignedShort, true);
  const Allowed scale_types =
      opacity_types | type_bit(detail::kGltfUnsignedByte, false) | type_bit(detail::kGltfUnsignedShort, false);
  const Allowed rotation_types = type_bit(detail::kGltfByte, true) | type_bit(detail::kGltfShort, true);
  const Allowed position_types = scale_types | rotation_types | type_bit(detail::kGltfByte, false) |
                                 type_bit(detail::kGltfShort, false);
  d->world = prims_[index].world;
  RGS_RETURN_IF_ERROR(accessor(attrs, "POSITION", "VEC3", 3, position_types, &d->pos));
  RGS_RETURN_IF_ERROR(accessor(attrs, "KHR_gaussian_splatting:ROTATION", "VEC4", 4, rotation_types, &d->rot));
  RGS_RETURN_IF_ERROR(accessor(attrs, "KHR_gaussian_splatting:SCALE", "VEC3", 3, scale_types, &d->scale));
  RGS_RETURN_IF_ERROR(accessor(attrs, "KHR_gaussian_splatting:OPACITY", "SCALAR", 1, opacity_types, &d->opacity));
  RGS_RETURN_IF_ERROR(sh_accessors(attrs, where, d));
  const uint64_t n = d->pos.count;
  for (const Accessor* a : {&d->rot, &d->scale, &d->opacity}) {
    if (a->count != n) {
      return corrupt(where + ": attribute counts differ (" + std::to_string(n) + " positions, " +
                     std::to_string(a->count) + " in another attribute)");
    }
  }
  for (const Accessor& a : d->sh) {
    if (a.count != n)
      return corrupt(where + ": SH accessor holds " + std::to_string(a.count) + " values, POSITION " +
                     std::to_string(n));
  }
  return Status();
}

/// A node's world transform M = R·s + translation (column-major `m`), with R as a quaternion.
struct NodeTransform {
  const double* m = nullptr;
  bool identity = true;
  double s = 1;
  double qr[4] = {1, 0, 0, 0};  ///< (w, x, y, z) of R
};

/// Splits the world transform of splat primitive `index` (`d`) into R and uniform s > 0; refuses any other
/// transform, and a rotation of a primitive with SH above degree 0.
Status node_transform(const PrimitiveAccessors& d, size_t index, NodeTransform* t) {
  const double* m = t->m = d.world;
  double col[3];
  for (int c = 0; c < 3; ++c)
    col[c] = std::sqrt(m[c * 4] * m[c * 4] + m[c * 4 + 1] * m[c * 4 + 1] + m[c * 4 + 2] * m[c * 4 + 2]);
  const double s = t->s = col[0];
  for (int i = 0; i < 16; ++i) t->identity = t->identity && std::fabs(m[i] - ((i % 5 == 0) ? 1.0 : 0.0)) < 1e-12;
  if (t->identity) return Status();
  const double det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
                     m[8] * (m[1] * m[6] - m[5] * m[2]);
  if (!(s > 0) || std::fabs(col[1] - s) > 1e-6 * s || std::fabs(col[2] - s) > 1e-6 * s || det <= 0 ||
      std::fabs(m[3]) + std::fabs(m[7]) + std::fabs(m[11]) > 1e-12 || std::fabs(m[15] - 1) > 1e-12) {
    return Status(StatusCode::kUnsupportedFeature, "glTF splat primitive " + std::to_string(index) +
                                                       " has a node transform that is not rotation + uniform "
                                                       "positive scale + translation");
  }
  // Rotation matrix R = M / s (M column-major), to a quaternion.
  const double r[3][3] = {
      {m[0] / s, m[4] / s, m[8] / s}, {m[1] / s, m[5] / s, m[9] / s}, {m[2] / s, m[6] / s, m[10] / s}};
  detail::matrix_quaternion(r, t->qr);
  const bool rotates = std::fabs(std::fabs(t->qr[0]) - 1.0) > 1e-9;
  if (rotates && d.degree > 0) {
    return Status(StatusCode::kUnsupportedFeature,
                  "glTF splat primitive " + std::to_string(index) + " is rotated by its node and has SH degree " +
                      std::to_string(d.degree) + "; rotating SH coefficients is not supported");
  }
  return Status();
}

/// Decodes the Gaussians of one primitive, transformed by `t`, into `cloud` from Gaussian `at` on; counts
/// opacities outside [0, 1] and negative scales.
void copy_gaussians(const PrimitiveAccessors& d, const NodeTransform& t, uint64_t at, format::GaussianCloud* cloud,
                    uint64_t* bad_opacity, uint64_t* bad_scale) {
  const uint32_t k_count = cloud->sh_coefficients();
  const double* m = t.m;
  const double* qr = t.qr;
  const uint64_t n = d.pos.count;
  for (uint64_t i = 0; i < n; ++i, ++at) {
    double p[3], q[4], sc[3];
    for (int a = 0; a < 3; ++a) p[a] = d.pos.get(i, a);
    for (int a = 0; a < 3; ++a) sc[a] = d.scale.get(i, a);
    // glTF (x, y, z, w) → (w, x, y, z)
    q[0] = d.rot.get(i, 3), q[1] = d.rot.get(i, 0), q[2] = d.rot.get(i, 1), q[3] = d.rot.get(i, 2);
    if (!t.identity) {
      double u[3];
      for (int r = 0; r < 3; ++r) u[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
      std::memcpy(p, u, sizeof(u));
      for (double& v : sc) v *= t.s;
      const double w = qr[0] * q[0] - qr[1] * q[1] - qr[2] * q[2] - qr[3] * q[3];
      const double x = qr[0] * q[1] + qr[1] * q[0] + qr[2] * q[3] - qr[3] * q[2];
      const double y = qr[0] * q[2] - qr[1] * q[3] + qr[2] * q[0] + qr[3] * q[1];
      const double z = qr[0] * q[3] + qr[1] * q[2] - qr[2] * q[1] + qr[3] * q[0];
      q[0] = w, q[1] = x, q[2] = y, q[3] = z;
    }
    for (int a = 0; a < 3; ++a) {
      cloud->means[at * 3 + a] = static_cast<float>(p[a]);
      cloud->scales[at * 3 + a] = static_cast<float>(sc[a]);
      *bad_scale += sc[a] < 0;
    }
    for (int a = 0; a < 4; ++a) cloud->rotations[at * 4 + a] = static_cast<float>(q[a]);
    const float o = d.opacity.get(i, 0);
    *bad_opacity += o < 0.0f || o > 1.0f;
    cloud->opacities[at] = o;
    for (uint32_t k = 0; k < k_count; ++k) {
      for (int c = 0; c < 3; ++c) cloud->sh[(at * k_count + k) * 3 + c] = d.sh[k].get(i, c);
    }
  }
}

Result<InteropScene> Reader::read(const std::string& container, uint64_t file_bytes) {
  file_bytes_ = file_bytes;
  if (!doc_.is_object()) return corrupt("glTF JSON is not an object");
  RGS_RETURN_IF_ERROR(check_asset());
  RGS_RETURN_IF_ERROR(find_primitives());
  std::vector<PrimitiveAccessors> parts;
  uint64_t total = 0;
  for (size_t pi = 0; pi < prims_.size(); ++pi) {
    PrimitiveAccessors d;
    RGS_RETURN_IF_ERROR(primitive_accessors(pi, &d));
    if (!parts.empty() && parts.front().degree != d.degree) {
      return Status(StatusCode::kUnsupportedFeature, "glTF splat primitive " + std::to_string(pi) +
                                                         " has SH degree " + std::to_string(d.degree) +
                                                         ", primitive 0 has " + std::to_string(parts.front().degree));
    }
    total += d.pos.count;
    RGS_RETURN_IF_ERROR(detail::check_limit("glTF declares ", total, "or more Gaussians", options_.max_gaussians));
    parts.push_back(std::move(d));
    // Per primitive, so that many nodes drawing one mesh are refused before their parts pile up.
    RGS_RETURN_IF_ERROR(detail::check_decode_budget(accessor_bytes_, input_bytes(file_bytes),
                                                    options_.max_decompression_ratio, "",
                                                    "the accessors of " + std::to_string(total) + " Gaussians"));
  }

  InteropScene scene;
  scene.format = container;
  scene.format_version = 2;
  scene.file_bytes = input_bytes(file_bytes);
  scene.declared_gaussians = total;
  scene.stored_frame = "LUF";
  format::GaussianCloud& cloud = scene.cloud;
  cloud.sh_degree = parts.front().degree;
  cloud.resize(static_cast<size_t>(total));
  uint64_t at = 0, bad_opacity = 0, bad_scale = 0;
  for (size_t pi = 0; pi < parts.size(); ++pi) {
    NodeTransform t;
    RGS_RETURN_IF_ERROR(node_transform(parts[pi], pi, &t));
    copy_gaussians(parts[pi], t, at, &cloud, &bad_opacity, &bad_scale);
    at += parts[pi].pos.count;
  }
  if (bad_opacity != 0 || bad_scale != 0) {
    return corrupt(std::to_string(bad_opacity) + " opacities outside [0, 1] and " + std::to_string(bad_scale) +
                   " negative scales (KHR_gaussian_splatting stores activated values)");
  }
  if (options_.convert_frame) {
    detail::AxisFlip flip;
    detail::flip_to_rdf("LUF", &flip);
    detail::apply_axis_flip(flip, &cloud);
    scene.frame_converted = true;
  }
  scene.notes = std::move(notes_);
  RGS_RETURN_IF_ERROR(detail::finish_hygiene(options_.invalid_policy, "Gaussian", &cloud, &scene.hygiene));
  return scene;
}

/// The JSON and BIN chunks of a GLB, or the JSON text of a .gltf.
struct Container {
  std::string name = "gltf";  ///< "glb" or "gltf"
  const uint8_t* json_begin = nullptr;
  uint64_t json_size = 0;
  const uint8_t* bin = nullptr;
  uint64_t bin_size = 0;
};

/// Splits `data` into its container's chunks and parses the JSON (nesting bounded).
Status parse_container(const uint8_t* data, size_t size, Container* c, json* doc) {
  c->json_begin = data;
  c->json_size = size;
  if (size >= 4 && format::load_u32_le(data) == detail::kGlbMagic) {
    c->name = "glb";
    if (size < detail::kGlbHeaderBytes + 8) {
      return Status(StatusCode::kIoError, "GLB file of " + std::to_string(size) + " bytes ends inside its header");
    }
    const uint32_t version = format::load_u32_le(data + 4);
    if (version != 2) {
      return Status(StatusCode::kUnsupportedVersion,
                    "GLB version " + std::to_string(version) + " is not supported (2)");
    }
    const uint32_t length = format::load_u32_le(data + 8);
    if (length > size) {
      return Status(StatusCode::kIoError, "GLB header declares " + std::to_string(length) + " bytes but the file has " +
                                              std::to_string(size) + " (truncated file?)");
    }
    uint64_t at = detail::kGlbHeaderBytes;
    bool have_json = false;
    while (at + 8 <= length) {
      const uint64_t chunk = format::load_u32_le(data + at);
      const uint32_t type = format::load_u32_le(data + at + 4);
      if (chunk > length - at - 8) {
        return Status(StatusCode::kIoError, "GLB chunk at byte " + std::to_string(at) + " declares " +
                                                std::to_string(chunk) + " bytes, past the end at " +
                                                std::to_string(length));
      }
      if (!have_json) {
        if (type != detail::kGlbChunkJson) return corrupt("GLB's first chunk is not JSON");
        c->json_begin = data + at + 8;
        c->json_size = chunk;
        have_json = true;
      } else if (type == detail::kGlbChunkBin && c->bin == nullptr) {
        c->bin = data + at + 8;
        c->bin_size = chunk;
      }
      at += 8 + chunk;
    }
    if (!have_json) return corrupt("GLB has no JSON chunk");
  } else if (size >= 3 && data[0] == 0xEF && data[1] == 0xBB && data[2] == 0xBF) {
    c->json_begin += 3, c->json_size -= 3;  // JSON glTF: skip a UTF-8 byte-order mark
  }
  if (c->json_size > kMaxGltfJsonBytes) {
    return Status(StatusCode::kLimitExceeded, "glTF JSON of " + std::to_string(c->json_size) + " bytes exceeds " +
                                                  std::to_string(kMaxGltfJsonBytes));
  }
  RGS_ASSIGN_OR_RETURN(*doc, detail::parse_scene_json(c->json_begin, static_cast<size_t>(c->json_size),
                                                       c->name == "glb" ? "GLB JSON chunk" : "glTF JSON"));
  return Status();
}

Result<InteropScene> read_document(const uint8_t* data, size_t size, const detail::SceneFolder* folder,
                                   const InteropReadOptions& options) {
  Container c;
  json doc;
  RGS_RETURN_IF_ERROR(parse_container(data, size, &c, &doc));
  Reader reader(doc, c.bin, c.bin_size, folder, options);
  return reader.read(c.name, size);
}

}  // namespace

bool looks_like_gltf(const uint8_t* head, size_t n) {
  if (head == nullptr) return false;
  if (n >= 8 && format::load_u32_le(head) == detail::kGlbMagic) return format::load_u32_le(head + 4) == 2;
  size_t i = 0;
  if (n >= 3 && head[0] == 0xEF && head[1] == 0xBB && head[2] == 0xBF) i = 3;
  while (i < n && (head[i] == ' ' || head[i] == '\t' || head[i] == '\r' || head[i] == '\n')) ++i;
  if (i >= n || head[i] != '{') return false;
  const std::string text(reinterpret_cast<const char*>(head) + i, n - i);
  return text.find("\"asset\"") != std::string::npos || text.find(detail::kKhrGaussianSplatting) != std::string::npos;
}

Result<InteropScene> read_gltf(const std::string& path, const InteropReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(auto file, format::MappedFile::open(path));  // its errors name the path
  return detail::guarded<InteropScene>(path, "decoding the glTF file", [&]() -> Result<InteropScene> {
    const detail::SceneFolder folder(std::filesystem::path(path).parent_path().string(), path);
    RGS_ASSIGN_OR_RETURN(InteropScene scene, read_document(file->data(), file->size(), &folder, options));
    scene.files = folder.files();
    return scene;
  });
}

Result<InteropScene> read_gltf_bytes(const uint8_t* data, size_t size, const std::string& name,
                                     const InteropReadOptions& options) {
  return detail::guarded_bytes<InteropScene>(data, size, name, "decoding the glTF file",
                                             [&] { return read_document(data, size, nullptr, options); });
}

namespace detail {

Result<std::vector<std::string>> list_gltf_files(const std::string& path) {
  RGS_ASSIGN_OR_RETURN(auto file, format::MappedFile::open(path));
  return guarded<std::vector<std::string>>(path, "listing the glTF file's buffers",
                                           [&]() -> Result<std::vector<std::string>> {
    Container c;
    json doc;
    RGS_RETURN_IF_ERROR(parse_container(file->data(), file->size(), &c, &doc));
    const SceneFolder folder(std::filesystem::path(path).parent_path().string(), path);
    std::vector<std::string> files = {path};
    const json& buffers = member(doc, "buffers");
    for (size_t i = 0; buffers.is_array() && i < buffers.size(); ++i) {
      const json& uri = member(buffers[i], "uri");
      if (!uri.is_string() || uri.get_ref<const std::string&>().rfind("data:", 0) == 0) continue;
      RGS_ASSIGN_OR_RETURN(std::string relative, folder.resolve(uri.get<std::string>(), "",
                                                                "glTF", "buffers[" + std::to_string(i) + "].uri"));
      files.push_back(folder.display(relative));
    }
    return files;
  });
}

}  // namespace detail

}  // namespace rgs::converter
