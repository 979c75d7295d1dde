// LodStreamer: level selection, the page pool with its LRU, the reader thread, the uploads on a copy stream and
// the frame gather (lod_streamer.h, docs/LOD.md).
#include "rgs/runtime/lod_streamer.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <string>
#include <system_error>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/spec.h"
#include "rgs/kernels/device_scene.h"
#include "rgs/parallel/fork_join.h"
#include "rgs/parallel/worker_pool.h"
#include "rgs/runtime/cuda_device.h"

namespace rgs::runtime {
namespace {

constexpr uint32_t P = LodStreamer::kPageGaussians;

uint64_t pages_for(uint64_t count) { return (count + P - 1) / P; }

/// Bytes of one Gaussian in the compact arrays.
uint64_t gaussian_bytes(uint32_t sh_bytes, bool residual) { return 12 + 8 + 6 + 2 + sh_bytes + (residual ? 3 : 0); }

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

/// Offsets of the attribute blocks in a host staging buffer of `capacity` Gaussians, structure of arrays in the
/// order means, rotations, scales, opacities, sh, residual.
struct StagingLayout {
  uint64_t offset[6];
  uint64_t record[6];
  StagingLayout(uint64_t capacity, uint32_t sh_bytes, bool residual) {
    const uint64_t records[6] = {12, 8, 6, 2, sh_bytes, residual ? 3u : 0u};
    uint64_t at = 0;
    for (int a = 0; a < 6; ++a) {
      record[a] = records[a];
      offset[a] = at;
      at += capacity * records[a];
    }
  }
};

/// Bytes a reader thread takes on at least: a small batch is read by few threads.
constexpr uint64_t kBytesPerReader = uint64_t{128} << 10;

}  // namespace

Status LodStreamer::Arrays::allocate(uint64_t n, uint32_t sh_bytes, bool residual, const std::string& what) {
  RGS_RETURN_IF_ERROR(means.allocate_exactly(n * 3, what + " means"));
  RGS_RETURN_IF_ERROR(rotations.allocate_exactly(n * 4, what + " rotations"));
  RGS_RETURN_IF_ERROR(scales.allocate_exactly(n * 3, what + " scales"));
  RGS_RETURN_IF_ERROR(opacities.allocate_exactly(n, what + " opacities"));
  // The kernels may read the SH arrays up to kCompactShPadding bytes past the last record (device_scene.h).
  RGS_RETURN_IF_ERROR(sh.allocate_exactly(n * sh_bytes + kernels::kCompactShPadding, what + " SH"));
  RGS_RETURN_IF_CUDA_ERROR(cudaMemset(sh.data(), 0, sh.bytes()), what + " SH");
  if (residual) {
    RGS_RETURN_IF_ERROR(sh_dc_residual.allocate_exactly(n * 3 + kernels::kCompactShPadding, what + " SH DC residual"));
    RGS_RETURN_IF_CUDA_ERROR(cudaMemset(sh_dc_residual.data(), 0, sh_dc_residual.bytes()), what + " SH DC residual");
  }
  return Status();
}

kernels::CompactArrays LodStreamer::Arrays::view() const {
  return {means.data(), rotations.data(), scales.data(), opacities.data(), sh.data(), sh_dc_residual.data()};
}

uint64_t LodStreamer::Arrays::bytes() const {
  return means.bytes() + rotations.bytes() + scales.bytes() + opacities.bytes() + sh.bytes() + sh_dc_residual.bytes();
}

void LodStreamer::StreamDeleter::operator()(cudaStream_t s) const {
  cudaStreamSynchronize(s);
  cudaStreamDestroy(s);
}

void LodStreamer::EventDeleter::operator()(cudaEvent_t e) const { cudaEventDestroy(e); }

void LodStreamer::PoolDeleter::operator()(parallel::WorkerPool* pool) const { delete pool; }

namespace {

/// Gaussians a reader thread copies and checks in one piece: ranges are cut into slices of at most this many,
/// so that one large range is spread over threads (a frame that streams a single range of a 65,536-Gaussian chunk
/// would otherwise wait for one thread to check all of it).
constexpr uint64_t kSliceGaussians = 8192;

/// Copies every range of `items` into `staging` (layout `layout`) and checks the copies: slices of the ranges
/// copied and checked (RgsFile::read_lod_slice) in parallel, then each range's checksum over its whole copy. The
/// first failing range in `items` order gives the error.
template <typename Item>
Status read_ranges(const format::RgsFile& file, const std::vector<Item>& items, uint8_t* staging,
                   const StagingLayout& layout, uint64_t bytes, parallel::WorkerPool& readers) {
  const auto target_of = [&](const Item& item) {
    uint8_t* parts[6];
    for (int a = 0; a < 6; ++a) parts[a] = staging + layout.offset[a] + item.at * layout.record[a];
    return format::LodRangeTarget{parts[0], parts[1], parts[2], parts[3], parts[4],
                                  layout.record[5] != 0 ? parts[5] : nullptr};
  };
  struct Slice {
    size_t item;
    uint64_t begin, end;
  };
  std::vector<Slice> slices;
  for (size_t i = 0; i < items.size(); ++i) {
    const uint64_t count = file.lod()->at(items[i].level, items[i].chunk).count;
    for (uint64_t b = 0; b < count; b += kSliceGaussians) {
      slices.push_back({i, b, std::min(count, b + kSliceGaussians)});
    }
  }
  const unsigned workers = parallel::worker_count(bytes, kBytesPerReader, readers.workers());
  std::vector<Status> sliced(slices.size());
  RGS_RETURN_IF_ERROR(readers.run(slices.size(), workers, [&](unsigned, uint64_t k) {
    const Item& item = items[slices[k].item];
    sliced[k] = file.read_lod_slice(item.level, item.chunk, target_of(item), slices[k].begin, slices[k].end);
  }));
  // Each range's error is its first failing slice's, whichever thread found it first.
  std::vector<Status> results(items.size());
  for (size_t k = 0; k < slices.size(); ++k) {
    if (!sliced[k].ok() && results[slices[k].item].ok()) results[slices[k].item] = sliced[k];
  }
  RGS_RETURN_IF_ERROR(readers.run(items.size(), workers, [&](unsigned, uint64_t i) {
    if (results[i].ok()) results[i] = file.check_lod_checksum(items[i].level, items[i].chunk, target_of(items[i]));
  }));
  for (Status& r : results) {
    if (!r.ok()) return r;
  }
  return Status();
}

}  // namespace

uint64_t LodStreamer::range_bytes(uint32_t level, uint32_t chunk) const {
  return file_->lod()->at(level, chunk).count * gaussian_bytes(sh_bytes_, residual_);
}

uint64_t LodStreamer::device_bytes() const {
  return pool_.bytes() + frame_.bytes() + upload_.bytes() + gather_runs_.bytes() + upload_runs_.bytes();
}

uint64_t LodStreamer::pool_bytes() const { return pool_.bytes(); }

Result<LodStreamer> LodStreamer::open(const format::RgsFile& file, const LodStreamOptions& options,
                                      cudaStream_t stream) {
  const format::LodIndex* index = file.lod();
  RGS_RETURN_ERROR_IF(index == nullptr, StatusCode::kInvalidArgument,
                      file.name() + ": no level-of-detail index to stream (rgs-convert --lod-levels builds one)");
  LodStreamer s;
  s.file_ = std::make_shared<const format::RgsFile>(file);
  // Every CPU but one, which the render thread keeps for launching the frames the reader overlaps.
  s.readers_.reset(new parallel::WorkerPool(std::max(1u, parallel::available_cpus() - 1)));
  s.options_ = options;
  s.sh_bytes_ = 3 * format::sh_coefficient_count(file.metadata().sh_degree);
  s.residual_ = file.find(format::SectionId::kShDcResidual) != nullptr;
  const uint64_t bpg = gaussian_bytes(s.sh_bytes_, s.residual_);
  const uint32_t coarsest = index->level_count - 1;
  s.level_count_ = index->level_count;
  s.ranges_.assign(size_t{index->chunk_count} * index->level_count, Range{});

  uint64_t coarse_total = 0, coarse_pages = 0, all_pages = 0, largest = 0;
  for (uint32_t c = 0; c < index->chunk_count; ++c) {
    coarse_total += index->at(coarsest, c).count;
    coarse_pages += pages_for(index->at(coarsest, c).count);
  }
  for (const format::LodLevel& v : index->levels) {
    all_pages += pages_for(v.count);
    largest = std::max(largest, v.count);
  }
  const uint64_t n0 = index->full_detail_count();
  const uint64_t max_splats = options.budget.max_splats;
  // The frame holds what a selection can draw: the budget, or all coarsest levels when they exceed it.
  const uint64_t frame_capacity = max_splats == 0 ? n0 : std::max(max_splats, coarse_total);
  RGS_RETURN_ERROR_IF(frame_capacity > (uint64_t{1} << 31) - 1, StatusCode::kLimitExceeded,
                      file.name() + ": a frame of " + std::to_string(frame_capacity) +
                          " Gaussians exceeds the GPU renderer's 2^31 - 1");
  s.upload_capacity_ = std::min<uint64_t>(file.gaussian_count(), std::max(largest, options.stream_bytes_per_frame / bpg));
  const uint64_t fixed = (frame_capacity + s.upload_capacity_) * bpg;
  uint64_t pool_pages = all_pages;
  if (options.memory_budget != 0) {
    const uint64_t needed = fixed + coarse_pages * P * bpg;
    RGS_RETURN_ERROR_IF(options.memory_budget < needed, StatusCode::kLimitExceeded,
                        file.name() + ": a memory budget of " + std::to_string(options.memory_budget) +
                            " bytes cannot hold the frame arrays, the upload buffer and the coarsest levels (" +
                            std::to_string(needed) + " bytes); raise it or lower the splat budget");
    pool_pages = std::min(all_pages, (options.memory_budget - fixed) / (uint64_t{P} * bpg));
  }
  s.pool_pages_ = pool_pages;
  RGS_RETURN_IF_ERROR(s.pool_.allocate(pool_pages * P, s.sh_bytes_, s.residual_, "LOD pool"));
  RGS_RETURN_IF_ERROR(s.frame_.allocate(frame_capacity, s.sh_bytes_, s.residual_, "LOD frame"));
  s.frame_capacity_ = frame_capacity;
  RGS_RETURN_IF_ERROR(s.upload_.allocate(s.upload_capacity_, s.sh_bytes_, s.residual_, "LOD upload"));
  for (PinnedBuffer& staging : s.staging_) RGS_RETURN_IF_ERROR(staging.reserve(s.upload_capacity_ * bpg, "LOD staging"));
  // The run lists of a frame's gather and of an upload at their largest (a range adds at most one partial
  // page), allocated once: growing one along a path would free pinned or device memory, which waits for the
  // device, in the middle of a frame.
  const uint64_t max_gather_runs = frame_capacity / P + index->chunk_count;
  const uint64_t max_upload_runs = s.upload_capacity_ / P + uint64_t{index->chunk_count} * index->level_count;
  RGS_RETURN_IF_ERROR(s.gather_runs_.reserve_exact(max_gather_runs, "LOD gather runs"));
  RGS_RETURN_IF_ERROR(s.upload_runs_.reserve_exact(max_upload_runs, "LOD upload runs"));
  RGS_RETURN_IF_ERROR(s.run_staging_.reserve(max_gather_runs * sizeof(kernels::GatherRun), "LOD gather runs"));
  RGS_RETURN_IF_ERROR(s.scatter_staging_.reserve(max_upload_runs * sizeof(kernels::GatherRun), "LOD upload runs"));
  cudaStream_t copy_stream = nullptr;
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamCreateWithFlags(&copy_stream, cudaStreamNonBlocking), "LOD copy stream");
  s.copy_stream_.reset(copy_stream);
  for (auto* event : {&s.gathered_, &s.uploaded_}) {
    cudaEvent_t e = nullptr;
    RGS_RETURN_IF_CUDA_ERROR(cudaEventCreateWithFlags(&e, cudaEventDisableTiming), "LOD event");
    event->reset(e);
  }
  RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(s.gathered_.get(), stream), "LOD event");
  s.free_pages_.resize(pool_pages);
  for (uint64_t p = 0; p < pool_pages; ++p) s.free_pages_[p] = static_cast<uint32_t>(pool_pages - 1 - p);

  // The coarsest level of every chunk, pinned (every chunk can always be drawn), through the same pipeline in
  // batches that fill the staging buffer, each read and uploaded before the next.
  double unused = 0;
  Batch batch;
  auto flush = [&]() -> Status {
    if (batch.keys.empty()) return Status();
    s.start_reading(std::move(batch));
    batch = Batch{};
    RGS_RETURN_IF_ERROR(s.upload_read(&unused, &unused));
    return s.finish_uploads(&unused);
  };
  for (uint32_t c = 0; c < index->chunk_count; ++c) {
    if (batch.staged + index->at(coarsest, c).count > s.upload_capacity_) RGS_RETURN_IF_ERROR(flush());
    RGS_RETURN_ERROR_IF(!s.request_range(coarsest, c, 0, &batch), StatusCode::kLimitExceeded,
                        file.name() + ": the LOD pool has no room for the coarsest level of chunk " + std::to_string(c));
    s.range_at({c, coarsest}).pinned = true;
  }
  RGS_RETURN_IF_ERROR(flush());
  return s;
}

