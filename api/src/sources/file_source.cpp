// The source of a conversion from files: their scenes read whole and merged, or binary PLYs too large for memory
// opened to be read in batches, one file after the other (docs/LOD.md#scenes-larger-than-memory).
#include <algorithm>
#include <filesystem>

#include "../internal_pipeline.h"
#include "rgs/converter/scene_reader.h"

namespace rgs::api::detail {

namespace {

/// The PLYs at `srcs` opened as one stream when the conversion builds them out of core: levels of detail written
/// (writes_levels; runtime profile, no target) of binary PLYs whose estimated peak read whole, `estimate` or for several
/// files that of their merged scene (estimate_merged_memory), is above the memory limit. Null otherwise (an ascii
/// PLY or another format among them included). kLimitExceeded when the files hold more Gaussians together than
/// max_gaussians.
Result<std::unique_ptr<converter::PlyStream>> open_batches(const std::vector<std::string>& srcs,
                                                           const std::string& name, uint64_t estimate,
                                                           const std::string& dst, OutputFormat output,
                                                           const ConvertOptions& options) {
  std::unique_ptr<converter::PlyStream> none;
  if (!writes_levels(dst, output, options) || options.target.active() ||
      options.profile != format::StorageProfile::kRuntime) {
    return none;
  }
  const uint64_t limit = convert_memory_limit(options);
  if (limit == 0 || (estimate <= limit && srcs.size() == 1)) return none;
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
  RGS_RETURN_IF_ERROR(stream.status());
  const uint64_t count = (*stream)->vertex_count();
  if (std::max(estimate, estimate_merged_memory(count, (*stream)->sh_degree())) <= limit) return none;
  RGS_RETURN_ERROR_IF(count > read.max_gaussians, StatusCode::kLimitExceeded,
                      name + ": the inputs hold " + group_digits(count) + " Gaussians together, above " +
                          "the limit of " + group_digits(read.max_gaussians) + " (max_gaussians, --max-gaussians)");
  return stream;
}

/// Reads the scenes at `srcs` (named `name` together) whole, the Gaussians of the inputs before each one counted
/// against options.read.max_gaussians (the merged scene's limit); with several, the merged scene's estimated memory
/// checked, each input edited (ConvertOptions::input_edits, widened to the merge's SH degree first, as a batch is)
/// and described in `*inputs`. For a PLY `output`, PLY inputs keep their opacity logits and log scales as read.
Result<std::vector<converter::InputScene>> read_inputs(const std::vector<std::string>& srcs, const std::string& name,
                                                      OutputFormat output, const ConvertOptions& options,
                                                      std::vector<MergeInput>* inputs) {
  converter::SceneReadOptions read = scene_read_options(options);
  read.keep_pre_activation = output == OutputFormat::kPly;  // an unedited PLY's logits and log scales bit for bit
  const uint64_t most = read.max_gaussians;
  uint64_t held = 0;
  uint32_t degree = 0;
  std::vector<converter::InputScene> scenes;
  for (const std::string& src : srcs) {
    read.max_gaussians = most - held;
    auto scene = converter::read_scene(src, read);
    if (!scene.ok() && scene.status().code() == StatusCode::kLimitExceeded && held > 0) {
      return Status(scene.status()).prepend(name + ": the merged scene may hold " + group_digits(most) +
                                            " Gaussians (max_gaussians, --max-gaussians) and the inputs before " +
                                            src + " hold " + group_digits(held));
    }
    RGS_RETURN_IF_ERROR(scene.status());
    held += std::max<uint64_t>(scene->declared_vertices, scene->cloud.size());
    degree = std::max(degree, scene->cloud.sh_degree);
    scenes.push_back(std::move(scene).value());
  }
  if (srcs.size() == 1) return scenes;
  RGS_RETURN_IF_ERROR(check_convert_memory(name, estimate_merged_memory(held, degree), options,
                                           "the merged scene (" + group_digits(held) + " Gaussians at SH degree " +
                                               std::to_string(degree) + ", every input widened to it)"));
  for (size_t i = 0; i < srcs.size(); ++i) {
    format::GaussianCloud& cloud = scenes[i].cloud;
    const std::vector<converter::EditAction>& edits = options.input_edits[i];
    std::vector<uint64_t> removed(edits.size(), 0);
    const uint64_t read_count = cloud.size();
    if (!edits.empty()) RGS_RETURN_IF_ERROR(converter::raise_sh_degree(&cloud, degree));
    if (Status s = apply_edits(edits, &cloud, &removed); !s.ok()) return s.prepend(srcs[i]);
    describe_merge_input(edits, read_count, removed, &(*inputs)[i]);
  }
  return scenes;
}

}  // namespace

Result<SceneSource> open_file_source(const std::vector<std::string>& srcs, const std::string& dst, OutputFormat output,
                                     const ConvertOptions& options) {
  SceneSource source;
  for (const std::string& src : srcs) {
    if (srcs.size() > 1) source.merge_inputs.emplace_back().path = src;
    source.name += (source.name.empty() ? "" : " + ") + src;
    source.source_file += (source.source_file.empty() ? "" : " + ") + std::filesystem::path(src).filename().string();
  }
  uint64_t estimate = 0;  // of reading every input whole, when there is a limit
  if (convert_memory_limit(options) != 0) {
    RGS_ASSIGN_OR_RETURN(estimate, estimate_convert_memory(srcs));
  }
  RGS_ASSIGN_OR_RETURN(source.stream, open_batches(srcs, source.name, estimate, dst, output, options));
  if (source.stream) {
    RGS_RETURN_ERROR_IF(options.read.lod.has_value(), StatusCode::kInvalidArgument,
                        source.name + ": a level of detail applies only to streamed SOG (lod-meta.json); this input "
                                      "is a PLY file");
    for (const auto& edits : options.input_edits) {
      for (const converter::EditAction& edit : edits) {
        if (edit.kind == converter::EditKind::kDecimate) return needs_whole_scene(source.name, "decimate");
      }
    }
    return source;
  }
  RGS_RETURN_IF_ERROR(check_convert_memory(source.name, estimate, options));
  RGS_ASSIGN_OR_RETURN(std::vector<converter::InputScene> scenes,
                       read_inputs(srcs, source.name, output, options, &source.merge_inputs));
  RGS_ASSIGN_OR_RETURN(source.scene, converter::merge_scenes(std::move(scenes)));
  return source;
}

}  // namespace rgs::api::detail
