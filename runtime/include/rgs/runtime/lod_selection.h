// Per-frame level-of-detail selection: which level of which chunk of a level-of-detail .rgs a camera draws
// (format/SPEC.md §4.9.1, docs/LOD.md). Host code, no GPU.
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/lod.h"
#include "rgs/runtime/camera.h"

namespace rgs::runtime {

/// What a frame may draw.
struct LodBudget {
  /// Most Gaussians (splats) a frame draws; 0: no limit.
  uint64_t max_splats = 0;
  /// Largest projected error a level may show, in pixels (SPEC §4.9.1: error · f / d): the floor of select_lod.
  /// The default is the largest swept error whose frames stayed within 1 dB of the full detail's against its
  /// supersampled render on every measured scene (docs/LOD.md#the-default-pixel-error).
  float pixel_error = 1.5f;
};

/// One chunk a frame draws, at one level.
struct LodChoice {
  uint32_t chunk = 0;
  uint32_t level = 0;
};

/// A frame's selection.
struct LodSelection {
  /// The chunks whose sphere meets the view frustum, in chunk order, each with the level to draw.
  std::vector<LodChoice> choices;
  /// Gaussians of the chosen levels.
  uint64_t splats = 0;
  /// Chunks outside the frustum (not drawn).
  uint32_t culled = 0;
  /// Chunks drawn coarser than their floor (the pixel threshold's level), to meet the splat budget.
  uint32_t coarsened = 0;
  /// False when even the coarsest level of every visible chunk exceeds the budget (they are then all chosen).
  bool within_budget = true;
};

/// Projected error in pixels of a world-space `error` at chunk `chunk` seen by `camera` (SPEC §4.9.1):
/// error · max(fx, fy) / max(near_plane, |camera centre − center| − radius).
double projected_error(const Camera& camera, const format::LodChunk& chunk, float error);

/// Chooses a level per chunk in the frustum. Its floor is the coarsest level whose projected error is at most
/// budget.pixel_error (0: the full detail, or the coarsest level of error 0). With no splat budget every chunk
/// takes its floor. With one, every chunk starts at its coarsest level and, while a step fits the budget, the
/// chunk whose step removes the most projected error per splat added is refined: a step goes from level l to
/// the finer level k ≥ floor of largest (error(l) − error(k)) · f / d / (count(k) − count(l)) among those
/// that remove error and fit (ties: the coarser k, then the lower chunk index). Pure and deterministic: the
/// same index, camera and budget give the same selection. The camera must be valid (validate_camera).
LodSelection select_lod(const format::LodIndex& index, const Camera& camera, const LodBudget& budget);

}  // namespace rgs::runtime
