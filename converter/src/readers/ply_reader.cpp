// PLY reader: header validation, binary (LE/BE, any scalar types, any property order) and ascii vertex
// decoding, INRIA activations and input hygiene (docs/INPUT_HYGIENE.md).
//
// Memory: read_ply() streams the vertex data with pread() through one reusable 1 MB buffer per worker
// thread, so the peak is the decoded cloud plus a few MB, not the file (mmap'd pages would count toward
// RSS); read_ply_bytes() copies the caller's span through the same buffers. With PlyReadOptions::hash_file the same
// pass feeds the bytes to XXH64 in file order, so the file is read once. PlyStream hashes every one of its passes
// so, and compares each later pass's hash and the file's identity with the first pass's.
#include "rgs/converter/ply_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <xxhash.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "../internal_huge_pages.h"
#include "../internal_input_file.h"
#include "../internal_interop.h"
#include "../internal_parallel.h"
#include "internal_ply_header.h"
#include "rgs/converter/scene_reader.h"

namespace rgs::converter {

namespace {

using detail::PlyElement;
using detail::PlyHeader;
using detail::PlyProperty;
using detail::PlyStorage;
using detail::PlyType;

constexpr bool kHostLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
/// Bytes of vertex data a worker reads from a file at once (rounded down to whole rows, at least one):
/// small enough that a chunk is still in cache when it is hashed and decoded.
constexpr size_t kFileChunkBytes = size_t{1} << 20;
/// Bytes of ascii text scanned per window.
constexpr size_t kAsciiWindowBytes = size_t{1} << 20;
/// Longest ascii token accepted (numbers are far shorter); bounds the carried-over partial token.
constexpr size_t kMaxAsciiToken = 256;
/// Rows per worker below which decoding stays on one thread.
constexpr uint64_t kMinRowsPerWorker = 8192;
/// Most SH values per Gaussian (degree 3: 16 coefficients × 3 channels).
constexpr uint32_t kMaxShValues = 48;

// ---------------------------------------------------------------------------------------------------
// Vertex layout: where each needed value lives in a row.

/// One needed value: byte offset in a binary row, type, and index among the vertex properties (ascii).
struct FieldSource {
  uint32_t offset = 0;
  uint32_t index = 0;
  PlyType type = PlyType::kFloat32;
};

struct VertexLayout {
  uint32_t sh_degree = 0;
  uint32_t sh_values = 3;  ///< K·3
  FieldSource mean[3];
  FieldSource opacity;
  FieldSource scale[3];
  FieldSource rot[4];
  /// SH in cloud order: entry k·3 + c is coefficient k of channel c.
  FieldSource sh[kMaxShValues];
  size_t stride = 0;          ///< binary row size
  size_t property_count = 0;  ///< values per ascii row
  /// Every needed value is float32 and the file is little-endian on a little-endian host.
  bool all_float_native = false;
};

/// Validates the vertex properties and locates the ones the cloud needs.
Status resolve_layout(const PlyElement& vertex, PlyStorage storage, VertexLayout* layout) {
  std::unordered_map<std::string_view, size_t> by_name;
  size_t offset = 0;
  std::vector<uint32_t> offsets(vertex.properties.size());
  for (size_t p = 0; p < vertex.properties.size(); ++p) {
    const PlyProperty& prop = vertex.properties[p];
    if (prop.is_list) {
      return Status(StatusCode::kUnsupportedFeature,
                    "PLY header line " + std::to_string(prop.header_line) + ": vertex property '" + prop.name +
                        "' is a list; 3DGS vertices have scalar properties only");
    }
    if (!prop.known_type) {
      return Status(StatusCode::kUnsupportedFeature,
                    "PLY header line " + std::to_string(prop.header_line) + ": unknown type '" + prop.type_name +
                        "' of vertex property '" + prop.name +
                        "' (known: char uchar short ushort int uint float double and int8..float64)");
    }
    offsets[p] = static_cast<uint32_t>(offset);
    offset += detail::ply_type_size(prop.type);
    by_name.emplace(prop.name, p);
  }
  layout->stride = offset;
  layout->property_count = vertex.properties.size();

  auto find = [&](const std::string& name, FieldSource* out) -> Status {
    auto it = by_name.find(name);
    if (it == by_name.end()) {
      return Status(StatusCode::kUnsupportedFeature,
                    "missing required vertex property '" + name +
                        "' (3DGS PLY needs x y z f_dc_0..2 opacity scale_0..2 rot_0..3)");
    }
    out->index = static_cast<uint32_t>(it->second);
    out->offset = offsets[it->second];
    out->type = vertex.properties[it->second].type;
    return Status();
  };
  static const char* const kAxes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) RGS_RETURN_IF_ERROR(find(kAxes[a], &layout->mean[a]));
  for (int c = 0; c < 3; ++c) RGS_RETURN_IF_ERROR(find("f_dc_" + std::to_string(c), &layout->sh[c]));
  RGS_RETURN_IF_ERROR(find("opacity", &layout->opacity));
  for (int a = 0; a < 3; ++a) RGS_RETURN_IF_ERROR(find("scale_" + std::to_string(a), &layout->scale[a]));
  for (int a = 0; a < 4; ++a) RGS_RETURN_IF_ERROR(find("rot_" + std::to_string(a), &layout->rot[a]));

