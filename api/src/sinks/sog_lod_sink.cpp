// The streamed SOG sink (an output named lod-meta.json): the levels of detail of the quantized scene, each
// level's chunks as SOG files next to it (converter::write_sog_lod).
#include "../internal_pipeline.h"
#include "rgs/converter/sog_writer.h"

namespace rgs::api::detail {

Status write_sog_lod_output(const std::string& dst, PipelineScene* scene, format::FileSink& files) {
  const auto start = Clock::now();
  RGS_ASSIGN_OR_RETURN(converter::SogWriteSummary sog, converter::write_sog_lod(dst, *scene->levels, {}, files));
  scene->report.seconds.write = seconds_since(start);
  scene->report.output_bytes = sog.bytes;
  scene->report.output_description = "PlayCanvas streamed SOG";
  std::vector<std::string>& notes = scene->report.output_notes;
  notes.insert(notes.end(), sog.limitations.begin(), sog.limitations.end());
  return Status();
}

}  // namespace rgs::api::detail