bool LodStreamer::make_room(uint64_t pages, uint64_t frame) {
  if (free_pages_.size() >= pages) return true;
  if (victims_frame_ != frame) {
    // The candidates, once a frame: ranges neither drawn nor requested in it, nor on their way in.
    victims_.clear();
    next_victim_ = 0;
    victims_frame_ = frame;
    for (size_t i = 0; i < ranges_.size(); ++i) {
      const Range& r = ranges_[i];
      if (!r.pinned && r.state == RangeState::kReady && r.last_used < frame) {
        victims_.push_back({static_cast<uint32_t>(i / level_count_), static_cast<uint32_t>(i % level_count_)});
      }
    }
    std::stable_sort(victims_.begin(), victims_.end(), [this](const Key& a, const Key& b) {
      return range_at(a).last_used < range_at(b).last_used;
    });
  }
  while (free_pages_.size() < pages) {
    if (next_victim_ == victims_.size()) return false;
    evict(victims_[next_victim_++]);
  }
  return true;
}

void LodStreamer::evict(const Key& key) {
  Range& range = range_at(key);
  free_pages_.insert(free_pages_.end(), range.pages.rbegin(), range.pages.rend());
  range.pages.clear();
  range.state = RangeState::kAbsent;
  resident_bytes_ -= range_bytes(key.second, key.first);
}

