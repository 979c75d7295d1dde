// Serializes an EncodedScene, or a StreamedScene section by section, into .rgs bytes (SPEC.md §2–§4, §7).
#include "rgs/format/writer.h"

#include <fcntl.h>
#include <unistd.h>
#include <xxhash.h>
#include <zstd.h>

#include <cerrno>
#include <cstring>

#include <algorithm>
#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "internal_archive.h"
#include "internal_bytes.h"
#include "internal_lod.h"
#include "internal_sections.h"
#include "rgs/format/file_io.h"

namespace rgs::format {
namespace detail {

void encode_metadata(const SceneMetadata& m, uint8_t* out) {
  ByteWriter w(out, kMetadataSize);
  w.put_u32(m.sh_degree);
  w.put_u8(static_cast<uint8_t>(m.frame));
  w.put_u8(static_cast<uint8_t>(m.quaternion_order));
  w.put_u8(static_cast<uint8_t>(m.scale_encoding));
  w.put_u8(static_cast<uint8_t>(m.opacity_encoding));
  w.put_u8(static_cast<uint8_t>(m.sh_layout));
  w.put_zeros(7);
  for (float v : m.bounds.aabb_min) w.put_f32(v);
  for (float v : m.bounds.aabb_max) w.put_f32(v);
  for (float v : m.bounds.sphere_center) w.put_f32(v);
  w.put_f32(m.bounds.sphere_radius);
  w.put_u32(m.sh_quantization.bits);
  w.put_f32(m.sh_quantization.clip_percentile);
  for (const auto& row : m.sh_quantization.scales) {
    for (float v : row) w.put_f32(v);
  }
  w.put_zeros(16);
}

bool provenance_size(const Provenance& provenance, uint64_t* size, std::string* why) {
  if (provenance.size() > UINT32_MAX) {
    *why = "provenance has " + dec(provenance.size()) + " entries, more than a u32 count holds";
    return false;
  }
  uint64_t total = 4;
  for (size_t i = 0; i < provenance.size(); ++i) {
    const auto& [key, value] = provenance[i];
    if (key.size() > UINT32_MAX || value.size() > UINT32_MAX) {
      *why = "provenance entry " + dec(i) + " has a key or value longer than a u32 length holds";
      return false;
    }
    if (!checked_add(total, 8, &total) || !checked_add(total, key.size(), &total) ||
        !checked_add(total, value.size(), &total)) {
      *why = "provenance size overflows 64 bits";
      return false;
    }
  }
  *size = total;
  return true;
}

void encode_provenance(const Provenance& provenance, uint8_t* out, size_t size) {
  ByteWriter w(out, size);
  w.put_u32(static_cast<uint32_t>(provenance.size()));
  for (const auto& [key, value] : provenance) {
    w.put_u32(static_cast<uint32_t>(key.size()));
    w.put_bytes(key.data(), key.size());
    w.put_u32(static_cast<uint32_t>(value.size()));
    w.put_bytes(value.data(), value.size());
  }
}

Status check_zstd_level(int level) {
  RGS_RETURN_ERROR_IF(level < 1 || level > ZSTD_maxCLevel(), StatusCode::kInvalidArgument,
                      "zstd level " + std::to_string(level) + " outside 1.." + std::to_string(ZSTD_maxCLevel()));
  return Status();
}

Status compress_zstd_frame(const uint8_t* raw, size_t size, int level, uint32_t workers, std::vector<uint8_t>* out) {
  std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> cctx(ZSTD_createCCtx(), ZSTD_freeCCtx);
  if (!cctx) return Status(StatusCode::kOutOfMemory, "cannot create a zstd compression context");
  // §7 Content size and checksum in every frame (self-checking); jobs of a fixed size, so that the bytes do not
  // depend on the workers. Each worker holds a compression context: no more of them than the frame has jobs.
  const size_t jobs = std::max<size_t>(1, (size + kZstdJobBytes - 1) / kZstdJobBytes);
  const int threads = static_cast<int>(std::clamp<size_t>(workers, 1, std::min<size_t>(jobs, 256)));
  for (auto [param, value] : {std::pair{ZSTD_c_compressionLevel, level}, std::pair{ZSTD_c_checksumFlag, 1},
                              std::pair{ZSTD_c_contentSizeFlag, 1}}) {
    const size_t r = ZSTD_CCtx_setParameter(cctx.get(), param, value);
    if (ZSTD_isError(r)) {
      return Status(StatusCode::kInvalidArgument, std::string("zstd parameter rejected: ") + ZSTD_getErrorName(r));
    }
  }
  // A zstd library built without threads refuses workers and writes the frame single-threaded (other bytes).
  if (!ZSTD_isError(ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_nbWorkers, threads))) {
    for (auto [param, value] : {std::pair{ZSTD_c_jobSize, static_cast<int>(kZstdJobBytes)},
                                std::pair{ZSTD_c_overlapLog, kZstdOverlapLog}}) {
      const size_t r = ZSTD_CCtx_setParameter(cctx.get(), param, value);
      if (ZSTD_isError(r)) {
        return Status(StatusCode::kInvalidArgument, std::string("zstd job parameter rejected: ") +
                                                        ZSTD_getErrorName(r));
      }
    }
  }
  const size_t start = out->size();
  const size_t bound = ZSTD_compressBound(size);
  if (ZSTD_isError(bound)) return Status(StatusCode::kInvalidArgument, dec(size) + " bytes are too large for zstd");
  out->resize(start + bound);
  const size_t n = ZSTD_compress2(cctx.get(), out->data() + start, bound, raw, size);
  if (ZSTD_isError(n)) {
    return Status(StatusCode::kOutOfMemory, std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
  }
  out->resize(start + n);
  out->shrink_to_fit();  // the bound can be twice the frame; the section is kept until the file is written
  return Status();
}

uint32_t threads_per_job(uint32_t threads, size_t jobs) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  const size_t n = std::max<size_t>(jobs, 1);
  return static_cast<uint32_t>((threads + n - 1) / n);
}

Status run_jobs(std::vector<std::function<Status()>>& jobs, uint32_t threads, const char* what) {
  std::vector<Status> results(jobs.size());
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t j; (j = next.fetch_add(1)) < jobs.size();) {
      try {  // nothing may escape a thread: error messages allocate
        results[j] = jobs[j]();
      } catch (const std::exception&) {
        results[j] = Status(StatusCode::kOutOfMemory, std::string("out of memory ") + what);
      }
    }
  };
  threads = static_cast<uint32_t>(std::min<size_t>(threads_per_job(threads, 1), jobs.size()));
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error&) {
      break;
    }
  }
  worker();
  for (std::thread& t : pool) t.join();
  for (const Status& s : results) RGS_RETURN_IF_ERROR(s);
  return Status();
}

}  // namespace detail

