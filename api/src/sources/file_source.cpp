// The source of a conversion from files: their scenes read whole and merged, or binary PLYs too large for memory
// opened to be read in batches, one file after the other (docs/LOD.md#scenes-larger-than-memory).
#include <filesystem>

#include "../internal_convert_memory.h"
#include "../internal_pipeline.h"
#include "rgs/converter/scene_reader.h"

namespace rgs::api::detail {

namespace {

/// The PLYs at `srcs` opened as one stream when the conversion builds them out of core: a level-of-detail .rgs
/// output (runtime profile, no target) of binary PLYs whose estimated peak read whole, `estimate`, is above the
/// memory limit. Null otherwise (an ascii PLY or another format among them included).
Result<std::unique_ptr<converter::PlyStream>> open_batches(const std::vector<std::string>& srcs, uint64_t estimate,
                                                           OutputFormat output, const ConvertOptions& options) {
  std::unique_ptr<converter::PlyStream> none;
  if (output != OutputFormat::kRgs || !options.lod_levels || options.target.active() ||
      options.profile != format::StorageProfile::kRuntime) {
    return none;
  }
  const uint64_t limit = convert_memory_limit(options);
  if (limit == 0 || estimate <= limit) return none;
  for (const std::string& src : srcs) {
    RGS_ASSIGN_OR_RETURN(const std::string format_id, converter::detect_scene_format(src));
    if (format_id != "ply") return none;
  }
  const converter::SceneReadOptions read = scene_read_options(options);
  converter::PlyReadOptions ply;
  ply.invalid_policy = read.invalid_policy;
  ply.max_gaussians = read.max_gaussians;
  ply.hash_file = true;
  auto stream = converter::PlyStream::open(srcs, ply);
  if (!stream.ok() && stream.status().code() == StatusCode::kUnsupportedFeature) return none;  // an ascii PLY
  return stream;
}

}  // namespace

Result<SceneSource> open_file_source(const std::vector<std::string>& srcs, OutputFormat output,
                                     const ConvertOptions& options) {
  SceneSource source;
  uint64_t estimate = 0;  // of reading every input whole, when there is a limit
  for (const std::string& src : srcs) {
    source.name += (source.name.empty() ? "" : " + ") + src;
    source.source_file += (source.source_file.empty() ? "" : " + ") + std::filesystem::path(src).filename().string();
    if (convert_memory_limit(options) == 0) continue;
    RGS_ASSIGN_OR_RETURN(const uint64_t bytes, estimate_convert_memory(src));
    estimate += bytes;
  }
  RGS_ASSIGN_OR_RETURN(source.stream, open_batches(srcs, estimate, output, options));
  if (source.stream) return source;
  RGS_RETURN_IF_ERROR(check_convert_memory(source.name, estimate, options));
  std::vector<converter::InputScene> scenes;
  for (const std::string& src : srcs) {
    RGS_ASSIGN_OR_RETURN(converter::InputScene scene, converter::read_scene(src, scene_read_options(options)));
    scenes.push_back(std::move(scene));
  }
  RGS_ASSIGN_OR_RETURN(source.scene, converter::merge_scenes(std::move(scenes)));
  return source;
}

}  // namespace rgs::api::detail
