// The stages of a batched source: a binary PLY larger than its memory limit read in batches, quantized batch by
// batch with the scene's own SH scales, its levels of detail built by converter::build_lod_out_of_core and handed
// to the output's sink, the .rgs or the streamed SOG (docs/LOD.md#scenes-larger-than-memory).
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "../internal_pipeline.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/file_io.h"
#include "rgs/parallel/fork_join.h"

namespace rgs::api::detail {

namespace {

/// Gaussians a batch holds at most, and the share of the memory limit the batches take.
constexpr uint64_t kMaxBatchGaussians = uint64_t{1} << 20;
constexpr uint64_t kMinBatchGaussians = uint64_t{1} << 12;
constexpr uint64_t kBatchShareOfLimit = 16;

/// Memory the reading holds beside its batches: per thread (a PLY read buffer, a stack), and in all.
constexpr uint64_t kThreadBytes = uint64_t{2} << 20;
constexpr uint64_t kReadSlackBytes = uint64_t{16} << 20;


/// The process's resident memory now (Linux /proc/self/statm), 0 when unknown: what the memory limit holds
/// before the conversion's own arrays. The heap that earlier work freed goes back to the system first
/// (malloc_trim), so that it is not counted as held.
uint64_t resident_bytes() {
  malloc_trim(0);
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0;
  unsigned long long size = 0, resident = 0;
  const int read = std::fscanf(f, "%llu %llu", &size, &resident);
  std::fclose(f);
  const long page = sysconf(_SC_PAGE_SIZE);
  return read == 2 && page > 0 ? uint64_t(resident) * uint64_t(page) : 0;
}

/// Bytes a batch takes per Gaussian: the float cloud as read and its quantized copy.
uint64_t batch_bytes_per_gaussian(uint32_t sh_degree) {
  const uint64_t sh = uint64_t{3} * format::sh_coefficient_count(sh_degree);
  return (3 + 4 + 3 + 1 + sh) * sizeof(float) + 12 + 8 + 6 + 2 + sh + 3;
}

void merge_stats(const converter::ErrorStats& part, converter::ErrorStats* total) {
  const uint64_t n = total->samples + part.samples;
  if (n == 0) return;
  total->rms = std::sqrt((total->rms * total->rms * double(total->samples) + part.rms * part.rms * double(part.samples)) /
                         double(n));
  total->max = std::max(total->max, part.max);
  total->samples = n;
}

/// Adds one batch's errors to the scene's (max and root-mean-square over every sample).
void merge_errors(const converter::AttributeErrors& part, converter::AttributeErrors* total) {
  merge_stats(part.position, &total->position);
  merge_stats(part.rotation_deg, &total->rotation_deg);
  merge_stats(part.scale_relative, &total->scale_relative);
  merge_stats(part.scale_of_largest_axis, &total->scale_of_largest_axis);
  merge_stats(part.opacity, &total->opacity);
  for (int d = 0; d < 4; ++d) {
    merge_stats(part.sh[d], &total->sh[d]);
    for (int c = 0; c < 3; ++c) merge_stats(part.sh_channel[d][c], &total->sh_channel[d][c]);
  }
}

void merge_quantization(const converter::QuantizationReport& part, converter::QuantizationReport* total) {
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 3; ++c) total->sh_clipped[d][c] += part.sh_clipped[d][c];
  }
  total->scales_subnormal += part.scales_subnormal;
  total->scales_flushed_to_zero += part.scales_flushed_to_zero;
  total->max_flushed_of_largest_axis = std::max(total->max_flushed_of_largest_axis, part.max_flushed_of_largest_axis);
}

