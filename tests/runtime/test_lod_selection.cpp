// Level-of-detail selection (runtime/lod_selection.h) on a hand-made index: frustum culling of chunk spheres, the
// coarsest level under the pixel threshold, the splat budget spent on the most projected error removed per splat.
#include <doctest/doctest.h>

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

}  // namespace
}  // namespace rgs::runtime
