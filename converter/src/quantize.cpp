// Quantization of float Gaussians into the .rgs runtime profile (paper "Compact Attribute Storage").
//
// Determinism: every output value depends only on its own inputs and on the per-(degree, channel) SH
// scales, which come from a max (order independent) or a percentile (nth_element on a buffer filled in
// index order), so the result does not depend on the number of worker threads. The optional error
// measurement follows attribute_errors.cpp's chunking exactly, so it equals measure_quantization_errors().
#include "rgs/converter/quantize.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <vector>

#include "internal_error_accumulators.h"
#include "internal_huge_pages.h"
#include "internal_parallel.h"
#include "rgs/format/half.h"

namespace rgs::converter {

namespace {

constexpr uint64_t kMinGaussiansPerWorker = 32768;
/// Largest float32 that rounds to a finite binary16 (65504); 65520 and above round to inf.
constexpr float kHalfOverflow = 65520.0f;
/// Most negative finite binary16, stored for log(0) = −inf so the section stays finite (exp gives 0).
constexpr float kLowestHalf = -65504.0f;
/// Largest binary16 whose exp is a finite float32 (SPEC §4.5): ln of the largest float, 88.7228, rounds to
/// 88.75, whose exp overflows, so log scales above 88.6875 (linear scales above about 3.3e38) are stored as
/// 88.6875, within one binary16 step (0.0625 in the log, 6.4 % of the scale) of the value.
constexpr float kLargestLogScale = 88.6875f;

bool finite(float v) { return std::isfinite(v); }

/// First problem found in a slice of the cloud (index UINT64_MAX when none) and the SH maxima.
struct ScanResult {
  uint64_t bad_index = std::numeric_limits<uint64_t>::max();
  std::string why;
  float max_abs[4][3] = {};
};

void scan_slice(const format::GaussianCloud& cloud, const QuantizeOptions& options, uint64_t begin, uint64_t end,
                ScanResult* out) {
  const uint32_t sh_values = cloud.sh_coefficients() * 3;
  float max_value[48] = {};  // max |SH| per value index k·3 + c over the slice
  auto fail = [out](uint64_t i, std::string why) {
    out->bad_index = i;
    out->why = std::move(why);
  };
  for (uint64_t i = begin; i < end; ++i) {
    for (int a = 0; a < 3; ++a) {
      if (!finite(cloud.means[i * 3 + a])) return fail(i, "mean component " + std::to_string(a) + " is not finite");
    }
    double n2 = 0;
    for (int a = 0; a < 4; ++a) {
      const float q = cloud.rotations[i * 4 + a];
      if (!finite(q)) return fail(i, "rotation component " + std::to_string(a) + " is not finite");
      n2 += static_cast<double>(q) * q;
    }
    if (n2 < static_cast<double>(std::numeric_limits<float>::min())) return fail(i, "rotation has zero norm");
    for (int a = 0; a < 3; ++a) {
      const float s = cloud.scales[i * 3 + a];
      if (!finite(s) || s < 0.0f) {
        return fail(i, "scale " + std::to_string(a) + " = " + std::to_string(s) + " is not finite and >= 0");
      }
      if (options.scale_encoding == format::ScaleEncoding::kLinear && s >= kHalfOverflow) {
        return fail(i, "scale " + std::to_string(a) + " = " + std::to_string(s) +
                           " overflows FP16 (max 65504); use the log scale encoding");
      }
    }
    const float o = cloud.opacities[i];
    if (!(o >= 0.0f && o <= 1.0f)) {
      return fail(i, "opacity " + std::to_string(o) + " is outside [0, 1] (expected the activated opacity)");
    }
    const float* sh = cloud.sh.data() + i * sh_values;
    bool sh_finite = true;
    for (uint32_t j = 0; j < sh_values; ++j) {
      sh_finite = sh_finite && finite(sh[j]);
      max_value[j] = std::max(max_value[j], std::fabs(sh[j]));
    }
    if (!sh_finite) {
      for (uint32_t j = 0; j < sh_values; ++j) {
        if (!finite(sh[j])) {
          return fail(i, "SH coefficient " + std::to_string(j / 3) + " channel " + std::to_string(j % 3) +
                             " is not finite");
        }
      }
    }
  }
  for (uint32_t j = 0; j < sh_values; ++j) {
    float& m = out->max_abs[format::sh_degree_of_coefficient(j / 3)][j % 3];
    m = std::max(m, max_value[j]);
  }
}

/// s = m / 127 stored as float32, nudged up (only when float rounding went down far enough) so that
/// m / s < 127.5 (exactly, as quantize_value() decides), i.e. the largest coefficient gets q = ±127.
float scale_for(float m) {
  if (!(m > 0.0f)) return 0.0f;
  float s = static_cast<float>(static_cast<double>(m) / 127.0);
  while (s == 0.0f || static_cast<double>(m) / static_cast<double>(s) >= 127.5) {
    s = std::nextafter(s, std::numeric_limits<float>::infinity());
  }
  return s;
}

/// q = clamp(round_half_away(v / s), −127, 127) for s > 0 (s = +inf gives 0); *clipped when the
/// clamp changed the rounded value (|v / s| >= 127.5).
///
/// Exact without a division, and branch-free (the sign of v is random, so a branch on it mispredicts
/// half the time): k = trunc(|v| · (1/s)) is floor(|v| / s) or off by one next to an integer, and
/// q = k + (|v| >= (k + 0.5)·s) is then the exactly rounded quotient, because (k + 0.5)·s is exact in
/// double ((2k + 1) has <= 9 bits, s 24) and |v| is exact too. This equals round_half_away of the double
/// quotient fl(v / s): for float v and s the true quotient is either exactly k + 0.5 or at least 2^-32
/// (relative) away from it, far more than fl()'s 2^-53, so fl(v / s) never crosses a rounding boundary.
inline int8_t quantize_value(float v, double s, double inv_s, bool* clipped) {
  const double av = std::fabs(static_cast<double>(v));
  const int k = static_cast<int>(std::min(av * inv_s, 128.0));
  const int q = k + static_cast<int>(av >= (k + 0.5) * s);
  *clipped = q > 127;
  const int qc = std::min(q, 127);
  const int neg = -static_cast<int>(std::signbit(v));
  return static_cast<int8_t>((qc ^ neg) - neg);
}

/// The DC residual of v for code q at scale s (SPEC §4.8): round-half-away(256 · (v / s − q)) clamped to
/// [−127, 127]; 0 for a zero scale (s = +inf). |v / s − q| ≤ 0.5 unless q was clipped. The clamp keeps the
/// decoded value q + r/256 strictly inside q's rounding interval, so quantizing it again gives q and r back.
inline int8_t dc_residual(float v, double s, int8_t q) {
  if (std::isinf(s)) return 0;
  const double r = std::round((static_cast<double>(v) / s - q) * 256.0);
  return static_cast<int8_t>(std::clamp(r, -127.0, 127.0));
}

/// The arguments quantize() refuses before looking at any Gaussian.
Status check_quantize_inputs(const format::GaussianCloud& cloud, const QuantizeOptions& options) {
  RGS_RETURN_IF_ERROR(detail::check_consistent(cloud, "cloud"));
  const float pct = options.sh_clip_percentile;
  if (!(pct > 0.0f && pct <= 100.0f)) {
    return Status(StatusCode::kInvalidArgument,
                  "SH clip percentile " + std::to_string(pct) + " is outside (0, 100]");
  }
  if (options.sh_dc_bits != 8 && options.sh_dc_bits != 16) {
    return Status(StatusCode::kInvalidArgument,
                  "SH DC precision of " + std::to_string(options.sh_dc_bits) + " bits is not 8 or 16");
  }
  if (options.scale_encoding != format::ScaleEncoding::kLinear &&
      options.scale_encoding != format::ScaleEncoding::kLog) {
    return Status(StatusCode::kInvalidArgument,
                  "unknown scale encoding " + std::to_string(static_cast<int>(options.scale_encoding)));
  }
  return Status();
}

/// Pass 1: validates every Gaussian (the first bad one of the first slice that has one is reported, named as
/// Gaussian first + its index) and finds max |SH| per (degree, channel) into `max_abs`.
Status scan_cloud(const format::GaussianCloud& cloud, const QuantizeOptions& options, unsigned workers,
                  float max_abs[4][3], uint64_t first = 0) {
  std::vector<ScanResult> scans(workers);
  RGS_RETURN_IF_ERROR(detail::parallel_slices(cloud.size(), workers, [&](unsigned t, uint64_t b, uint64_t e) {
    scan_slice(cloud, options, b, e, &scans[t]);
  }));
  for (const ScanResult& s : scans) {
    if (s.bad_index != std::numeric_limits<uint64_t>::max()) {
      return Status(StatusCode::kInvalidArgument,
                    "cannot quantize Gaussian " + std::to_string(first + s.bad_index) + ": " + s.why);
    }
    for (int d = 0; d < 4; ++d) {
      for (int c = 0; c < 3; ++c) max_abs[d][c] = std::max(max_abs[d][c], s.max_abs[d][c]);
    }
  }
  return Status();
}

/// SH scales: max rule (`max_abs`), or the P-th percentile of |SH| (nearest rank) per (degree, channel).
format::ShQuantization sh_quantization(const format::GaussianCloud& cloud, float pct, const float max_abs[4][3]) {
  const uint64_t n = cloud.size();
  const uint32_t k_count = cloud.sh_coefficients();
  format::ShQuantization shq;
  shq.bits = 8;
  shq.clip_percentile = pct;
  std::vector<float> magnitudes;
  for (uint32_t d = 0; d <= cloud.sh_degree; ++d) {
    const uint32_t k_begin = d * d;
    const uint32_t k_end = (d + 1) * (d + 1);
    for (uint32_t c = 0; c < 3; ++c) {
      float m = max_abs[d][c];
      if (pct < 100.0f && n > 0) {
        const uint64_t count = n * (k_end - k_begin);
        magnitudes.resize(static_cast<size_t>(count));
        size_t w = 0;
        for (uint64_t i = 0; i < n; ++i) {
          for (uint32_t k = k_begin; k < k_end; ++k) magnitudes[w++] = std::fabs(cloud.sh[(i * k_count + k) * 3 + c]);
        }
        const double rank = std::ceil(static_cast<double>(pct) / 100.0 * static_cast<double>(count));
        const uint64_t r = static_cast<uint64_t>(std::clamp(rank, 1.0, static_cast<double>(count)));
        std::nth_element(magnitudes.begin(), magnitudes.begin() + static_cast<ptrdiff_t>(r - 1), magnitudes.end());
        m = magnitudes[r - 1];
      }
      shq.scales[d][c] = scale_for(m);
    }
  }
  return shq;
}

/// Per-value SH tables of pass 2 and what it encodes: the scale of each of the K·3 values of a Gaussian, in
/// double as the division uses it, its reciprocal, whether it is zero, and the float32 s[d][c] as
/// dequantize_range() multiplies it.
struct EncodeTables {
  EncodeTables(const format::ShQuantization& shq, uint32_t coefficients, bool log_scales, bool dc_residuals,
               bool measure_errors)
      : k_count(coefficients),
        sh_values(coefficients * 3),
        log_scale(log_scales),
        dc_residual(dc_residuals),
        measure(measure_errors) {
    for (uint32_t j = 0; j < sh_values; ++j) {
      const float sj = shq.scales[format::sh_degree_of_coefficient(j / 3)][j % 3];
      zero_scale[j] = sj == 0.0f;
      divisor[j] = sj == 0.0f ? std::numeric_limits<double>::infinity() : static_cast<double>(sj);
      reciprocal[j] = 1.0 / divisor[j];
      dequant_scale[j] = sj;
    }
  }
  uint32_t k_count;
  uint32_t sh_values;
  bool log_scale;
  bool dc_residual;  ///< write sh_dc_residual (sh_dc_bits 16)
  bool measure;      ///< accumulate the errors of the dequantized values
  double divisor[48];
  double reciprocal[48];
  bool zero_scale[48];
  float dequant_scale[48];
};

/// What pass 2 counts in one chunk: clipped SH values per value index, linear scales stored as FP16
/// subnormals or flushed to zero, and (when measured) the error accumulators.
struct ChunkResult {
  uint64_t clip_count[48] = {};
  uint64_t scales_subnormal = 0;
  uint64_t scales_flushed_to_zero = 0;
  double max_flushed_of_largest_axis = 0;
  detail::Accumulators errors;
};

/// Pass 2 on Gaussians [b, e): encodes them into `out` (arrays already sized) and counts into `res`.
void encode_chunk(const format::GaussianCloud& cloud, const EncodeTables& t, uint64_t b, uint64_t e,
                  format::EncodedScene* out, ChunkResult* res) {
  const uint32_t sh_values = t.sh_values;
  const float* sh_in = cloud.sh.data();
  int8_t* sh_out = out->sh.data();
  for (uint64_t i = b; i < e; ++i) {
    double q[4];
    double n2 = 0;
    for (int a = 0; a < 4; ++a) {
      q[a] = cloud.rotations[i * 4 + a];
      n2 += q[a] * q[a];
    }
    const double inv = 1.0 / std::sqrt(n2);
    uint16_t rot_bits[4];
    for (int a = 0; a < 4; ++a) rot_bits[a] = format::float_to_half_bits(static_cast<float>(q[a] * inv));
    std::memcpy(&out->rotations[i * 4], rot_bits, sizeof(rot_bits));
    uint16_t scale_bits[3];
    const float largest_axis =
        std::max(std::max(cloud.scales[i * 3], cloud.scales[i * 3 + 1]), cloud.scales[i * 3 + 2]);
    for (int a = 0; a < 3; ++a) {
      const float s = cloud.scales[i * 3 + a];
      float v = s;
      if (t.log_scale) {
        v = s > 0.0f ? std::min(static_cast<float>(std::log(static_cast<double>(s))), kLargestLogScale)
                     : kLowestHalf;
      }
      scale_bits[a] = format::float_to_half_bits(v);
      // Linear scales stored as FP16 subnormals or flushed to zero (normal, exact 0 and log are not).
      const uint16_t magnitude = scale_bits[a] & 0x7fffu;
      if (!t.log_scale && magnitude < 0x0400u && s != 0.0f) {
        ++(magnitude == 0 ? res->scales_flushed_to_zero : res->scales_subnormal);
        if (magnitude == 0) {
          res->max_flushed_of_largest_axis =
              std::max(res->max_flushed_of_largest_axis, static_cast<double>(s) / largest_axis);
        }
      }
    }
    std::memcpy(&out->scales[i * 3], scale_bits, sizeof(scale_bits));
    const uint16_t opacity_bits = format::float_to_half_bits(cloud.opacities[i]);
    out->opacities[i] = opacity_bits;
    // Codes go through a local buffer: int8_t stores may alias anything, and writing them straight
    // to the output would make the compiler reload the tables after every store.
    const float* sh = sh_in + i * sh_values;
    int8_t codes[48];
    for (uint32_t j = 0; j < sh_values; ++j) {
      // Branch-free; a zero scale divides by +inf (q = 0) and counts every non-zero coefficient
      // as clipped.
      bool clip = false;
      codes[j] = quantize_value(sh[j], t.divisor[j], t.reciprocal[j], &clip);
      res->clip_count[j] += static_cast<uint32_t>(clip) | static_cast<uint32_t>(t.zero_scale[j] & (sh[j] != 0.0f));
    }
    std::memcpy(sh_out + i * sh_values, codes, sh_values);
    int8_t residual[3] = {};
    if (t.dc_residual) {
      for (int c = 0; c < 3; ++c) residual[c] = dc_residual(sh[c], t.divisor[c], codes[c]);
      std::memcpy(&out->sh_dc_residual[i * 3], residual, sizeof(residual));
    }
    if (t.measure) {
      // Dequantize exactly as format::dequantize_range() does, then compare with the source.
      float rot_f[4], scale_f[3], sh_f[48];
      for (int a = 0; a < 4; ++a) rot_f[a] = format::half_bits_to_float(rot_bits[a]);
      for (int a = 0; a < 3; ++a) {
        const float v = format::half_bits_to_float(scale_bits[a]);
        scale_f[a] = t.log_scale ? std::exp(v) : v;
      }
      for (uint32_t j = 0; j < sh_values; ++j) sh_f[j] = t.dequant_scale[j] * static_cast<float>(codes[j]);
      if (t.dc_residual) {
        for (int c = 0; c < 3; ++c) sh_f[c] = format::sh_dc_value(t.dequant_scale[c], codes[c], residual[c]);
      }
      const float* mean = &cloud.means[i * 3];  // stored bit for bit
      const detail::GaussianView ref{mean, &cloud.rotations[i * 4], &cloud.scales[i * 3], cloud.opacities[i], sh};
      const detail::GaussianView test{mean, rot_f, scale_f, format::half_bits_to_float(opacity_bits), sh_f};
      detail::accumulate_gaussian(ref, test, t.k_count, &res->errors);
    }
  }
}

/// Merges the chunks' counts and error accumulators in chunk order into the optional `report` and `errors`.
void merge_chunks(const std::vector<ChunkResult>& chunk_results, uint32_t sh_values, QuantizationReport* report,
                  AttributeErrors* errors) {
  detail::Accumulators total_errors;
  QuantizationReport total_report;
  for (const ChunkResult& r : chunk_results) {
    for (uint32_t j = 0; j < sh_values; ++j) {
      total_report.sh_clipped[format::sh_degree_of_coefficient(j / 3)][j % 3] += r.clip_count[j];
    }
    total_report.scales_subnormal += r.scales_subnormal;
    total_report.scales_flushed_to_zero += r.scales_flushed_to_zero;
    total_report.max_flushed_of_largest_axis =
        std::max(total_report.max_flushed_of_largest_axis, r.max_flushed_of_largest_axis);
    total_errors.merge(r.errors);
  }
  if (report != nullptr) *report = total_report;
  if (errors != nullptr) *errors = total_errors.result();
}

}  // namespace

format::SceneBounds compute_bounds(const format::GaussianCloud& cloud) {
  format::SceneBounds b;
  const uint64_t n = cloud.size();
  if (n == 0) return b;
  // Both passes are min/max reductions over parallel slices: the result does not depend on the split.
  const unsigned workers = detail::worker_count(n, kMinGaussiansPerWorker);
  struct Box {
    float lo[3], hi[3];
  };
  // Fixed arrays (worker_count() is at most kMaxWorkers) and slices that allocate nothing: neither can
  // fail, so the pool's status is always ok.
  Box boxes[detail::kMaxWorkers];
  static_cast<void>(detail::parallel_slices(n, workers, [&](unsigned t, uint64_t begin, uint64_t end) {
    format::box_of_means(&cloud.means[begin * 3], end - begin, boxes[t].lo, boxes[t].hi);
  }));
  for (int a = 0; a < 3; ++a) {
    b.aabb_min[a] = boxes[0].lo[a];
    b.aabb_max[a] = boxes[0].hi[a];
    for (unsigned t = 0; t < workers; ++t) {
      const Box& box = boxes[t];
      b.aabb_min[a] = std::min(b.aabb_min[a], box.lo[a]);
      b.aabb_max[a] = std::max(b.aabb_max[a], box.hi[a]);
    }
  }
  double center[3];
  format::set_sphere_center(&b, center);
  double r2s[detail::kMaxWorkers] = {};
  static_cast<void>(detail::parallel_slices(n, workers, [&](unsigned t, uint64_t begin, uint64_t end) {
    r2s[t] = format::max_squared_distance(&cloud.means[begin * 3], end - begin, center);
  }));
  b.sphere_radius = format::sphere_radius_for(*std::max_element(r2s, r2s + workers));
  return b;
}

namespace {

/// Encodes `cloud` (checked by scan_cloud) with the SH scales `shq`; metadata as quantize() fills it.
Result<format::EncodedScene> encode_cloud(const format::GaussianCloud& cloud, const QuantizeOptions& options,
                                          const format::ShQuantization& shq, QuantizationReport* report,
                                          AttributeErrors* errors) {
  const uint64_t n = cloud.size();
  const uint32_t degree = cloud.sh_degree;
  const uint32_t k_count = cloud.sh_coefficients();
  const unsigned workers = detail::worker_count(n, kMinGaussiansPerWorker);
  format::EncodedScene out;
  out.count = n;
  out.metadata.sh_degree = degree;
  out.metadata.scale_encoding = options.scale_encoding;
  out.metadata.sh_quantization = shq;
  out.metadata.antialiased = cloud.antialiased;
  out.metadata.bounds = compute_bounds(cloud);
  if (!std::isfinite(out.metadata.bounds.sphere_radius)) {
    // Finite means can still span more than float32 holds: e.g. ±3e38 on each axis is 1e39 across.
    const format::SceneBounds& b = out.metadata.bounds;
    char span[160];
    std::snprintf(span, sizeof span, "(%g, %g, %g)..(%g, %g, %g)", b.aabb_min[0], b.aabb_min[1], b.aabb_min[2],
                  b.aabb_max[0], b.aabb_max[1], b.aabb_max[2]);
    return Status(StatusCode::kInvalidArgument,
                  std::string("the means span ") + span +
                      ": the radius of their bounding sphere exceeds the float32 range (SPEC §4.1.1)");
  }
  std::string why;
  if (!format::is_valid_quantization(shq, degree, &why)) {
    return Status(StatusCode::kInvalidArgument, "computed SH quantization is invalid: " + why);
  }
  const bool dc_residual = options.sh_dc_bits == 16;
  detail::size_sections(&out, n, uint64_t{k_count} * 3, dc_residual);
  if (n > 0) std::memcpy(out.means.data(), cloud.means.data(), n * 3 * sizeof(float));

  // Pass 2: encode, in chunks of kErrorChunkGaussians taken by the workers in turn. Per chunk: clip and
  // FP16 counts (integers) and, when asked, the error accumulators of the dequantized values (merged in
  // chunk order below), so nothing depends on which worker ran a chunk.
  const EncodeTables tables(shq, k_count, options.scale_encoding == format::ScaleEncoding::kLog, dc_residual,
                            errors != nullptr);
  const uint64_t chunks = (n + detail::kErrorChunkGaussians - 1) / detail::kErrorChunkGaussians;
  std::vector<ChunkResult> chunk_results(static_cast<size_t>(chunks));
  RGS_RETURN_IF_ERROR(detail::parallel_items(chunks, workers, [&](unsigned, uint64_t chunk) {
    const uint64_t b = chunk * detail::kErrorChunkGaussians;
    encode_chunk(cloud, tables, b, std::min(n, b + detail::kErrorChunkGaussians), &out, &chunk_results[chunk]);
  }));
  merge_chunks(chunk_results, tables.sh_values, report, errors);
  return out;
}

/// What a failed allocation while quantizing `cloud` says (catch_bad_alloc).
auto out_of_memory(const format::GaussianCloud& cloud) {
  return [&cloud] { return "out of memory quantizing " + std::to_string(cloud.size()) + " Gaussians"; };
}

}  // namespace

Result<format::EncodedScene> quantize(const format::GaussianCloud& cloud, const QuantizeOptions& options,
                                      QuantizationReport* report, AttributeErrors* errors) {
  RGS_RETURN_IF_ERROR(check_quantize_inputs(cloud, options));
  return catch_bad_alloc([&]() -> Result<format::EncodedScene> {
    float max_abs[4][3] = {};
    RGS_RETURN_IF_ERROR(scan_cloud(cloud, options, detail::worker_count(cloud.size(), kMinGaussiansPerWorker), max_abs));
    return encode_cloud(cloud, options, sh_quantization(cloud, options.sh_clip_percentile, max_abs), report, errors);
  }, out_of_memory(cloud));
}

QuantizeScan::QuantizeScan(const QuantizeOptions& options) : options_(options) {}

Status QuantizeScan::add(const format::GaussianCloud& batch, uint64_t first) {
  RGS_RETURN_IF_ERROR(check_quantize_inputs(batch, options_));
  RGS_RETURN_ERROR_IF(options_.sh_clip_percentile != 100.0f, StatusCode::kInvalidArgument,
                      "an SH clip percentile needs every coefficient at once; a scene read in batches takes the "
                      "max rule (percentile 100)");
  float max_abs[4][3] = {};
  const unsigned workers = detail::worker_count(batch.size(), kMinGaussiansPerWorker);
  RGS_RETURN_IF_ERROR(
      catch_bad_alloc([&] { return scan_cloud(batch, options_, workers, max_abs, first); }, out_of_memory(batch)));
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 3; ++c) max_abs_[d][c] = std::max(max_abs_[d][c], max_abs[d][c]);
  }
  return Status();
}

format::ShQuantization QuantizeScan::sh_quantization(uint32_t sh_degree) const {
  format::GaussianCloud shape;
  shape.sh_degree = sh_degree;
  return converter::sh_quantization(shape, 100.0f, max_abs_);
}

Result<format::EncodedScene> quantize(const format::GaussianCloud& cloud, const QuantizeOptions& options,
                                      const format::ShQuantization& shq, QuantizationReport* report,
                                      AttributeErrors* errors) {
  RGS_RETURN_IF_ERROR(check_quantize_inputs(cloud, options));
  return catch_bad_alloc([&] { return encode_cloud(cloud, options, shq, report, errors); }, out_of_memory(cloud));
}

}  // namespace rgs::converter
