// The level-of-detail builder (format/SPEC.md §4.9, lod_builder.h): octree chunks, nested grid levels,
// moment-matched parents; the building blocks are internal_lod_chunks.h's.
//
// One builder for both memory modes: the scene comes in partitions (the scene itself in memory; buckets of
// partition files out of core, lod_out_of_core.cpp), each Morton-sorted and cut into octree chunks. Per chunk, in
// parallel: its Gaussians re-sorted by Morton code on a grid over the chunk's own cube, one pass over adjacent
// codes giving each level's grid; then level 0 copied and each further level merged from the one before as read
// back from the chunk's buffer (so parents are exactly the merge of the stored children). Chunks are built a few
// per worker at a time and handed to the level store in chunk order (arrays in memory, spill files out of core).
// With one partition every chunk is planned before any is built, so the level count is chosen first and only
// those levels are built; with several it is chosen at the end (level l depends only on level l − 1, so the levels
// kept do not depend on the ones built beyond them).
//
// Determinism: every chunk's output depends only on its own Gaussians, and the only cross-chunk reductions
// are integer sums and the bounds' min/max, so the bytes depend neither on the threads nor on the partitions.
#include "rgs/converter/lod_builder.h"

#include <xxhash.h>

#include <algorithm>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "../internal_parallel.h"
#include "internal_levels.h"

namespace rgs::converter {
namespace detail {
namespace {

/// What is kept of a chunk once its levels are in the store.
struct BuiltChunk {
  ChunkPlan plan;
  ChunkReach reach;
  float center[3];
  uint64_t checksum[format::kMaxLodLevels];
};

/// XXH64 of Gaussians [first, first + count) of `s` across its sections (SPEC §4.9 `checksum`).
uint64_t range_checksum(const format::EncodedScene& s, uint64_t first, uint64_t count, const Layout& t) {
  XXH64_state_t* state = XXH64_createState();
  XXH64_reset(state, 0);
  for (int k = 0; k < section_count(t.dc_residual); ++k) {
    const uint64_t width = section_width(k, t.sh_values);
    XXH64_update(state, section_bytes(s, k) + first * width, count * width);
  }
  const uint64_t digest = XXH64_digest(state);
  XXH64_freeState(state);
  return digest;
}

/// The chunks of one partition built a group at a time, each group's handed to `store` in order.
Status build_partition(const Partition& part, const std::vector<ChunkPlan>& plans, uint32_t levels,
                       const double scene_center[3], unsigned workers, LevelStore& store,
                       std::vector<Scratch>* scratch, std::vector<BuiltChunk>* chunks, Progress* progress) {
  const Layout t = describe_layout(*part.scene);
  const uint64_t group = uint64_t{workers} * kChunksPerWorker;
  std::vector<format::EncodedScene> outputs(group);
  std::vector<BuiltChunk> built(group);
  for (uint64_t g0 = 0; g0 < plans.size(); g0 += group) {
    const uint64_t g1 = std::min<uint64_t>(plans.size(), g0 + group);
    RGS_RETURN_IF_ERROR(parallel_items(g1 - g0, workers, [&](unsigned worker, uint64_t k) {
      BuiltChunk& chunk = built[k];
      chunk.plan = plans[g0 + k];
      uint64_t first[format::kMaxLodLevels], total = 0;
      for (uint32_t l = 0; l < levels; ++l) {
        first[l] = total;
        total += chunk.plan.count[l];
      }
      size_sections(&outputs[k], total, t.sh_values, t.dc_residual);
      double center[3];
      chunk_center(chunk.plan, chunk.center, center);
      chunk.reach = build_chunk(*part.scene, part.order.index.data(), part.order.keys.data(), chunk.plan, first, levels,
                                t, center, scene_center, &(*scratch)[worker], &outputs[k]);
      for (uint32_t l = 0; l < levels && store.needs_checksums(); ++l) {
        chunk.checksum[l] = range_checksum(outputs[k], first[l], chunk.plan.count[l], t);
      }
    }));
    for (uint64_t k = 0; k < g1 - g0; ++k) {
      const uint32_t c = static_cast<uint32_t>(chunks->size());
      uint64_t from = 0;
      for (uint32_t l = 0; l < levels; from += built[k].plan.count[l++]) {
        for (int s = 0; s < section_count(t.dc_residual); ++s) {
          const uint64_t width = section_width(s, t.sh_values);
          RGS_RETURN_IF_ERROR(
              store.put(c, l, s, section_bytes(outputs[k], s) + from * width, built[k].plan.count[l] * width));
        }
      }
      chunks->push_back(built[k]);
    }
    progress->add(2 * (plans[g1 - 1].end - plans[g0].begin));
    progress->report();
  }
  return Status();
}

/// The scene in memory as the one partition: Morton-sorted over its cube, cut into octree leaves.
class WholeScene final : public PartitionSource {
 public:
  WholeScene(const format::EncodedScene& scene, const MortonGrid& grid, uint64_t max_chunk, unsigned workers)
      : scene_(scene), grid_(grid), max_chunk_(max_chunk), workers_(workers) {}
  uint32_t count() const override { return 1; }
  Status load(uint32_t, Partition* out) override {
    out->scene = &scene_;
    RGS_RETURN_IF_ERROR(sort_by_morton(scene_, grid_, workers_, &out->order));
    split_node(out->order.keys.data(), 0, scene_.count, 0, max_chunk_, &out->order.leaves);
    return Status();
  }

