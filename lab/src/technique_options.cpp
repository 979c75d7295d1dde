// Options that render chosen RoofGS techniques (rgs/lab/technique_options.h).
#include "rgs/lab/technique_options.h"

#include "rgs/api/preset.h"
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
  runtime::RenderOptions options = api::cpu_render_options(api::Preset::kFaithful, bounds);
  options.roofgs = techniques;
  return options;
}

#if RGS_HAS_CUDA
runtime::GpuRenderOptions gpu_technique_options(const runtime::RoofgsOptions& techniques, bool scene_has_compact,
                                                bool fused) {
  runtime::GpuRenderOptions options;
  options.pipeline = runtime::GpuPipeline::kRoofgs;
  options.roofgs.compact_attributes = scene_has_compact;
  options.roofgs.fused_preprocess = fused;
  options.roofgs.techniques = techniques;
  options.stages = roofgs_stages();
  return options;
}
#endif

}  // namespace rgs::lab
