// The GPU frame plan on the host: the decisions of each preset's configuration, the automatic sub-tile culling
// and chunking rules at their thresholds, the errors, and the key layout the CPU reference uses too.
#include <doctest/doctest.h>

#include <cstdint>
#include <optional>

#include "render_test_util.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/runtime/frame_plan.h"

namespace rgs::test {
namespace {

namespace k = rgs::kernels;
using runtime::GpuRoofgsOptions;
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

/// The options of the fastest preset (api::gpu_render_options(kFastest)): every technique, depth order,
/// binary16 blending, long tiles in chunks.
GpuRoofgsOptions fastest() {
  GpuRoofgsOptions o;
  o.techniques = RoofgsOptions::all();
  o.techniques.depth_order = true;
  o.techniques.half_blend = true;
  o.techniques.tile_chunk_pairs = k::kTileChunkPairs;
  return o;
}

TEST_CASE("frame plan: the fastest preset's frame at 1080p") {
  const runtime::Camera camera = identity_camera(1920, 1080, 1000.f);
  auto plan = runtime::plan_frame(fastest(), camera, unit_sphere_at(5.f), true);
  REQUIRE_MESSAGE(plan.ok(), plan.status().to_string());
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
  runtime::RenderOptions cpu;
  cpu.roofgs = fastest().techniques;
  cpu.scene_bounds = unit_sphere_at(5.f);
  format::GaussianCloud cloud;
  add_gaussian(&cloud, 0.f, 0.f, 5.f, 0.1f, 0.5f, 0.f, 0.f, 0.f);
  auto setup = runtime::setup_frame(cloud, camera, cpu);
  REQUIRE(setup.ok());
  CHECK(setup->key.depth_bits == plan->key.depth_bits);
  CHECK(setup->key.cull_z_min == plan->switches.cull_z_min);
  CHECK(setup->key.cull_z_max == plan->switches.cull_z_max);
}

TEST_CASE("frame plan: without the 32-bit key the sort covers the tile bits and the exact depth") {
  GpuRoofgsOptions o;
  o.techniques = RoofgsOptions{};
  o.compact_attributes = false;
  // 3840×2160: 240×135 = 32,400 tiles → 15 tile bits above the 32 depth bits.
  auto plan = runtime::plan_frame(o, identity_camera(3840, 2160, 2000.f), std::nullopt, false);
  REQUIRE_MESSAGE(plan.ok(), plan.status().to_string());
  CHECK_FALSE(plan->switches.key32);
  CHECK(plan->sort_bits == 47);
  CHECK_FALSE(plan->reorder_ties);
  CHECK(plan->allocation == k::PairAllocation::kBlockOrder);
  // Depth order without the 32-bit key changes nothing in the plan: the 64-bit key holds the depth.
  o.techniques.depth_order = true;
  auto same = runtime::plan_frame(o, identity_camera(3840, 2160, 2000.f), std::nullopt, false);
  REQUIRE(same.ok());
  CHECK_FALSE(same->reorder_ties);
}

TEST_CASE("frame plan: what cannot be planned") {
  const runtime::Camera camera = identity_camera(640, 360, 500.f);
  GpuRoofgsOptions o = fastest();
  // Compact attributes of a scene uploaded from a float cloud.
  CHECK(runtime::plan_frame(o, camera, unit_sphere_at(5.f), false).status().code() == StatusCode::kInvalidArgument);
  // The 32-bit key without bounds.
  CHECK(runtime::plan_frame(o, camera, std::nullopt, true).status().code() == StatusCode::kInvalidArgument);
  // σ of the fast exp outside [0, 1).
  o.techniques.fast_exp_sigma = 1.f;
  CHECK(runtime::plan_frame(o, camera, unit_sphere_at(5.f), true).status().code() == StatusCode::kInvalidArgument);
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
  GpuRoofgsOptions paper;
  paper.techniques = RoofgsOptions::all();
  paper.subtile_culling = SubtileCulling::kOff;
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

}  // namespace
}  // namespace rgs::test
