// Level-of-detail building blocks (internal_lod_chunks.h): Morton sort and octree leaves, level plans, and
// the moment-matched merge of a chunk's levels (format/SPEC.md §4.9, rules in lod_builder.h).
//
// Determinism: a chunk's levels depend only on its own Gaussians in their sorted order.
#include "internal_lod_chunks.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "../internal_huge_pages.h"
#include "../internal_interop.h"
#include "../internal_parallel.h"
#include "rgs/format/half.h"
#include "rgs/format/metadata.h"

namespace rgs::converter::detail {
namespace {

/// Floor of the parent's eigenvalues (scale 1e-18): keeps log scales finite for flat parents.
constexpr double kTinyEigenvalue = 1e-36;
constexpr double kMaxMergeOpacity = 0.999;
/// Largest finite binary16; log scales are capped like quantize() does (SPEC §4.5).
constexpr float kLargestHalf = 65504.0f;
constexpr float kLargestLogScale = 88.6875f;
constexpr float kLowestHalf = -65504.0f;

/// Copies Gaussian `i` of `src` to Gaussian `j` of `dst` bit for bit.
void copy_gaussian(const format::EncodedScene& src, uint64_t i, format::EncodedScene* dst, uint64_t j,
                   const Layout& t) {
  std::memcpy(&dst->means[j * 3], &src.means[i * 3], 3 * sizeof(float));
  std::memcpy(&dst->rotations[j * 4], &src.rotations[i * 4], 4 * sizeof(uint16_t));
  std::memcpy(&dst->scales[j * 3], &src.scales[i * 3], 3 * sizeof(uint16_t));
  dst->opacities[j] = src.opacities[i];
  std::memcpy(&dst->sh[j * t.sh_values], &src.sh[i * t.sh_values], t.sh_values);
  if (t.dc_residual) std::memcpy(&dst->sh_dc_residual[j * 3], &src.sh_dc_residual[i * 3], 3);
}

/// Linear scale of a stored scale, as dequantize_range() decodes it.
inline float linear_scale(uint16_t bits, bool log_scale) {
  const float v = format::half_bits_to_float(bits);
  return log_scale ? std::exp(v) : v;
}

/// Eigen-decomposition of the symmetric 3×3 `a` by cyclic Jacobi rotations: a = v diag(values) vᵀ, the
/// eigenvectors the columns of v.
void jacobi_eigen(double a[3][3], double values[3], double v[3][3]) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) v[r][c] = r == c ? 1.0 : 0.0;
  }
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off == 0 || off <= 1e-36 * diag) break;
    static constexpr int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (const auto& pair : kPairs) {
      const int p = pair[0], q = pair[1];
      if (a[p][q] == 0) continue;
      // Rotation zeroing a[p][q] (Numerical Recipes §11.1): t = tan of the angle, the smaller root.
      const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
      const double t = std::fabs(theta) > 1e150
                           ? 0.5 / theta
                           : (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
      const double c = 1 / std::sqrt(t * t + 1);
      const double s = t * c;
      // a ← Jᵀ a J and v ← v J, J the identity with J[p][p] = J[q][q] = c, J[p][q] = s, J[q][p] = −s.
      const auto rotate = [c, s](double& x, double& y) {  // (x, y) ← (c x − s y, s x + c y)
        const double x0 = x, y0 = y;
        x = c * x0 - s * y0;
        y = s * x0 + c * y0;
      };
      for (int k = 0; k < 3; ++k) rotate(a[k][p], a[k][q]);  // columns p, q
      for (int k = 0; k < 3; ++k) rotate(a[p][k], a[q][k]);  // rows p, q
      a[p][q] = a[q][p] = 0;
      for (int k = 0; k < 3; ++k) rotate(v[k][p], v[k][q]);
    }
  }
  for (int i = 0; i < 3; ++i) values[i] = a[i][i];
}

/// The renderer's low-pass in pixels² (cov2D + 0.3, docs/DESIGN.md#conventions): a level's merge sees its
/// children as drawn where its error is one pixel.
constexpr double kLowPassPixels2 = 0.3;

