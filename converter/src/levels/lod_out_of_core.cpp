// The out-of-core parts of the level-of-detail builder (lod_builder.h, build_lod_out_of_core): the scene's
// partitions found from counts instead of one sort of the whole scene and kept in partition files on disk
// (Buckets), and the levels spilled per (level, section) for the sinks to read back (SpillStore, SpilledLevels).
// The builder itself is lod_builder.cpp's, the same as in memory.
//
// Passes over the input: (1) counts of the means on a grid of 8^D cells over the scene's cube (the octree of
// counts), from which the octree nodes that the in-memory sort would keep whole or split further follow; (2) every
// Gaussian appended to the partition file of its node's bucket (consecutive nodes in Morton order, as many as
// fit the memory limit). A bucket loaded is sorted by Morton code (stable: the input order within a bucket is the
// input order) and its nodes cut into chunks exactly as the whole scene's sort cuts them. The output is
// level-major, so the spill files of a section, level after level, are that section. Partition and spill files
// have no name (O_TMPFILE), so nothing is left on disk however the process ends.
//
// The passes must see the same Gaussians: every mean of a later pass is checked against the scene's box and the
// counts' nodes before it indexes a count, a node or a partition, and a disagreement is kCorruptData, never a
// write outside an array or a file built from two inputs.
#include <fcntl.h>
#include <unistd.h>

#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "internal_levels.h"
#include "internal_lod_chunks.h"
#include "../internal_parallel.h"
#include "rgs/converter/lod_builder.h"

