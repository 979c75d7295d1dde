// GPU options of the presets.
#include "internal_gpu_preset.h"

namespace rgs::api {

runtime::GpuRenderOptions gpu_render_options(Preset preset, bool scene_has_compact) {
  runtime::GpuRenderOptions o;
  if (preset == Preset::kFaithful) {
    o.pipeline = runtime::GpuPipeline::kBaseline;
    return o;
  }
  o.pipeline = runtime::GpuPipeline::kRoofgs;
  o.roofgs.compact_attributes = scene_has_compact;
  o.roofgs.fused_preprocess = true;
  o.roofgs.techniques = preset_techniques(preset);
  if (preset == Preset::kPaper) {
    o.roofgs.balanced_emission = false;
    o.roofgs.subtile_culling = runtime::SubtileCulling::kOff;
  }
  return o;
}

bool reads_fp32_attributes(const runtime::GpuRenderOptions& options) {
  return options.pipeline == runtime::GpuPipeline::kBaseline || !options.roofgs.compact_attributes;
}

}  // namespace rgs::api