  // f_rest_0..M-1, M in {0, 9, 24, 45}; indices must be canonical decimal and contiguous.
  size_t rest_count = 0;
  for (const PlyProperty& prop : vertex.properties) rest_count += prop.name.rfind("f_rest_", 0) == 0;
  uint32_t degree = 0;
  if (!detail::sh_degree_of_rest_count(rest_count, &degree)) {
    return Status(StatusCode::kUnsupportedFeature,
                  "vertex has " + std::to_string(rest_count) +
                      " f_rest_* properties; 3DGS files have 0, 9, 24 or 45 (SH degree 0..3)");
  }
  const uint32_t k_count = format::sh_coefficient_count(degree);
  for (size_t r = 0; r < rest_count; ++r) {
    FieldSource src;
    const std::string name = "f_rest_" + std::to_string(r);
    if (by_name.find(name) == by_name.end()) {
      return Status(StatusCode::kUnsupportedFeature,
                    "vertex has " + std::to_string(rest_count) + " f_rest_* properties but no '" + name +
                        "'; expected exactly f_rest_0..f_rest_" + std::to_string(rest_count - 1));
    }
    RGS_RETURN_IF_ERROR(find(name, &src));
    // f_rest is channel-major: f_rest[c·(K−1) + k−1] is coefficient k of channel c.
    const uint32_t c = static_cast<uint32_t>(r / (k_count - 1));
    const uint32_t k = static_cast<uint32_t>(r % (k_count - 1)) + 1;
    layout->sh[k * 3 + c] = src;
  }
  layout->sh_degree = degree;
  layout->sh_values = k_count * 3;