namespace {

using detail::ByteWriter;
using detail::dec;

/// One section as it will be written: raw bytes (a view into the scene, or owned when they had to be
/// encoded; null when a StreamedScene produces them as the file is written), the zstd or archive-coded frame
/// when compressed, and its place in the file.
struct PlannedSection {
  SectionId id{};
  Codec codec = Codec::kNone;
  ElementType element_type = ElementType::kBytes;
  uint32_t components = 1;
  uint64_t element_count = 0;
  const uint8_t* raw = nullptr;
  uint64_t raw_size = 0;
  std::vector<uint8_t> owned_raw;
  std::vector<uint8_t> compressed;
  uint64_t offset = 0;

  const uint8_t* stored() const { return codec != Codec::kNone ? compressed.data() : raw; }
  uint64_t stored_size() const { return codec != Codec::kNone ? compressed.size() : raw_size; }
  bool streamed() const { return raw == nullptr && raw_size > 0; }
};

/// A file ready to be written: its sections in §4 order with their offsets, and what its header (§2) holds.
struct PlannedFile {
  std::vector<PlannedSection> sections;
  SceneMetadata metadata;
  uint64_t count = 0;
  uint32_t required_flags = 0;
  FormatVersion version;
  uint64_t table_end = 0, file_size = 0;
  /// Produces the bytes of the streamed sections (StreamedScene::produce); unset for an in-memory scene.
  std::function<Status(SectionId, const ChunkSink&)> produce;
};

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidArgument, message); }

