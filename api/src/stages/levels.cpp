// The levels-of-detail stage, in both memory modes: the quantized scene's levels built in memory
// (converter::build_lod), or a scene read in batches quantized batch by batch into converter::build_lod_out_of_core
// (docs/LOD.md#scenes-larger-than-memory). Either way the sinks read the levels as converter::Levels.
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "../internal_pipeline.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/parallel/fork_join.h"

namespace rgs::api::detail {

namespace {

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

void merge_stats(const converter::ErrorStats& part, converter::ErrorStats* total) {
  const uint64_t n = total->samples + part.samples;
  if (n == 0) return;
  total->rms = std::sqrt((total->rms * total->rms * double(total->samples) + part.rms * part.rms * double(part.samples)) /
                         double(n));
  total->max = std::max(total->max, part.max);
  total->samples = n;
}

/// Adds one batch's quantization report and errors to the scene's (sums, maxima and root-mean-squares over every
/// sample).
void merge_measures(const converter::QuantizationReport& quantization, const converter::AttributeErrors& part,
                    RgsOutputReport* report) {
  converter::AttributeErrors* total = &report->errors;
  merge_stats(part.position, &total->position);
  merge_stats(part.rotation_deg, &total->rotation_deg);
  merge_stats(part.scale_relative, &total->scale_relative);
  merge_stats(part.scale_of_largest_axis, &total->scale_of_largest_axis);
  merge_stats(part.opacity, &total->opacity);
  converter::QuantizationReport& q = report->quantization;
  for (int d = 0; d < 4; ++d) {
    merge_stats(part.sh[d], &total->sh[d]);
    for (int c = 0; c < 3; ++c) merge_stats(part.sh_channel[d][c], &total->sh_channel[d][c]);
    for (int c = 0; c < 3; ++c) q.sh_clipped[d][c] += quantization.sh_clipped[d][c];
  }
  q.scales_subnormal += quantization.scales_subnormal;
  q.scales_flushed_to_zero += quantization.scales_flushed_to_zero;
  q.max_flushed_of_largest_axis = std::max(q.max_flushed_of_largest_axis, quantization.max_flushed_of_largest_axis);
}

/// The quantized batches build_lod_out_of_core() reads in its passes (the pass that needs only the means skips
/// quantizing); the first pass that quantizes also measures what it cost (RgsOutputReport::errors and
/// quantization).
class QuantizedBatches final : public converter::EncodedBatches {
 public:
  QuantizedBatches(SceneBatches* batches, const converter::QuantizeOptions& options, const format::ShQuantization& shq,
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
    const bool measures = pass_ == measured_pass_;
    converter::QuantizationReport quantization;
    converter::AttributeErrors errors;
    RGS_ASSIGN_OR_RETURN(*batch, converter::quantize(cloud_, options_, shq_, measures ? &quantization : nullptr,
                                                     measures ? &errors : nullptr));
    if (measures) merge_measures(quantization, errors, report_);
    return true;
  }

 private:
  SceneBatches* batches_;
  converter::QuantizeOptions options_;
  format::ShQuantization shq_;
  RgsOutputReport* report_;
  format::GaussianCloud cloud_;
  int pass_ = 0;
  int measured_pass_ = 0;  ///< the pass whose batches measure the errors: the first that quantizes
};

/// The levels of detail of the quantized scene (converter::build_lod): `levels` per chunk (0: auto).
Status build_in_memory(PipelineScene* scene, uint32_t levels, const ConvertOptions& options, ProgressReporter* progress) {
  progress->building_lod();
  const auto start = Clock::now();
  converter::LodBuildOptions lod;
  lod.levels = levels;
  lod.max_chunk_gaussians = options.lod_chunk_gaussians;
  auto built = converter::build_lod(*scene->encoded, lod);
  if (!built.ok()) return Status(built.status()).prepend(scene->name);
  scene->lod.emplace(std::move(built).value());
  scene->levels = converter::held_levels(*scene->lod);
  scene->report.seconds.lod = seconds_since(start);
  return Status();
}

/// The out-of-core build of build_levels().
Status build_out_of_core(PipelineScene* scene, const std::string& dst, OutputFormat output,
                         const ConvertOptions& options, ProgressReporter* progress) {
  SceneBatches& batches = *scene->batches;
  RGS_ASSIGN_OR_RETURN(const BatchStatistics* scanned, batches.scan(progress));
  const BatchStatistics& stats = *scanned;
  const converter::PlyStream& stream = batches.stream();
  const converter::QuantizeOptions& quantize = batches.quantize();  // as the first pass scanned
  ConvertReport& report = scene->report;
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
  head.provenance = rgs_provenance(scene->source_file, options, stream.file_bytes(), stream.file_xxh64().value_or(0),
                                   stream.storage_format(), report.hygiene.dropped_gaussians);

  RgsOutputReport rgs;
  QuantizedBatches quantized(&batches, quantize, stats.shq, &rgs);
  converter::OutOfCoreLodOptions lod;
  lod.lod.levels = options.lod_levels.value_or(0);
  lod.lod.max_chunk_gaussians = options.lod_chunk_gaussians;
  // The limit bounds the whole process: what it holds already, the batches and the reading threads' buffers and
  // stacks are not the build's.
  const uint64_t limit = convert_memory_limit(options);
  const uint64_t held =
      resident_bytes() + batches.batch_bytes() + kReadSlackBytes + uint64_t{parallel::available_cpus()} * kThreadBytes;
  lod.memory_limit = limit - std::min(limit, held);
  lod.sh_dc_residual = quantize.sh_dc_bits == 16;
  // Beside the output, on its disk: its nearest folder that exists (the sink creates the rest only when it writes).
  std::error_code ec;
  std::filesystem::path spill = std::filesystem::absolute(dst, ec).lexically_normal().parent_path();
  while (!std::filesystem::is_directory(spill, ec) && spill.has_relative_path()) spill = spill.parent_path();
  lod.spill_folder = spill.string();
  lod.progress = [&](const char* stage, double fraction) { progress->out_of_core(stage, fraction); };
  const auto build_start = Clock::now();
  auto built = converter::build_lod_out_of_core(quantized, head, lod);
  if (!built.ok()) return batches.pass_error(built.status(), scene->name);
  report.seconds.lod = seconds_since(build_start);
  rgs.out_of_core_partitions = built->partitions;
  if (output == OutputFormat::kRgs) report.rgs = std::move(rgs);
  scene->levels = std::move(built->levels);
  report.output_notes.push_back(
      "built out of core: " + group_digits(built->partitions) + (built->partitions == 1 ? " partition" : " partitions") +
      " of at most " + group_digits(built->partition_capacity) + " Gaussians in a memory limit of " +
      group_digits(limit) + " bytes");
  report.gaussians = stats.count;
  report.sh_degree = stats.sh_degree;
  return Status();
}

}  // namespace

Status build_levels(PipelineScene* scene, const std::string& dst, OutputFormat output, const ConvertOptions& options,
                    ProgressReporter* progress) {
  if (scene->batches) return build_out_of_core(scene, dst, output, options, progress);
  return build_in_memory(scene, options.lod_levels.value_or(0), options, progress);
}

}  // namespace rgs::api::detail
