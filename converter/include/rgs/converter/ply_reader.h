// Reads trained 3DGS scenes from PLY (INRIA layout or any property order) into float Gaussians.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// What to do with Gaussians whose values cannot be rendered (docs/INPUT_HYGIENE.md).
enum class InvalidPolicy {
  /// Fail with kCorruptData, naming the counts and the first bad vertex (default).
  kReject,
  /// Drop such Gaussians and report how many were dropped.
  kSanitize,
};

/// Counts of problem values found in the input, reported whatever the policy.
struct InputHygiene {
  /// Non-finite (NaN or ±inf) values in means, f_dc/f_rest, scales or rotations.
  uint64_t nonfinite_values = 0;
  /// Gaussians with at least one such value.
  uint64_t gaussians_with_nonfinite = 0;
  /// Gaussians whose rotation quaternion has zero (or subnormal-squared) norm, so normalize() fails.
  uint64_t zero_norm_quaternions = 0;
  /// Opacity logits that are ±inf. These are well defined (sigmoid gives exactly 1 or 0) and are kept
  /// under every policy; NaN opacity counts as non-finite above.
  uint64_t infinite_opacity_logits = 0;
  /// Gaussians removed under kSanitize (0 under kReject).
  uint64_t dropped_gaussians = 0;
  /// Index (in the file) of the first Gaussian that is non-finite or has a zero quaternion; -1 if none.
  int64_t first_invalid_index = -1;
};

struct PlyReadOptions {
  InvalidPolicy invalid_policy = InvalidPolicy::kReject;
  /// Refuse files declaring more vertices than this (kLimitExceeded) before allocating.
  uint64_t max_gaussians = uint64_t{1} << 28;
  /// Also compute XXH64 (seed 0) of the whole file into PlyScene::file_xxh64 (provenance). Binary files
  /// are hashed in the reading pass, chunk by chunk in file order, so they are read only once.
  bool hash_file = false;
  /// Also keep each Gaussian's opacity logit and log scales as read (GaussianCloud::pre_activation), so that a
  /// PLY written from the cloud has them bit for bit.
  bool keep_pre_activation = false;
};

/// A PLY scene and what was learned while reading it.
struct PlyScene {
  /// Activated float Gaussians (GaussianCloud documents the layout).
  format::GaussianCloud cloud;
  InputHygiene hygiene;
  /// Size of the PLY file in bytes and its storage format ("binary_little_endian", "binary_big_endian",
  /// "ascii").
  uint64_t file_bytes = 0;
  std::string storage_format;
  /// Number of vertices declared in the header (before sanitizing).
  uint64_t declared_vertices = 0;
  /// XXH64 (seed 0) of every byte of the file, when PlyReadOptions::hash_file was set; else empty.
  std::optional<uint64_t> file_xxh64;
};

/// Reads a 3DGS PLY file. Properties are found by name (x y z, f_dc_0..2, f_rest_0..M-1 with M in {0, 9,
/// 24, 45} giving SH degree 0..3, opacity, scale_0..2, rot_0..3); other properties (nx ny nz, ...) are
/// ignored. Storage: binary_little_endian, binary_big_endian or ascii; property types char/uchar/short/
/// ushort/int/uint/float/double and their int8..float64 aliases. Elements other than `vertex` are
/// allowed only after it. Activations as the INRIA code applies them at load: opacity = sigmoid,
/// scale = exp, rotation = normalize (w, x, y, z); SH reordered from channel-major f_rest to [N, K, 3].
/// Errors name `path` and the cause: kIoError (missing, unreadable, file shorter than the header says),
/// kCorruptData (not a PLY, malformed header, face before vertex, bad ascii token, invalid values under
/// kReject), kUnsupportedFeature (unknown property type, list property in vertex, f_rest count not 0/9/
/// 24/45, missing required property), kLimitExceeded (vertex count above max_gaussians).
Result<PlyScene> read_ply(const std::string& path, const PlyReadOptions& options = {});

/// Same as read_ply on bytes in memory (tests, fuzzing). `name` is used in error messages.
Result<PlyScene> read_ply_bytes(const uint8_t* data, size_t size, const std::string& name,
                                const PlyReadOptions& options = {});

