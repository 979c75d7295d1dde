// Input format detection and dispatch. To add a format: write a detector (content only, never the
// extension) and a reader, and add one row to kFormats; the "unsupported format" message lists the rows.
#include "rgs/converter/scene_reader.h"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "../internal_input_file.h"
#include "../internal_interop.h"
#include "../internal_json.h"
#include "internal_ply_header.h"
#include "../internal_zip.h"
#include "rgs/converter/gltf.h"
#include "rgs/converter/ksplat_reader.h"
#include "rgs/converter/playcanvas_readers.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/splat_reader.h"
#include "rgs/converter/spz.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include <xxhash.h>

namespace rgs::converter {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// Bytes read for detection (a PLY header longer than this is still detected as PLY by its first line).
constexpr size_t kHeadBytes = 64 * 1024;
/// JSON files larger than this are not parsed for detection.
constexpr uint64_t kMaxDetectJsonBytes = uint64_t{64} << 20;

/// What a detector sees of an input.
struct Probe {
  /// The file to read: `path` itself, or the meta file found in the directory `path`.
  std::string path;
  std::vector<uint8_t> head;  ///< the first kHeadBytes bytes (fewer for a shorter file)
  uint64_t size = 0;
  /// For a ZIP archive: the names of its entries (read from the central directory at its end), and why they
  /// could not be listed.
  std::vector<std::string> zip_entries;
  std::string zip_error;
  /// The whole file parsed as JSON, when it starts like a JSON object and parses.
  std::optional<json> json_root;
  std::string json_error;  ///< parse error when it starts like JSON but does not parse
};

bool head_starts_with(const Probe& p, const char* magic, size_t offset = 0) {
  const size_t n = std::strlen(magic);
  return p.head.size() >= offset + n && std::memcmp(p.head.data() + offset, magic, n) == 0;
}

// --- detectors ------------------------------------------------------------------------------------

/// The PLY header's elements, when the file is a PLY whose header fits the probe.
std::optional<detail::PlyHeader> ply_header(const Probe& p) {
  if (!detail::starts_with_ply_magic(p.head.data(), p.head.size())) return std::nullopt;
  const size_t end = detail::find_ply_header_end(p.head.data(), p.head.size());
  if (end == 0) return std::nullopt;
  detail::PlyHeader header;
  if (!detail::parse_ply_header(p.head.data(), end, &header).ok()) return std::nullopt;
  return header;
}

bool detect_compressed_ply(const Probe& p) {
  const auto header = ply_header(p);
  if (!header) return false;
  bool chunk = false, packed = false;
  for (const auto& e : header->elements) {
    chunk = chunk || e.name == "chunk";
    if (e.name != "vertex") continue;
    for (const auto& prop : e.properties) packed = packed || prop.name == "packed_position";
  }
  return chunk && packed;
}

/// Any other PLY goes to read_ply, which explains what is wrong with it if it is not a 3DGS scene.
bool detect_ply(const Probe& p) { return detail::starts_with_ply_magic(p.head.data(), p.head.size()); }

/// A ZIP archive with meta.json at its top level. One whose directory cannot be read goes to the bundle
/// reader too, which names the damage (a truncated .sog should say so, not "unsupported format").
bool detect_sog_bundle(const Probe& p) {
  if (!detail::has_zip_magic(p.head.data(), p.head.size())) return false;
  return !p.zip_error.empty() ||
         std::find(p.zip_entries.begin(), p.zip_entries.end(), "meta.json") != p.zip_entries.end();
}

bool json_has(const Probe& p, std::initializer_list<const char*> keys) {
  if (!p.json_root || !p.json_root->is_object()) return false;
  return std::all_of(keys.begin(), keys.end(), [&](const char* k) { return p.json_root->contains(k); });
}

/// "means" plus any other attribute group, so that a SOG meta missing a field gets the SOG reader's error.
bool detect_sog_meta(const Probe& p) {
  return json_has(p, {"means"}) && (json_has(p, {"quats"}) || json_has(p, {"scales"}) || json_has(p, {"sh0"}));
}

bool detect_sog_lod(const Probe& p) { return json_has(p, {"lodLevels", "filenames", "tree"}); }

/// A .rgs file (its magic).
bool detect_rgs(const Probe& p) {
  return p.head.size() >= 8 && std::memcmp(p.head.data(), format::kMagic, 8) == 0;
}

bool detect_spz(const Probe& p) { return looks_like_spz(p.head.data(), p.head.size()); }

bool detect_gltf(const Probe& p) { return looks_like_gltf(p.head.data(), p.head.size()); }

bool detect_ksplat(const Probe& p) { return looks_like_ksplat(p.head.data(), p.head.size(), p.size); }
bool detect_splat(const Probe& p) { return looks_like_splat(p.head.data(), p.head.size(), p.size); }

// --- readers not in playcanvas_readers.h ----------------------------------------------------------

/// kInvalidArgument when `options` asks for a level of detail of `path`, an input of the format `what`.
Status refuse_lod(const std::string& path, const SceneReadOptions& options, const std::string& what) {
  RGS_RETURN_ERROR_IF(options.lod.has_value(), StatusCode::kInvalidArgument,
                      path + ": a level of detail applies only to streamed SOG (lod-meta.json); this input is " +
                          what);
  return Status();
}

PlyReadOptions ply_read_options(const SceneReadOptions& options) {
  PlyReadOptions ply_options;
  ply_options.invalid_policy = options.invalid_policy;
  ply_options.max_gaussians = options.max_gaussians;
  ply_options.hash_file = options.hash_file;
  ply_options.keep_pre_activation = options.keep_pre_activation;
  return ply_options;
}

InputScene ply_input_scene(PlyScene ply, std::string path) {
  InputScene scene;
  scene.cloud = std::move(ply.cloud);
  scene.hygiene = ply.hygiene;
  scene.format_id = "ply";
  scene.description = ply.storage_format + " PLY";
  scene.storage_format = ply.storage_format;
  scene.file_bytes = ply.file_bytes;
  scene.file_count = 1;
  scene.declared_vertices = ply.declared_vertices;
  scene.files = {std::move(path)};
  scene.file_xxh64 = ply.file_xxh64;
  return scene;
}

Result<InputScene> read_ply_scene(const std::string& path, const SceneReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(PlyScene ply, read_ply(path, ply_read_options(options)));
  return ply_input_scene(std::move(ply), path);
}

/// Reads `path` with an InteropScene reader (SPZ, glTF, .splat, .ksplat) into an InputScene. An SPZ file is read
/// in the frame spz_frame_for() gives, and its scene notes which axes were taken.
template <Result<InteropScene> (*kRead)(const std::string&, const InteropReadOptions&)>
Result<InputScene> read_interop_scene(const std::string& path, const SceneReadOptions& options) {
  InteropReadOptions o;
  o.invalid_policy = options.invalid_policy;
  o.max_gaussians = options.max_gaussians;
  o.max_decompression_ratio = options.max_decompression_ratio;
  const bool spz = kRead == &read_spz;
  const SpzFrame frame = spz_frame_for(options, path);
  if (spz) o.convert_frame = frame == SpzFrame::kRub;
  RGS_ASSIGN_OR_RETURN(InteropScene interop, kRead(path, o));
  if (spz) {
    interop.notes.insert(interop.notes.begin(),
                         interop.frame_declared ? "SPZ axes declared by the file (coordinate-system extension: " +
                                                      interop.stored_frame + "), turned to RDF; no spz frame is assumed"
                                                : spz_frame_note(frame, /*writing=*/false));
  }
  const std::string& f = interop.format;
  std::string description = f == "spz"    ? "Niantic SPZ v" + std::to_string(interop.format_version)
                            : f == "glb"   ? "binary glTF (GLB) with KHR_gaussian_splatting"
                            : f == "gltf"  ? "glTF with KHR_gaussian_splatting"
                            : f == "splat" ? "antimatter15 .splat"
                                           : "GaussianSplats3D .ksplat v0.1";
  if (!interop.stored_frame.empty() && interop.stored_frame != "RDF") {
    description += interop.frame_converted ? " (stored " + interop.stored_frame + ", turned to RDF)"
                                           : " (axes as stored)";
  }
  InputScene scene;
  scene.cloud = std::move(interop.cloud);
  scene.hygiene = interop.hygiene;
  scene.format_id = interop.format;
  scene.storage_format = interop.format_version ? f + " v" + std::to_string(interop.format_version) : f;
  scene.description = std::move(description);
  scene.file_bytes = interop.file_bytes;
  scene.files = interop.files.empty() ? std::vector<std::string>{path} : std::move(interop.files);
  scene.file_count = scene.files.size();
  scene.declared_vertices = interop.declared_gaussians;
  scene.notes = std::move(interop.notes);
  if (options.hash_file) {
    RGS_ASSIGN_OR_RETURN(std::shared_ptr<const format::MappedFile> file, format::MappedFile::open(path));
    scene.file_xxh64 = XXH64(file->data(), file->size(), 0);
  }
  return scene;
}

/// A .rgs file in memory (mapped, or standard input's bytes): rgs_file_scene, and its XXH64 when asked for.
Result<InputScene> rgs_input_scene(const uint8_t* data, size_t size, const std::string& name,
                                   const SceneReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::from_bytes(data, size, rgs_read_options(options), name));
  RGS_ASSIGN_OR_RETURN(InputScene scene, rgs_file_scene(file, options));
  if (options.hash_file) scene.file_xxh64 = XXH64(data, size, 0);
  return scene;
}