  bool all_float = kHostLittleEndian && storage == PlyStorage::kBinaryLittleEndian;
  auto check = [&all_float](const FieldSource& f) { all_float = all_float && f.type == PlyType::kFloat32; };
  for (const auto& f : layout->mean) check(f);
  for (const auto& f : layout->scale) check(f);
  for (const auto& f : layout->rot) check(f);
  check(layout->opacity);
  for (uint32_t j = 0; j < layout->sh_values; ++j) check(layout->sh[j]);
  layout->all_float_native = all_float;
  return Status();
}

// ---------------------------------------------------------------------------------------------------
// Activation and hygiene, shared by every storage format.

/// The raw PLY values of one Gaussian, converted to float32.
struct RawGaussian {
  float mean[3];
  float opacity;
  float scale[3];
  float rot[4];
  float sh[kMaxShValues];
};

/// Hygiene counts of one slice of vertices, and the file indices of its invalid Gaussians (ascending); merged
/// in slice order.
struct HygieneCounts : InputHygiene {
  std::vector<uint64_t> invalid;
};

/// Converts to float32 without the undefined behaviour of casting an out-of-range double.
inline float to_float(double v) {
  constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
  if (v > kMax) return std::numeric_limits<float>::infinity();
  if (v < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

/// Fills `g` with get(field) for every field of `layout`.
template <typename Get>
inline void gather(const VertexLayout& layout, Get&& get, RawGaussian* g) {
  for (int a = 0; a < 3; ++a) g->mean[a] = get(layout.mean[a]);
  for (int a = 0; a < 3; ++a) g->scale[a] = get(layout.scale[a]);
  for (int a = 0; a < 4; ++a) g->rot[a] = get(layout.rot[a]);
  g->opacity = get(layout.opacity);
  for (uint32_t j = 0; j < layout.sh_values; ++j) g->sh[j] = get(layout.sh[j]);
}

/// Applies the INRIA activations to Gaussian `i` and stores it; counts problems into `counts`.
inline void activate_and_store(const RawGaussian& g, uint64_t i, uint32_t sh_values, format::GaussianCloud* cloud,
                               HygieneCounts* counts) {
  std::copy(g.mean, g.mean + 3, cloud->means.data() + i * 3);
  std::copy(g.sh, g.sh + sh_values, cloud->sh.data() + i * sh_values);
  std::copy(g.rot, g.rot + 4, cloud->rotations.data() + i * 4);
  // exp(-inf) = 0 is a valid (degenerate) scale, the PLY encoding of scale 0; exp overflow is not.
  for (int a = 0; a < 3; ++a) cloud->scales[i * 3 + a] = detail::activate_scale(g.scale[a]);
  counts->infinite_opacity_logits += std::isinf(g.opacity);
  cloud->opacities[i] = detail::activate_opacity(g.opacity);  // NaN stays NaN
  if (!cloud->pre_activation.empty()) {
    cloud->pre_activation[i * 4] = g.opacity;
    std::copy(g.scale, g.scale + 3, cloud->pre_activation.data() + i * 4 + 1);
  }
  if (detail::check_gaussian(cloud, i, counts)) counts->invalid.push_back(i);
}

// ---------------------------------------------------------------------------------------------------
// Binary rows.

template <typename T>
inline T load_raw(const uint8_t* p, bool swap) {
  uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  if (swap) std::reverse(bytes, bytes + sizeof(T));
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return v;
}

inline float load_value(const uint8_t* row, const FieldSource& f, bool swap) {
  const uint8_t* p = row + f.offset;
  switch (f.type) {
    case PlyType::kInt8: return static_cast<float>(load_raw<int8_t>(p, false));
    case PlyType::kUint8: return static_cast<float>(load_raw<uint8_t>(p, false));
    case PlyType::kInt16: return static_cast<float>(load_raw<int16_t>(p, swap));
    case PlyType::kUint16: return static_cast<float>(load_raw<uint16_t>(p, swap));
    case PlyType::kInt32: return static_cast<float>(load_raw<int32_t>(p, swap));
    case PlyType::kUint32: return static_cast<float>(load_raw<uint32_t>(p, swap));
    case PlyType::kFloat32: return load_raw<float>(p, swap);
    case PlyType::kFloat64: return to_float(load_raw<double>(p, swap));
  }
  return 0.0f;
}

inline float load_float_native(const uint8_t* row, const FieldSource& f) {
  float v;
  std::memcpy(&v, row + f.offset, 4);
  return v;
}

/// Decodes rows [0, n) starting at `rows` into cloud indices [first, first + n).
template <bool kAllFloatNative>
void decode_binary_rows(const uint8_t* rows, uint64_t n, uint64_t first, const VertexLayout& layout, bool swap,
                        format::GaussianCloud* cloud, HygieneCounts* counts) {
  RawGaussian g;
  const uint32_t sh_values = layout.sh_values;
  for (uint64_t r = 0; r < n; ++r) {
    const uint8_t* row = rows + r * layout.stride;
    auto get = [&](const FieldSource& f) {
      if constexpr (kAllFloatNative) {
        return load_float_native(row, f);
      } else {
        return load_value(row, f, swap);
      }
    };
    gather(layout, get, &g);
    activate_and_store(g, first + r, sh_values, cloud, counts);
  }
}

// ---------------------------------------------------------------------------------------------------
// Byte sources: a memory span, or a file read through one reusable buffer.

class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// Bytes [offset, offset + n), valid until the next call. The caller keeps the range inside size().
  /// Not thread safe.
  virtual Result<const uint8_t*> view(uint64_t offset, size_t n) = 0;
  /// Copies bytes [offset, offset + n) into `dst`. Thread safe.
  virtual Status read_into(uint64_t offset, size_t n, uint8_t* dst) const = 0;
  virtual uint64_t size() const = 0;
};

class MemorySource final : public ByteSource {
 public:
  MemorySource(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  Result<const uint8_t*> view(uint64_t offset, size_t /*n*/) override { return data_ + offset; }
  Status read_into(uint64_t offset, size_t n, uint8_t* dst) const override {
    if (n != 0) std::memcpy(dst, data_ + offset, n);
    return Status();
  }
  uint64_t size() const override { return size_; }

 private:
  const uint8_t* data_;
  size_t size_;
};

class FileSource final : public ByteSource {
 public:
  ~FileSource() override {
    if (fd_ >= 0) ::close(fd_);
  }
  Status open(const std::string& path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);  // a FIFO is refused, not waited on
    if (fd_ < 0) return Status(StatusCode::kIoError, "cannot open: " + detail::errno_message(errno));
    struct stat st;
    if (::fstat(fd_, &st) != 0) return Status(StatusCode::kIoError, "cannot stat: " + detail::errno_message(errno));
    if (S_ISDIR(st.st_mode)) return Status(StatusCode::kIoError, "is a directory, not a PLY file");
    if (!S_ISREG(st.st_mode)) return Status(StatusCode::kIoError, "not a regular file");
    size_ = static_cast<uint64_t>(st.st_size);
    opened_ = st;
    return Status();
  }
  /// The file as open() found it (fstat of its descriptor).
  const struct stat& opened() const { return opened_; }
  Result<const uint8_t*> view(uint64_t offset, size_t n) override {
    if (buffer_.size() < n) {
      buffer_.clear();
      buffer_.shrink_to_fit();
      buffer_.resize(n);
    }
    RGS_RETURN_IF_ERROR(read_into(offset, n, buffer_.data()));
    return buffer_.data();
  }
  Status read_into(uint64_t offset, size_t n, uint8_t* dst) const override {
    return detail::read_exact(fd_, std::string(), dst, n, offset);
  }
  uint64_t size() const override { return size_; }

 private:
  int fd_ = -1;
  uint64_t size_ = 0;
  struct stat opened_ {};
  std::vector<uint8_t> buffer_;
};

/// Feeds file bytes to XXH64 in file order while workers read chunks in parallel: chunk c is hashed only
/// after chunks 0..c-1. Chunks are claimed in increasing order by running workers, so the owner of the
/// lowest unhashed chunk never waits and the handoff cannot deadlock; abort() releases every waiter.
class OrderedHasher {
 public:
  explicit OrderedHasher(XXH64_state_t* state) : state_(state) {}
  /// Waits for chunk `index`'s turn, hashes [data, data + size) and passes the turn on. False after abort().
  bool update(uint64_t index, const uint8_t* data, size_t size) {
    std::unique_lock<std::mutex> lock(mutex_);
    turn_.wait(lock, [&] { return aborted_ || next_ == index; });
    if (aborted_) return false;
    XXH64_update(state_, data, size);
    ++next_;
    lock.unlock();
    turn_.notify_all();
    return true;
  }
  void abort() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      aborted_ = true;
    }
    turn_.notify_all();
  }

 private:
  XXH64_state_t* state_;
  std::mutex mutex_;
  std::condition_variable turn_;
  uint64_t next_ = 0;
  bool aborted_ = false;
};

