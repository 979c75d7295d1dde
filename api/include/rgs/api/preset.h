// Named render configurations: the three presets of the front door.
// Header usable without CUDA (runtime::RenderOptions of the CPU reference); the GPU options are in
// gpu_preset.h.
#pragma once

#include <string>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/roofgs_options.h"

namespace rgs::api {

/// What a frame is rendered with. kFaithful and kPaper give the same techniques on the GPU and on the CPU
/// (which renders the dequantized attributes, equal to the GPU's compact reads); kFastest is the fastest of
/// its kind on each backend (cpu_backend_options).
enum class Preset {
  /// The fastest configuration measured on each backend. On the GPU (rgs-bench's "fastest"): RoofGS pipeline on the compact .rgs
  /// attributes, fused kernel, 32-bit keys with depth order (ties in exact depth order), SnugBox + AccuTile
  /// within the 3DGS rectangle, folded dual-pixel rasterizer, half-precision blending (α the device's exp2
  /// rounded to binary16, binary16 T, colours summed in binary16 over windows of 4 pairs and in FP32 across
  /// them), long tiles in chunks, warp-balanced
  /// emission, per-frame sub-tile culling. Reads only the runtime sections. On the CPU: the 3DGS rules
  /// (cpu_backend_options).
  kFastest = 0,
  /// The 3DGS rasterizer, rule by rule (FP32 attributes, 64-bit keys, 3σ rectangles, expf): the reference
  /// the others are measured against. Needs the FP32 attributes on the GPU (LoadOptions::presets).
  kFaithful = 1,
  /// The paper's combination as published: compact attributes, fused kernel, 32-bit key, SnugBox +
  /// AccuTile (Speedy-Splat's, not limited to the 3DGS rectangle), folded dual-pixel rasterizer, fast exp
  /// with the paper's σ = 0.045677; no depth order, no warp-balanced emission, no sub-tile culling.
  kPaper = 2,
};

/// "fastest", "faithful" or "paper".
const char* preset_name(Preset preset);

/// Parses preset_name()'s strings. @return kInvalidArgument naming the accepted names.
Result<Preset> parse_preset(const std::string& name);

/// The shared technique switches of `preset` (RoofgsOptions; all off for kFaithful).
runtime::RoofgsOptions preset_techniques(Preset preset);

/// CPU reference options for `preset`'s techniques, term by term as the GPU applies them (for testing the GPU
/// against the CPU): preset_techniques(preset), `bounds` (required by the 32-bit key of kFastest and kPaper),
/// background black, all hardware threads.
runtime::RenderOptions cpu_render_options(Preset preset, const format::SceneBounds& bounds);

/// What Renderer renders `preset` with on the CPU: each preset is the fastest of its kind on the backend that
/// runs it. kFastest is there the 3DGS rules (kFaithful's options): the CPU reference emulates every binary16
/// rounding of the GPU's half-precision blending in software, which makes that pipeline several times slower
/// on the CPU than the 3DGS rules; the CPU then renders the baseline image itself, which the GPU's kFastest
/// frame matches within its documented tolerance (docs/RENDERER.md). The other presets: cpu_render_options.
runtime::RenderOptions cpu_backend_options(Preset preset, const format::SceneBounds& bounds);

/// True when `preset`'s GPU pipeline reads the FP32 attributes (kFaithful), false when it reads only the
/// compact runtime sections of a .rgs scene.
bool preset_reads_fp32(Preset preset);

}  // namespace rgs::api