namespace rgs::converter {
namespace {

using namespace detail;

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "partition and spill files hold host-order arrays");

/// Most cells per axis of the count grid: 2^kMaxCountDepth (8^8 cells, 64 MiB of counts).
constexpr int kMaxCountDepth = 8;
/// Most buckets at once: each keeps a write buffer during the partition pass.
constexpr uint64_t kMaxBuckets = 512;
/// Write buffers: of a partition file (the partition pass shares a quarter of the memory limit among them),
/// and of a spill file (6 sections × the levels at once).
constexpr size_t kMaxPartitionBufferBytes = size_t{1} << 20;
constexpr size_t kMinPartitionBufferBytes = size_t{64} << 10;
constexpr size_t kSpillBufferBytes = size_t{64} << 10;
/// Bytes a Gaussian of a bucket costs beyond its record while the bucket is sorted: key, index and the radix
/// sort's copies of both.
constexpr uint64_t kSortBytesPerGaussian = 24;
/// The allocator's slack and the small arrays (nodes, chunk records) beside the budgeted ones.
constexpr uint64_t kSlackBytes = uint64_t{4} << 20;
/// A cell of the count grid in no node (the counts found it empty).
constexpr uint32_t kNoNode = UINT32_MAX;

Status io_error(const std::string& what, const std::string& path) {
  return Status(StatusCode::kIoError, what + " " + path + ": " + std::strerror(errno));
}

/// An append-only file written through a buffer, or read back whole in pieces.
class SpillFile {
 public:
  ~SpillFile() { close(); }
  /// Creates an unnamed file in `folder` (O_TMPFILE; where the file system has none, a named one removed at once):
  /// its disk space goes back when it is closed or the process ends, however it ends.
  Status open(const std::string& folder, const std::string& what, size_t buffer_bytes) {
    path_ = what + " in " + folder;
    buffer_bytes_ = buffer_bytes;
    fd_ = ::open(folder.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    if (fd_ < 0 && (errno == EOPNOTSUPP || errno == EISDIR || errno == EINVAL)) {
      std::string name = (std::filesystem::path(folder) / ".rgs-spill-XXXXXX").string();
      fd_ = ::mkostemp(name.data(), O_CLOEXEC);
      if (fd_ >= 0) ::unlink(name.c_str());
    }
    return fd_ < 0 ? io_error("cannot create a temporary file for the", path_) : Status();
  }
  bool is_open() const { return fd_ >= 0; }
  Status append(const void* data, size_t size) {
    const auto* bytes = static_cast<const uint8_t*>(data);
    if (buffer_.size() + size > buffer_bytes_) RGS_RETURN_IF_ERROR(flush());
    if (size >= buffer_bytes_) return write_all(bytes, size);
    buffer_.insert(buffer_.end(), bytes, bytes + size);
    return Status();
  }
  Status flush() {
    Status s = write_all(buffer_.data(), buffer_.size());
    buffer_.clear();
    return s;
  }
  uint64_t size() const { return written_ + buffer_.size(); }
  /// Reads [offset, offset + size) of what was written and flushed.
  Status read(uint64_t offset, void* data, size_t size) const {
    auto* bytes = static_cast<uint8_t*>(data);
    while (size > 0) {
      const ssize_t got = ::pread(fd_, bytes, size, static_cast<off_t>(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) return got == 0 ? Status(StatusCode::kIoError, "short read of " + path_) : io_error("cannot read", path_);
      bytes += got;
      size -= static_cast<size_t>(got);
      offset += static_cast<uint64_t>(got);
    }
    return Status();
  }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    std::vector<uint8_t>().swap(buffer_);
  }

 private:
  Status write_all(const uint8_t* bytes, size_t size) {
    while (size > 0) {
      const ssize_t done = ::write(fd_, bytes, size);
      if (done < 0 && errno == EINTR) continue;
      if (done <= 0) return io_error("cannot write", path_);
      bytes += done;
      size -= static_cast<size_t>(done);
      written_ += static_cast<uint64_t>(done);
    }
    return Status();
  }
  std::string path_;
  size_t buffer_bytes_ = 0;
  int fd_ = -1;
  uint64_t written_ = 0;
  std::vector<uint8_t> buffer_;
};

/// A Gaussian's bytes in a partition file: its values of every per-Gaussian section, in section order.
struct RecordLayout {
  uint64_t sh = 0;  ///< SH values
  bool residual = false;
  uint64_t bytes() const { return 12 + 8 + 6 + 2 + sh + (residual ? 3 : 0); }
};

// The record copies are the out-of-core build's inner loop (every Gaussian, in and out of a bucket): fixed-size
// copies, not a loop over the section table.
void put_record(const format::EncodedScene& s, uint64_t i, const RecordLayout& r, uint8_t* out) {
  std::memcpy(out, &s.means[i * 3], 12);
  std::memcpy(out + 12, &s.rotations[i * 4], 8);
  std::memcpy(out + 20, &s.scales[i * 3], 6);
  std::memcpy(out + 26, &s.opacities[i], 2);
  std::memcpy(out + 28, &s.sh[i * r.sh], r.sh);
  if (r.residual) std::memcpy(out + 28 + r.sh, &s.sh_dc_residual[i * 3], 3);
}

void get_record(const uint8_t* in, const RecordLayout& r, uint64_t i, format::EncodedScene* s) {
  std::memcpy(&s->means[i * 3], in, 12);
  std::memcpy(&s->rotations[i * 4], in + 12, 8);
  std::memcpy(&s->scales[i * 3], in + 20, 6);
  std::memcpy(&s->opacities[i], in + 26, 2);
  std::memcpy(&s->sh[i * r.sh], in + 28, r.sh);
  if (r.residual) std::memcpy(&s->sh_dc_residual[i * 3], in + 28 + r.sh, 3);
}

/// An octree node of the count grid that build_lod keeps whole (a chunk) or cuts further (`split`: a finest
/// cell of the count grid holding more than a chunk), and the bucket it goes to.
struct Node {
  uint64_t first_cell = 0, end_cell = 0;  ///< count-grid cells [first, end) in Morton order
  uint64_t count = 0;
  bool split = false;
  uint32_t bucket = 0;
};

/// The nodes under (depth, prefix), appended in Morton order: build_lod's split_node() on counts.
void collect_nodes(const std::vector<uint32_t>& prefix_counts, int count_depth, int depth, uint64_t prefix,
                   uint64_t max_count, std::vector<Node>* nodes) {
  const int below = 3 * (count_depth - depth);
  const uint64_t first = prefix << below, end = (prefix + 1) << below;
  const uint64_t count = prefix_counts[end] - prefix_counts[first];
  if (count == 0) return;
  if (count <= max_count || depth == count_depth) {
    nodes->push_back(Node{first, end, count, count > max_count, 0});
    return;
  }
  for (uint64_t child = 0; child < 8; ++child) {
    collect_nodes(prefix_counts, count_depth, depth + 1, prefix * 8 + child, max_count, nodes);
  }
}

/// Levels held in the spill files of an out-of-core build: level l's section k in file l · 6 + k.
class SpilledLevels final : public SectionLevels {
 public:
  SpilledLevels(format::EncodedScene head, format::LodIndex index, std::vector<std::unique_ptr<SpillFile>> spills,
                bool residual)
      : SectionLevels(std::move(head), std::move(index), residual), spills_(std::move(spills)) {
    uint64_t first = 0;
    for (uint32_t l = 0; l < index_.level_count; ++l) {
      level_first_.push_back(first);
      first += spills_[l * kLevelSections]->size() / 12;
    }
    level_first_.push_back(head_.count);
  }

