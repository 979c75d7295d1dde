// rgs-info: prints a .rgs file's header, sections, conventions, bounds, SH scales and provenance.
// With --check it validates everything (checksums, codecs, values) and exits 1 on the first problem.
// "-" reads the file from standard input. Strings from the file (provenance) are printed escaped.

#include <CLI/CLI.hpp>

#include <algorithm>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_common.h"
#include "rgs/config.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"

namespace {

using namespace rgs;
constexpr const char* kTool = "rgs-info";

/// One level of a level-of-detail index over all chunks: its Gaussians and its largest error (SPEC §4.9).
struct LevelTotals {
  uint64_t gaussians = 0;
  double max_error = 0;
};

LevelTotals level_totals(const format::LodIndex& lod, uint32_t level) {
  LevelTotals t;
  for (uint32_t c = 0; c < lod.chunk_count; ++c) {
    t.gaussians += lod.at(level, c).count;
    t.max_error = std::max<double>(t.max_error, lod.at(level, c).error);
  }
  return t;
}

nlohmann::json to_json(const format::RgsFile& file) {
  const auto& h = file.header();
  const auto& m = file.metadata();
  const auto& b = m.bounds;
  nlohmann::json j;
  j["file"] = file.name();
  j["bytes"] = file.file_size();
  j["version"] = {h.major, h.minor};
  j["required_flags"] = h.required_flags;
  j["optional_flags"] = h.optional_flags;
  j["gaussians"] = h.gaussian_count;
  j["sh_degree"] = m.sh_degree;
  j["conventions"] = {{"frame", format::to_string(m.frame)},
                      {"quaternion_order", format::to_string(m.quaternion_order)},
                      {"scale_encoding", format::to_string(m.scale_encoding)},
                      {"opacity_encoding", format::to_string(m.opacity_encoding)},
                      {"sh_layout", format::to_string(m.sh_layout)}};
  j["bounds"] = {{"aabb_min", b.aabb_min}, {"aabb_max", b.aabb_max},
                 {"sphere_center", b.sphere_center}, {"sphere_radius", b.sphere_radius}};
  j["sh_quantization"] = {{"bits", m.sh_quantization.bits},
                          {"clip_percentile", m.sh_quantization.clip_percentile},
                          {"scales", m.sh_quantization.scales}};
  if (const format::LodIndex* lod = file.lod()) {
    nlohmann::json levels = nlohmann::json::array();
    for (uint32_t l = 0; l < lod->level_count; ++l) {
      const LevelTotals t = level_totals(*lod, l);
      levels.push_back({{"level", l}, {"gaussians", t.gaussians}, {"max_error", t.max_error}});
    }
    j["lod"] = {{"chunks", lod->chunk_count}, {"levels", levels}, {"full_detail", lod->full_detail_count()}};
  }
  nlohmann::json sections = nlohmann::json::array();
  for (const auto& s : file.sections()) {
    sections.push_back({{"id", static_cast<uint32_t>(s.id)}, {"name", format::section_name(s.id)},
                        {"codec", format::codec_name(s.codec)},
                        {"element_type", format::element_type_name(s.element_type)},
                        {"components", s.components}, {"elements", s.element_count}, {"offset", s.offset},
                        {"stored_bytes", s.stored_size}, {"raw_bytes", s.raw_size}});
  }
  j["sections"] = sections;
  nlohmann::json provenance = nlohmann::json::object();
  for (const auto& [key, value] : file.provenance()) provenance[key] = value;
  j["provenance"] = provenance;
  return j;
}

void print_text(const format::RgsFile& file) {
  const auto& h = file.header();
  const auto& m = file.metadata();
  const auto& b = m.bounds;
  const uint64_t n = h.gaussian_count;
  std::printf("%s\n", tools::escape_text(file.name()).c_str());
  std::printf("  format           .rgs %u.%u, flags required 0x%08x optional 0x%08x\n", h.major, h.minor,
              h.required_flags, h.optional_flags);
  std::printf("  size             %s bytes (%s B/Gaussian)\n", tools::group_digits(file.file_size()).c_str(),
              tools::fixed(n ? static_cast<double>(file.file_size()) / static_cast<double>(n) : 0.0, 2).c_str());
  std::printf("  gaussians        %s, SH degree %u\n", tools::group_digits(n).c_str(), m.sh_degree);
  std::printf("  conventions      frame %s, quaternion %s, scale %s, opacity %s, SH %s\n",
              format::to_string(m.frame), format::to_string(m.quaternion_order),
              format::to_string(m.scale_encoding), format::to_string(m.opacity_encoding),
              format::to_string(m.sh_layout));
  std::printf("  aabb             [%g, %g, %g] .. [%g, %g, %g]\n", b.aabb_min[0], b.aabb_min[1], b.aabb_min[2],
              b.aabb_max[0], b.aabb_max[1], b.aabb_max[2]);
  std::printf("  bounding sphere  centre (%g, %g, %g), radius %g\n", b.sphere_center[0], b.sphere_center[1],
              b.sphere_center[2], b.sphere_radius);
  std::printf("  SH quantization  INT%u, clip percentile %g; scale s[d] (R, G, B):\n", m.sh_quantization.bits,
              m.sh_quantization.clip_percentile);
  for (uint32_t d = 0; d <= m.sh_degree; ++d) {
    const auto& s = m.sh_quantization.scales[d];
    std::printf("    degree %u       %s %s %s\n", d, tools::sci(s[0]).c_str(), tools::sci(s[1]).c_str(),
                tools::sci(s[2]).c_str());
  }
  if (const format::LodIndex* lod = file.lod()) {
    std::printf("  levels of detail %u chunks x %u levels (format/SPEC.md 4.9); full detail %s Gaussians\n",
                lod->chunk_count, lod->level_count, tools::group_digits(lod->full_detail_count()).c_str());
    for (uint32_t l = 0; l < lod->level_count; ++l) {
      const LevelTotals t = level_totals(*lod, l);
      std::printf("    level %-2u       %s Gaussians, error <= %s scene units\n", l,
                  tools::group_digits(t.gaussians).c_str(), tools::sci(t.max_error).c_str());
    }
  }
  std::printf("  sections\n    %-4s %-14s %-5s %-5s %5s %12s %12s %14s %14s %7s\n", "id", "name", "codec", "type",
              "comps", "elements", "offset", "stored", "raw", "B/Gauss");
  for (const auto& s : file.sections()) {
    std::printf("    %-4u %-14s %-5s %-5s %5u %12s %12s %14s %14s %7s\n", static_cast<uint32_t>(s.id),
                format::section_name(s.id), format::codec_name(s.codec), format::element_type_name(s.element_type),
                s.components, tools::group_digits(s.element_count).c_str(), tools::group_digits(s.offset).c_str(),
                tools::group_digits(s.stored_size).c_str(), tools::group_digits(s.raw_size).c_str(),
                tools::fixed(n ? static_cast<double>(s.stored_size) / static_cast<double>(n) : 0.0, 2).c_str());
  }
  if (!file.provenance().empty()) {
    std::printf("  provenance\n");
    for (const auto& [key, value] : file.provenance()) {
      std::printf("    %-16s %s\n", tools::escape_text(key).c_str(), tools::escape_text(value).c_str());
    }
  }
}

int run(const std::string& path, bool check, bool json) {
  // The file's bytes: mapped, or standard input's content for "-".
  std::shared_ptr<const format::MappedFile> mapping;
  std::vector<uint8_t> stdin_bytes;
  if (path == "-") {
    auto bytes = tools::read_standard_input();
    if (!bytes.ok()) return tools::report_error(kTool, bytes.status());
    stdin_bytes = std::move(bytes).value();
  } else {
    Status readable = tools::check_input_file(path);
    if (!readable.ok()) return tools::report_error(kTool, readable);
    auto mapped = format::MappedFile::open(path);
    if (!mapped.ok()) return tools::report_error(kTool, mapped.status());
    mapping = std::move(mapped).value();
  }
  const uint8_t* data = mapping ? mapping->data() : stdin_bytes.data();
  const size_t size = mapping ? mapping->size() : stdin_bytes.size();
  auto file = format::RgsFile::from_bytes(data, size, tools::read_options(), path);
  if (!file.ok()) {
    // Name the common mix-up instead of only the magic mismatch.
    if (file.status().code() == StatusCode::kNotRgsFile && size >= 4 &&
        std::equal(data, data + 4, reinterpret_cast<const uint8_t*>("ply\n"))) {
      return tools::report_error(kTool, Status(StatusCode::kNotRgsFile,
                                               path + ": this is a PLY file, not .rgs; rgs-info reads .rgs files "
                                                      "(convert it with: rgs-convert " + path + " out.rgs)"));
    }
    return tools::report_error(kTool, file.status());
  }
  Status check_status;
  if (check) check_status = format::validate(data, size, tools::read_options().limits, path);
  if (json) {
    nlohmann::json j = to_json(*file);
    if (check) j["check"] = check_status.ok() ? "ok" : check_status.to_string();
    std::printf("%s\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  } else {
    print_text(*file);
    if (check && check_status.ok()) {
      std::printf("  check            ok (header, table, every section checksum, codec and value)\n");
    }
  }
  if (!check_status.ok()) return tools::report_error(kTool, check_status);
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  bool check = false;
  bool json = false;
  CLI::App app{"Print a .rgs file's header, sections, conventions and provenance; --check validates every "
               "checksum, codec frame and value.",
               kTool};
  app.add_option("file", path, ".rgs file; - reads standard input")->required();
  app.add_flag("--check", check, "Validate fully; exit 1 and name the first problem if the file is invalid");
  app.add_flag("--json", json, "Print JSON instead of text");
  app.set_version_flag("--version", rgs::tools::version_line(kTool));
  rgs::tools::add_scene_read_options(app, /*with_spz_frame=*/false);
  if (auto code = tools::parse_command_line(app, argc, argv, kTool)) return *code;
  return tools::finish(kTool, run(path, check, json));
}
