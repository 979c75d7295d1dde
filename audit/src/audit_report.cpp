#include "rgs/audit/audit_report.h"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <system_error>

#include "rgs/format/file_io.h"

namespace rgs::audit {

namespace {

using nlohmann::json;

/// A dB value: a number, "inf" / "-inf", or null for NaN (no value: a view without foreground).
json db_json(double v) {
  if (std::isnan(v)) return nullptr;
  return std::isinf(v) ? json(v > 0 ? "inf" : "-inf") : json(v);
}

json stats_json(const converter::ErrorStats& s) { return {{"max", s.max}, {"rms", s.rms}, {"samples", s.samples}}; }

std::string image_name(size_t candidate, size_t view, const char* what, const char* ext) {
  return "c" + std::to_string(candidate) + "_v" + std::to_string(view) + "_" + what + ext;
}

json verdict_json(const Verdict& v) {
  return {{"passed", v.passed},
          {"metric", verdict_metric_name(v.metric)},
          {"psnr_mean_db", db_json(v.psnr_mean_db)},
          {"whole_frame_psnr_mean_db", db_json(v.whole_frame_psnr_mean_db)},
          {"foreground_psnr_mean_db", db_json(v.foreground_psnr_mean_db)},
          {"worst_view", {{"name", v.worst_view}, {"psnr_db", db_json(v.worst_psnr_db)}}},
          {"bytes_saved", v.bytes_saved ? json(*v.bytes_saved) : json(nullptr)},
          {"bytes_saved_fraction", v.bytes_saved ? json(v.bytes_saved_fraction) : json(nullptr)},
          {"content_lost", v.content_lost.empty() ? json(nullptr) : json(v.content_lost)}};
}

/// `s` with its bytes per Gaussian of the source (`source_gaussians`), and its ratio to `source_bytes` if not 0.
json scene_json(const SceneInfo& s, uint64_t source_bytes, uint64_t source_gaussians) {
  const double per_g = source_gaussians ? 1.0 / double(source_gaussians) : 0.0;
  json j = {{"path", s.path},
            {"label", s.label},
            {"format", s.format},
            {"bytes", s.file_bytes},
            {"gaussians", s.gaussians},
            {"sh_degree", s.sh_degree},
            {"bytes_per_gaussian", double(s.file_bytes) * per_g},
            {"load_seconds", s.load_seconds}};
  if (source_bytes > 0) j["ratio"] = s.file_bytes > 0 ? double(source_bytes) / double(s.file_bytes) : 0.0;
  json sections = json::array();
  for (const SectionSize& e : s.sections) {
    sections.push_back({{"name", e.name}, {"codec", e.codec}, {"bytes", e.stored_bytes}, {"raw_bytes", e.raw_bytes},
                        {"bytes_per_gaussian", double(e.stored_bytes) * per_g}});
  }
  j["sections"] = sections;
  if (!s.sections.empty()) j["header_table_padding_bytes"] = s.overhead_bytes;
  return j;
}

json attributes_json(const AttributeReport& a, uint32_t degree) {
  static const char* kChannels[3] = {"R", "G", "B"};
  json sh = json::array();
  for (uint32_t d = 0; d <= degree && d < 4; ++d) {
    json ch = json::array();
    for (uint32_t c = 0; c < 3; ++c) {
      json e = {{"channel", kChannels[c]}, {"error", stats_json(a.errors.sh_channel[d][c])}};
      if (a.sh_quantization) {
        e["scale"] = a.sh_quantization->scales[d][c];
        e["clipped"] = a.clipped[d][c];
      }
      ch.push_back(e);
    }
    sh.push_back({{"degree", d}, {"error", stats_json(a.errors.sh[d])}, {"channels", ch}});
  }
  return {{"position_scene_units", stats_json(a.errors.position)},
          {"rotation_deg", stats_json(a.errors.rotation_deg)},
          {"scale_relative", stats_json(a.errors.scale_relative)},
          {"scale_of_largest_axis", stats_json(a.errors.scale_of_largest_axis)},
          {"opacity", stats_json(a.errors.opacity)},
          {"sh", sh},
          {"pairing", {{"method", a.pairing == converter::PairingMethod::kIndex ? "index" : "content"},
                       {"position_tolerance_scene_units", a.position_tolerance},
                       {"source_gaussians_unpaired", a.source_unpaired}}}};
}

}  // namespace

const char* verdict_metric_name(VerdictMetric metric) {
  return metric == VerdictMetric::kForeground ? "foreground" : "whole_frame";
}

VerdictMetric verdict_metric(const AuditResult& result) {
  bool background = false, foreground = false;
  for (const ViewMetrics& m : result.candidates.at(0).views) {
    background = background || m.foreground_fraction < 1.0;
    foreground = foreground || m.foreground_fraction > 0.0;
  }
  return background && foreground ? VerdictMetric::kForeground : VerdictMetric::kWholeFrame;
}

Verdict verdict(const AuditResult& result, size_t candidate, double threshold_db) {
  const CandidateResult& c = result.candidates.at(candidate);
  Verdict v;
  v.threshold_db = threshold_db;
  v.metric = verdict_metric(result);
  v.whole_frame_psnr_mean_db = c.summary.psnr_mean_db;
  v.foreground_psnr_mean_db = c.summary.foreground_psnr_mean_db;
  const bool foreground = v.metric == VerdictMetric::kForeground;
  v.psnr_mean_db = foreground ? c.summary.foreground_psnr_mean_db : c.summary.psnr_mean_db;
  const uint64_t total = result.source.gaussians;
  if (total > 0 && c.scene.gaussians == 0) {
    v.content_lost = "it has no Gaussian";
  } else if (total > 0 && double(c.reference_gaussians) < kMinContentKept * double(total)) {
    v.content_lost = "its recorded edits kept " + rgs::group_digits(c.reference_gaussians) + " of the source's " +
                     rgs::group_digits(total) + " Gaussians, under " + std::to_string(int(kMinContentKept * 100)) + "%";
  }
  v.passed = v.psnr_mean_db >= threshold_db && v.content_lost.empty();
  v.worst_view = result.views.at(c.summary.worst_view).name;
  v.worst_psnr_db = verdict_view_psnr_db(c.views.at(c.summary.worst_view));
  if (c.scene.file_bytes > 0) {
    v.bytes_saved = int64_t(result.source.file_bytes) - int64_t(c.scene.file_bytes);
    v.bytes_saved_fraction = result.source.file_bytes > 0 ? double(*v.bytes_saved) / double(result.source.file_bytes)
                                                          : 0.0;
  }
  return v;
}

bool passes_gate(const AuditResult& result, double min_psnr_db) {
  for (size_t i = 0; i < result.candidates.size(); ++i) {
    const Verdict v = verdict(result, i, min_psnr_db);
    if (v.worst_psnr_db < min_psnr_db || !v.content_lost.empty()) return false;
  }
  return true;
}

std::string audit_json(const AuditResult& r, const ReportOptions& options) {
  json j;
  j["schema"] = kAuditSchemaName;
  j["schema_version"] = kAuditSchemaVersion;
  j["tool_version"] = options.tool_version;
  if (!options.command_line.empty()) j["command"] = options.command_line;
  j["backend"] = backend_name(r.backend);
  j["device"] = r.device;
  j["renderer"] = "3DGS baseline, FP32, black background";
  j["metrics"] = {{"psnr", "clamped [0,1] RGB, peak 1, MSE in float64"},
                  {"ssim", "11x11 Gaussian window, sigma 1.5, C1 0.01^2, C2 0.03^2, valid windows, mean of R,G,B"},
                  {"max_abs_diff", "max over pixels of max over RGB of |a-b|, clamped"},
                  {"foreground_psnr", "PSNR over the pixels where the source render's alpha or colour is not the "
                                      "black background"}};
  bool all_passed = true;
  for (size_t i = 0; i < r.candidates.size(); ++i) all_passed = all_passed && verdict(r, i, options.threshold_db).passed;
  const char* metric = verdict_metric_name(verdict_metric(r));
  j["verdict"] = {{"threshold_db", options.threshold_db},
                  {"metric", metric},
                  {"criterion", std::string("mean over the views of the ") + metric + " PSNR >= threshold_db"},
                  {"passed", all_passed}};
  j["heat_scale_percentile"] = kHeatScalePercentile;
  j["source"] = scene_json(r.source, 0, r.source.gaussians);
  json views = json::array();
  for (const ViewInfo& v : r.views) views.push_back({{"name", v.name}, {"width", v.width}, {"height", v.height}});
  j["views"] = views;
  json cands = json::array();
  for (size_t i = 0; i < r.candidates.size(); ++i) {
    const CandidateResult& c = r.candidates[i];
    json cj = scene_json(c.scene, r.source.file_bytes, r.source.gaussians);
    if (c.attributes) {
      cj["errors"] = attributes_json(*c.attributes, c.scene.sh_degree);
    } else {
      cj["errors"] = nullptr;
      cj["errors_note"] = c.attributes_note;
    }
    json vj = json::array();
    for (size_t v = 0; v < c.views.size(); ++v) {
      const ViewMetrics& m = c.views[v];
      vj.push_back({{"name", r.views[v].name}, {"psnr_db", db_json(m.psnr_db)}, {"ssim", m.ssim},
                    {"max_abs_diff", m.max_abs_diff}, {"foreground_psnr_db", db_json(m.foreground_psnr_db)},
                    {"foreground_fraction", m.foreground_fraction}, {"seconds", m.seconds},
                    {"render_seconds", m.render_seconds}});
    }
    cj["views"] = vj;
    cj["psnr_db"] = {{"mean", db_json(c.summary.psnr_mean_db)}, {"min", db_json(c.summary.psnr_min_db)}};
    cj["ssim"] = {{"mean", c.summary.ssim_mean}, {"min", c.summary.ssim_min}};
    cj["foreground_psnr_db"] = {{"mean", db_json(c.summary.foreground_psnr_mean_db)},
                                {"min", db_json(c.summary.foreground_psnr_min_db)}};
    cj["render_seconds"] = c.summary.render_seconds;
    cj["reference"] = {{"description", c.reference.empty() ? json("the whole source") : json(c.reference)},
                       {"gaussians", c.reference_gaussians}};
    if (!r.views.empty()) cj["verdict"] = verdict_json(verdict(r, i, options.threshold_db));
    cj["max_abs_diff"] = c.summary.max_abs_diff;
    cj["heat_scale"] = c.heat_scale;
    cj["worst_view"] = r.views.empty() ? std::string() : r.views[c.summary.worst_view].name;
    json worst = json::array();
    for (const ViewImages& w : c.worst) {
      json wj = {{"view", w.view}, {"name", r.views[w.view].name}, {"psnr_db", db_json(w.psnr_db)},
                 {"heat_scale", w.heat_scale}, {"image_width", w.source.width}, {"image_height", w.source.height}};
      if (!options.image_dir.empty()) {
        wj["source_image"] = options.image_dir + image_name(i, w.view, "source", ".ppm");
        wj["candidate_image"] = options.image_dir + image_name(i, w.view, "candidate", ".ppm");
        wj["diff_image"] = options.image_dir + image_name(i, w.view, "diff", ".pgm");
      }
      worst.push_back(wj);
    }
    cj["worst_views"] = worst;
    cands.push_back(cj);
  }
  j["candidates"] = cands;
  j["time_seconds"] = {{"total", options.total_seconds}, {"views", r.render_seconds}};
  if (options.min_psnr_db) {
    j["gate"] = {{"min_psnr_db", *options.min_psnr_db},
                 {"metric", metric},
                 {"criterion", std::string("every view's ") + metric + " PSNR >= min_psnr_db"},
                 {"passed", passes_gate(r, *options.min_psnr_db)}};
  }
  return j.dump(2) + "\n";
}

Result<Image8> read_netpbm(const std::string& path) {
  RGS_ASSIGN_OR_RETURN(const auto file, format::MappedFile::open(path));
  const uint8_t* data = file->data();
  const size_t size = file->size();
  size_t pos = 2;
  RGS_RETURN_ERROR_IF(size < 2 || data[0] != 'P' || (data[1] != '5' && data[1] != '6'), StatusCode::kCorruptData,
                      path + ": not a binary PPM (P6) or PGM (P5)");
  uint64_t fields[3] = {};
  for (uint64_t& field : fields) {
    while (pos < size && (std::isspace(data[pos]) || data[pos] == '#')) {
      if (data[pos] == '#') {
        while (pos < size && data[pos] != '\n') ++pos;
      } else {
        ++pos;
      }
    }
    const size_t start = pos;
    while (pos < size && pos - start < 9 && std::isdigit(data[pos])) field = field * 10 + (data[pos++] - '0');
    RGS_RETURN_ERROR_IF(pos == start, StatusCode::kCorruptData, path + ": damaged netpbm header");
  }
  Image8 image;
  image.channels = data[1] == '6' ? 3 : 1;
  const uint64_t bytes = fields[0] * fields[1] * image.channels;
  RGS_RETURN_ERROR_IF(fields[2] != 255 || fields[0] == 0 || fields[1] == 0, StatusCode::kCorruptData,
                      path + ": a " + std::to_string(fields[0]) + "x" + std::to_string(fields[1]) +
                          " image of maxval " + std::to_string(fields[2]) + " (expected 255)");
  RGS_RETURN_ERROR_IF(pos >= size || !std::isspace(data[pos]) || size - pos - 1 < bytes, StatusCode::kCorruptData,
                      path + ": " + std::to_string(bytes) + " pixel bytes expected, the file has " +
                          std::to_string(pos < size ? size - pos - 1 : 0));
  image.width = uint32_t(fields[0]);
  image.height = uint32_t(fields[1]);
  image.pixels.assign(data + pos + 1, data + pos + 1 + bytes);
  return image;
}

Status write_netpbm(const std::string& path, const Image8& image, format::FileSink& files) {
  RGS_RETURN_ERROR_IF(image.channels != 1 && image.channels != 3, StatusCode::kInvalidArgument,
                      path + ": netpbm images have 1 or 3 channels, not " + std::to_string(image.channels));
  RGS_RETURN_ERROR_IF(image.pixels.size() != size_t(image.width) * image.height * image.channels ||
                          image.width == 0 || image.height == 0,
                      StatusCode::kInvalidArgument, path + ": pixel count does not match the image size");
  const std::string header = std::string(image.channels == 3 ? "P6" : "P5") + "\n" + std::to_string(image.width) +
                             " " + std::to_string(image.height) + "\n255\n";
  std::vector<uint8_t> bytes(header.begin(), header.end());
  bytes.insert(bytes.end(), image.pixels.begin(), image.pixels.end());
  return files.write(path, bytes.data(), bytes.size());
}

std::vector<std::pair<std::string, const Image8*>> report_images(const AuditResult& r, const std::string& dir) {
  const std::string base = (std::filesystem::path(dir) / "").string();
  std::vector<std::pair<std::string, const Image8*>> images;
  for (size_t i = 0; i < r.candidates.size(); ++i) {
    for (const ViewImages& w : r.candidates[i].worst) {
      images.emplace_back(base + image_name(i, w.view, "source", ".ppm"), &w.source);
      images.emplace_back(base + image_name(i, w.view, "candidate", ".ppm"), &w.candidate);
      images.emplace_back(base + image_name(i, w.view, "diff", ".pgm"), &w.difference);
    }
  }
  return images;
}

Status write_report_images(const AuditResult& r, const std::string& dir, format::FileSink& files) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  RGS_RETURN_ERROR_IF(ec, StatusCode::kIoError, dir + ": cannot create the image folder: " + ec.message());
  for (const auto& [path, image] : report_images(r, dir)) RGS_RETURN_IF_ERROR(write_netpbm(path, *image, files));
  return Status();
}

}  // namespace rgs::audit