/// s1 s2 + s1 s3 + s2 s3 of the scales sqrt(s_a² + dilation2): the area term of a Gaussian as drawn.
double drawn_area(const double s[3], double dilation2) {
  double d[3];
  for (int a = 0; a < 3; ++a) d[a] = std::sqrt(s[a] * s[a] + dilation2);
  return d[0] * d[1] + d[0] * d[2] + d[1] * d[2];
}

/// Row and column of the six entries of a symmetric 3x3 matrix's upper triangle, in merge_cell's moment order.
constexpr int kRow[6] = {0, 0, 0, 1, 1, 2};
constexpr int kCol[6] = {0, 1, 2, 1, 2, 2};

/// Merges Gaussians [b, e) of `out` into Gaussian `p` of `out` (moment matching; lod_builder.h has the
/// rule), clamping the mean into [lo, hi]. `dilation2`: the low-pass in world units² (δ² of lod_builder.h).
void merge_cell(format::EncodedScene* out, uint64_t b, uint64_t e, uint64_t p, const Layout& t, const float lo[3],
                const float hi[3], double dilation2, std::vector<ChildTerms>* children) {
  const uint64_t m = e - b;
  children->resize(m);
  double total_weight = 0, total_area = 0;
  for (uint64_t i = 0; i < m; ++i) {
    const uint64_t g = b + i;
    double scales[3];
    for (int a = 0; a < 3; ++a) scales[a] = linear_scale(out->scales[g * 3 + a], t.log_scale);
    const double area = drawn_area(scales, dilation2);
    const double alpha = format::half_bits_to_float(out->opacities[g]);
    (*children)[i] = {alpha * area, area, alpha};
    total_weight += alpha * area;
    total_area += area;
  }
  if (!(total_weight > 0) || !std::isfinite(total_weight)) {  // no weight anywhere: equal weights
    for (ChildTerms& c : *children) c.weight = 1;
    total_weight = static_cast<double>(m);
  }
  // Moments about the first child's mean (offsets are cell-sized, so no cancellation against the coordinates).
  double origin[3];
  for (int a = 0; a < 3; ++a) origin[a] = out->means[b * 3 + a];
  double first[3] = {0, 0, 0};
  double second[6] = {0, 0, 0, 0, 0, 0};  // xx, xy, xz, yy, yz, zz of Σ w (Σ_i + d dᵀ)
  double sh[48] = {};
  for (uint64_t i = 0; i < m; ++i) {
    const uint64_t g = b + i;
    const double w = (*children)[i].weight;
    double d[3];
    for (int a = 0; a < 3; ++a) d[a] = static_cast<double>(out->means[g * 3 + a]) - origin[a];
    double q[4], n2 = 0;
    for (int a = 0; a < 4; ++a) {
      q[a] = format::half_bits_to_float(out->rotations[g * 4 + a]);
      n2 += q[a] * q[a];
    }
    if (n2 > 0) {
      const double inv = 1 / std::sqrt(n2);
      for (double& c : q) c *= inv;
    } else {
      q[0] = 1, q[1] = q[2] = q[3] = 0;
    }
    const std::array<double, 9> r = quaternion_matrix(q);
    double s2[3];
    for (int a = 0; a < 3; ++a) {
      const double s = linear_scale(out->scales[g * 3 + a], t.log_scale);
      s2[a] = s * s;
    }
    for (int u = 0; u < 6; ++u) {
      const int ra = kRow[u], cb = kCol[u];
      const double cov =
          r[ra * 3] * r[cb * 3] * s2[0] + r[ra * 3 + 1] * r[cb * 3 + 1] * s2[1] + r[ra * 3 + 2] * r[cb * 3 + 2] * s2[2];
      second[u] += w * (cov + d[ra] * d[cb]);
    }
    for (int a = 0; a < 3; ++a) first[a] += w * d[a];
    // SH decoded as dequantize_range() does: s · q, the DC term s · (q + r / 256) with a residual.
    const int8_t* codes = &out->sh[g * t.sh_values];
    float values[48];
    for (uint32_t j = 0; j < t.sh_values; ++j) values[j] = t.sh_scale[j] * static_cast<float>(codes[j]);
    if (t.dc_residual) {
      const int8_t* res = &out->sh_dc_residual[g * 3];
      for (int c = 0; c < 3; ++c) values[c] = format::sh_dc_value(t.sh_scale[c], codes[c], res[c]);
    }
    for (uint32_t j = 0; j < t.sh_values; ++j) sh[j] += w * values[j];
  }
  const double inv_w = 1 / total_weight;
  double mean_offset[3];
  for (int a = 0; a < 3; ++a) mean_offset[a] = first[a] * inv_w;
  double cov[3][3];
  for (int u = 0; u < 6; ++u) {
    const int ra = kRow[u], cb = kCol[u];
    cov[ra][cb] = cov[cb][ra] = second[u] * inv_w - mean_offset[ra] * mean_offset[cb];
  }
  double values[3], vectors[3][3];
  jacobi_eigen(cov, values, vectors);
  // Descending eigenvalues; a right-handed frame (det +1) so it is a rotation.
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return values[i] > values[j] || (values[i] == values[j] && i < j); });
  double rot[3][3], scale[3];
  for (int c = 0; c < 3; ++c) {
    scale[c] = std::sqrt(std::max(values[order[c]], kTinyEigenvalue));
    for (int r = 0; r < 3; ++r) rot[r][c] = vectors[r][order[c]];
  }
  const double det = rot[0][0] * (rot[1][1] * rot[2][2] - rot[1][2] * rot[2][1]) -
                     rot[0][1] * (rot[1][0] * rot[2][2] - rot[1][2] * rot[2][0]) +
                     rot[0][2] * (rot[1][0] * rot[2][1] - rot[1][1] * rot[2][0]);
  if (det < 0) {
    for (int r = 0; r < 3; ++r) rot[r][2] = -rot[r][2];
  }
  double quat[4];  // unit, w ≥ 0
  matrix_quaternion(rot, quat);
  const double inv = (quat[0] < 0 ? -1.0 : 1.0) / std::sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] +
                                                            quat[3] * quat[3]);
  for (double& c : quat) c *= inv;

  // Opacity: coverage of the children over the parent's area, both as drawn (our rule; lod_builder.h).
  const double parent_area = drawn_area(scale, dilation2);
  double log_transmittance = 0;
  for (const ChildTerms& c : *children) {
    const double ln_t = std::log1p(-std::min(c.alpha, kMaxMergeOpacity));
    // Children without area (points) share the parent's area equally.
    log_transmittance += (total_area > 0 ? c.area / parent_area : 1.0 / static_cast<double>(m)) * ln_t;
  }
  const double alpha = std::clamp(-std::expm1(log_transmittance), 0.0, 1.0);

  // Encode into Gaussian p.
  for (int a = 0; a < 3; ++a) {
    const float v = static_cast<float>(origin[a] + mean_offset[a]);
    out->means[p * 3 + a] = std::clamp(v, lo[a], hi[a]);
  }
  for (int a = 0; a < 4; ++a) out->rotations[p * 4 + a] = format::float_to_half_bits(static_cast<float>(quat[a]));
  for (int a = 0; a < 3; ++a) {
    float v;
    if (t.log_scale) {
      v = std::min(static_cast<float>(std::log(scale[a])), kLargestLogScale);
      v = std::max(v, kLowestHalf);
    } else {
      v = static_cast<float>(std::min(scale[a], static_cast<double>(kLargestHalf)));
    }
    out->scales[p * 3 + a] = format::float_to_half_bits(v);
  }
  out->opacities[p] = format::float_to_half_bits(static_cast<float>(alpha));
  int8_t* codes = &out->sh[p * t.sh_values];
  for (uint32_t j = 0; j < t.sh_values; ++j) {
    const double v = sh[j] * inv_w;
    const double s = t.sh_scale[j];
    const double q = s > 0 ? std::clamp(std::round(v / s), -127.0, 127.0) : 0.0;
    codes[j] = static_cast<int8_t>(q);
    if (t.dc_residual && j < 3) {
      // As quantize(): r = round-half-away(256 · (v / s − q)) clamped to [−127, 127]; 0 for a zero scale.
      const double r = s > 0 ? std::clamp(std::round((v / s - q) * 256.0), -127.0, 127.0) : 0.0;
      out->sh_dc_residual[p * 3 + j] = static_cast<int8_t>(r);
    }
  }
}