 private:
  Status read_section(int k, uint64_t first, uint64_t count, uint8_t* out) const override {
    const uint64_t width = section_width(k, sh_values_);
    for (uint32_t l = 0; l < index_.level_count; ++l) {
      const uint64_t lo = std::max(first, level_first_[l]), hi = std::min(first + count, level_first_[l + 1]);
      if (lo >= hi) continue;
      RGS_RETURN_IF_ERROR(spills_[l * kLevelSections + k]->read((lo - level_first_[l]) * width,
                                                                out + (lo - first) * width, (hi - lo) * width));
    }
    return Status();
  }
  std::vector<std::unique_ptr<SpillFile>> spills_;
  std::vector<uint64_t> level_first_;  ///< where each level starts in the output order, then the count
};

/// The scene's partitions out of core: the counting and partitioning passes over the batches, each partition
/// (bucket) in a file of its own until it is loaded.
class Buckets final : public PartitionSource {
 public:
  Buckets(const format::EncodedScene& head, const OutOfCoreLodOptions& options, const RecordLayout& record)
      : head_(head), options_(options), grid_(head.metadata.bounds.aabb_min, head.metadata.bounds.aabb_max),
        record_(record) {
    workers_ = parallel::thread_count(options.lod.threads);
    planned_levels_ = options.lod.levels == 0 ? kAutoMaxLevels : options.lod.levels;
  }

  /// The two passes: counts, then every Gaussian into its bucket's file.
  Status prepare(EncodedBatches& batches) {
    RGS_RETURN_IF_ERROR(count_cells(batches));
    RGS_RETURN_IF_ERROR(plan_buckets());
    return partition(batches);
  }
  uint32_t count() const override { return bucket_count_; }
  Status load(uint32_t b, Partition* out) override {
    out->scene = &bucket_;
    return load_bucket(b, &out->order);
  }
  uint64_t capacity() const { return capacity_; }

 private:
  void report(const char* stage, double fraction) {
    if (options_.progress) options_.progress(stage, fraction);
  }

  /// Pass 1: counts per cell of the count grid, then their prefix sums.
  Status count_cells(EncodedBatches& batches) {
    const uint64_t budget = options_.memory_limit / 16;
    count_depth_ = 1;
    while (count_depth_ < kMaxCountDepth && (uint64_t{8} << (3 * count_depth_)) * 4 <= budget) ++count_depth_;
    const uint64_t cells = uint64_t{1} << (3 * count_depth_);
    prefix_.assign(cells + 1, 0);
    report("counting", 0);
    RGS_RETURN_IF_ERROR(batches.rewind());
    std::vector<float> means;
    uint64_t seen = 0;
    for (;;) {
      RGS_ASSIGN_OR_RETURN(const bool more, batches.next_means(&means));
      if (!more) break;
      const uint64_t n = means.size() / 3;
      for (uint64_t i = 0; i < n; ++i) {
        RGS_RETURN_IF_ERROR(check_inside_box(&means[i * 3]));
        ++prefix_[cell_of(&means[i * 3]) + 1];
      }
      seen += n;
      report("counting", 0.25 * static_cast<double>(seen) / static_cast<double>(head_.count));
    }
    RGS_RETURN_ERROR_IF(seen != head_.count, StatusCode::kCorruptData,
                        "the input gave " + std::to_string(seen) + " Gaussians, " + std::to_string(head_.count) +
                            " before (did it change while it was read?)");
    for (uint64_t c = 0; c < cells; ++c) prefix_[c + 1] += prefix_[c];
    return Status();
  }