/// The PLY's batches as convert() reads the scene: the edits of the file each comes from
/// (ConvertOptions::input_edits), then the scene's (ConvertOptions::edits) applied (each acts on one Gaussian at a
/// time, so batch by batch is the whole scene's result), then SH bands above ConvertOptions::sh_degree dropped,
/// the anti-aliasing flag applied.
class PlyBatches {
 public:
  /// `options` hold one list of input_edits per file of `stream`.
  PlyBatches(converter::PlyStream* stream, const ConvertOptions& options, uint64_t batch)
      : stream_(stream), options_(options), batch_(batch) {
    reset();
  }
  Result<bool> next(format::GaussianCloud* cloud) {
    for (;;) {
      RGS_ASSIGN_OR_RETURN(const uint64_t consumed, stream_->read(batch_, cloud));
      if (consumed == 0) return false;
      const size_t file = stream_->file();
      read_[file] += cloud->size();
      RGS_RETURN_IF_ERROR(apply_edits(options_.input_edits[file], cloud, &input_removed_[file]));
      RGS_RETURN_IF_ERROR(apply_edits(options_.edits, cloud, &removed_));
      if (cloud->size() == 0) continue;  // every Gaussian of the batch dropped by sanitizing or the edits
      cloud->antialiased = options_.read.antialiased;
      if (options_.sh_degree && *options_.sh_degree < cloud->sh_degree) {
        RGS_RETURN_IF_ERROR(converter::reduce_sh_degree(cloud, *options_.sh_degree));
      }
      return true;
    }
  }
  /// Back to the first batch; the counts of what the edits removed start again.
  Status rewind() {
    reset();
    return stream_->rewind();
  }
  /// Since the last rewind: the Gaussians each edit of the scene removed (one entry per edit); per file, those
  /// read and those each of its edits removed.
  const std::vector<uint64_t>& removed() const { return removed_; }
  const std::vector<uint64_t>& read() const { return read_; }
  const std::vector<std::vector<uint64_t>>& input_removed() const { return input_removed_; }

 private:
  void reset() {
    removed_.assign(options_.edits.size(), 0);
    read_.assign(options_.input_edits.size(), 0);
    input_removed_.clear();
    for (const auto& edits : options_.input_edits) input_removed_.emplace_back(edits.size(), 0);
  }
  converter::PlyStream* stream_;
  const ConvertOptions& options_;
  uint64_t batch_;
  std::vector<uint64_t> removed_, read_;
  std::vector<std::vector<uint64_t>> input_removed_;
};

/// The quantized batches build_lod_out_of_core() reads in its passes (the pass that needs only the means skips
/// quantizing); the first pass that quantizes also measures what it cost (RgsOutputReport::errors and
/// quantization).
class QuantizedBatches final : public converter::EncodedBatches {
 public:
  QuantizedBatches(PlyBatches* batches, const converter::QuantizeOptions& options, const format::ShQuantization& shq,
                   RgsOutputReport* report)
      : batches_(batches), options_(options), shq_(shq), report_(report) {}
  Status rewind() override {
    ++pass_;
    return batches_->rewind();
  }
  Result<bool> next_means(std::vector<float>* means) override {
    RGS_ASSIGN_OR_RETURN(const bool more, batches_->next(&cloud_));
    if (more) means->swap(cloud_.means);
    return more;
  }
  Result<bool> next(format::EncodedScene* batch) override {
    RGS_ASSIGN_OR_RETURN(const bool more, batches_->next(&cloud_));
    if (!more) return false;
    if (measured_pass_ == 0) measured_pass_ = pass_;
    if (pass_ != measured_pass_) {
      RGS_ASSIGN_OR_RETURN(*batch, converter::quantize(cloud_, options_, shq_));
      return true;
    }
    converter::QuantizationReport quantization;
    converter::AttributeErrors errors;
    RGS_ASSIGN_OR_RETURN(*batch, converter::quantize(cloud_, options_, shq_, &quantization, &errors));
    merge_quantization(quantization, &report_->quantization);
    merge_errors(errors, &report_->errors);
    return true;
  }