/// What appearance_error compares of Gaussian g of `out`: its mean, its RMS radius √(s₁² + s₂² + s₃²) (linear
/// scales), its colour as the DC term draws it (0.5 + C₀ · dc) and its opacity.
std::array<float, 8> look_of(const format::EncodedScene& out, uint64_t g, const Layout& t) {
  std::array<float, 8> k;
  double r2 = 0;
  for (int a = 0; a < 3; ++a) {
    k[a] = out.means[g * 3 + a];
    const double s = linear_scale(out.scales[g * 3 + a], t.log_scale);
    r2 += s * s;
    const int8_t q = out.sh[g * t.sh_values + a];
    const float dc = t.dc_residual ? format::sh_dc_value(t.sh_scale[a], q, out.sh_dc_residual[g * 3 + a])
                                   : t.sh_scale[a] * static_cast<float>(q);
    k[4 + a] = static_cast<float>(0.5 + 0.28209479177387814 * dc);
  }
  k[3] = static_cast<float>(std::sqrt(r2));
  k[7] = std::clamp(format::half_bits_to_float(out.opacities[g]), 0.0f, 1.0f);
  return k;
}

/// The appearance error of a level (lod_builder.h): over the full detail's Gaussians j, weighted by their
/// coverage α_j · r_j², the root mean square of √(|μ_j − μ_p|² + (r_p − r_j)²) + |c_j − c_p| · r_p, p the
/// Gaussian of the level that j was merged into (`ancestor`), in world units, at most float32's largest.
double appearance_error(const std::vector<std::array<float, 8>>& base, const std::vector<std::array<float, 8>>& looks,
                        const std::vector<uint32_t>& ancestor) {
  double sum = 0, total = 0, plain = 0;
  for (size_t j = 0; j < base.size(); ++j) {
    const std::array<float, 8>& c = base[j];
    const std::array<float, 8>& p = looks[ancestor[j]];
    double d2 = 0, colour2 = 0;
    for (int a = 0; a < 3; ++a) {
      d2 += (double(c[a]) - p[a]) * (double(c[a]) - p[a]);
      colour2 += (double(c[4 + a]) - p[4 + a]) * (double(c[4 + a]) - p[4 + a]);
    }
    const double dr = double(p[3]) - c[3];
    const double e = std::sqrt(d2 + dr * dr) + std::sqrt(colour2) * p[3];
    const double w = double(c[7]) * c[3] * c[3];
    sum += w * e * e;
    total += w;
    plain += e * e;
  }
  const double rms = total > 0 ? std::sqrt(sum / total) : std::sqrt(plain / double(base.size()));
  constexpr double kLargest = std::numeric_limits<float>::max();
  return std::isfinite(rms) ? std::min(rms, kLargest) : kLargest;
}

