// Reads a trained 3DGS scene in any supported input format, found by content rather than by extension.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rgs/converter/interop.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Options shared by every input reader.
struct SceneReadOptions {
  /// What to do with Gaussians whose values cannot be rendered (PLY; the other readers reject them).
  InvalidPolicy invalid_policy = InvalidPolicy::kReject;
  /// Refuse inputs declaring more Gaussians than this (kLimitExceeded) before allocating for them.
  uint64_t max_gaussians = uint64_t{1} << 28;
  /// What the input's codec layers (zstd, gzip, deflate, WebP images, glTF accessors without data) may decode
  /// to: at most this many bytes per byte of the scene's files, counting them as at least 1 MiB
  /// (format/SPEC.md §5.5 for every format; the default of format::ReadLimits::max_decompression_ratio).
  /// Checked from declared sizes before anything is allocated for them (kLimitExceeded).
  uint32_t max_decompression_ratio = 8;
  /// Also compute InputScene::file_xxh64 (provenance).
  bool hash_file = false;
  /// PLY inputs: PlyReadOptions::keep_pre_activation.
  bool keep_pre_activation = false;
  /// .rgs inputs: also keep the scene as stored (InputScene::encoded), for callers that use the quantized
  /// sections themselves (replication, re-encoding without a second quantization).
  bool keep_encoded = false;
  /// .rgs inputs: verify each section's XXH64 (format::ReadOptions::verify_checksums).
  bool verify_checksums = true;
  /// Level of detail of a streamed SOG (lod-meta.json): 0 is the finest. Unset reads LOD 0. Setting it for
  /// any other input is an error (kInvalidArgument), so a user's --lod is never silently ignored.
  std::optional<uint32_t> lod;
  /// SPZ inputs: the axes the file is taken to hold when it does not declare them (SpzFrame;
  /// converter/INTEROP.md "SPZ axes"). Every SPZ read adds a note on the axes to InputScene::notes
  /// (spz_frame_note(), or that the file declared them). Other formats ignore it.
  SpzFrame spz_frame = SpzFrame::kRub;
  /// SPZ files read or written with another frame than spz_frame, by path as given (compared after
  /// lexical normalization: "./a.spz" is "a.spz"). spz_frame_for() looks them up.
  std::map<std::string, SpzFrame> spz_frame_by_path;
  /// Read the scene as trained with the 2D Mip filter (GaussianCloud::antialiased), for inputs that cannot say
  /// so: PLY, glTF, SOG, .ksplat, .splat, and SPZ files whose writer left the flag unset. A .rgs file carries its own flag
  /// (SPEC §2.2), which this does not change.
  bool antialiased = false;
};

/// The frame SPZ file `path` is read or written with: its entry in options.spz_frame_by_path, else
/// options.spz_frame.
SpzFrame spz_frame_for(const SceneReadOptions& options, const std::string& path);

/// The extension of `path` in lower case, with its dot (".ply"; "" when none).
std::string extension_of(const std::string& path);

/// format::ReadOptions carrying `options`' limits and checksum choice: what a .rgs file is opened with
/// (format::RgsFile::open) by read_scene and by callers that map a .rgs themselves (the GPU upload).
format::ReadOptions rgs_read_options(const SceneReadOptions& options);

