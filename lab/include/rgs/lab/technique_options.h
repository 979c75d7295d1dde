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

/// CPU reference options with exactly `techniques`: the 3DGS rules for everything else (runtime::cpu_render_options
/// of the faithful preset: background black, all hardware threads), `bounds` for the 32-bit key.
runtime::RenderOptions cpu_technique_options(const runtime::RoofgsOptions& techniques,
                                             const format::SceneBounds& bounds);

#if RGS_HAS_CUDA
/// GPU options of the RoofGS pipeline with exactly `techniques` (GpuRenderOptions::lab_techniques, the lab's plan
/// factory): compact attributes when `scene_has_compact`, the fused kernel or (`fused` false) the separate
/// stages, warp-balanced emission and sub-tile culling chosen per frame (runtime::GpuRoofgsOptions' defaults),
/// and the lab's stages (roofgs_stages()), so that every combination renders.
runtime::GpuRenderOptions gpu_technique_options(const runtime::RoofgsOptions& techniques, bool scene_has_compact,
                                                bool fused = true);

/// GPU options of `preset` with its techniques as the lab's to change (GpuRenderOptions::lab_techniques set to
/// runtime::gpu_techniques(preset, scene_has_compact)), and the lab's stages.
runtime::GpuRenderOptions gpu_preset_techniques(runtime::Preset preset, bool scene_has_compact);

/// What `options` renders a frame of a scene with (`scene_has_compact`: it holds the compact sections) with: its
/// lab techniques, or its preset's.
runtime::GpuTechniques planned_techniques(const runtime::GpuRenderOptions& options, bool scene_has_compact);
#endif

}  // namespace rgs::lab
