// The census of one frame (rgs/lab/frame_census.h): the CPU reference's 3DGS preprocess and pair sort,
// then every pixel of every tile against every Gaussian of the tile's list, in list order.
#include "rgs/lab/frame_census.h"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <new>
#include <string>
#include <vector>

#include "rgs/kernels/shared/blend_math.h"
#include "rgs/parallel/fork_join.h"
#include "rgs/runtime/cpu_renderer.h"

namespace rgs::lab {
namespace {

namespace k = kernels;
using runtime::ProjectedGaussian;

/// 4×4 blocks per tile side.
constexpr int kBlocksPerSide = k::kTileSize / 4;

/// Counts of one tile row, summed in row order afterwards (the totals do not depend on the thread count).
struct RowCounts {
  uint64_t blended = 0, skipped = 0;
  uint32_t max_blended = 0;
  uint64_t blending_pairs[kCensusCells] = {0, 0, 0};
  uint64_t reaching_pairs[kCensusCells] = {0, 0, 0};
  uint64_t saturated_tiles = 0, hidden_rect_pairs = 0, hidden_reaching_pairs = 0;
};

/// α of `g` at pixel (x, y) by the 3DGS rule, or −1 when the pair does not blend there (power > 0 or
/// α < 1/255). power < −6 is skipped before the exponential: exp(−6) < 1/255 for any opacity ≤ 1.
float alpha_at(const ProjectedGaussian& g, float x, float y) {
  const float power = k::baseline_power(g.conic, g.mean[0] - x, g.mean[1] - y);
  if (power > 0.f || power < -6.f) return -1.f;
  const float alpha = std::fmin(k::kAlphaMax, g.opacity * std::exp(power));
  return alpha < k::kAlphaMin ? -1.f : alpha;
}

/// Adds the cells a pair's 4×4-block mask covers: 16×16 (any block), 8×8 (each quadrant with a block), 4×4.
void count_cells(uint16_t blocks, uint64_t* pairs) {
  if (blocks == 0) return;
  pairs[int(CensusCell::k16)] += 1;
  for (int quadrant = 0; quadrant < 4; ++quadrant) {
    const int shift = (quadrant / 2) * 2 * kBlocksPerSide + (quadrant % 2) * 2;  // top-left block of the quadrant
    const uint16_t quad_mask = uint16_t((0x3u | (0x3u << kBlocksPerSide)) << shift);
    if ((blocks & quad_mask) != 0) pairs[int(CensusCell::k8)] += 1;
  }
  pairs[int(CensusCell::k4)] += std::bitset<16>(blocks).count();
}

/// Walks tile (tx, ty): every pixel against every Gaussian of its list, tracking per pair the 4×4 blocks where
/// it blends and where it reaches α ≥ 1/255; `blends[j]` is set when pair j blends anywhere. The pairs from the
/// largest index at which a pixel's walk ended onwards are hidden when every pixel's walk ended.
void census_tile(const std::vector<ProjectedGaussian>& gaussians, const uint32_t* ids, uint64_t count, int tx, int ty,
                 const FrameCensus& frame, std::vector<uint16_t>* blend_blocks, std::vector<uint16_t>* reach_blocks,
                 uint8_t* blends, uint16_t* blended_map, RowCounts* row) {
  blend_blocks->assign(count, 0);
  reach_blocks->assign(count, 0);
  const uint32_t x0 = uint32_t(tx) * k::kTileSize, y0 = uint32_t(ty) * k::kTileSize;
  const uint32_t x1 = std::min<uint32_t>(x0 + k::kTileSize, frame.width);
  const uint32_t y1 = std::min<uint32_t>(y0 + k::kTileSize, frame.height);
  uint64_t saturation = 0;  // largest index at which a pixel's walk ended; `count` once one never ends
  for (uint32_t y = y0; y < y1; ++y) {
    for (uint32_t x = x0; x < x1; ++x) {
      const uint16_t block = uint16_t(1u << (((y - y0) / 4) * kBlocksPerSide + (x - x0) / 4));
      float T = 1.f;
      bool done = false;
      uint32_t blended = 0;
      for (uint64_t j = 0; j < count; ++j) {
        const float alpha = alpha_at(gaussians[ids[j]], float(x), float(y));
        if (alpha >= 0.f) (*reach_blocks)[j] |= block;
        if (done) continue;
        if (alpha < 0.f) {
          ++row->skipped;
          continue;
        }
        const float test_T = T * (1.f - alpha);
        if (test_T < k::kTransmittanceMin) {
          done = true;
          saturation = std::max(saturation, j);
          continue;
        }
        T = test_T;
        ++blended;
        (*blend_blocks)[j] |= block;
      }
      if (!done) saturation = count;
      row->blended += blended;
      if (blended_map != nullptr) blended_map[size_t(y) * frame.width + x] = uint16_t(blended);
      row->max_blended = std::max(row->max_blended, blended);
    }
  }
  for (uint64_t j = 0; j < count; ++j) {
    count_cells((*blend_blocks)[j], row->blending_pairs);
    count_cells((*reach_blocks)[j], row->reaching_pairs);
    blends[j] = (*blend_blocks)[j] != 0;
  }
  if (saturation >= count) return;
  row->saturated_tiles += 1;
  row->hidden_rect_pairs += count - saturation;
  for (uint64_t j = saturation; j < count; ++j) row->hidden_reaching_pairs += (*reach_blocks)[j] != 0;
}

}  // namespace

Result<FrameCensus> census_frame(const format::GaussianCloud& cloud, const runtime::Camera& camera, unsigned num_threads,
                                 std::vector<uint16_t>* blended_map) {
  runtime::RenderOptions options;  // the 3DGS baseline
  options.num_threads = num_threads;
  RGS_ASSIGN_OR_RETURN(const runtime::FrameSetup frame, runtime::setup_frame(cloud, camera, options));
  runtime::RenderStats stats;
  std::vector<ProjectedGaussian> projected;
  RGS_RETURN_IF_ERROR(runtime::preprocess_cpu(cloud, camera, frame, options, &stats, &projected));
  RGS_ASSIGN_OR_RETURN(const runtime::TileBins bins, runtime::bin_and_sort_cpu(projected, frame, options));

  FrameCensus census;
  census.width = frame.width;
  census.height = frame.height;
  census.gaussians = cloud.size();
  census.visible = stats.visible;
  census.rect_pairs = bins.values.size();
  std::vector<RowCounts> rows;
  std::vector<uint8_t> pair_blends, contributes;
  try {
    contributes.assign(projected.size(), 0);
    rows.resize(size_t(frame.tiles_y));
    pair_blends.assign(bins.values.size(), 0);
    if (blended_map != nullptr) blended_map->assign(census.pixels(), 0);
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory,
                  "census: out of memory for the flags of " + std::to_string(bins.values.size()) + " pairs and " +
                      std::to_string(projected.size()) + " Gaussians");
  }
  Status walked = parallel::parallel_for(uint64_t(frame.tiles_y), parallel::thread_count(num_threads),
                                             [&](uint64_t ty) {
    std::vector<uint16_t> blend_blocks, reach_blocks;  // per worker, reused across the row's tiles
    for (int tx = 0; tx < frame.tiles_x; ++tx) {
      const uint64_t id = ty * uint64_t(frame.tiles_x) + uint64_t(tx);
      const uint64_t begin = bins.tile_begin[id], end = bins.tile_begin[id + 1];
      census_tile(projected, bins.values.data() + begin, end - begin, tx, int(ty), census, &blend_blocks,
                  &reach_blocks, pair_blends.data() + begin, blended_map != nullptr ? blended_map->data() : nullptr,
                  &rows[ty]);
    }
  });
  if (!walked.ok()) return walked.prepend("census");

  for (const RowCounts& row : rows) {
    census.blended += row.blended;
    census.skipped += row.skipped;
    census.max_blended = std::max(census.max_blended, row.max_blended);
    census.saturated_tiles += row.saturated_tiles;
    census.hidden_rect_pairs += row.hidden_rect_pairs;
    census.hidden_reaching_pairs += row.hidden_reaching_pairs;
    for (int c = 0; c < kCensusCells; ++c) {
      census.blending_pairs[c] += row.blending_pairs[c];
      census.reaching_pairs[c] += row.reaching_pairs[c];
    }
  }
  for (size_t p = 0; p < pair_blends.size(); ++p) contributes[bins.values[p]] |= pair_blends[p];
  census.contributing = uint64_t(std::count(contributes.begin(), contributes.end(), uint8_t{1}));
  return census;
}

}  // namespace rgs::lab
