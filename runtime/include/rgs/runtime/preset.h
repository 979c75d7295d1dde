// The presets: the product's render vocabulary. A preset names what a frame is rendered with on the CPU and on the
// GPU; the technique switches behind each one (preset_techniques.h, frame_plan.h) are the lab's vocabulary.
#pragma once

#include <string>

#include "rgs/format/status.h"

namespace rgs::runtime {

/// What a frame is rendered with. kFaithful and kPaper give the same techniques on the GPU and on the CPU
/// (which renders the dequantized attributes, equal to the GPU's compact reads); kFastest is the fastest of
/// its kind on each backend.
enum class Preset {
  /// The fastest configuration measured on each backend. On the GPU: RoofGS pipeline on the compact .rgs
  /// attributes, fused kernel, 32-bit keys with depth order (ties in exact depth order), SnugBox + AccuTile
  /// within the 3DGS rectangle, folded dual-pixel rasterizer, half-precision blending (α the device's exp2
  /// rounded to binary16, binary16 T, colours summed in binary16 over windows of 4 pairs and in FP32 across
  /// them), long tiles in chunks, warp-balanced emission, per-frame sub-tile culling. Reads only the runtime
  /// sections. On the CPU: the 3DGS rules, which the GPU frame matches within its documented tolerance
  /// (docs/RENDERER.md): the CPU reference emulates every binary16 rounding in software, several times slower
  /// there than the 3DGS rules.
  kFastest = 0,
  /// The 3DGS rasterizer, rule by rule (FP32 attributes, 64-bit keys, 3σ rectangles, expf): the reference
  /// the others are measured against. Needs the FP32 attributes on the GPU.
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

/// True when `preset`'s GPU pipeline reads the FP32 attributes (kFaithful), false when it reads only the
/// compact runtime sections of a .rgs scene.
bool preset_reads_fp32(Preset preset);

}  // namespace rgs::runtime
