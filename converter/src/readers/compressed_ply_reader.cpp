// PlayCanvas compressed PLY reader: per-chunk (256 Gaussians) float bounds, packed 32-bit vertex words and
// optional 8-bit SH, as written by PlayCanvas SuperSplat / splat-transform.
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "../internal_huge_pages.h"
#include "../internal_input_file.h"
#include "../internal_interop.h"
#include "../internal_parallel.h"
#include "internal_ply_header.h"
#include "rgs/converter/playcanvas_readers.h"

namespace rgs::converter {

namespace {

using detail::PlyElement;
using detail::PlyHeader;
using detail::PlyProperty;
using detail::PlyType;

constexpr uint64_t kGaussiansPerChunk = 256;
constexpr uint64_t kMaxFileBytes = uint64_t{1} << 40;
constexpr uint64_t kMinGaussiansPerWorker = 65536;
using detail::kMaxOpacityLogit;
using detail::kShC0;

const char* const kChunkFields[] = {"min_x",       "min_y",       "min_z",       "max_x",
                                    "max_y",       "max_z",       "min_scale_x", "min_scale_y",
                                    "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z"};
const char* const kChunkColorFields[] = {"min_r", "min_g", "min_b", "max_r", "max_g", "max_b"};
const char* const kVertexFields[] = {"packed_position", "packed_rotation", "packed_scale", "packed_color"};

/// Byte offset of each element's data and its row size (scalar properties only).
struct ElementData {
  const PlyElement* element = nullptr;
  uint64_t offset = 0;
  uint64_t stride = 0;
};

Status property_offset(const ElementData& e, const std::string& name, PlyType type, uint64_t* offset) {
  uint64_t at = 0;
  for (const PlyProperty& p : e.element->properties) {
    if (p.name == name) {
      if (!p.known_type || p.is_list || p.type != type) {
        return Status(StatusCode::kUnsupportedFeature, "PLY header line " + std::to_string(p.header_line) +
                                                           ": property '" + name + "' of element '" + e.element->name +
                                                           "' is '" + p.type_name + "'; compressed PLY stores it as " +
                                                           detail::ply_type_name(type));
      }
      *offset = at;
      return Status();
    }
    at += detail::ply_type_size(p.type);
  }
  return Status(StatusCode::kCorruptData,
                "element '" + e.element->name + "' has no property '" + name + "' (compressed PLY)");
}

/// The decoded bounds of one chunk.
struct ChunkBounds {
  double lo[12 + 6];
};

inline double lerp(double a, double b, double t) { return a * (1 - t) + b * t; }

/// Where everything read lies: the elements, the byte offsets of their properties within a row (chunk bounds
/// in kChunkFields then kChunkColorFields order, vertex words in kVertexFields order, SH f_rest_* in order)
/// and the SH degree the sh element's properties give.
struct Layout {
  ElementData chunk, vertex, sh;
  uint64_t n = 0;  ///< Gaussians (vertices)
  uint64_t chunks = 0;
  bool chunk_colors = false;
  uint64_t chunk_offsets[18] = {};
  uint64_t vertex_offsets[4] = {};
  uint32_t degree = 0;
  std::vector<uint64_t> sh_offsets;
};

/// Locates the elements 'chunk', 'vertex' and optional 'sh' in the `size` bytes of the file; those after a list
/// property cannot be located (and are not needed then).
Status locate_elements(const PlyHeader& header, size_t size, const SceneReadOptions& options, Layout* layout) {
  ElementData &chunk = layout->chunk, &vertex = layout->vertex, &sh = layout->sh;
  uint64_t at = header.data_offset;
  const PlyProperty* first_list = nullptr;
  for (const PlyElement& element : header.elements) {
    const bool needed = element.name == "chunk" || element.name == "vertex" || element.name == "sh";
    uint64_t stride = 0;
    for (const PlyProperty& p : element.properties) {
      if ((p.is_list || !p.known_type) && first_list == nullptr) first_list = &p;
      if (!p.is_list && p.known_type) stride += detail::ply_type_size(p.type);
    }
    if (needed && first_list != nullptr) {
      return Status(StatusCode::kUnsupportedFeature, "PLY header line " + std::to_string(first_list->header_line) +
                                                         ": property '" + first_list->name +
                                                         "' is a list or of unknown type, so element '" + element.name +
                                                         "' cannot be located; compressed PLY elements are scalar");
    }
    if (first_list != nullptr) continue;  // not needed, and nothing after it can be located
    if (needed && ((element.name == "chunk" && chunk.element) || (element.name == "vertex" && vertex.element) ||
                   (element.name == "sh" && sh.element))) {
      return Status(StatusCode::kCorruptData, "PLY header line " + std::to_string(element.header_line) + ": second '" +
                                                  element.name + "' element");
    }
    if (element.name == "vertex") {
      RGS_RETURN_IF_ERROR(detail::check_limit("PLY declares ", element.count, "vertices", options.max_gaussians));
    }
    if (stride != 0 && element.count > (size - std::min<uint64_t>(at, size)) / stride) {
      return Status(StatusCode::kIoError, "element '" + element.name + "' needs " + std::to_string(element.count) +
                                              " rows × " + std::to_string(stride) + " bytes from offset " +
                                              std::to_string(at) + ", but the file has " + std::to_string(size) +
                                              " bytes (truncated file?)");
    }
    ElementData d{&element, at, stride};
    if (element.name == "chunk") chunk = d;
    if (element.name == "vertex") vertex = d;
    if (element.name == "sh") sh = d;
    at += element.count * stride;
  }
  if (chunk.element == nullptr || vertex.element == nullptr) {
    return Status(StatusCode::kCorruptData, "compressed PLY needs elements 'chunk' and 'vertex'");
  }
  return Status();
}

/// Checks the chunk count against the vertices and finds the properties of the located elements; the SH degree
/// follows from the number of f_rest_* properties.
Status locate_properties(Layout* layout) {
  const ElementData &chunk = layout->chunk, &sh = layout->sh;
  const uint64_t n = layout->n = layout->vertex.element->count;
  const uint64_t chunks = layout->chunks = (n + kGaussiansPerChunk - 1) / kGaussiansPerChunk;
  if (chunk.element->count != chunks) {
    return Status(StatusCode::kCorruptData, "compressed PLY has " + std::to_string(chunk.element->count) +
                                                " chunks for " + std::to_string(n) + " vertices; expected " +
                                                std::to_string(chunks) + " (one per 256)");
  }
  for (int f = 0; f < 12; ++f) {
    RGS_RETURN_IF_ERROR(property_offset(chunk, kChunkFields[f], PlyType::kFloat32, &layout->chunk_offsets[f]));
  }
  for (const PlyProperty& p : chunk.element->properties) {
    layout->chunk_colors = layout->chunk_colors || p.name == "min_r";
  }
  if (layout->chunk_colors) {
    for (int f = 0; f < 6; ++f) {
      RGS_RETURN_IF_ERROR(
          property_offset(chunk, kChunkColorFields[f], PlyType::kFloat32, &layout->chunk_offsets[12 + f]));
    }
  }
  for (int f = 0; f < 4; ++f) {
    RGS_RETURN_IF_ERROR(
        property_offset(layout->vertex, kVertexFields[f], PlyType::kUint32, &layout->vertex_offsets[f]));
  }
  if (!sh.element) return Status();
  size_t rest_count = 0;
  for (const PlyProperty& p : sh.element->properties) rest_count += p.name.rfind("f_rest_", 0) == 0;
  if (!detail::sh_degree_of_rest_count(rest_count, &layout->degree)) {
    return Status(StatusCode::kUnsupportedFeature,
                  "element 'sh' has " + std::to_string(rest_count) + " f_rest_* properties; expected 9, 24 or 45");
  }
  if (sh.element->count != n) {
    return Status(StatusCode::kCorruptData, "element 'sh' has " + std::to_string(sh.element->count) + " rows for " +
                                                std::to_string(n) + " vertices");
  }
  layout->sh_offsets.resize(rest_count);
  for (size_t r = 0; r < rest_count; ++r) {
    RGS_RETURN_IF_ERROR(property_offset(sh, "f_rest_" + std::to_string(r), PlyType::kUint8, &layout->sh_offsets[r]));
  }
  return Status();
}

/// Chunk bounds, checked finite, and small enough that what is decoded from them is a finite float32: exp of
/// the log-scale bounds, and the SH DC (c − 0.5) / C0 of the colour bounds. Every decoded value lies between
/// its chunk's two bounds, so checking the bounds covers every Gaussian.
Result<std::vector<ChunkBounds>> read_chunk_bounds(const uint8_t* data, const Layout& layout) {
  std::vector<ChunkBounds> bounds(static_cast<size_t>(layout.chunks));
  const int fields = layout.chunk_colors ? 18 : 12;
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  for (uint64_t c = 0; c < layout.chunks; ++c) {
    const uint8_t* row = data + layout.chunk.offset + c * layout.chunk.stride;
    for (int f = 0; f < fields; ++f) {
      const float v = format::load_f32_le(row + layout.chunk_offsets[f]);
      const bool scale_field = f >= 6 && f < 12;
      const bool color_field = f >= 12;
      if (!std::isfinite(v) || (scale_field && std::exp(static_cast<double>(v)) > kFloatMax) ||
          (color_field && std::fabs((static_cast<double>(v) - 0.5) / kShC0) > kFloatMax)) {
        return Status(StatusCode::kCorruptData, "chunk " + std::to_string(c) + " has " +
                                                    (std::isfinite(v) ? "an overflowing " : "a non-finite ") +
                                                    (f < 12 ? kChunkFields[f] : kChunkColorFields[f - 12]) + " (" +
                                                    std::to_string(v) + ")");
      }
      bounds[c].lo[f] = static_cast<double>(v);
    }
  }
  return bounds;
}

/// Decodes Gaussian `i` from its packed vertex words (and 8-bit SH through `sh_lut`) within its chunk's
/// bounds `b` into `cloud` (sized, at the layout's SH degree).
inline void decode_gaussian(const uint8_t* data, const Layout& layout, const ChunkBounds& b, const float* sh_lut,
                            uint64_t i, format::GaussianCloud* cloud) {
  const uint32_t k_count = cloud->sh_coefficients();
  const uint32_t rest = k_count - 1;
  const uint8_t* row = data + layout.vertex.offset + i * layout.vertex.stride;
  const uint32_t pos = format::load_u32_le(row + layout.vertex_offsets[0]);
  const uint32_t rot = format::load_u32_le(row + layout.vertex_offsets[1]);
  const uint32_t scl = format::load_u32_le(row + layout.vertex_offsets[2]);
  const uint32_t col = format::load_u32_le(row + layout.vertex_offsets[3]);
  // 11-10-11 unorm position and log scale within the chunk's bounds.
  const double unit[3] = {((pos >> 21) & 2047) / 2047.0, ((pos >> 11) & 1023) / 1023.0, (pos & 2047) / 2047.0};
  const double sunit[3] = {((scl >> 21) & 2047) / 2047.0, ((scl >> 11) & 1023) / 1023.0, (scl & 2047) / 2047.0};
  for (int a = 0; a < 3; ++a) {
    cloud->means[i * 3 + a] = static_cast<float>(lerp(b.lo[a], b.lo[3 + a], unit[a]));
    const float log_scale = static_cast<float>(lerp(b.lo[6 + a], b.lo[9 + a], sunit[a]));
    cloud->scales[i * 3 + a] = static_cast<float>(std::exp(static_cast<double>(log_scale)));
  }
  // Smallest three: 2-bit index of the largest component (0 = w), the others as 10-bit unorm of
  // ±1/√2, in w x y z order.
  const double kNorm = std::sqrt(2.0);
  detail::decode_smallest_three(static_cast<int>(rot >> 30),
                                [&](int k) { return (((rot >> (20 - 10 * k)) & 1023) / 1023.0 - 0.5) * kNorm; },
                                &cloud->rotations[i * 4]);
  // Colour (8-8-8) and opacity (8): colour within the chunk's colour bounds when it has them.
  float* g_sh = cloud->sh.data() + i * k_count * 3;
  for (int c = 0; c < 3; ++c) {
    const double u = ((col >> (24 - 8 * c)) & 255) / 255.0;
    const double value = layout.chunk_colors ? lerp(b.lo[12 + c], b.lo[15 + c], u) : u;
    g_sh[c] = static_cast<float>((value - 0.5) / kShC0);
  }
  const double alpha = (col & 255) / 255.0;
  const double logit = alpha <= 0   ? -kMaxOpacityLogit
                       : alpha >= 1 ? kMaxOpacityLogit
                                    : std::clamp(-std::log(1.0 / alpha - 1.0), -kMaxOpacityLogit, kMaxOpacityLogit);
  const float stored_logit = static_cast<float>(logit);
  cloud->opacities[i] = static_cast<float>(1.0 / (1.0 + std::exp(-static_cast<double>(stored_logit))));
  if (rest) {
    // f_rest is channel-major: f_rest[c·rest + k − 1] is coefficient k of channel c.
    const uint8_t* sh_row = data + layout.sh.offset + i * layout.sh.stride;
    for (uint32_t c = 0; c < 3; ++c) {
      for (uint32_t k = 1; k <= rest; ++k) {
        g_sh[k * 3 + c] = sh_lut[sh_row[layout.sh_offsets[c * rest + k - 1]]];
      }
    }
  }
}

Result<InputScene> read_impl(const uint8_t* data, size_t size, const SceneReadOptions& options) {
  if (!detail::starts_with_ply_magic(data, size)) {
    return Status(StatusCode::kCorruptData, "not a PLY file (first line is not 'ply')");
  }
  const size_t header_end = detail::find_ply_header_end(data, std::min(size, detail::kMaxPlyHeaderBytes));
  if (header_end == 0) return Status(StatusCode::kCorruptData, "PLY header has no 'end_header' line");
  PlyHeader header;
  RGS_RETURN_IF_ERROR(detail::parse_ply_header(data, header_end, &header));
  if (header.storage != detail::PlyStorage::kBinaryLittleEndian) {
    return Status(StatusCode::kUnsupportedFeature, std::string("compressed PLY must be binary_little_endian, not ") +
                                                       detail::ply_storage_name(header.storage));
  }
  Layout layout;
  RGS_RETURN_IF_ERROR(locate_elements(header, size, options, &layout));
  RGS_RETURN_IF_ERROR(locate_properties(&layout));
  RGS_ASSIGN_OR_RETURN(const std::vector<ChunkBounds> bounds, read_chunk_bounds(data, layout));
  const uint64_t n = layout.n;

  InputScene scene;
  scene.cloud.sh_degree = layout.degree;
  detail::resize_cloud_huge(&scene.cloud, static_cast<size_t>(n));
  // 8-bit SH: 0 and 255 are the ends of the range exactly, the others bin centres.
  float sh_lut[256];
  for (int v = 0; v < 256; ++v) {
    const double unit = v == 0 ? 0.0 : v == 255 ? 1.0 : (v + 0.5) / 256.0;
    sh_lut[v] = static_cast<float>((unit - 0.5) * 8.0);
  }
  format::GaussianCloud* cloud = &scene.cloud;
  const unsigned workers = detail::worker_count(n, kMinGaussiansPerWorker);
  RGS_RETURN_IF_ERROR(detail::parallel_slices(n, workers, [&](unsigned, uint64_t begin, uint64_t end) {
    for (uint64_t i = begin; i < end; ++i) {
      decode_gaussian(data, layout, bounds[static_cast<size_t>(i / kGaussiansPerChunk)], sh_lut, i, cloud);
    }
  }));

  scene.format_id = "compressed_ply";
  scene.storage_format = "binary_little_endian";
  scene.description = "PlayCanvas compressed PLY";
  scene.file_bytes = size;
  scene.file_count = 1;
  scene.declared_vertices = n;
  if (options.hash_file) scene.file_xxh64 = XXH64(data, size, 0);
  return scene;
}

}  // namespace

Result<InputScene> read_compressed_ply_bytes(const uint8_t* data, size_t size, const std::string& name,
                                             const SceneReadOptions& options) {
  return detail::guarded<InputScene>(name, "decoding the compressed PLY",
                                     [&] { return read_impl(data, size, options); });
}

Result<InputScene> read_compressed_ply(const std::string& path, const SceneReadOptions& options) {
  std::vector<uint8_t> bytes;
  RGS_RETURN_IF_ERROR(detail::read_whole_file(path, kMaxFileBytes, &bytes));  // names the path
  return read_compressed_ply_bytes(bytes.data(), bytes.size(), path, options);
}

}  // namespace rgs::converter
