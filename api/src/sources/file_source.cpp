// The source of a conversion from a file: the scene read whole, or a binary PLY too large for memory opened to be
// read in batches (docs/LOD.md#scenes-larger-than-memory).
#include "../internal_convert_memory.h"
#include "../internal_pipeline.h"
#include "rgs/converter/scene_reader.h"

namespace rgs::api::detail {

namespace {

/// The PLY at `src` opened as a stream when the conversion builds it out of core: a level-of-detail .rgs output
/// (runtime profile, no target) of a binary PLY whose estimated peak read whole is above the memory limit. Null
/// otherwise (an ascii PLY included).
Result<std::unique_ptr<converter::PlyStream>> open_batches(const std::string& src, OutputFormat output,
                                                           const ConvertOptions& options) {
  std::unique_ptr<converter::PlyStream> none;
  if (output != OutputFormat::kRgs || !options.lod_levels || options.target.active() ||
      options.profile != format::StorageProfile::kRuntime) {
    return none;
  }
  const uint64_t limit = convert_memory_limit(options);
  if (limit == 0) return none;
  RGS_ASSIGN_OR_RETURN(const uint64_t estimate, estimate_convert_memory(src));
  if (estimate <= limit) return none;
  RGS_ASSIGN_OR_RETURN(const std::string format_id, converter::detect_scene_format(src));
  if (format_id != "ply") return none;
  const converter::SceneReadOptions read = scene_read_options(options);
  converter::PlyReadOptions ply;
  ply.invalid_policy = read.invalid_policy;
  ply.max_gaussians = read.max_gaussians;
  ply.hash_file = true;
  auto stream = converter::PlyStream::open(src, ply);
  if (!stream.ok() && stream.status().code() == StatusCode::kUnsupportedFeature) return none;  // an ascii PLY
  return stream;
}

}  // namespace

Result<SceneSource> open_file_source(const std::string& src, OutputFormat output, const ConvertOptions& options) {
  SceneSource source;
  source.name = src;
  RGS_ASSIGN_OR_RETURN(source.stream, open_batches(src, output, options));
  if (source.stream) return source;
  RGS_RETURN_IF_ERROR(check_convert_memory(src, options));
  RGS_ASSIGN_OR_RETURN(source.scene, converter::read_scene(src, scene_read_options(options)));
  return source;
}

}  // namespace rgs::api::detail
