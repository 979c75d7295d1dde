// convert_report_json(): a conversion's report as JSON, the one builder behind rgs-convert --json and the dict of
// Python's convert() and save().
#include <nlohmann/json.hpp>

#include "rgs/api/convert.h"
#include "rgs/api/scene.h"
#include "rgs/converter/interop.h"
#include "rgs/converter/scene_reader.h"

namespace rgs::api {
namespace {

using nlohmann::json;

json stats_json(const converter::ErrorStats& s) { return {{"max", s.max}, {"rms", s.rms}, {"samples", s.samples}}; }

/// `s` as a fraction of the scene extent (0 for an extent of 0).
converter::ErrorStats of_extent(converter::ErrorStats s, double extent) {
  const double scale = extent > 0 ? 1.0 / extent : 0.0;
  s.max *= scale;
  s.rms *= scale;
  return s;
}

}  // namespace

std::string convert_report_json(const ConvertReport& r, const std::string& src, const std::string& dst,
                                const ConvertOptions& options) {
  const double per_gaussian = r.gaussians ? 1.0 / static_cast<double>(r.gaussians) : 0.0;
  json j;
  j["input"] = {{"path", src},
                {"bytes", r.input_bytes},
                {"format", r.input_format},
                {"description", r.input_description},
                {"storage", r.input_storage},
                {"declared_vertices", r.declared_gaussians},
                {"compact", r.input_compact},
                {"notes", r.input_notes}};
  j["output"] = {{"path", dst},
                 {"bytes", r.output_bytes},
                 {"format", output_format_name(r.output_format)},
                 {"description", r.output_description},
                 {"notes", r.output_notes}};
  j["gaussians"] = r.gaussians;
  j["sh_degree"] = r.sh_degree;
  j["bytes_per_gaussian"] = {{"input", double(r.input_bytes) * per_gaussian},
                             {"output", double(r.output_bytes) * per_gaussian}};
  j["ratio"] = r.output_bytes > 0 ? double(r.input_bytes) / double(r.output_bytes) : 0.0;
  j["hygiene"] = {{"nonfinite_values", r.hygiene.nonfinite_values},
                  {"gaussians_with_nonfinite", r.hygiene.gaussians_with_nonfinite},
                  {"zero_norm_quaternions", r.hygiene.zero_norm_quaternions},
                  {"infinite_opacity_logits", r.hygiene.infinite_opacity_logits},
                  {"dropped_gaussians", r.hygiene.dropped_gaussians}};
  if (r.output_format == OutputFormat::kPly) j["zero_scales"] = r.zero_scales;
  if (r.spz) {
    j["spz"] = {{"version", r.spz->version},
                {"fractional_bits", r.spz->fractional_bits},
                {"position_step", r.spz->position_step},
                {"scales_clamped", r.spz->scales_clamped},
                {"colors_clamped", r.spz->colors_clamped},
                {"sh_clamped", r.spz->sh_clamped},
                {"frame", converter::spz_frame_name(converter::spz_frame_for(options.read, dst))}};
  }
  if (r.rate_control) {
    const RateControlReport& f = *r.rate_control;
    const format::ArchiveOptions& a = f.settings;
    json target;
    if (options.target.psnr_db) target["psnr_db"] = *options.target.psnr_db;
    if (options.target.bytes) target["bytes"] = *options.target.bytes;
    j["rate_control"] = {
        {"target", target},
        {"psnr_mean_db", f.psnr_mean_db},
        {"psnr_min_db", f.psnr_min_db},
        {"search_psnr_db", f.search_psnr_db},
        {"settings", {{"position_error", a.position_error},
                      {"rotation_bits", a.rotation_bits},
                      {"rotation_step", a.rotation_step},
                      {"scale_bits", a.scale_bits},
                      {"scale_step", a.scale_step},
                      {"opacity_bits", a.opacity_bits},
                      {"opacity_step", a.opacity_step},
                      {"opacity_floor", a.opacity_floor},
                      {"sh_step_multipliers", a.sh_step_multipliers}}},
        {"views", f.views},
        {"width", f.width},
        {"height", f.height},
        {"search_width", f.search_width},
        {"search_height", f.search_height},
        {"backend", device_name(f.device)},
        {"device", f.device_name},
        {"encodings", f.encodings},
        {"renders", f.renders},
        {"seconds", f.seconds},
        {"encode_seconds", f.encode_seconds},
        {"render_seconds", f.render_seconds},
        {"views_note", f.views_note}};
  }
  if (!r.merge_inputs.empty()) {
    json inputs = json::array();
    for (const MergeInput& in : r.merge_inputs) {
      inputs.push_back({{"path", in.path}, {"gaussians", in.gaussians}, {"kept", in.kept}, {"edits", in.edits}});
    }
    std::vector<std::string> edits;
    for (const converter::EditAction& e : options.edits) edits.push_back(converter::edit_action_text(e));
    j["merge"] = {{"inputs", inputs}, {"edits", edits}};
  }
  if (r.rgs) {
    const RgsOutputReport& q = *r.rgs;
    json sh = json::array();
    for (uint32_t d = 0; d <= r.sh_degree; ++d) {
      const auto& scales = q.sh_quantization.scales[d];
      const auto& clipped = q.quantization.sh_clipped[d];
      sh.push_back({{"degree", d}, {"error", stats_json(q.errors.sh[d])},
                    {"scale", {scales[0], scales[1], scales[2]}}, {"clipped", {clipped[0], clipped[1], clipped[2]}}});
    }
    j["scales_fp16"] = {{"subnormal", q.quantization.scales_subnormal},
                        {"flushed_to_zero", q.quantization.scales_flushed_to_zero},
                        {"max_flushed_of_largest_axis", q.quantization.max_flushed_of_largest_axis}};
    j["extent"] = q.extent;
    if (q.lod_levels > 0) {
      j["lod"] = {{"levels", q.lod_levels}, {"chunks", q.lod_chunks}, {"gaussians", q.lod_gaussians}};
    }
    if (q.position_bits > 0) j["archive_omitted"] = q.archive_omitted;
    j["errors"] = {{"position", stats_json(q.errors.position)},
                   {"position_of_extent", stats_json(of_extent(q.errors.position, q.extent))},
                   {"rotation_deg", stats_json(q.errors.rotation_deg)},
                   {"scale_relative", stats_json(q.errors.scale_relative)},
                   {"scale_of_largest_axis", stats_json(q.errors.scale_of_largest_axis)},
                   {"opacity", stats_json(q.errors.opacity)},
                   {"sh", sh}};
  }
  // "quantize" includes the error measurement, which runs in the same pass.
  j["seconds"] = {{"read", r.seconds.read}, {"quantize", r.seconds.quantize}, {"lod", r.seconds.lod},
                  {"write", r.seconds.write}, {"total", r.seconds.total}};
  return j.dump(2, ' ', false, json::error_handler_t::replace);
}

}  // namespace rgs::api