bool LodStreamer::request_range(uint32_t level, uint32_t chunk, uint64_t frame, Batch* batch) {
  const uint64_t count = file_->lod()->at(level, chunk).count;
  const uint64_t pages = pages_for(count);
  if (!make_room(pages, frame)) return false;
  Range& range = range_at({chunk, level});
  range.pages.assign(free_pages_.rbegin(), free_pages_.rbegin() + static_cast<ptrdiff_t>(pages));
  free_pages_.resize(free_pages_.size() - pages);
  range.last_used = frame;
  range.state = RangeState::kReading;
  for (size_t i = 0; i < range.pages.size(); ++i) {
    const uint32_t n = static_cast<uint32_t>(std::min<uint64_t>(P, count - i * P));
    batch->scatter_runs.push_back({static_cast<uint32_t>(batch->staged + i * P), range.pages[i] * P, n});
  }
  batch->keys.push_back({chunk, level});
  batch->items.push_back({level, chunk, batch->staged});
  batch->staged += count;
  batch->bytes += range_bytes(level, chunk);
  resident_bytes_ += range_bytes(level, chunk);
  return true;
}

void LodStreamer::drop(const Batch& batch) {
  for (const Key& key : batch.keys) {
    if (range_at(key).state != RangeState::kAbsent) evict(key);
  }
}