/// Levels 1..levels−1 of a chunk from its sorted local codes: level l uses the finest grid coarser than
/// level l − 1's with at most a quarter of its count of cells (or one cell).
void plan_levels(const uint64_t* codes, uint64_t n, double cube_edge, uint32_t levels, ChunkPlan* plan) {
  // cells[k] = distinct values of code >> 3k = 1 + number of adjacent pairs whose highest differing bit is
  // at or above 3k.
  uint64_t above[kMaxShift + 2] = {};
  for (uint64_t i = 1; i < n; ++i) {
    const uint64_t x = codes[i - 1] ^ codes[i];
    if (x != 0) ++above[(63 - __builtin_clzll(x)) / 3];
  }
  uint64_t cells[kMaxShift + 1];
  uint64_t running = 0;
  for (int k = kMaxShift; k >= 0; --k) {
    running += above[k];
    cells[k] = 1 + running;
  }
  plan->count[0] = n;
  plan->error[0] = 0;
  int prev_shift = -1;
  for (uint32_t l = 1; l < levels; ++l) {
    const uint64_t prev = plan->count[l - 1];
    if (prev == 1) {  // one Gaussian left: repeated as is
      plan->shift[l] = prev_shift;
      plan->count[l] = 1;
      plan->error[l] = plan->error[l - 1];
      continue;
    }
    int k = prev_shift + 1;
    while (k < kMaxShift && !(cells[k] * 4 <= prev || cells[k] == 1)) ++k;
    plan->shift[l] = k;
    plan->count[l] = cells[k];
    const double diagonal = std::sqrt(3.0) * cube_edge * std::ldexp(1.0, k - kGridBits);
    plan->error[l] = std::max(plan->error[l - 1], format::round_up_float(diagonal));
    prev_shift = k;
  }
}

}  // namespace