  /// The count-grid cell of a mean inside the scene's box (MortonGrid::code clamps any other value, NaN
  /// included, to a cell at the grid's edge: check_inside_box first).
  uint64_t cell_of(const float* mean) const { return grid_.code(mean) >> (3 * (kGridBits - count_depth_)); }

  /// kCorruptData unless the mean lies inside head.metadata.bounds' box, which every pass must respect: a mean
  /// outside it (or NaN) means the input changed between its passes.
  Status check_inside_box(const float* mean) const {
    const format::SceneBounds& b = head_.metadata.bounds;
    for (int a = 0; a < 3; ++a) {
      if (mean[a] >= b.aabb_min[a] && mean[a] <= b.aabb_max[a]) continue;
      char text[256];
      std::snprintf(text, sizeof(text),
                    "(%.9g, %.9g, %.9g) outside the scene's box (%.9g, %.9g, %.9g)..(%.9g, %.9g, %.9g)", mean[0],
                    mean[1], mean[2], b.aabb_min[0], b.aabb_min[1], b.aabb_min[2], b.aabb_max[0], b.aabb_max[1],
                    b.aabb_max[2]);
      return Status(StatusCode::kCorruptData,
                    std::string("the input gave a mean ") + text + " (did it change while it was read?)");
    }
    return Status();
  }

  /// The nodes, and consecutive nodes grouped into buckets that fit the memory limit; the cell → node map.
  Status plan_buckets() {
    const uint64_t max_chunk = options_.lod.max_chunk_gaussians;
    collect_nodes(prefix_, count_depth_, 0, 0, max_chunk, &nodes_);
    const uint64_t per_gaussian = record_.bytes() + kSortBytesPerGaussian;
    // Held while a bucket is built: the cell map, the spill buffers, the chunk outputs of a group (levels at
    // most 4/3 of the full detail: 2× is ample) and the workers' sort scratch.
    const uint64_t fixed = kSlackBytes + 4 * (uint64_t{1} << (3 * count_depth_)) +
                           uint64_t{6} * planned_levels_ * kSpillBufferBytes +
                           workers_ * kChunksPerWorker * 2 * max_chunk * record_.bytes() +
                           workers_ * max_chunk * kSortBytesPerGaussian;
    RGS_RETURN_ERROR_IF(options_.memory_limit < fixed + max_chunk * per_gaussian, StatusCode::kLimitExceeded,
                        "the out-of-core build has " + std::to_string(options_.memory_limit) +
                            " bytes of memory, below the " + std::to_string(fixed + max_chunk * per_gaussian) +
                            " that chunks of " + std::to_string(max_chunk) +
                            " Gaussians need; raise the memory limit (--memory-limit) or make the chunks smaller "
                            "(--lod-chunk)");
    capacity_ = (options_.memory_limit - fixed) / per_gaussian;
    uint64_t in_bucket = 0;
    for (Node& node : nodes_) {
      if (in_bucket > 0 && in_bucket + node.count > capacity_) {
        ++bucket_count_;
        in_bucket = 0;
      }
      node.bucket = bucket_count_;
      in_bucket += node.count;
      RGS_RETURN_ERROR_IF(in_bucket > capacity_, StatusCode::kLimitExceeded,
                          std::to_string(node.count) + " Gaussians lie in one cell of 1/" +
                              std::to_string(uint64_t{1} << count_depth_) +
                              " of the scene's extent, more than the memory limit holds at once (" +
                              std::to_string(capacity_) + ")");
    }
    ++bucket_count_;
    RGS_RETURN_ERROR_IF(bucket_count_ > kMaxBuckets, StatusCode::kLimitExceeded,
                        "the scene needs " + std::to_string(bucket_count_) + " partitions of at most " +
                            std::to_string(capacity_) + " Gaussians, more than " + std::to_string(kMaxBuckets) +
                            "; raise the memory limit");
    // prefix_ becomes the cell → node map (its counts are no longer needed); cells the counts found empty are
    // in no node.
    std::fill(prefix_.begin(), prefix_.end(), kNoNode);
    for (uint32_t k = 0; k < nodes_.size(); ++k) {
      for (uint64_t c = nodes_[k].first_cell; c < nodes_[k].end_cell; ++c) prefix_[c] = k;
    }
    return Status();
  }

