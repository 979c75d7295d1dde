// rgs-info: prints a .rgs file's header, sections, conventions, bounds, SH scales and provenance, and for any
// other scene the converter reads (PLY, compressed PLY, SOG, SPZ, glTF/GLB, .ksplat, .splat) its format, Gaussian count,
// SH degree, bounds, size and reading notes. With --check it validates everything (a .rgs file's checksums,
// codecs and values; another scene is read and decoded in full) and exits 1 on the first problem. "-" reads a
// .rgs or PLY file from standard input. Strings from the file (provenance, names) are printed escaped.

#include <CLI/CLI.hpp>

#include <algorithm>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_common.h"
#include "rgs/config.h"
#include "rgs/converter/scene_reader.h"
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

/// A streamed SOG's leaf error tables (InputScene::lod_errors): per level, the largest over the leaves.
std::vector<double> level_max_errors(const std::vector<std::vector<double>>& tables) {
  std::vector<double> max(tables.empty() ? 0 : tables[0].size(), 0.0);
  for (const std::vector<double>& t : tables) {
    for (size_t l = 0; l < t.size() && l < max.size(); ++l) max[l] = std::max(max[l], t[l]);
  }
  return max;
}

nlohmann::json bounds_json(const format::SceneBounds& b) {
  return {{"aabb_min", b.aabb_min}, {"aabb_max", b.aabb_max}, {"sphere_center", b.sphere_center},
          {"sphere_radius", b.sphere_radius}};
}

/// The bounds' lines of the text output.
void print_bounds(const format::SceneBounds& b) {
  std::printf("  aabb             [%g, %g, %g] .. [%g, %g, %g]\n", b.aabb_min[0], b.aabb_min[1], b.aabb_min[2],
              b.aabb_max[0], b.aabb_max[1], b.aabb_max[2]);
  std::printf("  bounding sphere  centre (%g, %g, %g), radius %g\n", b.sphere_center[0], b.sphere_center[1],
              b.sphere_center[2], b.sphere_radius);
}

