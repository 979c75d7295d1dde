// The sinks of the float formats, written from the cloud as read (after the stages): INRIA PLY, SPZ, GLB
// (KHR_gaussian_splatting) and SOG (a bundle, or a folder when the output is named meta.json).
#include <cstdio>

#include "../internal_pipeline.h"
#include "rgs/converter/gltf.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/sog_writer.h"
#include "rgs/converter/spz.h"

namespace rgs::api::detail {

namespace {

/// Writes the cloud of `scene` to `dst` through `files`; fills the report's output bytes, description and notes.
using CloudWriter = Status (*)(const std::string& dst, const ConvertOptions& options, const PipelineScene& scene,
                               format::FileSink& files, ConvertReport* report);

Status write_ply_cloud(const std::string& dst, const ConvertOptions&, const PipelineScene& scene,
                       format::FileSink& files, ConvertReport* report) {
  converter::PlyWriteReport ply;
  RGS_ASSIGN_OR_RETURN(report->output_bytes, converter::write_ply(dst, scene.input.cloud, &ply, files));
  report->output_description = scene.input.format_id == "rgs" ? "INRIA PLY, dequantized" : "INRIA PLY";
  report->zero_scales = ply.zero_scales;
  if (ply.zero_scales > 0) {
    char log_scale[32];
    std::snprintf(log_scale, sizeof(log_scale), "%.4f", static_cast<double>(converter::kZeroScaleLog));
    report->output_notes.push_back(std::to_string(ply.zero_scales) + " zero scales written as log-scale " +
                                   log_scale + ", not -inf");
  }
  return Status();
}

Status write_spz_cloud(const std::string& dst, const ConvertOptions& options, const PipelineScene& scene,
                       format::FileSink& files, ConvertReport* report) {
  converter::SpzWriteOptions spz_options;
  spz_options.frame = converter::spz_frame_for(options.read, dst);
  RGS_ASSIGN_OR_RETURN(converter::SpzWriteSummary spz,
                       converter::write_spz(dst, scene.input.cloud, spz_options, files));
  report->output_bytes = spz.bytes;
  report->output_description = "SPZ v" + std::to_string(spz.version);
  report->output_notes = spz.limitations;
  auto clamped = [&](uint64_t n, const char* what) {
    if (n > 0) report->output_notes.push_back(std::to_string(n) + " " + what + " clamped to the SPZ range");
  };
  clamped(spz.scales_clamped, "scale values");
  clamped(spz.colors_clamped, "DC colour values");
  clamped(spz.sh_clamped, "SH rest values");
  report->spz = std::move(spz);
  return Status();
}

Status write_glb_cloud(const std::string& dst, const ConvertOptions&, const PipelineScene& scene,
                       format::FileSink& files, ConvertReport* report) {
  RGS_ASSIGN_OR_RETURN(converter::GltfWriteSummary glb, converter::write_glb(dst, scene.input.cloud, {}, files));
  report->output_bytes = glb.bytes;
  report->output_description = "KHR_gaussian_splatting GLB";
  report->output_notes = glb.limitations;
  return Status();
}

Status write_sog_cloud(const std::string& dst, const ConvertOptions&, const PipelineScene& scene,
                       format::FileSink& files, ConvertReport* report) {
  converter::SogWriteOptions sog_options;
  const bool folder = converter::is_sog_folder_path(dst);
  sog_options.container = folder ? converter::SogContainer::kFolder : converter::SogContainer::kBundle;
  RGS_ASSIGN_OR_RETURN(converter::SogWriteSummary sog,
                       converter::write_sog(dst, scene.input.cloud, sog_options, files));
  report->output_bytes = sog.bytes;
  report->output_description = folder ? "PlayCanvas SOG v2 folder" : "PlayCanvas SOG v2";
  report->output_notes = sog.limitations;
  return Status();
}

}  // namespace

Status write_cloud_output(const std::string& dst, OutputFormat output, const ConvertOptions& options,
                          ProgressReporter* progress, PipelineScene* scene, format::FileSink& files) {
  const CloudWriter writer = output == OutputFormat::kPly   ? write_ply_cloud
                             : output == OutputFormat::kSpz ? write_spz_cloud
                             : output == OutputFormat::kGlb ? write_glb_cloud
                                                            : write_sog_cloud;
  // Around every writer: the "writing" stage, the time, the counts, and the note that a format other than SPZ
  // cannot say that the scene is anti-aliased.
  progress->writing();
  const auto start = Clock::now();
  const format::GaussianCloud& cloud = scene->input.cloud;
  RGS_RETURN_IF_ERROR(writer(dst, options, *scene, files, &scene->report));
  if (cloud.antialiased && output != OutputFormat::kSpz) {
    // PLY and KHR_gaussian_splatting have no field for it; SPZ keeps it in its header flag.
    scene->report.output_notes.push_back(
        "anti-aliased scene (2D Mip filter): this format cannot say so; read the file back with --antialiased "
        "(Python: antialiased=True) to render it as trained");
  }
  scene->report.seconds.write = seconds_since(start);
  scene->report.gaussians = cloud.size();
  scene->report.sh_degree = cloud.sh_degree;
  return Status();
}

}  // namespace rgs::api::detail
