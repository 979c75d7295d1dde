// Rendering with RoofGS techniques chosen one by one instead of a preset's (one-technique ablations): the
// lab's entry beside the front door, which speaks presets only. The CPU reference renders these options with
// runtime::render_cpu, the GPU with runtime::GpuRenderer.
#pragma once

#include "rgs/config.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/roofgs_options.h"
#if RGS_HAS_CUDA
#include "rgs/runtime/gpu_renderer.h"
#endif

namespace rgs::lab {

/// Checks that `techniques` can be rendered: half_blend needs folded_coefficients and fast_exp.
/// @return kInvalidArgument naming what is missing.
Status check_techniques(const runtime::RoofgsOptions& techniques);

/// CPU reference options with exactly `techniques`: the 3DGS rules for everything else (api::cpu_render_options
/// of the faithful preset: background black, all hardware threads), `bounds` for the 32-bit key.
runtime::RenderOptions cpu_technique_options(const runtime::RoofgsOptions& techniques,
                                             const format::SceneBounds& bounds);

#if RGS_HAS_CUDA
/// GPU options of the RoofGS pipeline with exactly `techniques`: compact attributes when `scene_has_compact`,
/// the fused kernel or (`fused` false) the separate stages, warp-balanced emission and sub-tile culling chosen
/// per frame (runtime::GpuRoofgsOptions' defaults), and the lab's stages (roofgs_stages()), so that every
/// combination renders.
runtime::GpuRenderOptions gpu_technique_options(const runtime::RoofgsOptions& techniques, bool scene_has_compact,
                                                bool fused = true);
#endif

}  // namespace rgs::lab
