// build_lod(): the level-of-detail rules of format/SPEC.md §4.9 on real scenes, the moment-matching merge on
// hand-made ones, determinism across thread counts, and the inputs it refuses.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "rgs/converter/lod_builder.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/half.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using converter::build_lod;
using converter::LodBuildOptions;
using converter::LodScene;

format::EncodedScene quantized(const std::string& path, format::ScaleEncoding encoding) {
  auto ply = converter::read_ply(repo_path(path));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  converter::QuantizeOptions options;
  options.scale_encoding = encoding;
  auto encoded = converter::quantize(ply->cloud, options);
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  return std::move(encoded).value();
}

LodScene build_ok(const format::EncodedScene& scene, const LodBuildOptions& options) {
  auto r = build_lod(scene, options);
  REQUIRE_MESSAGE(r.ok(), r.status().to_string());
  return std::move(r).value();
}

/// Linear scale of stored scale bits, as the readers decode it.
float linear_scale(const format::EncodedScene& s, uint64_t i, int axis) {
  const float v = format::half_bits_to_float(s.scales[i * 3 + axis]);
  return s.metadata.scale_encoding == format::ScaleEncoding::kLog ? std::exp(v) : v;
}

/// Gaussian i's stored bytes (every section) as one string, for bitwise comparisons.
std::string record(const format::EncodedScene& s, uint64_t i) {
  const size_t sh_values = format::sh_coefficient_count(s.metadata.sh_degree) * 3;
  std::string r;
  r.append(reinterpret_cast<const char*>(&s.means[i * 3]), 12);
  r.append(reinterpret_cast<const char*>(&s.rotations[i * 4]), 8);
  r.append(reinterpret_cast<const char*>(&s.scales[i * 3]), 6);
  r.append(reinterpret_cast<const char*>(&s.opacities[i]), 2);
  r.append(reinterpret_cast<const char*>(&s.sh[i * sh_values]), sh_values);
  if (!s.sh_dc_residual.empty()) r.append(reinterpret_cast<const char*>(&s.sh_dc_residual[i * 3]), 3);
  return r;
}

double distance(const float* a, const float* b) {
  double d2 = 0;
  for (int k = 0; k < 3; ++k) d2 += std::pow(double(a[k]) - double(b[k]), 2);
  return std::sqrt(d2);
}