/// Decodes the binary vertex rows: workers claim chunks of about kFileChunkBytes in file order, each reading into
/// its own buffer (pread is thread safe), so reading and decoding both run in parallel while memory stays at one
/// buffer per worker; when `hasher` is set, each chunk is also fed to it in file order right after it is read
/// (still in cache). Counts are kept per chunk and merged in file order, so the result does not depend on the
/// number of workers or on which worker decoded a chunk.
Status decode_binary(const ByteSource& source, uint64_t data_offset, uint64_t n, const VertexLayout& layout,
                     bool swap, OrderedHasher* hasher, format::GaussianCloud* cloud, HygieneCounts* total) {
  const unsigned workers = detail::worker_count(n, kMinRowsPerWorker);
  const size_t stride = layout.stride;
  const uint64_t chunk_rows = std::max<uint64_t>(1, kFileChunkBytes / stride);
  const uint64_t chunks = n == 0 ? 0 : (n - 1) / chunk_rows + 1;
  std::vector<HygieneCounts> parts(static_cast<size_t>(chunks));
  std::vector<Status> errors(static_cast<size_t>(chunks));
  std::vector<std::vector<uint8_t>> buffers(workers);
  for (auto& b : buffers) b.resize(static_cast<size_t>(std::min(chunk_rows, n) * stride));  // may throw: before threads
  std::atomic<bool> failed{false};
  RGS_RETURN_IF_ERROR(detail::parallel_items(chunks, workers, [&](unsigned t, uint64_t c) {
    if (failed.load(std::memory_order_relaxed)) return;
    const uint64_t first = c * chunk_rows;
    const uint64_t rows = std::min(chunk_rows, n - first);
    const size_t bytes = static_cast<size_t>(rows * stride);
    Status s = source.read_into(data_offset + first * stride, bytes, buffers[t].data());
    if (s.ok() && hasher != nullptr && !hasher->update(c, buffers[t].data(), bytes)) return;  // aborted
    if (s.ok()) {
      try {  // the invalid-index list can grow; name what ran out
        if (layout.all_float_native) {
          decode_binary_rows<true>(buffers[t].data(), rows, first, layout, swap, cloud, &parts[c]);
        } else {
          decode_binary_rows<false>(buffers[t].data(), rows, first, layout, swap, cloud, &parts[c]);
        }
      } catch (const std::bad_alloc&) {
        s = Status(StatusCode::kOutOfMemory, "out of memory listing invalid Gaussians");
      }
    }
    if (!s.ok()) {
      errors[c] = std::move(s);
      failed = true;
      if (hasher != nullptr) hasher->abort();
    }
  }));
  for (const Status& s : errors) RGS_RETURN_IF_ERROR(s);
  for (HygieneCounts& p : parts) {
    detail::add_hygiene(p, 0, total);  // the invalid indices are ours
    total->invalid.insert(total->invalid.end(), p.invalid.begin(), p.invalid.end());
  }
  return Status();
}

/// Feeds bytes [begin, end) of `source` to `state` in order, through view() windows of kFileChunkBytes.
Status hash_range(ByteSource* source, uint64_t begin, uint64_t end, XXH64_state_t* state) {
  for (uint64_t at = begin; at < end;) {
    const size_t size = static_cast<size_t>(std::min<uint64_t>(kFileChunkBytes, end - at));
    RGS_ASSIGN_OR_RETURN(const uint8_t* bytes, source->view(at, size));
    XXH64_update(state, bytes, size);
    at += size;
  }
  return Status();
}

// ---------------------------------------------------------------------------------------------------
// Ascii rows.

/// Whitespace tokenizer over a ByteSource window that slides forward, tracking line numbers.
class AsciiTokenizer {
 public:
  AsciiTokenizer(ByteSource* source, uint64_t start, size_t first_line)
      : source_(source), pos_(start), win_start_(start), win_end_(start), line_(first_line) {}

  size_t line() const { return line_; }

  /// Next token into *token; *eof when the file ends first.
  Status next(std::string_view* token, bool* eof) {
    *eof = false;
    for (;;) {  // skip whitespace
      if (pos_ == win_end_) {
        if (win_end_ == source_->size()) {
          *eof = true;
          return Status();
        }
        RGS_RETURN_IF_ERROR(slide(pos_));
      }
      const uint8_t ch = win_[pos_ - win_start_];
      if (ch == '\n') {
        ++line_;
      } else if (ch != ' ' && ch != '\t' && ch != '\r' && ch != '\f' && ch != '\v') {
        break;
      }
      ++pos_;
    }
    for (;;) {
      const uint64_t start = pos_;
      uint64_t p = pos_;
      while (p < win_end_) {
        const uint8_t ch = win_[p - win_start_];
        if (ch == ' ' || ch == '\n' || ch == '\t' || ch == '\r' || ch == '\f' || ch == '\v') break;
        ++p;
      }
      const bool cut = p == win_end_ && win_end_ < source_->size();  // the token may continue past the window
      // Too long, or cut although the window starts at it: the token is absurdly long.
      if (p - start > kMaxAsciiToken || (cut && win_start_ == start)) {
        return Status(StatusCode::kCorruptData, "line " + std::to_string(line_) + ": token longer than " +
                                                    std::to_string(kMaxAsciiToken) + " bytes");
      }
      if (cut) {
        RGS_RETURN_IF_ERROR(slide(start));  // re-read from its start
        continue;
      }
      *token = std::string_view(reinterpret_cast<const char*>(win_ + (start - win_start_)), p - start);
      pos_ = p;
      return Status();
    }
  }

 private:
  Status slide(uint64_t at) {
    const size_t n = static_cast<size_t>(std::min<uint64_t>(kAsciiWindowBytes, source_->size() - at));
    RGS_ASSIGN_OR_RETURN(win_, source_->view(at, n));
    win_start_ = at;
    win_end_ = at + n;
    return Status();
  }

