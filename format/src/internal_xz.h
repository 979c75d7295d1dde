// .xz streams of quantized codes (SPEC.md §3.3.2, version 1.5): written and checked with liblzma.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::format::detail {

/// §7 The raw bytes of each block of an .xz stream (liblzma's lzma_mt::block_size): blocks are compressed
/// independently, so the stream does not depend on how many threads compress them.
inline constexpr size_t kXzBlockBytes = size_t{8} << 20;
/// §3.3.2 The smallest LZMA2 dictionary a reader accepts whatever the codes' size, and the dictionary of the
/// writer's XzMatches::kNear.
inline constexpr uint32_t kXzMinDictionaryBytes = uint32_t{1} << 20;
/// How far back the writer's LZMA2 encoder looks for matches.
enum class XzMatches {
  /// Planes of codes, whose matches are near: xz's preset 1 in normal mode (hash chains, a 1 MiB dictionary),
  /// within 0.5 % of kFar's bytes on the measured planes at 1.4-1.8 times its speed (docs/AUDITS.md).
  kNear,
  /// SH records, which a codebook-trained scene repeats a section apart: xz's preset 6 (binary trees), with a
  /// dictionary of the codes rounded up to a power of 2, 1 to 8 MiB (xz_writer_dictionary).
  kFar,
};
/// The LZMA2 dictionary of XzMatches::kFar for `raw_size` bytes of codes.
uint32_t xz_writer_dictionary(uint64_t raw_size);
/// §3.3.2 The largest LZMA2 dictionary a reader accepts in a stream of `raw_size` bytes, max(1 MiB, 2 raw_size):
/// a dictionary need not be much larger than what it decodes, and this library's writer's fits. The decoder's
/// memory is about this.
uint64_t xz_max_dictionary(uint64_t raw_size);

/// True when the bytes start with the .xz stream magic (FD 37 7A 58 5A 00), which no zstd frame does.
bool is_xz_stream(const uint8_t* src, size_t size);
/// §3.3.2 Checks an .xz stream without decoding it: one stream of exactly `size` bytes (no padding, no second
/// stream), a CRC32, CRC64 or SHA-256 check, and an index whose uncompressed size is `raw_size`.
/// kCorruptData.
Status check_xz_stream(const uint8_t* src, size_t size, uint64_t raw_size);
/// §3.3.2 Checks and decodes an .xz stream into exactly `raw_size` bytes, block by block: each block LZMA2
/// alone with a dictionary of at most xz_max_dictionary(raw_size). kCorruptData (damaged, another filter, a
/// larger dictionary, or a block's check that does not match), kOutOfMemory.
Status decode_xz_stream(const uint8_t* src, size_t size, uint8_t* dst, size_t raw_size);
/// §3.3.2, §7 Appends one .xz stream of `size` raw bytes to `out`: LZMA2 (`matches`; `literal_context_bits` lc
/// 0..4, lp 0, pb 0: the codes are bytes without alignment) in blocks of kXzBlockBytes, CRC32 checks, compressed
/// by up to `workers` threads (0 counts as 1, at most one a block): the same bytes for any `workers`. Each thread
/// holds an encoder and its block's input and output (lzma_stream_encoder_mt_memusage: 123 MB for kFar with the
/// 8 MiB dictionary, 38 MB for kNear). kOutOfMemory, kInvalidArgument.
Status compress_xz_stream(const uint8_t* raw, size_t size, uint32_t literal_context_bits, XzMatches matches,
                          uint32_t workers, std::vector<uint8_t>* out);

}  // namespace rgs::format::detail