 private:
  PlyBatches* batches_;
  converter::QuantizeOptions options_;
  format::ShQuantization shq_;
  RgsOutputReport* report_;
  format::GaussianCloud cloud_;
  int pass_ = 0;
  int measured_pass_ = 0;  ///< the pass whose batches measure the errors: the first that quantizes
};

/// The error of a pass over `stream`, naming `src` once (the stream's errors name it already, the build's do
/// not); a file that changed since the stream opened it is named as the cause of whatever the pass found.
Status pass_error(Status status, const converter::PlyStream& stream, const std::string& src) {
  RGS_RETURN_IF_ERROR(stream.check_unchanged());
  if (status.message().compare(0, src.size() + 2, src + ": ") != 0) status.prepend(src);
  return status;
}

/// What the first pass learns (every value checked on the way): the count, the SH scales, the means' box.
struct SceneStatistics {
  uint64_t count = 0;
  uint32_t sh_degree = 0;
  float box_lo[3] = {0, 0, 0}, box_hi[3] = {0, 0, 0};
  format::ShQuantization shq;
};

Result<SceneStatistics> scan(PlyBatches& batches, const converter::QuantizeOptions& quantize,
                             const converter::PlyStream& stream, ProgressReporter* progress) {
  SceneStatistics stats;
  converter::QuantizeScan scan(quantize);
  format::GaussianCloud cloud;
  for (;;) {
    RGS_ASSIGN_OR_RETURN(const bool more, batches.next(&cloud));
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
    uint64_t read = stream.hygiene().dropped_gaussians;
    for (const uint64_t r : batches.read()) read += r;
    progress->scanning(double(read) / double(stream.vertex_count()));
  }
  stats.shq = scan.sh_quantization(stats.sh_degree);
  return stats;
}

}  // namespace

