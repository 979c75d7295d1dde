// convert() and its siblings: the options' checks, the output formats' names, and the driver that runs a source
// through the conversion's stages into its sink, in one output transaction (internal_pipeline.h).
#include "rgs/api/convert.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <utility>

#include "internal_pipeline.h"
#include "rgs/converter/sog_writer.h"

namespace rgs::api {

namespace {

struct FormatName {
  OutputFormat format;
  const char* name;
  const char* extension;
};
constexpr FormatName kFormatNames[] = {{OutputFormat::kRgs, "rgs", ".rgs"},
                                       {OutputFormat::kPly, "ply", ".ply"},
                                       {OutputFormat::kSpz, "spz", ".spz"},
                                       {OutputFormat::kGlb, "glb", ".glb"},
                                       {OutputFormat::kSog, "sog", ".sog"}};

const FormatName& entry(OutputFormat format) {
  for (const FormatName& f : kFormatNames) {
    if (f.format == format) return f;
  }
  return kFormatNames[0];
}

/// The formats' names, or their extensions as "*.rgs", comma-separated.
std::string format_list(bool extensions) {
  std::string list;
  for (const FormatName& f : kFormatNames) {
    list += (list.empty() ? "" : ", ") + (extensions ? "*" + std::string(f.extension) : std::string(f.name));
  }
  return list;
}

}  // namespace

int zstd_level_for(const ConvertOptions& options) {
  const bool archive = options.profile == format::StorageProfile::kArchive;
  return options.zstd_level.value_or(archive ? kArchiveDefaultZstdLevel : kDefaultZstdLevel);
}

namespace {

/// Whether `choice` differs from the default CameraChoice (the orbit's default size aside).
bool names_views(const CameraChoice& choice) {
  return !choice.cameras_path.empty() || choice.every != 1 || choice.limit != 0 || choice.fly != 0 ||
         choice.orbit != 0 || choice.path != 0 || choice.width != 0 || choice.height != 0;
}

/// The target's own rules (check_convert_options).
Status check_target(const ConvertOptions& options) {
  const ConvertTarget& target = options.target;
  RGS_RETURN_ERROR_IF(!target.active() && names_views(target.views), StatusCode::kInvalidArgument,
                      "convert: views (cameras, every, limit, fly, orbit, path, width, height) choose the views of "
                      "a PSNR or byte target (--target-psnr, --target-bytes), and none is set");
  if (!target.active()) return Status();
  RGS_RETURN_ERROR_IF(target.psnr_db && target.bytes, StatusCode::kInvalidArgument,
                      "convert: a PSNR target and a byte target exclude each other");
  RGS_RETURN_ERROR_IF(target.psnr_db && !(std::isfinite(*target.psnr_db) && *target.psnr_db > 0),
                      StatusCode::kInvalidArgument,
                      "convert: target PSNR " + std::to_string(target.psnr_db.value_or(0)) +
                          " dB is not a finite, positive number");
  RGS_RETURN_ERROR_IF(target.bytes && *target.bytes == 0, StatusCode::kInvalidArgument,
                      "convert: a target of 0 bytes");
  RGS_RETURN_ERROR_IF(options.lod_levels.has_value(), StatusCode::kInvalidArgument,
                      "convert: a PSNR or byte target (--target-psnr, --target-bytes) writes the archive profile, "
                      "which has no levels of detail (lod_levels, --lod-levels: they need the runtime profile)");
  RGS_RETURN_ERROR_IF(options.to && *options.to != OutputFormat::kRgs, StatusCode::kInvalidArgument,
                      std::string("convert: a PSNR or byte target chooses the archive profile of a .rgs output, not ") +
                          output_format_name(*options.to));
  return Status();
}

}  // namespace

Status check_convert_options(const ConvertOptions& options) {
  RGS_RETURN_IF_ERROR(check_target(options));
  if (options.target.active() && options.profile != format::StorageProfile::kArchive) {
    ConvertOptions archive = options;  // a target writes the archive profile
    archive.profile = format::StorageProfile::kArchive;
    return check_convert_options(archive);
  }
  std::vector<converter::EditAction> edits = options.edits;
  for (const auto& input : options.input_edits) edits.insert(edits.end(), input.begin(), input.end());
  for (const converter::EditAction& edit : edits) {
    if (Status s = converter::check_edit_action(edit); !s.ok()) return s.prepend("convert: edit");
  }
  RGS_RETURN_ERROR_IF(options.sh_degree && *options.sh_degree > 3, StatusCode::kInvalidArgument,
                      "convert: SH degree " + std::to_string(*options.sh_degree) + " outside 0..3");
  RGS_RETURN_ERROR_IF(!(options.sh_clip_percentile > 0.0f && options.sh_clip_percentile <= 100.0f),
                      StatusCode::kInvalidArgument, "convert: SH clip percentile outside (0, 100]");
  RGS_RETURN_ERROR_IF(options.sh_dc_bits != 8 && options.sh_dc_bits != 16, StatusCode::kInvalidArgument,
                      "convert: SH DC precision of " + std::to_string(options.sh_dc_bits) + " bits is not 8 or 16");
  if (options.profile == format::StorageProfile::kArchive) {
    format::ArchiveOptions archive_options = options.archive;
    archive_options.zstd_level = zstd_level_for(options);  // as write_options() codes the archive
    Status archive = format::check_archive_options(archive_options);
    if (!archive.ok()) return archive.prepend("convert: archive profile");
  }
  return detail::rgs_write_options(options).status();
}

const char* output_format_name(OutputFormat format) { return entry(format).name; }

Status check_convert_output(const std::string& dst, OutputFormat output, const ConvertOptions& options) {
  RGS_RETURN_ERROR_IF(options.target.active() && output != OutputFormat::kRgs, StatusCode::kInvalidArgument,
                      dst + ": a PSNR or byte target chooses the archive profile of a .rgs output, not " +
                          output_format_name(output));
  RGS_RETURN_ERROR_IF(options.lod_levels && !detail::writes_levels(dst, output, options), StatusCode::kInvalidArgument,
                      dst + ": levels of detail (lod_levels, --lod-levels) are written into a .rgs or a streamed SOG "
                            "(lod-meta.json), and a " + std::string(output_format_name(output)) +
                          " output has none");
  return check_convert_options(options);
}

converter::SceneReadOptions scene_read_options(const ConvertOptions& options) {
  converter::SceneReadOptions read = options.read;
  read.invalid_policy = options.sanitize || detail::has_edit(options, converter::EditKind::kFilterNan)
                            ? converter::InvalidPolicy::kSanitize
                            : converter::InvalidPolicy::kReject;
  read.hash_file = true;  // provenance's source_xxh64, computed in the reading pass
  return read;
}

Result<OutputFormat> parse_output_format(const std::string& name) {
  for (const FormatName& f : kFormatNames) {
    if (name == f.name) return f.format;
  }
  return Status(StatusCode::kInvalidArgument, "unknown output format '" + name + "' (use " + format_list(false) + ")");
}

std::vector<std::string> output_paths(const std::string& dst, OutputFormat output) {
  if (output == OutputFormat::kSog && converter::is_sog_folder_path(dst)) return converter::sog_folder_files(dst);
  return {dst};
}

Result<OutputFormat> output_format_for(const std::string& dst, std::optional<OutputFormat> to) {
  const std::string ext = converter::extension_of(dst);
  const FormatName* by_ext = nullptr;
  for (const FormatName& f : kFormatNames) {
    // A SOG entry's name (meta.json, lod-meta.json) chooses SOG only when `to` does not choose: as a .json it
    // contradicts no format.
    const bool sog_entry = converter::is_sog_folder_path(dst) || converter::is_sog_lod_path(dst);
    if (ext == f.extension || (!to && f.format == OutputFormat::kSog && sog_entry)) by_ext = &f;
  }
  if (!to) {
    RGS_RETURN_ERROR_IF(by_ext == nullptr, StatusCode::kInvalidArgument,
                        dst + ": cannot tell the output format from this name; name the output " +
                            format_list(true) + ", meta.json (a SOG folder) or lod-meta.json (a streamed SOG), or "
                            "choose the format with rgs-convert --to or Python's to= (" + format_list(false) + ")");
    return by_ext->format;
  }
  RGS_RETURN_ERROR_IF(by_ext != nullptr && by_ext->format != *to, StatusCode::kInvalidArgument,
                      dst + ": the name says " + by_ext->name + " but the format asked for is " +
                          entry(*to).name + "; name the output *" + entry(*to).extension +
                          " or leave the format to the name");
  return *to;
}

namespace {

/// The output transaction of one conversion: the caller's (ConvertOptions::files), or one of its own that
/// commit() commits. `options()` are the caller's with `files` pointing to it.
class ConversionOutputs {
 public:
  explicit ConversionOutputs(const ConvertOptions& options) : options_(options) {
    if (options_.files == nullptr) options_.files = &own_;
  }
  const ConvertOptions& options() const { return options_; }
  /// Declares the files of `dst` (OutputFormat `output`) and the files read, `inputs`, to the transaction.
  Status declare(const std::string& dst, OutputFormat output, const std::vector<std::string>& inputs) {
    for (const std::string& input : inputs) RGS_RETURN_IF_ERROR(options_.files->add_input(input));
    return options_.files->declare(output_paths(dst, output));
  }
  /// Commits the transaction when it is the conversion's own; `report` is passed through.
  Result<ConvertReport> commit(Result<ConvertReport> report) {
    if (!report.ok() || options_.files != &own_) return report;
    RGS_RETURN_IF_ERROR(own_.commit());
    return report;
  }

