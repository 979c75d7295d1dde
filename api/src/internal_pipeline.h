// The conversion pipeline, private to rgs_api: a source yields the scene (whole, or in batches pass after pass
// when it is larger than memory), stages act on it in order, and one sink writes it through the output
// transaction. convert(), convert_bytes(), convert_scene() and convert_cloud() differ only in their source
// (docs/DESIGN.md#the-scene-pipeline).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/output_transaction.h"

namespace rgs::api::detail {

using Clock = std::chrono::steady_clock;

/// Seconds from `start` to now.
double seconds_since(Clock::time_point start);

/// Calls ConvertOptions::progress, if set, once per stage, keeping the fractions non-decreasing. Each stage
/// starts at its share of a typical conversion to the output (reading and quantizing are quick next to the
/// archive and SPZ encoders); rate control spreads its steps over most of the range.
class ProgressReporter {
 public:
  ProgressReporter(const ConvertOptions& options, OutputFormat output);
  void reading() { report("reading", 0.0); }
  /// Rate control's `done` steps of at most `bound`, with what its search is doing.
  void fitting(const std::string& what, uint32_t done, uint32_t bound);
  void quantizing() { report("quantizing", shares_.quantize); }
  void encoding_archive() { report("encoding the archive", shares_.encode); }
  void building_lod() { report("building levels of detail", shares_.quantize); }
  void writing() { report("writing", shares_.write); }
  /// The out-of-core conversion's reading pass, `fraction` of it done.
  void scanning(double fraction);
  /// A stage of the out-of-core build at `fraction` of it, which starts after the reading pass.
  void out_of_core(const char* stage, double fraction);
  void done() { report("done", 1.0); }