Result<InputScene> read_rgs_scene(const std::string& path, const SceneReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(std::shared_ptr<const format::MappedFile> mapping, format::MappedFile::open(path));
  return rgs_input_scene(mapping->data(), mapping->size(), path, options);
}

// --- the table ------------------------------------------------------------------------------------

struct SceneFormat {
  const char* id;           ///< InputScene::format_id (the reader may refine it: "glb" or "gltf")
  const char* description;  ///< for "supported: ..." and help texts
  bool (*detect)(const Probe&);
  Result<InputScene> (*read)(const std::string& path, const SceneReadOptions& options);
};

/// First match wins: more specific detectors come before the general ones of the same family, and .ksplat and
/// .splat, which have no signature, come last.
const SceneFormat kFormats[] = {
    {"compressed_ply", "PlayCanvas compressed PLY (.compressed.ply)", detect_compressed_ply, read_compressed_ply},
    {"ply", "3DGS PLY (.ply, INRIA layout or any property order)", detect_ply, read_ply_scene},
    {"rgs", "RoofGS .rgs", detect_rgs, read_rgs_scene},
    {"sog_bundle", "PlayCanvas bundled SOG (.sog)", detect_sog_bundle, read_sog},
    {"sog", "PlayCanvas SOG (meta.json with its WebP images, or their folder)", detect_sog_meta, read_sog},
    {"sog_lod", "PlayCanvas streamed SOG (lod-meta.json, or its folder; --lod picks the level)", detect_sog_lod,
     read_sog_lod},
    {"spz", "Niantic SPZ v2-v4 (.spz)", detect_spz, read_interop_scene<read_spz>},
    {"gltf", "KHR_gaussian_splatting glTF (.glb, .gltf)", detect_gltf, read_interop_scene<read_gltf>},
    {"ksplat", "GaussianSplats3D .ksplat (compression levels 0-2)", detect_ksplat, read_interop_scene<read_ksplat>},
    {"splat", "antimatter15 .splat (32-byte records)", detect_splat, read_interop_scene<read_splat>},
};

