// SPZ reader: versions 2-3 (one gzip member holding a 16-byte header and the attribute arrays) and
// version 4 (32-byte plaintext header, extension records, TOC, one zstd stream per attribute).
#include "rgs/converter/spz.h"

#include <zlib.h>
#define ZSTD_STATIC_LINKING_ONLY  // ZSTD_getErrorCode / ZSTD_error_checksum_wrong
#include <zstd.h>
#include <zstd_errors.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "../internal_input_file.h"
#include "../internal_interop.h"
#include "../internal_spz.h"

namespace rgs::converter {

namespace {

using format::load_u32_le;
using format::load_u64_le;

/// Above this, an SPZ version field is damage, not a version from the future (they count 1, 2, 3, 4, ...).
constexpr uint32_t kMaxPlausibleSpzVersion = 255;

/// Largest expansion of a zstd stream: a block (at most 128 KiB of output) takes at least 4 bytes
/// (3-byte header + 1 RLE byte), so output <= 32768 × input.
constexpr uint64_t kMaxZstdExpansion = 32768;
/// Largest expansion of deflate data (a 258-byte match costs at least 2 bits: ~1032:1), plus slack for
/// the gzip header and trailer.
constexpr uint64_t kMaxDeflateExpansion = 1032;
/// Largest extension block read from the end of a gzip payload.
constexpr uint64_t kMaxLegacyExtensionBytes = uint64_t{16} << 20;

struct Header {
  uint32_t version = 0;
  uint32_t num_points = 0;
  uint32_t sh_degree = 0;
  uint32_t fractional_bits = 0;
  uint8_t flags = 0;
};

/// The fields both containers' headers share, from byte 4 on: version, count, SH degree, fractional bits, flags.
Header read_header(const uint8_t* p) {
  return Header{load_u32_le(p + 4), load_u32_le(p + 8), p[12], p[13], p[14]};
}

/// Byte size of each attribute array, in file order.
struct StreamSizes {
  uint64_t bytes[detail::kSpzStreamCount] = {};
};

/// Checks the header fields every version shares; fills the stream sizes.
Status check_header(const Header& h, const InteropReadOptions& options, StreamSizes* sizes) {
  if (h.version == 0 || h.version > kMaxPlausibleSpzVersion) {
    return Status(StatusCode::kCorruptData, "damaged SPZ file: its version field reads " + std::to_string(h.version) +
                                                ", which no SPZ version has");
  }
  if (h.version < kMinSpzVersion || h.version > kMaxSpzVersion) {
    return Status(StatusCode::kUnsupportedVersion,
                  "SPZ version " + std::to_string(h.version) + " is not supported (this build reads " +
                      std::to_string(kMinSpzVersion) + ".." + std::to_string(kMaxSpzVersion) + ")");
  }
  if (h.sh_degree > 3) {
    return Status(h.sh_degree == 4 ? StatusCode::kUnsupportedFeature : StatusCode::kCorruptData,
                  "SPZ SH degree " + std::to_string(h.sh_degree) +
                      (h.sh_degree == 4 ? " is not supported (RoofGS clouds hold degree 0..3)" : " is invalid (0..4)"));
  }
  if (h.fractional_bits > detail::kSpzMaxFractionalBits) {
    return Status(StatusCode::kCorruptData, "SPZ fractionalBits " + std::to_string(h.fractional_bits) + " > " +
                                                std::to_string(detail::kSpzMaxFractionalBits));
  }
  RGS_RETURN_IF_ERROR(detail::check_limit("SPZ declares ", h.num_points, "Gaussians", options.max_gaussians));
  const uint64_t n = h.num_points;
  const uint64_t rot = h.version >= kMinSpzVersionForSmallestThree ? 4 : 3;
  const uint64_t per_point[detail::kSpzStreamCount] = {9, 1, 3, 3, rot, detail::spz_sh_bytes(h.sh_degree)};
  for (int s = 0; s < detail::kSpzStreamCount; ++s) sizes->bytes[s] = n * per_point[s];  // n < 2^32
  return Status();
}

/// Parses `[u32 type][u32 length][payload]` records; a coordinate-system record naming a frame sets *frame and
/// *declared.
Status parse_extensions(const uint8_t* p, uint64_t n, std::string* frame, bool* declared,
                        std::vector<std::string>* notes) {
  uint64_t pos = 0;
  while (pos < n) {
    if (n - pos < 8) {
      return Status(StatusCode::kCorruptData, "SPZ extension block ends inside a record header (" +
                                                  std::to_string(n - pos) + " bytes left)");
    }
    const uint32_t type = load_u32_le(p + pos);
    const uint32_t length = load_u32_le(p + pos + 4);
    pos += 8;
    if (length > n - pos) {
      return Status(StatusCode::kCorruptData, "SPZ extension 0x" + detail::hex32(type) + " declares " +
                                                  std::to_string(length) + " bytes but " + std::to_string(n - pos) +
                                                  " remain in the extension block");
    }
    if (type == detail::kSpzExtCoordinateSystem && length >= 4) {
      const uint32_t value = load_u32_le(p + pos);
      if (value >= 1 && value <= 8) {
        *frame = detail::spz_frame_name(value);
        *declared = true;
      } else if (value >= 9 && value <= 16) {
        return Status(StatusCode::kUnsupportedFeature,
                      "SPZ coordinate-system extension names rotated frame " + std::to_string(value) +
                          " (LFD..RBU); only the flip-only frames LDB..RUF are supported");
      } else if (value != 0) {
        return Status(StatusCode::kCorruptData,
                      "SPZ coordinate-system extension holds unknown value " + std::to_string(value));
      }
    } else {
      notes->push_back("SPZ extension 0x" + detail::hex32(type) + " (" + std::to_string(length) +
                       " bytes) skipped: not used by RoofGS");
    }
    pos += length;
  }
  return Status();
}

/// Decodes the attribute arrays into `cloud` (stored axes, rotations not yet renormalized).
void decode(const Header& h, const uint8_t* const streams[detail::kSpzStreamCount], format::GaussianCloud* cloud) {
  const uint64_t n = h.num_points;
  cloud->sh_degree = h.sh_degree;
  cloud->resize(static_cast<size_t>(n));
  const uint32_t k_count = cloud->sh_coefficients();
  const uint8_t* pos = streams[detail::kSpzPositions];
  const uint8_t* alpha = streams[detail::kSpzAlphas];
  const uint8_t* color = streams[detail::kSpzColors];
  const uint8_t* scale = streams[detail::kSpzScales];
  const uint8_t* rot = streams[detail::kSpzRotations];
  const uint8_t* sh = streams[detail::kSpzSh];
  const bool smallest_three = h.version >= kMinSpzVersionForSmallestThree;
  const int fb = static_cast<int>(h.fractional_bits);
  for (uint64_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      cloud->means[i * 3 + a] = detail::spz_decode_position(pos + (i * 3 + a) * 3, fb);
      cloud->scales[i * 3 + a] = detail::spz_decode_scale(scale[i * 3 + a]);
    }
    cloud->opacities[i] = detail::spz_decode_alpha(alpha[i]);
    float* out_sh = cloud->sh.data() + i * k_count * 3;
    for (int c = 0; c < 3; ++c) out_sh[c] = detail::spz_decode_color(color[i * 3 + c]);
    for (uint32_t k = 1; k < k_count; ++k) {
      for (int c = 0; c < 3; ++c) {
        out_sh[k * 3 + c] = detail::spz_decode_sh(sh[(i * (k_count - 1) + (k - 1)) * 3 + c]);
      }
    }
    float xyzw[4];
    if (smallest_three) {
      detail::spz_decode_smallest_three(rot + i * 4, xyzw);
    } else {
      detail::spz_decode_first_three(rot + i * 3, xyzw);
    }
    float* q = cloud->rotations.data() + i * 4;
    q[0] = xyzw[3];
    q[1] = xyzw[0];
    q[2] = xyzw[1];
    q[3] = xyzw[2];
  }
}

/// Frame conversion, hygiene and notes, shared by both containers.
Status finish(const Header& h, const std::string& stored_frame, const InteropReadOptions& options,
              InteropScene* scene) {
  scene->format = "spz";
  scene->format_version = h.version;
  scene->declared_gaussians = h.num_points;
  scene->stored_frame = stored_frame;
  if (options.convert_frame || scene->frame_declared) {
    detail::AxisFlip flip;
    if (!detail::flip_to_rdf(stored_frame, &flip)) {
      return Status(StatusCode::kUnsupportedFeature, "SPZ frame '" + stored_frame + "' cannot be converted");
    }
    detail::apply_axis_flip(flip, &scene->cloud);
    scene->frame_converted = true;
  }
  // Trained with the 2D Mip filter: the renderers apply its opacity compensation (GaussianCloud::antialiased).
  scene->cloud.antialiased = (h.flags & detail::kSpzFlagAntialiased) != 0;
  const uint8_t unknown = h.flags & ~(detail::kSpzFlagAntialiased | detail::kSpzFlagExtensions);
  if (unknown != 0) {
    scene->notes.push_back("SPZ header flag bits 0x" + detail::hex32(unknown) + " unknown and ignored");
  }
  return detail::finish_hygiene(options.invalid_policy, "Gaussian", &scene->cloud, &scene->hygiene);
}

Status zstd_status(size_t code, int stream) {
  const ZSTD_ErrorCode e = ZSTD_getErrorCode(code);
  const std::string what = "SPZ stream " + std::to_string(stream) + " (" + detail::kSpzStreamNames[stream] + "): ";
  if (e == ZSTD_error_checksum_wrong) {
    return Status(StatusCode::kChecksumMismatch, what + "zstd content checksum does not match");
  }
  if (e == ZSTD_error_memory_allocation) return Status(StatusCode::kOutOfMemory, what + "zstd out of memory");
  return Status(StatusCode::kCorruptData, what + "zstd data is malformed (" + ZSTD_getErrorName(code) + ")");
}

Result<InteropScene> read_v4(const uint8_t* data, size_t size, const InteropReadOptions& options) {
  if (size < detail::kSpzV4HeaderBytes) {
    return Status(StatusCode::kIoError,
                  "file is " + std::to_string(size) + " bytes, shorter than the 32-byte SPZ header");
  }
  const Header h = read_header(data);
  const uint32_t num_streams = data[15];
  const uint32_t toc_offset = load_u32_le(data + 16);
  StreamSizes sizes;
  RGS_RETURN_IF_ERROR(check_header(h, options, &sizes));
  if (h.version < kMinSpzVersionForZstd) {
    return Status(StatusCode::kUnsupportedVersion,
                  "plaintext SPZ header with version " + std::to_string(h.version) +
                      " (versions before 4 are gzip-wrapped and start with 1f 8b)");
  }
  for (size_t b = 20; b < detail::kSpzV4HeaderBytes; ++b) {
    if (data[b] != 0) {
      return Status(StatusCode::kCorruptData, "SPZ header reserved byte " + std::to_string(b) + " is " +
                                                  std::to_string(data[b]) + ", must be 0");
    }
  }
  // Streams of size zero are omitted (an SH-0 file has 5).
  int present[detail::kSpzStreamCount];
  uint32_t expected_streams = 0;
  for (int s = 0; s < detail::kSpzStreamCount; ++s) {
    if (sizes.bytes[s] != 0) present[expected_streams++] = s;
  }
  if (num_streams != expected_streams) {
    return Status(StatusCode::kCorruptData, "SPZ header declares " + std::to_string(num_streams) + " streams; " +
                                                std::to_string(h.num_points) + " Gaussians at SH degree " +
                                                std::to_string(h.sh_degree) + " need " +
                                                std::to_string(expected_streams));
  }
  if (toc_offset < detail::kSpzV4HeaderBytes) {
    return Status(StatusCode::kCorruptData,
                  "SPZ TOC offset " + std::to_string(toc_offset) + " is inside the 32-byte header");
  }
  if (!(h.flags & detail::kSpzFlagExtensions) && toc_offset != detail::kSpzV4HeaderBytes) {
    return Status(StatusCode::kCorruptData, "SPZ TOC offset " + std::to_string(toc_offset) +
                                                " leaves an extension block but the extension flag is not set");
  }
  const uint64_t toc_end = uint64_t{toc_offset} + uint64_t{num_streams} * 16;
  if (toc_end > size) {
    return Status(StatusCode::kIoError, "SPZ TOC ends at byte " + std::to_string(toc_end) + " > file size " +
                                            std::to_string(size) + " (truncated file?)");
  }
  InteropScene scene;
  std::string frame = "RUB";
  RGS_RETURN_IF_ERROR(parse_extensions(data + detail::kSpzV4HeaderBytes, toc_offset - detail::kSpzV4HeaderBytes,
                                       &frame, &scene.frame_declared, &scene.notes));
  // Every stream inside the file, back to back, the last ending at the end of the file.
  uint64_t offsets[detail::kSpzStreamCount] = {};
  uint64_t compressed[detail::kSpzStreamCount] = {};
  auto stream_name = [&present](uint32_t t) {
    return "SPZ stream " + std::to_string(t) + " (" + detail::kSpzStreamNames[present[t]] + ")";
  };
  uint64_t at = toc_end;
  for (uint32_t t = 0; t < num_streams; ++t) {
    const int s = present[t];
    const uint8_t* e = data + toc_offset + t * 16;
    compressed[s] = load_u64_le(e);
    const uint64_t raw = load_u64_le(e + 8);
    const std::string name = stream_name(t);
    if (raw != sizes.bytes[s]) {
      return Status(StatusCode::kCorruptData, name + " holds " + std::to_string(raw) + " bytes; " +
                                                  std::to_string(h.num_points) + " Gaussians need " +
                                                  std::to_string(sizes.bytes[s]));
    }
    uint64_t end = 0;
    if (!format::checked_add(at, compressed[s], &end) || end > size) {
      return Status(StatusCode::kIoError, name + " ends at byte " +
                                              (end == 0 ? std::string("2^64+") : std::to_string(end)) +
                                              " > file size " + std::to_string(size) + " (truncated file?)");
    }
    uint64_t most = 0;
    if (format::checked_mul(compressed[s], kMaxZstdExpansion, &most) && raw > most) {
      return Status(StatusCode::kCorruptData, name + ": " + std::to_string(compressed[s]) +
                                                  " zstd bytes cannot expand to " + std::to_string(raw));
    }
    offsets[s] = at;
    at = end;
  }
  if (at != size) {
    return Status(StatusCode::kCorruptData, "SPZ streams end at byte " + std::to_string(at) + " but the file has " +
                                                std::to_string(size) + " bytes");
  }
  uint64_t raw_total = 0;
  for (uint32_t t = 0; t < num_streams; ++t) raw_total += sizes.bytes[present[t]];  // < 2^32 · 64
  RGS_RETURN_IF_ERROR(detail::check_decode_budget(raw_total, size, options.max_decompression_ratio, "",
                                                  "the SPZ streams of " + std::to_string(h.num_points) + " Gaussians"));
  // Declared frame sizes, when the frames carry them, before allocating.
  for (uint32_t t = 0; t < num_streams; ++t) {
    const int s = present[t];
    const unsigned long long declared = ZSTD_findDecompressedSize(data + offsets[s], compressed[s]);
    if (declared == ZSTD_CONTENTSIZE_ERROR) {
      return Status(StatusCode::kCorruptData, stream_name(t) + " is not a sequence of zstd frames");
    }
    if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared != sizes.bytes[s]) {
      return Status(StatusCode::kCorruptData, stream_name(t) + " zstd frames declare " + std::to_string(declared) +
                                                  " bytes, the TOC " + std::to_string(sizes.bytes[s]));
    }
  }
  std::vector<uint8_t> raw[detail::kSpzStreamCount];
  const uint8_t* views[detail::kSpzStreamCount] = {};
  std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  if (!dctx) return Status(StatusCode::kOutOfMemory, "cannot allocate a zstd decompression context");
  for (uint32_t t = 0; t < num_streams; ++t) {
    const int s = present[t];
    raw[s].resize(static_cast<size_t>(sizes.bytes[s]));
    const size_t got = ZSTD_decompressDCtx(dctx.get(), raw[s].data(), raw[s].size(), data + offsets[s],
                                           static_cast<size_t>(compressed[s]));
    if (ZSTD_isError(got)) return zstd_status(got, s);
    if (got != raw[s].size()) {
      return Status(StatusCode::kCorruptData, stream_name(t) + " decompresses to " + std::to_string(got) +
                                                  " bytes, expected " + std::to_string(raw[s].size()));
    }
    views[s] = raw[s].data();
  }
  decode(h, views, &scene.cloud);
  for (auto& r : raw) std::vector<uint8_t>().swap(r);
  RGS_RETURN_IF_ERROR(finish(h, frame, options, &scene));
  scene.file_bytes = size;
  return scene;
}

