// GPU RoofGS pipeline: term-by-term agreement with the CPU reference's RoofGS mode, structural
// identities (fused = separate stages, 32-bit key + depth order = baseline at 1080p, 4K and 8K, frames
// deterministic), and quality against the GPU baseline.
//
// Tolerances against the CPU reference (same RoofgsOptions, same dequantized values):
// - The kernels are compiled with --fmad=false, so everything before blending (projection, conic, SnugBox,
//   AccuTile walk, depth bins, keys, folded coefficients) is the CPU's arithmetic bit for bit, except ln o
//   (device logf vs libm logf, ≤ 1 ulp), without the fast exp expf (≤ 2 ulp), and with binary16 blending the
//   device's exp2, whose α is the host's but where 2^v lies within its error of a rounding boundary (one
//   binary16 unit then). Pair counts must therefore be equal exactly.
// - A last-bit change of α can flip the 1/255 skip (a pixel changes by ≤ α·T·|c| ≤ (1/255)·1.0 ≈ 0.004 for
//   colours ≤ 1; SH colours reach ~1.5, so ≤ 0.006) or the T < 1e-4 stop (≤ 1e-4·|c|), and later
//   Gaussians of that pixel then see a T changed by the same relative amount. Bound: max |Δ| ≤ 0.02 per
//   channel, PSNR ≥ 70 dB (measured: see the MESSAGE lines).
// Quality against the GPU baseline: the CPU-measured budgets of tests/runtime/test_render_real.cpp.
// Every RoofGS configuration here renders with the lab's stages (lab::roofgs_stages()), which launch the
// product's kernels for the presets' variants.
#include <algorithm>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "gpu_test_util.h"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/runtime/device_buffer.h"
#include "rgs/lab/roofgs_stages.h"
#include "rgs/lab/technique_options.h"
#include "zero_opacity_scene.h"