std::string hex_bytes(const std::vector<uint8_t>& head, size_t n) {
  std::string s;
  char buf[4];
  for (size_t i = 0; i < std::min(n, head.size()); ++i) {
    std::snprintf(buf, sizeof(buf), "%02x", head[i]);
    s += (i ? " " : "") + std::string(buf);
  }
  return s;
}

/// What an input no reader accepts looks like, in words.
std::string describe_unknown(const Probe& p) {
  if (p.size == 0) return "an empty file";
  if (p.head.size() >= 2 && p.head[0] == 0x1f && p.head[1] == 0x8b) return "gzip data (an SPZ file before v4?)";
  if (head_starts_with(p, "glTF")) return "a binary glTF (.glb)";
  if (head_starts_with(p, "RIFF") && head_starts_with(p, "WEBP", 8)) return "a WebP image";
  if (head_starts_with(p, "\x89PNG")) return "a PNG image";
  if (detail::has_zip_magic(p.head.data(), p.head.size())) {
    std::string names;
    bool npy = !p.zip_entries.empty();
    for (size_t i = 0; i < p.zip_entries.size(); ++i) {
      const std::string& e = p.zip_entries[i];
      npy = npy && e.size() > 4 && e.compare(e.size() - 4, 4, ".npy") == 0;
      if (i < 6) names += (i ? ", " : "") + e;
    }
    if (p.zip_entries.size() > 6) names += ", ...";
    return std::string(npy ? "a NumPy .npz archive" : "a ZIP archive") + " without meta.json (entries: " + names + ")";
  }
  if (!p.json_error.empty()) return "a file that starts like JSON but does not parse (" + p.json_error + ")";
  if (p.json_root) {
    if (!p.json_root->is_object()) return std::string("a JSON ") + p.json_root->type_name();
    if (p.json_root->contains("asset") && p.json_root->contains("accessors")) return "a glTF JSON (.gltf)";
    std::string keys;
    size_t shown = 0;
    for (auto it = p.json_root->begin(); it != p.json_root->end() && shown < 8; ++it, ++shown) {
      keys += (keys.empty() ? "" : ", ") + it.key();
    }
    if (p.json_root->size() > shown) keys += ", ...";
    return "a JSON object with keys {" + keys + "}";
  }
  return "unrecognized data (first bytes: " + hex_bytes(p.head, 8) + ")";
}

