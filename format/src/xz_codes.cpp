// .xz streams of quantized codes (SPEC §3.3.2, §7): the writer's threaded LZMA2 encoder, the reader's checks and
// its block-by-block decoder, which accepts LZMA2 alone with a bounded dictionary.
#include "internal_xz.h"

#include <lzma.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include "internal_bytes.h"

namespace rgs::format::detail {

namespace {

constexpr uint8_t kXzMagic[6] = {0xFD, '7', 'z', 'X', 'Z', 0x00};
/// The stream header and the stream footer (xz file format §2.1.1, §2.1.2).
constexpr size_t kXzStreamHeaderBytes = 12;
constexpr size_t kXzStreamFooterBytes = 12;

using IndexPtr = std::unique_ptr<lzma_index, void (*)(lzma_index*)>;

void free_index(lzma_index* index) { lzma_index_end(index, nullptr); }

/// The stream's flags and its index, checked against the stream's size and `raw_size` (check_xz_stream).
Status read_xz_index(const uint8_t* src, size_t size, uint64_t raw_size, lzma_stream_flags* flags, IndexPtr* index) {
  RGS_RETURN_ERROR_IF(size < kXzStreamHeaderBytes + kXzStreamFooterBytes || !is_xz_stream(src, size),
                      StatusCode::kCorruptData, "not an .xz stream (" + dec(size) + " bytes)");
  RGS_RETURN_ERROR_IF(lzma_stream_header_decode(flags, src) != LZMA_OK, StatusCode::kCorruptData,
                      ".xz stream header is damaged or names an unknown check");
  lzma_stream_flags footer;
  RGS_RETURN_ERROR_IF(lzma_stream_footer_decode(&footer, src + size - kXzStreamFooterBytes) != LZMA_OK,
                      StatusCode::kCorruptData, ".xz stream footer is damaged (or the stream has trailing bytes)");
  RGS_RETURN_ERROR_IF(lzma_stream_flags_compare(flags, &footer) != LZMA_OK, StatusCode::kCorruptData,
                      ".xz stream footer does not match its header");
  RGS_RETURN_ERROR_IF(flags->check != LZMA_CHECK_CRC32 && flags->check != LZMA_CHECK_CRC64 &&
                          flags->check != LZMA_CHECK_SHA256,
                      StatusCode::kCorruptData,
                      ".xz stream check " + dec(static_cast<uint64_t>(flags->check)) +
                          ": SPEC 3.3.2 requires CRC32, CRC64 or SHA-256");
  const uint64_t backward = footer.backward_size;
  RGS_RETURN_ERROR_IF(backward > size - kXzStreamHeaderBytes - kXzStreamFooterBytes, StatusCode::kCorruptData,
                      ".xz index of " + dec(backward) + " bytes does not fit the stream");
  // The index holds a record of a few bytes per block: its memory is bounded by the stream's size.
  uint64_t memlimit = std::max<uint64_t>(uint64_t{1} << 20, uint64_t{size} * 16);
  lzma_index* decoded = nullptr;
  size_t pos = size - kXzStreamFooterBytes - static_cast<size_t>(backward);
  const lzma_ret r = lzma_index_buffer_decode(&decoded, &memlimit, nullptr, src, &pos, size - kXzStreamFooterBytes);
  if (r == LZMA_MEM_ERROR) return Status(StatusCode::kOutOfMemory, "out of memory decoding an .xz index");
  if (decoded != nullptr) index->reset(decoded);
  RGS_RETURN_ERROR_IF(r != LZMA_OK || pos != size - kXzStreamFooterBytes, StatusCode::kCorruptData,
                      ".xz index is damaged or shorter than the footer says");
  RGS_RETURN_ERROR_IF(lzma_index_stream_flags(decoded, flags) != LZMA_OK, StatusCode::kCorruptData,
                      ".xz stream flags refused");
  RGS_RETURN_ERROR_IF(lzma_index_stream_size(decoded) != size, StatusCode::kCorruptData,
                      ".xz index describes a stream of " + dec(lzma_index_stream_size(decoded)) + " bytes, not " +
                          dec(size) + " (SPEC 3.3.2: one stream, no padding)");
  RGS_RETURN_ERROR_IF(lzma_index_uncompressed_size(decoded) != raw_size, StatusCode::kCorruptData,
                      ".xz stream decodes to " + dec(lzma_index_uncompressed_size(decoded)) + " bytes, expected " +
                          dec(raw_size));
  return Status();
}

}  // namespace

uint32_t xz_writer_dictionary(uint64_t raw_size) {
  uint32_t dictionary = kXzMinDictionaryBytes;
  while (dictionary < raw_size && dictionary < (uint32_t{8} << 20)) dictionary *= 2;
  return dictionary;
}

uint64_t xz_max_dictionary(uint64_t raw_size) { return std::max<uint64_t>(kXzMinDictionaryBytes, 2 * raw_size); }

bool is_xz_stream(const uint8_t* src, size_t size) {
  return size >= sizeof(kXzMagic) && std::memcmp(src, kXzMagic, sizeof(kXzMagic)) == 0;
}

Status check_xz_stream(const uint8_t* src, size_t size, uint64_t raw_size) {
  lzma_stream_flags flags;
  IndexPtr index(nullptr, free_index);
  return read_xz_index(src, size, raw_size, &flags, &index);
}

Status decode_xz_stream(const uint8_t* src, size_t size, uint8_t* dst, size_t raw_size) {
  lzma_stream_flags flags;
  IndexPtr index(nullptr, free_index);
  RGS_RETURN_IF_ERROR(read_xz_index(src, size, raw_size, &flags, &index));
  lzma_index_iter iter;
  lzma_index_iter_init(&iter, index.get());
  uint64_t block_number = 0;
  while (!lzma_index_iter_next(&iter, LZMA_INDEX_ITER_BLOCK)) {
    const std::string what = ".xz block " + dec(block_number++);
    // The index lies within the stream (read_xz_index), so every block does too.
    const size_t offset = static_cast<size_t>(iter.block.compressed_file_offset);
    lzma_filter filters[LZMA_FILTERS_MAX + 1];
    lzma_block block{};
    block.version = 1;
    block.check = flags.check;
    block.filters = filters;
    block.header_size = lzma_block_header_size_decode(src[offset]);
    RGS_RETURN_ERROR_IF(block.header_size > iter.block.total_size, StatusCode::kCorruptData,
                        what + ": header larger than the block");
    const lzma_ret header = lzma_block_header_decode(&block, nullptr, src + offset);
    if (header == LZMA_MEM_ERROR) return Status(StatusCode::kOutOfMemory, "out of memory decoding " + what);
    RGS_RETURN_ERROR_IF(header != LZMA_OK, StatusCode::kCorruptData, what + ": damaged block header");
    std::unique_ptr<lzma_filter, void (*)(lzma_filter*)> owned(filters, [](lzma_filter* f) {
      lzma_filters_free(f, nullptr);
    });
    RGS_RETURN_ERROR_IF(filters[0].id != LZMA_FILTER_LZMA2 || filters[1].id != LZMA_VLI_UNKNOWN,
                        StatusCode::kCorruptData, what + ": SPEC 3.3.2 allows the LZMA2 filter alone");
    const uint64_t dictionary = static_cast<const lzma_options_lzma*>(filters[0].options)->dict_size;
    RGS_RETURN_ERROR_IF(dictionary > xz_max_dictionary(raw_size), StatusCode::kCorruptData,
                        what + ": LZMA2 dictionary of " + dec(dictionary) + " bytes, more than the " +
                            dec(xz_max_dictionary(raw_size)) + " SPEC 3.3.2 allows for " + dec(raw_size) + " bytes");
    RGS_RETURN_ERROR_IF(lzma_block_compressed_size(&block, iter.block.unpadded_size) != LZMA_OK,
                        StatusCode::kCorruptData, what + ": its size in the index does not match its header");
    size_t in_pos = offset + block.header_size;
    size_t out_pos = static_cast<size_t>(iter.block.uncompressed_file_offset);
    const size_t out_end = out_pos + static_cast<size_t>(iter.block.uncompressed_size);
    const size_t block_end = offset + static_cast<size_t>(iter.block.total_size);
    const lzma_ret r = lzma_block_buffer_decode(&block, nullptr, src, &in_pos, block_end, dst, &out_pos, out_end);
    if (r == LZMA_MEM_ERROR) return Status(StatusCode::kOutOfMemory, "out of memory decoding " + what);
    RGS_RETURN_ERROR_IF(r != LZMA_OK || out_pos != out_end || in_pos != block_end, StatusCode::kCorruptData,
                        what + (r == LZMA_DATA_ERROR ? ": damaged data or check mismatch" : ": damaged"));
  }
  return Status();
}

Status compress_xz_stream(const uint8_t* raw, size_t size, uint32_t literal_context_bits, XzMatches matches,
                          uint32_t workers, std::vector<uint8_t>* out) {
  lzma_options_lzma options;
  const bool far = matches == XzMatches::kFar;
  RGS_RETURN_ERROR_IF(lzma_lzma_preset(&options, far ? 6 : 1) || literal_context_bits > LZMA_LCLP_MAX,
                      StatusCode::kInvalidArgument, "LZMA2 options refused");
  options.mode = LZMA_MODE_NORMAL;  // preset 1's fast mode takes 5 % more bytes of the codes
  options.dict_size = far ? xz_writer_dictionary(size) : kXzMinDictionaryBytes;
  options.lc = literal_context_bits;
  options.lp = 0;
  options.pb = 0;
  lzma_filter filters[2] = {{LZMA_FILTER_LZMA2, &options}, {LZMA_VLI_UNKNOWN, nullptr}};
  const size_t blocks = std::max<size_t>(1, (size + kXzBlockBytes - 1) / kXzBlockBytes);
  lzma_mt mt{};
  mt.block_size = kXzBlockBytes;
  mt.threads = static_cast<uint32_t>(std::clamp<size_t>(workers, 1, std::min<size_t>(blocks, 16384)));
  mt.filters = filters;
  mt.check = LZMA_CHECK_CRC32;
  lzma_stream stream = LZMA_STREAM_INIT;
  const lzma_ret init = lzma_stream_encoder_mt(&stream, &mt);
  if (init == LZMA_MEM_ERROR) return Status(StatusCode::kOutOfMemory, "out of memory for an .xz encoder");
  RGS_RETURN_ERROR_IF(init != LZMA_OK, StatusCode::kInvalidArgument, "the .xz encoder refused its options");
  std::unique_ptr<lzma_stream, void (*)(lzma_stream*)> owned(&stream, lzma_end);
  const size_t start = out->size();
  const size_t bound = lzma_stream_buffer_bound(size);
  RGS_RETURN_ERROR_IF(bound == 0, StatusCode::kInvalidArgument, dec(size) + " bytes are too large for .xz");
  out->resize(start + bound);
  stream.next_in = raw;
  stream.avail_in = size;
  stream.next_out = out->data() + start;
  stream.avail_out = bound;
  lzma_ret r = LZMA_OK;
  while (r == LZMA_OK) r = lzma_code(&stream, LZMA_FINISH);
  if (r == LZMA_MEM_ERROR) return Status(StatusCode::kOutOfMemory, "out of memory compressing .xz blocks");
  RGS_RETURN_ERROR_IF(r != LZMA_STREAM_END, StatusCode::kInvalidArgument,
                      ".xz compression failed (liblzma code " + dec(static_cast<uint64_t>(r)) + ")");
  out->resize(start + static_cast<size_t>(stream.total_out));
  out->shrink_to_fit();
  return Status();
}

}  // namespace rgs::format::detail