/// Stable LSD radix sort of (keys, values) by key, 8 bits a pass, skipping passes whose digit is the same for
/// every key. tmp_keys / tmp_values hold at least n elements.
void radix_sort(uint64_t* keys, uint32_t* values, size_t n, uint64_t* tmp_keys, uint32_t* tmp_values) {
  if (n < 2) return;
  std::vector<std::array<uint32_t, 256>> hist(8);
  for (auto& h : hist) h.fill(0);
  for (size_t i = 0; i < n; ++i) {
    const uint64_t k = keys[i];
    for (int d = 0; d < 8; ++d) ++hist[static_cast<size_t>(d)][(k >> (8 * d)) & 0xff];
  }
  uint64_t* src_k = keys;
  uint32_t* src_v = values;
  uint64_t* dst_k = tmp_keys;
  uint32_t* dst_v = tmp_values;
  for (int d = 0; d < 8; ++d) {
    auto& h = hist[static_cast<size_t>(d)];
    if (h[(src_k[0] >> (8 * d)) & 0xff] == n) continue;  // one digit value: the pass would change nothing
    uint32_t offset = 0;
    for (uint32_t& c : h) {
      const uint32_t count = c;
      c = offset;
      offset += count;
    }
    for (size_t i = 0; i < n; ++i) {
      const uint32_t slot = h[(src_k[i] >> (8 * d)) & 0xff]++;
      dst_k[slot] = src_k[i];
      dst_v[slot] = src_v[i];
    }
    std::swap(src_k, dst_k);
    std::swap(src_v, dst_v);
  }
  if (src_k != keys) {
    std::memcpy(keys, src_k, n * sizeof(uint64_t));
    std::memcpy(values, src_v, n * sizeof(uint32_t));
  }
}

/// Octree leaves of the Morton-sorted keys [begin, end) of the node at `depth`: nodes holding more than
/// `max_count` split into their eight children (empty ones dropped); a finest cell still too large is cut
/// by index into equal pieces. Leaves are appended in Morton order.
void split_node(const uint64_t* keys, uint64_t begin, uint64_t end, int depth, uint64_t max_count,
                std::vector<std::pair<uint64_t, uint64_t>>* leaves) {
  const uint64_t n = end - begin;
  if (n <= max_count) {
    leaves->emplace_back(begin, end);
    return;
  }
  if (depth == kGridBits) {
    const uint64_t pieces = (n + max_count - 1) / max_count;
    for (uint64_t p = 0; p < pieces; ++p) leaves->emplace_back(begin + n * p / pieces, begin + n * (p + 1) / pieces);
    return;
  }
  const int shift = 3 * (kGridBits - 1 - depth);
  uint64_t pos = begin;
  for (uint64_t child = 0; child < 8 && pos < end; ++child) {
    const uint64_t child_end = static_cast<uint64_t>(
        std::partition_point(keys + pos, keys + end, [&](uint64_t k) { return ((k >> shift) & 7) <= child; }) -
        keys);
    if (child_end > pos) split_node(keys, pos, child_end, depth + 1, max_count, leaves);
    pos = child_end;
  }
}