/// Every rule of SPEC §4.9 and of build_lod()'s contract that can be checked from the output alone.
void check_lod(const format::EncodedScene& in, const LodScene& lod, const LodBuildOptions& options) {
  const format::EncodedScene& out = lod.scene;
  const format::LodIndex& index = lod.index;
  const uint32_t C = index.chunk_count, L = index.level_count;
  const uint64_t n0 = in.count;
  REQUIRE(out.is_consistent());
  REQUIRE(C >= 1);
  REQUIRE(L >= 1);
  REQUIRE(L <= format::kMaxLodLevels);
  REQUIRE(index.chunks.size() == C);
  REQUIRE(index.levels.size() == size_t(L) * C);
  CHECK(out.sh_dc_residual.empty() == in.sh_dc_residual.empty());
  CHECK(out.metadata.sh_degree == in.metadata.sh_degree);
  CHECK(out.metadata.scale_encoding == in.metadata.scale_encoding);
  CHECK(std::memcmp(&out.metadata.sh_quantization, &in.metadata.sh_quantization, sizeof(format::ShQuantization)) == 0);
  REQUIRE(out.provenance.size() == in.provenance.size() + 2);
  CHECK(out.provenance[out.provenance.size() - 2] == std::make_pair(std::string("lod_levels"), std::to_string(L)));
  CHECK(out.provenance.back() == std::make_pair(std::string("lod_chunks"), std::to_string(C)));

  // Level-major records tiling [0, N); counts ≥ 1, non-increasing, about a quarter per level; errors.
  uint64_t next = 0;
  std::vector<uint64_t> totals(L, 0);
  for (uint32_t l = 0; l < L; ++l) {
    for (uint32_t c = 0; c < C; ++c) {
      CAPTURE(l);
      CAPTURE(c);
      const format::LodLevel& r = index.levels[size_t(l) * C + c];
      CHECK(&r == &index.at(l, c));
      REQUIRE(r.first == next);
      REQUIRE(r.count >= 1);
      CHECK(r.checksum == 0);
      CHECK(r.count <= options.max_chunk_gaussians);
      CHECK(std::isfinite(r.error));
      next += r.count;
      totals[l] += r.count;
      if (l == 0) {
        CHECK(r.error == 0.0f);
      } else {
        const format::LodLevel& p = index.at(l - 1, c);
        CHECK(r.count <= p.count);
        CHECK((4 * r.count <= p.count || r.count == 1));
        CHECK(r.error >= p.error);
      }
    }
  }
  CHECK(next == out.count);
  CHECK(totals[0] == n0);
  CHECK(index.full_detail_count() == n0);
  if (options.levels == 0) {
    // Auto: the first level at 1/64 of the full detail or with one Gaussian per chunk, at most 8 levels.
    CHECK(L <= 8);
    const bool done = totals[L - 1] * 64 <= n0 || totals[L - 1] == C;
    CHECK((done || L == 8));
    for (uint32_t l = 0; l + 1 < L; ++l) CHECK((totals[l] * 64 > n0 && totals[l] > C));
  } else {
    CHECK(L == options.levels);
  }

  // Level 0 is the input, bit for bit, reordered.
  std::vector<std::string> a(n0), b(n0);
  for (uint64_t i = 0; i < n0; ++i) {
    a[i] = record(in, i);
    b[i] = record(out, i);
  }
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  CHECK(a == b);

  // Valid values (SPEC §4.4–§4.7) and every Gaussian of every level inside its chunk's sphere.
  const bool log_scale = out.metadata.scale_encoding == format::ScaleEncoding::kLog;
  uint64_t bad_values = 0, outside_sphere = 0;
  for (uint32_t c = 0; c < C; ++c) {
    const format::LodChunk& chunk = index.chunks[c];
    REQUIRE(std::isfinite(chunk.radius));
    for (uint32_t l = 0; l < L; ++l) {
      const format::LodLevel& r = index.at(l, c);
      for (uint64_t g = r.first; g < r.first + r.count; ++g) {
        bool zero_rotation = true;
        for (int k = 0; k < 4; ++k) {
          const float q = format::half_bits_to_float(out.rotations[g * 4 + k]);
          bad_values += !std::isfinite(q);
          zero_rotation = zero_rotation && q == 0.0f;
        }
        bad_values += zero_rotation;
        float largest = 0;
        for (int k = 0; k < 3; ++k) {
          const float v = format::half_bits_to_float(out.scales[g * 3 + k]);
          bad_values += log_scale ? !(v <= 88.6875f) : !(v >= 0.0f && std::isfinite(v));
          largest = std::max(largest, linear_scale(out, g, k));
        }
        const float o = format::half_bits_to_float(out.opacities[g]);
        bad_values += !(o >= 0.0f && o <= 1.0f);
        const size_t sh_values = format::sh_coefficient_count(out.metadata.sh_degree) * 3;
        for (size_t j = 0; j < sh_values; ++j) bad_values += out.sh[g * sh_values + j] == -128;
        outside_sphere += distance(&out.means[g * 3], chunk.center) + 3.0 * largest > double(chunk.radius);
      }
    }
  }
  CHECK(bad_values == 0);
  CHECK(outside_sphere == 0);

  // Metadata bounds hold every mean of every level (SPEC §4.1.1, validators' slack).
  const format::SceneBounds& bounds = out.metadata.bounds;
  uint64_t outside_bounds = 0;
  double slack = bounds.sphere_radius;
  for (int k = 0; k < 3; ++k) slack = std::max(slack, double(std::fabs(bounds.sphere_center[k])));
  for (uint64_t g = 0; g < out.count; ++g) {
    for (int k = 0; k < 3; ++k) {
      outside_bounds += out.means[g * 3 + k] < bounds.aabb_min[k] || out.means[g * 3 + k] > bounds.aabb_max[k];
      outside_bounds += !std::isfinite(out.means[g * 3 + k]);
    }
    outside_bounds += distance(&out.means[g * 3], bounds.sphere_center) > bounds.sphere_radius + 1e-6 * slack;
  }
  CHECK(outside_bounds == 0);
  format::GaussianCloud positions;
  positions.means = out.means;
  const format::SceneBounds expected = converter::compute_bounds(positions);
  CHECK(std::memcmp(&expected, &bounds, sizeof(bounds)) == 0);
}

