// Level-of-detail builder in memory (format/SPEC.md §4.9): octree chunks, nested grid levels, moment-matched
// parents; the building blocks are internal_lod_chunks.h's.
//
// Plan: (1) Morton-sort every mean on a grid over the scene's cube and cut the sorted order into octree
// leaves (the chunks). (2) Per chunk, in parallel: re-sort its Gaussians by Morton code on a grid over the
// chunk's own cube; one pass over adjacent codes gives the number of cells at every grid size, from which
// each level's grid follows. (3) Choose L, lay out the level-major ranges and size the output once.
// (4) Per chunk, in parallel: copy level 0, then merge each level's cells into the next level's parents,
// reading the children back from the output (so parents are exactly the merge of the stored children).
//
// Determinism: every chunk's output depends only on its own Gaussians, and the only cross-chunk reductions
// are integer sums and the bounds' min/max, so the bytes do not depend on the number of threads.
#include "rgs/converter/lod_builder.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "internal_huge_pages.h"
#include "internal_lod_chunks.h"
#include "internal_parallel.h"

namespace rgs::converter {
namespace {

using namespace detail;

Status check_inputs(const format::EncodedScene& scene, const LodBuildOptions& options) {
  RGS_RETURN_ERROR_IF(!scene.is_consistent(), StatusCode::kInvalidArgument,
                      "build_lod: scene arrays do not match its count and SH degree");
  RGS_RETURN_ERROR_IF(scene.count == 0, StatusCode::kInvalidArgument, "build_lod: the scene has no Gaussians");
  RGS_RETURN_ERROR_IF(options.levels > format::kMaxLodLevels, StatusCode::kInvalidArgument,
                      "build_lod: " + std::to_string(options.levels) + " levels exceed the format's " +
                          std::to_string(format::kMaxLodLevels));
  RGS_RETURN_ERROR_IF(options.max_chunk_gaussians == 0, StatusCode::kInvalidArgument,
                      "build_lod: max_chunk_gaussians must be >= 1");
  RGS_RETURN_ERROR_IF(scene.count > kMaxOutputGaussians, StatusCode::kLimitExceeded,
                      "build_lod: " + std::to_string(scene.count) + " Gaussians exceed 2^31 - 1");
  const auto encoding = scene.metadata.scale_encoding;
  RGS_RETURN_ERROR_IF(encoding != format::ScaleEncoding::kLinear && encoding != format::ScaleEncoding::kLog,
                      StatusCode::kInvalidArgument,
                      "build_lod: unknown scale encoding " + std::to_string(static_cast<int>(encoding)));
  return Status();
}

/// Step 1, the chunks: Morton sort over the scene's cube, octree leaves of at most max_chunk_gaussians.
Result<MortonOrder> sort_into_chunks(const format::EncodedScene& in, uint64_t max_chunk_gaussians, unsigned workers) {
  const uint64_t n0 = in.count;
  MortonOrder order;
  for (int a = 0; a < 3; ++a) order.box_lo[a] = order.box_hi[a] = in.means[static_cast<size_t>(a)];
  for (uint64_t i = 0; i < n0; ++i) {
    for (int a = 0; a < 3; ++a) {
      order.box_lo[a] = std::min(order.box_lo[a], in.means[i * 3 + a]);
      order.box_hi[a] = std::max(order.box_hi[a], in.means[i * 3 + a]);
    }
  }
  std::vector<uint64_t>& keys = order.keys;
  std::vector<uint32_t>& index = order.index;
  detail::resize_huge(keys, n0);
  detail::resize_huge(index, n0);
  const MortonGrid grid(order.box_lo, order.box_hi);
  RGS_RETURN_IF_ERROR(detail::parallel_slices(n0, parallel::worker_count(n0, 65536, workers), [&](unsigned, uint64_t b, uint64_t e) {
    for (uint64_t i = b; i < e; ++i) {
      keys[i] = grid.code(&in.means[i * 3]);
      index[i] = static_cast<uint32_t>(i);
    }
  }));
  {
    std::vector<uint64_t> tmp_keys;
    std::vector<uint32_t> tmp_index;
    detail::resize_huge(tmp_keys, n0);
    detail::resize_huge(tmp_index, n0);
    radix_sort(keys.data(), index.data(), n0, tmp_keys.data(), tmp_index.data());
  }
  split_node(keys.data(), 0, n0, 0, max_chunk_gaussians, &order.leaves);
  return order;
}

/// Where each record's range starts: first[l·C + c].
struct Layouts {
  uint32_t chunks = 0, levels = 0;
  std::vector<uint64_t> first;
  uint64_t at(uint32_t level, uint32_t chunk) const { return first[static_cast<size_t>(level) * chunks + chunk]; }
};

/// Step 3, the output's first index of each (level, chunk) range: levels coarse after fine, chunks in order.
Layouts lay_out_ranges(const std::vector<ChunkPlan>& plans, uint32_t levels) {
  const auto chunk_count = static_cast<uint32_t>(plans.size());
  Layouts ranges;
  ranges.chunks = chunk_count;
  ranges.levels = levels;
  ranges.first.resize(static_cast<size_t>(levels) * chunk_count);
  uint64_t offset = 0;
  for (uint32_t l = 0; l < levels; ++l) {
    for (uint32_t c = 0; c < chunk_count; ++c) {
      ranges.first[static_cast<size_t>(l) * chunk_count + c] = offset;
      offset += plans[c].count[l];
    }
  }
  return ranges;
}

/// Step 3, the output scene's metadata and arrays of `total` Gaussians, and an LOD index of the given shape.
void allocate_output(const format::EncodedScene& in, const Layout& t, uint32_t levels, uint32_t chunk_count,
                     uint64_t total, LodScene* result) {
  format::EncodedScene& out = result->scene;
  out.metadata = in.metadata;
  out.provenance = in.provenance;
  out.provenance.emplace_back("lod_levels", std::to_string(levels));
  out.provenance.emplace_back("lod_chunks", std::to_string(chunk_count));
  out.count = total;
  detail::resize_huge(out.means, total * 3);
  detail::resize_huge(out.rotations, total * 4);
  detail::resize_huge(out.scales, total * 3);
  detail::resize_huge(out.opacities, total);
  detail::resize_huge(out.sh, total * t.sh_values);
  if (t.dc_residual) detail::resize_huge(out.sh_dc_residual, total * 3);

  format::LodIndex& lod = result->index;
  lod.chunk_count = chunk_count;
  lod.level_count = levels;
  lod.chunks.resize(chunk_count);
  lod.levels.resize(static_cast<size_t>(levels) * chunk_count);
}

/// Step 5: each chunk's bounding radius and levels in the LOD index, and the scene's sphere radius.
Status fill_lod_index(const std::vector<ChunkPlan>& plans, const std::vector<ChunkReach>& reaches,
                      const Layouts& ranges, LodScene* result) {
  format::LodIndex& lod = result->index;
  double scene_d2 = 0;
  for (uint32_t c = 0; c < lod.chunk_count; ++c) {
    scene_d2 = std::max(scene_d2, reaches[c].scene_d2_over(lod.level_count));
    RGS_ASSIGN_OR_RETURN(lod.chunks[c].radius, chunk_radius(reaches[c], lod.level_count, c));
    for (uint32_t l = 0; l < lod.level_count; ++l) {
      format::LodLevel& level = lod.at(l, c);
      level.first = ranges.at(l, c);
      level.count = plans[c].count[l];
      level.error = plans[c].error[l];
      level.checksum = 0;
    }
  }
  result->scene.metadata.bounds.sphere_radius = format::sphere_radius_for(scene_d2);
  return Status();
}

Result<LodScene> build(const format::EncodedScene& in, const LodBuildOptions& options) {
  const uint64_t n0 = in.count;
  const unsigned workers = parallel::thread_count(options.threads);
  Progress progress(options.progress, 3 * n0);

  RGS_ASSIGN_OR_RETURN(MortonOrder order, sort_into_chunks(in, options.max_chunk_gaussians, workers));
  const auto chunk_count = static_cast<uint32_t>(order.leaves.size());
  progress.add(n0 / 2);
  progress.report();

  const uint32_t planned_levels = options.levels == 0 ? kAutoMaxLevels : options.levels;
  std::vector<Scratch> scratch(workers);
  RGS_ASSIGN_OR_RETURN(std::vector<ChunkPlan> plans,
                       plan_chunks(in, planned_levels, workers, &order, &scratch, &progress));

  uint64_t totals[format::kMaxLodLevels] = {};
  const uint32_t levels = choose_level_count(plans, planned_levels, options, n0, totals);
  uint64_t total = 0;
  for (uint32_t l = 0; l < levels; ++l) total += totals[l];
  RGS_RETURN_ERROR_IF(total > kMaxOutputGaussians, StatusCode::kLimitExceeded,
                      "build_lod: " + std::to_string(levels) + " levels of " + std::to_string(n0) +
                          " Gaussians make " + std::to_string(total) + ", more than 2^31 - 1");
  const Layouts ranges = lay_out_ranges(plans, levels);
  const Layout t = describe_layout(in);
  LodScene result;
  allocate_output(in, t, levels, chunk_count, total, &result);

  // Scene bounds by compute_bounds()' rule over every output mean: parents are clamped into their chunk's
  // AABB, so the AABB is the input means' (box_lo, box_hi); the sphere's centre follows from it and its
  // radius from the largest distance, measured per chunk below.
  format::SceneBounds& bounds = result.scene.metadata.bounds;
  for (int a = 0; a < 3; ++a) {
    bounds.aabb_min[a] = order.box_lo[a];
    bounds.aabb_max[a] = order.box_hi[a];
  }
  double scene_center[3];
  format::set_sphere_center(&bounds, scene_center);

  // 4. Per chunk: level 0 copied, coarser levels merged, sphere.
  std::vector<ChunkReach> reaches(chunk_count);
  RGS_RETURN_IF_ERROR(detail::parallel_items(chunk_count, workers, [&](unsigned worker, uint64_t c) {
    const ChunkPlan& plan = plans[c];
    format::LodChunk& chunk = result.index.chunks[c];
    double center[3];
    chunk_center(plan, chunk.center, center);
    uint64_t first[format::kMaxLodLevels];
    for (uint32_t l = 0; l < levels; ++l) first[l] = ranges.at(l, static_cast<uint32_t>(c));
    reaches[c] = build_chunk(in, order.index.data(), order.keys.data(), plan, first, levels, t, center, scene_center,
                             &scratch[worker], &result.scene);
    progress.add(2 * (plan.end - plan.begin));
    if (worker == 0) progress.report();
  }));
  RGS_RETURN_IF_ERROR(fill_lod_index(plans, reaches, ranges, &result));
  progress.finish();
  return result;
}

}  // namespace

Result<LodScene> build_lod(const format::EncodedScene& scene, const LodBuildOptions& options) {
  RGS_RETURN_IF_ERROR(check_inputs(scene, options));
  try {
    return build(scene, options);
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory,
                  "build_lod: out of memory building the levels of " + std::to_string(scene.count) + " Gaussians");
  }
}

}  // namespace rgs::converter
