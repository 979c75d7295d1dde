// The GPU frame plan on the host: the decisions of each preset's configuration, the automatic sub-tile culling
// and chunking rules at their thresholds, the errors, the key layout the CPU reference uses too, and the pass
// limit and tile-row groups of frames with more pairs than a pass holds.
#include <doctest/doctest.h>

#include <cstdint>
#include <optional>
#include <vector>

#include "render_test_util.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/runtime/frame_plan.h"
#include "rgs/runtime/preset_techniques.h"

namespace rgs::test {
namespace {

namespace k = rgs::kernels;
using runtime::GpuRoofgsOptions;
using runtime::GpuTechniques;
using runtime::Preset;
using runtime::RoofgsOptions;
using runtime::SubtileCulling;

format::SceneBounds unit_sphere_at(float z) {
  format::SceneBounds b;
  b.sphere_center[2] = z;
  b.sphere_radius = 1.f;
  for (int a = 0; a < 3; ++a) {
    b.aabb_min[a] = b.sphere_center[a] - 1.f;
    b.aabb_max[a] = b.sphere_center[a] + 1.f;
  }
  return b;
}

/// The fastest preset's RoofGS options on a scene with the compact sections.
GpuRoofgsOptions fastest() { return runtime::gpu_techniques(Preset::kFastest, true).roofgs; }

/// The RoofGS pipeline with `options` (the lab's plan factory's input).
GpuTechniques roofgs(const GpuRoofgsOptions& options) { return {runtime::GpuPipeline::kRoofgs, options}; }

TEST_CASE("frame plan: the fastest preset's frame at 1080p") {
  const runtime::Camera camera = identity_camera(1920, 1080, 1000.f);
  auto plan = runtime::plan_frame(Preset::kFastest, camera, unit_sphere_at(5.f), true);
  REQUIRE_MESSAGE(plan.ok(), plan.status().to_string());
  // Every technique, depth order, binary16 blending, long tiles in chunks, the fused kernel, balanced emission.
  const RoofgsOptions& t = plan->techniques.roofgs.techniques;
  CHECK(plan->techniques.pipeline == runtime::GpuPipeline::kRoofgs);
  CHECK((t.key32 && t.snugbox_accutile && t.folded_coefficients && t.fast_exp && t.depth_order && t.half_blend));
  CHECK(t.tile_chunk_pairs == k::kTileChunkPairs);
  CHECK(plan->fused);
  CHECK(plan->balanced_emission);
  CHECK(plan->techniques.roofgs.subtile_culling == SubtileCulling::kAuto);
  CHECK(plan->tiles_x == 120);
  CHECK(plan->tiles_y == 68);
  CHECK(plan->switches.key32);
  CHECK(plan->switches.compact);
  CHECK(plan->sort_bits == 32);
  CHECK(plan->key.tile_bits == 13);  // 8,160 tiles
  CHECK(plan->switches.key_depth_bits == 19);
  CHECK(plan->switches.quantizer.z_near == 4.f);
  CHECK(plan->switches.quantizer.z_far == 6.f);
  // Depth order reorders the tied keys after the sort, so the emission order is free.
  CHECK(plan->reorder_ties);
  CHECK(plan->allocation == k::PairAllocation::kArrivalOrder);
  // The same layout as the CPU reference's frame setup (one function for both).
  const runtime::RenderOptions cpu = runtime::cpu_render_options(Preset::kFastest, unit_sphere_at(5.f));
  CHECK(cpu.roofgs.half_blend == t.half_blend);
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.f, 0.f, 5.f, 0.1f, 0.5f, 0.f, 0.f, 0.f);
  auto setup = runtime::setup_frame(cloud, camera, cpu);
  REQUIRE(setup.ok());
  CHECK(setup->key.depth_bits == plan->key.depth_bits);
  CHECK(setup->key.cull_z_min == plan->switches.cull_z_min);
  CHECK(setup->key.cull_z_max == plan->switches.cull_z_max);
}

TEST_CASE("frame plan: without the 32-bit key the sort covers the tile bits and the exact depth") {
  // The faithful preset: the baseline pipeline, separate stages; 3840×2160: 240×135 = 32,400 tiles → 15 tile
  // bits above the 32 depth bits.
  auto baseline = runtime::plan_frame(Preset::kFaithful, identity_camera(3840, 2160, 2000.f), std::nullopt, true);
  REQUIRE_MESSAGE(baseline.ok(), baseline.status().to_string());
  CHECK(baseline->techniques.pipeline == runtime::GpuPipeline::kBaseline);
  CHECK(baseline->techniques.reads_fp32());
  CHECK(baseline->sort_bits == 47);
  CHECK_FALSE(baseline->fused);
  // The RoofGS pipeline with every technique off.
  GpuRoofgsOptions o;
  o.techniques = RoofgsOptions{};
  o.compact_attributes = false;
  auto plan = runtime::plan_frame(roofgs(o), identity_camera(3840, 2160, 2000.f), std::nullopt, false);
  REQUIRE_MESSAGE(plan.ok(), plan.status().to_string());
  CHECK_FALSE(plan->switches.key32);
  CHECK(plan->sort_bits == 47);
  CHECK_FALSE(plan->reorder_ties);
  CHECK(plan->allocation == k::PairAllocation::kBlockOrder);
  // Depth order without the 32-bit key changes nothing in the plan: the 64-bit key holds the depth.
  o.techniques.depth_order = true;
  auto same = runtime::plan_frame(roofgs(o), identity_camera(3840, 2160, 2000.f), std::nullopt, false);
  REQUIRE(same.ok());
  CHECK_FALSE(same->reorder_ties);
}

TEST_CASE("frame plan: what cannot be planned") {
  const runtime::Camera camera = identity_camera(640, 360, 500.f);
  GpuRoofgsOptions o = fastest();
  // Compact attributes of a scene uploaded from a float cloud; the preset reads its FP32 arrays instead.
  CHECK(runtime::plan_frame(roofgs(o), camera, unit_sphere_at(5.f), false).status().code() ==
        StatusCode::kInvalidArgument);
  auto fallback = runtime::plan_frame(Preset::kFastest, camera, unit_sphere_at(5.f), false);
  REQUIRE(fallback.ok());
  CHECK(fallback->techniques.reads_fp32());
  // The 32-bit key without bounds.
  CHECK(runtime::plan_frame(Preset::kFastest, camera, std::nullopt, true).status().code() ==
        StatusCode::kInvalidArgument);
  // σ of the fast exp outside [0, 1).
  o.techniques.fast_exp_sigma = 1.f;
  CHECK(runtime::plan_frame(roofgs(o), camera, unit_sphere_at(5.f), true).status().code() ==
        StatusCode::kInvalidArgument);
}

TEST_CASE("blend plan: sub-tile culling per frame, at the large-pair threshold") {
  GpuRoofgsOptions o = fastest();
  // kAuto with SnugBox + AccuTile: on while large Gaussians hold at most half the pairs.
  CHECK(runtime::plan_blend(o, 1000, 500).raster.subtile_culling);
  CHECK_FALSE(runtime::plan_blend(o, 1000, 501).raster.subtile_culling);
  // With 3σ rectangles the culling pays in every frame; kOn and kOff force it.
  o.techniques.snugbox_accutile = false;
  CHECK(runtime::plan_blend(o, 1000, 1000).raster.subtile_culling);
  o.subtile_culling = SubtileCulling::kOff;
  CHECK_FALSE(runtime::plan_blend(o, 1000, 0).raster.subtile_culling);
  o.subtile_culling = SubtileCulling::kOn;
  o.techniques.snugbox_accutile = true;
  CHECK(runtime::plan_blend(o, 1000, 1000).raster.subtile_culling);
  // Culling exists in the folded rasterizer only.
  o.techniques.folded_coefficients = false;
  CHECK_FALSE(runtime::plan_blend(o, 1000, 0).raster.subtile_culling);
}

TEST_CASE("blend plan: long tiles in chunks only with binary16 blending and more pairs than a chunk") {
  GpuRoofgsOptions o = fastest();
  CHECK(runtime::plan_blend(o, 1'000'000, 0).chunk_pairs == k::kTileChunkPairs);
  // Large frames take larger chunks (at least 1/kTileChunksPerFrame of the pairs).
  CHECK(runtime::plan_blend(o, 8'000'000, 0).chunk_pairs == (8'000'000 + k::kTileChunksPerFrame - 1) /
                                                                 k::kTileChunksPerFrame);
  // No chunks where large Gaussians hold most pairs, in a frame of fewer pairs than a chunk, or in FP32.
  CHECK(runtime::plan_blend(o, 1'000'000, 900'000).chunk_pairs == 0);
  CHECK(runtime::plan_blend(o, k::kTileChunkPairs, 0).chunk_pairs == 0);
  o.techniques.half_blend = false;
  CHECK(runtime::plan_blend(o, 1'000'000, 0).chunk_pairs == 0);
}

TEST_CASE("blend plan: the presets' rasterizers are product variants, the ablations' lab ones") {
  // fastest, culled or not.
  CHECK_FALSE(k::is_lab_variant(runtime::plan_blend(fastest(), 1000, 0).raster));
  CHECK_FALSE(k::is_lab_variant(runtime::plan_blend(fastest(), 1000, 1000).raster));
  // paper: every technique of the paper, FP32 blending, no culling.
  GpuRoofgsOptions paper = runtime::gpu_techniques(Preset::kPaper, true).roofgs;
  CHECK(paper.subtile_culling == SubtileCulling::kOff);
  CHECK_FALSE(k::is_lab_variant(runtime::plan_blend(paper, 1000, 0).raster));
  // FP32 blending with culling, the folded rasterizer alone, the fast exp alone.
  paper.subtile_culling = SubtileCulling::kOn;
  CHECK(k::is_lab_variant(runtime::plan_blend(paper, 1000, 0).raster));
  GpuRoofgsOptions folded;
  folded.techniques = RoofgsOptions{};
  folded.techniques.folded_coefficients = true;
  CHECK(k::is_lab_variant(runtime::plan_blend(folded, 1000, 0).raster));
  GpuRoofgsOptions fast_exp;
  fast_exp.techniques = RoofgsOptions{};
  fast_exp.techniques.fast_exp = true;
  CHECK(k::is_lab_variant(runtime::plan_blend(fast_exp, 1000, 0).raster));
}

TEST_CASE("pass limit: every pair count below the sort's 32-bit limit without a budget, what fits with one") {
  using runtime::kMaxPassPairs;
  CHECK(kMaxPassPairs == 2147483647u);
  CHECK(runtime::pass_pair_limit(0, 1u << 30, 16, 1024).value() == kMaxPassPairs);
  // 1 GiB budget, 300 MiB held, 17 bytes a pair: what is left, rounded down.
  const uint64_t gib = uint64_t{1} << 30, held = uint64_t{300} << 20;
  CHECK(runtime::pass_pair_limit(gib, held, 17, 1024).value() == (gib - held) / 17);
  // A budget larger than the sort can take still stops at its limit.
  CHECK(runtime::pass_pair_limit(uint64_t{1} << 40, held, 16, 1024).value() == kMaxPassPairs);
  // Too little room: an error that names the budget and what the scene holds.
  const auto tight = runtime::pass_pair_limit(held + 1000 * 16, held, 16, 1024);
  REQUIRE_FALSE(tight.ok());
  CHECK(tight.status().code() == StatusCode::kLimitExceeded);
  CHECK(tight.status().message().find(std::to_string(held)) != std::string::npos);
  CHECK_FALSE(runtime::pass_pair_limit(held / 2, held, 16, 1024).ok());
}

TEST_CASE("tile groups: consecutive rows covering the grid once, sized for 4/5 of the limit, at least two") {
  using runtime::TileRows;
  const auto check_cover = [](const std::vector<TileRows>& groups, TileRows rows) {
    REQUIRE_FALSE(groups.empty());
    CHECK(groups.front().begin == rows.begin);
    CHECK(groups.back().end == rows.end);
    for (size_t i = 0; i < groups.size(); ++i) {
      CHECK(groups[i].size() >= 1);
      if (i > 0) CHECK(groups[i].begin == groups[i - 1].end);
    }
  };
  // 8K (270 tile rows), 2^31 - 1 pairs a pass: 2.5 billion pairs fill 2 groups of 4/5 of the limit, 3.5 billion 3.
  const TileRows rows8k{0, 270};
  const auto g = runtime::plan_tile_groups(rows8k, 2500000000u, runtime::kMaxPassPairs);
  CHECK(g.size() == 2);
  check_cover(g, rows8k);
  const auto g3 = runtime::plan_tile_groups(rows8k, 3500000000u, runtime::kMaxPassPairs);
  CHECK(g3.size() == 3);
  check_cover(g3, rows8k);
  CHECK(g3[0] == TileRows{0, 90});
  // Just over the limit: still two groups; a sub-range (a group being split again) stays inside itself.
  const TileRows middle{40, 47};
  const auto halves = runtime::plan_tile_groups(middle, 1001, 1000);
  CHECK(halves.size() == 2);
  check_cover(halves, middle);
  // No more groups than rows: one row each; a single row cannot be split (the renderer reports it).
  const auto rows_each = runtime::plan_tile_groups(TileRows{0, 5}, 1000000, 10);
  CHECK(rows_each.size() == 5);
  check_cover(rows_each, TileRows{0, 5});
  CHECK(runtime::plan_tile_groups(TileRows{3, 4}, 1000000, 10).size() == 1);
}

}  // namespace
}  // namespace rgs::test
