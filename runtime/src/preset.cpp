// Presets: their names, and the technique switches behind them on the CPU reference and the GPU.
#include "rgs/runtime/preset.h"

#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/runtime/frame_plan.h"
#include "rgs/runtime/preset_techniques.h"

namespace rgs::runtime {

const char* preset_name(Preset preset) {
  switch (preset) {
    case Preset::kFastest: return "fastest";
    case Preset::kFaithful: return "faithful";
    case Preset::kPaper: return "paper";
  }
  return "unknown";
}

Result<Preset> parse_preset(const std::string& name) {
  for (Preset p : {Preset::kFastest, Preset::kFaithful, Preset::kPaper}) {
    if (name == preset_name(p)) return p;
  }
  return Status(StatusCode::kInvalidArgument,
                "unknown preset '" + name + "' (use fastest, faithful or paper)");
}

bool preset_reads_fp32(Preset preset) { return preset == Preset::kFaithful; }

RoofgsOptions preset_techniques(Preset preset) {
  RoofgsOptions t;  // all off: the 3DGS baseline
  if (preset == Preset::kFastest) {
    t = RoofgsOptions::all();
    t.depth_order = true;
    t.fast_exp_sigma = kernels::kFastExpSigmaZeroMean;
    t.half_blend = true;
    t.tile_chunk_pairs = kernels::kTileChunkPairs;
  } else if (preset == Preset::kPaper) {
    t = RoofgsOptions::all();
    t.accutile_within_baseline_rect = false;
  }
  return t;
}

RenderOptions cpu_render_options(Preset preset, const format::SceneBounds& bounds) {
  RenderOptions o;
  o.roofgs = preset_techniques(preset);
  o.scene_bounds = bounds;
  return o;
}

RenderOptions cpu_backend_options(Preset preset, const format::SceneBounds& bounds) {
  return cpu_render_options(preset == Preset::kFastest ? Preset::kFaithful : preset, bounds);
}

GpuTechniques gpu_techniques(Preset preset, bool scene_has_compact) {
  GpuTechniques t;
  if (preset == Preset::kFaithful) return t;  // the baseline pipeline
  t.pipeline = GpuPipeline::kRoofgs;
  t.roofgs.compact_attributes = scene_has_compact;
  t.roofgs.techniques = preset_techniques(preset);
  if (preset == Preset::kPaper) {
    t.roofgs.balanced_emission = false;
    t.roofgs.subtile_culling = SubtileCulling::kOff;
  }
  return t;
}

}  // namespace rgs::runtime