 private:
  const format::EncodedScene& scene_;
  MortonGrid grid_;
  uint64_t max_chunk_;
  unsigned workers_;
};

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

}  // namespace

Result<BuiltIndex> build_levels(PartitionSource& source, LevelStore& store, const format::EncodedScene& head,
                                const LodBuildOptions& options, Progress* progress) {
  const unsigned workers = parallel::thread_count(options.threads);
  const uint32_t planned = options.levels == 0 ? kAutoMaxLevels : options.levels;
  BuiltIndex out;
  out.head.metadata = head.metadata;
  double scene_center[3];
  format::set_sphere_center(&out.head.metadata.bounds, scene_center);
  std::vector<Scratch> scratch(workers);
  std::vector<BuiltChunk> chunks;
  std::optional<LevelChoice> choice;
  for (uint32_t b = 0; b < source.count(); ++b) {
    Partition part;
    RGS_RETURN_IF_ERROR(source.load(b, &part));
    RGS_ASSIGN_OR_RETURN(std::vector<ChunkPlan> plans,
                         plan_chunks(*part.scene, planned, workers, &part.order, &scratch, progress));
    if (source.count() == 1) {  // every chunk is known: the levels are chosen before they are built
      RGS_ASSIGN_OR_RETURN(choice, choose_levels(plans, planned, options, head.count));
      out.index = lay_out_index(plans, choice->levels);
      RGS_RETURN_IF_ERROR(store.reserve(out.index, choice->total));
    }
    RGS_RETURN_IF_ERROR(build_partition(part, plans, choice ? choice->levels : planned, scene_center, workers, store,
                                        &scratch, &chunks, progress));
  }
  std::vector<ChunkPlan> plans;
  std::vector<ChunkReach> reaches;
  for (const BuiltChunk& c : chunks) {
    plans.push_back(c.plan);
    reaches.push_back(c.reach);
  }
  if (!choice) {
    RGS_ASSIGN_OR_RETURN(choice, choose_levels(plans, planned, options, head.count));
    out.index = lay_out_index(plans, choice->levels);
  }
  for (uint32_t c = 0; c < out.index.chunk_count; ++c) {
    std::copy_n(chunks[c].center, 3, out.index.chunks[c].center);
    for (uint32_t l = 0; l < choice->levels && store.needs_checksums(); ++l) {
      out.index.at(l, c).checksum = chunks[c].checksum[l];
    }
  }
  RGS_ASSIGN_OR_RETURN(out.head.metadata.bounds.sphere_radius, set_chunk_radii(reaches, &out.index));
  out.head.provenance = head.provenance;
  out.head.provenance.emplace_back("lod_levels", std::to_string(choice->levels));
  out.head.provenance.emplace_back("lod_chunks", std::to_string(out.index.chunk_count));
  out.head.count = choice->total;
  return out;
}

}  // namespace detail

Result<LodScene> build_lod(const format::EncodedScene& scene, const LodBuildOptions& options) {
  using namespace detail;
  RGS_RETURN_IF_ERROR(check_inputs(scene, options));
  return catch_bad_alloc([&]() -> Result<LodScene> {
    // The head: the scene's metadata with the box of its means (parents are clamped into their chunk's box, so
    // it is also the box of every output mean, as compute_bounds() would find it).
    format::EncodedScene head = head_of(scene);
    format::SceneBounds& bounds = head.metadata.bounds;
    format::box_of_means(scene.means.data(), scene.count, bounds.aabb_min, bounds.aabb_max);
    const unsigned workers = parallel::thread_count(options.threads);
    WholeScene source(scene, MortonGrid(bounds.aabb_min, bounds.aabb_max), options.max_chunk_gaussians, workers);
    LodScene result;
    const std::unique_ptr<LevelStore> store = held_store(&result, describe_layout(scene));
    Progress progress(options.progress, 5 * scene.count / 2);
    RGS_ASSIGN_OR_RETURN(BuiltIndex built, build_levels(source, *store, head, options, &progress));
    result.index = std::move(built.index);
    result.scene.metadata = built.head.metadata;
    result.scene.provenance = std::move(built.head.provenance);
    progress.finish();
    return result;
  }, [&] { return "build_lod: out of memory building the levels of " + std::to_string(scene.count) + " Gaussians"; });
}

}  // namespace rgs::converter