/// The writer refuses anything validate() would reject, so every file it writes passes --check.
/// Array shapes and metadata; the values are checked by check_values().
Status check_scene_shape(const EncodedScene& scene) {
  if (Status s = detail::check_metadata(scene.metadata); !s.ok()) return invalid("metadata: " + s.message());
  if (!scene.is_consistent()) {
    const uint64_t k = sh_coefficient_count(scene.metadata.sh_degree);
    return invalid("encoded scene arrays do not match count " + dec(scene.count) + " and SH degree " +
                   dec(scene.metadata.sh_degree) + ": means " + dec(scene.means.size()) + " (expected " +
                   dec(scene.count * 3) + "), rotations " + dec(scene.rotations.size()) + " (" +
                   dec(scene.count * 4) + "), scales " + dec(scene.scales.size()) + " (" + dec(scene.count * 3) +
                   "), opacities " + dec(scene.opacities.size()) + " (" + dec(scene.count) + "), sh " +
                   dec(scene.sh.size()) + " (" + dec(scene.count * k * 3) + "), sh_dc_residual " +
                   dec(scene.sh_dc_residual.size()) + " (0 or " + dec(scene.count * 3) + ")");
  }
  return Status();
}

Status check_options(const WriteOptions& options) {
  RGS_RETURN_IF_ERROR(detail::check_zstd_level(options.zstd_level));
  for (const auto& [id, codec] : options.codecs) {
    if (!detail::is_known_section(id)) {
      return invalid("codec requested for unknown section id " + dec(static_cast<uint32_t>(id)));
    }
    if (codec != Codec::kNone && codec != Codec::kZstd) {
      return invalid("unknown codec " + dec(static_cast<uint16_t>(codec)) + " requested for section " +
                     section_name(id));
    }
    detail::SectionLayout layout;
    (void)detail::expected_layout(id, 0, &layout);
    if (options.lod != nullptr && layout.per_gaussian && codec != Codec::kNone) {
      return invalid(std::string("a level-of-detail file stores section ") + section_name(id) +
                     " raw (SPEC 4.9), not with " + codec_name(codec));
    }
  }
  if (options.lod != nullptr && options.profile != StorageProfile::kRuntime) {
    return invalid("a level-of-detail file stores the runtime profile (SPEC 4.9), not the archive profile");
  }
  return Status();
}

/// Appends section `id` of `count` elements (SPEC §3.1 layout of a scene of SH degree `sh_degree`, raw_size
/// from it) to `plan`, with the codec `options` asks for; its bytes are set by the caller.
PlannedSection& add_section(SectionId id, uint64_t count, uint32_t sh_degree, const WriteOptions& options,
                            std::vector<PlannedSection>* plan) {
  PlannedSection& s = plan->emplace_back();
  detail::SectionLayout layout;
  (void)detail::expected_layout(id, sh_degree, &layout);  // every id added here is known
  s.id = id;
  s.element_type = layout.element_type;
  s.components = layout.components;
  s.element_count = count;
  s.raw_size = count * layout.components * element_type_size(layout.element_type);
  const auto it = options.codecs.find(id);
  s.codec = it == options.codecs.end() ? Codec::kNone : it->second;
  return s;
}

/// Appends a section whose raw bytes are `bytes` (owned by the section).
void add_owned_section(SectionId id, std::vector<uint8_t> bytes, const WriteOptions& options, PlannedFile* file) {
  PlannedSection& s = add_section(id, bytes.size(), 0, options, &file->sections);
  s.owned_raw = std::move(bytes);
  s.raw = s.owned_raw.data();
}