/// The input's attribute layout that the merge needs: SH sizes and scales, scale and DC-residual encodings.
Layout describe_layout(const format::EncodedScene& in) {
  Layout t;
  t.k_count = format::sh_coefficient_count(in.metadata.sh_degree);
  t.sh_values = t.k_count * 3;
  t.log_scale = in.metadata.scale_encoding == format::ScaleEncoding::kLog;
  t.dc_residual = !in.sh_dc_residual.empty();
  for (uint32_t j = 0; j < t.sh_values; ++j) {
    t.sh_scale[j] = in.metadata.sh_quantization.scales[format::sh_degree_of_coefficient(j / 3)][j % 3];
  }
  return t;
}

ChunkReach build_chunk(const format::EncodedScene& in, const uint32_t* sorted_index, const uint64_t* sorted_codes,
                       const ChunkPlan& plan, const uint64_t first[], uint32_t levels, const Layout& t,
                       const double center[3], const double scene_center[3], Scratch* scratch,
                       format::EncodedScene* out) {
  const uint64_t n = plan.end - plan.begin;
  for (uint64_t j = 0; j < n; ++j) copy_gaussian(in, sorted_index[plan.begin + j], out, first[0] + j, t);
  std::vector<uint64_t>& codes = scratch->codes;
  std::vector<uint64_t>& next = scratch->next_codes;
  codes.assign(sorted_codes + plan.begin, sorted_codes + plan.end);
  ChunkReach reach;
  scratch->base.resize(n);
  for (uint64_t j = 0; j < n; ++j) scratch->base[j] = look_of(*out, first[0] + j, t);
  scratch->ancestor.resize(n);
  for (uint64_t j = 0; j < n; ++j) scratch->ancestor[j] = static_cast<uint32_t>(j);
  for (uint32_t l = 1; l < levels; ++l) {
    const uint64_t prev_first = first[l - 1];
    const uint64_t prev_count = plan.count[l - 1];
    reach.error[l] = reach.error[l - 1];
    if (prev_count == 1) {
      copy_gaussian(*out, prev_first, out, first[l], t);
      continue;
    }
    scratch->parent_of.resize(prev_count);
    const int shift = 3 * plan.shift[l];
    next.clear();
    uint64_t p = first[l];
    for (uint64_t g0 = 0; g0 < prev_count;) {
      const uint64_t cell = codes[g0] >> shift;
      uint64_t g1 = g0 + 1;
      while (g1 < prev_count && (codes[g1] >> shift) == cell) ++g1;
      std::fill(scratch->parent_of.begin() + g0, scratch->parent_of.begin() + g1, static_cast<uint32_t>(p - first[l]));
      if (g1 - g0 == 1) {
        copy_gaussian(*out, prev_first + g0, out, p, t);
      } else {
        const double pixel = plan.error[l];  // world size of a pixel where level l is drawn first
        merge_cell(out, prev_first + g0, prev_first + g1, p, t, plan.lo, plan.hi, kLowPassPixels2 * pixel * pixel,
                   &scratch->children);
      }
      next.push_back(codes[g0]);
      ++p;
      g0 = g1;
    }
    std::swap(codes, next);
    for (uint32_t& a : scratch->ancestor) a = scratch->parent_of[a];
    scratch->looks.resize(plan.count[l]);
    for (uint64_t g = 0; g < plan.count[l]; ++g) scratch->looks[g] = look_of(*out, first[l] + g, t);
    const double measured = appearance_error(scratch->base, scratch->looks, scratch->ancestor);
    reach.error[l] = std::max(reach.error[l], format::round_up_float(measured));
  }
  // Sphere radius per level of the chunk: |mean − centre| + 3 · largest linear scale, in double.
  for (uint32_t l = 0; l < levels; ++l) {
    double radius = 0, level_d2 = 0;
    for (uint64_t g = first[l]; g < first[l] + plan.count[l]; ++g) {
      double d2 = 0, scene_d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double m = out->means[g * 3 + a];
        d2 += (m - center[a]) * (m - center[a]);
        scene_d2 += (m - scene_center[a]) * (m - scene_center[a]);
      }
      level_d2 = std::max(level_d2, scene_d2);
      double largest = 0;
      for (int a = 0; a < 3; ++a) {
        const uint16_t bits = out->scales[g * 3 + a];
        double s = linear_scale(bits, t.log_scale);
        if (t.log_scale) s = std::max(s, std::exp(static_cast<double>(format::half_bits_to_float(bits))));
        largest = std::max(largest, s);
      }
      radius = std::max(radius, std::sqrt(d2) + 3 * largest);
    }
    reach.radius[l] = radius;
    reach.scene_d2[l] = level_d2;
  }
  return reach;
}

