// Options that render chosen RoofGS techniques (rgs/lab/technique_options.h).
#include "rgs/lab/technique_options.h"

#include "rgs/runtime/preset_techniques.h"
#if RGS_HAS_CUDA
#include "rgs/lab/roofgs_stages.h"
#endif

namespace rgs::lab {

Status check_techniques(const runtime::RoofgsOptions& techniques) {
  RGS_RETURN_ERROR_IF(techniques.half_blend && !(techniques.folded_coefficients && techniques.fast_exp),
                      StatusCode::kInvalidArgument,
                      "half_blend needs folded_coefficients and fast_exp (binary16 blending is the folded "
                      "kernel's with the fast exp)");
  return Status();
}

runtime::RenderOptions cpu_technique_options(const runtime::RoofgsOptions& techniques,
                                             const format::SceneBounds& bounds) {
  runtime::RenderOptions options = runtime::cpu_render_options(runtime::Preset::kFaithful, bounds);
  options.roofgs = techniques;
  return options;
}

#if RGS_HAS_CUDA
runtime::GpuRenderOptions gpu_technique_options(const runtime::RoofgsOptions& techniques, bool scene_has_compact,
                                                bool fused) {
  runtime::GpuRenderOptions options;
  runtime::GpuTechniques& t = options.lab_techniques.emplace();
  t.pipeline = runtime::GpuPipeline::kRoofgs;
  t.roofgs.compact_attributes = scene_has_compact;
  t.roofgs.fused_preprocess = fused;
  t.roofgs.techniques = techniques;
  options.stages = roofgs_stages();
  return options;
}

runtime::GpuRenderOptions gpu_preset_techniques(runtime::Preset preset, bool scene_has_compact) {
  runtime::GpuRenderOptions options;
  options.preset = preset;
  options.lab_techniques = runtime::gpu_techniques(preset, scene_has_compact);
  options.stages = roofgs_stages();
  return options;
}

runtime::GpuTechniques planned_techniques(const runtime::GpuRenderOptions& options, bool scene_has_compact) {
  return options.lab_techniques.value_or(runtime::gpu_techniques(options.preset, scene_has_compact));
}
#endif

}  // namespace rgs::lab