/// Starts the plan of a scene of `count` Gaussians: the options and metadata checked, then the sections in §4
/// order, metadata, provenance (only when non-empty), means, rotations, scales, opacities, sh and, with
/// `residual`, sh_dc_residual, the per-Gaussian ones without their bytes.
Status plan_sections(const SceneMetadata& metadata, const Provenance& provenance, uint64_t count, bool residual,
                     const WriteOptions& options, PlannedFile* file) {
  RGS_RETURN_IF_ERROR(check_options(options));
  if (Status s = detail::check_metadata(metadata); !s.ok()) return invalid("metadata: " + s.message());
  uint64_t provenance_bytes = 0;
  std::string why;
  if (!detail::provenance_size(provenance, &provenance_bytes, &why)) return invalid(why);
  file->metadata = metadata;
  file->count = count;
  file->required_flags = metadata.antialiased ? kRequiredFlagAntialiased : 0;
  file->sections.reserve(9);
  std::vector<uint8_t> bytes(kMetadataSize);
  detail::encode_metadata(metadata, bytes.data());
  add_owned_section(SectionId::kMetadata, std::move(bytes), options, file);
  if (!provenance.empty()) {
    bytes.assign(static_cast<size_t>(provenance_bytes), 0);
    detail::encode_provenance(provenance, bytes.data(), bytes.size());
    add_owned_section(SectionId::kProvenance, std::move(bytes), options, file);
  }
  for (SectionId id : detail::kGaussianSections) {
    if (id != SectionId::kShDcResidual || residual) add_section(id, count, metadata.sh_degree, options, &file->sections);
  }
  return Status();
}

/// The planned section `id`, or null.
PlannedSection* find_section(PlannedFile* file, SectionId id) {
  for (PlannedSection& s : file->sections) {
    if (s.id == id) return &s;
  }
  return nullptr;
}

/// Points a section at a typed array's raw little-endian bytes: the array itself on little-endian
/// hosts, an encoded copy otherwise.
template <typename T>
void set_array_raw(PlannedSection* s, const std::vector<T>& values) {
  if constexpr (detail::kHostLittleEndian || sizeof(T) == 1) {
    s->raw = reinterpret_cast<const uint8_t*>(values.data());
  } else {
    s->owned_raw.resize(s->raw_size);
    ByteWriter w(s->owned_raw.data(), s->owned_raw.size());
    for (T v : values) {
      if constexpr (sizeof(T) == 2) {
        w.put_u16(v);
      } else {
        w.put_f32(v);
      }
    }
    s->raw = s->owned_raw.data();
  }
}

/// Plans the sections of an in-memory `scene` (its shape checked) with their bytes: views of its arrays.
Status plan_scene(const EncodedScene& scene, bool residual, const WriteOptions& options, PlannedFile* file) {
  RGS_RETURN_IF_ERROR(check_scene_shape(scene));
  RGS_RETURN_IF_ERROR(plan_sections(scene.metadata, scene.provenance, scene.count, residual, options, file));
  set_array_raw(find_section(file, SectionId::kMeans), scene.means);
  set_array_raw(find_section(file, SectionId::kRotations), scene.rotations);
  set_array_raw(find_section(file, SectionId::kScales), scene.scales);
  set_array_raw(find_section(file, SectionId::kOpacities), scene.opacities);
  set_array_raw(find_section(file, SectionId::kSh), scene.sh);
  if (residual) set_array_raw(find_section(file, SectionId::kShDcResidual), scene.sh_dc_residual);
  return Status();
}

/// §4.3–§4.7 Checks the values of every per-Gaussian section of `file` that has its bytes, as the reader does
/// (check_records: the first bad Gaussian of the first section that has one), as kInvalidArgument.
Status check_values(const PlannedFile& file) {
  for (const PlannedSection& s : file.sections) {
    if (s.raw == nullptr || s.element_count == 0) continue;  // check_records passes other sections
    const uint64_t record = s.raw_size / s.element_count;
    Status st = detail::check_records(s.id, file.metadata, s.raw, static_cast<size_t>(s.element_count),
                                      static_cast<size_t>(record), 0);
    if (!st.ok()) return invalid(st.message());
  }
  return Status();
}