void LodStreamer::start_reading(Batch batch) {
  batch.slot = next_slot_;
  next_slot_ ^= 1;
  reading_batch_ = std::move(batch);
  const StagingLayout layout(upload_capacity_, sh_bytes_, residual_);
  auto read = [file = file_, items = reading_batch_.items, bytes = reading_batch_.bytes, layout,
               staging = static_cast<uint8_t*>(staging_[reading_batch_.slot].data()), readers = readers_.get()]() {
    const auto t0 = std::chrono::steady_clock::now();
    ReadDone done;
    try {
      done.status = read_ranges(*file, items, staging, layout, bytes, *readers);
    } catch (const std::bad_alloc&) {
      done.status = Status(StatusCode::kOutOfMemory, file->name() + ": out of memory reading level-of-detail ranges");
    }
    done.ms = ms_since(t0);
    return done;
  };
  try {
    reading_ = std::async(std::launch::async, read);
  } catch (const std::system_error&) {  // no thread to be had: read now, on this one
    std::promise<ReadDone> done;
    done.set_value(read());
    reading_ = done.get_future();
  }
}

Status LodStreamer::upload_read(double* wait_ms, double* read_ms) {
  if (!reading_.valid()) return Status();
  const auto t0 = std::chrono::steady_clock::now();
  ReadDone done = reading_.get();
  *wait_ms += ms_since(t0);
  *read_ms += done.ms;
  const Status& read = done.status;
  Batch batch = std::move(reading_batch_);
  reading_batch_ = Batch{};
  if (!read.ok()) {
    drop(batch);
    return read;
  }
  // Pages are overwritten only after the frames gathered before have read theirs.
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamWaitEvent(copy_stream_.get(), gathered_.get(), 0), "LOD upload");
  const StagingLayout layout(upload_capacity_, sh_bytes_, residual_);
  const kernels::CompactArrays dst = upload_.view();
  void* targets[6] = {dst.means, dst.rotations, dst.scales, dst.opacities, dst.sh, dst.sh_dc_residual};
  const uint8_t* staging = static_cast<const uint8_t*>(staging_[batch.slot].data());
  for (int a = 0; a < 6; ++a) {
    if (layout.record[a] == 0) continue;
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(targets[a], staging + layout.offset[a], batch.staged * layout.record[a],
                                             cudaMemcpyHostToDevice, copy_stream_.get()),
                             "LOD upload");
  }
  const size_t run_bytes = batch.scatter_runs.size() * sizeof(kernels::GatherRun);
  RGS_RETURN_IF_ERROR(scatter_staging_.reserve(run_bytes, "LOD upload runs"));
  std::memcpy(scatter_staging_.data(), batch.scatter_runs.data(), run_bytes);
  RGS_RETURN_IF_ERROR(upload_runs_.reserve(batch.scatter_runs.size(), "LOD upload runs"));
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(upload_runs_.data(), scatter_staging_.data(), run_bytes,
                                           cudaMemcpyHostToDevice, copy_stream_.get()),
                           "LOD upload runs");
  RGS_RETURN_IF_CUDA_ERROR(kernels::gather_gaussians(upload_runs_.data(),
                                                     static_cast<uint32_t>(batch.scatter_runs.size()), upload_.view(),
                                                     pool_.view(), sh_bytes_, copy_stream_.get()),
                           "LOD scatter kernel");
  RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(uploaded_.get(), copy_stream_.get()), "LOD upload");
  for (const Key& key : batch.keys) range_at(key).state = RangeState::kUploading;
  uploading_ = std::move(batch.keys);
  return Status();
}