TEST_CASE("lod: guitar in several chunks satisfies every rule of SPEC 4.9 (linear and log scales)") {
  for (auto encoding : {format::ScaleEncoding::kLinear, format::ScaleEncoding::kLog}) {
    const std::string encoding_name = format::to_string(encoding);
    CAPTURE(encoding_name);
    const format::EncodedScene scene = quantized("samples/guitar.ply", encoding);
    LodBuildOptions options;
    options.max_chunk_gaussians = 4096;
    const LodScene lod = build_ok(scene, options);
    CHECK(lod.index.chunk_count > 8);
    MESSAGE("guitar: " << scene.count << " Gaussians, " << lod.index.chunk_count << " chunks, "
                       << lod.index.level_count << " levels, " << lod.scene.count << " Gaussians out");
    check_lod(scene, lod, options);
  }
}

TEST_CASE("lod: SH 3 with DC residuals at explicit level counts, in one chunk and in several") {
  const format::EncodedScene scene = quantized(kGuitarSh3, format::ScaleEncoding::kLinear);
  REQUIRE(!scene.sh_dc_residual.empty());
  for (uint32_t levels : {1u, 3u, 16u}) {
    for (uint32_t max_chunk : {500u, 65536u}) {
      CAPTURE(levels);
      CAPTURE(max_chunk);
      LodBuildOptions options;
      options.levels = levels;
      options.max_chunk_gaussians = max_chunk;
      const LodScene lod = build_ok(scene, options);
      CHECK((max_chunk < scene.count) == (lod.index.chunk_count > 1));
      check_lod(scene, lod, options);
      if (levels == 16) {
        // Every chunk gets down to one Gaussian, then repeats it bit for bit.
        for (uint32_t c = 0; c < lod.index.chunk_count; ++c) {
          const format::LodLevel& last = lod.index.at(15, c);
          CHECK(last.count == 1);
          CHECK(record(lod.scene, last.first) == record(lod.scene, lod.index.at(14, c).first));
        }
      }
    }
  }
}

/// Closed-form eigenvalues of a symmetric 3×3 matrix (trigonometric method), descending.
void symmetric_eigenvalues(const double m[3][3], double out[3]) {
  const double p1 = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
  const double q = (m[0][0] + m[1][1] + m[2][2]) / 3;
  const double p2 = std::pow(m[0][0] - q, 2) + std::pow(m[1][1] - q, 2) + std::pow(m[2][2] - q, 2) + 2 * p1;
  const double p = std::sqrt(p2 / 6);
  double b[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) b[i][j] = (m[i][j] - (i == j ? q : 0)) / p;
  }
  const double det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) -
                     b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
                     b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
  const double phi = std::acos(std::clamp(det / 2, -1.0, 1.0)) / 3;
  out[0] = q + 2 * p * std::cos(phi);
  out[2] = q + 2 * p * std::cos(phi + 2.0943951023931957);  // phi + 2π/3
  out[1] = 3 * q - out[0] - out[2];
}

/// Covariance R diag(s²) Rᵀ of Gaussian i of a dequantized cloud (quaternion normalized, 3DGS convention).
void covariance(const format::GaussianCloud& g, uint64_t i, double cov[3][3]) {
  double q[4], n = 0;
  for (int k = 0; k < 4; ++k) n += std::pow(q[k] = g.rotations[i * 4 + k], 2);
  for (double& v : q) v /= std::sqrt(n);
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      cov[a][b] = 0;
      for (int k = 0; k < 3; ++k) cov[a][b] += r[a][k] * r[b][k] * std::pow(double(g.scales[i * 3 + k]), 2);
    }
  }
}

