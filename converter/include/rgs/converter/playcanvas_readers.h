// Readers of the PlayCanvas splat formats: compressed PLY, SOG (meta.json + WebP images, or a bundled
// .sog) and streamed SOG (lod-meta.json). read_scene() picks them by content; call these directly when the
// format is known.
//
// Every reader converts to the project's conventions (docs/DESIGN.md#attributes; GaussianCloud):
// means in the stored frame (no PlayCanvas axis flip), rotations normalized (w, x, y, z), linear scales
// (exp of the stored log scales), opacities as sigmoid of a logit clamped to ±13.8155 (the logit of
// 1 − 1e-6: an 8-bit alpha of 0 or 255 would be ±inf), SH [N, K, 3] with f_rest read channel-major.
// Counts, image sizes and codebook sizes are checked against each other and against max_gaussians before
// anything is allocated for them; non-finite codebook or range values are kCorruptData.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "rgs/converter/scene_reader.h"

namespace rgs::converter {

/// Reads a PlayCanvas compressed PLY: binary_little_endian; element `chunk` (one row per 256 Gaussians:
/// float min/max of x y z, of the log scales, and optionally of r g b), element `vertex` with uint
/// packed_position (11-10-11 bits), packed_rotation (2-bit largest-component index + 3 × 10 bits),
/// packed_scale (11-10-11) and packed_color (8-8-8-8: r g b and sigmoid opacity), and an optional element
/// `sh` of uchar f_rest_0..M-1 (M = 9, 24, 45), value v ↦ (v/256 + 1/512 − 0.5) · 8 (0 and 255 map to −4
/// and +4). Colours become SH DC: (c − 0.5) / 0.28209479177387814. Elements and properties are found by
/// name; other elements after these are skipped.
/// Errors name `path`: kIoError (unreadable, shorter than the header says), kCorruptData (not such a
/// file, chunk count ≠ ceil(vertices / 256), non-finite chunk bounds, or bounds whose decoded scale or SH DC
/// overflows float32), kUnsupportedFeature (another storage
/// format, property types or SH count), kLimitExceeded (vertices above max_gaussians), kOutOfMemory.
Result<InputScene> read_compressed_ply(const std::string& path, const SceneReadOptions& options = {});

/// Same as read_compressed_ply on bytes in memory (tests, fuzzing). `name` is used in error messages.
Result<InputScene> read_compressed_ply_bytes(const uint8_t* data, size_t size, const std::string& name,
                                             const SceneReadOptions& options = {});

/// Reads a PlayCanvas SOG scene. `path` is a meta.json (images resolved next to it) or a bundled .sog
/// (ZIP). meta.json fields are read by name: v2 (`"version": 2`, `count`, `means` {mins, maxs, files:
/// [low, high]}, `scales` {codebook[256], files}, `quats` {files}, `sh0` {codebook[256], files}, optional
/// `shN` {count, bands, codebook[256], files: [centroids, labels]}) and the earlier unversioned layout
/// (`means.shape`, per-channel mins/maxs for scales and sh0 with the opacity logit in sh0's fourth channel,
/// scalar mins/maxs for shN). Images must hold at least `count` pixels (row-major, pixel i is Gaussian i);
/// shN centroid images must be 64·(SH coefficients − 1) wide. Means are sign(v)·(exp|v| − 1) of the 16-bit
/// lerp between mins and maxs; quaternions are smallest-three with the largest component's index in the
/// alpha byte (252..255 for w, x, y, z).
/// Errors name the file: kIoError (missing/unreadable files), kCorruptData (bad JSON, missing or mistyped
/// fields, images too small, bad quaternion tag, non-finite values, palette index out of range),
/// kUnsupportedVersion (a meta version other than 2), kLimitExceeded (count or image pixels above limits),
/// kChecksumMismatch (ZIP CRC), kUnsupportedFeature (ZIP64, encryption, unknown ZIP method), kOutOfMemory.
/// Decodes the images on up to 16 threads.
Result<InputScene> read_sog(const std::string& path, const SceneReadOptions& options = {});

/// Reads one level of detail (SceneReadOptions::lod, default 0) of a PlayCanvas streamed SOG: a
/// lod-meta.json (`lodLevels`, `filenames`: chunk meta.json paths relative to it, `tree` of nodes whose
/// `lods` map a level to {file, offset, count}; optional `version` 1, per-level `counts`, and `lodErrors`
/// with each leaf's `errors`: `lodLevels` finite non-negative numbers, into InputScene::lod_errors). Every chunk
/// file the level references is read with the SOG rules above, in file-index order; within a chunk the
/// referenced ranges are taken in offset order and must lie inside it without overlapping. Chunks are
/// decoded in parallel (up to 16 threads, about 7 decoded images per thread in memory at once).
/// Errors: those of read_sog, plus kInvalidArgument (lod ≥ lodLevels), kCorruptData (malformed tree,
/// references or error tables, counts that disagree), kLimitExceeded (level total above max_gaussians).
Result<InputScene> read_sog_lod(const std::string& path, const SceneReadOptions& options = {});

}  // namespace rgs::converter