/// Inflates a gzip member in pieces, telling a truncated input (kIoError) from bad data (kCorruptData)
/// and a failed CRC-32 or length check (kChecksumMismatch).
class GzipReader {
 public:
  GzipReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  ~GzipReader() {
    if (initialized_) inflateEnd(&zs_);
  }
  GzipReader(const GzipReader&) = delete;
  GzipReader& operator=(const GzipReader&) = delete;

  Status open() {
    zs_ = z_stream{};
    const int r = inflateInit2(&zs_, 16 + MAX_WBITS);  // gzip wrapper only
    if (r != Z_OK)
      return Status(StatusCode::kOutOfMemory, "cannot initialize zlib inflate (code " + std::to_string(r) + ")");
    initialized_ = true;
    return Status();
  }

  /// Inflates up to `n` bytes into `out`; *got < n only when the member ended.
  Status read(uint8_t* out, size_t n, size_t* got) {
    *got = 0;
    while (*got < n && !ended_) {
      refill();
      const size_t want = std::min<size_t>(n - *got, UINT_MAX);
      zs_.next_out = out + *got;
      zs_.avail_out = static_cast<uInt>(want);
      const int r = inflate(&zs_, Z_NO_FLUSH);
      *got += want - zs_.avail_out;
      if (r == Z_STREAM_END) {
        ended_ = true;
      } else if (r == Z_OK || r == Z_BUF_ERROR) {
        if (zs_.avail_out != 0 && zs_.avail_in == 0 && fed_ == size_) {
          return Status(StatusCode::kIoError, "gzip stream ends after " + std::to_string(size_) +
                                                  " bytes without its end marker (truncated file?)");
        }
      } else if (r == Z_DATA_ERROR) {
        const std::string msg = zs_.msg ? zs_.msg : "invalid deflate data";
        if (msg.find("check") != std::string::npos) {
          return Status(StatusCode::kChecksumMismatch, "gzip " + msg + " (CRC-32 or length of the inflated data)");
        }
        return Status(StatusCode::kCorruptData, "bad gzip data: " + msg);
      } else if (r == Z_MEM_ERROR) {
        return Status(StatusCode::kOutOfMemory, "zlib out of memory");
      } else if (r != Z_OK) {
        return Status(StatusCode::kCorruptData, "bad gzip data (zlib code " + std::to_string(r) + ")");
      }
    }
    return Status();
  }

