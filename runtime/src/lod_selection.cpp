// Per-frame level-of-detail selection (lod_selection.h).
#include "rgs/runtime/lod_selection.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <queue>
#include <tuple>

namespace rgs::runtime {

namespace {

/// The view frustum's planes in camera space, computed once per frame: the near plane z = near, and the four side
/// planes through the camera centre and the image edges (pixel centres at integer coordinates, so the edges are
/// at −0.5 and width − 0.5), each as a unit inward normal (a, b) in the (x, z) or (y, z) plane: a·x + b·z ≥ 0
/// inside.
struct Frustum {
  explicit Frustum(const Camera& camera) : camera_(camera) {
    const double left = camera.cx, right = double(camera.width) - camera.cx;
    const double top = camera.cy, bottom = double(camera.height) - camera.cy;
    const double planes[4][2] = {{camera.fx, left}, {-camera.fx, right}, {camera.fy, top}, {-camera.fy, bottom}};
    for (int k = 0; k < 4; ++k) {
      const double length = std::hypot(planes[k][0], planes[k][1]);
      normal_[k][0] = planes[k][0] / length;
      normal_[k][1] = planes[k][1] / length;
    }
  }
  bool holds(const float center[3], float radius) const {
    const auto& R = camera_.rotation;
    double p[3];
    for (int i = 0; i < 3; ++i) {
      p[i] = double(R[i * 3 + 0]) * center[0] + double(R[i * 3 + 1]) * center[1] + double(R[i * 3 + 2]) * center[2] +
             camera_.translation[i];
    }
    const double r = radius;
    if (p[2] + r <= camera_.near_plane) return false;
    for (int k = 0; k < 4; ++k) {
      if (normal_[k][0] * p[k < 2 ? 0 : 1] + normal_[k][1] * p[2] < -r) return false;
    }
    return true;
  }