/// A binary PLY read in batches of vertices, in file order, pass after pass, without holding the file or its
/// whole cloud (out-of-core conversion). A batch holds exactly what read_ply gives for those vertices; under
/// InvalidPolicy::kSanitize its invalid Gaussians are dropped and counted in hygiene(), under kReject the
/// first one fails the read. Memory: one 1 MB buffer per decoding thread and the caller's batch.
///
/// Every pass reads the file open() found, or fails: when a pass starts (open(), rewind()) and when it has read
/// its last vertex, the file at the path must have the device, inode, size and modification time open() saw,
/// and each pass hashes what it reads (XXH64, the header and the bytes after the vertices included), which must
/// be the first pass's hash. Otherwise the read that ends the pass (or rewind()) fails with kIoError:
/// "<path>: the file changed during the passes of the out-of-core build (size 123 → 456 bytes)". A batch read
/// before the end of a pass can hold bytes of a file that is changing: a caller builds nothing that outlasts the
/// pass until the pass has ended without error.
class PlyStream {
 public:
  /// Opens `path` and checks its header as read_ply does. Errors name `path`: read_ply's header errors, and
  /// kUnsupportedFeature for an ascii PLY (read whole with read_ply).
  static Result<std::unique_ptr<PlyStream>> open(const std::string& path, const PlyReadOptions& options = {});
  /// Opens the binary PLYs at `paths` (one or more) as one stream of their vertices in the order given (a merge):
  /// each pass reads every file in turn, each checked as above, a batch holding vertices of one file at the
  /// highest SH degree of the files (the bands a file lacks zero: raise_sh_degree). The counts below are the
  /// files' together: vertex_count and file_bytes their sums, storage_format the distinct formats joined by
  /// " + ", hygiene() summed (first_invalid_index counted over the files in turn), file_xxh64 for several files
  /// XXH64 over each file's little-endian XXH64 (InputScene::file_xxh64's rule). Errors: open()'s for each file.
  static Result<std::unique_ptr<PlyStream>> open(const std::vector<std::string>& paths,
                                                 const PlyReadOptions& options = {});
  ~PlyStream();
  PlyStream(const PlyStream&) = delete;
  PlyStream& operator=(const PlyStream&) = delete;

  /// Vertices the header declares, and the SH degree their f_rest properties give.
  uint64_t vertex_count() const;
  uint32_t sh_degree() const;
  uint64_t file_bytes() const;
  /// "binary_little_endian" or "binary_big_endian".
  std::string storage_format() const;

  /// Reads the next at most `max` vertices of this pass into `*batch` (replaced; activations as read_ply).
  /// The read that consumes the last vertex also checks the pass (see the class).
  /// @return how many vertices of the file it consumed (0 at the end of the pass; the batch holds fewer when
  ///         some were dropped). Errors name the path: kIoError (short or unreadable file, or a file that
  ///         changed since open(), which is named as the cause of any other error too), kCorruptData (an
  ///         invalid Gaussian under kReject, named by its vertex index), kOutOfMemory.
  Result<uint64_t> read(uint64_t max, format::GaussianCloud* batch);
  /// The file (its index in open()'s `paths`) whose vertices the last read() returned.
  size_t file() const { return current_; }
  /// Starts a new pass at the first vertex; hygiene() restarts. Errors name the path: kIoError when the file
  /// changed since open() (see the class), or cannot be read.
  Status rewind();
  /// kIoError naming the path when the file at the path is not the one open() found (another device, inode,
  /// size or modification time; see the class); else OK. For a caller whose own checks failed on a batch, to
  /// name the change as the cause.
  Status check_unchanged() const;
  /// The hygiene counts of the vertices read in this pass (first_invalid_index a file index).
  const InputHygiene& hygiene() const;
  /// With PlyReadOptions::hash_file: XXH64 (seed 0) of the whole file once the first pass has read every
  /// vertex (computed as it read them); else empty.
  std::optional<uint64_t> file_xxh64() const;

 private:
  PlyStream() = default;
  struct State;
  std::vector<std::unique_ptr<State>> states_;  ///< one per file, read in turn
  size_t current_ = 0;  ///< the file this pass reads
  uint64_t vertices_ = 0, bytes_ = 0;  ///< the files' together
  uint32_t degree_ = 0;
  std::string storage_;
  mutable InputHygiene hygiene_;  ///< hygiene()'s sum
};

/// The most bytes a PLY whose header starts `data[0, size)` can hold, for reading one from a stream
/// (standard input) without buffering more than its header proves: binary PLY exactly the header plus every
/// element's rows; ascii PLY, and binary elements with list properties, an upper bound of 64 bytes per
/// value (a row of a list element: 64 KiB). 0 while `data` does not yet hold the whole header (read more).
/// A vertex count above `max_gaussians` is refused from the header, before the stream's body is read, as
/// read_ply_bytes() would refuse it after.
/// Errors: kCorruptData (not a PLY, malformed header, or no end_header within the first 1 MiB),
/// kLimitExceeded (vertex count above max_gaussians).
Result<uint64_t> ply_stream_bytes(const uint8_t* data, size_t size, uint64_t max_gaussians = UINT64_MAX);

}  // namespace rgs::converter