Status unsupported(const std::string& path, const std::string& what) {
  std::string list;
  for (const std::string& f : supported_scene_formats()) list += (list.empty() ? "" : ", ") + f;
  return Status(StatusCode::kInvalidArgument, path + ": unsupported format: " + what + "; supported: " + list);
}

/// Fills `probe` for `path`, resolving a directory to the meta file inside it.
Status make_probe(const std::string& path, Probe* probe) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return Status(StatusCode::kIoError, path + ": " + detail::errno_message(errno));
  probe->path = path;
  if (S_ISDIR(st.st_mode)) {
    // The meta file inside a folder is a file the scene names: no link is followed to it (SceneFolder).
    probe->path.clear();
    for (const char* name : {"lod-meta.json", "meta.json"}) {
      struct stat meta;
      if (::lstat((fs::path(path) / name).c_str(), &meta) != 0) continue;
      probe->path = (fs::path(path) / name).string();
      if (S_ISLNK(meta.st_mode)) {
        return Status(StatusCode::kCorruptData, probe->path + ": is a symbolic link; files a scene names are not "
                                                              "followed through links (docs/INPUT_HYGIENE.md)");
      }
      break;
    }
    if (probe->path.empty()) return unsupported(path, "a directory without lod-meta.json or meta.json");
  }
  RGS_RETURN_IF_ERROR(detail::read_file_head(probe->path, kHeadBytes, &probe->head, &probe->size));
  if (detail::has_zip_magic(probe->head.data(), probe->head.size())) {
    auto names = detail::ZipArchive::list(probe->path);  // the end record and central directory only
    if (names.ok()) {
      probe->zip_entries = std::move(*names);
    } else {
      probe->zip_error = names.status().message();
    }
  }
  // JSON: an object, possibly after a UTF-8 byte order mark and whitespace.
  size_t i = 0;
  if (probe->head.size() >= 3 && probe->head[0] == 0xef && probe->head[1] == 0xbb && probe->head[2] == 0xbf) i = 3;
  while (i < probe->head.size() && std::strchr(" \t\r\n", probe->head[i]) != nullptr && probe->head[i] != 0) ++i;
  if (i < probe->head.size() && probe->head[i] == '{' && probe->size > kMaxDetectJsonBytes) {
    return Status(StatusCode::kLimitExceeded, probe->path + ": a JSON file of " + std::to_string(probe->size) +
                                                  " bytes, above the " + std::to_string(kMaxDetectJsonBytes >> 20) +
                                                  " MiB that scene JSON files (meta.json, lod-meta.json, .gltf) "
                                                  "may have");
  }
  if (i < probe->head.size() && probe->head[i] == '{') {
    std::vector<uint8_t> bytes;
    RGS_RETURN_IF_ERROR(detail::read_whole_file(probe->path, kMaxDetectJsonBytes, &bytes));
    auto root = detail::parse_scene_json(bytes.data() + i, bytes.size() - i, probe->path);
    if (root.ok()) {
      probe->json_root = std::move(root).value();
    } else {
      probe->json_error = root.status().message();
      // Nested too deep but JSON: its top-level keys still say which reader names the problem.
      auto outline = detail::parse_json_outline(bytes.data() + i, bytes.size() - i);
      if (outline.ok() && outline->is_object()) probe->json_root = std::move(outline).value();
    }
  }
  return Status();
}