 private:
  struct Shares {
    double quantize, encode, write;
  };
  /// `stage` reported unless it is the one reported last (by content).
  void report(const char* stage, double fraction);
  /// `stage` at `fraction` (or the fraction reached, if more), with rate control's `step` of `steps`.
  void advance(const char* stage, double fraction, uint32_t step = 0, uint32_t steps = 0);
  const std::function<void(const ConvertProgress&)>& callback_;
  Shares shares_;
  std::string text_;  ///< rate control's stage text
  const char* stage_ = nullptr;
  double fraction_ = 0;
};

/// Where a conversion's Gaussians come from: a scene read whole (a file, bytes, a cloud, a scene read already),
/// or a binary PLY too large for memory, read in batches pass after pass (docs/LOD.md#scenes-larger-than-memory).
struct SceneSource {
  /// The source as named in messages, and the provenance's source_file (each file's name, joined by " + ").
  std::string name, source_file;
  /// The whole scene (unset for a batched source): its cloud and what was learned reading it.
  std::optional<converter::InputScene> scene;
  /// The batched PLY (null for a whole source).
  std::unique_ptr<converter::PlyStream> stream;
  /// A merge's inputs (ConvertReport::merge_inputs); a batched source's counts are filled by its first pass.
  std::vector<MergeInput> merge_inputs;
  /// When reading began (ConvertTimes::read).
  Clock::time_point start = Clock::now();
};

/// Whether a conversion to `dst` in `output` writes levels of detail: a .rgs with ConvertOptions::lod_levels, or a
/// streamed SOG (lod-meta.json).
bool writes_levels(const std::string& dst, OutputFormat output, const ConvertOptions& options);

/// kLimitExceeded naming `src`, `what` needs the estimate ("converting it": estimate_convert_memory of its inputs
/// together; or a merged scene's) and the limit when `estimate` is above convert_memory_limit(options); no check when
/// the limit is 0 (unknown physical memory). The check convert() runs before it reads a file whole
/// (convert_memory.cpp).
Status check_convert_memory(const std::string& src, uint64_t estimate, const ConvertOptions& options,
                            const std::string& what = "converting it");

/// The files at `srcs` (one or more) as the source of a conversion to `dst` in `output`, named by their names
/// joined with " + ": in batches, file after file (converter::PlyStream of them all), when they are binary PLYs
/// whose levels of detail are written (writes_levels; the runtime profile, no target) and whose estimated peak
/// when read whole together or when merged is above convert_memory_limit(options); else each read whole (converter::read_scene, after check_convert_memory
/// of their sum), the merged scene's estimate checked, each input edited (ConvertOptions::input_edits) and merged
/// (converter::merge_scenes). Their Gaussians together are held to options.read.max_gaussians.
Result<SceneSource> open_file_source(const std::vector<std::string>& srcs, const std::string& dst,
                                     OutputFormat output, const ConvertOptions& options);

struct PipelineScene;

/// A stage of the conversion, in the one list conversion_stages() gives (docs/DESIGN.md#the-scene-pipeline). A
/// per-batch stage (`batch` set) acts on each Gaussian alone, so that batch after batch gives the whole scene's
/// result: it runs on the cloud of a scene read whole, and on each batch of a scene read in batches as the batch is
/// read. A whole-scene stage (`whole` set) needs every Gaussian at once: a scene read in batches refuses it by
/// `name`, unless it `takes_batches` (the first pass's checks and the levels of detail, built out of core).
struct Stage {
  std::string name;
  /// Acts on `batch`, adding to (*removed)[i] the Gaussians scene edit i (ConvertOptions::edits) removed.
  std::function<Status(format::GaussianCloud* batch, std::vector<uint64_t>* removed)> batch;
  std::function<Status(PipelineScene* scene)> whole;
  bool takes_batches = false;
};

/// What the first pass over a scene read in batches learns, every value checked on the way: the count, the SH
/// degree and scales (converter::QuantizeScan), the means' box.
struct BatchStatistics {
  uint64_t count = 0;
  uint32_t sh_degree = 0;
  float box_lo[3] = {0, 0, 0}, box_hi[3] = {0, 0, 0};
  format::ShQuantization shq;
};

/// A scene read in batches, pass after pass (docs/LOD.md#scenes-larger-than-memory): binary PLYs as one
/// converter::PlyStream, each batch edited by the edits of the file it comes from (ConvertOptions::input_edits),
/// then by the per-batch stages added, in order, and given the anti-aliasing flag (ConvertOptions::read).
class SceneBatches {
 public:
  /// `options` hold one list of input_edits per file of `stream` and must outlive this; the batch size follows
  /// convert_memory_limit(options); the first pass scans as `quantize` will quantize.
  SceneBatches(std::unique_ptr<converter::PlyStream> stream, const ConvertOptions& options,
               const converter::QuantizeOptions& quantize);
  void add(const Stage& stage) { stages_.push_back(stage); }
  /// The next batch into `*batch`; false after the last. A batch that the edits emptied is skipped.
  Result<bool> next(format::GaussianCloud* batch);
  /// Back to the first batch; the counts of what the edits removed start again.
  Status rewind();
  /// The first pass, once (later calls give its result), reported as `progress`'s scanning; then removed(),
  /// read() and input_removed() hold the whole scene's counts.
  Result<const BatchStatistics*> scan(ProgressReporter* progress);
  /// Since the last rewind: the Gaussians each scene edit removed; per file, those read and those each of its
  /// edits removed.
  const std::vector<uint64_t>& removed() const { return removed_; }
  const std::vector<uint64_t>& read() const { return read_; }
  const std::vector<std::vector<uint64_t>>& input_removed() const { return input_removed_; }
  const converter::PlyStream& stream() const { return *stream_; }
  /// How the batches quantize: the options the first pass scanned with.
  const converter::QuantizeOptions& quantize() const { return quantize_; }
  /// The report's input fields (ConvertReport documents them) as the stream declares them.
  void describe(ConvertReport* report) const;
  /// Bytes a batch takes at most: its float cloud as read and its quantized copy.
  uint64_t batch_bytes() const;
  /// The error of a pass, naming the source `name` once (the stream's errors name it already, the build's do not);
  /// a file that changed since the stream opened it is named as the cause of whatever the pass found.
  Status pass_error(Status status, const std::string& name) const;