  /// Pass 2: every Gaussian appended to its bucket's partition file. Each must lie in the box and in a node the
  /// counts gave it, no node holding more than it counted, before it indexes anything: a file's bytes can change
  /// between passes (the source checks its own bytes only at a pass's end).
  Status partition(EncodedBatches& batches) {
    buckets_.resize(bucket_count_);
    const size_t buffer = std::clamp<size_t>(options_.memory_limit / 4 / bucket_count_, kMinPartitionBufferBytes,
                                             kMaxPartitionBufferBytes);
    for (uint32_t b = 0; b < bucket_count_; ++b) {
      buckets_[b] = std::make_unique<SpillFile>();
      RGS_RETURN_IF_ERROR(buckets_[b]->open(options_.spill_folder, "partition " + std::to_string(b), buffer));
    }
    report("partitioning", 0.25);
    RGS_RETURN_IF_ERROR(batches.rewind());
    format::EncodedScene batch;
    std::vector<uint8_t> record(record_.bytes());
    std::vector<uint64_t> in_node(nodes_.size(), 0);
    const Status changed(StatusCode::kCorruptData,
                         "the input gave other Gaussians than in its first pass (did it change while it was read?)");
    uint64_t seen = 0;
    for (;;) {
      RGS_ASSIGN_OR_RETURN(const bool more, batches.next(&batch));
      if (!more) break;
      RGS_RETURN_ERROR_IF(seen + batch.count > head_.count, StatusCode::kCorruptData,
                          "the input gave more Gaussians than in its first pass (did it change while it was read?)");
      for (uint64_t i = 0; i < batch.count; ++i) {
        RGS_RETURN_IF_ERROR(check_inside_box(&batch.means[i * 3]));
        const uint32_t node = prefix_[cell_of(&batch.means[i * 3])];
        if (node == kNoNode || ++in_node[node] > nodes_[node].count) return changed;
        put_record(batch, i, record_, record.data());
        RGS_RETURN_IF_ERROR(buckets_[nodes_[node].bucket]->append(record.data(), record.size()));
      }
      seen += batch.count;
      report("partitioning", 0.25 + 0.25 * static_cast<double>(seen) / static_cast<double>(head_.count));
    }
    std::vector<uint32_t>().swap(prefix_);
    for (auto& b : buckets_) RGS_RETURN_IF_ERROR(b->flush());
    for (size_t k = 0; k < nodes_.size(); ++k) {
      if (in_node[k] != nodes_[k].count) return changed;
    }
    return Status();
  }

  /// Reads bucket b, sorts it and cuts its nodes into chunks: the bucket's part of build_lod's MortonOrder.
  Status load_bucket(uint32_t b, MortonOrder* order) {
    SpillFile& file = *buckets_[b];
    const uint64_t n = file.size() / record_.bytes();
    bucket_ = format::EncodedScene{};  // sized afresh: growing the last bucket's arrays would copy them
    size_sections(&bucket_, n, record_.sh, record_.residual);
    bucket_.metadata = head_.metadata;
    std::vector<uint8_t> piece(std::max<uint64_t>(1, (uint64_t{4} << 20) / record_.bytes()) * record_.bytes());
    for (uint64_t i = 0; i < n;) {
      const uint64_t m = std::min<uint64_t>(n - i, piece.size() / record_.bytes());
      RGS_RETURN_IF_ERROR(file.read(i * record_.bytes(), piece.data(), static_cast<size_t>(m * record_.bytes())));
      for (uint64_t j = 0; j < m; ++j) get_record(piece.data() + j * record_.bytes(), record_, i + j, &bucket_);
      i += m;
    }
    file.close();  // its disk space goes back
    RGS_RETURN_IF_ERROR(sort_by_morton(bucket_, grid_, workers_, order));
    uint64_t position = 0;
    for (const Node& node : nodes_) {
      if (node.bucket != b) continue;
      if (node.split) {
        split_node(order->keys.data(), position, position + node.count, count_depth_, options_.lod.max_chunk_gaussians,
                   &order->leaves);
      } else {
        order->leaves.emplace_back(position, position + node.count);
      }
      position += node.count;
    }
    return Status();
  }