Status LodStreamer::finish_uploads(double* wait_ms) {
  const auto t0 = std::chrono::steady_clock::now();
  // The previous gather's run list (pinned) may be rewritten only once its copy is done.
  RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(gathered_.get()), "LOD gather");
  if (!uploading_.empty()) {
    // Also frees the staging buffer and the scatter run list of that upload for reuse.
    RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(uploaded_.get()), "LOD upload");
    for (const Key& key : uploading_) range_at(key).state = RangeState::kReady;
    uploading_.clear();
  }
  *wait_ms += ms_since(t0);
  return Status();
}

Result<LodFrameStats> LodStreamer::prepare(const Camera& camera, cudaStream_t stream) {
  LodFrameStats stats;
  // The pipeline moves one step: frame k − 2's reads become drawable, frame k − 1's are uploaded.
  RGS_RETURN_IF_ERROR(finish_uploads(&stats.wait_ms));
  RGS_RETURN_IF_ERROR(upload_read(&stats.wait_ms, &stats.read_ms));
  const format::LodIndex& index = *file_->lod();
  const uint32_t coarsest = index.level_count - 1;
  const uint64_t frame = ++frame_index_;
  const LodSelection selection = select_lod(index, camera, options_.budget);
  stats.chunks_drawn = static_cast<uint32_t>(selection.choices.size());
  stats.chunks_culled = selection.culled;
  stats.chunks_coarsened = selection.coarsened;

  // Gather: each chunk at its wanted level when drawable, else at the finest drawable coarser one.
  std::vector<kernels::GatherRun> runs;
  std::vector<Key> wanted;
  uint64_t dst = 0;
  for (const LodChoice& choice : selection.choices) {
    uint32_t level = choice.level;
    Range* r = &range_at({choice.chunk, level});
    if (r->state != RangeState::kReady) {
      if (r->state == RangeState::kAbsent) wanted.push_back({choice.chunk, choice.level});
      ++stats.chunks_not_resident;
      do {
        r = &range_at({choice.chunk, ++level});
      } while (level < coarsest && r->state != RangeState::kReady);
    }
    Range& range = *r;
    range.last_used = frame;
    uint64_t left = index.at(level, choice.chunk).count;
    for (uint32_t page : range.pages) {
      const uint32_t count = static_cast<uint32_t>(std::min<uint64_t>(P, left));
      left -= count;
      kernels::GatherRun run{page * P, static_cast<uint32_t>(dst), count};
      if (!runs.empty() && runs.back().src + runs.back().count == run.src && runs.back().count % P == 0) {
        runs.back().count += count;  // contiguous pages: one run
      } else {
        runs.push_back(run);
      }
      dst += count;
    }
  }
  stats.splats = dst;
  const size_t run_bytes = runs.size() * sizeof(kernels::GatherRun);
  RGS_RETURN_IF_ERROR(run_staging_.reserve(run_bytes, "LOD gather runs"));
  if (run_bytes > 0) std::memcpy(run_staging_.data(), runs.data(), run_bytes);
  RGS_RETURN_IF_ERROR(gather_runs_.reserve(runs.size(), "LOD gather runs"));
  RGS_RETURN_IF_CUDA_ERROR(
      cudaMemcpyAsync(gather_runs_.data(), run_staging_.data(), run_bytes, cudaMemcpyHostToDevice, stream),
      "LOD gather runs");
  RGS_RETURN_IF_CUDA_ERROR(kernels::gather_gaussians(gather_runs_.data(), static_cast<uint32_t>(runs.size()),
                                                     pool_.view(), frame_.view(), sh_bytes_, stream),
                           "LOD gather kernel");
  RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(gathered_.get(), stream), "LOD gather");

  const format::SceneMetadata& meta = file_->metadata();
  kernels::CompactGaussiansView view;
  const kernels::CompactArrays arrays = frame_.view();
  view.means = arrays.means;
  view.rotations = arrays.rotations;
  view.scales = arrays.scales;
  view.opacities = arrays.opacities;
  view.sh = arrays.sh;
  view.sh_dc_residual = residual_ ? arrays.sh_dc_residual : nullptr;
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 3; ++c) view.sh_scales[d][c] = meta.sh_quantization.scales[d][c];
  }
  view.scale_encoding = meta.scale_encoding == format::ScaleEncoding::kLog ? kernels::CompactScaleEncoding::kLog
                                                                         : kernels::CompactScaleEncoding::kLinear;
  view.sh_degree = meta.sh_degree;
  view.count = static_cast<uint32_t>(dst);
  frame_scene_ = GpuScene::compact_view(view, meta.bounds, static_cast<uint32_t>(frame_capacity_), meta.antialiased);

  // Requests for the wanted ranges, in chunk order, within the per-frame byte budget and the pool; the reader
  // checks and stages them while this frame renders.
  Batch batch;
  for (const Key& key : wanted) {
    const uint64_t count = index.at(key.second, key.first).count;
    const uint64_t bytes = range_bytes(key.second, key.first);
    if (batch.bytes + bytes > options_.stream_bytes_per_frame || batch.staged + count > upload_capacity_) continue;
    // Room is made only from ranges this frame does not draw; stop when there is none.
    if (!request_range(key.second, key.first, frame, &batch)) break;
    ++stats.ranges_streamed;
  }
  stats.bytes_streamed = batch.bytes;
  if (!batch.keys.empty()) start_reading(std::move(batch));
  stats.bytes_resident = resident_bytes_;
  return stats;
}

}  // namespace rgs::runtime
