// A scene read in batches, pass after pass: binary PLYs too large for memory, each batch edited and passed through
// the per-batch stages as it is read; the first pass learns what the quantizer and the level builder take
// (docs/LOD.md#scenes-larger-than-memory).
#include <algorithm>

#include "../internal_pipeline.h"

namespace rgs::api::detail {

namespace {

/// Gaussians a batch holds at most, and the share of the memory limit the batches take.
constexpr uint64_t kMaxBatchGaussians = uint64_t{1} << 20;
constexpr uint64_t kMinBatchGaussians = uint64_t{1} << 12;
constexpr uint64_t kBatchShareOfLimit = 16;

/// Bytes a batch takes per Gaussian: the float cloud as read and its quantized copy.
uint64_t batch_bytes_per_gaussian(uint32_t sh_degree) {
  const uint64_t sh = uint64_t{3} * format::sh_coefficient_count(sh_degree);
  return (3 + 4 + 3 + 1 + sh) * sizeof(float) + 12 + 8 + 6 + 2 + sh + 3;
}

}  // namespace

uint64_t SceneBatches::batch_bytes() const { return batch_ * batch_bytes_per_gaussian(stream_->sh_degree()); }

SceneBatches::SceneBatches(std::unique_ptr<converter::PlyStream> stream, const ConvertOptions& options,
                           const converter::QuantizeOptions& quantize)
    : stream_(std::move(stream)), options_(options), quantize_(quantize) {
  batch_ = std::clamp(convert_memory_limit(options) / kBatchShareOfLimit / batch_bytes_per_gaussian(stream_->sh_degree()),
                      kMinBatchGaussians, kMaxBatchGaussians);
  reset();
}

Result<bool> SceneBatches::next(format::GaussianCloud* cloud) {
  for (;;) {
    RGS_ASSIGN_OR_RETURN(const uint64_t consumed, stream_->read(batch_, cloud));
    if (consumed == 0) return false;
    const size_t file = stream_->file();
    read_[file] += cloud->size();
    RGS_RETURN_IF_ERROR(apply_edits(options_.input_edits[file], cloud, &input_removed_[file]));
    for (const Stage& stage : stages_) RGS_RETURN_IF_ERROR(stage.batch(cloud, &removed_));
    if (cloud->size() == 0) continue;  // every Gaussian of the batch dropped by sanitizing or the edits
    cloud->antialiased = options_.read.antialiased;
    return true;
  }
}

Status SceneBatches::rewind() {
  reset();
  return stream_->rewind();
}

void SceneBatches::reset() {
  removed_.assign(options_.edits.size(), 0);
  read_.assign(options_.input_edits.size(), 0);
  input_removed_.clear();
  for (const auto& edits : options_.input_edits) input_removed_.emplace_back(edits.size(), 0);
}

void SceneBatches::describe(ConvertReport* report) const {
  report->input_format = "ply";
  report->input_storage = stream_->storage_format();
  report->input_description = report->input_storage + " PLY";
  report->input_bytes = stream_->file_bytes();
  report->declared_gaussians = stream_->vertex_count();
}

Status SceneBatches::pass_error(Status status, const std::string& name) const {
  RGS_RETURN_IF_ERROR(stream_->check_unchanged());
  if (status.message().compare(0, name.size() + 2, name + ": ") != 0) status.prepend(name);
  return status;
}

Result<const BatchStatistics*> SceneBatches::scan(ProgressReporter* progress) {
  if (statistics_) return &*statistics_;
  BatchStatistics stats;
  converter::QuantizeScan scan(quantize_);
  format::GaussianCloud cloud;
  for (;;) {
    RGS_ASSIGN_OR_RETURN(const bool more, next(&cloud));
    if (!more) break;
    RGS_RETURN_IF_ERROR(scan.add(cloud, stats.count));
    stats.sh_degree = cloud.sh_degree;
    for (uint64_t i = 0; i < cloud.size(); ++i) {
      for (int a = 0; a < 3; ++a) {
        const float v = cloud.means[i * 3 + a];
        stats.box_lo[a] = stats.count + i == 0 ? v : std::min(stats.box_lo[a], v);
        stats.box_hi[a] = stats.count + i == 0 ? v : std::max(stats.box_hi[a], v);
      }
    }
    stats.count += cloud.size();
    uint64_t read = stream_->hygiene().dropped_gaussians;
    for (const uint64_t r : read_) read += r;
    progress->scanning(double(read) / double(stream_->vertex_count()));
  }
  stats.shq = scan.sh_quantization(stats.sh_degree);
  statistics_ = stats;
  return &*statistics_;
}

}  // namespace rgs::api::detail