Result<const SceneFormat*> detect(const std::string& path, Probe* probe) {
  RGS_RETURN_IF_ERROR(make_probe(path, probe));
  for (const SceneFormat& f : kFormats) {
    if (f.detect(*probe)) return &f;
  }
  // .ksplat and .splat have no signature, so a damaged one fails detection; a file named so gets the reader's reason.
  for (const SceneFormat& f : kFormats) {
    const bool unsigned_format = f.detect == detect_ksplat || f.detect == detect_splat;
    if (unsigned_format && probe->size > 0 && extension_of(probe->path) == "." + std::string(f.id)) return &f;
  }
  return unsupported(path, describe_unknown(*probe));
}

}  // namespace

std::string extension_of(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

SpzFrame spz_frame_for(const SceneReadOptions& options, const std::string& path) {
  if (options.spz_frame_by_path.empty()) return options.spz_frame;
  const std::filesystem::path wanted = std::filesystem::path(path).lexically_normal();
  for (const auto& [entry, frame] : options.spz_frame_by_path) {
    if (std::filesystem::path(entry).lexically_normal() == wanted) return frame;
  }
  return options.spz_frame;
}

format::ReadOptions rgs_read_options(const SceneReadOptions& options) {
  format::ReadOptions read_options;
  read_options.limits.max_gaussians = options.max_gaussians;
  read_options.limits.max_decompression_ratio = options.max_decompression_ratio;
  read_options.verify_checksums = options.verify_checksums;
  return read_options;
}

Result<InputScene> rgs_file_scene(const format::RgsFile& file, const SceneReadOptions& options) {
  const std::string& name = file.name();
  RGS_RETURN_IF_ERROR(refuse_lod(name, options, "a .rgs file"));
  auto encoded = file.read_scene();
  if (!encoded.ok()) return Status(encoded.status()).prepend(name);
  auto cloud = format::dequantize(*encoded);
  if (!cloud.ok()) return Status(cloud.status()).prepend(name);
  InputScene scene;
  scene.cloud = std::move(cloud).value();
  scene.bounds = file.metadata().bounds;
  if (options.keep_encoded) scene.encoded = std::move(encoded).value();
  scene.format_id = "rgs";
  const bool archive = (file.header().required_flags & format::kRequiredFlagArchiveCodecs) != 0;
  scene.description = archive ? "RoofGS .rgs, archive profile, decoded" : "RoofGS .rgs, dequantized";
  scene.storage_format = archive ? "rgs archive" : "rgs";
  scene.file_bytes = file.file_size();
  scene.file_count = 1;
  scene.files = {name};
  scene.declared_vertices = file.gaussian_count();
  if (std::string note = rgs_antialiased_note(file, options); !note.empty()) scene.notes.push_back(std::move(note));
  return scene;
}

std::string rgs_antialiased_note(const format::RgsFile& file, const SceneReadOptions& options) {
  if (!options.antialiased || file.metadata().antialiased) return std::string();
  return file.name() + ": antialiased (--antialiased) ignored: a .rgs file records whether its scene was trained "
                       "with the 2D Mip filter, and this one records that it was not";
}

Result<InputScene> read_scene(const std::string& path, const SceneReadOptions& options) {
  Probe probe;
  RGS_ASSIGN_OR_RETURN(const SceneFormat* format, detect(path, &probe));
  if (std::strcmp(format->id, "sog_lod") != 0) {
    RGS_RETURN_IF_ERROR(refuse_lod(probe.path, options, format->description));
  }
  RGS_ASSIGN_OR_RETURN(InputScene scene, format->read(probe.path, options));
  if (scene.format_id != "rgs") scene.bounds = compute_bounds(scene.cloud);
  if (options.antialiased && scene.format_id != "rgs") scene.cloud.antialiased = true;  // a .rgs says so itself
  return scene;
}

Result<InputScene> read_scene_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const SceneReadOptions& options) {
  if (size >= 8 && std::memcmp(data, format::kMagic, 8) == 0) return rgs_input_scene(data, size, name, options);
  RGS_RETURN_IF_ERROR(refuse_lod(name, options, "a PLY file"));
  RGS_ASSIGN_OR_RETURN(PlyScene ply, read_ply_bytes(data, size, name, ply_read_options(options)));
  InputScene scene = ply_input_scene(std::move(ply), name);
  scene.bounds = compute_bounds(scene.cloud);
  scene.cloud.antialiased = options.antialiased;
  return scene;
}