/// §4.9 Adds the lod section of `index` after the runtime sections of `file`: the index's structure checked
/// against the scene and, when the sections have their bytes, each range's values and chunk sphere checked and
/// its checksum computed, split over two threads by range; the checksums of `index` are kept otherwise.
/// Errors are kInvalidArgument naming the chunk and level.
Status add_lod_section(const LodIndex& index, const WriteOptions& options, PlannedFile* file) {
  if (Status s = detail::check_lod_structure(index, file->count); !s.ok()) return invalid(s.message());
  file->required_flags |= kRequiredFlagLod;
  const PlannedSection* means = find_section(file, SectionId::kMeans);
  if (means->streamed()) {
    add_owned_section(SectionId::kLod, detail::encode_lod(index), options, file);
    return Status();
  }
  std::array<const uint8_t*, 6> parts{};
  for (size_t a = 0; a < 6; ++a) {
    if (const PlannedSection* s = find_section(file, detail::kGaussianSections[a])) parts[a] = s->raw;
  }
  LodIndex checked = index;
  const size_t records = checked.levels.size();
  auto check_records = [&](size_t begin, size_t end) {
    for (size_t r = begin; r < end; ++r) {
      const uint32_t level = static_cast<uint32_t>(r / checked.chunk_count);
      const uint32_t chunk = static_cast<uint32_t>(r % checked.chunk_count);
      LodLevel& v = checked.levels[r];
      const LodRangeView range = detail::lod_range_view(parts, v.first, v.count, file->metadata.sh_degree);
      Status s = detail::check_lod_range(checked, level, chunk, range, file->metadata, false);
      if (!s.ok()) return invalid(s.message());
      v.checksum = detail::lod_range_checksum(range);
    }
    return Status();
  };
  std::vector<std::function<Status()>> halves = {[&] { return check_records(0, records / 2); },
                                                 [&] { return check_records(records / 2, records); }};
  RGS_RETURN_IF_ERROR(detail::run_jobs(halves, 2, "checking the level-of-detail ranges"));
  add_owned_section(SectionId::kLod, detail::encode_lod(checked), options, file);
  return Status();
}

/// §3.3 Gives the per-Gaussian sections of `file`, in the order means, rotations, scales, opacities, sh, the
/// archive codecs and `archive`'s stored bytes (moved out), and sets the flags they need; an empty scene keeps
/// codec none (nothing to code).
void use_archive_codecs(ArchiveScene* archive, PlannedFile* file) {
  if (file->count == 0) return;
  const SectionId ids[5] = {SectionId::kMeans, SectionId::kRotations, SectionId::kScales, SectionId::kOpacities,
                            SectionId::kSh};
  for (size_t i = 0; i < 5; ++i) {
    PlannedSection& s = *find_section(file, ids[i]);
    s.codec = i == 0 ? Codec::kDraco : Codec::kQuantized;
    s.compressed = std::move(archive->stored[i]);
    if (i > 0 && detail::quantized_codes_are_xz(s.compressed.data(), s.compressed.size())) {
      file->required_flags |= kRequiredFlagXzCodes;
    }
  }
  file->required_flags |= kRequiredFlagArchiveCodecs;
  // §2.2 The sh section's first byte is its transform (§3.3.2).
  if (find_section(file, SectionId::kSh)->compressed[0] ==
      static_cast<uint8_t>(detail::QuantizedTransform::kShColourDifferences)) {
    file->required_flags |= kRequiredFlagShColourDifferences;
  }
}

/// §6 The oldest version that has every feature `file` uses.
FormatVersion file_version(const PlannedFile& file) {
  FormatVersion version{kFormatMajor, 0};
  auto require = [&version](FormatVersion v) {
    if (!version_at_least(version, v)) version = v;
  };
  const uint32_t flags = file.required_flags;
  if (file.metadata.scale_encoding == ScaleEncoding::kLog) require(kMinVersionForLogScales);
  if (flags & kRequiredFlagArchiveCodecs) require(kMinVersionForArchiveCodecs);
  if (flags & kRequiredFlagLod) require(kMinVersionForLod);
  if (flags & kRequiredFlagShColourDifferences) require(kMinVersionForShColourDifferences);
  if (flags & kRequiredFlagXzCodes) require(kMinVersionForXzCodes);
  if (flags & kRequiredFlagAntialiased) require(kMinVersionForAntialiased);
  for (const PlannedSection& s : file.sections) {
    if (s.id == SectionId::kProvenance) require(kMinVersionForProvenance);
    if (s.id == SectionId::kShDcResidual) require(kMinVersionForShDcResidual);
    if (s.codec == Codec::kZstd) require(kMinVersionForZstdCodec);
  }
  return version;
}

