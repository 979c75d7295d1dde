// LodStreamer: level selection, the page pool with its LRU, the uploads on a copy stream and the frame gather
// (lod_streamer.h, docs/LOD.md).
#include "rgs/runtime/lod_streamer.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <string>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/spec.h"
#include "rgs/kernels/device_scene.h"
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
  s.file_ = file;
  s.options_ = options;
  s.sh_bytes_ = 3 * format::sh_coefficient_count(file.metadata().sh_degree);
  s.residual_ = file.find(format::SectionId::kShDcResidual) != nullptr;
  const uint64_t bpg = gaussian_bytes(s.sh_bytes_, s.residual_);
  const uint32_t coarsest = index->level_count - 1;

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
  RGS_RETURN_IF_ERROR(s.upload_.allocate(s.upload_capacity_, s.sh_bytes_, s.residual_, "LOD upload"));
  RGS_RETURN_IF_ERROR(s.staging_.reserve(s.upload_capacity_ * bpg, "LOD staging"));
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

  // The coarsest level of every chunk, pinned: every chunk can always be drawn.
  uint64_t staged = 0;
  double unused = 0;
  for (uint32_t c = 0; c < index->chunk_count; ++c) {
    const uint64_t count = index->at(coarsest, c).count;
    if (staged + count > s.upload_capacity_) {
      RGS_RETURN_IF_ERROR(s.start_uploads(staged));
      RGS_RETURN_IF_ERROR(s.finish_uploads(&unused));
      staged = 0;
    }
    RGS_RETURN_IF_ERROR(s.stage_range(coarsest, c, staged, 0));
    s.resident_[{c, coarsest}].pinned = true;
    staged += count;
  }
  RGS_RETURN_IF_ERROR(s.start_uploads(staged));
  RGS_RETURN_IF_ERROR(s.finish_uploads(&unused));
  return s;
}

bool LodStreamer::make_room(uint64_t pages, uint64_t frame) {
  while (free_pages_.size() < pages) {
    // Least recently used first, then the lowest (chunk, level): a deterministic victim.
    auto victim = resident_.end();
    for (auto it = resident_.begin(); it != resident_.end(); ++it) {
      const Range& r = it->second;
      if (r.pinned || !r.ready || r.last_used >= frame) continue;
      if (victim == resident_.end() || r.last_used < victim->second.last_used) victim = it;
    }
    if (victim == resident_.end()) return false;
    free_pages_.insert(free_pages_.end(), victim->second.pages.rbegin(), victim->second.pages.rend());
    resident_.erase(victim);
  }
  return true;
}

bool LodStreamer::take_pages(uint64_t pages, uint64_t frame, std::vector<uint32_t>* out) {
  if (!make_room(pages, frame)) return false;
  out->assign(free_pages_.end() - static_cast<ptrdiff_t>(pages), free_pages_.end());
  std::reverse(out->begin(), out->end());
  free_pages_.resize(free_pages_.size() - pages);
  return true;
}

Status LodStreamer::stage_range(uint32_t level, uint32_t chunk, uint64_t at, uint64_t frame) {
  RGS_ASSIGN_OR_RETURN(const format::LodRangeView view, file_->lod_range(level, chunk));
  std::vector<uint32_t> pages;
  RGS_RETURN_ERROR_IF(!take_pages(pages_for(view.count), frame, &pages),
                      StatusCode::kLimitExceeded,
                      file_->name() + ": the LOD pool has no room for chunk " + std::to_string(chunk) + " level " +
                          std::to_string(level));
  const StagingLayout layout(upload_capacity_, sh_bytes_, residual_);
  const format::ByteView* parts[6] = {&view.means, &view.rotations, &view.scales, &view.opacities, &view.sh,
                                      &view.sh_dc_residual};
  uint8_t* staging = static_cast<uint8_t*>(staging_.data());
  for (int a = 0; a < 6; ++a) {
    if (layout.record[a] == 0 || parts[a]->size == 0) continue;
    std::memcpy(staging + layout.offset[a] + at * layout.record[a], parts[a]->data, parts[a]->size);
  }
  for (size_t i = 0; i < pages.size(); ++i) {
    const uint32_t count = static_cast<uint32_t>(std::min<uint64_t>(P, view.count - i * P));
    scatter_runs_.push_back({static_cast<uint32_t>(at + i * P), pages[i] * P, count});
  }
  Range& range = resident_[{chunk, level}];
  range.pages = std::move(pages);
  range.last_used = frame;
  range.ready = false;
  pending_.push_back({chunk, level});
  return Status();
}

