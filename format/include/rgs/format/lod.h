// The level-of-detail index of a .rgs file (format/SPEC.md §4.9): spatial chunks, each at several levels of
// detail, stored level-major in the ordinary per-Gaussian sections.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace rgs::format {

/// §4.9 Most levels a chunk may have (level 0, the full detail, included).
inline constexpr uint32_t kMaxLodLevels = 16;

/// §4.9 Bytes of the index's fixed parts: the head, one chunk record, one level record.
inline constexpr uint64_t kLodHeadSize = 16;
inline constexpr uint64_t kLodChunkRecordSize = 16;
inline constexpr uint64_t kLodLevelRecordSize = 24;

/// §4.9 A chunk's bounding sphere, world units: every Gaussian of every level of the chunk has
/// |mean − center| + 3 · (its largest linear scale) ≤ radius, so the sphere holds each Gaussian's 3σ
/// ellipsoid (what a renderer culls and measures distances with).
struct LodChunk {
  float center[3] = {0, 0, 0};
  float radius = 0;
};

/// §4.9 One level of one chunk: Gaussians [first, first + count) of every per-Gaussian section. A writer's
/// caller sets `first` (the prefix sum of the counts in record order); the writer checks it.
struct LodLevel {
  uint64_t first = 0;
  uint64_t count = 0;
  /// World-space error of this level against level 0 (0 for level 0), as the writer measures it: at distance d
  /// a camera of focal length f pixels sees it as error · f / d pixels (§4.9.1). Steers selection only.
  float error = 0;
  /// XXH64 of the range's raw bytes of means, rotations, scales, opacities, sh and (when present)
  /// sh_dc_residual, in that order as one stream: lets a reader verify one chunk without reading others.
  /// The writer computes it; the value given to it is ignored.
  uint64_t checksum = 0;
};

/// §4.9 The index: C chunks, each with L levels; level records are level-major (record l·C + c is level l
/// of chunk c) and their ranges tile [0, N) in record order, so level 0 of every chunk -- the full-detail
/// scene -- is the prefix [0, full_detail_count()) of each section.
struct LodIndex {
  uint32_t chunk_count = 0;
  uint32_t level_count = 0;
  std::vector<LodChunk> chunks;  ///< [C]
  std::vector<LodLevel> levels;  ///< [L · C], level-major

  const LodLevel& at(uint32_t level, uint32_t chunk) const {
    return levels[static_cast<size_t>(level) * chunk_count + chunk];
  }
  LodLevel& at(uint32_t level, uint32_t chunk) { return levels[static_cast<size_t>(level) * chunk_count + chunk]; }
  /// Gaussians of level 0 over all chunks: the full-detail scene's size.
  uint64_t full_detail_count() const {
    uint64_t n = 0;
    for (uint32_t c = 0; c < chunk_count && c < levels.size(); ++c) n += levels[c].count;
    return n;
  }
  /// Raw bytes of the index section: 16 + 16·C + 24·L·C.
  uint64_t section_bytes() const {
    return kLodHeadSize + kLodChunkRecordSize * chunk_count + kLodLevelRecordSize * levels.size();
  }
};

}  // namespace rgs::format