/// A scene read from any input format, and what was learned while reading it.
struct InputScene {
  /// Activated float Gaussians (GaussianCloud documents the layout); a .rgs input dequantized.
  format::GaussianCloud cloud;
  /// The scene's bounds: a .rgs file's metadata bounds (SPEC §4.1.1), else compute_bounds(cloud).
  format::SceneBounds bounds;
  /// .rgs inputs with SceneReadOptions::keep_encoded: the scene as stored (quantized sections, metadata).
  std::optional<format::EncodedScene> encoded;
  InputHygiene hygiene;
  /// Short identifier of the input format: "rgs", "ply", "compressed_ply", "sog", "sog_bundle", "sog_lod",
  /// "spz", "glb", "gltf", "ksplat", "splat".
  std::string format_id;
  /// The format in words for summaries, e.g. "binary_little_endian PLY", "PlayCanvas SOG v2 (bundled .sog)",
  /// "PlayCanvas streamed SOG, LOD 0 of 5 (8 chunks)".
  std::string description;
  /// PLY inputs: the storage format of the `format` line ("binary_little_endian", ...). Others: format_id
  /// (SPZ and glTF with their version: "spz v4", "glb v2"; a .rgs in the archive profile: "rgs archive").
  std::string storage_format;
  /// Bytes of every file read (meta files, images and chunks included) and how many files that was; a file
  /// that several names reach (spellings of one path, hard links) counts once.
  uint64_t file_bytes = 0;
  uint64_t file_count = 0;
  /// Number of Gaussians the input declares (before any are dropped).
  uint64_t declared_vertices = 0;
  /// Every file read (the entry file first: the PLY, meta.json, lod-meta.json, .gltf, ...), as named in
  /// messages: the files an output of the same run must not replace.
  std::vector<std::string> files;
  /// With SceneReadOptions::hash_file: XXH64 (seed 0) of the file for single-file inputs (PLY, compressed
  /// PLY, bundled .sog); for inputs made of several files, XXH64 over the little-endian XXH64 of each file
  /// read, in a fixed order: SOG folder: meta.json, then its images (means low, means high, quats, scales,
  /// sh0[, shN centroids, shN labels]); streamed SOG: lod-meta.json, the level's chunk meta.json files in
  /// file-index order, then each chunk's images in the same order. Else empty.
  std::optional<uint64_t> file_xxh64;
  /// What the input said that the cloud cannot hold or that was ignored, and the frame conversion applied,
  /// one sentence each (SPZ, glTF, .ksplat, .splat: InteropScene::notes); empty for the other formats.
  std::vector<std::string> notes;
  /// Streamed SOG inputs whose lod-meta.json declares 'lodErrors': each leaf's 'errors' table in tree order,
  /// one value per level (PlayCanvas's dimensionless error against the leaf's finest level; docs/LOD.md
  /// "The error tables"). Else empty.
  std::vector<std::vector<double>> lod_errors;
};

/// Reads the scene at `path`, detecting its format from its content (magic bytes, PLY header elements,
/// JSON keys, file size), never from its extension:
/// - 3DGS PLY (read_ply: INRIA layout or any property order; binary or ascii);
/// - PlayCanvas compressed PLY (`chunk` + packed `vertex` [+ `sh`] elements);
/// - PlayCanvas SOG: a meta.json (or the folder holding it) with its WebP images, v2 (codebooks) or the
///   earlier unversioned layout; a bundled `.sog` (ZIP of meta.json and the images, stored or deflated);
/// - PlayCanvas streamed SOG: a lod-meta.json (or the folder holding it) and its chunk folders; one level of
///   detail is read (SceneReadOptions::lod, default 0);
/// - Niantic SPZ v2-v4 (read_spz; axes as SceneReadOptions::spz_frame says);
/// - KHR_gaussian_splatting glTF, binary (.glb) or JSON (.gltf) with its buffers (read_gltf);
/// - RoofGS .rgs (format::RgsFile: every section's checksum, frame and values checked, then dequantized; the
///   limits max_gaussians and max_decompression_ratio as format::ReadLimits);
/// - GaussianSplats3D .ksplat v0.1 (read_ksplat), compression levels 0-2, found by its version bytes, compression
///   level and size (the format has no magic);
/// - antimatter15 .splat (read_splat), tried last: the format has no signature, so a file is taken as .splat
///   only when no other detector matched and looks_like_splat accepts its size and first records.
/// The order of the checks: PLY family, .rgs, SOG family, SPZ, glTF, .ksplat, .splat. A file named .ksplat or
/// .splat that its detector refuses goes to that reader, which names what is wrong with it.
/// A directory is read through the lod-meta.json or meta.json it contains.
/// Errors name `path` and the cause: kInvalidArgument "unsupported format: <what it looks like>; supported:
/// <list>" for other content, and for a lod given for a non-streamed input; otherwise the errors of the
/// format's reader (kIoError, kNotRgsFile, kUnsupportedVersion, kCorruptData, kUnsupportedFeature,
/// kLimitExceeded, kChecksumMismatch, kOutOfMemory).
/// Thread safety: may be called concurrently; decodes on up to 16 threads of its own.
Result<InputScene> read_scene(const std::string& path, const SceneReadOptions& options = {});

/// The scene of an opened .rgs file, as read_scene reads one: every runtime section checked
/// (format::RgsFile::read_scene), then dequantized; bounds from its metadata. For callers that opened the file
/// already, so that it is opened once (the front door). file_xxh64 stays empty (read_scene computes it from the
/// file's bytes with SceneReadOptions::hash_file). Errors name the file: those of RgsFile::read_scene and
/// format::dequantize; kInvalidArgument when options.lod asks for a streamed-SOG level.
Result<InputScene> rgs_file_scene(const format::RgsFile& file, const SceneReadOptions& options = {});

