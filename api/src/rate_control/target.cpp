// convert()'s rate control (ConvertOptions::target): the views, the fit of the archive options on the scene it
// read, the options that write the choice and its report.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "rate_control.h"
#include "knobs.h"
#include "rgs/api/camera.h"
#include "rgs/api/convert.h"
#include "rgs/converter/cloud_edits.h"

namespace rgs::api {

std::string describe_archive_options(const format::ArchiveOptions& o, uint32_t sh_degree) {
  std::string text = "rotation " + std::to_string(o.rotation_bits) + ", scale " + std::to_string(o.scale_bits) +
                     ", opacity " + std::to_string(o.opacity_bits) + " bits; ";
  if (o.rotation_step != 1 || o.scale_step != 1 || o.opacity_step != 1) {
    char steps[96];
    std::snprintf(steps, sizeof(steps), "code steps x%.3g/%.3g/%.3g; ", o.rotation_step, o.scale_step, o.opacity_step);
    text += steps;
  }
  if (o.opacity_floor > 0) {
    char floor[64];
    std::snprintf(floor, sizeof(floor), "opacity floor %.3g/255; ", 255 * o.opacity_floor);
    text += floor;
  }
  text += "SH step x";
  for (uint32_t d = 0; d <= std::min<uint32_t>(sh_degree, 3); ++d) {
    text += (d ? "/" : "") + std::to_string(o.sh_step_multipliers[d]);
  }
  char position[64];
  std::snprintf(position, sizeof(position), "; position error %.3g of the extent", o.position_error);
  return text + position;
}

namespace detail {

namespace {

/// The views of `options.target` for the scene read from `src_name`, after `options.edits`: make_cameras when it
/// names a cameras file, an orbit or a path, else default_views (its note in `note`). Cameras of a file are in
/// the source's frame and move with the edits; an orbit, a path or guessed views are made on the edited scene.
Result<std::vector<runtime::Camera>> target_views(const ConvertOptions& options, const converter::InputScene& input,
                                                  const std::string& src_name, std::string* note) {
  const CameraChoice& views = options.target.views;
  std::vector<runtime::Camera> cameras;
  bool from_file = !views.cameras_path.empty();
  if (!from_file && views.orbit == 0 && views.path == 0) {
    RGS_ASSIGN_OR_RETURN(DefaultViews found, default_views(src_name, input.cloud, views));
    *note = std::move(found.note);
    cameras = std::move(found.cameras);
    from_file = !found.cameras_path.empty();
  } else {
    auto made = make_cameras(views, content_frame(input.cloud));
    if (!made.ok()) return Status(made.status()).prepend(src_name + ": rate control's views");
    cameras = std::move(made).value();
  }
  if (from_file) {  // in the source's frame: moved with the scene
    const converter::EditMotion m = converter::edit_motion(options.edits);
    for (runtime::Camera& cam : cameras) runtime::move_camera(&cam, m.rotation, m.scale, m.offset);
  }
  return cameras;
}

/// fit_archive's options for `options` (as convert() will write the archive) on the scene read from `src_name`.
FitOptions fit_options(const ConvertOptions& options, const converter::InputScene& input, const std::string& src_name) {
  const ConvertTarget& target = options.target;
  FitOptions fit;
  fit.target = target;
  fit.quantize.scale_encoding = options.scale_encoding;
  fit.quantize.sh_clip_percentile = options.sh_clip_percentile;
  fit.sh_degree = options.sh_degree;
  fit.start = options.archive;
  // As convert() codes the archive: at its zstd level (the .xz trials as format::resolve_archive_options keeps them).
  ConvertOptions archive = options;
  archive.profile = format::StorageProfile::kArchive;
  fit.start.zstd_level = zstd_level_for(archive);
  // The provenance: the source's name and storage, the converter's name and the options' text.
  fit.provenance_bytes = 768 + std::filesystem::path(src_name).filename().string().size() +
                         input.storage_format.size() + options.converter_name.size();
  return fit;
}

}  // namespace

Result<RateControlReport> fit_target(const converter::InputScene& input, const std::string& src_name,
                                     ConvertOptions* options, const FitProgress::Sink& progress) {
  std::string note;
  RGS_ASSIGN_OR_RETURN(const std::vector<runtime::Camera> views, target_views(*options, input, src_name, &note));
  FitOptions fit = fit_options(*options, input, src_name);
  FitProgress steps(progress);
  fit.progress = &steps;
  auto fitted = fit_archive(input.cloud, views, fit);
  if (!fitted.ok()) return Status(fitted.status()).prepend(src_name);
  options->profile = format::StorageProfile::kArchive;
  options->archive = fitted->chosen.options;
  options->archive_earlier = std::move(fitted->archive);
  RateControlReport report = std::move(fitted->report);
  report.views_note = std::move(note);
  return report;
}

}  // namespace detail

}  // namespace rgs::api