nlohmann::json to_json(const format::RgsFile& file) {
  const auto& h = file.header();
  const auto& m = file.metadata();
  nlohmann::json j;
  j["file"] = file.name();
  j["bytes"] = file.file_size();
  j["version"] = {h.major, h.minor};
  j["required_flags"] = h.required_flags;
  j["optional_flags"] = h.optional_flags;
  j["gaussians"] = h.gaussian_count;
  j["sh_degree"] = m.sh_degree;
  j["antialiased"] = m.antialiased;
  j["conventions"] = {{"frame", format::to_string(m.frame)},
                      {"quaternion_order", format::to_string(m.quaternion_order)},
                      {"scale_encoding", format::to_string(m.scale_encoding)},
                      {"opacity_encoding", format::to_string(m.opacity_encoding)},
                      {"sh_layout", format::to_string(m.sh_layout)}};
  j["bounds"] = bounds_json(m.bounds);
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
  const uint64_t n = h.gaussian_count;
  std::printf("%s\n", tools::escape_text(file.name()).c_str());
  std::printf("  format           .rgs %u.%u, flags required 0x%08x optional 0x%08x\n", h.major, h.minor,
              h.required_flags, h.optional_flags);
  std::printf("  size             %s bytes (%s B/Gaussian)\n", rgs::group_digits(file.file_size()).c_str(),
              tools::fixed(n ? static_cast<double>(file.file_size()) / static_cast<double>(n) : 0.0, 2).c_str());
  std::printf("  gaussians        %s, SH degree %u\n", rgs::group_digits(n).c_str(), m.sh_degree);
  std::printf("  conventions      frame %s, quaternion %s, scale %s, opacity %s, SH %s\n",
              format::to_string(m.frame), format::to_string(m.quaternion_order),
              format::to_string(m.scale_encoding), format::to_string(m.opacity_encoding),
              format::to_string(m.sh_layout));
  if (m.antialiased) {
    std::printf("  anti-aliased     yes: trained with the 2D Mip filter, opacities compensated when rendered\n");
  }
  print_bounds(m.bounds);
  std::printf("  SH quantization  INT%u, clip percentile %g; scale s[d] (R, G, B):\n", m.sh_quantization.bits,
              m.sh_quantization.clip_percentile);
  for (uint32_t d = 0; d <= m.sh_degree; ++d) {
    const auto& s = m.sh_quantization.scales[d];
    std::printf("    degree %u       %s %s %s\n", d, tools::sci(s[0]).c_str(), tools::sci(s[1]).c_str(),
                tools::sci(s[2]).c_str());
  }
  if (const format::LodIndex* lod = file.lod()) {
    std::printf("  levels of detail %u chunks x %u levels (format/SPEC.md 4.9); full detail %s Gaussians\n",
                lod->chunk_count, lod->level_count, rgs::group_digits(lod->full_detail_count()).c_str());
    for (uint32_t l = 0; l < lod->level_count; ++l) {
      const LevelTotals t = level_totals(*lod, l);
      std::printf("    level %-2u       %s Gaussians, error <= %s scene units\n", l,
                  rgs::group_digits(t.gaussians).c_str(), tools::sci(t.max_error).c_str());
    }
  }
  std::printf("  sections\n    %-4s %-14s %-5s %-5s %5s %12s %12s %14s %14s %7s\n", "id", "name", "codec", "type",
              "comps", "elements", "offset", "stored", "raw", "B/Gauss");
  for (const auto& s : file.sections()) {
    std::printf("    %-4u %-14s %-5s %-5s %5u %12s %12s %14s %14s %7s\n", static_cast<uint32_t>(s.id),
                format::section_name(s.id), format::codec_name(s.codec), format::element_type_name(s.element_type),
                s.components, rgs::group_digits(s.element_count).c_str(), rgs::group_digits(s.offset).c_str(),
                rgs::group_digits(s.stored_size).c_str(), rgs::group_digits(s.raw_size).c_str(),
                tools::fixed(n ? static_cast<double>(s.stored_size) / static_cast<double>(n) : 0.0, 2).c_str());
  }
  if (!file.provenance().empty()) {
    std::printf("  provenance\n");
    for (const auto& [key, value] : file.provenance()) {
      std::printf("    %-16s %s\n", tools::escape_text(key).c_str(), tools::escape_text(value).c_str());
    }
  }
}

nlohmann::json to_json(const std::string& path, const converter::InputScene& scene) {
  nlohmann::json j;
  j["file"] = path;
  j["format"] = scene.format_id;
  j["description"] = scene.description;
  j["storage_format"] = scene.storage_format;
  j["bytes"] = scene.file_bytes;
  j["files"] = scene.files;
  j["gaussians"] = scene.cloud.size();
  j["declared_gaussians"] = scene.declared_vertices;
  j["sh_degree"] = scene.cloud.sh_degree;
  j["bounds"] = bounds_json(scene.bounds);
  j["notes"] = scene.notes;
  if (!scene.lod_errors.empty()) {
    j["lod"] = {{"leaves", scene.lod_errors.size()}, {"max_errors", level_max_errors(scene.lod_errors)}};
  }
  return j;
}