  bool ended() const { return ended_; }
  /// Compressed bytes after the end of the member.
  uint64_t trailing_bytes() const { return zs_.avail_in + (size_ - fed_); }

 private:
  void refill() {
    if (zs_.avail_in != 0 || fed_ == size_) return;
    const size_t chunk = std::min<size_t>(size_ - fed_, UINT_MAX);
    zs_.next_in = const_cast<Bytef*>(data_ + fed_);  // zlib's API is not const-correct
    zs_.avail_in = static_cast<uInt>(chunk);
    fed_ += chunk;
  }

  const uint8_t* data_;
  size_t size_;
  size_t fed_ = 0;
  z_stream zs_{};
  bool initialized_ = false;
  bool ended_ = false;
};

Result<InteropScene> read_legacy(const uint8_t* data, size_t size, const InteropReadOptions& options) {
  GzipReader gz(data, size);
  RGS_RETURN_IF_ERROR(gz.open());
  uint8_t head[detail::kSpzLegacyHeaderBytes];
  size_t got = 0;
  RGS_RETURN_IF_ERROR(gz.read(head, sizeof(head), &got));
  if (got < sizeof(head)) {
    return Status(StatusCode::kCorruptData, "gzip stream inflates to " + std::to_string(got) +
                                                " bytes, less than the 16-byte SPZ header");
  }
  if (load_u32_le(head) != detail::kSpzMagic) {
    return Status(StatusCode::kCorruptData, "gzip stream does not start with the SPZ magic 'NGSP'");
  }
  const Header h = read_header(head);
  if (h.version >= kMinSpzVersionForZstd && h.version <= kMaxSpzVersion) {
    return Status(StatusCode::kUnsupportedVersion, "gzip-wrapped SPZ declares version " + std::to_string(h.version) +
                                                       "; version 4 files are not gzip-wrapped");
  }
  StreamSizes sizes;
  RGS_RETURN_IF_ERROR(check_header(h, options, &sizes));
  if (head[15] != 0) {
    return Status(StatusCode::kCorruptData,
                  "SPZ header reserved byte 15 is " + std::to_string(head[15]) + ", must be 0");
  }
  uint64_t payload = 0;
  for (uint64_t b : sizes.bytes) payload += b;  // < 2^32 · 64
  uint64_t most = 0;
  if (format::checked_mul(size, kMaxDeflateExpansion, &most) && payload > most + 1024) {
    return Status(StatusCode::kCorruptData, "SPZ declares " + std::to_string(h.num_points) + " Gaussians needing " +
                                                std::to_string(payload) + " bytes, more than " +
                                                std::to_string(size) + " gzip bytes can inflate to");
  }
  RGS_RETURN_IF_ERROR(detail::check_decode_budget(payload, size, options.max_decompression_ratio, "",
                                                  "the gzip stream's " + std::to_string(h.num_points) + " Gaussians"));
  std::vector<uint8_t> body(static_cast<size_t>(payload));
  RGS_RETURN_IF_ERROR(gz.read(body.data(), body.size(), &got));
  if (got < body.size()) {
    return Status(StatusCode::kCorruptData, "gzip stream ends after " + std::to_string(got + 16) + " of " +
                                                std::to_string(payload + 16) + " bytes that " +
                                                std::to_string(h.num_points) + " Gaussians need");
  }
  // What follows the arrays: extension records (flag 0x2) or nothing.
  std::vector<uint8_t> tail;
  uint8_t piece[4096];
  while (!gz.ended()) {
    RGS_RETURN_IF_ERROR(gz.read(piece, sizeof(piece), &got));
    tail.insert(tail.end(), piece, piece + got);
    if (tail.size() > kMaxLegacyExtensionBytes) {
      return Status(
          StatusCode::kLimitExceeded,
          "SPZ data continues more than " + std::to_string(kMaxLegacyExtensionBytes) + " bytes past its arrays");
    }
  }
  if (gz.trailing_bytes() != 0) {
    return Status(StatusCode::kCorruptData,
                  std::to_string(gz.trailing_bytes()) + " bytes follow the gzip member of the SPZ file");
  }
  InteropScene scene;
  std::string frame = "RUB";
  if (h.flags & detail::kSpzFlagExtensions) {
    RGS_RETURN_IF_ERROR(parse_extensions(tail.data(), tail.size(), &frame, &scene.frame_declared, &scene.notes));
  } else if (!tail.empty()) {
    return Status(StatusCode::kCorruptData, std::to_string(tail.size()) +
                                                " bytes follow the SPZ arrays but the extension flag is not set");
  }
  const uint8_t* views[detail::kSpzStreamCount];
  uint64_t at = 0;
  for (int s = 0; s < detail::kSpzStreamCount; ++s) {
    views[s] = body.data() + at;
    at += sizes.bytes[s];
  }
  decode(h, views, &scene.cloud);
  std::vector<uint8_t>().swap(body);
  RGS_RETURN_IF_ERROR(finish(h, frame, options, &scene));
  scene.file_bytes = size;
  return scene;
}