/// Compresses every zstd section of `plan`, the sections at the same time, the threads shared among them.
Status compress_sections(const WriteOptions& options, std::vector<PlannedSection>* plan) {
  const size_t sections =
      std::count_if(plan->begin(), plan->end(), [](const PlannedSection& s) { return s.codec == Codec::kZstd; });
  const uint32_t workers = detail::threads_per_job(options.threads, sections);
  std::vector<std::function<Status()>> jobs;
  for (PlannedSection& s : *plan) {
    if (s.codec != Codec::kZstd) continue;
    jobs.push_back([&options, &s, workers] {
      Status st = detail::compress_zstd_frame(s.raw, static_cast<size_t>(s.raw_size), options.zstd_level, workers,
                                              &s.compressed);
      return st.ok() ? st : st.prepend(std::string("section ") + section_name(s.id));
    });
  }
  return detail::run_jobs(jobs, options.threads, "compressing sections");
}

/// Ends the plan of `file`: its version, the zstd sections compressed and the §3 layout, the table after the
/// header and each section at the next multiple of kSectionAlignment.
Status finish_plan(const WriteOptions& options, PlannedFile* file) {
  file->version = file_version(*file);
  RGS_RETURN_IF_ERROR(compress_sections(options, &file->sections));
  file->table_end = kHeaderSize + uint64_t{kSectionEntrySize} * file->sections.size();
  uint64_t end = file->table_end;
  for (PlannedSection& s : file->sections) {
    if (!detail::checked_align_up(end, kSectionAlignment, &s.offset) ||
        !checked_add(s.offset, s.stored_size(), &end)) {
      return invalid("file size overflows 64 bits");
    }
  }
  if (end > SIZE_MAX) return Status(StatusCode::kOutOfMemory, "file of " + dec(end) + " bytes exceeds memory");
  file->file_size = end;
  return Status();
}

/// Checks `scene` and `options` and lays the file out: everything but writing the section bytes. With the
/// archive profile, `archive` receives the archive-coded scene, whose decoded arrays the plan points into.
Status plan_file(const EncodedScene& scene, const WriteOptions& options, std::optional<ArchiveScene>* archive,
                 PlannedFile* file) {
  RGS_RETURN_IF_ERROR(check_options(options));
  const EncodedScene* planned = &scene;
  if (options.profile == StorageProfile::kArchive) {
    PlannedFile source;
    RGS_RETURN_IF_ERROR(plan_scene(scene, !scene.sh_dc_residual.empty(), options, &source));
    RGS_RETURN_IF_ERROR(check_values(source));
    RGS_ASSIGN_OR_RETURN(ArchiveScene encoded, encode_archive(scene, options.archive, options.archive_earlier));
    planned = &archive->emplace(std::move(encoded)).decoded;
  }
  // §4.8 The archive stores the DC term at its INT8 step (times its multiplier), without the residual.
  const bool residual = !planned->sh_dc_residual.empty() && !archive->has_value();
  RGS_RETURN_IF_ERROR(plan_scene(*planned, residual, options, file));
  RGS_RETURN_IF_ERROR(check_values(*file));
  if (archive->has_value()) use_archive_codecs(&**archive, file);
  if (options.lod != nullptr) RGS_RETURN_IF_ERROR(add_lod_section(*options.lod, options, file));
  return finish_plan(options, file);
}

