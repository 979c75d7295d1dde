// The named GPU configurations rgs-bench measures: the presets under their own names, then the lab's
// ablations and comparison modes. Available only with RGS_WITH_CUDA.
#pragma once

#include <string>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/runtime/gpu_renderer.h"

namespace rgs::lab {

/// One named GPU configuration (rgs-bench --mode).
struct GpuMode {
  std::string name;         ///< e.g. "faithful", "fastest", "only-key32"
  std::string description;  ///< one line for --help and reports
  /// True when the mode must read compact attributes (fails on a scene without them).
  bool requires_compact = false;
  /// True when the mode needs the lab's stages (roofgs_stages(): the separate preprocess and duplication, or a
  /// lab variant of the render kernel, kernels::is_lab_variant), which gpu_mode_options() then sets.
  bool lab = false;
};

/// Every named configuration, in rgs-bench's order: the presets under their own names (faithful, fastest,
/// paper: GpuRenderOptions::preset), then the lab configurations: roofgs, fastest-fp32-blend,
/// fastest-whole-tiles, roofgs-serial-emission, roofgs-no-subtile, roofgs-subtile-always, roofgs-none, and the
/// paper's one-technique ablation only-compact, only-fused, only-key32, only-snugbox, only-folded, only-fastexp.
/// The names are the same in rgs-bench's --mode, its JSON and the CLI's --preset.
const std::vector<GpuMode>& gpu_modes();

/// Options of the mode called `name` for a scene with or without compact attributes; with the lab's stages
/// (GpuRenderOptions::stages) for the modes that need them, the product's otherwise.
/// @return kInvalidArgument for an unknown name, or a mode that needs compact attributes on a scene
/// without them (the message says so).
Result<runtime::GpuRenderOptions> gpu_mode_options(const std::string& name, bool scene_has_compact);

}  // namespace rgs::lab
