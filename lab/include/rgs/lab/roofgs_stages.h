// The lab's stages of the RoofGS pipeline: those no preset uses (the separate preprocess and duplication, the
// render kernel's lab variants), for runtime::GpuRenderOptions::stages. Available only with RGS_WITH_CUDA.
#pragma once

#include "rgs/kernels/roofgs_pipeline.h"

namespace rgs::lab {

/// Every RoofGS stage: the separate preprocess and duplication (fused_preprocess off), and a render stage that
/// launches the lab variants of the render kernel (kernels::is_lab_variant: the RoofGS pixel kernel, the
/// folded kernel without the fast exp, FP32 blending with sub-tile culling) and kernels::render_roofgs for the
/// others, so that a configuration the presets reach renders with the product's kernels.
kernels::RoofgsStages roofgs_stages();

}  // namespace rgs::lab
