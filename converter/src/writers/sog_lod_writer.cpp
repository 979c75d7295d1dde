// PlayCanvas streamed SOG writer: lod-meta.json over chunk folders of SOG v2, from the project's own levels of
// detail (converter::build_lod; docs/LOD.md "Streamed SOG out").
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rgs/converter/sog_writer.h"
#include "rgs/format/encoded_scene.h"

namespace rgs::converter {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

/// One file of one level: chunks [first_chunk, end_chunk).
struct LodFile {
  uint32_t level = 0;
  uint32_t first_chunk = 0, end_chunk = 0;
  std::string name;  ///< "L_K/meta.json"
};

std::vector<LodFile> plan_files(const format::LodIndex& index) {
  std::vector<LodFile> files;
  for (uint32_t l = 0; l < index.level_count; ++l) {
    uint32_t k = 0;
    for (uint32_t c = 0; c < index.chunk_count;) {
      LodFile f{l, c, c, std::to_string(l) + "_" + std::to_string(k++) + "/meta.json"};
      uint64_t n = 0;
      while (f.end_chunk < index.chunk_count &&
             (f.end_chunk == c || n + index.at(l, f.end_chunk).count <= kSogLodFileGaussians)) {
        n += index.at(l, f.end_chunk++).count;
      }
      c = f.end_chunk;
      files.push_back(f);
    }
  }
  return files;
}

/// The tree over chunk leaves: consecutive nodes paired level by level up to one root.
json build_tree(std::vector<json> nodes) {
  if (nodes.empty()) return json::object();
  while (nodes.size() > 1) {
    std::vector<json> up;
    for (size_t i = 0; i < nodes.size(); i += 2) {
      if (i + 1 == nodes.size()) {
        up.push_back(std::move(nodes[i]));
        continue;
      }
      json bound = nodes[i]["bound"];
      for (int a = 0; a < 3; ++a) {
        bound["min"][a] = std::min(bound["min"][a].get<double>(), nodes[i + 1]["bound"]["min"][a].get<double>());
        bound["max"][a] = std::max(bound["max"][a].get<double>(), nodes[i + 1]["bound"]["max"][a].get<double>());
      }
      up.push_back({{"bound", bound}, {"children", {std::move(nodes[i]), std::move(nodes[i + 1])}}});
    }
    nodes = std::move(up);
  }
  return std::move(nodes[0]);
}

Status check_lod(const Levels& levels) {
  const format::LodIndex& index = levels.index();
  const uint64_t count = levels.head().count;
  RGS_RETURN_ERROR_IF(index.chunk_count == 0 || index.level_count == 0 || index.chunks.size() != index.chunk_count ||
                          index.levels.size() != uint64_t{index.chunk_count} * index.level_count,
                      StatusCode::kCorruptData,
                      "streamed SOG: the level-of-detail index has " + std::to_string(index.levels.size()) +
                          " records for " + std::to_string(index.chunk_count) + " chunks x " +
                          std::to_string(index.level_count) + " levels");
  for (const format::LodLevel& r : index.levels) {
    RGS_RETURN_ERROR_IF(r.first + r.count > count || r.count == 0, StatusCode::kCorruptData,
                        "streamed SOG: a level-of-detail range [" + std::to_string(r.first) + ", +" +
                            std::to_string(r.count) + ") is empty or outside the scene's " + std::to_string(count) +
                            " Gaussians");
  }
  return Status();
}

/// The Gaussians [first, first + count) of `levels` dequantized into `*cloud`.
Status read_cloud(const Levels& levels, uint64_t first, uint64_t count, format::GaussianCloud* cloud) {
  format::EncodedScene range;
  RGS_RETURN_IF_ERROR(levels.read(first, count, &range));
  return format::dequantize_range(range, 0, count, cloud);
}

/// The leaves: per chunk the AABB of its level-0 means and where each level lies in the files.
Result<std::vector<json>> chunk_leaves(const Levels& levels, const std::vector<LodFile>& files) {
  const format::LodIndex& index = levels.index();
  std::vector<json> leaves(index.chunk_count);
  format::GaussianCloud level0;
  for (uint32_t c = 0; c < index.chunk_count; ++c) {
    RGS_RETURN_IF_ERROR(read_cloud(levels, index.at(0, c).first, index.at(0, c).count, &level0));
    float box_lo[3], box_hi[3];
    format::box_of_means(level0.means.data(), level0.size(), box_lo, box_hi);
    const double lo[3] = {box_lo[0], box_lo[1], box_lo[2]}, hi[3] = {box_hi[0], box_hi[1], box_hi[2]};
    // PlayCanvas's error unit (docs/LOD.md "The error tables"): the level's error over the leaf's half
    // diagonal, squared, so that the engine's screen coverage times it is the squared error in pixels.
    const double half = 0.5 * std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                        (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const double r = half > 0 ? half : index.chunks[c].radius;
    json errors = json::array();
    for (uint32_t l = 0; l < index.level_count; ++l) {
      const double e = index.at(l, c).error;
      errors.push_back(e > 0 ? (e / r) * (e / r) : 0.0);
      RGS_RETURN_ERROR_IF(!std::isfinite(errors.back().get<double>()) || !(e >= 0), StatusCode::kCorruptData,
                          "streamed SOG: chunk " + std::to_string(c) + " level " + std::to_string(l) + " has error " +
                              std::to_string(e) + " over a chunk of radius " + std::to_string(r));
    }
    leaves[c] = {{"bound", {{"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}}},
                 {"lods", json::object()},
                 {"errors", std::move(errors)}};
  }
  for (size_t f = 0; f < files.size(); ++f) {
    uint64_t offset = 0;
    for (uint32_t c = files[f].first_chunk; c < files[f].end_chunk; ++c) {
      const uint64_t count = index.at(files[f].level, c).count;
      leaves[c]["lods"][std::to_string(files[f].level)] = {{"file", f}, {"offset", offset}, {"count", count}};
      offset += count;
    }
  }
  return leaves;
}

/// The chunks of `file` (their ranges of its level, consecutive in the level-major order) as one cloud.
Result<format::GaussianCloud> file_cloud(const Levels& levels, const LodFile& file) {
  const format::LodIndex& index = levels.index();
  const format::LodLevel& first = index.at(file.level, file.first_chunk);
  const format::LodLevel& last = index.at(file.level, file.end_chunk - 1);
  format::GaussianCloud cloud;
  RGS_RETURN_IF_ERROR(read_cloud(levels, first.first, last.first + last.count - first.first, &cloud));
  return cloud;
}

}  // namespace

Result<SogWriteSummary> write_sog_lod(const std::string& lod_meta_path, const Levels& levels,
                                      const SogWriteOptions& options, format::FileSink& sink) {
  RGS_RETURN_IF_ERROR(check_lod(levels));
  const format::LodIndex& index = levels.index();
  const fs::path root = fs::path(lod_meta_path).parent_path();
  const std::vector<LodFile> files = plan_files(index);
  RGS_ASSIGN_OR_RETURN(std::vector<json> leaves, chunk_leaves(levels, files));
  // Every file is declared before the first is written: a sink that is a transaction refuses the set when one
  // of them is an input (an older streamed SOG in the same folder, say).
  std::vector<std::string> paths;
  for (const LodFile& file : files) {
    for (std::string& image : sog_folder_files((root / file.name).string())) paths.push_back(std::move(image));
  }
  paths.push_back(lod_meta_path);
  RGS_RETURN_IF_ERROR(sink.declare(paths));
  SogWriteSummary summary;
  json names = json::array();
  SogWriteOptions folder = options;
  folder.container = SogContainer::kFolder;
  for (const LodFile& file : files) {
    names.push_back(file.name);
    const fs::path meta = root / file.name;
    RGS_RETURN_IF_ERROR(sink.create_folder(meta.parent_path().string()));
    RGS_ASSIGN_OR_RETURN(format::GaussianCloud cloud, file_cloud(levels, file));
    auto written = write_sog(meta.string(), cloud, folder, sink);
    if (!written.ok()) return written.status();
    summary.bytes += written->bytes;
    summary.sh_degree = written->sh_degree;
    summary.limitations = written->limitations;
  }
  json meta = {{"lodLevels", index.level_count},
               {"lodErrors", true},
               {"environment", nullptr},
               {"filenames", names},
               {"tree", build_tree(std::move(leaves))}};
  const std::string text = meta.dump();
  RGS_RETURN_IF_ERROR(sink.write(lod_meta_path, text.data(), text.size()));
  summary.bytes += text.size();
  summary.files = {lod_meta_path};
  summary.limitations.push_back(std::to_string(index.level_count) + " levels of detail over " +
                                std::to_string(index.chunk_count) + " chunks in " +
                                std::to_string(files.size()) + " SOG files, from the runtime profile's values");
  return summary;
}

}  // namespace rgs::converter