  ByteSource* source_;
  const uint8_t* win_ = nullptr;
  uint64_t pos_;
  uint64_t win_start_;
  uint64_t win_end_;
  size_t line_;
};

/// Parses one ascii token as `type` (locale independent). Returns false on a malformed or out-of-range
/// token. Floats accept "inf", "-inf", "nan" (any case) and a leading '+'.
bool parse_ascii_value(std::string_view tok, PlyType type, float* out) {
  const char* first = tok.data();
  const char* last = first + tok.size();
  if (first != last && *first == '+' && last - first > 1 && first[1] != '-' && first[1] != '+') ++first;
  switch (type) {
    case PlyType::kFloat32: {
      float v;
      auto [p, ec] = std::from_chars(first, last, v);
      if (p != last) return false;
      if (ec == std::errc::result_out_of_range) {
        // Under/overflow in float: parse as double and round (gives 0, a subnormal or ±inf).
        double d;
        auto [p2, ec2] = std::from_chars(first, last, d);
        if (ec2 != std::errc() || p2 != last) return false;
        v = to_float(d);
      } else if (ec != std::errc()) {
        return false;
      }
      *out = v;
      return true;
    }
    case PlyType::kFloat64: {
      double d;
      auto [p, ec] = std::from_chars(first, last, d);
      if (ec != std::errc() || p != last) return false;
      *out = to_float(d);
      return true;
    }
    default: {
      int64_t v;
      auto [p, ec] = std::from_chars(first, last, v);
      if (ec != std::errc() || p != last) return false;
      int64_t lo = 0, hi = 0;
      switch (type) {
        case PlyType::kInt8: lo = INT8_MIN, hi = INT8_MAX; break;
        case PlyType::kUint8: lo = 0, hi = UINT8_MAX; break;
        case PlyType::kInt16: lo = INT16_MIN, hi = INT16_MAX; break;
        case PlyType::kUint16: lo = 0, hi = UINT16_MAX; break;
        case PlyType::kInt32: lo = INT32_MIN, hi = INT32_MAX; break;
        default: lo = 0, hi = UINT32_MAX; break;
      }
      if (v < lo || v > hi) return false;
      *out = static_cast<float>(v);
      return true;
    }
  }
}

Status decode_ascii(ByteSource* source, const PlyHeader& header, const PlyElement& vertex, const VertexLayout& layout,
                    format::GaussianCloud* cloud, HygieneCounts* counts) {
  AsciiTokenizer tokens(source, header.data_offset, header.header_lines + 1);
  std::vector<float> values(layout.property_count);
  RawGaussian g;
  const uint64_t n = vertex.count;
  for (uint64_t i = 0; i < n; ++i) {
    for (size_t p = 0; p < layout.property_count; ++p) {
      std::string_view tok;
      bool eof = false;
      RGS_RETURN_IF_ERROR(tokens.next(&tok, &eof));
      const PlyProperty& prop = vertex.properties[p];
      if (eof) {
        return Status(StatusCode::kIoError, "line " + std::to_string(tokens.line()) + ": file ends in vertex " +
                                                std::to_string(i) + " of " + std::to_string(n) + " (property '" +
                                                prop.name + "' missing)");
      }
      if (!parse_ascii_value(tok, prop.type, &values[p])) {
        std::string shown(tok.substr(0, 40));
        return Status(StatusCode::kCorruptData, "line " + std::to_string(tokens.line()) + ": bad value '" + shown +
                                                    "' for property '" + prop.name + "' (" +
                                                    detail::ply_type_name(prop.type) + ") of vertex " +
                                                    std::to_string(i));
      }
    }
    gather(layout, [&values](const FieldSource& f) { return values[f.index]; }, &g);
    activate_and_store(g, i, layout.sh_values, cloud, counts);
  }
  return Status();
}

// ---------------------------------------------------------------------------------------------------
// The whole read.

/// A PLY's header and where its vertices are: what every way of reading the vertex data starts from.
struct PlyBody {
  PlyHeader header;
  size_t vertex_element = 0;  ///< index of the vertex element in header.elements
  VertexLayout layout;
  uint64_t n = 0;  ///< vertices
  bool swap = false;  ///< binary data in the other byte order than the host's
  const PlyElement& vertex() const { return header.elements[vertex_element]; }
};

