// load() as a pipeline, private to rgs_api: the file opened and identified once (the source), the Gaussians of a
// format other than .rgs quantized as rgs-convert writes them (the stage), and the Scene made for its device (the
// host sink: the CPU reference's float Gaussians; the GPU sink: the device scene or the level-of-detail
// streamer). docs/DESIGN.md#the-scene-pipeline.
#pragma once

#include <optional>
#include <string>

#include "internal_scene.h"
#include "rgs/api/scene.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"

namespace rgs::api::detail {

/// A scene on its way into a Scene.
struct LoadScene {
  /// The path (or a cloud's name), as named in SceneInfo and messages.
  std::string name;
  /// A .rgs file, opened (header, table and metadata checked; its sections are read by the sink).
  std::optional<format::RgsFile> rgs;
  /// Any other input, read whole (converter::read_scene), or a cloud in memory.
  std::optional<converter::InputScene> input;
  /// The input quantized by quantize_for_load (LoadOptions::quantize_other_formats).
  std::optional<format::EncodedScene> encoded;
  /// SceneInfo::content, set by load_content_frame before the sink.
  ContentFrame content;
};

/// The source: `path` opened once. A .rgs (by its magic or extension, format::is_rgs_path) is opened with
/// converter::rgs_read_options(options.read_options); any other format is read (converter::read_scene).
/// Errors name `path`.
Result<LoadScene> open_load_scene(const std::string& path, const LoadOptions& options);

/// The stage: a scene of another format quantized with the converter's defaults (converter::QuantizeOptions{},
/// what `rgs-convert in.ply out.rgs` writes), so that it renders as its .rgs would; nothing for a .rgs or when
/// options.quantize_other_formats is false.
Status quantize_for_load(LoadScene* scene, const LoadOptions& options);

/// content_frame of the scene's Gaussians, on the CPU and the GPU alike: of the cloud read (before quantize_for_load,
/// which keeps the means and whose FP16 opacities content_frame weighs alike), or of a .rgs file's full detail, its
/// means and opacities alone decoded. Errors: those of RgsFile::decode_section (the sink checks the values),
/// kOutOfMemory.
Result<ContentFrame> load_content_frame(const LoadScene& scene);

/// The host sink: the scene for the CPU reference renderer, the float Gaussians it renders (a .rgs dequantized,
/// every level of a level-of-detail file when its levels are used).
Result<Scene> make_host_scene(LoadScene scene, const LoadOptions& options);

/// The GPU sink (CUDA builds; kUnsupportedFeature otherwise): the scene in device memory (a .rgs's sections
/// uploaded as stored, a quantized scene from its arrays, a float one as FP32), or a level-of-detail streamer.
Result<Scene> make_gpu_scene(LoadScene scene, const LoadOptions& options);

// What both sinks report alike.

/// Bytes of the runtime sections of `n` Gaussians of SH degree `degree` (SPEC §4.3-4.7), no DC residual.
uint64_t runtime_bytes(uint64_t n, uint32_t degree);

/// Host bytes of a float cloud's arrays.
uint64_t cloud_bytes(const format::GaussianCloud& cloud);

/// Bytes of one Gaussian in the runtime sections of `file`, the DC residual included.
uint64_t stored_gaussian_bytes(const format::RgsFile& file);

/// True when the levels of detail of `file` are to be used: the file has them and options.lod asks for them (a
/// streamed-SOG level, read_options.lod, given for a .rgs loads the file whole).
bool use_levels(const format::RgsFile& file, const LoadOptions& options);

/// What every sink reports alike: the scene's name and device, its bounds and content, what its Gaussians hold.
SceneInfo scene_info(const std::string& path, Device device, const format::SceneBounds& bounds,
                     const ContentFrame& content, uint64_t gaussians, uint32_t sh_degree, bool antialiased);

/// What every sink of a level-of-detail .rgs reports alike: the file, its full detail and its levels.
SceneInfo lod_scene_info(const format::RgsFile& file, const std::string& path, const LoadOptions& options,
                         Device device);

/// A scene loaded whole (not level-of-detail): with options.lod.enabled, a note when the budgets differ from the
/// defaults (the file has no levels to use them on); without, the index of a level-of-detail file in info->lod
/// (inactive), so that callers can tell that the full detail of such a file was loaded. `opened`: the .rgs file
/// loaded, or null for another format.
void describe_unused_levels(const std::string& path, const LoadOptions& options, SceneInfo* info,
                            const format::RgsFile* opened);

}  // namespace rgs::api::detail
