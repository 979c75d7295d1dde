// The RoofGS frame plan: every per-frame decision of the GPU pipeline, on the host.
#include "rgs/runtime/frame_plan.h"

#include <algorithm>
#include <string>

#include "rgs/kernels/shared/host_device.h"
#include "rgs/kernels/shared/tile_chunks.h"

namespace rgs::runtime {

Result<FramePlan> plan_frame(Preset preset, const Camera& camera, const std::optional<format::SceneBounds>& bounds,
                             bool scene_has_compact) {
  return plan_frame(gpu_techniques(preset, scene_has_compact), camera, bounds, scene_has_compact);
}

Result<FramePlan> plan_frame(const GpuTechniques& techniques, const Camera& camera,
                             const std::optional<format::SceneBounds>& bounds, bool scene_has_compact) {
  FramePlan plan;
  plan.techniques = techniques;
  plan.tiles_x = uint32_t(kernels::tile_count_for(int(camera.width)));
  plan.tiles_y = uint32_t(kernels::tile_count_for(int(camera.height)));
  if (techniques.pipeline == GpuPipeline::kBaseline) {
    plan.sort_bits = 32 + kernels::key32_tile_bits(plan.tiles_x * plan.tiles_y);
    plan.fused = plan.balanced_emission = false;
    return plan;
  }
  const GpuRoofgsOptions& options = techniques.roofgs;
  const RoofgsOptions& t = options.techniques;
  RGS_RETURN_ERROR_IF(!(t.fast_exp_sigma >= 0.f && t.fast_exp_sigma < 1.f), StatusCode::kInvalidArgument,
                      "GpuRenderer: fast_exp_sigma " + std::to_string(t.fast_exp_sigma) + " outside [0, 1)");
  RGS_RETURN_ERROR_IF(options.compact_attributes && !scene_has_compact, StatusCode::kInvalidArgument,
                      "GpuRenderer: compact attributes asked for a scene without them (load a .rgs file)");
  kernels::RoofgsFrame& rf = plan.switches;
  rf.compact = options.compact_attributes;
  rf.key32 = t.key32;
  rf.snugbox_accutile = t.snugbox_accutile;
  rf.accutile_within_baseline_rect = t.accutile_within_baseline_rect;
  rf.fast_exp = t.fast_exp;
  rf.fast_exp_sigma = t.fast_exp_sigma;
  if (t.key32) {
    RGS_ASSIGN_OR_RETURN(plan.key, make_depth_key(camera, bounds, plan.tiles_x, plan.tiles_y));
    rf.key_depth_bits = plan.key.depth_bits;
    rf.quantizer = plan.key.quantizer;
    rf.cull_z_min = plan.key.cull_z_min;
    rf.cull_z_max = plan.key.cull_z_max;
    rf.empty_depth_range = plan.key.empty_depth_range;
  }
  // Depth order changes no key: with the 32-bit key it puts each run of tied keys in exact depth order after
  // the sort; the 64-bit key holds the exact depth already.
  plan.sort_bits = t.key32 ? 32 : 32 + kernels::key32_tile_bits(plan.tiles_x * plan.tiles_y);
  plan.reorder_ties = t.key32 && t.depth_order;
  // With depth order the final order of tied pairs does not depend on the order they are emitted in, so the
  // fused kernel's blocks need not wait for their predecessors' counts.
  plan.allocation = plan.reorder_ties ? kernels::PairAllocation::kArrivalOrder : kernels::PairAllocation::kBlockOrder;
  plan.fused = options.fused_preprocess;
  plan.balanced_emission = options.balanced_emission;
  return plan;
}

BlendPlan plan_blend(const GpuRoofgsOptions& options, uint64_t pairs, uint64_t large_pairs) {
  const RoofgsOptions& t = options.techniques;
  // kAuto: with SnugBox + AccuTile a large Gaussian's tiles are those its ellipse reaches, so its blocks are
  // nearly all covered; with 3σ rectangles its corner tiles are not, and the culling pays for them.
  const bool subtile = options.subtile_culling == SubtileCulling::kOn ||
                       (options.subtile_culling == SubtileCulling::kAuto &&
                        kernels::auto_block_culling(t.snugbox_accutile, pairs, large_pairs));
  BlendPlan plan;
  plan.raster = kernels::RasterOptions{t.folded_coefficients, t.fast_exp, t.folded_coefficients && subtile,
                                       t.half_blend};
  // Long tiles in chunks: binary16 blending only (the chunk records are binary16).
  static_assert(kernels::kChunkLargeTiles == kernels::kSubtileLargeTiles, "large_pairs counts the culling's measure");
  const bool half = t.folded_coefficients && t.fast_exp && t.half_blend;
  const uint32_t chunk_pairs = kernels::frame_chunk_pairs(pairs, large_pairs, t.tile_chunk_pairs);
  if (half && chunk_pairs > 0 && pairs > chunk_pairs) plan.chunk_pairs = chunk_pairs;
  return plan;
}

Result<uint64_t> pass_pair_limit(uint64_t scratch_budget, uint64_t fixed_bytes, uint64_t bytes_per_pair,
                                 uint64_t min_pairs) {
  if (scratch_budget == 0) return kMaxPassPairs;
  const uint64_t room = scratch_budget > fixed_bytes ? scratch_budget - fixed_bytes : 0;
  const uint64_t limit = std::min(kMaxPassPairs, room / std::max<uint64_t>(bytes_per_pair, 1));
  RGS_RETURN_ERROR_IF(limit < min_pairs, StatusCode::kLimitExceeded,
                      "GpuRenderer: the scratch budget of " + std::to_string(scratch_budget) + " bytes leaves room for " +
                          std::to_string(limit) + " pairs once the scene's " + std::to_string(fixed_bytes) +
                          " bytes of per-Gaussian and per-tile buffers are held; a pass needs at least " +
                          std::to_string(min_pairs) + " (" + std::to_string(bytes_per_pair) + " bytes a pair)");
  return limit;
}

std::vector<TileRows> plan_tile_groups(TileRows rows, uint64_t pairs, uint64_t limit) {
  const uint64_t target = std::max<uint64_t>(limit - limit / 5, 1);
  const uint64_t wanted = std::max<uint64_t>((pairs + target - 1) / target, 2);
  const uint32_t groups = uint32_t(std::min<uint64_t>(wanted, rows.size()));
  std::vector<TileRows> out;
  out.reserve(groups);
  for (uint32_t i = 0; i < groups; ++i) {
    const uint32_t begin = rows.begin + uint32_t(uint64_t(rows.size()) * i / groups);
    const uint32_t end = rows.begin + uint32_t(uint64_t(rows.size()) * (i + 1) / groups);
    out.push_back({begin, end});
  }
  return out;
}

}  // namespace rgs::runtime