/// Reads and checks the header of `source` and locates the vertex data (read_ply's header errors).
Result<PlyBody> read_body(ByteSource* source, const PlyReadOptions& options) {
  const uint64_t file_size = source->size();
  // Header: look for end_header in the first bytes, growing the window up to kMaxPlyHeaderBytes.
  size_t window = static_cast<size_t>(std::min<uint64_t>(file_size, 64 * 1024));
  RGS_ASSIGN_OR_RETURN(const uint8_t* head, source->view(0, window));
  if (!detail::starts_with_ply_magic(head, window)) {
    return Status(StatusCode::kCorruptData, "not a PLY file (first line is not 'ply')");
  }
  size_t header_end = detail::find_ply_header_end(head, window);
  while (header_end == 0 && window < file_size && window < detail::kMaxPlyHeaderBytes) {
    window =
        static_cast<size_t>(std::min<uint64_t>(file_size, std::min<size_t>(window * 4, detail::kMaxPlyHeaderBytes)));
    RGS_ASSIGN_OR_RETURN(head, source->view(0, window));
    header_end = detail::find_ply_header_end(head, window);
  }
  if (header_end == 0) {
    if (window >= file_size) {
      return Status(StatusCode::kCorruptData,
                    "PLY header has no 'end_header' line (file is " + std::to_string(file_size) + " bytes)");
    }
    return Status(StatusCode::kCorruptData, "PLY header has no 'end_header' line in its first " +
                                                std::to_string(detail::kMaxPlyHeaderBytes) + " bytes");
  }
  PlyBody body;
  PlyHeader& header = body.header;
  RGS_RETURN_IF_ERROR(detail::parse_ply_header(head, header_end, &header));

  // Elements before the vertex element are allowed only when empty (they would shift its data).
  const PlyElement* vertex = nullptr;
  for (const PlyElement& element : header.elements) {
    if (element.name != "vertex") continue;
    if (vertex != nullptr) {
      return Status(StatusCode::kCorruptData,
                    "PLY header line " + std::to_string(element.header_line) + ": second 'vertex' element");
    }
    vertex = &element;
  }
  if (vertex == nullptr) return Status(StatusCode::kCorruptData, "PLY header declares no 'vertex' element");
  for (const PlyElement& element : header.elements) {
    if (&element == vertex) break;
    if (element.count > 0) {
      return Status(StatusCode::kCorruptData,
                    "PLY header line " + std::to_string(element.header_line) + ": element '" + element.name +
                        "' precedes 'vertex' (" + std::to_string(element.count) +
                        " entries); only elements after the vertex data are supported");
    }
  }

  body.vertex_element = static_cast<size_t>(vertex - header.elements.data());
  VertexLayout& layout = body.layout;
  RGS_RETURN_IF_ERROR(resolve_layout(*vertex, header.storage, &layout));

  const uint64_t n = vertex->count;
  RGS_RETURN_IF_ERROR(detail::check_limit("PLY declares ", n, "vertices", options.max_gaussians));
  const uint64_t remaining = file_size - header.data_offset;
  if (header.storage == PlyStorage::kAscii) {
    // Each value takes at least one character and one separator.
    const uint64_t per_vertex = 2 * uint64_t{layout.property_count};
    if (n > 0 && (n > (remaining + 1) / per_vertex)) {
      return Status(StatusCode::kIoError,
                    "file has " + std::to_string(remaining) + " bytes after the header but " + std::to_string(n) +
                        " ascii vertices of " + std::to_string(layout.property_count) + " values need at least " +
                        (n <= UINT64_MAX / per_vertex ? std::to_string(n * per_vertex - 1) : std::string("2^64")) +
                        " (truncated file?)");
    }
  } else if (n > remaining / layout.stride) {
    return Status(
        StatusCode::kIoError,
        "file has " + std::to_string(remaining) + " bytes after the header but " + std::to_string(n) + " vertices × " +
            std::to_string(layout.stride) + " bytes need " +
            (n <= UINT64_MAX / layout.stride ? std::to_string(n * layout.stride) : std::string("more than 2^64")) +
            " (truncated file?)");
  }
  body.n = n;
  body.swap = (header.storage == PlyStorage::kBinaryBigEndian) == kHostLittleEndian;
  return body;
}

Result<PlyScene> read_from_source(ByteSource* source, const PlyReadOptions& options) {
  const uint64_t file_size = source->size();
  RGS_ASSIGN_OR_RETURN(PlyBody body, read_body(source, options));
  const PlyHeader& header = body.header;
  const PlyElement* vertex = &body.vertex();
  const VertexLayout& layout = body.layout;
  const uint64_t n = body.n;

  PlyScene scene;
  scene.file_bytes = file_size;
  scene.storage_format = detail::ply_storage_name(header.storage);
  scene.declared_vertices = n;
  scene.cloud.sh_degree = layout.sh_degree;
  detail::resize_cloud_huge(&scene.cloud, static_cast<size_t>(n));
  if (options.keep_pre_activation) detail::resize_huge(scene.cloud.pre_activation, static_cast<size_t>(n) * 4);

  std::unique_ptr<XXH64_state_t, decltype(&XXH64_freeState)> hash_state(nullptr, XXH64_freeState);
  if (options.hash_file) {
    hash_state.reset(XXH64_createState());
    if (!hash_state) return Status(StatusCode::kOutOfMemory, "cannot allocate an XXH64 state");
    XXH64_reset(hash_state.get(), 0);
  }

  HygieneCounts counts;
  if (header.storage == PlyStorage::kAscii) {
    RGS_RETURN_IF_ERROR(decode_ascii(source, header, *vertex, layout, &scene.cloud, &counts));
    // Ascii files are tokenized through a sliding window; hash them in a second, sequential pass.
    if (hash_state) RGS_RETURN_IF_ERROR(hash_range(source, 0, file_size, hash_state.get()));
  } else {
    if (hash_state) RGS_RETURN_IF_ERROR(hash_range(source, 0, header.data_offset, hash_state.get()));
    OrderedHasher hasher(hash_state.get());
    RGS_RETURN_IF_ERROR(decode_binary(*source, header.data_offset, n, layout, body.swap,
                                      hash_state ? &hasher : nullptr, &scene.cloud, &counts));
    const uint64_t vertex_end = header.data_offset + n * layout.stride;
    if (hash_state) RGS_RETURN_IF_ERROR(hash_range(source, vertex_end, file_size, hash_state.get()));
  }
  if (hash_state) scene.file_xxh64 = static_cast<uint64_t>(XXH64_digest(hash_state.get()));

  scene.hygiene = counts;
  RGS_RETURN_IF_ERROR(
      detail::apply_invalid_policy(options.invalid_policy, "vertex", counts.invalid, &scene.cloud, &scene.hygiene));
  return scene;
}

}  // namespace