double ChunkReach::radius_over(uint32_t levels) const {
  double r = 0;
  for (uint32_t l = 0; l < levels; ++l) r = std::max(r, radius[l]);
  return std::isfinite(r) ? r : std::numeric_limits<double>::infinity();
}

double ChunkReach::scene_d2_over(uint32_t levels) const {
  double d2 = 0;
  for (uint32_t l = 0; l < levels; ++l) d2 = std::max(d2, scene_d2[l]);
  return d2;
}

Result<float> chunk_radius(const ChunkReach& reach, uint32_t levels, uint32_t c) {
  const float radius = format::round_up_float(reach.radius_over(levels) * (1 + 1e-6));
  RGS_RETURN_ERROR_IF(!std::isfinite(radius), StatusCode::kInvalidArgument,
                      "build_lod: chunk " + std::to_string(c) + " holds a Gaussian whose 3-sigma extent overflows float32");
  return radius;
}

void chunk_center(const ChunkPlan& plan, float stored[3], double center[3]) {
  for (int a = 0; a < 3; ++a) {
    stored[a] = static_cast<float>(0.5 * (static_cast<double>(plan.lo[a]) + static_cast<double>(plan.hi[a])));
    // Read back through a volatile, as set_sphere_center() does: GCC 12 at -O3 otherwise forwards the
    // unrounded double, and the radius would be measured from a centre that is not the stored one.
    const volatile float rounded = stored[a];
    center[a] = rounded;
  }
}

Status sort_by_morton(const format::EncodedScene& in, const MortonGrid& grid, unsigned workers, MortonOrder* order) {
  const uint64_t n = in.count;
  resize_huge(order->keys, n);
  resize_huge(order->index, n);
  uint64_t* keys = order->keys.data();
  uint32_t* index = order->index.data();
  RGS_RETURN_IF_ERROR(parallel_slices(n, parallel::worker_count(n, 65536, workers), [&](unsigned, uint64_t b, uint64_t e) {
    for (uint64_t i = b; i < e; ++i) {
      keys[i] = grid.code(&in.means[i * 3]);
      index[i] = static_cast<uint32_t>(i);
    }
  }));
  std::vector<uint64_t> tmp_keys;
  std::vector<uint32_t> tmp_index;
  resize_huge(tmp_keys, n);
  resize_huge(tmp_index, n);
  radix_sort(keys, index, n, tmp_keys.data(), tmp_index.data());
  return Status();
}

Result<std::vector<ChunkPlan>> plan_chunks(const format::EncodedScene& in, uint32_t planned_levels, unsigned workers,
                                           MortonOrder* order, std::vector<Scratch>* scratch, Progress* progress) {
  const auto chunk_count = static_cast<uint32_t>(order->leaves.size());
  std::vector<ChunkPlan> plans(chunk_count);
  std::vector<uint64_t>& keys = order->keys;
  std::vector<uint32_t>& index = order->index;
  RGS_RETURN_IF_ERROR(detail::parallel_items(chunk_count, workers, [&](unsigned worker, uint64_t c) {
    ChunkPlan& plan = plans[c];
    plan.begin = order->leaves[c].first;
    plan.end = order->leaves[c].second;
    const uint64_t n = plan.end - plan.begin;
    for (int a = 0; a < 3; ++a) plan.lo[a] = plan.hi[a] = in.means[static_cast<uint64_t>(index[plan.begin]) * 3 + a];
    for (uint64_t j = plan.begin; j < plan.end; ++j) {
      const float* mean = &in.means[static_cast<uint64_t>(index[j]) * 3];
      for (int a = 0; a < 3; ++a) {
        plan.lo[a] = std::min(plan.lo[a], mean[a]);
        plan.hi[a] = std::max(plan.hi[a], mean[a]);
      }
    }
    const MortonGrid grid(plan.lo, plan.hi);
    for (uint64_t j = plan.begin; j < plan.end; ++j) keys[j] = grid.code(&in.means[static_cast<uint64_t>(index[j]) * 3]);
    Scratch& s = (*scratch)[worker];
    if (s.tmp_keys.size() < n) {
      s.tmp_keys.resize(n);
      s.tmp_values.resize(n);
    }
    radix_sort(&keys[plan.begin], &index[plan.begin], n, s.tmp_keys.data(), s.tmp_values.data());
    plan_levels(&keys[plan.begin], n, grid.edge, planned_levels, &plan);
    progress->add(n / 2);
    if (worker == 0) progress->report();
  }));
  return plans;
}

