// The stages of a whole scene: a conversion's, in the order they run (the edits, rate control with a target, the
// empty-scene check, the SH reduction, quantizing and the levels of detail for a .rgs or a streamed SOG), and
// load()'s quantizing of formats other than .rgs.
#include <algorithm>

#include "../internal_load.h"
#include "../internal_pipeline.h"
#include "../rate_control/rate_control.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/sog_writer.h"

namespace rgs::api::detail {

namespace {

/// Rate control (ConvertOptions::target): the archive options fitted on the scene as read (its SH bands all
/// rendered as the source's), written into `*options` for the stages and the sink that follow.
Status fit(PipelineScene* scene, ConvertOptions* options, ProgressReporter* progress) {
  RGS_ASSIGN_OR_RETURN(RateControlReport rate,
                       fit_target(scene->input, scene->name, options,
                                  [progress](const std::string& what, uint32_t done, uint32_t bound) {
                                    progress->fitting(what, done, bound);
                                  }));
  scene->report.rate_control = std::move(rate);
  return Status();
}

/// A per-batch stage's `batch` on a whole scene's cloud, what it removed counted per scene edit; the bounds follow
/// the edited means.
Status apply_to_whole(const std::function<Status(format::GaussianCloud*, std::vector<uint64_t>*)>& batch,
                      PipelineScene* scene) {
  Status applied = batch(&scene->input.cloud, &scene->edits_removed);
  if (!applied.ok()) return applied.prepend(scene->name);
  scene->input.bounds = converter::compute_bounds(scene->input.cloud);
  return Status();
}

/// The first pass's end: a scene read in batches scanned (its counts, SH scales and box learned, its merge inputs
/// described), then for either the notes of what the per-batch stages removed and reduced, and the empty-scene
/// check.
Status finish_first_pass(PipelineScene* scene, const ConvertOptions& options, ProgressReporter* progress) {
  ConvertReport& report = scene->report;
  uint64_t count = scene->input.cloud.size();
  if (scene->batches) {
    SceneBatches& batches = *scene->batches;
    auto stats = batches.scan(progress);
    if (!stats.ok()) return batches.pass_error(stats.status(), scene->name);
    count = (*stats)->count;
    report.seconds.read = seconds_since(scene->start);
    report.hygiene = batches.stream().hygiene();
    scene->edits_removed = batches.removed();
    for (size_t f = 0; f < report.merge_inputs.size(); ++f) {
      describe_merge_input(options.input_edits[f], batches.read()[f], batches.input_removed()[f],
                           &report.merge_inputs[f]);
    }
  }
  note_edits(options.edits, scene->edits_removed, &report);
  if (options.sh_degree && *options.sh_degree < scene->read_sh_degree) {
    report.input_notes.push_back("SH degree " + std::to_string(scene->read_sh_degree) + " reduced to " +
                                 std::to_string(*options.sh_degree));
  }
  if (count > 0 || options.allow_empty) return Status();
  return empty_scene_error(scene->name, report.hygiene.dropped_gaussians, scene->edited_out());
}

/// Quantizes the cloud for `output`, a .rgs or a streamed SOG (which writes the runtime profile's values). For a .rgs,
/// the quantization report and, for the runtime profile, its errors measured in the same pass (the archive's are
/// measured on what it decodes to, by the sink); the provenance set. The cloud is freed unless the archive's sink
/// measures against it.
Status quantize_scene(PipelineScene* scene, OutputFormat output, const ConvertOptions& options,
                      ProgressReporter* progress) {
  const bool archive = options.profile == format::StorageProfile::kArchive;
  RgsOutputReport* rgs = output == OutputFormat::kRgs ? &scene->report.rgs.emplace() : nullptr;
  converter::InputScene& input = scene->input;
  progress->quantizing();
  const auto start = Clock::now();
  auto encoded =
      converter::quantize(input.cloud, rgs ? rgs_quantize_options(options) : sog_lod_quantize_options(options),
                          rgs ? &rgs->quantization : nullptr, rgs && !archive ? &rgs->errors : nullptr);
  if (!encoded.ok()) return Status(encoded.status()).prepend(scene->name);
  scene->report.seconds.quantize = seconds_since(start);
  scene->report.gaussians = input.cloud.size();
  scene->report.sh_degree = input.cloud.sh_degree;
  // Not read again but by the archive's sink: freed before the writer's buffers exist (peak RSS).
  if (!(rgs && archive)) input.cloud = {};
  if (rgs) {
    encoded->provenance = rgs_provenance(scene->source_file, options, input.file_bytes, input.file_xxh64.value_or(0),
                                         input.storage_format, input.hygiene.dropped_gaussians);
  }
  scene->encoded.emplace(std::move(encoded).value());
  return Status();
}

bool moves(converter::EditKind kind) {
  return kind == converter::EditKind::kTranslate || kind == converter::EditKind::kRotate ||
         kind == converter::EditKind::kScale;
}

/// The edit's text, with the Gaussians it removed when it filters.
std::string edit_summary(const converter::EditAction& edit, uint64_t removed) {
  if (moves(edit.kind)) return converter::edit_action_text(edit);
  return converter::edit_action_text(edit) + " removed " + group_digits(removed) +
         (removed == 1 ? " Gaussian" : " Gaussians");
}

}  // namespace

Status empty_scene_error(const std::string& name, uint64_t sanitized, uint64_t edited_out) {
  const std::string why =
      edited_out > 0 ? "the edits (filter, crop) removed all " + std::to_string(edited_out) +
                           " Gaussians left after reading, so the scene is empty"
      : sanitized > 0 ? "sanitizing (--sanitize) dropped all " + std::to_string(sanitized) +
                            " Gaussians, so the scene is empty"
                      : "the input has no Gaussians";
  return Status(StatusCode::kInvalidArgument,
                name + ": " + why + "; allow_empty (--allow-empty) writes an empty scene");
}

Status apply_edits(const std::vector<converter::EditAction>& edits, format::GaussianCloud* cloud,
                   std::vector<uint64_t>* removed) {
  for (size_t i = 0; i < edits.size(); ++i) {
    RGS_ASSIGN_OR_RETURN(const uint64_t r, converter::apply_edit(cloud, edits[i]));
    (*removed)[i] += r;
  }
  return Status();
}

bool has_edit(const ConvertOptions& options, converter::EditKind kind) {
  const auto is = [kind](const converter::EditAction& e) { return e.kind == kind; };
  return std::any_of(options.edits.begin(), options.edits.end(), is) ||
         std::any_of(options.input_edits.begin(), options.input_edits.end(),
                     [&](const auto& edits) { return std::any_of(edits.begin(), edits.end(), is); });
}

void describe_merge_input(const std::vector<converter::EditAction>& edits, uint64_t read,
                          const std::vector<uint64_t>& removed, MergeInput* input) {
  input->gaussians = input->kept = read;
  for (size_t i = 0; i < edits.size(); ++i) {
    input->edits.push_back(edit_summary(edits[i], removed[i]));
    input->kept -= removed[i];
  }
}

void note_edits(const std::vector<converter::EditAction>& edits, const std::vector<uint64_t>& removed,
                ConvertReport* report) {
  for (size_t i = 0; i < edits.size(); ++i) {
    const converter::EditKind kind = edits[i].kind;
    if (moves(kind)) continue;
    const uint64_t dropped = report->hygiene.dropped_gaussians;
    report->input_notes.push_back(
        edit_summary(edits[i], removed[i]) +
        (kind == converter::EditKind::kFilterNan && dropped > 0
             ? " (and reading dropped " + group_digits(dropped) + " with a non-finite value or a zero-norm rotation)"
             : ""));
  }
}

std::vector<Stage> conversion_stages(const std::string& dst, OutputFormat output, ConvertOptions* options,
                                     ProgressReporter* progress) {
  std::vector<Stage> stages;
  if (!options->edits.empty()) {
    Stage& edits = stages.emplace_back();
    edits.name = "the edits";
    auto batch = [options](format::GaussianCloud* cloud, std::vector<uint64_t>* removed) {
      return apply_edits(options->edits, cloud, removed);
    };
    if (has_edit(*options, converter::EditKind::kDecimate)) {
      edits.name = "decimate";  // keeps a share of the whole scene's Gaussians, not one Gaussian at a time
      edits.whole = [batch](PipelineScene* s) { return apply_to_whole(batch, s); };
    } else {
      edits.batch = batch;
    }
  }
  if (options->target.active()) {
    stages.push_back({"rate control (target_psnr, target_bytes)", nullptr,
                      [options, progress](PipelineScene* s) { return fit(s, options, progress); }});
  }
  if (options->sh_degree) {
    stages.push_back({"the SH reduction",
                      [degree = *options->sh_degree](format::GaussianCloud* cloud, std::vector<uint64_t>*) {
                        return degree < cloud->sh_degree ? converter::reduce_sh_degree(cloud, degree) : Status();
                      },
                      nullptr});
  }
  stages.push_back({"the first pass", nullptr,
                    [options, progress](PipelineScene* s) { return finish_first_pass(s, *options, progress); }, true});
  const bool levels = writes_levels(dst, output, *options);
  if (levels || output == OutputFormat::kRgs) {
    stages.push_back({levels ? "the levels of detail" : "quantizing", nullptr,
                      [dst, output, options, progress, levels](PipelineScene* s) {
                        if (!s->batches) {  // a scene read in batches is quantized batch by batch by the build
                          RGS_RETURN_IF_ERROR(quantize_scene(s, output, *options, progress));
                        }
                        return levels ? build_levels(s, dst, output, *options, progress) : Status();
                      },
                      levels});
  }
  return stages;
}

Status run_stage(const Stage& stage, PipelineScene* scene) {
  if (stage.batch && scene->batches) {
    scene->batches->add(stage);
    return Status();
  }
  if (stage.batch) return apply_to_whole(stage.batch, scene);
  if (scene->batches && !stage.takes_batches) return needs_whole_scene(scene->name, stage.name);
  return stage.whole(scene);
}

Status needs_whole_scene(const std::string& name, const std::string& what) {
  return Status(StatusCode::kInvalidArgument,
                name + ": " + what +
                    " needs the whole scene (or input) in memory, and this conversion reads it in batches (out of "
                    "core: its estimated peak is above the memory limit); raise memory_limit (--memory-limit) to "
                    "read it whole");
}

uint64_t PipelineScene::edited_out() const {
  uint64_t out = 0;
  for (const uint64_t r : edits_removed) out += r;
  for (const MergeInput& merged : report.merge_inputs) out += merged.gaussians - merged.kept;
  return out;
}

Status quantize_for_load(LoadScene* scene, const LoadOptions& options) {
  if (!scene->input || !options.quantize_other_formats) return Status();
  auto encoded = converter::quantize(scene->input->cloud, converter::QuantizeOptions{});
  if (!encoded.ok()) return Status(encoded.status()).prepend(scene->name);
  scene->input->cloud = format::GaussianCloud{};
  scene->encoded.emplace(std::move(encoded).value());
  return Status();
}

}  // namespace rgs::api::detail