void print_text(const std::string& path, const converter::InputScene& scene) {
  const uint64_t n = scene.cloud.size();
  std::printf("%s\n", tools::escape_text(path).c_str());
  std::printf("  format           %s (%s)\n", tools::escape_text(scene.description).c_str(), scene.format_id.c_str());
  std::printf("  size             %s bytes in %s file%s (%s B/Gaussian)\n", rgs::group_digits(scene.file_bytes).c_str(),
              rgs::group_digits(scene.file_count).c_str(), scene.file_count == 1 ? "" : "s",
              tools::fixed(n ? static_cast<double>(scene.file_bytes) / static_cast<double>(n) : 0.0, 2).c_str());
  std::printf("  gaussians        %s, SH degree %u", rgs::group_digits(n).c_str(), scene.cloud.sh_degree);
  if (scene.declared_vertices != n) {
    std::printf(" (the file declares %s)", rgs::group_digits(scene.declared_vertices).c_str());
  }
  std::printf("\n");
  print_bounds(scene.bounds);
  for (const std::string& note : scene.notes) std::printf("  note             %s\n", tools::escape_text(note).c_str());
  if (scene.lod_errors.empty()) return;
  std::printf("  levels of detail %s leaves with error tables (PlayCanvas's relative unit, docs/LOD.md)\n",
              rgs::group_digits(scene.lod_errors.size()).c_str());
  const std::vector<double> max = level_max_errors(scene.lod_errors);
  for (size_t l = 0; l < max.size(); ++l) std::printf("    level %-2zu       error <= %s\n", l, tools::sci(max[l]).c_str());
}

/// Any scene the converter reads, through its reading door: a file or folder, or `data` (standard input).
int describe_scene(const std::string& path, const uint8_t* data, size_t size, bool check, bool json) {
  auto scene = data ? converter::read_scene_bytes(data, size, path, tools::scene_read_options())
                    : converter::read_scene(path, tools::scene_read_options());
  if (!scene.ok()) return tools::report_error(kTool, scene.status());
  if (json) {
    nlohmann::json j = to_json(path, *scene);
    if (check) j["check"] = "ok";
    std::printf("%s\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  } else {
    print_text(path, *scene);
    if (check) std::printf("  check            ok (read and decoded in full, every value checked)\n");
  }
  return tools::kExitOk;
}

int run(const std::string& path, bool check, bool json) {
  std::error_code ec;
  if (path != "-" && std::filesystem::is_directory(path, ec)) return describe_scene(path, nullptr, 0, check, json);
  // The file's bytes: mapped, or standard input's content for "-".
  std::shared_ptr<const format::MappedFile> mapping;
  std::vector<uint8_t> stdin_bytes;
  if (path == "-") {
    auto bytes = tools::read_standard_input();
    if (!bytes.ok()) return tools::report_error(kTool, bytes.status());
    stdin_bytes = std::move(bytes).value();
  } else {
    if (Status readable = tools::check_input_file(path); !readable.ok()) return tools::report_error(kTool, readable);
    auto mapped = format::MappedFile::open(path);
    if (!mapped.ok()) return tools::report_error(kTool, mapped.status());
    mapping = std::move(mapped).value();
  }
  const uint8_t* data = mapping ? mapping->data() : stdin_bytes.data();
  const size_t size = mapping ? mapping->size() : stdin_bytes.size();
  auto file = format::RgsFile::from_bytes(data, size, tools::read_options(), path);
  if (!file.ok()) {
    if (file.status().code() == StatusCode::kNotRgsFile) {
      return describe_scene(path, path == "-" ? data : nullptr, size, check, json);
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
  CLI::App app{"Print a .rgs file's header, sections, conventions and provenance, or any other scene's format, "
               "Gaussian count, SH degree, bounds and size (PLY, compressed PLY, SOG, SPZ, glTF/GLB, .ksplat, .splat); "
               "--check validates every checksum, codec frame and value.",
               kTool};
  app.add_option("file", path,
                 "Scene file or folder (.rgs, PLY, compressed PLY, SOG meta.json/.sog/folder, lod-meta.json, SPZ, "
                 "glTF/GLB, .ksplat, .splat); - reads a .rgs or PLY file from standard input")
      ->required();
  app.add_flag("--check", check,
               "Validate fully (a .rgs file's checksums, codecs and values; another scene read and decoded in "
               "full); exit 1 and name the first problem if the file is invalid");
  app.add_flag("--json", json, "Print JSON instead of text");
  rgs::tools::add_scene_read_options(app);
  if (auto code = tools::parse_command_line(app, argc, argv, kTool)) return *code;
  return tools::finish(kTool, run(path, check, json));
}
