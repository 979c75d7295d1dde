// Presets: the technique switches shared by the CPU reference and the GPU pipelines.
#include "rgs/api/preset.h"

#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/tile_chunks.h"

namespace rgs::api {

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

runtime::RoofgsOptions preset_techniques(Preset preset) {
  runtime::RoofgsOptions t;  // all off: the 3DGS baseline
  if (preset == Preset::kFastest) {
    t = runtime::RoofgsOptions::all();
    t.depth_order = true;
    t.fast_exp_sigma = kernels::kFastExpSigmaZeroMean;
    t.half_blend = true;
    t.tile_chunk_pairs = kernels::kTileChunkPairs;
  } else if (preset == Preset::kPaper) {
    t = runtime::RoofgsOptions::all();
    t.accutile_within_baseline_rect = false;
  }
  return t;
}

runtime::RenderOptions cpu_render_options(Preset preset, const format::SceneBounds& bounds) {
  runtime::RenderOptions o;
  o.roofgs = preset_techniques(preset);
  o.scene_bounds = bounds;
  return o;
}

runtime::RenderOptions cpu_backend_options(Preset preset, const format::SceneBounds& bounds) {
  return cpu_render_options(preset == Preset::kFastest ? Preset::kFaithful : preset, bounds);
}

bool preset_reads_fp32(Preset preset) { return preset == Preset::kFaithful; }

}  // namespace rgs::api
