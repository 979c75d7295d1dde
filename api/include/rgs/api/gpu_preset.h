// GPU render options of the presets, and the named variants rgs-bench measures (ablations included), in one
// place for the tools and the library. Available only with RGS_WITH_CUDA.
#pragma once

#include <string>
#include <vector>

#include "rgs/api/preset.h"
#include "rgs/format/status.h"
#include "rgs/runtime/gpu_renderer.h"

namespace rgs::api {

/// GpuRenderOptions of `preset` (background black, no stage timing). `scene_has_compact`: whether the scene
/// holds the compact .rgs sections; the RoofGS presets read them when present and fall back to the FP32
/// arrays otherwise (a scene uploaded from a float cloud).
runtime::GpuRenderOptions gpu_render_options(Preset preset, bool scene_has_compact);

/// One named GPU configuration (rgs-bench --mode).
struct GpuMode {
  std::string name;         ///< e.g. "faithful", "fastest", "only-key32"
  std::string description;  ///< one line for --help and reports
  /// True when the mode must read compact attributes (fails on a scene without them).
  bool requires_compact = false;
  /// True when the mode may render with a lab variant of the render kernel (kernels::is_lab_variant): it runs
  /// only in builds with RGS_LAB_KERNELS.
  bool lab = false;
};

/// Every named configuration, in rgs-bench's order: the presets under their own names (faithful, fastest,
/// paper: gpu_render_options()), then the lab configurations: roofgs, fastest-fp32-blend, fastest-whole-tiles,
/// roofgs-serial-emission, roofgs-no-subtile, roofgs-subtile-always, roofgs-none, and the paper's
/// one-technique ablation only-compact, only-fused, only-key32, only-snugbox, only-folded, only-fastexp.
/// The names are the same in rgs-bench's --mode, its JSON, the CLI's --preset and Python.
const std::vector<GpuMode>& gpu_modes();

/// Options of the mode called `name` for a scene with or without compact attributes.
/// @return kInvalidArgument for an unknown name, or a mode that needs compact attributes on a scene
/// without them (the message says so); kUnsupportedFeature for a lab mode in a build without RGS_LAB_KERNELS.
Result<runtime::GpuRenderOptions> gpu_mode_options(const std::string& name, bool scene_has_compact);

/// True when rendering with `options` reads the scene's FP32 arrays (the baseline pipeline, or the RoofGS one
/// without compact attributes): what runtime::GpuSceneOptions::fp32_attributes must be for it.
bool reads_fp32_attributes(const runtime::GpuRenderOptions& options);

}  // namespace rgs::api