 private:
  format::OutputTransaction own_;
  ConvertOptions options_;
};

/// `options` for `inputs` inputs: input_edits one list each, but one input's before `edits` (they act alike).
/// kInvalidArgument naming `dst` for the edits of more inputs.
Result<ConvertOptions> per_input(ConvertOptions options, size_t inputs, const std::string& dst) {
  RGS_RETURN_ERROR_IF(options.input_edits.size() > inputs, StatusCode::kInvalidArgument,
                      dst + ": the edits of " + std::to_string(options.input_edits.size()) + " inputs for " +
                          std::to_string(inputs));
  options.input_edits.resize(inputs);
  if (inputs != 1) return options;
  std::vector<converter::EditAction>& own = options.input_edits[0];
  options.edits.insert(options.edits.begin(), own.begin(), own.end());
  own.clear();
  return options;
}

/// The sink of `output` at `dst`: `scene` written through `options`' output transaction.
Status write_output(const std::string& dst, OutputFormat output, const ConvertOptions& options,
                    detail::ProgressReporter* progress, detail::PipelineScene* scene) {
  detail::ProgressSink files(*options.files, progress);
  if (output == OutputFormat::kRgs) return detail::write_rgs_output(dst, options, progress, scene, files);
  if (output == OutputFormat::kSog && converter::is_sog_lod_path(dst)) {
    return detail::write_sog_lod_output(dst, scene, files);
  }
  return detail::write_cloud_output(dst, output, options, progress, scene, files);
}

/// The conversion's one driver: `source`'s scene, whole or in batches, through the stages of a conversion to `dst`
/// in `output` (conversion_stages) into its sink, within `options`' output transaction (internal_pipeline.h);
/// with a byte target, a file over it is kLimitExceeded (its provenance larger than the fit allowed for).
Result<ConvertReport> run(detail::SceneSource source, const std::string& dst, OutputFormat output,
                          const ConvertOptions& options, detail::ProgressReporter* progress) {
  ConvertOptions settings = options;  // rate control writes its choice here
  detail::PipelineScene scene;
  scene.name = source.name;
  scene.source_file = source.source_file;
  scene.start = source.start;
  scene.edits_removed.assign(options.edits.size(), 0);
  ConvertReport& report = scene.report;
  report.merge_inputs = std::move(source.merge_inputs);
  report.output_format = output;
  if (source.stream) {
    scene.read_sh_degree = source.stream->sh_degree();
    scene.batches = std::make_unique<detail::SceneBatches>(
        std::move(source.stream), settings,
        output == OutputFormat::kRgs ? detail::rgs_quantize_options(settings) : detail::sog_lod_quantize_options(settings));
    scene.batches->describe(&report);
  } else {
    scene.input = std::move(*source.scene);
    scene.read_sh_degree = scene.input.cloud.sh_degree;
    detail::describe_input(scene.input, &report);
    report.seconds.read = detail::seconds_since(source.start);
  }
  for (const detail::Stage& stage : detail::conversion_stages(dst, output, &settings, progress)) {
    RGS_RETURN_IF_ERROR(detail::run_stage(stage, &scene));
  }
  RGS_RETURN_IF_ERROR(write_output(dst, output, settings, progress, &scene));
  report.seconds.total = detail::seconds_since(source.start);
  if (options.target.bytes && report.output_bytes > *options.target.bytes) {
    return Status(StatusCode::kLimitExceeded,
                  dst + ": the archive has " + rgs::group_digits(report.output_bytes) +
                      " bytes, over the target of " + rgs::group_digits(*options.target.bytes) +
                      " (its provenance is larger than the fit allowed for)");
  }
  progress->done();
  return std::move(report);
}

/// A whole source: the scene `input` read from `name` (its files the inputs).
Result<detail::SceneSource> whole_source(Result<converter::InputScene> input, const std::string& name) {
  if (!input.ok()) return input.status();
  detail::SceneSource source;
  source.name = name;
  source.source_file = std::filesystem::path(name).filename().string();
  source.scene.emplace(std::move(input).value());
  return source;
}

/// Every door of convert(): the options for `inputs` inputs, the output checked and declared, then the source
/// `open` gives for them run into `dst`, a whole source's files declared as read. `reads` when `open` reads
/// (`srcs`, or bytes): the output is declared before it, so that a refused output costs no read, and the
/// "reading" stage is reported.
Result<ConvertReport> convert_source(
    const std::vector<std::string>& srcs, size_t inputs, const std::string& dst, const ConvertOptions& given,
    bool reads, const std::function<Result<detail::SceneSource>(const ConvertOptions&, OutputFormat)>& open) {
  const auto start = detail::Clock::now();
  RGS_ASSIGN_OR_RETURN(const ConvertOptions options, per_input(given, inputs, dst));
  RGS_ASSIGN_OR_RETURN(OutputFormat output, output_format_for(dst, options.to));
  RGS_RETURN_IF_ERROR(check_convert_output(dst, output, options));
  ConversionOutputs outputs(options);
  if (reads) RGS_RETURN_IF_ERROR(outputs.declare(dst, output, srcs));
  detail::ProgressReporter progress(options, output);
  if (reads) progress.reading();
  RGS_ASSIGN_OR_RETURN(detail::SceneSource source, open(options, output));
  source.start = start;
  if (source.scene) RGS_RETURN_IF_ERROR(outputs.declare(dst, output, source.scene->files));
  return outputs.commit(run(std::move(source), dst, output, outputs.options(), &progress));
}

}  // namespace

Result<ConvertReport> convert(const std::string& src, const std::string& dst, const ConvertOptions& options) {
  return convert(std::vector<std::string>{src}, dst, options);
}

Result<ConvertReport> convert(const std::vector<std::string>& srcs, const std::string& dst,
                              const ConvertOptions& options) {
  RGS_RETURN_ERROR_IF(srcs.empty(), StatusCode::kInvalidArgument, dst + ": no input to convert");
  return convert_source(srcs, srcs.size(), dst, options, true, [&](const ConvertOptions& o, OutputFormat output) {
    return detail::open_file_source(srcs, dst, output, o);
  });
}

Result<ConvertReport> convert_scene(converter::InputScene input, const std::string& src, const std::string& dst,
                                    const ConvertOptions& options) {
  return convert_source({}, 1, dst, options, false,
                        [&](const ConvertOptions&, OutputFormat) { return whole_source(std::move(input), src); });
}

Result<ConvertReport> convert_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const std::string& dst, const ConvertOptions& options) {
  return convert_source({}, 1, dst, options, true, [&](const ConvertOptions& o, OutputFormat) {
    return whole_source(converter::read_scene_bytes(data, size, name, scene_read_options(o)), name);
  });
}

Result<ConvertReport> convert_cloud(format::GaussianCloud cloud, const std::string& name, const std::string& dst,
                                    const ConvertOptions& options) {
  return convert_source({}, 1, dst, options, true, [&](const ConvertOptions& o, OutputFormat) {
    return whole_source(converter::scene_from_cloud(std::move(cloud), name, scene_read_options(o)), name);
  });
}

}  // namespace rgs::api