 private:
  void reset();
  std::unique_ptr<converter::PlyStream> stream_;
  const ConvertOptions& options_;
  converter::QuantizeOptions quantize_;
  uint64_t batch_;
  std::vector<Stage> stages_;
  std::vector<uint64_t> removed_, read_;
  std::vector<std::vector<uint64_t>> input_removed_;
  std::optional<BatchStatistics> statistics_;
};

/// The scene on its way from the stages to the sink: the float cloud as read (freed once quantized where nothing
/// reads it again), or its batches; its quantized form, its levels of detail, and the report filled as the work
/// goes.
struct PipelineScene {
  converter::InputScene input;
  /// A scene read in batches (null for a whole one): its per-batch stages act as its batches are read.
  std::unique_ptr<SceneBatches> batches;
  std::string name, source_file;  ///< SceneSource's
  Clock::time_point start;        ///< SceneSource's
  uint32_t read_sh_degree = 0;    ///< the SH degree as read, before the stages
  std::optional<format::EncodedScene> encoded;
  std::optional<converter::LodScene> lod;
  /// The levels of detail as the sinks read them: `lod` held, or those of an out-of-core build.
  std::unique_ptr<converter::Levels> levels;
  ConvertReport report;
  /// Per scene edit (ConvertOptions::edits), the Gaussians it removed: once the first pass is done.
  std::vector<uint64_t> edits_removed;
  /// Gaussians the edits removed, the scene's and the merge inputs'.
  uint64_t edited_out() const;
};

/// The stages a conversion to `output` at `dst` runs, in order: the edits (per batch but for decimate), rate
/// control with a target, the SH reduction (per batch), the first pass's notes and empty-scene check, then for a
/// .rgs quantizing, and for a .rgs with levels of detail or a streamed SOG quantizing and building the levels (in
/// memory, or out of core from a scene read in batches). `options` must outlive the stages (rate control changes
/// `*options`' archive settings).
std::vector<Stage> conversion_stages(const std::string& dst, OutputFormat output, ConvertOptions* options,
                                     ProgressReporter* progress);

/// kInvalidArgument: `what` (a stage, an input's edit) needs the scene `name` whole, which is read in batches.
Status needs_whole_scene(const std::string& name, const std::string& what);

/// Runs `stage` on `scene`: a per-batch stage on a whole scene's cloud, or added to a scene read in batches (it acts
/// as they are read); a whole-scene stage on the scene. kInvalidArgument naming the stage for a whole-scene stage
/// on a scene read in batches (unless it takes batches).
Status run_stage(const Stage& stage, PipelineScene* scene);

/// The levels of detail of the scene, as converter::Levels in scene->levels: a whole scene's quantized form
/// (scene->encoded) built in memory (converter::build_lod), or a scene read in batches quantized batch by batch with
/// its scanned SH scales into converter::build_lod_out_of_core, spilling beside `dst`
/// (docs/LOD.md#scenes-larger-than-memory).
Status build_levels(PipelineScene* scene, const std::string& dst, OutputFormat output, const ConvertOptions& options,
                    ProgressReporter* progress);

/// The error of a conversion whose scene is empty (refused unless ConvertOptions::allow_empty), naming `name` and
/// why: the edits removed the rest (`edited_out`), sanitizing dropped every Gaussian (`sanitized`), or the input
/// has none.
Status empty_scene_error(const std::string& name, uint64_t sanitized, uint64_t edited_out);

/// Applies `edits` in order to `cloud` (converter::apply_edit), adding to (*removed)[i] the Gaussians edit i
/// removed (`removed` has one entry per edit). Whole scenes and the batches of an out-of-core build alike.
Status apply_edits(const std::vector<converter::EditAction>& edits, format::GaussianCloud* cloud,
                   std::vector<uint64_t>* removed);

/// Whether an edit of `kind` is among `options`' edits, the scene's or an input's.
bool has_edit(const ConvertOptions& options, converter::EditKind kind);

/// One input note per filtering edit (filter-nan, filter, crop): how many Gaussians it removed (for filter-nan, also
/// those reading dropped, report->hygiene, which must be set).
void note_edits(const std::vector<converter::EditAction>& edits, const std::vector<uint64_t>& removed,
                ConvertReport* report);

/// Fills `input` (its path set) for a merge's input of `read` Gaussians whose `edits` removed `removed[i]` each.
void describe_merge_input(const std::vector<converter::EditAction>& edits, uint64_t read,
                          const std::vector<uint64_t>& removed, MergeInput* input);

// The sinks: each writes `scene` (after the stages) to `dst` through `files` (the output transaction, as a
// ProgressSink), filling scene->report's output fields.

/// The .rgs sink (runtime or archive profile, levels of detail): the scene's `encoded` (and `lod`) written, or the
/// `levels` of an out-of-core build streamed.
Status write_rgs_output(const std::string& dst, const ConvertOptions& options, ProgressReporter* progress,
                        PipelineScene* scene, format::FileSink& files);

/// The sink of a float format, `output` kPly, kSpz, kGlb or kSog (a bundle, or a folder when `dst` is named
/// meta.json): the scene's cloud written.
Status write_cloud_output(const std::string& dst, OutputFormat output, const ConvertOptions& options,
                          ProgressReporter* progress, PipelineScene* scene, format::FileSink& files);

/// The streamed SOG sink (`dst` named lod-meta.json): the scene's `levels` written.
Status write_sog_lod_output(const std::string& dst, PipelineScene* scene, format::FileSink& files);

/// Forwards to another sink, reporting the "writing" stage when the first bytes reach the file (before that,
/// the archive profile's encoder or the SPZ compressor is still running).
class ProgressSink final : public format::FileSink {
 public:
  ProgressSink(format::FileSink& inner, ProgressReporter* progress) : inner_(inner), progress_(progress) {}
  using format::FileSink::write;
  Status write(const std::string& path, const format::ChunkProducer& produce) override;
  Status write_by_name(const std::string& path, const format::ByNameWriter& write_to) override;
  Status declare(const std::vector<std::string>& paths) override { return inner_.declare(paths); }
  Status create_folder(const std::string& path) override { return inner_.create_folder(path); }