/// A small SH-1 cloud, quantized with the converter's defaults (DC residuals) and the given scale encoding.
format::EncodedScene hand_made(const std::vector<std::vector<float>>& gaussians, format::ScaleEncoding encoding) {
  // Each row: mean (3), quaternion (4), scales (3), opacity, then 12 SH values (4 coefficients × 3 channels).
  format::GaussianCloud cloud;
  cloud.sh_degree = 1;
  cloud.resize(gaussians.size());
  for (size_t i = 0; i < gaussians.size(); ++i) {
    const std::vector<float>& g = gaussians[i];
    REQUIRE(g.size() == 23);
    std::copy(g.begin(), g.begin() + 3, &cloud.means[i * 3]);
    std::copy(g.begin() + 3, g.begin() + 7, &cloud.rotations[i * 4]);
    std::copy(g.begin() + 7, g.begin() + 10, &cloud.scales[i * 3]);
    cloud.opacities[i] = g[10];
    std::copy(g.begin() + 11, g.end(), &cloud.sh[i * 12]);
  }
  converter::QuantizeOptions options;
  options.scale_encoding = encoding;
  auto e = converter::quantize(cloud, options);
  REQUIRE_MESSAGE(e.ok(), e.status().to_string());
  return std::move(e).value();
}

TEST_CASE("lod: two Gaussians merge into the moment-matched parent") {
  const std::vector<std::vector<float>> rows = {
      {0.0f, 0.0f, 0.0f, 0.9f, 0.1f, -0.3f, 0.2f, 0.10f, 0.05f, 0.02f, 0.7f,
       0.5f, -0.2f, 0.1f, 0.05f, 0.02f, -0.01f, 0.03f, -0.04f, 0.0f, 0.01f, 0.02f, 0.03f},
      {0.3f, -0.1f, 0.2f, 0.2f, 0.8f, 0.1f, -0.4f, 0.20f, 0.04f, 0.01f, 0.4f,
       -0.3f, 0.4f, 0.2f, -0.02f, 0.04f, 0.05f, -0.03f, 0.01f, 0.02f, 0.0f, -0.02f, 0.01f}};
  for (auto encoding : {format::ScaleEncoding::kLinear, format::ScaleEncoding::kLog}) {
    const std::string encoding_name = format::to_string(encoding);
    CAPTURE(encoding_name);
    const format::EncodedScene scene = hand_made(rows, encoding);
    LodBuildOptions options;
    options.levels = 2;
    const LodScene lod = build_ok(scene, options);
    check_lod(scene, lod, options);
    REQUIRE(lod.index.chunk_count == 1);
    REQUIRE(lod.index.at(1, 0).count == 1);
    auto children = format::dequantize(scene);
    auto all = format::dequantize(lod.scene);
    REQUIRE(children.ok());
    REQUIRE(all.ok());
    const format::GaussianCloud& ch = *children;
    const uint64_t p = lod.index.at(1, 0).first;

    // The formulas of lod_builder.h in double from the decoded children; areas of the scales as drawn.
    // δ² from the cell's diagonal g: the means differ in x's top bit, so the cell is the chunk's 0.3 cube.
    const double g = std::sqrt(3.0) * double(0.3f);
    const double delta2 = 0.3 * g * g;
    auto drawn_area = [delta2](double s0, double s1, double s2) {
      const double d0 = std::sqrt(s0 * s0 + delta2), d1 = std::sqrt(s1 * s1 + delta2), d2 = std::sqrt(s2 * s2 + delta2);
      return d0 * d1 + d0 * d2 + d1 * d2;
    };
    double w[2], area[2], alpha[2];
    for (int i = 0; i < 2; ++i) {
      const float* s = &ch.scales[i * 3];
      area[i] = drawn_area(s[0], s[1], s[2]);
      alpha[i] = ch.opacities[i];
      w[i] = alpha[i] * area[i];
    }
    const double W = w[0] + w[1];
    double mu[3];
    for (int a = 0; a < 3; ++a) mu[a] = (w[0] * ch.means[a] + w[1] * ch.means[3 + a]) / W;
    double expected[3][3] = {};
    for (int i = 0; i < 2; ++i) {
      double c[3][3];
      covariance(ch, i, c);
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) {
          expected[a][b] += w[i] * (c[a][b] + (ch.means[i * 3 + a] - mu[a]) * (ch.means[i * 3 + b] - mu[b])) / W;
        }
      }
    }
    for (int a = 0; a < 3; ++a) CHECK(all->means[p * 3 + a] == doctest::Approx(mu[a]).epsilon(1e-6));
    // Covariance from the stored scales and rotation, within FP16 precision of the largest eigenvalue.
    double eig[3], got[3][3];
    symmetric_eigenvalues(expected, eig);
    covariance(*all, p, got);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) CHECK(std::fabs(got[a][b] - expected[a][b]) <= 3e-3 * eig[0]);
    }
    // Scales: square roots of the eigenvalues, largest first.
    for (int k = 0; k < 3; ++k) {
      CHECK(all->scales[p * 3 + k] == doctest::Approx(std::sqrt(eig[k])).epsilon(2e-3));
    }
    // SH: the weighted mean, to half an INT8 step (the DC term to half a residual step).
    const auto& s = scene.metadata.sh_quantization.scales;
    for (int j = 0; j < 12; ++j) {
      const double v = (w[0] * ch.sh[j] + w[1] * ch.sh[12 + j]) / W;
      const double step = s[format::sh_degree_of_coefficient(uint32_t(j / 3))][j % 3];
      CAPTURE(j);
      CHECK(std::fabs(all->sh[p * 12 + j] - v) <= (j < 3 ? step / 512 : step / 2) * 1.001 + 1e-7);
    }
    // Opacity: coverage over the parent's area S_p as drawn (from the exact eigenvalues).
    const double sp = drawn_area(std::sqrt(eig[0]), std::sqrt(eig[1]), std::sqrt(eig[2]));
    const double ln_t =
        area[0] / sp * std::log(1 - std::min(alpha[0], 0.999)) + area[1] / sp * std::log(1 - std::min(alpha[1], 0.999));
    CHECK(all->opacities[p] == doctest::Approx(1 - std::exp(ln_t)).epsilon(2e-3));
    // The stored quaternion is unit with w ≥ 0.
    CHECK(all->rotations[p * 4] >= 0.0f);
  }
}

