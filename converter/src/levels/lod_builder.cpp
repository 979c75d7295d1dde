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

#include "../internal_huge_pages.h"
#include "internal_lod_chunks.h"
#include "../internal_parallel.h"

namespace rgs::converter {
namespace {

using namespace detail;

Status check_inputs(const format::EncodedScene& scene, const LodBuildOptions& options) {
  RGS_RETURN_ERROR_IF(!scene.is_consistent(), StatusCode::kInvalidArgument,
                      "build_lod: scene arrays do not match its count and SH degree");
  RGS_RETURN_IF_ERROR(check_lod_request(scene.count, options));
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
  RGS_RETURN_IF_ERROR(sort_by_morton(in, MortonGrid(order.box_lo, order.box_hi), workers, &order));
  split_node(order.keys.data(), 0, n0, 0, max_chunk_gaussians, &order.leaves);
  return order;
}

/// Step 3, the output scene's metadata and arrays of `total` Gaussians.
void allocate_output(const format::EncodedScene& in, const Layout& t, uint32_t levels, uint32_t chunk_count,
                     uint64_t total, format::EncodedScene* out) {
  out->metadata = in.metadata;
  out->provenance = in.provenance;
  out->provenance.emplace_back("lod_levels", std::to_string(levels));
  out->provenance.emplace_back("lod_chunks", std::to_string(chunk_count));
  out->count = total;
  detail::resize_huge(out->means, total * 3);
  detail::resize_huge(out->rotations, total * 4);
  detail::resize_huge(out->scales, total * 3);
  detail::resize_huge(out->opacities, total);
  detail::resize_huge(out->sh, total * t.sh_values);
  if (t.dc_residual) detail::resize_huge(out->sh_dc_residual, total * 3);
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

  RGS_ASSIGN_OR_RETURN(const LevelChoice choice, choose_levels(plans, planned_levels, options, n0));
  const uint32_t levels = choice.levels;
  const Layout t = describe_layout(in);
  LodScene result;
  result.index = lay_out_index(plans, levels);
  allocate_output(in, t, levels, chunk_count, choice.total, &result.scene);

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
    for (uint32_t l = 0; l < levels; ++l) first[l] = result.index.at(l, static_cast<uint32_t>(c)).first;
    reaches[c] = build_chunk(in, order.index.data(), order.keys.data(), plan, first, levels, t, center, scene_center,
                             &scratch[worker], &result.scene);
    progress.add(2 * (plan.end - plan.begin));
    if (worker == 0) progress.report();
  }));
  // 5. Each chunk's bounding radius, and the scene's.
  RGS_ASSIGN_OR_RETURN(bounds.sphere_radius, set_chunk_radii(reaches, &result.index));
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
