// Serializes an EncodedScene, or a StreamedScene section by section, into .rgs bytes (SPEC.md §2–§4, §7).
#include "rgs/format/writer.h"

#include <fcntl.h>
#include <unistd.h>
#include <xxhash.h>
#include <zstd.h>

#include <cerrno>
#include <cstring>

#include <algorithm>
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

void run_jobs(std::vector<std::function<Status()>>& jobs, uint32_t threads, const char* what,
              std::vector<Status>* results) {
  results->assign(jobs.size(), Status());
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t j; (j = next.fetch_add(1)) < jobs.size();) {
      try {  // nothing may escape a thread: error messages allocate
        (*results)[j] = jobs[j]();
      } catch (const std::exception&) {
        (*results)[j] = Status(StatusCode::kOutOfMemory, std::string("out of memory ") + what);
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
}

}  // namespace detail

namespace {

using detail::ByteWriter;
using detail::dec;

/// One section as it will be written: raw bytes (a view into the scene, or owned when they had to be
/// encoded), the zstd frame when compressed, and its place in the file.
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

/// Checks the values of Gaussians [begin, end) (SPEC §4.3–§4.7); the first bad one in index order.
Status check_values(const EncodedScene& scene, uint64_t begin, uint64_t end) {
  const uint64_t k3 = uint64_t{3} * sh_coefficient_count(scene.metadata.sh_degree);
  for (uint64_t i = begin; i < end; ++i) {
    Status s = detail::check_mean(&scene.means[i * 3], i, scene.metadata.bounds);
    if (s.ok()) s = detail::check_rotation(&scene.rotations[i * 4], i);
    if (s.ok()) s = detail::check_scale(&scene.scales[i * 3], i, scene.metadata.scale_encoding);
    if (s.ok()) s = detail::check_opacity(scene.opacities[i], i);
    if (s.ok()) s = detail::check_sh(&scene.sh[i * k3], k3, i);
    if (!s.ok()) return invalid(s.message());
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

/// §4.9 Adds the lod section of `index` after the runtime sections of `plan`: the index checked against the
/// scene (its structure, each range's values and chunk sphere) and each range's checksum computed, split
/// over two threads by range. Errors are kInvalidArgument naming the chunk and level.
Status add_lod_section(const LodIndex& index, const EncodedScene& scene, const WriteOptions& options,
                       std::vector<PlannedSection>* plan) {
  if (Status s = detail::check_lod_structure(index, scene.count); !s.ok()) return invalid(s.message());
  const uint64_t k3 = uint64_t{3} * sh_coefficient_count(scene.metadata.sh_degree);
  auto raw_of = [&](SectionId id) -> const uint8_t* {
    for (const PlannedSection& s : *plan) {
      if (s.id == id) return s.raw;
    }
    return nullptr;
  };
  const uint8_t* means = raw_of(SectionId::kMeans);
  const uint8_t* rotations = raw_of(SectionId::kRotations);
  const uint8_t* scales = raw_of(SectionId::kScales);
  const uint8_t* opacities = raw_of(SectionId::kOpacities);
  const uint8_t* sh = raw_of(SectionId::kSh);
  const uint8_t* residual = raw_of(SectionId::kShDcResidual);
  LodIndex checked = index;
  const size_t records = checked.levels.size();
  auto check_records = [&](size_t begin, size_t end) {
    for (size_t r = begin; r < end; ++r) {
      const uint32_t level = static_cast<uint32_t>(r / checked.chunk_count);
      const uint32_t chunk = static_cast<uint32_t>(r % checked.chunk_count);
      LodLevel& v = checked.levels[r];
      auto view = [&](const uint8_t* base, uint64_t record) {
        return base == nullptr ? ByteView{} : ByteView{base + v.first * record, static_cast<size_t>(v.count * record)};
      };
      const LodRangeView range{v.first,         v.count,          view(means, 12), view(rotations, 8),
                               view(scales, 6), view(opacities, 2), view(sh, k3),  view(residual, 3)};
      Status s = detail::check_lod_range(checked, level, chunk, range, scene.metadata, false);
      if (!s.ok()) return invalid(s.message());
      v.checksum = detail::lod_range_checksum(range);
    }
    return Status();
  };
  std::vector<std::function<Status()>> halves = {[&] { return check_records(0, records / 2); },
                                                 [&] { return check_records(records / 2, records); }};
  std::vector<Status> results;
  detail::run_jobs(halves, 2, "checking the level-of-detail ranges", &results);
  for (const Status& s : results) RGS_RETURN_IF_ERROR(s);
  PlannedSection& section = plan->emplace_back();
  section.id = SectionId::kLod;
  section.owned_raw = detail::encode_lod(checked);
  section.raw = section.owned_raw.data();
  section.raw_size = section.owned_raw.size();
  section.element_count = section.raw_size;
  const auto codec = options.codecs.find(SectionId::kLod);
  if (codec != options.codecs.end()) section.codec = codec->second;
  return Status();
}

/// Points a section at a typed array's raw little-endian bytes: the array itself on little-endian
/// hosts, an encoded copy otherwise.
template <typename T>
void set_array_raw(PlannedSection* s, const std::vector<T>& values) {
  s->raw_size = uint64_t{values.size()} * sizeof(T);
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

/// A file ready to be written: its sections (stored bytes, checksums, offsets) and its header + table.
struct PlannedFile {
  std::vector<PlannedSection> sections;
  /// Header and section table, kHeaderSize + entries × kSectionEntrySize bytes; sections follow.
  std::vector<uint8_t> head;
  uint64_t file_size = 0;
};

/// Adds the sections of `scene` to `file` in §4 order: metadata, provenance (only when non-empty,
/// `provenance_bytes` long), then the runtime sections, each with the codec `options` asks for. With
/// `archive`, the runtime sections take its stored bytes (moved out). Returns the file's required flags.
/// Appends section `id` of `count` elements (SPEC §3.1 layout of a scene of SH degree `sh_degree`) to `plan`,
/// with the codec `options` asks for; its bytes are set by the caller.
PlannedSection& add_section(SectionId id, uint64_t count, uint32_t sh_degree, const WriteOptions& options,
                            std::vector<PlannedSection>* plan) {
  PlannedSection& s = plan->emplace_back();
  detail::SectionLayout layout;
  (void)detail::expected_layout(id, sh_degree, &layout);  // every id added here is known
  s.id = id;
  s.element_type = layout.element_type;
  s.components = layout.components;
  s.element_count = count;
  const auto it = options.codecs.find(id);
  s.codec = it == options.codecs.end() ? Codec::kNone : it->second;
  return s;
}

/// Adds the metadata section and, when `provenance` is not empty, the provenance section of
/// `provenance_bytes` (§4.1, §4.2).
void add_head_sections(const SceneMetadata& metadata, const Provenance& provenance, uint64_t provenance_bytes,
                       const WriteOptions& options, std::vector<PlannedSection>* plan) {
  auto add_owned = [&](SectionId id, uint64_t size) {
    PlannedSection& s = add_section(id, size, metadata.sh_degree, options, plan);
    s.owned_raw.resize(size);
    s.raw = s.owned_raw.data();
    s.raw_size = size;
    return s.owned_raw.data();
  };
  detail::encode_metadata(metadata, add_owned(SectionId::kMetadata, kMetadataSize));
  if (!provenance.empty()) {
    detail::encode_provenance(provenance, add_owned(SectionId::kProvenance, provenance_bytes), provenance_bytes);
  }
}

uint32_t add_sections(const EncodedScene& scene, const WriteOptions& options, uint64_t provenance_bytes,
                      ArchiveScene* archive, PlannedFile* file) {
  const uint64_t n = scene.count;
  std::vector<PlannedSection>& plan = file->sections;
  plan.reserve(8);
  auto add = [&](SectionId id, uint64_t count) -> PlannedSection& {
    return add_section(id, count, scene.metadata.sh_degree, options, &plan);
  };
  add_head_sections(scene.metadata, scene.provenance, provenance_bytes, options, &plan);
  set_array_raw(&add(SectionId::kMeans, n), scene.means);
  set_array_raw(&add(SectionId::kRotations, n), scene.rotations);
  set_array_raw(&add(SectionId::kScales, n), scene.scales);
  set_array_raw(&add(SectionId::kOpacities, n), scene.opacities);
  set_array_raw(&add(SectionId::kSh, n), scene.sh);
  // §4.8 The archive stores the DC term at its INT8 step (times its multiplier), without the residual.
  if (!scene.sh_dc_residual.empty() && archive == nullptr) {
    set_array_raw(&add(SectionId::kShDcResidual, n), scene.sh_dc_residual);
  }
  uint32_t required_flags = 0;
  if (archive != nullptr) {
    // §3.3 The per-Gaussian sections, in the order means, rotations, scales, opacities, sh, take the
    // archive codecs; an empty scene keeps codec none (nothing to code).
    const size_t first = plan.size() - 5;
    for (size_t i = 0; i < 5; ++i) {
      PlannedSection& s = plan[first + i];
      s.codec = n == 0 ? Codec::kNone : i == 0 ? Codec::kDraco : Codec::kQuantized;
      if (n > 0) s.compressed = std::move(archive->stored[i]);
    }
    if (n > 0) required_flags |= kRequiredFlagArchiveCodecs;
    // §2.2 The sh section's first byte is its transform (§3.3.2).
    const std::vector<uint8_t>& sh = plan[first + 4].compressed;
    if (n > 0 && sh[0] == static_cast<uint8_t>(detail::QuantizedTransform::kShColourDifferences)) {
      required_flags |= kRequiredFlagShColourDifferences;
    }
    for (size_t i = 1; i < 5 && n > 0; ++i) {
      const std::vector<uint8_t>& stored = plan[first + i].compressed;
      if (detail::quantized_codes_are_xz(stored.data(), stored.size())) required_flags |= kRequiredFlagXzCodes;
    }
  }
  return required_flags;
}

/// §6 The oldest version that has every feature the file uses.
FormatVersion file_version(const SceneMetadata& metadata, const Provenance& provenance,
                           const std::vector<PlannedSection>& plan, uint32_t required_flags) {
  FormatVersion version{kFormatMajor, 0};
  auto require = [&version](FormatVersion v) {
    if (!version_at_least(version, v)) version = v;
  };
  if (!provenance.empty()) require(kMinVersionForProvenance);
  if (metadata.scale_encoding == ScaleEncoding::kLog) require(kMinVersionForLogScales);
  if (required_flags & kRequiredFlagArchiveCodecs) require(kMinVersionForArchiveCodecs);
  if (required_flags & kRequiredFlagLod) require(kMinVersionForLod);
  if (required_flags & kRequiredFlagShColourDifferences) require(kMinVersionForShColourDifferences);
  if (required_flags & kRequiredFlagXzCodes) require(kMinVersionForXzCodes);
  if (required_flags & kRequiredFlagAntialiased) require(kMinVersionForAntialiased);
  for (const PlannedSection& s : plan) {
    if (s.id == SectionId::kShDcResidual) require(kMinVersionForShDcResidual);
  }
  for (const PlannedSection& s : plan) {
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
  std::vector<Status> results;
  detail::run_jobs(jobs, options.threads, "compressing sections", &results);
  for (const Status& st : results) RGS_RETURN_IF_ERROR(st);
  return Status();
}

/// §3 Layout: the table after the header, each section at the next multiple of kSectionAlignment. Sets the
/// sections' offsets and `file_size`; returns the end of the table.
Result<uint64_t> lay_out(PlannedFile* file) {
  const uint64_t table_end = kHeaderSize + uint64_t{kSectionEntrySize} * file->sections.size();
  uint64_t end = table_end;
  for (PlannedSection& s : file->sections) {
    if (!detail::checked_align_up(end, kSectionAlignment, &s.offset) ||
        !detail::checked_add(s.offset, s.stored_size(), &end)) {
      return invalid("file size overflows 64 bits");
    }
  }
  if (end > SIZE_MAX) return Status(StatusCode::kOutOfMemory, "file of " + dec(end) + " bytes exceeds memory");
  file->file_size = end;
  return table_end;
}

/// Value checks (SPEC §4.3–§4.7) and section checksums (§3.2), each split over two threads: the first
/// half of the Gaussians and the last section of `plan` on this thread, the rest on another. The first
/// bad Gaussian in index order is reported, as a sequential check would. Returns one checksum per section.
Result<std::vector<uint64_t>> check_and_checksum(const EncodedScene& scene, const std::vector<PlannedSection>& plan) {
  const uint64_t n = scene.count;
  std::vector<uint64_t> checksums(plan.size());
  const size_t sh_index = plan.size() - 1;
  std::vector<std::function<Status()>> halves = {
      [&] {
        checksums[sh_index] = detail::xxh64(plan[sh_index].stored(), plan[sh_index].stored_size());
        return check_values(scene, 0, n / 2);
      },
      [&] {
        for (size_t i = 0; i < sh_index; ++i) checksums[i] = detail::xxh64(plan[i].stored(), plan[i].stored_size());
        return check_values(scene, n / 2, n);
      }};
  std::vector<Status> results;
  detail::run_jobs(halves, 2, "reporting an invalid Gaussian", &results);
  for (const Status& s : results) RGS_RETURN_IF_ERROR(s);
  return checksums;
}

/// Encodes the header (§2) and the section table (§3.1) of a laid-out `file` of `count` Gaussians into
/// `file->head`, `table_end` bytes.
Status encode_head(FormatVersion version, uint32_t required_flags, uint64_t count, uint64_t table_end,
                   const std::vector<uint64_t>& checksums, PlannedFile* file) {
  const std::vector<PlannedSection>& plan = file->sections;
  file->head.resize(static_cast<size_t>(table_end));  // zero-filled: reserved fields
  ByteWriter header(file->head.data(), kHeaderSize);
  for (uint8_t b : kMagic) header.put_u8(b);
  header.put_u16(version.major);
  header.put_u16(version.minor);
  header.put_u32(kHeaderSize);
  header.put_u32(required_flags);  // §2.2
  header.put_u32(0);  // optional flags
  header.put_u64(count);
  header.put_u32(static_cast<uint32_t>(plan.size()));
  header.put_u32(0);  // reserved
  header.put_u64(kHeaderSize);  // table offset
  header.put_u64(file->file_size);
  ByteWriter table(file->head.data() + kHeaderSize, static_cast<size_t>(table_end - kHeaderSize));
  for (size_t i = 0; i < plan.size(); ++i) {
    const PlannedSection& s = plan[i];
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
  header.put_u64(
      detail::header_checksum(file->head.data(), file->head.data() + kHeaderSize, table_end - kHeaderSize));
  if (!header.ok() || !table.ok() || header.position() != kHeaderSize || table.position() != table_end - kHeaderSize) {
    return Status(StatusCode::kInvalidArgument, "internal error: header or table size mismatch");
  }
  return Status();
}

/// Checks `scene` and `options` and lays the file out: everything but copying the section bytes. With
/// `archive`, `scene` is its decoded scene and the runtime sections take its stored bytes (moved out).
Result<PlannedFile> plan_file(const EncodedScene& scene, const WriteOptions& options, ArchiveScene* archive) {
  RGS_RETURN_IF_ERROR(check_options(options));
  RGS_RETURN_IF_ERROR(check_scene_shape(scene));
  uint64_t provenance_bytes = 0;
  std::string why;
  if (!detail::provenance_size(scene.provenance, &provenance_bytes, &why)) return invalid(why);
  PlannedFile file;
  uint32_t required_flags = add_sections(scene, options, provenance_bytes, archive, &file);
  if (scene.metadata.antialiased) required_flags |= kRequiredFlagAntialiased;
  if (options.lod != nullptr) {
    RGS_RETURN_IF_ERROR(add_lod_section(*options.lod, scene, options, &file.sections));
    required_flags |= kRequiredFlagLod;
  }
  const FormatVersion version = file_version(scene.metadata, scene.provenance, file.sections, required_flags);
  RGS_RETURN_IF_ERROR(compress_sections(options, &file.sections));
  RGS_ASSIGN_OR_RETURN(const uint64_t table_end, lay_out(&file));
  RGS_ASSIGN_OR_RETURN(const std::vector<uint64_t> checksums, check_and_checksum(scene, file.sections));
  RGS_RETURN_IF_ERROR(encode_head(version, required_flags, scene.count, table_end, checksums, &file));
  return file;
}

/// Emits the planned file in order: header + table, then each section after its zero padding.
Status emit_file(const PlannedFile& file, const std::function<Status(const void*, size_t)>& sink) {
  static const uint8_t kZeros[kSectionAlignment] = {};
  RGS_RETURN_IF_ERROR(sink(file.head.data(), file.head.size()));
  uint64_t position = file.head.size();
  for (const PlannedSection& s : file.sections) {
    if (s.offset > position) RGS_RETURN_IF_ERROR(sink(kZeros, static_cast<size_t>(s.offset - position)));
    if (s.stored_size() > 0) RGS_RETURN_IF_ERROR(sink(s.stored(), static_cast<size_t>(s.stored_size())));
    position = s.offset + s.stored_size();
  }
  return Status();
}

/// Plans the file of `scene` in the chosen profile; `archive` keeps the archive-coded scene alive while the
/// plan points into it.
Result<PlannedFile> plan_profile(const EncodedScene& scene, const WriteOptions& options,
                                 std::optional<ArchiveScene>* archive) {
  if (options.profile != StorageProfile::kArchive) return plan_file(scene, options, nullptr);
  RGS_RETURN_IF_ERROR(check_options(options));
  RGS_RETURN_IF_ERROR(check_scene_shape(scene));
  RGS_RETURN_IF_ERROR(check_values(scene, 0, scene.count));
  RGS_ASSIGN_OR_RETURN(ArchiveScene encoded, encode_archive(scene, options.archive, options.archive_earlier));
  archive->emplace(std::move(encoded));
  return plan_file((*archive)->decoded, options, &**archive);
}

Result<std::vector<uint8_t>> serialize_checked(const EncodedScene& scene, const WriteOptions& options) {
  std::optional<ArchiveScene> archive;
  RGS_ASSIGN_OR_RETURN(PlannedFile file, plan_profile(scene, options, &archive));
  std::vector<uint8_t> out;
  out.reserve(static_cast<size_t>(file.file_size));
  RGS_RETURN_IF_ERROR(emit_file(file, [&out](const void* data, size_t size) {
    const uint8_t* bytes = static_cast<const uint8_t*>(data);
    out.insert(out.end(), bytes, bytes + size);
    return Status();
  }));
  return out;
}

/// fn(), with an allocation failure turned into kOutOfMemory naming the scene's size.
template <typename Fn>
auto catch_out_of_memory(const EncodedScene& scene, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
  } catch (const std::length_error&) {
  }
  return Status(StatusCode::kOutOfMemory, "out of memory serializing " + dec(scene.count) + " Gaussians");
}

}  // namespace

Result<std::vector<uint8_t>> serialize_scene(const EncodedScene& scene, const WriteOptions& options) {
  return catch_out_of_memory(scene, [&] { return serialize_checked(scene, options); });
}

Result<uint64_t> write_scene_file(const std::string& path, const EncodedScene& scene, const WriteOptions& options,
                                  FileSink& files, ArchiveScene* archive_out) {
  // Streams the sections from the scene's own arrays (no serialized copy of the whole file in memory).
  std::optional<ArchiveScene> archive;
  auto file = catch_out_of_memory(scene, [&] { return plan_profile(scene, options, &archive); });
  if (!file.ok()) return Status(file.status()).prepend(path);
  RGS_RETURN_IF_ERROR(files.write(path, [&](const ChunkSink& sink) { return emit_file(*file, sink); }));
  if (archive_out != nullptr && archive) *archive_out = std::move(*archive);  // the plan is not used again
  return file->file_size;
}

namespace {

/// Element bytes of per-Gaussian section `id` in a scene of `k3` SH values a Gaussian.
uint64_t element_bytes(SectionId id, uint64_t k3) {
  switch (id) {
    case SectionId::kMeans: return 12;
    case SectionId::kRotations: return 8;
    case SectionId::kScales: return 6;
    case SectionId::kOpacities: return 2;
    case SectionId::kSh: return k3;
    default: return 3;  // kShDcResidual
  }
}

/// Checks element `index` of per-Gaussian section `id` (SPEC §4.3–§4.7), as check_values() does.
Status check_element(SectionId id, const uint8_t* element, uint64_t index, uint64_t k3, const SceneMetadata& metadata) {
  Status s;
  switch (id) {
    case SectionId::kMeans: {
      float xyz[3];
      std::memcpy(xyz, element, sizeof xyz);
      s = detail::check_mean(xyz, index, metadata.bounds);
      break;
    }
    case SectionId::kRotations: {
      uint16_t wxyz[4];
      std::memcpy(wxyz, element, sizeof wxyz);
      s = detail::check_rotation(wxyz, index);
      break;
    }
    case SectionId::kScales: {
      uint16_t xyz[3];
      std::memcpy(xyz, element, sizeof xyz);
      s = detail::check_scale(xyz, index, metadata.scale_encoding);
      break;
    }
    case SectionId::kOpacities: {
      uint16_t v;
      std::memcpy(&v, element, sizeof v);
      s = detail::check_opacity(v, index);
      break;
    }
    case SectionId::kSh: s = detail::check_sh(reinterpret_cast<const int8_t*>(element), k3, index); break;
    default: break;
  }
  return s.ok() ? s : invalid(s.message());
}

/// pwrite() of all of [data, data + size) at `offset`.
Status write_at(int fd, const void* data, size_t size, uint64_t offset, const std::string& path) {
  const uint8_t* bytes = static_cast<const uint8_t*>(data);
  while (size > 0) {
    const ssize_t done = ::pwrite(fd, bytes, size, static_cast<off_t>(offset));
    if (done < 0 && errno == EINTR) continue;
    if (done <= 0) return Status(StatusCode::kIoError, "cannot write " + path + ": " + std::strerror(errno));
    bytes += done;
    size -= static_cast<size_t>(done);
    offset += static_cast<uint64_t>(done);
  }
  return Status();
}

/// Writes the planned `file` into the open `fd`: the stored sections as they are, the streamed ones from
/// scene.produce (checked, hashed and written as they come), then the header and table with their checksums.
Status emit_streamed(int fd, const std::string& path, const StreamedScene& scene, FormatVersion version,
                     uint32_t required_flags, uint64_t table_end, PlannedFile* file) {
  const uint64_t k3 = uint64_t{3} * sh_coefficient_count(scene.metadata.sh_degree);
  std::vector<uint64_t> checksums;
  for (const PlannedSection& section : file->sections) {
    if (section.raw != nullptr || section.raw_size == 0) {
      RGS_RETURN_IF_ERROR(write_at(fd, section.stored(), static_cast<size_t>(section.stored_size()), section.offset, path));
      checksums.push_back(detail::xxh64(section.stored(), section.stored_size()));
      continue;
    }
    std::unique_ptr<XXH64_state_t, decltype(&XXH64_freeState)> hash(XXH64_createState(), XXH64_freeState);
    if (!hash) return Status(StatusCode::kOutOfMemory, "cannot allocate an XXH64 state");
    XXH64_reset(hash.get(), 0);
    const uint64_t width = element_bytes(section.id, k3);
    uint64_t written = 0;
    const Status produced = scene.produce(section.id, [&](const void* data, size_t size) -> Status {
      const auto* bytes = static_cast<const uint8_t*>(data);
      RGS_RETURN_ERROR_IF(size % width != 0 || written + size > section.raw_size, StatusCode::kInvalidArgument,
                          std::string("internal error: section ") + section_name(section.id) +
                              " streamed in pieces that are not whole elements or past its size");
      for (uint64_t e = 0; e < size / width; ++e) {
        RGS_RETURN_IF_ERROR(check_element(section.id, bytes + e * width, written / width + e, k3, scene.metadata));
      }
      XXH64_update(hash.get(), bytes, size);
      RGS_RETURN_IF_ERROR(write_at(fd, bytes, size, section.offset + written, path));
      written += size;
      return Status();
    });
    RGS_RETURN_IF_ERROR(produced);
    RGS_RETURN_ERROR_IF(written != section.raw_size, StatusCode::kInvalidArgument,
                        std::string("internal error: section ") + section_name(section.id) + " streamed " +
                            dec(written) + " bytes of " + dec(section.raw_size));
    checksums.push_back(static_cast<uint64_t>(XXH64_digest(hash.get())));
  }
  RGS_RETURN_IF_ERROR(encode_head(version, required_flags, scene.count, table_end, checksums, file));
  RGS_RETURN_IF_ERROR(write_at(fd, file->head.data(), file->head.size(), 0, path));
  if (::ftruncate(fd, static_cast<off_t>(file->file_size)) != 0) {
    return Status(StatusCode::kIoError, "cannot size " + path + ": " + std::strerror(errno));
  }
  return Status();
}

}  // namespace

Result<uint64_t> write_streamed_scene_file(const std::string& path, const StreamedScene& scene,
                                           const WriteOptions& options, FileSink& files) {
  auto fail = [&](const Status& s) { return Status(s).prepend(path); };
  if (Status s = check_options(options); !s.ok()) return fail(s);
  if (options.profile != StorageProfile::kRuntime) return fail(invalid("a streamed scene is written in the runtime profile"));
  if (Status s = detail::check_metadata(scene.metadata); !s.ok()) return fail(invalid("metadata: " + s.message()));
  uint64_t provenance_bytes = 0;
  std::string why;
  if (!detail::provenance_size(scene.provenance, &provenance_bytes, &why)) return fail(invalid(why));
  PlannedFile file;
  add_head_sections(scene.metadata, scene.provenance, provenance_bytes, options, &file.sections);
  const uint64_t k3 = uint64_t{3} * sh_coefficient_count(scene.metadata.sh_degree);
  std::vector<SectionId> ids = {SectionId::kMeans, SectionId::kRotations, SectionId::kScales, SectionId::kOpacities,
                                SectionId::kSh};
  if (scene.sh_dc_residual) ids.push_back(SectionId::kShDcResidual);
  for (SectionId id : ids) {
    PlannedSection& section = add_section(id, scene.count, scene.metadata.sh_degree, options, &file.sections);
    if (section.codec != Codec::kNone) {
      return fail(invalid(std::string("a streamed scene stores section ") + section_name(id) + " raw"));
    }
    section.raw_size = scene.count * element_bytes(id, k3);
  }
  uint32_t required_flags = scene.metadata.antialiased ? kRequiredFlagAntialiased : 0;
  if (options.lod != nullptr) {
    if (Status s = detail::check_lod_structure(*options.lod, scene.count); !s.ok()) return fail(invalid(s.message()));
    PlannedSection& section = add_section(SectionId::kLod, 0, scene.metadata.sh_degree, options, &file.sections);
    section.owned_raw = detail::encode_lod(*options.lod);
    section.raw = section.owned_raw.data();
    section.raw_size = section.owned_raw.size();
    section.element_count = section.raw_size;
    required_flags |= kRequiredFlagLod;
  }
  const FormatVersion version = file_version(scene.metadata, scene.provenance, file.sections, required_flags);
  if (Status s = compress_sections(options, &file.sections); !s.ok()) return fail(s);
  auto table_end = lay_out(&file);
  if (!table_end.ok()) return fail(table_end.status());
  RGS_RETURN_IF_ERROR(files.write_by_name(path, [&](const std::string& temporary) -> Status {
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) return Status(StatusCode::kIoError, "cannot open " + temporary + ": " + std::strerror(errno));
    Status s = emit_streamed(fd, path, scene, version, required_flags, *table_end, &file);
    if (::close(fd) != 0 && s.ok()) s = Status(StatusCode::kIoError, "cannot close " + path + ": " + std::strerror(errno));
    return s;
  }));
  return file.file_size;
}

}  // namespace rgs::format