/// Encodes the header (§2) and the section table (§3.1) of a laid-out `file` whose sections have the
/// `checksums`, table_end bytes.
std::vector<uint8_t> encode_head(const PlannedFile& file, const std::vector<uint64_t>& checksums) {
  std::vector<uint8_t> head(static_cast<size_t>(file.table_end));  // zero-filled: reserved fields
  ByteWriter header(head.data(), kHeaderSize);
  for (uint8_t b : kMagic) header.put_u8(b);
  header.put_u16(file.version.major);
  header.put_u16(file.version.minor);
  header.put_u32(kHeaderSize);
  header.put_u32(file.required_flags);  // §2.2
  header.put_u32(0);  // optional flags
  header.put_u64(file.count);
  header.put_u32(static_cast<uint32_t>(file.sections.size()));
  header.put_u32(0);  // reserved
  header.put_u64(kHeaderSize);  // table offset
  header.put_u64(file.file_size);
  ByteWriter table(head.data() + kHeaderSize, head.size() - kHeaderSize);
  for (size_t i = 0; i < file.sections.size(); ++i) {
    const PlannedSection& s = file.sections[i];
    table.put_u32(static_cast<uint32_t>(s.id));
    table.put_u16(static_cast<uint16_t>(s.codec));
    table.put_u16(static_cast<uint16_t>(s.element_type));
    table.put_u32(s.components);
    table.put_u32(0);  // reserved
    table.put_u64(s.element_count);
    table.put_u64(s.offset);
    table.put_u64(s.stored_size());
    table.put_u64(s.raw_size);
    table.put_u64(checksums[i]);
    table.put_u64(0);  // reserved
  }
  header.put_u64(detail::header_checksum(head.data(), head.data() + kHeaderSize, head.size() - kHeaderSize));
  return head;
}

/// Writes `size` bytes at byte `offset` of the file being written.
using WriteAt = std::function<Status(uint64_t offset, const void* data, size_t size)>;

/// Writes the planned `file` through `write_at`: each section at its offset (a streamed one from file.produce,
/// its values checked and its checksum computed as it comes), then the header and table with the checksums.
/// The padding between sections is left to the destination, which holds zeros there.
Status emit_file(const PlannedFile& file, const WriteAt& write_at) {
  std::vector<uint64_t> checksums;
  for (const PlannedSection& section : file.sections) {
    if (!section.streamed()) {
      RGS_RETURN_IF_ERROR(write_at(section.offset, section.stored(), static_cast<size_t>(section.stored_size())));
      checksums.push_back(detail::xxh64(section.stored(), section.stored_size()));
      continue;
    }
    std::unique_ptr<XXH64_state_t, decltype(&XXH64_freeState)> hash(XXH64_createState(), XXH64_freeState);
    if (!hash) return Status(StatusCode::kOutOfMemory, "cannot allocate an XXH64 state");
    XXH64_reset(hash.get(), 0);
    const uint64_t width = section.raw_size / file.count;
    uint64_t written = 0;
    const Status produced = file.produce(section.id, [&](const void* data, size_t size) -> Status {
      const auto* bytes = static_cast<const uint8_t*>(data);
      RGS_RETURN_ERROR_IF(size % width != 0 || written + size > section.raw_size, StatusCode::kInvalidArgument,
                          std::string("internal error: section ") + section_name(section.id) +
                              " streamed in pieces that are not whole elements or past its size");
      Status s = detail::check_records(section.id, file.metadata, bytes, size / width, width, written / width);
      if (!s.ok()) return invalid(s.message());
      XXH64_update(hash.get(), bytes, size);
      RGS_RETURN_IF_ERROR(write_at(section.offset + written, bytes, size));
      written += size;
      return Status();
    });
    RGS_RETURN_IF_ERROR(produced);
    RGS_RETURN_ERROR_IF(written != section.raw_size, StatusCode::kInvalidArgument,
                        std::string("internal error: section ") + section_name(section.id) + " streamed " +
                            dec(written) + " bytes of " + dec(section.raw_size));
    checksums.push_back(static_cast<uint64_t>(XXH64_digest(hash.get())));
  }
  const std::vector<uint8_t> head = encode_head(file, checksums);
  return write_at(0, head.data(), head.size());
}