  const format::EncodedScene& head_;
  const OutOfCoreLodOptions& options_;
  MortonGrid grid_;
  RecordLayout record_;
  unsigned workers_ = 1;
  uint32_t planned_levels_ = 1;
  int count_depth_ = 1;
  std::vector<uint32_t> prefix_;  ///< counts per cell, their prefix sums, then the cell → node map
  std::vector<Node> nodes_;
  uint64_t capacity_ = 0;
  uint32_t bucket_count_ = 0;
  std::vector<std::unique_ptr<SpillFile>> buckets_;
  format::EncodedScene bucket_;
};

/// The store of an out-of-core build: each level's sections appended to spill files, read back as SpilledLevels.
class SpillStore final : public LevelStore {
 public:
  SpillStore(std::string folder, const RecordLayout& record) : folder_(std::move(folder)), record_(record) {}
  Status reserve(const format::LodIndex&, uint64_t) override { return Status(); }
  bool needs_checksums() const override { return true; }

  Status put(uint32_t, uint32_t l, int k, const uint8_t* bytes, uint64_t size) override {
    std::unique_ptr<SpillFile>& file = spills_[l * kLevelSections + k];
    if (!file) {
      file = std::make_unique<SpillFile>();
      RGS_RETURN_IF_ERROR(file->open(folder_, "level " + std::to_string(l) + " section " + std::to_string(k),
                                     kSpillBufferBytes));
    }
    return file->append(bytes, size);
  }

  /// The levels the build chose, as the spill files hold them (those beyond are dropped).
  Result<std::unique_ptr<Levels>> finish(BuiltIndex built) {
    spills_.resize(uint64_t{built.index.level_count} * kLevelSections);
    for (auto& file : spills_) RGS_RETURN_IF_ERROR(file ? file->flush() : Status());
    return std::unique_ptr<Levels>(std::make_unique<SpilledLevels>(std::move(built.head), std::move(built.index),
                                                                   std::move(spills_), record_.residual));
  }

 private:
  std::string folder_;  ///< the output's, where the unnamed spill files are made
  RecordLayout record_;
  std::vector<std::unique_ptr<SpillFile>> spills_ =
      std::vector<std::unique_ptr<SpillFile>>(format::kMaxLodLevels * kLevelSections);
};

}  // namespace

Result<bool> EncodedBatches::next_means(std::vector<float>* means) {
  format::EncodedScene batch;
  RGS_ASSIGN_OR_RETURN(const bool more, next(&batch));
  if (more) *means = std::move(batch.means);
  return more;
}

Result<OutOfCoreLevels> build_lod_out_of_core(EncodedBatches& batches, const format::EncodedScene& head,
                                              const OutOfCoreLodOptions& options) {
  RGS_RETURN_IF_ERROR(check_lod_request(head.count, options.lod));
  return catch_bad_alloc([&]() -> Result<OutOfCoreLevels> {
    RecordLayout record;
    record.sh = uint64_t{3} * format::sh_coefficient_count(head.metadata.sh_degree);
    record.residual = options.sh_dc_residual;
    Buckets buckets(head, options, record);
    RGS_RETURN_IF_ERROR(buckets.prepare(batches));
    SpillStore store(options.spill_folder, record);
    const std::function<void(double)> building = [&](double f) {
      if (options.progress) options.progress("building levels of detail", 0.5 + 0.5 * f);
    };
    Progress progress(building, 5 * head.count / 2);
    RGS_ASSIGN_OR_RETURN(BuiltIndex built, build_levels(buckets, store, head, options.lod, &progress));
    OutOfCoreLevels result;
    result.partitions = buckets.count();
    result.partition_capacity = buckets.capacity();
    RGS_ASSIGN_OR_RETURN(result.levels, store.finish(std::move(built)));
    return result;
  }, [&] {
    return "build_lod: out of memory building the levels of " + std::to_string(head.count) + " Gaussians out of core";
  });
}

}  // namespace rgs::converter
