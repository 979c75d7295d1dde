// Level-of-detail selection (runtime/lod_selection.h) on a hand-made index: frustum culling of chunk spheres, the
// coarsest level under the pixel threshold, the splat budget spent on the most projected error removed per splat.
#include <doctest/doctest.h>

#include <optional>
#include <random>

#include "rgs/runtime/lod_selection.h"

namespace rgs::runtime {
namespace {

/// Chunks of radius 1 on the +z axis at z = 5, 10, 20, 40 and one behind the camera (z = −10); three levels
/// of 1000, 250 and 60 Gaussians with errors 0, 0.01 and 0.04 world units.
format::LodIndex line_of_chunks() {
  format::LodIndex index;
  const float z[] = {5, 10, 20, 40, -10};
  index.chunk_count = 5;
  index.level_count = 3;
  for (float zc : z) index.chunks.push_back({{0, 0, zc}, 1.0f});
  const uint64_t counts[] = {1000, 250, 60};
  const float errors[] = {0, 0.01f, 0.04f};
  uint64_t first = 0;
  for (int l = 0; l < 3; ++l) {
    for (int c = 0; c < 5; ++c) {
      index.levels.push_back({first, counts[l], errors[l], 0});
      first += counts[l];
    }
  }
  return index;
}

/// At the origin looking along +z, 1000 × 1000 pixels, f = 1000.
Camera camera() {
  Camera c;
  c.fx = c.fy = 1000;
  c.cx = c.cy = 500;
  c.width = c.height = 1000;
  return c;
}

TEST_CASE("LOD selection: culling, pixel threshold, splat budget") {
  const format::LodIndex index = line_of_chunks();
  const Camera cam = camera();
  // Distances to the spheres: 4, 9, 19, 39. Level errors in pixels: 0.01 · 1000 / d and 0.04 · 1000 / d.
  CHECK(projected_error(cam, index.chunks[0], 0.01f) == doctest::Approx(2.5));
  CHECK(projected_error(cam, index.chunks[3], 0.04f) == doctest::Approx(40.0 / 39.0));

  SUBCASE("threshold 1 px, no budget") {
    const LodSelection s = select_lod(index, cam, {0, 1.0f});
    REQUIRE(s.choices.size() == 4);
    CHECK(s.culled == 1);  // the chunk behind the camera
    // d = 4: 2.5 px and 10 px -> level 0; d = 9: 1.11 px -> 0; d = 19: 0.53 px, 2.1 px -> 1; d = 39: 1.03 px -> 1.
    CHECK(s.choices[0].level == 0);
    CHECK(s.choices[1].level == 0);
    CHECK(s.choices[2].level == 1);
    CHECK(s.choices[3].level == 1);
    CHECK(s.splats == 1000 + 1000 + 250 + 250);
    CHECK(s.within_budget);
    CHECK(s.coarsened == 0);
  }
  SUBCASE("a budget refines, from the coarsest levels, the steps removing the most error per splat first") {
    const LodSelection s = select_lod(index, cam, {2000, 1.0f});
    // Floors (1 px): levels 0, 0, 1, 1. From 4 x 60, pixels removed per splat added: chunk 0 to level 1
    // 7.5 / 190, chunk 1 to 1 3.33 / 190, chunk 2 to 1 1.58 / 190, chunk 3 to 1 0.77 / 190, chunk 0 to 0
    // 2.5 / 750, chunk 1 to 0 1.11 / 750: the last one no longer fits 2000.
    CHECK(s.choices[0].level == 0);
    CHECK(s.choices[1].level == 1);
    CHECK(s.choices[2].level == 1);
    CHECK(s.choices[3].level == 1);
    CHECK(s.splats == 1000 + 250 + 250 + 250);
    CHECK(s.coarsened == 1);
    CHECK(s.within_budget);
  }
  SUBCASE("the budget goes to the chunk whose error drop per splat is largest") {
    // Two chunks at the same distance: A loses 0.05 for 900 splats, B 0.04 for 200. Coarsening the least
    // error first drew both at level 1; per splat, B's full detail is worth more.
    format::LodIndex two;
    two.chunk_count = 2;
    two.level_count = 2;
    two.chunks = {{{-1, 0, 10}, 1.0f}, {{1, 0, 10}, 1.0f}};
    two.levels = {{0, 1000, 0, 0}, {1000, 1000, 0, 0}, {2000, 100, 0.05f, 0}, {2100, 800, 0.04f, 0}};
    const LodSelection s = select_lod(two, cam, {1100, 0.0f});
    REQUIRE(s.choices.size() == 2);
    CHECK(s.choices[0].level == 1);
    CHECK(s.choices[1].level == 0);
    CHECK(s.splats == 1100);
    CHECK(select_lod(two, cam, {1100, 0.0f}).choices[1].level == s.choices[1].level);
  }
  SUBCASE("a budget below the coarsest levels draws them all and says so") {
    const LodSelection s = select_lod(index, cam, {100, 1.0f});
    for (const LodChoice& c : s.choices) CHECK(c.level == 2);
    CHECK(s.splats == 4 * 60);
    CHECK_FALSE(s.within_budget);
  }
  SUBCASE("a chunk just outside a side plane is culled, one touching it is kept") {
    format::LodIndex side = index;
    // The left image edge at z = 10 is x = -(500 / 1000) · 10 = -5; its plane's normal is tilted by atan(0.5).
    side.chunks[1].center[0] = -5.0f - 1.2f / 0.894427f;  // sphere 1.2 / cos beyond the plane: out
    side.chunks[2].center[0] = -5.0f - 0.8f;              // 0.8 · cos < 1 beyond: in
    side.chunks[2].center[2] = 10.0f;
    const LodSelection s = select_lod(side, cam, {0, 1.0f});
    CHECK(s.culled == 2);
    bool has1 = false, has2 = false;
    for (const LodChoice& c : s.choices) {
      has1 = has1 || c.chunk == 1;
      has2 = has2 || c.chunk == 2;
    }
    CHECK_FALSE(has1);
    CHECK(has2);
  }
}

/// The budget's greedy of lod_selection.h read literally, one step per scan of every chunk: from the coarsest
/// levels, the step of largest projected error removed per splat added among those that remove error and fit
/// (ties: the coarser level, then the lower chunk), until none fits.
std::vector<uint32_t> greedy_by_scans(const format::LodIndex& index, const Camera& cam, const LodBudget& budget,
                                      const std::vector<LodChoice>& visible) {
  std::vector<uint32_t> level(visible.size(), index.level_count - 1), floor(visible.size());
  uint64_t splats = 0;
  for (size_t i = 0; i < visible.size(); ++i) {
    const uint32_t c = visible[i].chunk;
    floor[i] = index.level_count - 1;
    while (floor[i] > 0 && projected_error(cam, index.chunks[c], index.at(floor[i], c).error) > budget.pixel_error) {
      --floor[i];
    }
    splats += index.at(level[i], c).count;
  }
  for (;;) {
    std::optional<std::pair<double, std::pair<size_t, uint32_t>>> best;
    for (size_t i = 0; i < visible.size(); ++i) {
      const uint32_t c = visible[i].chunk;
      for (uint32_t k = level[i]; k-- > floor[i];) {
        const double gain = projected_error(cam, index.chunks[c], index.at(level[i], c).error) -
                            projected_error(cam, index.chunks[c], index.at(k, c).error);
        const uint64_t cost = index.at(k, c).count - index.at(level[i], c).count;
        if (!(gain > 0) || splats + cost > budget.max_splats) continue;
        const double ratio = cost == 0 ? 1e300 : gain / double(cost);
        if (!best || ratio > best->first * (1 + 1e-12)) best = {{ratio, {i, k}}};
      }
    }
    if (!best) return level;
    const auto [i, k] = best->second;
    splats += index.at(k, visible[i].chunk).count - index.at(level[i], visible[i].chunk).count;
    level[i] = k;
  }
}

TEST_CASE("LOD selection equals its greedy read literally, whether or not the budget binds") {
  // Random chunks in front of the camera (some outside its frustum), with levels whose counts fall and errors
  // rise, under budgets from below the coarsest levels to above every floor: both the queue and the
  // chunk-by-chunk path (a budget that no step can overrun) must choose what the scan of every chunk per step
  // chooses.
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(0, 1);
  int refused = 0, unbounded = 0;  // selections that coarsened a chunk, and that no step could overrun
  for (int trial = 0; trial < 60; ++trial) {
    format::LodIndex index;
    index.chunk_count = static_cast<uint32_t>(1 + rng() % 60);
    index.level_count = static_cast<uint32_t>(1 + rng() % 4);
    index.levels.resize(size_t(index.chunk_count) * index.level_count);
    for (uint32_t c = 0; c < index.chunk_count; ++c) {
      index.chunks.push_back({{u(rng) * 40 - 20, u(rng) * 40 - 20, 5 + u(rng) * 60}, 0.5f + u(rng)});
      uint64_t count = 200 + rng() % 2000;
      float error = 0;
      for (uint32_t l = 0; l < index.level_count; ++l) {
        index.at(l, c).count = count;
        index.at(l, c).error = error;
        count = count / 2 + rng() % 50;
        error += 0.001f + u(rng) * 0.05f;
      }
    }
    const uint64_t full = index.full_detail_count();
    for (const double share : {0.02, 0.2, 0.5, 3.0}) {
      const LodBudget budget{uint64_t(share * double(full)), 0.5f + 2 * u(rng)};
      const LodSelection s = select_lod(index, camera(), budget);
      CAPTURE(trial);
      CAPTURE(share);
      const std::vector<uint32_t> expected = greedy_by_scans(index, camera(), budget, s.choices);
      REQUIRE(expected.size() == s.choices.size());
      for (size_t i = 0; i < expected.size(); ++i) CHECK(s.choices[i].level == expected[i]);
      refused += s.coarsened > 0 ? 1 : 0;
      unbounded += budget.max_splats >= full ? 1 : 0;
    }
  }
  CHECK(refused > 20);
  CHECK(unbounded == 60);
}

}  // namespace
}  // namespace rgs::runtime