Status check_lod_request(uint64_t count, const LodBuildOptions& options) {
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kInvalidArgument, "build_lod: the scene has no Gaussians");
  RGS_RETURN_ERROR_IF(options.levels > format::kMaxLodLevels, StatusCode::kInvalidArgument,
                      "build_lod: " + std::to_string(options.levels) + " levels exceed the format's " +
                          std::to_string(format::kMaxLodLevels));
  RGS_RETURN_ERROR_IF(options.max_chunk_gaussians == 0, StatusCode::kInvalidArgument,
                      "build_lod: max_chunk_gaussians must be >= 1");
  RGS_RETURN_ERROR_IF(count > kMaxOutputGaussians, StatusCode::kLimitExceeded,
                      "build_lod: " + std::to_string(count) + " Gaussians exceed 2^31 - 1");
  return Status();
}

Result<LevelChoice> choose_levels(const std::vector<ChunkPlan>& plans, uint32_t planned_levels,
                                  const LodBuildOptions& options, uint64_t n0) {
  uint64_t totals[format::kMaxLodLevels] = {};
  for (const ChunkPlan& p : plans) {
    for (uint32_t l = 0; l < planned_levels; ++l) totals[l] += p.count[l];
  }
  LevelChoice choice;
  choice.levels = planned_levels;
  if (options.levels == 0) {
    for (uint32_t l = 0; l < kAutoMaxLevels; ++l) {
      if (totals[l] * kAutoRatio <= n0 || totals[l] == plans.size()) {
        choice.levels = l + 1;
        break;
      }
    }
  }
  for (uint32_t l = 0; l < choice.levels; ++l) choice.total += totals[l];
  RGS_RETURN_ERROR_IF(choice.total > kMaxOutputGaussians, StatusCode::kLimitExceeded,
                      "build_lod: " + std::to_string(choice.levels) + " levels of " + std::to_string(n0) +
                          " Gaussians make " + std::to_string(choice.total) + ", more than 2^31 - 1");
  return choice;
}

format::LodIndex lay_out_index(const std::vector<ChunkPlan>& plans, uint32_t levels) {
  format::LodIndex index;
  index.chunk_count = static_cast<uint32_t>(plans.size());
  index.level_count = levels;
  index.chunks.resize(index.chunk_count);
  index.levels.resize(static_cast<size_t>(levels) * index.chunk_count);
  uint64_t first = 0;
  for (uint32_t l = 0; l < levels; ++l) {
    for (uint32_t c = 0; c < index.chunk_count; ++c) {
      format::LodLevel& level = index.at(l, c);
      level.first = first;
      level.count = plans[c].count[l];
      first += level.count;
    }
  }
  return index;
}

Result<float> set_chunk_radii(const std::vector<ChunkReach>& reaches, format::LodIndex* index) {
  double scene_d2 = 0;
  for (uint32_t c = 0; c < index->chunk_count; ++c) {
    RGS_ASSIGN_OR_RETURN(index->chunks[c].radius, chunk_radius(reaches[c], index->level_count, c));
    for (uint32_t l = 0; l < index->level_count; ++l) index->at(l, c).error = reaches[c].error[l];
    scene_d2 = std::max(scene_d2, reaches[c].scene_d2_over(index->level_count));
  }
  return format::sphere_radius_for(scene_d2);
}

}  // namespace rgs::converter::detail