Result<PlyScene> read_ply(const std::string& path, const PlyReadOptions& options) {
  return detail::guarded<PlyScene>(path, "decoding the PLY", [&]() -> Result<PlyScene> {
    FileSource source;
    RGS_RETURN_IF_ERROR(source.open(path));
    return read_from_source(&source, options);
  });
}

Result<PlyScene> read_ply_bytes(const uint8_t* data, size_t size, const std::string& name,
                                const PlyReadOptions& options) {
  return detail::guarded_bytes<PlyScene>(data, size, name, "decoding the PLY", [&]() -> Result<PlyScene> {
    MemorySource source(data, size);
    return read_from_source(&source, options);
  });
}

namespace {

std::string time_text(const struct timespec& t) {
  char text[48];
  std::snprintf(text, sizeof(text), "%lld.%09ld", static_cast<long long>(t.tv_sec), static_cast<long>(t.tv_nsec));
  return text;
}

}  // namespace

struct PlyStream::State {
  std::string path;
  PlyReadOptions options;
  FileSource source;
  PlyBody body;
  uint64_t next = 0;  ///< next vertex of this pass
  HygieneCounts pass_counts;  ///< hygiene of this pass (invalid indices not kept)
  /// XXH64 of what this pass read so far, in file order (from the header on).
  std::unique_ptr<XXH64_state_t, decltype(&XXH64_freeState)> hash{nullptr, XXH64_freeState};
  bool hashing = false;  ///< this pass has hashed every byte before its next vertex
  bool pass_checked = false;  ///< this pass's end was checked
  std::optional<uint64_t> file_xxh64;  ///< the first whole pass's

  /// kIoError when the file at `path` is not the one open() found (another file put in its place, removed,
  /// another size or modification time), or when `digest` (a later pass's XXH64) is not the first pass's: the
  /// passes of the out-of-core build must read the same bytes.
  Status check_unchanged(std::optional<uint64_t> digest = std::nullopt) const {
    const struct stat& was = source.opened();
    struct stat now {};
    std::string why;
    if (::stat(path.c_str(), &now) != 0) {
      why = "it can no longer be found: " + detail::errno_message(errno);
    } else if (now.st_dev != was.st_dev || now.st_ino != was.st_ino) {
      why = "another file was put in its place: inode " + std::to_string(was.st_ino) + " → " +
            std::to_string(now.st_ino);
    } else if (now.st_size != was.st_size) {
      why = "size " + std::to_string(was.st_size) + " → " + std::to_string(now.st_size) + " bytes";
    } else if (now.st_mtim.tv_sec != was.st_mtim.tv_sec || now.st_mtim.tv_nsec != was.st_mtim.tv_nsec) {
      why = "modification time " + time_text(was.st_mtim) + " → " + time_text(now.st_mtim) + " s";
    } else if (digest && file_xxh64 && *digest != *file_xxh64) {
      char text[64];
      std::snprintf(text, sizeof(text), "%016llx → %016llx", static_cast<unsigned long long>(*file_xxh64),
                    static_cast<unsigned long long>(*digest));
      why = std::string("other bytes of the same size and time: XXH64 ") + text;
    }
    if (why.empty()) return Status();
    return Status(StatusCode::kIoError, "the file changed during the passes of the out-of-core build (" + why + ")");
  }

  /// Starts a pass: its hash from the header's bytes.
  Status start_pass() {
    next = 0;
    pass_counts = HygieneCounts();
    XXH64_reset(hash.get(), 0);
    hashing = false;
    pass_checked = false;
    RGS_RETURN_IF_ERROR(hash_range(&source, 0, body.header.data_offset, hash.get()));
    hashing = true;
    return Status();
  }

  /// Ends a pass that read every vertex: the rest of the file hashed; the first pass keeps its digest, a later
  /// one must give the same, and the file must still be the one open() found.
  Status finish_pass() {
    pass_checked = true;
    if (!hashing) return check_unchanged();
    hashing = false;
    const uint64_t vertex_end = body.header.data_offset + body.n * body.layout.stride;
    RGS_RETURN_IF_ERROR(hash_range(&source, vertex_end, source.size(), hash.get()));
    const auto digest = static_cast<uint64_t>(XXH64_digest(hash.get()));
    if (file_xxh64) return check_unchanged(digest);
    file_xxh64 = digest;
    return check_unchanged();
  }

  /// The next at most `max` vertices of this pass into `batch` (PlyStream::read without the file's name).
  Result<uint64_t> read(uint64_t max, format::GaussianCloud* batch) {
    const uint64_t first = next;
    const uint64_t rows = std::min(max, body.n - first);
    batch->sh_degree = body.layout.sh_degree;
    detail::resize_cloud_huge(batch, static_cast<size_t>(rows));
    if (rows == 0) {
      if (!pass_checked && max > 0) RGS_RETURN_IF_ERROR(finish_pass());
      return uint64_t{0};
    }
    const uint64_t stride = body.layout.stride;
    OrderedHasher hasher(hash.get());
    HygieneCounts counts;
    const Status decoded = decode_binary(source, body.header.data_offset + first * stride, rows, body.layout,
                                         body.swap, hashing ? &hasher : nullptr, batch, &counts);
    if (!decoded.ok()) {
      hashing = false;  // this pass's hash misses bytes
      return decoded;
    }
    next = first + rows;
    detail::add_hygiene(counts, 0, &pass_counts);
    if (!counts.invalid.empty()) {
      if (pass_counts.first_invalid_index < 0) {
        pass_counts.first_invalid_index = static_cast<int64_t>(first + counts.invalid.front());
      }
      if (options.invalid_policy == InvalidPolicy::kReject) {
        return Status(StatusCode::kCorruptData,
                      "vertex " + std::to_string(pass_counts.first_invalid_index) +
                          " has non-finite values or a zero-norm quaternion (" +
                          std::to_string(pass_counts.gaussians_with_nonfinite + pass_counts.zero_norm_quaternions) +
                          " such Gaussians in the first " + std::to_string(next) +
                          " vertices); rerun with --sanitize to drop them");
      }
      batch->remove_gaussians(counts.invalid);
      pass_counts.dropped_gaussians += counts.invalid.size();
    }
    if (next == body.n) RGS_RETURN_IF_ERROR(finish_pass());
    return rows;
  }
};