Result<InteropScene> read_any(const uint8_t* data, size_t size, const InteropReadOptions& options) {
  if (size >= 4 && load_u32_le(data) == detail::kSpzMagic) return read_v4(data, size, options);
  if (size >= 2 && data[0] == 0x1f && data[1] == 0x8b) {
    auto scene = read_legacy(data, size, options);
    if (!scene.ok()) return Status(scene.status()).prepend("gzip-wrapped SPZ (v2/v3)");
    return scene;
  }
  return Status(StatusCode::kCorruptData, "not an SPZ file (starts neither with 'NGSP' nor with a gzip member)");
}

}  // namespace

bool looks_like_spz(const uint8_t* head, size_t n) {
  if (head == nullptr) return false;
  // The magic alone decides: a version this build does not read, or a damaged one, is read_spz's to name.
  if (n >= 8 && load_u32_le(head) == detail::kSpzMagic) return true;
  if (n < 3 || head[0] != 0x1f || head[1] != 0x8b || head[2] != 0x08) return false;
  z_stream zs{};
  if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) return false;
  uint8_t out[4];
  zs.next_in = const_cast<Bytef*>(head);
  zs.avail_in = static_cast<uInt>(std::min<size_t>(n, UINT_MAX));
  zs.next_out = out;
  zs.avail_out = sizeof(out);
  int r = Z_OK;
  while (zs.avail_out > 0 && r == Z_OK) r = inflate(&zs, Z_NO_FLUSH);
  const size_t got = sizeof(out) - zs.avail_out;
  inflateEnd(&zs);
  if (got == sizeof(out)) return load_u32_le(out) == detail::kSpzMagic;
  // Could not inflate four bytes: a head too short to tell, or a member damaged before them, which read_spz
  // names (rather than "unsupported format"); only a whole member of fewer bytes is something else.
  return r != Z_STREAM_END;
}

Result<InteropScene> read_spz(const std::string& path, const InteropReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(auto file, format::MappedFile::open(path));  // its errors name the path
  return read_spz_bytes(file->data(), file->size(), path, options);
}

Result<InteropScene> read_spz_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const InteropReadOptions& options) {
  return detail::guarded_bytes<InteropScene>(data, size, name, "decoding the SPZ file",
                                             [&] { return read_any(data, size, options); });
}

}  // namespace rgs::converter
