// Level-of-detail building blocks shared by the in-memory builder (lod_builder.cpp) and the out-of-core one
// (lod_out_of_core.cpp): the Morton order and its octree chunks, each chunk's level plan, the merge that
// builds a chunk's levels, and the level count and index they share. The rules are lod_builder.h's.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "rgs/converter/lod_builder.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/lod.h"
#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// Levels the automatic choice stops at.
constexpr uint32_t kAutoMaxLevels = 8;
/// The auto levels stop once the coarsest level holds at most 1/kAutoRatio of the full detail.
constexpr uint64_t kAutoRatio = 64;
/// Morton grids: 21 bits per axis, codes of 63 bits; shift k groups codes by code >> 3k (k = 21: one cell).
constexpr int kGridBits = 21;
constexpr int kMaxShift = kGridBits;
constexpr uint32_t kGridCells = uint32_t{1} << kGridBits;
constexpr uint64_t kMaxOutputGaussians = 0x7fffffff;

// ---------------------------------------------------------------------------------------------------------
// Morton codes and sorting.

/// The 21 low bits of v spread to every third bit.
inline uint64_t spread_bits(uint32_t v) {
  uint64_t x = v & 0x1fffffu;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

/// A grid of 2^21 cells per axis over the cube [lo, lo + edge]^3 (edge = the box's largest extent).
struct MortonGrid {
  double lo[3] = {0, 0, 0};
  double edge = 0;
  double cells_per_unit = 0;  ///< 2^21 / edge, 0 when the box is a point

  MortonGrid(const float box_lo[3], const float box_hi[3]) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = box_lo[a];
      edge = std::max(edge, static_cast<double>(box_hi[a]) - static_cast<double>(box_lo[a]));
    }
    if (edge > 0 && std::isfinite(edge)) cells_per_unit = static_cast<double>(kGridCells) / edge;
  }
  uint32_t cell(float v, int a) const {
    const double t = (static_cast<double>(v) - lo[a]) * cells_per_unit;
    if (!(t > 0)) return 0;  // NaN too
    if (t >= static_cast<double>(kGridCells - 1)) return kGridCells - 1;
    return static_cast<uint32_t>(t);
  }
  uint64_t code(const float* mean) const {
    return spread_bits(cell(mean[0], 0)) << 2 | spread_bits(cell(mean[1], 1)) << 1 | spread_bits(cell(mean[2], 2));
  }
};

/// Stable LSD radix sort of (keys, values) by key, 8 bits a pass, skipping passes whose digit is the same for
/// every key. tmp_keys / tmp_values hold at least n elements.
void radix_sort(uint64_t* keys, uint32_t* values, size_t n, uint64_t* tmp_keys, uint32_t* tmp_values);

/// Octree leaves of the Morton-sorted keys [begin, end) of the node at `depth`: nodes holding more than
/// `max_count` split into their eight children (empty ones dropped); a finest cell still too large is cut
/// by index into equal pieces. Leaves are appended in Morton order.
void split_node(const uint64_t* keys, uint64_t begin, uint64_t end, int depth, uint64_t max_count,
                std::vector<std::pair<uint64_t, uint64_t>>* leaves);

// ---------------------------------------------------------------------------------------------------------
// Plans.

/// What the analysis of one chunk decides: its range in the sorted order, its box and each level's grid.
struct ChunkPlan {
  uint64_t begin = 0, end = 0;  ///< level-0 Gaussians: sorted positions [begin, end)
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  int shift[format::kMaxLodLevels] = {};  ///< grid shift of level l ≥ 1 (cells of 2^shift finest cells)
  uint64_t count[format::kMaxLodLevels] = {};
  /// g(l) of lod_builder.h, the cell diagonal: the world size of the merge's pixel. The index's error is
  /// measured instead (ChunkReach::error).
  float error[format::kMaxLodLevels] = {};
};

// ---------------------------------------------------------------------------------------------------------
// Merging.

/// Shapes and tables of the scene the levels are built for.
struct Layout {
  uint32_t k_count = 1;
  uint32_t sh_values = 3;
  bool log_scale = false;
  bool dc_residual = false;
  float sh_scale[48] = {};  ///< s[deg(j / 3)][j % 3] per value j
};

/// The input's attribute layout that the merge needs: SH sizes and scales, scale and DC-residual encodings.
Layout describe_layout(const format::EncodedScene& in);

/// Per child of the cell being merged: its weight, area term and opacity.
struct ChildTerms {
  double weight, area, alpha;
};

/// Per-worker buffers, reused from chunk to chunk.
struct Scratch {
  std::vector<uint64_t> tmp_keys;
  std::vector<uint32_t> tmp_values;
  std::vector<uint64_t> codes, next_codes;
  std::vector<ChildTerms> children;
  std::vector<uint32_t> ancestor, parent_of;  ///< per level-0 Gaussian / per Gaussian of the level before
  std::vector<std::array<float, 8>> base, looks;  ///< level 0's and the current level's look (appearance_error)
};

/// What build_chunk() measures per level of its chunk, in double: the chunk sphere's radius about its centre
/// (+inf when a Gaussian's extent overflows) and the largest squared distance of a mean from the scene
/// sphere's centre. A file keeps the levels [0, L) and measures over those. `error`: the level's measured
/// appearance error in world units (lod_builder.h), non-decreasing over the levels, 0 at level 0; it becomes
/// the index record's `error` (set_chunk_radii).
struct ChunkReach {
  float error[format::kMaxLodLevels] = {};
  double radius[format::kMaxLodLevels] = {};
  double scene_d2[format::kMaxLodLevels] = {};
  /// The radius over levels [0, levels), +inf when not finite.
  double radius_over(uint32_t levels) const;
  double scene_d2_over(uint32_t levels) const;
};