/// The note every reader of a .rgs gives when options.antialiased asks for the 2D Mip filter and the file records
/// that its scene was trained without it: the option is ignored (the file's flag decides). Empty otherwise.
std::string rgs_antialiased_note(const format::RgsFile& file, const SceneReadOptions& options);

/// Reads a 3DGS PLY or a .rgs held in memory (a file given on standard input) into the InputScene read_scene
/// gives for the same file. `name` names the input in errors. Only PLY and .rgs are read from memory; other
/// formats need a file (read_scene). Errors: those of read_scene's PLY and .rgs readers, and
/// kInvalidArgument when `options` asks for a level of detail.
Result<InputScene> read_scene_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const SceneReadOptions& options = {});

/// Float Gaussians already in memory (a training run's arrays) as the InputScene a file holding them would
/// give: the same value rules as read_scene (quaternions normalized; non-finite values and zero quaternions
/// rejected, or dropped under InvalidPolicy::kSanitize: docs/INPUT_HYGIENE.md), and linear scales must be
/// ≥ 0 and opacities in [0, 1] (GaussianCloud's activated encoding). bounds = compute_bounds(cloud);
/// format_id "arrays". `name` names the scene in messages.
/// @return kInvalidArgument naming `name` for arrays that disagree with the cloud's size and SH degree, a
///         negative scale or an opacity outside [0, 1] (the first index); kCorruptData as read_scene.
Result<InputScene> scene_from_cloud(format::GaussianCloud cloud, const std::string& name,
                                    const SceneReadOptions& options = {});

/// What read_scene would do with `path`: the format_id of the reader it picks (e.g. "sog_lod"), or the
/// kInvalidArgument "unsupported format" error (kIoError when `path` cannot be read). Reads only the start
/// of the file (and a JSON file whole).
Result<std::string> detect_scene_format(const std::string& path);

/// The files read_scene would read for `path`, the entry file first, named as InputScene::files names them:
/// for a SOG folder or meta.json its images; for a streamed SOG its lod-meta.json, the chunk meta.json files
/// and their images; for a .gltf its buffer files; for every other input `path` alone (a folder: the meta
/// file in it). A tool declares them all as inputs before it writes anything, so that no output replaces a
/// file of the scene. Reads only the scene's JSON files; names are resolved under the same file-access policy
/// as read_scene (docs/INPUT_HYGIENE.md "Files a scene names"), with the same errors for names it refuses.
/// Errors: kIoError (unreadable), kCorruptData (a name outside the scene's folder, a symbolic link, bad JSON),
/// kInvalidArgument (unsupported format), kLimitExceeded.
Result<std::vector<std::string>> list_scene_files(const std::string& path);

/// Drops the SH bands of `cloud` above `degree` (a no-op when the cloud's degree is not above it), keeping
/// the lower coefficients bit for bit: what `rgs-convert --sh-degree N` does before writing any output.
/// Errors: kInvalidArgument for `degree` above 3 or an inconsistent cloud; kOutOfMemory.
Status reduce_sh_degree(format::GaussianCloud* cloud, uint32_t degree);

/// Raises the SH degree of `cloud` to `degree` (a no-op when the cloud's is not below it), keeping its
/// coefficients bit for bit and setting the added bands to zero, so that the cloud renders as before.
/// Errors: kInvalidArgument for `degree` above 3 or an inconsistent cloud; kOutOfMemory.
Status raise_sh_degree(format::GaussianCloud* cloud, uint32_t degree);

/// Several scenes, each as its reader gave it (axes and activations normalised), as one: their Gaussians in the
/// order given at the highest SH degree (raise_sh_degree); bounds compute_bounds(); counts, bytes, files and notes
/// (prefixed with their entry file) summed or joined in order; format_id, description and storage_format the
/// distinct ones joined by " + "; file_xxh64 XXH64 over each scene's little-endian XXH64 when all have one.
/// One scene is returned as it is.
/// @return kInvalidArgument for no scene, or for scenes whose anti-aliasing flags (GaussianCloud::antialiased)
///         differ, naming the first two such entry files: the 2D Mip filter's opacity compensation depends on
///         the view, so no flag renders both as trained; kOutOfMemory.
Result<InputScene> merge_scenes(std::vector<InputScene> scenes);

/// One line per supported input format, for help texts: "3DGS PLY (.ply)", ...
std::vector<std::string> supported_scene_formats();

}  // namespace rgs::converter