Result<std::unique_ptr<PlyStream>> PlyStream::open(const std::string& path, const PlyReadOptions& options) {
  return open(std::vector<std::string>{path}, options);
}

Result<std::unique_ptr<PlyStream>> PlyStream::open(const std::vector<std::string>& paths,
                                                   const PlyReadOptions& options) {
  std::unique_ptr<PlyStream> stream(new PlyStream());
  for (const std::string& path : paths) {
    RGS_ASSIGN_OR_RETURN(auto state, detail::guarded<std::unique_ptr<State>>(path, "opening the PLY", [&]() -> Result<std::unique_ptr<State>> {
      auto state = std::make_unique<State>();
      state->path = path;
      state->options = options;
      RGS_RETURN_IF_ERROR(state->source.open(path));
      RGS_ASSIGN_OR_RETURN(state->body, read_body(&state->source, options));
      RGS_RETURN_ERROR_IF(state->body.header.storage == PlyStorage::kAscii, StatusCode::kUnsupportedFeature,
                          "an ascii PLY is read whole, not in batches; convert it to binary first "
                          "(rgs-convert in.ply binary.ply)");
      state->hash.reset(XXH64_createState());
      if (!state->hash) return Status(StatusCode::kOutOfMemory, "cannot allocate an XXH64 state");
      RGS_RETURN_IF_ERROR(state->start_pass());
      return state;
    }));
    const std::string storage = detail::ply_storage_name(state->body.header.storage);
    if (stream->storage_.find(storage) == std::string::npos) stream->storage_ += " + " + storage;
    stream->vertices_ += state->body.n;
    stream->degree_ = std::max(stream->degree_, state->body.layout.sh_degree);
    stream->bytes_ += state->source.size();
    stream->states_.push_back(std::move(state));
  }
  RGS_RETURN_ERROR_IF(paths.empty(), StatusCode::kInvalidArgument, "PlyStream::open: no file named");
  return stream;
}

PlyStream::~PlyStream() = default;

uint64_t PlyStream::vertex_count() const { return vertices_; }
uint32_t PlyStream::sh_degree() const { return degree_; }
uint64_t PlyStream::file_bytes() const { return bytes_; }
std::string PlyStream::storage_format() const { return storage_.substr(3); }  // after the first " + "
const InputHygiene& PlyStream::hygiene() const {
  hygiene_ = InputHygiene();
  uint64_t offset = 0;
  for (const auto& st : states_) {
    detail::add_hygiene(st->pass_counts, offset, &hygiene_);
    offset += st->body.n;
  }
  return hygiene_;
}
std::optional<uint64_t> PlyStream::file_xxh64() const {
  std::vector<uint64_t> hashes;
  for (const auto& st : states_) {
    if (!st->options.hash_file || !st->file_xxh64) return std::nullopt;
    hashes.push_back(*st->file_xxh64);
  }
  return hashes.size() == 1 ? hashes.front() : detail::combine_hashes(hashes);
}

Status PlyStream::check_unchanged() const {
  for (const auto& st : states_) RGS_RETURN_IF_ERROR(Status(st->check_unchanged()).prepend(st->path));
  return Status();
}

Status PlyStream::rewind() {
  current_ = 0;
  for (const auto& state : states_) {
    State& st = *state;
    const Result<bool> started = detail::guarded<bool>(st.path, "starting a pass over the PLY", [&]() -> Result<bool> {
      RGS_RETURN_IF_ERROR(st.check_unchanged());
      RGS_RETURN_IF_ERROR(st.start_pass());
      return true;
    });
    if (!started.ok()) return started.status();
  }
  return Status();
}

Result<uint64_t> PlyStream::read(uint64_t max, format::GaussianCloud* batch) {
  for (; current_ < states_.size(); ++current_) {
    State& st = *states_[current_];
    const Result<uint64_t> rows = detail::guarded<uint64_t>(st.path, "decoding the PLY", [&]() -> Result<uint64_t> {
      Result<uint64_t> read = st.read(max, batch);
      // Bytes that end early or values that are not valid in a file that changed: the change is the cause.
      if (!read.ok()) RGS_RETURN_IF_ERROR(st.check_unchanged());
      return read;
    });
    if (!rows.ok()) return rows;
    if (*rows == 0 && max > 0) continue;  // this file's pass ended (and was checked): the next file's
    RGS_RETURN_IF_ERROR(raise_sh_degree(batch, sh_degree()));
    return rows;
  }
  batch->resize(0);
  return uint64_t{0};
}

}  // namespace rgs::converter
