// The frame census against the CPU reference's own renders: per pixel, the Gaussians it counts as blended are
// the ones whose alphas the render composited.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "render_test_util.h"
#include "rgs/lab/frame_census.h"

namespace rgs::test {
namespace {

using lab::CensusCell;
using lab::FrameCensus;

struct CensusWithMap {
  FrameCensus census;
  std::vector<uint16_t> map;
};

CensusWithMap census_ok(const format::GaussianCloud& cloud, const runtime::Camera& camera, unsigned threads = 0) {
  CensusWithMap out;
  auto r = lab::census_frame(cloud, camera, threads, &out.map);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  out.census = *r;
  return out;
}

/// Cells of `size`×`size` pixels (16, 8, 4) where the image's alpha is non-zero.
uint64_t covered_cells(const runtime::RenderResult& image, uint32_t size) {
  const uint32_t cx = (image.width + size - 1) / size, cy = (image.height + size - 1) / size;
  std::vector<uint8_t> covered(size_t(cx) * cy, 0);
  for (uint32_t y = 0; y < image.height; ++y) {
    for (uint32_t x = 0; x < image.width; ++x) {
      if (image.alpha[size_t(y) * image.width + x] > 0.f) covered[(y / size) * cx + x / size] = 1;
    }
  }
  return uint64_t(std::count(covered.begin(), covered.end(), uint8_t{1}));
}

void check_invariants(const FrameCensus& c) {
  CHECK(c.contributing <= c.visible);
  CHECK(c.visible <= c.gaussians);
  CHECK(c.reaching_pairs[int(CensusCell::k16)] <= c.rect_pairs);
  for (int cell = 0; cell < lab::kCensusCells; ++cell) {
    CAPTURE(cell);
    CHECK(c.blending_pairs[cell] <= c.reaching_pairs[cell]);
    if (cell > 0) {
      // A smaller cell splits each larger one into 4: at least as many pairs, at most 4 times as many.
      CHECK(c.blending_pairs[cell] >= c.blending_pairs[cell - 1]);
      CHECK(c.blending_pairs[cell] <= 4 * c.blending_pairs[cell - 1]);
      CHECK(c.reaching_pairs[cell] >= c.reaching_pairs[cell - 1]);
    }
  }
  CHECK(c.blended >= c.blending_pairs[int(CensusCell::k4)]);  // a blending pair blends at one pixel at least
  // Hidden pairs lie beyond every pixel's walk: none of them blends, so they and the blending ones are disjoint.
  CHECK(c.hidden_reaching_pairs <= c.hidden_rect_pairs);
  CHECK(c.hidden_rect_pairs <= c.rect_pairs);
  CHECK(c.blending_pairs[int(CensusCell::k16)] + c.hidden_reaching_pairs <= c.reaching_pairs[int(CensusCell::k16)]);
  CHECK((c.saturated_tiles == 0) <= (c.hidden_rect_pairs == 0));
}

}  // namespace

TEST_CASE("census: stacked copies of one Gaussian blend where its alpha does, until T would drop below 1e-4") {
  // The same Gaussian k times at one place: at a pixel each copy has the alpha a of the single Gaussian, so the
  // render of the stack has 1 − alpha = (1 − a)^b, b the copies the census says the pixel blended.
  const runtime::Camera camera = identity_camera(64, 48, 60.f);
  for (const float opacity : {0.5f, 0.999f}) {
    CAPTURE(opacity);
    format::GaussianCloud one;
    add_gaussian(&one, 0.1f, -0.05f, 4.f, 0.4f, opacity, 0.3f, 0.2f, 0.1f);
    const runtime::RenderResult single = render_ok(one, camera);
    constexpr int kCopies = 4;
    format::GaussianCloud stack;
    for (int i = 0; i < kCopies; ++i) add_gaussian(&stack, 0.1f, -0.05f, 4.f, 0.4f, opacity, 0.3f, 0.2f, 0.1f);
    const runtime::RenderResult image = render_ok(stack, camera);
    const CensusWithMap c = census_ok(stack, camera);
    check_invariants(c.census);
    CHECK(c.census.contributing == kCopies);
    uint64_t covered = 0, capped = 0;
    for (size_t p = 0; p < c.map.size(); ++p) {
      const float a = single.alpha[p];
      const uint16_t b = c.map[p];
      CAPTURE(p);
      if (a == 0.f) {
        CHECK(b == 0);
        continue;
      }
      ++covered;
      CHECK(b >= 1);
      CHECK(b <= kCopies);
      if (b < kCopies) ++capped;
      CHECK(1.0 - double(image.alpha[p]) == doctest::Approx(std::pow(1.0 - double(a), b)).epsilon(1e-5));
    }
    CHECK(covered > 100);
    // Opaque copies end the walk early near the centre: after α = 0.99, T = 1 − 0.99 = 0.00999999 in float32,
    // and a second copy would leave 9.999981e-05 < 1e-4. The half-transparent ones never end it.
    if (opacity > 0.99f) {
      CHECK(capped > 0);
      const size_t centre = size_t(std::max_element(single.alpha.begin(), single.alpha.end()) - single.alpha.begin());
      CHECK(single.alpha[centre] > 0.98f);
      CHECK(c.map[centre] == 1);
    } else {
      CHECK(capped == 0);
      CHECK(c.census.blended == kCopies * covered);
      CHECK(c.census.max_blended == kCopies);
      // Without early termination every pair that reaches 1/255 blends, and each cell the single Gaussian
      // covers holds the k copies.
      for (int cell = 0; cell < lab::kCensusCells; ++cell) {
        CHECK(c.census.blending_pairs[cell] == c.census.reaching_pairs[cell]);
      }
      CHECK(c.census.blending_pairs[int(CensusCell::k16)] == kCopies * covered_cells(single, 16));
      CHECK(c.census.blending_pairs[int(CensusCell::k8)] == kCopies * covered_cells(single, 8));
      CHECK(c.census.blending_pairs[int(CensusCell::k4)] == kCopies * covered_cells(single, 4));
      // Every other (pixel, copy) of the 3DGS rectangles' tiles is a test that changes nothing (all tiles full).
      CHECK(c.census.skipped == c.census.rect_pairs * 256 - c.census.blended);
    }
  }
}

TEST_CASE("census: behind a Gaussian that saturates every pixel, the rest of each tile's list is hidden") {
  // A Gaussian far wider than the view has α = 0.99 at every pixel; a second copy would take T below 1e-4, so every
  // walk ends at list index 1 and each tile's copies from there on are hidden.
  const runtime::Camera camera = identity_camera(64, 48, 60.f);
  constexpr int kCopies = 5;
  format::GaussianCloud stack;
  for (int i = 0; i < kCopies; ++i) add_gaussian(&stack, 0.f, 0.f, 4.f + 0.01f * float(i), 100.f, 0.999f, 0.3f, 0.2f, 0.1f);
  const CensusWithMap c = census_ok(stack, camera);
  check_invariants(c.census);
  const uint64_t tiles = (64 / 16) * (48 / 16);
  CHECK(c.census.rect_pairs == kCopies * tiles);
  CHECK(c.census.saturated_tiles == tiles);
  CHECK(c.census.hidden_rect_pairs == (kCopies - 1) * tiles);
  CHECK(c.census.hidden_reaching_pairs == (kCopies - 1) * tiles);
  CHECK(c.census.blending_pairs[int(CensusCell::k16)] == tiles);
  // Half as opaque, no walk ends: nothing is hidden.
  format::GaussianCloud faint;
  for (int i = 0; i < kCopies; ++i) add_gaussian(&faint, 0.f, 0.f, 4.f + 0.01f * float(i), 100.f, 0.5f, 0.3f, 0.2f, 0.1f);
  const CensusWithMap f = census_ok(faint, camera);
  check_invariants(f.census);
  CHECK(f.census.saturated_tiles == 0);
  CHECK(f.census.hidden_rect_pairs == 0);
}

TEST_CASE("census of guitar: pixels that blend are the pixels the render covers, counts independent of threads") {
  auto ply = converter::read_ply(repo_path("samples/guitar.ply"));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  const format::GaussianCloud& cloud = ply->cloud;
  auto cams = runtime::orbit_cameras(converter::compute_bounds(cloud), 2, 320, 240);
  REQUIRE(cams.ok());
  for (const runtime::Camera& camera : *cams) {
    CAPTURE(camera.name);
    const runtime::RenderResult image = render_ok(cloud, camera);
    const CensusWithMap c = census_ok(cloud, camera, 1);
    check_invariants(c.census);
    CHECK(c.census.gaussians == cloud.size());
    uint64_t mismatched = 0;
    for (size_t p = 0; p < c.map.size(); ++p) mismatched += (image.alpha[p] > 0.f) != (c.map[p] > 0);
    CHECK(mismatched == 0);
    CHECK(std::accumulate(c.map.begin(), c.map.end(), uint64_t{0}) == c.census.blended);
    CHECK(*std::max_element(c.map.begin(), c.map.end()) == c.census.max_blended);
    CHECK(c.census.blended > 10 * c.census.pixels() / 100);  // a real scene covers its view
    CHECK(c.census.skipped > 0);
    CHECK(c.census.contributing > 0);

    const CensusWithMap threaded = census_ok(cloud, camera, 3);
    CHECK(threaded.map == c.map);
    CHECK(threaded.census.blended == c.census.blended);
    CHECK(threaded.census.skipped == c.census.skipped);
    CHECK(threaded.census.contributing == c.census.contributing);
    for (int cell = 0; cell < lab::kCensusCells; ++cell) {
      CHECK(threaded.census.blending_pairs[cell] == c.census.blending_pairs[cell]);
      CHECK(threaded.census.reaching_pairs[cell] == c.census.reaching_pairs[cell]);
    }
    CHECK(threaded.census.saturated_tiles == c.census.saturated_tiles);
    CHECK(threaded.census.hidden_rect_pairs == c.census.hidden_rect_pairs);
    CHECK(threaded.census.hidden_reaching_pairs == c.census.hidden_reaching_pairs);
  }
}

}  // namespace rgs::test
