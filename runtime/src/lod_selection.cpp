// Per-frame level-of-detail selection (lod_selection.h).
#include "rgs/runtime/lod_selection.h"

#include <algorithm>
#include <cmath>
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
  std::vector<double> scale;  // f / d per chosen chunk: projected error = error · scale
  const std::array<float, 3> centre = camera_centre(camera);
  const double focal = std::max(camera.fx, camera.fy);
  const Frustum frustum(camera);
  for (uint32_t c = 0; c < index.chunk_count; ++c) {
    const format::LodChunk& chunk = index.chunks[c];
    if (!frustum.holds(chunk.center, chunk.radius)) {
      ++out.culled;
      continue;
    }
    const double s = focal / chunk_distance(camera, centre, chunk);  // projected_error(camera, chunk, 1)
    uint32_t level = coarsest;
    while (level > 0 && index.at(level, c).error * s > budget.pixel_error) --level;
    out.choices.push_back({c, level});
    scale.push_back(s);
    out.splats += index.at(level, c).count;
  }
  if (budget.max_splats == 0 || out.splats <= budget.max_splats) return out;

  // Coarsen the chunk whose next level shows the least error, one level at a time.
  using Step = std::tuple<double, uint32_t>;  // (projected error of the next coarser level, choice index)
  std::priority_queue<Step, std::vector<Step>, std::greater<Step>> next;
  std::vector<uint32_t> from(out.choices.size());
  auto push = [&](uint32_t i) {
    const LodChoice& ch = out.choices[i];
    if (ch.level < coarsest) next.emplace(index.at(ch.level + 1, ch.chunk).error * scale[i], i);
  };
  for (uint32_t i = 0; i < out.choices.size(); ++i) {
    from[i] = out.choices[i].level;
    push(i);
  }
  while (out.splats > budget.max_splats && !next.empty()) {
    const uint32_t i = std::get<1>(next.top());
    next.pop();
    LodChoice& ch = out.choices[i];
    out.splats -= index.at(ch.level, ch.chunk).count - index.at(ch.level + 1, ch.chunk).count;
    ++ch.level;
    push(i);
  }
  for (uint32_t i = 0; i < out.choices.size(); ++i) out.coarsened += out.choices[i].level != from[i] ? 1 : 0;
  out.within_budget = out.splats <= budget.max_splats;
  return out;
}

}  // namespace rgs::runtime
