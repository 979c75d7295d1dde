// rgs-bench's named GPU modes.
#include "rgs/lab/gpu_modes.h"

#include <functional>

#include "rgs/kernels/shared/frame_switches.h"
#include "rgs/lab/roofgs_stages.h"
#include "rgs/lab/technique_options.h"
#include "rgs/runtime/frame_plan.h"
#include "rgs/runtime/preset.h"

namespace rgs::lab {
namespace {

using runtime::Preset;
using runtime::preset_name;

using runtime::GpuRenderOptions;
using runtime::RoofgsOptions;

GpuRenderOptions roofgs_pipeline(bool compact, bool fused, const RoofgsOptions& techniques) {
  return gpu_technique_options(techniques, compact, fused);
}

struct ModeEntry {
  GpuMode mode;
  /// Options for a scene with (true) or without compact attributes.
  std::function<GpuRenderOptions(bool compact)> options;
};

ModeEntry roofgs_variant(const std::string& name, const std::string& description,
                         void (*set)(runtime::GpuRoofgsOptions&)) {
  return {{name, description, false}, [set](bool compact) {
            GpuRenderOptions o = roofgs_pipeline(compact, true, RoofgsOptions::all());
            set(o.lab_techniques->roofgs);
            return o;
          }};
}

ModeEntry only_mode(const std::string& name, const std::string& what, bool compact, bool fused,
                    void (*set)(RoofgsOptions&)) {
  return {{"only-" + name, "RoofGS pipeline with only " + what + " on", compact}, [=](bool) {
            RoofgsOptions t;  // all off
            if (set != nullptr) set(t);
            return roofgs_pipeline(compact, fused, t);
          }};
}

/// A preset under its own name (preset_name()): the presets are the first modes of the registry.
ModeEntry preset_mode(Preset preset, const std::string& description) {
  return {{preset_name(preset), description, false},
          [preset](bool) {
            GpuRenderOptions o;
            o.preset = preset;
            return o;
          }};
}

/// A variant of the fastest preset with one of its techniques changed.
ModeEntry fastest_variant(const std::string& name, const std::string& description,
                          void (*set)(runtime::RoofgsOptions&)) {
  return {{name, description, false}, [set](bool compact) {
            GpuRenderOptions o = gpu_preset_techniques(Preset::kFastest, compact);
            set(o.lab_techniques->roofgs.techniques);
            return o;
          }};
}

const std::vector<ModeEntry>& entries() {
  static const std::vector<ModeEntry> modes = {
      preset_mode(Preset::kFaithful,
                  "the 3DGS rasterizer, the baseline (FP32 attributes, 64-bit keys, 3-sigma rectangles, expf)"),
      preset_mode(Preset::kFastest,
                  "roofgs with depth order, half-precision blending (binary16 alpha: the device's FP32 exp2 of the "
                  "power in base 2, rounded to binary16; binary16 transmittance and colour sums) and long tiles blended in chunks, a block each "
                  "(tiles of more than max(1024, pairs/2048) pairs, unless Gaussians of more than 32 tiles hold most "
                  "pairs); the fused kernel allocates pairs in arrival order: the depth order makes their emission "
                  "order moot"),
      preset_mode(Preset::kPaper,
                  "the paper's combination as published: every RoofGS technique, fast exp sigma 0.045677, "
                  "SnugBox+AccuTile not limited to the 3DGS rectangle, each Gaussian's pairs written by its own "
                  "thread, no sub-tile culling"),
      {{"roofgs",
        "RoofGS pipeline, every technique on (compact attributes when the scene is a .rgs, fused kernel, 32-bit "
        "key, SnugBox+AccuTile, folded dual-pixel, fast exp sigma 0.045677); Gaussians with many tiles emitted "
        "by warps (every RoofGS mode but paper and roofgs-serial-emission); sub-tile culling in the folded "
        "rasterizer chosen per frame (off when SnugBox+AccuTile is on and more than half the pairs belong to "
        "Gaussians with more than 32 tiles; every mode but paper, roofgs-no-subtile and roofgs-subtile-always), "
        "per 4x4 block of 8 lanes",
        false},
       [](bool compact) { return roofgs_pipeline(compact, true, RoofgsOptions::all()); }},
      fastest_variant("fastest-fp32-blend", "fastest with FP32 blending (FP32 fast exp, sigma 0.05798)",
                      [](RoofgsOptions& t) { t.half_blend = false; }),
      fastest_variant("fastest-whole-tiles",
                      "fastest with every tile blended by one block (fastest blends long tiles in chunks, a block "
                      "each, merged front to back)",
                      [](RoofgsOptions& t) { t.tile_chunk_pairs = 0; }),
      roofgs_variant("roofgs-serial-emission",
                     "roofgs with each Gaussian's pairs written by its own thread (balanced emission off: the "
                     "paper's fused kernel as published)",
                     [](runtime::GpuRoofgsOptions& o) { o.balanced_emission = false; }),
      roofgs_variant("roofgs-no-subtile",
                     "roofgs without sub-tile culling (every warp of a tile walks all of the tile's pairs, as in "
                     "the paper)",
                     [](runtime::GpuRoofgsOptions& o) { o.subtile_culling = runtime::SubtileCulling::kOff; }),
      roofgs_variant("roofgs-subtile-always", "roofgs with sub-tile culling on in every frame",
                     [](runtime::GpuRoofgsOptions& o) { o.subtile_culling = runtime::SubtileCulling::kOn; }),
      {{"roofgs-none", "RoofGS pipeline with every technique off (separate stages, faithful's math)", false},
       [](bool) { return roofgs_pipeline(false, false, RoofgsOptions{}); }},
      only_mode("compact", "compact attributes (needs a .rgs scene)", true, false, nullptr),
      only_mode("fused", "the fused preprocess kernel", false, true, nullptr),
      only_mode("key32", "the 32-bit key", false, false, [](RoofgsOptions& t) { t.key32 = true; }),
      only_mode("snugbox", "SnugBox + AccuTile", false, false, [](RoofgsOptions& t) { t.snugbox_accutile = true; }),
      only_mode("folded", "the folded dual-pixel rasterizer", false, false,
                [](RoofgsOptions& t) { t.folded_coefficients = true; }),
      only_mode("fastexp", "the fast exp", false, false, [](RoofgsOptions& t) { t.fast_exp = true; }),
  };
  return modes;
}

/// Whether `o` needs a stage of the lab's (roofgs_stages()): the separate preprocess and duplication, or a lab
/// variant of the render kernel (kernels::is_lab_variant; with sub-tile culling kAuto, the plans of a frame
/// without large Gaussians and of one made of them both count).
bool uses_lab_stages(const GpuRenderOptions& o) {
  const runtime::GpuTechniques t = planned_techniques(o, false);
  if (t.pipeline == runtime::GpuPipeline::kBaseline) return false;
  return !t.roofgs.fused_preprocess || kernels::is_lab_variant(runtime::plan_blend(t.roofgs, 1, 0).raster) ||
         kernels::is_lab_variant(runtime::plan_blend(t.roofgs, 1, 1).raster);
}

}  // namespace

const std::vector<GpuMode>& gpu_modes() {
  static const std::vector<GpuMode> modes = [] {
    std::vector<GpuMode> m;
    for (const ModeEntry& e : entries()) {
      m.push_back(e.mode);
      m.back().lab = uses_lab_stages(e.options(false));
    }
    return m;
  }();
  return modes;
}

Result<GpuRenderOptions> gpu_mode_options(const std::string& name, bool scene_has_compact) {
  for (const ModeEntry& e : entries()) {
    if (e.mode.name != name) continue;
    RGS_RETURN_ERROR_IF(e.mode.requires_compact && !scene_has_compact, StatusCode::kInvalidArgument,
                        "mode " + name + " reads compact attributes, which only a .rgs scene has");
    GpuRenderOptions options = e.options(scene_has_compact);
    // The product's stages render the presets' configurations (timed as the product runs them); the others
    // need the lab's.
    options.stages = uses_lab_stages(options) ? roofgs_stages() : kernels::RoofgsStages{};
    return options;
  }
  std::string names;
  for (const ModeEntry& e : entries()) names += (names.empty() ? "" : ", ") + e.mode.name;
  return Status(StatusCode::kInvalidArgument, "unknown GPU mode '" + name + "' (use " + names + ")");
}

}  // namespace rgs::lab
