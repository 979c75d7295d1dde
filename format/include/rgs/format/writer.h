// Serializes an EncodedScene, or a scene streamed section by section, into .rgs bytes (SPEC.md §2–§4).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "rgs/format/archive.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/file_io.h"
#include "rgs/format/lod.h"
#include "rgs/format/spec.h"
#include "rgs/format/status.h"

namespace rgs::format {

/// What the per-Gaussian sections store (SPEC §3.3).
enum class StorageProfile {
  kRuntime,  ///< the runtime arrays as they are (codec none or zstd: lossless)
  kArchive,  ///< lossy archive codecs (Draco means, quantized sections) decoding into the runtime arrays
};

/// Storage choices of a conversion. The runtime profile is lossless and its default codec is kNone, so
/// a loader can map the file and copy each section to the GPU without decoding.
struct WriteOptions {
  /// Codec per section id; sections not listed are stored with Codec::kNone. With the archive profile only
  /// metadata and provenance follow it (the runtime sections take the archive codecs).
  std::map<SectionId, Codec> codecs;
  StorageProfile profile = StorageProfile::kRuntime;
  /// Choices of the archive profile (used when profile is kArchive). The file holds the scene as
  /// encode_archive() decodes it: in Draco's point order, with the bounds of the decoded means.
  ArchiveOptions archive;
  /// With the archive profile: an archive of the same scene encoded before (rate control's, with the chosen
  /// settings' points), which lends encode_archive() the sections it coded with the same settings (its
  /// `earlier`: Draco's means when the points match). The file's bytes do not depend on it. Not owned.
  const ArchiveScene* archive_earlier = nullptr;
  /// zstd compression level, 1..22 (ZSTD_maxCLevel()).
  int zstd_level = 19;
  /// Threads compressing each zstd section of the runtime profile (its frame's jobs, SPEC §7); the bytes do not
  /// depend on it. 0 (default): the machine's hardware threads. The archive profile takes ArchiveOptions::threads.
  uint32_t threads = 0;
  /// A level-of-detail index of the scene (SPEC §4.9; converter::build_lod makes one): written as the lod
  /// section with its range checksums, the file then stamped 1.3 with kRequiredFlagLod. It needs the runtime
  /// profile with every per-Gaussian section stored raw. Null: an ordinary file. Not owned.
  const LodIndex* lod = nullptr;
};

/// Serializes `scene` (SPEC §3 layout, sections in the order metadata, provenance if non-empty, means,
/// rotations, scales, opacities, sh, sh_dc_residual if any, lod with options.lod). Deterministic: the same scene
/// and options give identical bytes (no timestamps; zstd jobs and .xz blocks of a fixed size, whatever the threads;
/// SPEC §7). Peak memory: the output plus the zstd frames, and a zstd context per compressing thread
/// (ZSTD_estimateCCtxSize: 81 MB at level 19); for the archive's .xz trials, which run beside each section's zstd
/// frame, an LZMA encoder per thread as well (up to 123 MB, format/src/internal_xz.h).
/// Errors: kInvalidArgument for inconsistent arrays, an invalid quantization (is_valid_quantization), an
/// SH degree above 3, unknown enum values, non-finite or unordered bounds, a zstd level out of range, a
/// codec for an unknown section, or any value validate() would reject (SPEC §4.3–§4.7: non-finite means
/// or means outside the bounds, zero or non-finite rotations, negative linear scales, opacities outside
/// [0, 1], SH value -128) -- the writer never produces a file that fails validation. kOutOfMemory.
Result<std::vector<uint8_t>> serialize_scene(const EncodedScene& scene, const WriteOptions& options = {});

/// serialize_scene() streamed into `files` (default: written atomically in place): no partial file on
/// failure, an existing `path` untouched. Returns the number of bytes written. With the archive profile and
/// a non-null `archive`, it receives the archive-coded scene that was written (encode_archive(): `decoded` is
/// what readers of the file get, `source_index` maps it back to `scene`'s order; `stored` is left empty), so
/// that a caller can measure what the archive codecs cost without encoding twice. Errors: as serialize_scene, kIoError naming `path`.
Result<uint64_t> write_scene_file(const std::string& path, const EncodedScene& scene,
                                  const WriteOptions& options = {}, FileSink& files = atomic_files(),
                                  ArchiveScene* archive = nullptr);

/// A runtime-profile scene whose per-Gaussian sections are streamed rather than held in memory (a scene built
/// out of core, converter::build_lod_out_of_core): metadata, provenance and count as in EncodedScene.
struct StreamedScene {
  SceneMetadata metadata;
  Provenance provenance;
  uint64_t count = 0;
  /// Whether the file has the sh_dc_residual section (§4.8).
  bool sh_dc_residual = false;
  /// Streams the raw little-endian bytes of per-Gaussian section `id` (means, rotations, scales, opacities, sh,
  /// sh_dc_residual: [count, components] as §4.3–§4.8 lay them out) into `sink`, in order, whole elements per
  /// call. Called once per section, in file order.
  std::function<Status(SectionId id, const ChunkSink& sink)> produce;
};

/// Writes `scene` into `files` as write_scene_file() writes the EncodedScene holding the same arrays: the same
/// bytes. The runtime profile only, every per-Gaussian section raw (zstd only for metadata, provenance and lod);
/// options.lod, when set, must carry its range checksums (lod_range_checksum over the stored bytes), which the
/// writer cannot compute from sections streamed one at a time. Each value is checked as it streams past (as
/// serialize_scene checks it); the lod index's structure is checked, its chunk spheres are not. Peak memory: one
/// piece of `produce` and the small sections. Errors: those of write_scene_file, naming `path`.
Result<uint64_t> write_streamed_scene_file(const std::string& path, const StreamedScene& scene,
                                           const WriteOptions& options = {}, FileSink& files = atomic_files());

}  // namespace rgs::format