namespace rgs::test {
namespace {

using runtime::Camera;
using runtime::GpuRenderOptions;
using runtime::RoofgsOptions;

/// Flowers quantized in memory into the .rgs runtime profile: the GPU reads the compact sections, the CPU
/// renders their dequantized values (the same numbers).
struct CompactFlowers {
  bool available = false;
  CompactScene compact;
  std::string cameras_path;
};

const CompactFlowers& compact_flowers() {
  static const CompactFlowers scene = [] {
    CompactFlowers s;
    const GpuScenePair& fp32 = flowers_fp32();
    if (!fp32.available) return s;
    s.compact = make_compact(fp32.cloud, false);
    s.cameras_path = fp32.cameras_path;
    s.available = true;
    return s;
  }();
  return scene;
}

/// The compact flowers scene uploaded to the GPU, and a renderer for it.
struct Rig {
  runtime::GpuScene scene;
  runtime::GpuRenderer renderer;
};

Rig make_rig(const CompactFlowers& flowers) {
  auto scene = runtime::GpuScene::from_rgs(*flowers.compact.file);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  return Rig{std::move(scene).value(), std::move(renderer).value()};
}

GpuRenderOptions roofgs_options(const RoofgsOptions& techniques, bool compact = true, bool fused = true) {
  return lab::gpu_technique_options(techniques, compact, fused);
}

struct Mode {
  std::string name;
  RoofgsOptions techniques;
};

std::vector<Mode> modes() {
  std::vector<Mode> m;
  m.push_back({"compact only", RoofgsOptions{}});
  RoofgsOptions o;
  o.key32 = true;
  m.push_back({"32-bit key", o});
  o = {};
  o.snugbox_accutile = true;
  m.push_back({"SnugBox+AccuTile", o});
  o = {};
  o.folded_coefficients = true;
  m.push_back({"folded + dual pixel", o});
  o = {};
  o.fast_exp = true;
  m.push_back({"fast exp", o});
  m.push_back({"all four", RoofgsOptions::all()});
  o = RoofgsOptions::all();
  o.depth_order = true;
  o.fast_exp_sigma = kernels::kFastExpSigmaZeroMean;
  m.push_back({"all four + depth order, sigma 0.05798", o});
  o.half_blend = true;
  m.push_back({"all four + depth order + half blend", o});
  // Chunks of at least 64 pairs: nearly every flowers tile is blended by several chunk blocks and merged.
  o.tile_chunk_pairs = 64;
  m.push_back({"all four + depth order + half blend, chunks of >= 64 pairs", o});
  return m;
}

TEST_CASE("GPU RoofGS agrees with the CPU reference's RoofGS mode, technique by technique (flowers, 628x414)") {
  if (!have_gpu()) return;
  const CompactFlowers& scene = compact_flowers();
  if (!scene.available) return;
  Rig rig = make_rig(scene);
  const std::vector<Camera> cams = flowers_cameras(scene.cameras_path, 60, 628, 414);  // cameras 0, 60, 120
  for (const Mode& mode : modes()) {
    CAPTURE(mode.name);
    for (const Camera& cam : cams) {
      CAPTURE(cam.name);
      runtime::RenderOptions cpu_options;
      cpu_options.scene_bounds = scene.compact.bounds;
      cpu_options.roofgs = mode.techniques;
      auto cpu = runtime::render_cpu(scene.compact.dequantized, cam, cpu_options);
      REQUIRE_MESSAGE(cpu.ok(), cpu.status().to_string());
      for (bool fused : {true, false}) {
        CAPTURE(fused);
        const GpuFrame gpu =
            render_gpu(rig.renderer, rig.scene, cam, roofgs_options(mode.techniques, true, fused), false);
        const Diff d = compare_rgb(gpu.rgba, cpu->rgb);
        MESSAGE(mode.name << std::string(fused ? " fused" : " separate") << ", " << cam.name << ": PSNR " << d.psnr
                          << " dB, max |diff| " << d.max_abs << ", pairs " << gpu.stats.pairs);
        CHECK_FALSE(d.any_nan);
        CHECK(gpu.stats.pairs == cpu->stats.pairs);
        CHECK(d.max_abs <= 0.02);
        CHECK(d.psnr >= 70.0);
      }
    }
  }
}

TEST_CASE("a Gaussian of opacity 0 changes no pixel on the GPU: the scene without it renders the same bits") {
  // The archive profile leaves out the Gaussians whose opacity code is 0 (format/SPEC.md §3.3.2): guitar_sh3
  // with every third opacity set to 0 renders as guitar_sh3 without those Gaussians, in every mode, bit for
  // bit (the CPU reference's counterpart is in tests/runtime).
  if (!have_gpu()) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const GpuScenePair full = guitar_sh3(3);
  const ZeroOpacityScene s = zero_opacity_scene(full.cloud, 3);
  // FP32 attributes and the same bounds on both sides (quantizing each would give each its own SH scales).
  auto scene_a = runtime::GpuScene::from_cloud(s.with_zeros, full.bounds);
  auto scene_b = runtime::GpuScene::from_cloud(s.without, full.bounds);
  REQUIRE_MESSAGE(scene_a.ok(), scene_a.status().to_string());
  REQUIRE_MESSAGE(scene_b.ok(), scene_b.status().to_string());
  auto cams = runtime::orbit_cameras(full.bounds, 2, 628, 414);
  REQUIRE(cams.ok());
  for (const Mode& mode : modes()) {
    CAPTURE(mode.name);
    for (const Camera& cam : *cams) {
      const GpuFrame with = render_gpu(*renderer, *scene_a, cam, roofgs_options(mode.techniques, false), false);
      const GpuFrame wo = render_gpu(*renderer, *scene_b, cam, roofgs_options(mode.techniques, false), false);
      CHECK(with.rgba == wo.rgba);
    }
  }
}

TEST_CASE("the product's stages refuse what no preset uses, the lab's render it and the presets' variants alike") {
  // Without GpuRenderOptions::stages the renderer has the product's launches: the separate stages and the
  // render kernel's lab variants are refused with kUnsupportedFeature before any launch; with the lab's stages
  // they render, and a configuration of the presets renders the same bits through either.
  if (!have_gpu()) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const GpuScenePair guitar = guitar_sh3(1);
  auto scene = runtime::GpuScene::from_cloud(guitar.cloud, guitar.bounds);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto cams = runtime::orbit_cameras(guitar.bounds, 1, 160, 90);
  REQUIRE(cams.ok());
  const Camera& cam = (*cams)[0];
  runtime::DeviceImage image;
  RoofgsOptions folded_only;
  folded_only.folded_coefficients = true;
  GpuRenderOptions separate = roofgs_options(RoofgsOptions::all(), false, false);
  GpuRenderOptions lab_variant = roofgs_options(folded_only, false);
  for (GpuRenderOptions* o : {&separate, &lab_variant}) {
    GpuRenderOptions product = *o;
    product.stages = {};
    const auto refused = renderer->render(*scene, cam, product, &image);
    CHECK(refused.status().code() == StatusCode::kUnsupportedFeature);
    const auto rendered = renderer->render(*scene, cam, *o, &image);
    CHECK_MESSAGE(rendered.ok(), rendered.status().to_string());
  }
  RoofgsOptions preset = RoofgsOptions::all();
  preset.half_blend = true;
  GpuRenderOptions with_lab = roofgs_options(preset, false);
  GpuRenderOptions with_product = with_lab;
  with_product.stages = {};
  const GpuFrame a = render_gpu(*renderer, *scene, cam, with_lab, false);
  const GpuFrame b = render_gpu(*renderer, *scene, cam, with_product, false);
  CHECK(a.rgba == b.rgba);
}

TEST_CASE("GPU RoofGS agrees with the CPU reference term by term at SH 1, 2 and 3 (shipped guitar_sh3, 628x414)") {
  // The shipped SH-3 scene (tests/data/guitar_sh3.ply) quantized in memory into the runtime profile, at each SH
  // degree: every technique, compact (INT8 SH dequantized in registers) and FP32 attributes, fused and separate
  // stages, against the CPU reference's RoofGS mode on the dequantized values. Sorted pairs must equal the
  // CPU's TileBins exactly; images within the bounds at the top (a wrong band moves colours by more than
  // 0.02: the runtime suite asserts that each band does).
  if (!have_gpu()) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  for (const uint32_t degree : {1u, 2u, 3u}) {
    CAPTURE(degree);
    const GpuScenePair fp32 = guitar_sh3(degree);
    const CompactScene compact = make_compact(fp32.cloud, false);
    REQUIRE(compact.dequantized.sh_degree == degree);
    auto scene = runtime::GpuScene::from_rgs(*compact.file);
    REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
    auto cams = runtime::orbit_cameras(compact.bounds, 3, 628, 414);
    REQUIRE(cams.ok());
    double worst_psnr = std::numeric_limits<double>::infinity(), worst_diff = 0;
    for (const Mode& mode : modes()) {
      CAPTURE(mode.name);
      runtime::RenderOptions cpu_options;
      cpu_options.scene_bounds = compact.bounds;
      cpu_options.roofgs = mode.techniques;
      for (const Camera& cam : *cams) {
        CAPTURE(cam.name);
        auto cpu = runtime::render_cpu(compact.dequantized, cam, cpu_options);
        REQUIRE_MESSAGE(cpu.ok(), cpu.status().to_string());
        auto setup = runtime::setup_frame(compact.dequantized, cam, cpu_options);
        REQUIRE_MESSAGE(setup.ok(), setup.status().to_string());
        runtime::RenderStats cpu_stats;
        const auto projected = runtime::preprocess_cpu(compact.dequantized, cam, *setup, cpu_options, &cpu_stats);
        auto bins = runtime::bin_and_sort_cpu(projected, *setup, cpu_options);
        REQUIRE_MESSAGE(bins.ok(), bins.status().to_string());
        for (const bool compact_attributes : {true, false}) {
          for (const bool fused : {true, false}) {
            CAPTURE(compact_attributes);
            CAPTURE(fused);
            const GpuFrame gpu = render_gpu(*renderer, *scene, cam,
                                            roofgs_options(mode.techniques, compact_attributes, fused), false);
            const Diff d = compare_rgb(gpu.rgba, cpu->rgb);
            worst_psnr = std::min(worst_psnr, d.psnr);
            worst_diff = std::max(worst_diff, d.max_abs);
            CHECK_FALSE(d.any_nan);
            CHECK(gpu.stats.pairs == cpu->stats.pairs);
            CHECK(d.max_abs <= 0.02);
            CHECK(d.psnr >= 70.0);
            std::vector<uint64_t> keys;
            std::vector<uint32_t> values;
            const Status downloaded = renderer->download_sorted_pairs(&keys, &values);
            REQUIRE_MESSAGE(downloaded.ok(), downloaded.to_string());
            CHECK(keys == bins->keys);
            CHECK(values == bins->values);
          }
        }
      }
    }
    MESSAGE("guitar_sh3 at SH " << degree << ", " << modes().size() << " modes x " << cams->size()
                                << " views x 4 variants: worst PSNR " << worst_psnr << " dB, max |diff| "
                                << worst_diff);
  }
}

TEST_CASE(
    "fused and separate stages, and balanced and one-thread emission, give the same bytes, frames are deterministic") {
  if (!have_gpu()) return;
  const CompactFlowers& scene = compact_flowers();
  if (!scene.available) return;
  Rig rig = make_rig(scene);
  const Camera cam = flowers_cameras(scene.cameras_path, 1000, 1920, 1080)[0];
  for (const Mode& mode : modes()) {
    CAPTURE(mode.name);
    const GpuFrame fused = render_gpu(rig.renderer, rig.scene, cam, roofgs_options(mode.techniques, true, true), false);
    const GpuFrame again = render_gpu(rig.renderer, rig.scene, cam, roofgs_options(mode.techniques, true, true), false);
    const GpuFrame separate =
        render_gpu(rig.renderer, rig.scene, cam, roofgs_options(mode.techniques, true, false), false);
    GpuRenderOptions one_thread_each = roofgs_options(mode.techniques);
    one_thread_each.lab_techniques->roofgs.balanced_emission = false;
    const GpuFrame unbalanced = render_gpu(rig.renderer, rig.scene, cam, one_thread_each, false);
    CHECK(same_bits(fused.rgba, again.rgba));
    CHECK(same_bits(fused.rgba, separate.rgba));
    CHECK(same_bits(fused.rgba, unbalanced.rgba));
    CHECK(fused.stats.pairs == separate.stats.pairs);
    CHECK(fused.stats.pairs == unbalanced.stats.pairs);
  }
}

TEST_CASE(
    "sub-tile culling with SnugBox + AccuTile: the same bytes, with half blending the same alpha and depth "
    "(flowers at 1080p and 4K, daffodils at 4K)") {
  // Each group of 8 lanes of the folded rasterizer skips the pairs whose block_mask clears its 4x4 block; those pairs
  // cannot pass the 1/255 test there, so colour, alpha and depth keep every bit (with half blending alpha and depth;
  // the colour windows move with the lists). Without AccuTile, a 3-sigma rectangle hands needle-like Gaussians tiles
  // ~1,000 px from their mean, where the folded P's FP32 rounding (terms ~1e6) exceeds the mask's margin and lets a
  // pixel pass by rounding alone (flowers camera 0 at 4K: one such pixel of 9 million pairs); the mask, computed
  // without that cancellation, removes it. So folded-only frames may differ in a few pixels, by at most one alpha-1/255
  // contribution.
  if (!have_gpu()) return;
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const auto check_scene = [&](const runtime::GpuScene& scene, const std::vector<Camera>& cams) {
    RoofgsOptions folded_only;
    folded_only.folded_coefficients = true;
    RoofgsOptions plus = RoofgsOptions::all();
    plus.depth_order = true;
    RoofgsOptions plus_half = plus;
    plus_half.half_blend = true;
    for (const RoofgsOptions& techniques : {RoofgsOptions::all(), plus, plus_half, folded_only}) {
      GpuRenderOptions culled = roofgs_options(techniques, scene.has_compact());
      culled.lab_techniques->roofgs.subtile_culling = runtime::SubtileCulling::kOn;
      GpuRenderOptions whole_tile = culled;
      whole_tile.lab_techniques->roofgs.subtile_culling = runtime::SubtileCulling::kOff;
      for (const Camera& cam : cams) {
        CAPTURE(cam.name);
        CAPTURE(cam.width);
        CAPTURE(techniques.snugbox_accutile);
        CAPTURE(techniques.depth_order);
        CAPTURE(techniques.half_blend);
        const GpuFrame a = render_gpu(*renderer, scene, cam, culled, true);
        const GpuFrame b = render_gpu(*renderer, scene, cam, whole_tile, true);
        CHECK(a.stats.subtile_culling);
        CHECK_FALSE(b.stats.subtile_culling);
        CHECK(a.stats.pairs == b.stats.pairs);
        if (techniques.snugbox_accutile && techniques.half_blend) {
          // The colour windows follow the walk lists (half_blend.h), so the colour is grouped differently:
          // binary16 roundings of the windows' sums apart (the CPU reference's lists: flowers camera 0 at 1080p
          // and 4K, max |diff| 0.0011 and 0.0015, 87 and 89 dB). T and the depth sums do not depend on the
          // windows.
          std::vector<float> alpha_a, alpha_b;
          for (size_t i = 3; i < a.rgba.size(); i += 4) alpha_a.push_back(a.rgba[i]), alpha_b.push_back(b.rgba[i]);
          CHECK(same_bits(alpha_a, alpha_b));
          CHECK(same_bits(a.depth, b.depth));
          const Diff d = compare_rgb(a.rgba, rgb_of(b.rgba));
          MESSAGE("half blend, " << cam.name << " " << cam.width << "x" << cam.height << ": max |diff| " << d.max_abs
                                 << ", " << d.psnr << " dB");
          CHECK(d.max_abs <= 1.0 / 255);
          CHECK(d.psnr >= 80.0);
        } else if (techniques.snugbox_accutile) {
          CHECK(same_bits(a.rgba, b.rgba));
          CHECK(same_bits(a.depth, b.depth));
        } else {
          size_t differing = 0;
          for (size_t i = 0; i < a.rgba.size(); i += 4) {
            differing += std::memcmp(&a.rgba[i], &b.rgba[i], 4 * sizeof(float)) != 0;
          }
          const Diff d = compare_rgb(a.rgba, rgb_of(b.rgba));
          MESSAGE("folded only, " << cam.name << " " << cam.width << "x" << cam.height << ": " << differing
                                  << " pixels differ, max |diff| " << d.max_abs);
          CHECK(differing * 100000 <= a.rgba.size() / 4);
          CHECK(d.max_abs <= 0.02);
        }
      }
    }
  };
  // The automatic choice (the default): off where large Gaussians hold most pairs (flowers: 89-92 % at 4K),
  // on where they hold few (daffodils: 5 %).
  const auto automatic = [&](const runtime::GpuScene& scene, const Camera& cam) {
    const GpuFrame frame = render_gpu(*renderer, scene, cam, roofgs_options(RoofgsOptions::all(), true), false);
    MESSAGE(cam.name << " at " << cam.width << "x" << cam.height << ": " << frame.stats.large_pairs << " of "
                     << frame.stats.pairs << " pairs from large Gaussians, sub-tile culling "
                     << std::string(frame.stats.subtile_culling ? "on" : "off"));
    return frame.stats.subtile_culling;
  };
  const GpuScenePair& flowers = flowers_rgs();
  if (flowers.available) {
    std::vector<Camera> cams = flowers_cameras(flowers.cameras_path, 60, 1920, 1080);
    cams.push_back(flowers_cameras(flowers.cameras_path, 1000, 3840, 2160)[0]);
    check_scene(*flowers.gpu, cams);
    CHECK_FALSE(automatic(*flowers.gpu, cams.back()));
  }
  const GpuScenePair& daffodils_scene = daffodils();
  if (daffodils_scene.available) {
    auto cams = runtime::orbit_cameras(daffodils_scene.bounds, 4, 3840, 2160);
    REQUIRE(cams.ok());
    check_scene(*daffodils_scene.gpu, {(*cams)[0], (*cams)[1]});
    CHECK(automatic(*daffodils_scene.gpu, (*cams)[0]));
  }
}

TEST_CASE("sorted pairs equal the CPU reference's, term by term, with large Gaussians emitted in chunks") {
  // Pairs of Gaussians above kSerialTileLimit tiles are written a warp per chunk of their walk (at most
  // kLargeChunkSlices slices and about kLargeChunkPairs pairs; each warp adds up the slices before its chunk);
  // their positions and order must be the serial ones. The keys and values after the stable sort are therefore
  // the CPU's TileBins exactly. Flowers has Gaussians covering the whole grid: at 4K that is 135 tile rows of
  // 240 tiles (a chunk each) and at 8K 270 of 480.
  if (!have_gpu()) return;
  const CompactFlowers& scene = compact_flowers();
  if (!scene.available) return;
  Rig rig = make_rig(scene);
  RoofgsOptions rect_key32;
  rect_key32.key32 = true;
  RoofgsOptions accutile;
  accutile.snugbox_accutile = true;
  RoofgsOptions ordered = RoofgsOptions::all();
  ordered.depth_order = true;
  const std::vector<Mode> cases = {{"32-bit key (rectangles)", rect_key32},
                                   {"SnugBox+AccuTile (64-bit key)", accutile},
                                   {"all four", RoofgsOptions::all()},
                                   {"all four + depth order", ordered}};
  const uint32_t sizes[3][2] = {{1920, 1080}, {3840, 2160}, {7680, 4320}};
  for (const auto& size : sizes) {
    const Camera cam = flowers_cameras(scene.cameras_path, 1000, size[0], size[1])[0];
    CAPTURE(cam.width);
    for (const Mode& mode : cases) {
      CAPTURE(mode.name);
      runtime::RenderOptions cpu_options;
      cpu_options.scene_bounds = scene.compact.bounds;
      cpu_options.roofgs = mode.techniques;
      auto setup = runtime::setup_frame(scene.compact.dequantized, cam, cpu_options);
      REQUIRE_MESSAGE(setup.ok(), setup.status().to_string());
      runtime::RenderStats cpu_stats;
      const auto projected = runtime::preprocess_cpu(scene.compact.dequantized, cam, *setup, cpu_options, &cpu_stats);
      uint32_t largest = 0;
      for (const auto& g : projected) largest = std::max(largest, g.tiles_touched);
      auto bins = runtime::bin_and_sort_cpu(projected, *setup, cpu_options);
      REQUIRE_MESSAGE(bins.ok(), bins.status().to_string());
      // Pairs of the Gaussians above kSubtileLargeTiles tiles: what the preprocess counts for SubtileCulling::kAuto.
      uint64_t large_pairs = 0;
      for (const auto& g : projected) {
        if (g.tiles_touched > kernels::kSubtileLargeTiles) large_pairs += g.tiles_touched;
      }
      const double pairs = double(bins->keys.size());
      const bool auto_subtile = double(large_pairs) <= kernels::kSubtileMaxLargePairFraction * pairs;
      for (bool fused : {true, false}) {
        CAPTURE(fused);
        const GpuFrame frame =
            render_gpu(rig.renderer, rig.scene, cam, roofgs_options(mode.techniques, true, fused), false);
        CHECK(frame.stats.large_pairs == large_pairs);
        CHECK(frame.stats.subtile_culling ==
              (mode.techniques.folded_coefficients && (!mode.techniques.snugbox_accutile || auto_subtile)));
        std::vector<uint64_t> keys;
        std::vector<uint32_t> values;
        const Status downloaded = rig.renderer.download_sorted_pairs(&keys, &values);
        REQUIRE_MESSAGE(downloaded.ok(), downloaded.to_string());
        MESSAGE(mode.name << std::string(fused ? " fused" : " separate") << " at " << cam.width << "x"
                          << cam.height << ": " << keys.size() << " pairs, largest Gaussian " << largest << " tiles");
        CHECK(largest > kernels::kSerialTileLimit);  // the chunked path ran
        REQUIRE(keys.size() == bins->keys.size());
        CHECK(keys == bins->keys);
        CHECK(values == bins->values);
      }
    }
  }
}

TEST_CASE("depth order orders runs of tied keys of every length, across thread blocks, and writes the ranges") {
  // order_equal_keys_by_depth ranks each pair of a run of tied keys over the whole run, wherever the run's
  // ends lie, and writes the tile ranges. Real scenes tie in runs of at most ~15 pairs; here three clusters
  // of Gaussians in front of a 64x64 camera (16 tiles, 28 depth bits over the means' depths [5, 6]: bins of
  // 3.7e-9 units, finer than the float spacing of 4.8e-7 there, so runs are Gaussians of equal float depth)
  // give runs of ~200 (1,000 Gaussians 2e-6 deep; some longer than a 256-thread block), of ~10 (2,000
  // Gaussians 5e-5 deep) and of 1–2 (4,000 Gaussians 3e-3 deep), with indices in no depth order. The frame
  // must also equal the baseline's.
  if (!have_gpu()) return;
  format::GaussianCloud cloud;
  cloud.sh_degree = 0;
  uint32_t hash = 12345;
  const auto next = [&hash] {  // xorshift32 in [0, 1)
    hash ^= hash << 13;
    hash ^= hash >> 17;
    hash ^= hash << 5;
    return float(hash >> 8) / float(1u << 24);
  };
  for (int i = 0; i < 7000; ++i) {
    const float z = i % 7 == 3 ? 6.f + 2e-6f * next() : i % 7 < 3 ? 5.5f + 5e-5f * next() : 5.f + 3e-3f * next();
    add_gaussian(&cloud, 0.02f * (next() - 0.5f), 0.02f * (next() - 0.5f), z, 1.f, 0.5f + 0.4f * next(),
                 next() - 0.5f, next() - 0.5f, next() - 0.5f);
  }
  // Out of view, they widen the scene's bounding sphere; the AABB keeps the depth range at the clusters'.
  add_gaussian(&cloud, -100.f, 0.f, 5.f, 0.1f, 0.5f, 0.f, 0.f, 0.f);
  add_gaussian(&cloud, 100.f, 0.f, 5.f, 0.1f, 0.5f, 0.f, 0.f, 0.f);
  const format::SceneBounds bounds = converter::compute_bounds(cloud);
  auto scene = runtime::GpuScene::from_cloud(cloud, bounds);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  auto renderer = runtime::GpuRenderer::create();
  REQUIRE_MESSAGE(renderer.ok(), renderer.status().to_string());
  const Camera cam = identity_camera(64, 64, 60.f);
  RoofgsOptions key_only;
  key_only.key32 = true;
  key_only.depth_order = true;
  RoofgsOptions all = RoofgsOptions::all();
  all.depth_order = true;
  for (const RoofgsOptions& techniques : {key_only, all}) {
    CAPTURE(techniques.snugbox_accutile);
    runtime::RenderOptions cpu_options;
    cpu_options.scene_bounds = bounds;
    cpu_options.roofgs = techniques;
    auto setup = runtime::setup_frame(cloud, cam, cpu_options);
    REQUIRE_MESSAGE(setup.ok(), setup.status().to_string());
    runtime::RenderStats cpu_stats;
    const auto projected = runtime::preprocess_cpu(cloud, cam, *setup, cpu_options, &cpu_stats);
    auto bins = runtime::bin_and_sort_cpu(projected, *setup, cpu_options);
    REQUIRE_MESSAGE(bins.ok(), bins.status().to_string());
    // Runs of tied keys in the reference: both paths of the pass must be taken.
    size_t longest = 0, short_runs = 0;
    for (size_t a = 0, b = 0; a < bins->keys.size(); a = b) {
      for (b = a + 1; b < bins->keys.size() && bins->keys[b] == bins->keys[a];) ++b;
      longest = std::max(longest, b - a);
      short_runs += b - a > 1 && b - a <= 32;
    }
    const GpuFrame frame = render_gpu(*renderer, *scene, cam, roofgs_options(techniques, false), false);
    std::vector<uint64_t> keys;
    std::vector<uint32_t> values;
    const Status downloaded = renderer->download_sorted_pairs(&keys, &values);
    REQUIRE_MESSAGE(downloaded.ok(), downloaded.to_string());
    MESSAGE("depth order, synthetic runs: " << keys.size() << " pairs, " << short_runs
                                            << " runs of 2-32 tied keys, longest run " << longest);
    CHECK(longest > 256);
    CHECK(short_runs > 100);
    REQUIRE(keys.size() == bins->keys.size());
    CHECK(keys == bins->keys);
    CHECK(values == bins->values);
    if (!techniques.snugbox_accutile) {  // the 32-bit key + depth order alone: the baseline's frame, bit for bit
      const GpuFrame base = render_gpu(*renderer, *scene, cam, GpuRenderOptions{}, false);
      CHECK(same_bits(frame.rgba, base.rgba));
    }
  }
}

TEST_CASE("32-bit pair sort: stable for every policy's count, on counters zeroed ahead or by the sort") {
  // sort_pairs_ping_pong calls CUB's public SortPairs or, built against CCCL 3.0.1, launches CUB's onesweep
  // kernels itself: CUB's own sm_90 policy up to one 384-thread tile per SM, 512-thread tiles up to one per SM,
  // 384 above (kernels/src/sort.cu); the counts straddle those thresholds. Keys take 1,000 values, so runs of
  // equal keys must keep their input order (values are the input positions); the counters are zeroed by
  // clear_sort_counters for a larger capacity, or by the sort itself, on the same scratch in turn. Both paths
  // must give exactly the std::stable_sort result.
  if (!have_gpu()) return;
  MESSAGE("32-bit pair sort: " << std::string(kernels::sort_pairs_ping_pong_tuned()
                                                  ? "tuned onesweep launch (CCCL 3.0.1)"
                                                  : "CUB's public DeviceRadixSort::SortPairs"));
  int sms = 0;
  REQUIRE(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0) == cudaSuccess);
  const uint64_t one_per_sm = uint64_t(sms) * 384 * 23;
  const uint64_t counts[] = {1, 2, 1000, 8832, 8833, one_per_sm, one_per_sm + 1, uint64_t(sms) * 512 * 23 + 5,
                             3000000};
  const uint64_t capacity = 3000000 + 4096;
  SortBuffers buffers(capacity);
  auto& [keys, values, temp, temp_bytes, key_buffers, value_buffers] = buffers;
  int sorted = 0;
  uint32_t hash = 2463534242u;
  for (const uint64_t count : counts) {
    for (const bool zeroed_ahead : {true, false}) {
      CAPTURE(count);
      CAPTURE(zeroed_ahead);
      std::vector<uint32_t> key(count), value(count);
      for (uint64_t i = 0; i < count; ++i) {
        hash ^= hash << 13;
        hash ^= hash >> 17;
        hash ^= hash << 5;
        key[i] = (hash % 1000u) * 4294967u;  // 1,000 distinct keys spread over all 32 bits
        value[i] = uint32_t(i);
      }
      REQUIRE(cudaMemcpy(keys[0].data(), key.data(), count * 4, cudaMemcpyHostToDevice) == cudaSuccess);
      REQUIRE(cudaMemcpy(values[0].data(), value.data(), count * 4, cudaMemcpyHostToDevice) == cudaSuccess);
      if (zeroed_ahead) {
        REQUIRE(kernels::clear_sort_counters(temp.data(), temp_bytes, capacity, 0, 32, nullptr) == cudaSuccess);
      }
      size_t bytes = temp_bytes;
      REQUIRE(kernels::sort_pairs_ping_pong(temp.data(), &bytes, key_buffers, value_buffers, count,
                                            zeroed_ahead ? capacity : count, 0, 32, zeroed_ahead, &sorted,
                                            nullptr) == cudaSuccess);
      REQUIRE(cudaDeviceSynchronize() == cudaSuccess);
      std::vector<uint32_t> got_keys(count), got_values(count);
      REQUIRE(cudaMemcpy(got_keys.data(), key_buffers[sorted], count * 4, cudaMemcpyDeviceToHost) == cudaSuccess);
      REQUIRE(cudaMemcpy(got_values.data(), value_buffers[sorted], count * 4, cudaMemcpyDeviceToHost) == cudaSuccess);
      std::stable_sort(value.begin(), value.end(), [&](uint32_t a, uint32_t b) { return key[a] < key[b]; });
      std::sort(key.begin(), key.end());
      CHECK(got_keys == key);
      CHECK(got_values == value);
    }
  }
  // Counters zeroed for fewer pairs than the sort has, or scratch too small for them: refused, nothing run.
  size_t bytes = temp_bytes;
  CHECK(kernels::sort_pairs_ping_pong(temp.data(), &bytes, key_buffers, value_buffers, 3000000, 1000, 0, 32, true,
                                      &sorted, nullptr) == cudaErrorInvalidValue);
  bytes = 1024;
  CHECK(kernels::sort_pairs_ping_pong(temp.data(), &bytes, key_buffers, value_buffers, 3000000, 3000000, 0, 32, false,
                                      &sorted, nullptr) == cudaErrorInvalidValue);
  CHECK(kernels::clear_sort_counters(temp.data(), 1024, 3000000, 0, 32, nullptr) == cudaErrorInvalidValue);
}

TEST_CASE("32-bit key with depth order renders exactly the baseline's image at 1080p, 4K and 8K") {
  // key32 + depth_order sorts every tile as the 64-bit key does (docs/RENDERER.md), so with everything else
  // off the RoofGS frame must equal the baseline frame bit for bit. At 4K the key has 15 tile bits and at 8K
  // 17: a key that overflowed its tile bits (the public code's 19 fixed depth bits) would scramble tiles.
  if (!have_gpu()) return;
  const CompactFlowers& scene = compact_flowers();
  if (!scene.available) return;
  Rig rig = make_rig(scene);
  RoofgsOptions ordered;
  ordered.key32 = true;
  ordered.depth_order = true;
  const uint32_t sizes[3][2] = {{1920, 1080}, {3840, 2160}, {7680, 4320}};
  const int tile_bits[3] = {13, 15, 17};
  for (int s = 0; s < 3; ++s) {
    const Camera cam = flowers_cameras(scene.cameras_path, 1000, sizes[s][0], sizes[s][1])[0];
    CAPTURE(cam.width);
    const GpuFrame base = render_gpu(rig.renderer, rig.scene, cam, GpuRenderOptions{}, false);
    for (bool compact : {false, true}) {
      CAPTURE(compact);
      const GpuFrame key32 = render_gpu(rig.renderer, rig.scene, cam, roofgs_options(ordered, compact, true), false);
      CHECK(key32.stats.key_tile_bits == tile_bits[s]);
      CHECK(key32.stats.pairs == base.stats.pairs);
      CHECK(same_bits(key32.rgba, base.rgba));
    }
    // Without depth order the key quantizes depth: close to the baseline, not identical.
    RoofgsOptions plain;
    plain.key32 = true;
    const GpuFrame quantized = render_gpu(rig.renderer, rig.scene, cam, roofgs_options(plain, true, true), false);
    const Diff d = compare_rgb(quantized.rgba, rgb_of(base.rgba));
    MESSAGE(cam.width << "x" << cam.height << " 32-bit key without depth order vs baseline: PSNR " << d.psnr);
    CHECK(d.psnr >= 40.0);
  }
}

TEST_CASE("RoofGS quality against the GPU baseline, every 20th flowers camera at 1920x1080") {
  // Quality floors: the paper's combination mean ≥ 48 dB, min ≥ 45 dB; with depth order and σ = 0.05798
  // (beyond the paper) mean ≥ 50, min ≥ 48; with binary16 blending, whose α is 2^v rounded to binary16,
  // mean ≥ 60, min ≥ 58. Against the FP32 baseline of the PLY itself.
  if (!have_gpu()) return;
  const CompactFlowers& scene = compact_flowers();
  if (!scene.available) return;
  const runtime::GpuScene& fp32_scene = *flowers_fp32().gpu;
  Rig rig = make_rig(scene);
  const std::vector<Camera> cams = flowers_cameras(scene.cameras_path, 20, 1920, 1080);
  RoofgsOptions better = RoofgsOptions::all();
  better.depth_order = true;
  better.fast_exp_sigma = kernels::kFastExpSigmaZeroMean;
  struct Target {
    std::string name;
    RoofgsOptions techniques;
    double mean, min;
  };
  RoofgsOptions better_half = better;
  better_half.half_blend = true;
  const Target targets[3] = {{"paper (all four, sigma 0.045677)", RoofgsOptions::all(), 48.0, 45.0},
                             {"RoofGS+ (all four, depth order, sigma 0.05798)", better, 50.0, 48.0},
                             {"RoofGS+ with half-precision blending", better_half, 60.0, 58.0}};
  for (const Target& target : targets) {
    CAPTURE(target.name);
    double sum = 0, min = std::numeric_limits<double>::infinity();
    for (const Camera& cam : cams) {
      const GpuFrame base = render_gpu(rig.renderer, fp32_scene, cam, GpuRenderOptions{}, false);
      const GpuFrame fast = render_gpu(rig.renderer, rig.scene, cam, roofgs_options(target.techniques), false);
      const double p = compare_rgb(fast.rgba, rgb_of(base.rgba)).psnr;
      sum += p;
      min = std::min(min, p);
    }
    const double mean = sum / double(cams.size());
    MESSAGE(target.name << ": PSNR vs FP32 baseline over " << cams.size() << " views: mean " << mean << " dB, min "
                        << min << " dB");
    CHECK(mean >= target.mean);
    CHECK(min >= target.min);
  }
}

}  // namespace
}  // namespace rgs::test