Result<ConvertReport> convert_batches(SceneSource source, const std::string& dst, OutputFormat output,
                                      const ConvertOptions& options, Sink& sink, format::FileSink& files,
                                      ProgressReporter* progress) {
  const auto start = source.start;
  const std::string& src = source.name;
  std::unique_ptr<converter::PlyStream>& stream = source.stream;
  RGS_RETURN_ERROR_IF(options.read.lod.has_value(), StatusCode::kInvalidArgument,
                      src + ": a level of detail applies only to streamed SOG (lod-meta.json); this input is a PLY file");
  RGS_RETURN_ERROR_IF(has_edit(options, converter::EditKind::kDecimate), StatusCode::kInvalidArgument,
                      src + ": decimate needs the whole scene (or input) in memory, and this conversion reads it in "
                            "batches (out of core: its estimated peak is above the memory limit); raise memory_limit "
                            "(--memory-limit) to read it whole");
  const bool rgs_out = output == OutputFormat::kRgs;
  const uint64_t limit = convert_memory_limit(options);
  const uint64_t batch = std::clamp(limit / kBatchShareOfLimit / batch_bytes_per_gaussian(stream->sh_degree()),
                                    kMinBatchGaussians, kMaxBatchGaussians);
  const converter::QuantizeOptions quantize = rgs_out ? rgs_quantize_options(options) : sog_lod_quantize_options(options);
  PlyBatches batches(stream.get(), options, batch);
  auto scanned = scan(batches, quantize, *stream, progress);
  if (!scanned.ok()) return pass_error(scanned.status(), *stream, src);
  SceneStatistics stats = std::move(scanned).value();
  const converter::InputHygiene hygiene = stream->hygiene();
  uint64_t edited_out = 0;
  for (const uint64_t r : batches.removed()) edited_out += r;
  for (size_t f = 0; f < source.merge_inputs.size(); ++f) {
    describe_merge_input(options.input_edits[f], batches.read()[f], batches.input_removed()[f],
                         &source.merge_inputs[f]);
    edited_out += source.merge_inputs[f].gaussians - source.merge_inputs[f].kept;
  }
  if (stats.count == 0 && !options.allow_empty) return empty_scene_error(src, hygiene.dropped_gaussians, edited_out);
  PipelineScene scene;
  scene.name = src;
  ConvertReport& report = scene.report;
  report.seconds.read = seconds_since(start);
  report.output_format = output;
  report.input_format = "ply";
  report.input_storage = stream->storage_format();
  report.input_description = report.input_storage + " PLY";
  report.input_bytes = stream->file_bytes();
  report.declared_gaussians = stream->vertex_count();
  report.hygiene = hygiene;
  note_edits(options.edits, batches.removed(), &report);
  if (options.sh_degree && *options.sh_degree < stream->sh_degree()) {
    report.input_notes.push_back("SH degree " + std::to_string(stream->sh_degree()) + " reduced to " +
                                 std::to_string(*options.sh_degree));
  }

  // The scene as build_lod_out_of_core() needs it without its arrays: what quantize() of the whole cloud fills.
  format::EncodedScene head;
  head.count = stats.count;
  head.metadata.sh_degree = stats.sh_degree;
  head.metadata.scale_encoding = quantize.scale_encoding;
  head.metadata.sh_quantization = stats.shq;
  head.metadata.antialiased = options.read.antialiased;
  for (int a = 0; a < 3; ++a) {
    head.metadata.bounds.aabb_min[a] = stats.box_lo[a];
    head.metadata.bounds.aabb_max[a] = stats.box_hi[a];
  }
  head.provenance = rgs_provenance(source.source_file, options, stream->file_bytes(), stream->file_xxh64().value_or(0),
                                   stream->storage_format(), hygiene.dropped_gaussians);

  RgsOutputReport rgs;
  QuantizedBatches quantized(&batches, quantize, stats.shq, &rgs);
  converter::OutOfCoreLodOptions lod;
  lod.lod.levels = options.lod_levels.value_or(0);
  lod.lod.max_chunk_gaussians = options.lod_chunk_gaussians;
  // The limit bounds the whole process: what it holds already, the batches and the reading threads' buffers and
  // stacks are not the build's.
  const uint64_t held = resident_bytes() + batch * batch_bytes_per_gaussian(stream->sh_degree()) + kReadSlackBytes +
                        uint64_t{parallel::available_cpus()} * kThreadBytes;
  lod.memory_limit = limit - std::min(limit, held);
  lod.sh_dc_residual = quantize.sh_dc_bits == 16;
  lod.spill_folder = std::filesystem::path(dst).parent_path().string();
  if (lod.spill_folder.empty()) lod.spill_folder = ".";
  lod.progress = [&](const char* stage, double fraction) { progress->out_of_core(stage, fraction); };
  const auto build_start = Clock::now();
  auto built = converter::build_lod_out_of_core(quantized, head, lod);
  if (!built.ok()) return pass_error(built.status(), *stream, src);
  report.seconds.lod = seconds_since(build_start);
  if (rgs_out) {
    rgs.sh_quantization = stats.shq;
    rgs.extent = std::max({double(stats.box_hi[0]) - stats.box_lo[0], double(stats.box_hi[1]) - stats.box_lo[1],
                           double(stats.box_hi[2]) - stats.box_lo[2], 0.0});
    rgs.out_of_core_partitions = built->partitions;
    report.rgs = std::move(rgs);
  }
  scene.levels = std::move(built->levels);
  RGS_RETURN_IF_ERROR(sink.write(&scene, files));
  report.output_notes.push_back(
      "built out of core: " + group_digits(built->partitions) + (built->partitions == 1 ? " partition" : " partitions") +
      " of at most " + group_digits(built->partition_capacity) + " Gaussians in a memory limit of " +
      group_digits(limit) + " bytes");
  report.gaussians = stats.count;
  report.sh_degree = stats.sh_degree;
  report.merge_inputs = std::move(source.merge_inputs);
  report.seconds.total = seconds_since(start);
  progress->done();
  return std::move(report);
}

}  // namespace rgs::api::detail