Result<std::string> detect_scene_format(const std::string& path) {
  Probe probe;
  RGS_ASSIGN_OR_RETURN(const SceneFormat* format, detect(path, &probe));
  if (std::strcmp(format->id, "gltf") == 0 && head_starts_with(probe, "glTF")) return std::string("glb");
  return std::string(format->id);
}

Result<std::vector<std::string>> list_scene_files(const std::string& path) {
  Probe probe;
  RGS_ASSIGN_OR_RETURN(const SceneFormat* format, detect(path, &probe));
  const std::string id = format->id;
  if (id == "sog") return detail::list_sog_files(probe.path);
  if (id == "sog_lod") return detail::list_sog_lod_files(probe.path);
  if (id == "gltf") return detail::list_gltf_files(probe.path);
  return std::vector<std::string>{probe.path};
}

namespace {

/// reduce_sh_degree and raise_sh_degree of a consistent cloud: each Gaussian's SH values move in place to the
/// stride of SH `degree`, the bands above it dropped (front to back: Gaussian i's values move to i * to, never
/// after i * from) or those the cloud lacks zeroed (back to front, once the array has grown).
Status resize_sh(format::GaussianCloud* cloud, uint32_t degree) {
  const size_t n = cloud->size();
  const size_t from = cloud->sh_coefficients() * 3;
  const size_t to = format::sh_coefficient_count(degree) * 3;
  for (size_t i = 1; to < from && i < n; ++i) {
    std::memmove(cloud->sh.data() + i * to, cloud->sh.data() + i * from, to * sizeof(float));
  }
  try {
    cloud->sh.resize(n * to);
    if (to < from) cloud->sh.shrink_to_fit();
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, "no memory for the SH array of " + std::to_string(n) +
                                                " Gaussians at SH degree " + std::to_string(degree));
  }
  float* sh = cloud->sh.data();
  for (size_t i = n; to > from && i-- > 0;) {
    std::memmove(sh + i * to, sh + i * from, from * sizeof(float));
    std::fill(sh + i * to + from, sh + (i + 1) * to, 0.0f);
  }
  cloud->sh_degree = degree;
  return Status();
}

}  // namespace

