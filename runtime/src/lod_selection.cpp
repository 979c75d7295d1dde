// Per-frame level-of-detail selection (lod_selection.h).
#include "rgs/runtime/lod_selection.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <tuple>

namespace rgs::runtime {

bool sphere_in_frustum(const Camera& camera, const float center[3], float radius) {
  const auto& R = camera.rotation;
  double p[3];
  for (int i = 0; i < 3; ++i) {
    p[i] = double(R[i * 3 + 0]) * center[0] + double(R[i * 3 + 1]) * center[1] + double(R[i * 3 + 2]) * center[2] +
           camera.translation[i];
  }
  const double r = radius;
  if (p[2] + r <= camera.near_plane) return false;
  // Side planes through the camera centre and the image edges (pixel centres at integer coordinates, so the
  // edges are at −0.5 and width − 0.5): a·x + b·z ≥ 0 inside, with (a, b) the plane's inward normal.
  const double left = camera.cx, right = double(camera.width) - camera.cx;
  const double top = camera.cy, bottom = double(camera.height) - camera.cy;
  auto outside = [r](double a, double b, double x, double z) { return (a * x + b * z) / std::hypot(a, b) < -r; };
  return !(outside(camera.fx, left, p[0], p[2]) || outside(-camera.fx, right, p[0], p[2]) ||
           outside(camera.fy, top, p[1], p[2]) || outside(-camera.fy, bottom, p[1], p[2]));
}

namespace {

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
  for (uint32_t c = 0; c < index.chunk_count; ++c) {
    const format::LodChunk& chunk = index.chunks[c];
    if (!sphere_in_frustum(camera, chunk.center, chunk.radius)) {
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