 private:
  format::FileSink& inner_;
  ProgressReporter* progress_;
};

/// The provenance a .rgs conversion writes (SPEC §4.2): the source's file name (SceneSource::source_file), bytes,
/// XXH64 and storage, the converter and the options that change the bytes, the Gaussians dropped by sanitizing.
format::Provenance rgs_provenance(const std::string& source_file, const ConvertOptions& options, uint64_t file_bytes,
                                  uint64_t file_xxh64, const std::string& storage, uint64_t dropped_gaussians);

/// The write options of a .rgs conversion (profile, codecs, zstd level), checked.
Result<format::WriteOptions> rgs_write_options(const ConvertOptions& options);

/// How a .rgs conversion quantizes: scale encoding, SH clip percentile and DC bits (8 for the archive profile,
/// which drops the DC residual: SPEC §4.8).
converter::QuantizeOptions rgs_quantize_options(const ConvertOptions& options);

/// How a streamed SOG's levels quantize: the runtime profile's values, the DC term with its residual.
converter::QuantizeOptions sog_lod_quantize_options(const ConvertOptions& options);

/// Adds a note to `report` when a written .rgs of `gaussians` (every level) is over the readers' default
/// max_gaussians (format::ReadLimits): what to pass to read it.
void note_read_limit(uint64_t gaussians, ConvertReport* report);

/// The report's input fields from what the reader learned (ConvertReport documents them).
void describe_input(const converter::InputScene& input, ConvertReport* report);

}  // namespace rgs::api::detail