Status reduce_sh_degree(format::GaussianCloud* cloud, uint32_t degree) {
  RGS_RETURN_ERROR_IF(degree > 3, StatusCode::kInvalidArgument,
                      "SH degree " + std::to_string(degree) + " is above 3, the highest a cloud holds");
  RGS_RETURN_ERROR_IF(!cloud->is_consistent(), StatusCode::kInvalidArgument,
                      "reduce_sh_degree: the cloud's arrays disagree with its size and SH degree");
  return cloud->sh_degree <= degree ? Status() : resize_sh(cloud, degree);
}

Result<InputScene> scene_from_cloud(format::GaussianCloud cloud, const std::string& name,
                                    const SceneReadOptions& options) {
  RGS_RETURN_ERROR_IF(!cloud.is_consistent(), StatusCode::kInvalidArgument,
                      name + ": the arrays disagree with " + std::to_string(cloud.size()) +
                          " Gaussians at SH degree " + std::to_string(cloud.sh_degree));
  for (size_t i = 0; i < cloud.size(); ++i) {
    const float* s = &cloud.scales[i * 3];
    RGS_RETURN_ERROR_IF(s[0] < 0 || s[1] < 0 || s[2] < 0, StatusCode::kInvalidArgument,
                        name + ": Gaussian " + std::to_string(i) +
                            " has a negative scale (scales are linear, not log: exp() them first)");
    const float o = cloud.opacities[i];  // NaN: a non-finite value, for the hygiene rules below
    RGS_RETURN_ERROR_IF(o < 0 || o > 1, StatusCode::kInvalidArgument,
                        name + ": Gaussian " + std::to_string(i) +
                            " has an opacity outside [0, 1] (opacities are activated, not logits: sigmoid() them first)");
  }
  InputScene scene;
  scene.declared_vertices = cloud.size();
  Status values = detail::finish_hygiene(options.invalid_policy, "Gaussian", &cloud, &scene.hygiene);
  if (!values.ok()) return values.prepend(name);
  scene.cloud = std::move(cloud);
  if (options.antialiased) scene.cloud.antialiased = true;
  scene.bounds = compute_bounds(scene.cloud);
  scene.format_id = "arrays";
  scene.storage_format = "arrays";
  scene.description = "float Gaussians in memory";
  return scene;
}

std::vector<std::string> supported_scene_formats() {
  std::vector<std::string> out;
  for (const SceneFormat& f : kFormats) {
    out.emplace_back(f.description);
  }
  return out;
}

Status raise_sh_degree(format::GaussianCloud* cloud, uint32_t degree) {
  RGS_RETURN_ERROR_IF(degree > 3 || !cloud->is_consistent(), StatusCode::kInvalidArgument,
                      "raise_sh_degree: SH degree " + std::to_string(degree) + " above 3 or an inconsistent cloud");
  return cloud->sh_degree >= degree ? Status() : resize_sh(cloud, degree);
}

namespace {

/// `text` with `part` appended after " + ", unless it holds it already.
void join_distinct(const std::string& part, std::string* text) {
  if ((" + " + *text + " + ").find(" + " + part + " + ") == std::string::npos) {
    *text += (text->empty() ? "" : " + ") + part;
  }
}

}  // namespace

