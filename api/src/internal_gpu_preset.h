// GPU render options of the presets. Available only with RGS_WITH_CUDA.
#pragma once

#include "rgs/api/preset.h"
#include "rgs/runtime/gpu_renderer.h"

namespace rgs::api {

/// GpuRenderOptions of `preset` (background black, no stage timing). `scene_has_compact`: whether the scene
/// holds the compact .rgs sections; the RoofGS presets read them when present and fall back to the FP32
/// arrays otherwise (a scene uploaded from a float cloud).
runtime::GpuRenderOptions gpu_render_options(Preset preset, bool scene_has_compact);

/// True when rendering with `options` reads the scene's FP32 arrays (the baseline pipeline, or the RoofGS one
/// without compact attributes): what runtime::GpuSceneOptions::fp32_attributes must be for it.
bool reads_fp32_attributes(const runtime::GpuRenderOptions& options);

}  // namespace rgs::api