TEST_CASE("lod: coincident copies give 1 - (1 - a)^2, a lone Gaussian in its cell stays bit for bit") {
  // Two identical Gaussians: the parent is the same shape with the coverage of both.
  const std::vector<float> g = {1.0f, 2.0f, 3.0f, 1.0f, 0.0f, 0.0f, 0.0f, 0.3f, 0.2f, 0.1f, 0.5f,
                                0.2f, 0.1f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  {
    const format::EncodedScene scene = hand_made({g, g}, format::ScaleEncoding::kLinear);
    LodBuildOptions options;
    options.levels = 2;
    const LodScene lod = build_ok(scene, options);
    const uint64_t p = lod.index.at(1, 0).first;
    const float a = format::half_bits_to_float(scene.opacities[0]);
    CHECK(format::half_bits_to_float(lod.scene.opacities[p]) == doctest::Approx(1 - (1 - a) * (1 - a)).epsilon(1e-3));
    for (int k = 0; k < 3; ++k) CHECK(lod.scene.means[p * 3 + k] == scene.means[k]);
    for (int k = 0; k < 3; ++k) {
      CHECK(format::half_bits_to_float(lod.scene.scales[p * 3 + k]) ==
            doctest::Approx(format::half_bits_to_float(scene.scales[k])).epsilon(1e-3));
    }
    CHECK(std::equal(scene.sh.begin(), scene.sh.begin() + 12, lod.scene.sh.begin() + std::ptrdiff_t(p * 12)));
  }
  // Seven Gaussians in a small cluster and one far away: level 1 merges the cluster into one parent and
  // keeps the far one unchanged; level 2 merges the two.
  std::vector<std::vector<float>> rows;
  for (int i = 0; i < 7; ++i) {
    std::vector<float> r = g;
    r[0] = 0.001f * float(i);
    r[1] = 0.002f * float(i % 3);
    r[2] = 0.0015f * float(i % 2);
    r[7] = r[8] = r[9] = 0.001f;
    rows.push_back(r);
  }
  std::vector<float> far = g;
  far[0] = far[1] = far[2] = 10.0f;
  rows.push_back(far);
  const format::EncodedScene scene = hand_made(rows, format::ScaleEncoding::kLinear);
  LodBuildOptions options;
  options.levels = 3;
  const LodScene lod = build_ok(scene, options);
  check_lod(scene, lod, options);
  REQUIRE(lod.index.chunk_count == 1);
  CHECK(lod.index.at(1, 0).count == 2);
  CHECK(lod.index.at(2, 0).count == 1);
  const uint64_t l1 = lod.index.at(1, 0).first;
  const bool kept = record(lod.scene, l1) == record(scene, 7) || record(lod.scene, l1 + 1) == record(scene, 7);
  CHECK(kept);
  // The cluster's parent sits inside the cluster's box.
  const uint64_t cluster = record(lod.scene, l1) == record(scene, 7) ? l1 + 1 : l1;
  CHECK(lod.scene.means[cluster * 3] >= 0.0f);
  CHECK(lod.scene.means[cluster * 3] <= 0.006f);
  CHECK(lod.index.at(1, 0).error < lod.index.at(2, 0).error);
}

TEST_CASE("lod: the measured error is near 0 for coincident copies and large for erased thin bright streaks") {
  const std::vector<float> g = {1.0f, 2.0f, 3.0f, 1.0f, 0.0f, 0.0f, 0.0f, 0.3f, 0.2f, 0.1f, 0.5f,
                                0.2f, 0.1f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  LodBuildOptions options;
  options.levels = 2;
  // Four copies of each of two Gaussians 1 apart: level 1 merges the copies and changes nothing drawn.
  std::vector<std::vector<float>> copies(8, g);
  for (size_t i = 4; i < 8; ++i) copies[i][0] = 2.0f;
  const LodScene same = build_ok(hand_made(copies, format::ScaleEncoding::kLinear), options);
  REQUIRE(same.index.at(1, 0).count == 2);
  CHECK(same.index.at(1, 0).error < 1e-3f);  // against the RMS radius 0.37
  // Sixteen streaks 3 long and 0.003 thin, 0.05 apart, alternately white and black: level 1 merges them four
  // by four into grey. Their means span a 0.75 cube, whose diagonal (1.3) bounds every cell of the chunk, but
  // the lost stripes are 3 long: the measured error is above any cell's diagonal.
  std::vector<std::vector<float>> streaks;
  for (int i = 0; i < 16; ++i) {
    std::vector<float> r = g;
    r[0] = 0, r[1] = 0.05f * float(i), r[2] = 0;
    r[7] = 3.0f, r[8] = r[9] = 0.003f, r[10] = 0.9f;
    for (int c = 0; c < 3; ++c) r[11 + c] = (i % 2 == 0 ? 0.5f : -0.5f) / 0.28209479f;  // colour 1 or 0
    streaks.push_back(r);
  }
  const format::EncodedScene scene = hand_made(streaks, format::ScaleEncoding::kLinear);
  const LodScene lod = build_ok(scene, options);
  check_lod(scene, lod, options);
  REQUIRE(lod.index.at(1, 0).count == 4);
  CHECK(lod.index.at(1, 0).error > std::sqrt(3.0f) * 0.75f);
  CHECK(lod.index.at(1, 0).error > 2.0f);  // 0.9 · (|0.5 · (1, 1, 1)| · r_p ≈ 3): about 2.3
}

TEST_CASE("lod: identical means split by index into chunks, each merged into one Gaussian") {
  const std::vector<float> g = {1.0f, 2.0f, 3.0f, 1.0f, 0.0f, 0.0f, 0.0f, 0.3f, 0.2f, 0.1f, 0.5f,
                                0.2f, 0.1f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  std::vector<std::vector<float>> rows(1000, g);
  for (size_t i = 0; i < rows.size(); ++i) rows[i][10] = 0.1f + 0.0008f * float(i);  // distinct opacities
  const format::EncodedScene scene = hand_made(rows, format::ScaleEncoding::kLog);
  LodBuildOptions options;
  options.max_chunk_gaussians = 64;
  const LodScene lod = build_ok(scene, options);
  check_lod(scene, lod, options);
  CHECK(lod.index.chunk_count == 16);  // ceil(1000 / 64) pieces of 62 or 63
  CHECK(lod.index.level_count == 2);   // every chunk is down to one Gaussian at level 1
  for (uint32_t c = 0; c < lod.index.chunk_count; ++c) {
    CHECK(lod.index.at(1, c).count == 1);
    CHECK(lod.index.at(1, c).error == 0.0f);  // nothing moved
  }
  // One Gaussian per chunk: nothing to merge, a single level.
  options.max_chunk_gaussians = 1;
  const LodScene single = build_ok(scene, options);
  check_lod(scene, single, options);
  CHECK(single.index.chunk_count == 1000);
  CHECK(single.index.level_count == 1);
}

TEST_CASE("lod: the same bytes whatever the number of threads, progress from the calling thread") {
  const format::EncodedScene scene = quantized("samples/guitar.ply", format::ScaleEncoding::kLinear);
  LodBuildOptions options;
  options.max_chunk_gaussians = 2000;
  options.threads = 1;
  const LodScene one = build_ok(scene, options);
  for (uint32_t threads : {2u, 3u}) {
    CAPTURE(threads);
    options.threads = threads;
    std::vector<double> seen;
    bool other_thread = false;
    const std::thread::id caller = std::this_thread::get_id();
    options.progress = [&](double f) {
      seen.push_back(f);
      other_thread = other_thread || std::this_thread::get_id() != caller;
    };
    const LodScene many = build_ok(scene, options);
    options.progress = nullptr;
    CHECK(many.scene.means == one.scene.means);
    CHECK(many.scene.rotations == one.scene.rotations);
    CHECK(many.scene.scales == one.scene.scales);
    CHECK(many.scene.opacities == one.scene.opacities);
    CHECK(many.scene.sh == one.scene.sh);
    CHECK(many.scene.sh_dc_residual == one.scene.sh_dc_residual);
    CHECK(std::memcmp(&many.scene.metadata.bounds, &one.scene.metadata.bounds, sizeof(format::SceneBounds)) == 0);
    REQUIRE(many.index.levels.size() == one.index.levels.size());
    REQUIRE(many.index.chunks.size() == one.index.chunks.size());
    for (size_t i = 0; i < one.index.levels.size(); ++i) {
      CHECK(many.index.levels[i].first == one.index.levels[i].first);
      CHECK(many.index.levels[i].count == one.index.levels[i].count);
      CHECK(many.index.levels[i].error == one.index.levels[i].error);
    }
    CHECK(std::memcmp(many.index.chunks.data(), one.index.chunks.data(),
                      one.index.chunks.size() * sizeof(format::LodChunk)) == 0);
    CHECK(!other_thread);
    REQUIRE(!seen.empty());
    CHECK(seen.back() == 1.0);
    CHECK(std::is_sorted(seen.begin(), seen.end()));
    CHECK(seen.front() >= 0.0);
  }
}

TEST_CASE("lod: must-fail inputs") {
  const format::EncodedScene scene = hand_made(
      {{0, 0, 0, 1, 0, 0, 0, 0.1f, 0.1f, 0.1f, 0.5f, 0.1f, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}},
      format::ScaleEncoding::kLinear);
  CHECK(build_lod(scene).ok());
  format::EncodedScene broken = scene;
  broken.opacities.push_back(0);
  CHECK(build_lod(broken).status().code() == StatusCode::kInvalidArgument);
  format::EncodedScene empty = scene;
  empty.count = 0;
  empty.means.clear();
  empty.rotations.clear();
  empty.scales.clear();
  empty.opacities.clear();
  empty.sh.clear();
  empty.sh_dc_residual.clear();
  REQUIRE(empty.is_consistent());
  CHECK(build_lod(empty).status().code() == StatusCode::kInvalidArgument);
  LodBuildOptions options;
  options.levels = 17;
  CHECK(build_lod(scene, options).status().code() == StatusCode::kInvalidArgument);
  options.levels = 16;
  CHECK(build_lod(scene, options).ok());
  options.max_chunk_gaussians = 0;
  CHECK(build_lod(scene, options).status().code() == StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgs::test