Result<InputScene> merge_scenes(std::vector<InputScene> scenes) {
  RGS_RETURN_ERROR_IF(scenes.empty(), StatusCode::kInvalidArgument, "merge_scenes: no scene to merge");
  if (scenes.size() == 1) return std::move(scenes.front());
  InputScene out;
  std::vector<uint64_t> hashes;
  const auto name = [](const InputScene& s) { return s.files.empty() ? s.description : s.files.front(); };
  for (InputScene& s : scenes) {
    out.cloud.sh_degree = std::max(out.cloud.sh_degree, s.cloud.sh_degree);
    const bool aa = s.cloud.antialiased, first_aa = scenes.front().cloud.antialiased;
    RGS_RETURN_ERROR_IF(aa != first_aa, StatusCode::kInvalidArgument,
                        name(scenes.front()) + (first_aa ? " is" : " is not") + " anti-aliased (trained with the 2D "
                        "Mip filter) and " + name(s) + (aa ? " is" : " is not") + ": the filter's opacity "
                        "compensation depends on the view, so one scene cannot render both as trained; merge scenes "
                        "of one kind (--antialiased sets the flag of inputs that cannot carry it)");
  }
  out.cloud.antialiased = scenes.front().cloud.antialiased;
  format::GaussianCloud& c = out.cloud;
  size_t total = 0;
  for (const InputScene& s : scenes) total += s.cloud.size();
  const size_t to = c.sh_coefficients() * 3;
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&]() -> Status {
    // Sized once and each input freed once copied: the peak is the merged scene and the inputs not yet copied
    // (each widened as it is copied, not in place).
    c.means.reserve(total * 3);
    c.rotations.reserve(total * 4);
    c.scales.reserve(total * 3);
    c.opacities.reserve(total);
    c.sh.reserve(total * to);
    for (InputScene& s : scenes) {
      RGS_RETURN_ERROR_IF(!s.cloud.is_consistent(), StatusCode::kInvalidArgument,
                          "merge_scenes: " + name(s) + "'s arrays disagree with its size and SH degree");
      c.means.insert(c.means.end(), s.cloud.means.begin(), s.cloud.means.end());
      c.rotations.insert(c.rotations.end(), s.cloud.rotations.begin(), s.cloud.rotations.end());
      c.scales.insert(c.scales.end(), s.cloud.scales.begin(), s.cloud.scales.end());
      c.opacities.insert(c.opacities.end(), s.cloud.opacities.begin(), s.cloud.opacities.end());
      const size_t from = s.cloud.sh_coefficients() * 3;
      for (size_t i = 0; i < s.cloud.size(); ++i) {  // the bands the input lacks zero, as raise_sh_degree
        c.sh.insert(c.sh.end(), s.cloud.sh.begin() + i * from, s.cloud.sh.begin() + (i + 1) * from);
        c.sh.resize(c.sh.size() + to - from, 0.0f);
      }
      s.cloud = format::GaussianCloud();
    }
    return Status();
  }, [] { return "merge_scenes: no memory for the merged scene"; }));
  for (InputScene& s : scenes) {
    detail::add_hygiene(s.hygiene, out.declared_vertices, &out.hygiene);
    join_distinct(s.format_id, &out.format_id);
    join_distinct(s.description, &out.description);
    join_distinct(s.storage_format, &out.storage_format);
    out.file_bytes += s.file_bytes;
    out.file_count += s.file_count;
    out.declared_vertices += s.declared_vertices;
    out.files.insert(out.files.end(), s.files.begin(), s.files.end());
    for (const std::string& note : s.notes) out.notes.push_back(name(s) + ": " + note);
    if (s.file_xxh64) hashes.push_back(*s.file_xxh64);
  }
  if (hashes.size() == scenes.size()) out.file_xxh64 = detail::combine_hashes(hashes);
  out.bounds = compute_bounds(out.cloud);
  return out;
}

namespace detail {

void add_hygiene(const InputHygiene& part, uint64_t offset, InputHygiene* total) {
  total->nonfinite_values += part.nonfinite_values;
  total->gaussians_with_nonfinite += part.gaussians_with_nonfinite;
  total->zero_norm_quaternions += part.zero_norm_quaternions;
  total->infinite_opacity_logits += part.infinite_opacity_logits;
  total->dropped_gaussians += part.dropped_gaussians;
  if (total->first_invalid_index < 0 && part.first_invalid_index >= 0) {
    total->first_invalid_index = part.first_invalid_index + static_cast<int64_t>(offset);
  }
}

uint64_t combine_hashes(const std::vector<uint64_t>& hashes) {
  std::vector<uint8_t> bytes;
  bytes.reserve(hashes.size() * 8);
  for (uint64_t h : hashes) {
    for (int b = 0; b < 8; ++b) bytes.push_back(static_cast<uint8_t>(h >> (8 * b)));
  }
  return XXH64(bytes.data(), bytes.size(), 0);
}

}  // namespace detail

}  // namespace rgs::converter