/// Writes the planned `file` to `path` through `files`: pwrite() into the staged temporary.
Status write_planned(const std::string& path, const PlannedFile& file, FileSink& files) {
  return files.write_by_name(path, [&](const std::string& temporary) -> Status {
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) return Status(StatusCode::kIoError, "cannot open " + temporary + ": " + std::strerror(errno));
    Status s = emit_file(file, [&](uint64_t offset, const void* data, size_t size) {
      for (const uint8_t* bytes = static_cast<const uint8_t*>(data); size > 0;) {
        const ssize_t done = ::pwrite(fd, bytes, size, static_cast<off_t>(offset));
        if (done < 0 && errno == EINTR) continue;
        if (done <= 0) return Status(StatusCode::kIoError, "cannot write " + path + ": " + std::strerror(errno));
        bytes += done;
        size -= static_cast<size_t>(done);
        offset += static_cast<uint64_t>(done);
      }
      return Status();
    });
    if (s.ok() && ::ftruncate(fd, static_cast<off_t>(file.file_size)) != 0) {
      s = Status(StatusCode::kIoError, "cannot size " + path + ": " + std::strerror(errno));
    }
    if (::close(fd) != 0 && s.ok()) s = Status(StatusCode::kIoError, "cannot close " + path + ": " + std::strerror(errno));
    return s;
  });
}

/// fn(), with an allocation failure turned into kOutOfMemory naming the scene's size.
template <typename Fn>
Status catch_out_of_memory(uint64_t count, Fn&& fn) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
  } catch (const std::length_error&) {
  }
  return Status(StatusCode::kOutOfMemory, "out of memory serializing " + dec(count) + " Gaussians");
}

}  // namespace

Result<std::vector<uint8_t>> serialize_scene(const EncodedScene& scene, const WriteOptions& options) {
  std::vector<uint8_t> out;
  Status s = catch_out_of_memory(scene.count, [&] {
    std::optional<ArchiveScene> archive;
    PlannedFile file;
    RGS_RETURN_IF_ERROR(plan_file(scene, options, &archive, &file));
    out.assign(static_cast<size_t>(file.file_size), 0);
    return emit_file(file, [&out](uint64_t offset, const void* data, size_t size) {
      if (size > 0) std::memcpy(out.data() + offset, data, size);
      return Status();
    });
  });
  if (!s.ok()) return s;
  return out;
}

Result<uint64_t> write_scene_file(const std::string& path, const EncodedScene& scene, const WriteOptions& options,
                                  FileSink& files, ArchiveScene* archive_out) {
  // Writes the sections from the scene's own arrays (no serialized copy of the whole file in memory).
  std::optional<ArchiveScene> archive;
  PlannedFile file;
  Status s = catch_out_of_memory(scene.count, [&] { return plan_file(scene, options, &archive, &file); });
  if (!s.ok()) return s.prepend(path);
  RGS_RETURN_IF_ERROR(write_planned(path, file, files));
  if (archive_out != nullptr && archive) *archive_out = std::move(*archive);  // the plan is not used again
  return file.file_size;
}

Result<uint64_t> write_streamed_scene_file(const std::string& path, const StreamedScene& scene,
                                           const WriteOptions& options, FileSink& files) {
  PlannedFile file;
  Status s = catch_out_of_memory(scene.count, [&] {
    RGS_RETURN_IF_ERROR(plan_sections(scene.metadata, scene.provenance, scene.count, scene.sh_dc_residual, options,
                                      &file));
    RGS_RETURN_ERROR_IF(options.profile != StorageProfile::kRuntime, StatusCode::kInvalidArgument,
                        "a streamed scene is written in the runtime profile");
    for (const PlannedSection& section : file.sections) {
      RGS_RETURN_ERROR_IF(section.streamed() && section.codec != Codec::kNone, StatusCode::kInvalidArgument,
                          std::string("a streamed scene stores section ") + section_name(section.id) + " raw");
    }
    if (options.lod != nullptr) RGS_RETURN_IF_ERROR(add_lod_section(*options.lod, options, &file));
    return finish_plan(options, &file);
  });
  if (!s.ok()) return s.prepend(path);
  file.produce = scene.produce;
  RGS_RETURN_IF_ERROR(write_planned(path, file, files));
  return file.file_size;
}

}  // namespace rgs::format