 private:
  const Camera& camera_;
  double normal_[4][2];
};

/// The distance d of SPEC §4.9.1 from the camera centre `c` to `chunk`: max(near, |c − centre| − radius).
double chunk_distance(const Camera& camera, const std::array<float, 3>& c, const format::LodChunk& chunk) {
  const double dx = double(c[0]) - chunk.center[0], dy = double(c[1]) - chunk.center[1],
               dz = double(c[2]) - chunk.center[2];
  return std::max<double>(camera.near_plane, std::sqrt(dx * dx + dy * dy + dz * dz) - chunk.radius);
}

}  // namespace

double projected_error(const Camera& camera, const format::LodChunk& chunk, float error) {
  return double(error) * std::max(camera.fx, camera.fy) / chunk_distance(camera, camera_centre(camera), chunk);
}

LodSelection select_lod(const format::LodIndex& index, const Camera& camera, const LodBudget& budget) {
  LodSelection out;
  const uint32_t coarsest = index.level_count == 0 ? 0 : index.level_count - 1;
  std::vector<double> scale;    // f / d per chosen chunk: projected error = error · scale
  std::vector<uint32_t> floor;  // per chosen chunk, the coarsest level within the pixel threshold
  const std::array<float, 3> centre = camera_centre(camera);
  const double focal = std::max(camera.fx, camera.fy);
  const Frustum frustum(camera);
  out.choices.reserve(index.chunk_count);
  scale.reserve(index.chunk_count);
  floor.reserve(index.chunk_count);
  // Whether each chunk's counts do not fall from its coarsest level to its floor: then no step frees splats.
  bool counts_rise = true;
  uint64_t most = 0;  // the splats of every chunk at its largest level between its floor and its coarsest
  for (uint32_t c = 0; c < index.chunk_count; ++c) {
    const format::LodChunk& chunk = index.chunks[c];
    if (!frustum.holds(chunk.center, chunk.radius)) {
      ++out.culled;
      continue;
    }
    const double s = focal / chunk_distance(camera, centre, chunk);  // projected_error(camera, chunk, 1)
    uint32_t level = coarsest;
    while (level > 0 && index.at(level, c).error * s > budget.pixel_error) --level;
    const bool limited = budget.max_splats != 0;
    out.choices.push_back({c, limited ? coarsest : level});
    scale.push_back(s);
    floor.push_back(level);
    out.splats += index.at(out.choices.back().level, c).count;
    for (uint32_t k = level; k < coarsest; ++k) counts_rise &= index.at(k, c).count >= index.at(k + 1, c).count;
    most += index.at(level, c).count;  // the largest, when counts rise
  }
  if (budget.max_splats == 0) return out;
  out.within_budget = out.splats <= budget.max_splats;

  // From the coarsest levels, refine the chunk whose step removes the most projected error per splat added,
  // a step going to the finer level (down to the floor) of the best ratio, among those that fit the budget.
  using Step = std::tuple<double, int64_t, uint32_t>;  // (error removed per splat, −choice index, to level)
  // Choice i's best step from level `from`, among those that fit the budget when `bounded`.
  auto best_step = [&](uint32_t i, uint32_t from, bool bounded) -> std::optional<Step> {
    const uint32_t chunk = out.choices[i].chunk;
    std::optional<Step> best;
    for (uint32_t k = from; k-- > floor[i];) {
      const double gain = (index.at(from, chunk).error - index.at(k, chunk).error) * scale[i];
      const uint64_t cost = index.at(k, chunk).count - index.at(from, chunk).count;
      if (!(gain > 0) || (bounded && out.splats + cost > budget.max_splats)) continue;
      const double ratio = cost == 0 ? std::numeric_limits<double>::infinity() : gain / double(cost);
      if (!best || ratio > std::get<0>(*best)) best = Step{ratio, -int64_t{i}, k};
    }
    return best;
  };
  auto take = [&](const Step& step) {
    LodChoice& ch = out.choices[-std::get<1>(step)];
    out.splats += index.at(std::get<2>(step), ch.chunk).count - index.at(ch.level, ch.chunk).count;
    ch.level = std::get<2>(step);
  };

  // Until the budget first refuses a step, the queue takes the steps of each chunk's walk (its best steps without
  // the budget, one after another from the coarsest level) in the order of their ratios, but none before the steps
  // ahead of it in its walk: so no sooner than the smallest ratio up to it. With counts that do not fall as levels
  // get finer (the splats drawn only grow), every walk step whose smallest ratio so far lies in the top octaves is
  // therefore taken before any refusal when their splats together fit what the budget leaves. Those are taken at
  // once, and the queue does the rest (the same choice as the queue alone). When the budget holds every chunk at
  // its floor, nothing is refused and each walk is taken as it is found.
  constexpr int kLowOctave = -160, kHighOctave = 160;  // 2^-160 and below, 2^160 and above (+inf) share one
  struct Walk {
    int octave;  // of the smallest ratio up to this step
    uint32_t level;
  };
  const bool walked = counts_rise && out.within_budget, independent = walked && most <= budget.max_splats;
  std::vector<Walk> walks;
  walks.reserve(walked ? out.choices.size() * coarsest : 0);
  std::vector<size_t> walk_end(out.choices.size());
  std::vector<uint64_t> splats_by_octave(kHighOctave - kLowOctave + 1);
  for (uint32_t i = 0; i < out.choices.size() && walked; ++i) {
    double smallest = std::numeric_limits<double>::infinity();
    uint32_t from = out.choices[i].level;
    while (const std::optional<Step> step = best_step(i, from, false)) {
      const uint32_t to = std::get<2>(*step);
      if (independent) {
        take(*step);
        from = to;
        continue;
      }
      smallest = std::min(smallest, std::get<0>(*step));
      walks.push_back({std::clamp(std::ilogb(smallest), kLowOctave, kHighOctave), to});
      splats_by_octave[walks.back().octave - kLowOctave] +=
          index.at(to, out.choices[i].chunk).count - index.at(from, out.choices[i].chunk).count;
      from = to;
    }
    walk_end[i] = walks.size();
  }
  int taken_from = kHighOctave + 1;  // the walk steps of octaves >= taken_from are taken
  for (uint64_t taken = 0; walked && taken_from > kLowOctave &&
                           taken + splats_by_octave[taken_from - 1 - kLowOctave] <= budget.max_splats - out.splats;) {
    taken += splats_by_octave[--taken_from - kLowOctave];
  }
  std::vector<Step> first;  // each chunk's first step left; none when every walk was taken whole
  for (uint32_t i = 0; i < out.choices.size(); ++i) {
    for (size_t w = i == 0 ? 0 : walk_end[i - 1]; w < walk_end[i] && walks[w].octave >= taken_from; ++w) {
      take(Step{0, -int64_t{i}, walks[w].level});
    }
    if (taken_from == kLowOctave) continue;
    if (auto step = best_step(i, out.choices[i].level, true)) first.push_back(*step);
  }
  std::priority_queue<Step> next(std::less<Step>(), std::move(first));
  while (!next.empty()) {
    const Step top = next.top();
    next.pop();
    const auto i = static_cast<uint32_t>(-std::get<1>(top));
    const std::optional<Step> now = best_step(i, out.choices[i].level, true);  // the budget left shrinks
    if (!now) continue;
    if (*now != top) {
      next.push(*now);
      continue;
    }
    take(top);
    if (auto step = best_step(i, out.choices[i].level, true)) next.push(*step);
  }
  for (uint32_t i = 0; i < out.choices.size(); ++i) out.coarsened += out.choices[i].level != floor[i] ? 1 : 0;
  return out;
}

}  // namespace rgs::runtime
