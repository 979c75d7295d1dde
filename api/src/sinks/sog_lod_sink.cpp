// The streamed SOG sink (an output named lod-meta.json): the levels of detail of the quantized scene, each
// level's chunks as SOG files next to it (converter::write_sog_lod).
#include "../internal_pipeline.h"
#include "rgs/converter/sog_writer.h"

namespace rgs::api::detail {

namespace {

/// The streamed SOG (dst named lod-meta.json): the levels of detail of the quantized scene, each level's chunks
/// as SOG files (converter::write_sog_lod).
class SogLodSink final : public Sink {
 public:
  SogLodSink(std::string dst, ProgressReporter* progress) : dst_(std::move(dst)), progress_(progress) {}
  Status write(PipelineScene* scene, format::FileSink& files) override {
    ProgressSink progress_files(files, progress_);
    const auto start = Clock::now();
    RGS_ASSIGN_OR_RETURN(converter::SogWriteSummary sog, converter::write_sog_lod(dst_, *scene->levels, {}, progress_files));
    scene->report.seconds.write = seconds_since(start);
    scene->report.output_bytes = sog.bytes;
    scene->report.output_description = "PlayCanvas streamed SOG";
    std::vector<std::string>& notes = scene->report.output_notes;
    notes.insert(notes.end(), sog.limitations.begin(), sog.limitations.end());
    return Status();
  }

 private:
  std::string dst_;
  ProgressReporter* progress_;
};

}  // namespace

std::unique_ptr<Sink> make_sog_lod_sink(const std::string& dst, ProgressReporter* progress) {
  return std::make_unique<SogLodSink>(dst, progress);
}

}  // namespace rgs::api::detail