Status LodStreamer::start_uploads(uint64_t staged) {
  if (staged == 0) return Status();
  // Pages are overwritten only after the frames gathered before have read theirs.
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamWaitEvent(copy_stream_.get(), gathered_.get(), 0), "LOD upload");
  const StagingLayout layout(upload_capacity_, sh_bytes_, residual_);
  const kernels::CompactArrays dst = upload_.view();
  void* targets[6] = {dst.means, dst.rotations, dst.scales, dst.opacities, dst.sh, dst.sh_dc_residual};
  const uint8_t* staging = static_cast<const uint8_t*>(staging_.data());
  for (int a = 0; a < 6; ++a) {
    if (layout.record[a] == 0) continue;
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(targets[a], staging + layout.offset[a], staged * layout.record[a],
                                             cudaMemcpyHostToDevice, copy_stream_.get()),
                             "LOD upload");
  }
  const size_t run_bytes = scatter_runs_.size() * sizeof(kernels::GatherRun);
  RGS_RETURN_IF_ERROR(scatter_staging_.reserve(run_bytes, "LOD upload runs"));
  std::memcpy(scatter_staging_.data(), scatter_runs_.data(), run_bytes);
  RGS_RETURN_IF_ERROR(upload_runs_.reserve(scatter_runs_.size(), "LOD upload runs"));
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(upload_runs_.data(), scatter_staging_.data(), run_bytes,
                                           cudaMemcpyHostToDevice, copy_stream_.get()),
                           "LOD upload runs");
  RGS_RETURN_IF_CUDA_ERROR(kernels::gather_gaussians(upload_runs_.data(), static_cast<uint32_t>(scatter_runs_.size()),
                                                     upload_.view(), pool_.view(), sh_bytes_, copy_stream_.get()),
                           "LOD scatter kernel");
  RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(uploaded_.get(), copy_stream_.get()), "LOD upload");
  scatter_runs_.clear();
  return Status();
}

Status LodStreamer::finish_uploads(double* wait_ms) {
  const auto t0 = std::chrono::steady_clock::now();
  // The previous gather's run list (pinned) may be rewritten only once its copy is done.
  RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(gathered_.get()), "LOD gather");
  if (!pending_.empty()) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(uploaded_.get()), "LOD upload");
    for (const Key& key : pending_) resident_[key].ready = true;
    pending_.clear();
  }
  *wait_ms += ms_since(t0);
  return Status();
}

Result<LodFrameStats> LodStreamer::prepare(const Camera& camera, cudaStream_t stream) {
  LodFrameStats stats;
  RGS_RETURN_IF_ERROR(finish_uploads(&stats.wait_ms));
  const format::LodIndex& index = *file_->lod();
  const uint32_t coarsest = index.level_count - 1;
  const uint64_t frame = ++frame_index_;
  const LodSelection selection = select_lod(index, camera, options_.budget);
  stats.chunks_drawn = static_cast<uint32_t>(selection.choices.size());
  stats.chunks_culled = selection.culled;
  stats.chunks_coarsened = selection.coarsened;

  // Gather: each chunk at its wanted level when resident, else at the finest resident coarser one.
  std::vector<kernels::GatherRun> runs;
  std::vector<Key> wanted;
  uint64_t dst = 0;
  for (const LodChoice& choice : selection.choices) {
    uint32_t level = choice.level;
    auto it = resident_.find({choice.chunk, level});
    if (it == resident_.end() || !it->second.ready) {
      wanted.push_back({choice.chunk, choice.level});
      ++stats.chunks_not_resident;
      do {
        it = resident_.find({choice.chunk, ++level});
      } while (level < coarsest && (it == resident_.end() || !it->second.ready));
    }
    Range& range = it->second;
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
  frame_scene_ = GpuScene::compact_view(view, meta.bounds);

  // Uploads of the wanted ranges, in chunk order, within the per-frame byte budget and the pool.
  const auto t_read = std::chrono::steady_clock::now();
  uint64_t staged = 0;
  for (const Key& key : wanted) {
    const uint64_t count = index.at(key.second, key.first).count;
    const uint64_t bytes = range_bytes(key.second, key.first);
    if (stats.bytes_streamed + bytes > options_.stream_bytes_per_frame || staged + count > upload_capacity_) continue;
    // Room is made only from ranges this frame does not draw; stop when there is none.
    if (!make_room(pages_for(count), frame)) break;
    RGS_RETURN_IF_ERROR(stage_range(key.second, key.first, staged, frame));
    staged += count;
    stats.bytes_streamed += bytes;
    ++stats.ranges_streamed;
  }
  stats.wait_ms += ms_since(t_read);
  RGS_RETURN_IF_ERROR(start_uploads(staged));
  for (const auto& [key, range] : resident_) stats.bytes_resident += range_bytes(key.second, key.first);
  return stats;
}

}  // namespace rgs::runtime
