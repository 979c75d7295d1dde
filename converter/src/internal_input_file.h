// Whole-file and head-of-file reads for the scene readers, the file-access policy of multi-file scenes and the
// listing of the files they name (private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// Reads the regular file `path` whole into `out`. Errors name `path`: kIoError (missing, a directory, a FIFO
/// or device (refused without blocking), unreadable, changed while reading), kLimitExceeded (larger than max_bytes), kOutOfMemory.
Status read_whole_file(const std::string& path, uint64_t max_bytes, std::vector<uint8_t>* out);

/// Opens `path` read-only as a regular file; returns the descriptor (the caller closes it) and the size.
/// Errors name `path`: kIoError (missing, a directory, a FIFO or device, unreadable).
Status open_regular(const std::string& path, int* fd, uint64_t* size);

/// Reads bytes [offset, offset + n) of the open file `fd` into `dst` (pread: thread safe). Errors: kIoError naming
/// `path` (unless empty) and the byte range: a failed read, or a file that ends first.
Status read_exact(int fd, const std::string& path, uint8_t* dst, size_t n, uint64_t offset = 0);

/// Reads up to `max_bytes` from the start of `path` into `out` and its size into `file_size`.
/// Errors as read_whole_file (kIoError only).
Status read_file_head(const std::string& path, size_t max_bytes, std::vector<uint8_t>* out, uint64_t* file_size);

/// The most bytes a scene's codec layers may decode to: `ratio` times `file_bytes`, counting the files as at
/// least format::kDecompressionRatioMinBytes (SPEC §5.5, applied to every input format).
uint64_t decode_budget(uint64_t file_bytes, uint32_t ratio);

/// kLimitExceeded naming `where` when `decoded` bytes (what `what` would decode to) exceed
/// decode_budget(file_bytes, ratio); says which option raises the limit.
Status check_decode_budget(uint64_t decoded, uint64_t file_bytes, uint32_t ratio, const std::string& where,
                           const std::string& what);

/// Text of errno values used in messages ("no such file or directory", ...).
std::string errno_message(int err);

/// Checks `reference`, found in the field `field` of the scene file `where`, and returns its path relative to
/// the scene's folder ("0_0/means_l.webp"), normalised; `base` is the folder, relative to the scene's folder,
/// that the reference is relative to ("" or "0_0"). The rules of SceneFolder; also for names inside a bundle.
/// Errors: kCorruptData naming `where`, `field` and the cause ("... names '...', a '..' component (outside the
/// scene's folder)"); the reference is quoted at most 96 bytes long.
Result<std::string> resolve_scene_reference(const std::string& reference, const std::string& base,
                                            const std::string& where, const std::string& field);

/// A file as the file system knows it, whatever name reached it: its device and inode.
struct FileIdentity {
  uint64_t device = 0;
  uint64_t inode = 0;
  bool operator<(const FileIdentity& o) const { return device != o.device ? device < o.device : inode < o.inode; }
};

/// The files of one multi-file scene (a SOG folder, a streamed SOG, a .gltf with its buffers), opened under
/// one policy (docs/INPUT_HYGIENE.md "Files a scene names"):
/// - a reference (SOG `files`, streamed SOG `filenames`, glTF `buffers[].uri`) is a URI reference, as the web
///   viewers these formats were made for fetch it: after percent-decoding it must be relative, hold no `..`
///   component and no NUL byte, and it may have no scheme, query or fragment; it resolves inside the scene's
///   folder;
/// - no symbolic link is followed: not the file, not a folder on the way (a link could lead anywhere, and its
///   target's properties are not reported);
/// - only regular files are opened (a FIFO, device or folder is refused before it is opened, so nothing
///   blocks);
/// - every file read is recorded (files()), so that a tool can refuse an output that would replace it;
/// - every distinct file (device and inode) counts once towards the scene's bytes (distinct_bytes()), however
///   many names reach it (spellings of one path, hard links), so that naming a file again never raises a limit
///   that is set relative to the scene's size (the decompression ratio).
/// The scene's folder itself (the folder of the file the user named) is trusted as named.
/// Thread safety: read() may be called concurrently.
class SceneFolder {
 public:
  /// `root`: the folder holding the scene's entry file; `entry`: that file's path when it is read as named
  /// (it is recorded first in files(), and counted in distinct_bytes() at its size), else empty.
  SceneFolder(std::string root, std::string entry);

  /// resolve_scene_reference for a file of this scene.
  Result<std::string> resolve(const std::string& reference, const std::string& base, const std::string& where,
                              const std::string& field) const {
    return resolve_scene_reference(reference, base, where, field);
  }

  /// Reads the regular file at `relative` (from resolve) whole into `out`, or with `prefix` its first `n` bytes.
  /// Nothing is allocated before the file's size is known.
  /// Errors name the file: kCorruptData (a symbolic link on the way; with `prefix` a file shorter than `n`),
  /// kIoError (missing, not a regular file, unreadable), kLimitExceeded (without `prefix`: larger than `n`),
  /// kOutOfMemory.
  Status read(const std::string& relative, uint64_t n, std::vector<uint8_t>* out, bool prefix = false) const;

  /// How the file at `relative` is named in files(): the scene folder joined with it.
  std::string display(const std::string& relative) const;
  /// display(), with `relative` cut to 96 bytes: for messages.
  std::string display_bounded(const std::string& relative) const;

  /// Every file read so far (the entry file first), in the order of their first read.
  std::vector<std::string> files() const;

  /// Bytes of the distinct files read so far, each file (device and inode) counted once, at the most bytes
  /// read of it (a prefix read counts its prefix); the entry file included. The basis of the scene's
  /// decompression-ratio limit (decode_budget).
  uint64_t distinct_bytes() const;
  /// How many distinct files that is.
  uint64_t distinct_files() const;

 private:
  Status open_file(const std::string& relative, int* fd, uint64_t* size, FileIdentity* identity) const;
  void record(const std::string& relative, const FileIdentity& identity, uint64_t bytes) const;

  std::string root_;
  mutable std::mutex mutex_;
  mutable std::vector<std::string> files_;
  mutable std::map<FileIdentity, uint64_t> distinct_;
};

/// The files a multi-file scene names, listed without decoding it, for converter::list_scene_files. Each resolves
/// names as its reader does (SceneFolder), so that every file the reader would open is listed, and a name the
/// reader would refuse is refused here with the same error.
/// A SOG meta.json (or its folder) and the images it names; a bundled .sog is one file.
Result<std::vector<std::string>> list_sog_files(const std::string& path);
/// A streamed SOG's lod-meta.json (or its folder), every chunk meta.json it names and their images.
Result<std::vector<std::string>> list_sog_lod_files(const std::string& path);
/// A .gltf and the buffer files it names (a GLB's external buffers too).
Result<std::vector<std::string>> list_gltf_files(const std::string& path);

}  // namespace rgs::converter::detail
