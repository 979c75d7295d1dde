// The frame plan of the GPU pipelines: every per-frame decision (the pipeline, technique switches the kernels
// read, the 32-bit key's layout, the sort's key bits, how pairs are allocated, the rasterizer variant, sub-tile
// culling, long tiles in chunks) made by pure host functions from a preset, the camera and the frame's pair
// counts. GpuRenderer executes the plan and decides nothing itself; these functions build and are tested
// without CUDA (docs/RENDERER.md#the-frame-plan). The product plans from a Preset; the lab's plan factory
// (lab/technique_options.h) plans any combination of the techniques through the same functions.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/kernels/shared/frame_switches.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/depth_key.h"
#include "rgs/runtime/preset.h"
#include "rgs/runtime/roofgs_options.h"

namespace rgs::runtime {

/// Sub-tile culling in the folded rasterizer (beyond the paper).
enum class SubtileCulling {
  kOff,
  kOn,
  /// Per frame: on, unless SnugBox + AccuTile is on and more than kernels::kSubtileMaxLargePairFraction of the
  /// pairs belong to Gaussians with more than kernels::kSubtileLargeTiles tiles (counted by the preprocess;
  /// read back with the pair count).
  kAuto,
};

/// Techniques of the RoofGS pipeline; every combination is valid (ablation). All off renders what the
/// baseline renders.
struct GpuRoofgsOptions {
  /// Read the compact .rgs sections (FP16 geometry, INT8 SH) straight from device memory and dequantize in
  /// registers (paper item 1); needs GpuScene::has_compact(). Off: read the FP32 arrays.
  bool compact_attributes = true;
  /// One fused kernel for preprocess + tile duplication + keys, pairs allocated in Gaussian order by a
  /// decoupled look-back (deterministic), or in the blocks' arrival order with depth order and the 32-bit key,
  /// whose final order does not depend on it (kernels::PairAllocation); off: separate preprocess, scan and
  /// duplicate kernels.
  bool fused_preprocess = true;
  /// Pairs of Gaussians with more than kernels::kSerialTileLimit tiles written by warps
  /// (kernels::emit_large_gaussians) instead of by their own thread; same pairs in the same order.
  bool balanced_emission = true;
  /// With folded coefficients: whether each group of 8 lanes of the rasterizer skips the pairs that cannot
  /// reach alpha 1/255 on its 4×4 block of the tile (kernels::RasterOptions::subtile_culling); the same image
  /// bits on every SnugBox + AccuTile frame tested (see kernels::subtile_mask for the caveat), but for the half
  /// blend's colour windows, which follow the lists (kernels/shared/half_blend.h). The CPU reference follows
  /// kAuto.
  SubtileCulling subtile_culling = SubtileCulling::kAuto;
  /// The techniques shared with the CPU reference (32-bit key, SnugBox + AccuTile, folded coefficients with
  /// dual pixels, fast exp and its σ, depth order). The 32-bit key needs GpuScene::bounds().
  RoofgsOptions techniques = RoofgsOptions::all();
};

/// Which pipeline renders a frame.
enum class GpuPipeline {
  kBaseline,  ///< the 3DGS rasterizer, faithfully (kernels/baseline_pipeline.h)
  kRoofgs,    ///< the RoofGS pipeline with the techniques of GpuRoofgsOptions (kernels/roofgs_pipeline.h)
};

/// What a GPU frame is planned from: the pipeline and, for kRoofgs, its techniques.
struct GpuTechniques {
  GpuPipeline pipeline = GpuPipeline::kBaseline;
  /// Used when pipeline == kRoofgs.
  GpuRoofgsOptions roofgs;
  /// Whether the frame reads the scene's FP32 arrays: the baseline, or RoofGS without compact attributes
  /// (what runtime::GpuSceneOptions::fp32_attributes must be for it).
  bool reads_fp32() const { return pipeline == GpuPipeline::kBaseline || !roofgs.compact_attributes; }
};

/// The techniques `preset` renders with on the GPU. `scene_has_compact`: whether the scene holds the compact
/// .rgs sections; the RoofGS presets read them when present and fall back to the FP32 arrays otherwise (a scene
/// uploaded from a float cloud).
GpuTechniques gpu_techniques(Preset preset, bool scene_has_compact);

/// The decisions made before the preprocess.
struct FramePlan {
  /// What the frame was planned from.
  GpuTechniques techniques;
  /// Tile grid of the frame (16×16 tiles).
  uint32_t tiles_x = 0, tiles_y = 0;
  /// What the preprocess and emission kernels read: technique switches and the 32-bit key's layout.
  kernels::RoofgsFrame switches;
  /// The key's layout (key32 only; zero otherwise).
  DepthKey key;
  /// Bits of the pair key the radix sort covers: 32 with key32, else 32 + ceil(log2(tiles)).
  int sort_bits = 0;
  /// key32 with depth order: the tied keys are put in exact depth order after the sort
  /// (kernels::order_equal_keys_by_depth, which also writes the ranges).
  bool reorder_ties = false;
  /// Where the fused kernel allocates each block's pairs: arrival order where reorder_ties makes the emission
  /// order moot, else block order (deterministic).
  kernels::PairAllocation allocation = kernels::PairAllocation::kBlockOrder;
  /// One fused kernel for preprocess, counting and emission; else separate preprocess, scan and duplicate.
  bool fused = true;
  /// Gaussians with many tiles emitted by warps (kernels::emit_large_gaussians).
  bool balanced_emission = true;
};

/// Plans a frame of `preset` from `camera` over a scene with `bounds` (needed by the 32-bit key) that holds the
/// compact sections or not: the product's seam, plan_frame(gpu_techniques(preset, scene_has_compact), ...).
Result<FramePlan> plan_frame(Preset preset, const Camera& camera, const std::optional<format::SceneBounds>& bounds,
                             bool scene_has_compact);

/// Plans a frame with `techniques` (the lab's plan factory; the presets come here too). A baseline frame plans
/// only its tile grid and sort bits (32 + ceil(log2(tiles))). Errors, RoofGS only: kInvalidArgument
/// (fast_exp_sigma outside [0, 1), compact attributes asked of a scene without them, key32 without bounds or
/// with non-finite ones), kLimitExceeded (a tile grid leaving fewer than 8 depth bits): those of make_depth_key.
Result<FramePlan> plan_frame(const GpuTechniques& techniques, const Camera& camera,
                             const std::optional<format::SceneBounds>& bounds, bool scene_has_compact);

/// The decisions made once the frame's pair count is known.
struct BlendPlan {
  /// The rasterizer variant (kernels::is_lab_variant says whether a product build has it).
  kernels::RasterOptions raster;
  /// Pairs per chunk of the long tiles (kernels/shared/tile_chunks.h), 0 when the frame blends every tile
  /// whole: chunks need binary16 blending and a frame with more pairs than one chunk.
  uint32_t chunk_pairs = 0;
};

/// Plans the blend of a RoofGS frame of `pairs` pairs, `large_pairs` of them from Gaussians with more than
/// kernels::kSubtileLargeTiles tiles: sub-tile culling as options.subtile_culling says (kAuto: off where
/// SnugBox + AccuTile is on and large Gaussians hold more than kernels::kSubtileMaxLargePairFraction of the
/// pairs), and the chunk size (kernels::frame_chunk_pairs).
BlendPlan plan_blend(const GpuRoofgsOptions& options, uint64_t pairs, uint64_t large_pairs);

/// Most pairs one pass of a frame emits, sorts and blends: the sort and the kernels take pair counts as 32-bit
/// signed integers (CUB's int arguments among them). A frame with more pairs is rendered in groups of tile rows
/// (plan_tile_groups), so no count on the way reaches its type's limit.
constexpr uint64_t kMaxPassPairs = (uint64_t{1} << 31) - 1;

/// The pairs one pass may hold: kMaxPassPairs, or under a scratch budget (GpuRenderOptions::scratch_budget,
/// bytes; 0: none) what fits once `fixed_bytes` (the frame's buffers that do not grow with its pairs) are
/// held, at `bytes_per_pair` (sort buffers and scratch, large-Gaussian list). Errors: kLimitExceeded when the
/// budget leaves room for fewer than `min_pairs` pairs (the message gives both sizes).
Result<uint64_t> pass_pair_limit(uint64_t scratch_budget, uint64_t fixed_bytes, uint64_t bytes_per_pair,
                                 uint64_t min_pairs);

/// Tile rows [begin, end) of the grid that one pass renders (kernels::FrameParams::tile_row_begin/end).
struct TileRows {
  uint32_t begin = 0, end = 0;
  uint32_t size() const { return end - begin; }
  bool operator==(const TileRows& o) const { return begin == o.begin && end == o.end; }
};

/// Splits `rows`, whose pairs number `pairs` > `limit`, into consecutive groups, top to bottom, of about
/// limit·4/5 pairs each if the pairs were spread evenly over the rows (at least 2 groups, at most one row each).
/// A group that still holds more than `limit` pairs is split again by the renderer, which counts them.
std::vector<TileRows> plan_tile_groups(TileRows rows, uint64_t pairs, uint64_t limit);

}  // namespace rgs::runtime