/// Builds levels [0, levels) of the chunk `plan` describes into `out`, level l from Gaussian first[l] on:
/// level 0 copied from `in` in the sorted order (sorted_index[plan.begin, plan.end)), each further level
/// merged from the one before as read back from `out`. sorted_codes holds the chunk's local Morton codes
/// (plan_chunks).
ChunkReach build_chunk(const format::EncodedScene& in, const uint32_t* sorted_index, const uint64_t* sorted_codes,
                       const ChunkPlan& plan, const uint64_t first[], uint32_t levels, const Layout& t,
                       const double center[3], const double scene_center[3], Scratch* scratch,
                       format::EncodedScene* out);

/// The chunk sphere's radius of `reach` over levels [0, levels): enlarged by 1e-6 relative and rounded up to
/// float32 (lod_builder.h). kInvalidArgument naming chunk `c` when a Gaussian's 3σ extent overflows float32.
Result<float> chunk_radius(const ChunkReach& reach, uint32_t levels, uint32_t c);

/// A chunk's centre: the midpoint of its box in float32, and that float32 in double.
void chunk_center(const ChunkPlan& plan, float stored[3], double center[3]);

/// Calls options.progress with done / total from the calling thread, at most every 10 ms.
class Progress {
 public:
  Progress(const std::function<void(double)>& fn, uint64_t total) : fn_(fn), total_(std::max<uint64_t>(total, 1)) {}
  void add(uint64_t work) { done_.fetch_add(work, std::memory_order_relaxed); }
  /// From the calling thread only.
  void report() {
    if (!fn_) return;
    const auto now = std::chrono::steady_clock::now();
    if (reported_ && now - last_ < std::chrono::milliseconds(10)) return;
    const double f = std::min(1.0, static_cast<double>(done_.load(std::memory_order_relaxed)) / static_cast<double>(total_));
    if (reported_ && f <= last_fraction_) return;
    reported_ = true;
    last_ = now;
    last_fraction_ = f;
    fn_(f);
  }
  void finish() {
    if (fn_) fn_(1.0);
  }

 private:
  const std::function<void(double)>& fn_;
  uint64_t total_;
  std::atomic<uint64_t> done_{0};
  bool reported_ = false;
  double last_fraction_ = 0;
  std::chrono::steady_clock::time_point last_;
};

/// Scene-wide Morton order: the input's box, its Gaussians sorted by Morton code over that box's cube, and the
/// octree leaves ([begin, end) into `index`) that become the chunks.
struct MortonOrder {
  float box_lo[3], box_hi[3];
  std::vector<uint64_t> keys;
  std::vector<uint32_t> index;
  std::vector<std::pair<uint64_t, uint64_t>> leaves;
};

/// order->keys and order->index: the Morton codes of the means of `in` on `grid` and the Gaussians' indices,
/// sorted by code (stable, so equal codes keep the input's order). Leaves are left to the caller. Errors: a
/// worker's kOutOfMemory.
Status sort_by_morton(const format::EncodedScene& in, const MortonGrid& grid, unsigned workers, MortonOrder* order);

/// Per chunk of `order` (its leaves): its box, its Gaussians sorted by Morton code on a grid over the chunk's
/// own cube (order->keys and order->index rewritten in place), and each of planned_levels levels' grid.
Result<std::vector<ChunkPlan>> plan_chunks(const format::EncodedScene& in, uint32_t planned_levels, unsigned workers,
                                           MortonOrder* order, std::vector<Scratch>* scratch, Progress* progress);

/// The checks both builders make of a request to build the levels of `count` Gaussians: kInvalidArgument for
/// no Gaussians, options.levels above the format's kMaxLodLevels or options.max_chunk_gaussians 0,
/// kLimitExceeded for more than 2^31 - 1 Gaussians.
Status check_lod_request(uint64_t count, const LodBuildOptions& options);

/// The levels chosen and the Gaussians they hold over every chunk (the output's count).
struct LevelChoice {
  uint32_t levels = 0;
  uint64_t total = 0;
};

/// The number of levels: `options.levels`, or with 0 (auto) the first level holding at most 1/64 of the full
/// detail (n0 Gaussians), or where every chunk is down to one Gaussian (further levels would repeat it); with
/// the Gaussians of those levels over every chunk. kLimitExceeded when that total exceeds 2^31 - 1.
Result<LevelChoice> choose_levels(const std::vector<ChunkPlan>& plans, uint32_t planned_levels,
                                  const LodBuildOptions& options, uint64_t n0);

/// An LOD index of `levels` levels over the chunks `plans` describes, its records' ranges laid out in the
/// output's order (levels coarse after fine, chunks in order), each with its plan's count. Errors, checksums,
/// chunk centres and radii are left 0 for the caller.
format::LodIndex lay_out_index(const std::vector<ChunkPlan>& plans, uint32_t levels);

/// Sets each chunk's radius (chunk_radius of reaches[c] over the index's levels) and each record's error
/// (reaches[c].error) in `index`, and returns the scene sphere's radius: sphere_radius_for the largest squared
/// distance of a kept mean from the scene's centre. Errors: chunk_radius's, for the first chunk that fails.
Result<float> set_chunk_radii(const std::vector<ChunkReach>& reaches, format::LodIndex* index);

}  // namespace rgs::converter::detail
