// Encoder of the archive profile (SPEC §3.3): Draco means in kd-tree order, quantized other sections.
//
// Determinism: Draco runs single-threaded; each quantized section is one zstd frame or .xz stream with fixed
// parameters (its jobs or blocks of a fixed size, whatever the workers); sections are coded on parallel threads
// but each one's bytes depend only on its input, so the output does not depend on the number of threads.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include <xxhash.h>

#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/core/encoder_buffer.h>
#include <draco/core/quantization_utils.h>
#include <draco/point_cloud/point_cloud_builder.h>

#include "internal_archive.h"
#include "internal_bytes.h"
#include "internal_sections.h"
#include "internal_xz.h"
#include "rgs/format/archive.h"
#include "rgs/format/half.h"

namespace rgs::format {

namespace {

using detail::dec;
using detail::QuantizedTransform;

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidArgument, message); }

/// Planar code buffer of §3.3.2: `components` planes of n codes, 1 byte each (bits <= 8) or two byte
/// planes (low bytes, then high bytes).
struct CodePlanes {
  uint64_t n = 0;
  uint32_t width = 1;
  std::vector<uint8_t> bytes;
  CodePlanes(uint64_t count, uint32_t components, uint32_t bits)
      : n(count), width(bits <= 8 ? 1 : 2), bytes(static_cast<size_t>(count * components * (bits <= 8 ? 1 : 2))) {}
  void set(uint32_t c, uint64_t i, uint32_t code) {
    uint8_t* plane = bytes.data() + c * n * width;
    plane[i] = static_cast<uint8_t>(code);
    if (width == 2) plane[n + i] = static_cast<uint8_t>(code >> 8);
  }
  /// The codes of Gaussians order[0], order[1], ... of these codes, in that order.
  CodePlanes gathered(const std::vector<uint64_t>& order) const {
    const uint64_t planes = n == 0 ? 0 : bytes.size() / n;
    CodePlanes out(order.size(), static_cast<uint32_t>(planes / width), width == 2 ? 16 : 8);
    for (uint64_t k = 0; k < planes; ++k) {
      const uint8_t* from = bytes.data() + k * n;
      uint8_t* to = out.bytes.data() + k * out.n;
      for (uint64_t i = 0; i < order.size(); ++i) to[i] = from[order[i]];
    }
    return out;
  }
};

/// A section's codes for every Gaussian of the scene, in the scene's order (including those the archive leaves
/// out), and its transform's parameters: computed on sequential reads of the scene, while Draco runs when the
/// points are new, then gathered into the archive's order (encode_archive).
struct SourceCodes {
  CodePlanes codes{0, 0, 8};
  std::vector<float> params;
};

/// The literal context bits (LZMA's lc) the writer chooses between: lc 0 codes each byte on its own, lc 4 by the
/// high half of the byte before; which codes a section smaller depends on the scene (guitar's rotations take lc 0,
/// biker's lc 4).
constexpr uint32_t kXzLiteralContextBits[] = {0, 4};
/// For planes of codes the writer chooses lc, and whether LZMA beats zstd at all, on the first this many bytes of
/// the section's codes: the whole section is coded once more, not once for each choice.
constexpr size_t kXzSampleBytes = size_t{1} << 20;

/// Header (§3.3.2; the codebook transform adds its size, §3.3.3) + zstd frame of the codes, at `o.zstd_level`
/// with up to `o.threads` workers (encode_archive sets them for each section); with `o.xz`, an .xz stream of
/// them instead where one is smaller (ties keep zstd). Planes of codes take the literal context bits that code a
/// sample best, and no .xz stream where zstd codes the sample better. SH records of rest coefficients (transforms
/// 5 and 6 above degree 0) repeat a section apart, and a transform-5 section holds entries, DC codes and indices
/// one after the other, so no sample stands for them: they are coded at lc 0 (daffodils' 0.7 % smaller than at
/// lc 4, flowers' 0.2 % larger), with LZMA's slower far-match search.
Status finish_quantized(QuantizedTransform transform, uint32_t bits, uint32_t components,
                        const std::vector<float>& params, const std::vector<uint8_t>& codes, const ArchiveOptions& o,
                        std::vector<uint8_t>* out, uint32_t codebook_size = 0) {
  const bool codebook = transform == QuantizedTransform::kShCodebook;
  out->assign(detail::quantized_header_bytes(params.size(), codebook), 0);
  (*out)[0] = static_cast<uint8_t>(transform);
  (*out)[1] = static_cast<uint8_t>(bits);
  store_u16_le(out->data() + 2, static_cast<uint16_t>(params.size()));
  store_u32_le(out->data() + 4, components);
  for (size_t p = 0; p < params.size(); ++p) store_f32_le(out->data() + 8 + 4 * p, params[p]);
  if (codebook) store_u32_le(out->data() + 8 + 4 * params.size(), codebook_size);
  if (!o.xz) return detail::compress_zstd_frame(codes.data(), codes.size(), o.zstd_level, o.threads, out);
  // The zstd frame and the .xz trial run at the same time (each on `o.threads` workers): neither waits for the
  // other's result.
  std::vector<uint8_t> xz(out->begin(), out->end());
  bool xz_coded = false;
  std::vector<std::function<Status()>> jobs = {
      [&] { return detail::compress_zstd_frame(codes.data(), codes.size(), o.zstd_level, o.threads, out); },
      [&] {
        const bool records = codebook || (transform == QuantizedTransform::kShColourDifferences && components > 3);
        const detail::XzMatches matches = records ? detail::XzMatches::kFar : detail::XzMatches::kNear;
        uint32_t lc = 0;
        if (!records) {
          const size_t sample = std::min(codes.size(), kXzSampleBytes);
          std::vector<uint8_t> zstd_sample, xz_sample;
          RGS_RETURN_IF_ERROR(detail::compress_zstd_frame(codes.data(), sample, o.zstd_level, 1, &zstd_sample));
          size_t best = SIZE_MAX;
          for (uint32_t choice : kXzLiteralContextBits) {
            xz_sample.clear();
            RGS_RETURN_IF_ERROR(detail::compress_xz_stream(codes.data(), sample, choice, matches, 1, &xz_sample));
            if (xz_sample.size() < best) best = xz_sample.size(), lc = choice;
          }
          if (best >= zstd_sample.size()) return Status();  // zstd codes these planes better
        }
        xz_coded = true;
        return detail::compress_xz_stream(codes.data(), codes.size(), lc, matches, o.threads, &xz);
      }};
  RGS_RETURN_IF_ERROR(detail::run_jobs(jobs, 2, "coding a section"));
  if (xz_coded && xz.size() < out->size()) out->swap(xz);
  return Status();
}

/// The SH step multipliers as the parameters of transforms 4 and 5.
std::vector<float> sh_params(const ArchiveOptions& o) {
  return {static_cast<float>(o.sh_step_multipliers[0]), static_cast<float>(o.sh_step_multipliers[1]),
          static_cast<float>(o.sh_step_multipliers[2]), static_cast<float>(o.sh_step_multipliers[3])};
}

/// Step multiplier of value c of an SH record (coefficient c / 3).
int sh_multiplier(const ArchiveOptions& o, uint64_t c) {
  return static_cast<int>(o.sh_step_multipliers[sh_degree_of_coefficient(static_cast<uint32_t>(c / 3))]);
}

/// Transform-4 code of runtime value q with multiplier m: round half away from zero, as the runtime quantizer
/// does, clamped to 127 / m.
int8_t sh_code(int q, int m) {
  const int code = std::min((std::abs(q) + m / 2) / m, 127 / m);
  return static_cast<int8_t>(q < 0 ? -code : code);
}

uint32_t round_code(double v, uint32_t max_code) {
  const double r = std::floor(v + 0.5);
  return r <= 0 ? 0u : r >= max_code ? max_code : static_cast<uint32_t>(r);
}

/// The code of v (in code units) on the writer's coarser grid: v rounded to a multiple of `step` (≥ 1), then
/// to a code.
uint32_t round_code(double v, double step, uint32_t max_code) {
  return round_code(step == 1 ? v : std::floor(v / step + 0.5) * step, max_code);
}

/// §3.3.2 transform 1 codes of every rotation of the scene.
SourceCodes rotation_codes(const EncodedScene& s, const ArchiveOptions& o) {
  const uint64_t n = s.count;
  const uint32_t max_code = (1u << o.rotation_bits) - 1;
  SourceCodes out;
  CodePlanes& codes = out.codes = CodePlanes(n, 4, o.rotation_bits);
  const double inv = max_code / std::sqrt(2.0), lo = -std::sqrt(0.5);
  for (uint64_t i = 0; i < n; ++i) {
    const uint16_t* h = &s.rotations[i * 4];
    double q[4], n2 = 0;
    for (int a = 0; a < 4; ++a) {
      q[a] = half_bits_to_float(h[a]);
      n2 += q[a] * q[a];
    }
    const double norm = std::sqrt(n2);
    uint32_t largest = 0;
    for (uint32_t a = 1; a < 4; ++a) {
      if (std::fabs(q[a]) > std::fabs(q[largest])) largest = a;
    }
    const double sign = q[largest] < 0 ? -1.0 : 1.0;  // q and -q are the same rotation
    codes.set(0, i, largest);
    uint32_t code[3];
    double target[3], sum2 = 0;
    for (uint32_t a = 0, c = 0; a < 4; ++a) {
      if (a == largest) continue;
      target[c] = (sign * q[a] / norm - lo) * inv;
      code[c] = round_code(target[c], o.rotation_step, max_code);
      const double v = lo + code[c] / inv;
      sum2 += v * v;
      ++c;
    }
    // Coarse steps can round the three components out of the unit ball, where the decoder clamps the largest
    // to 0: the component rounded furthest away from zero moves back onto the grid point on its other side.
    if (o.rotation_step != 1 && sum2 > 1) {
      uint32_t worst = 0;
      double worst_out = -1;
      for (uint32_t c = 0; c < 3; ++c) {
        const double v = lo + code[c] / inv, t = lo + target[c] / inv;
        const double outward = std::fabs(v) - std::fabs(t);
        if (outward > worst_out) worst_out = outward, worst = c;
      }
      const double t = target[worst], k = o.rotation_step;
      const double toward_zero = t > max_code / 2.0 ? std::floor(t / k) * k : std::ceil(t / k) * k;
      code[worst] = round_code(toward_zero, max_code);
    }
    for (uint32_t c = 0; c < 3; ++c) codes.set(c + 1, i, code[c]);
  }
  return out;
}

/// A log-scale offset whose scale binary16 flushes to 0 (exp(-32) is far below 2^-25, where f16 rounds to 0): the
/// transform-2 offset of a linear axis whose every scale is 0.
constexpr float kZeroLinearScaleOffset = -32.0f;
/// The log-scale the converter stores for a scale of 0 under the log encoding (the lowest finite binary16).
constexpr double kZeroLogScale = -65504.0;

/// §3.3.2 transform 2 codes of every scale of the scene, on the range of ln(scale) per axis over the Gaussians
/// the archive keeps (`omitted`: ascending source indices of those it leaves out).
///
/// Scales of 0 (linear 0, or the log encoding's -65504) are outside the range, which they would stretch to
/// ln 0 = -inf (or -65504): they take code 0. An axis whose every kept scale is 0 (the flat axis of a 2D-Gaussian
/// or surfel scene) gets an offset that decodes to 0 again and a step of 0; so does a constant axis (one Gaussian,
/// or one size for all) with its own value as the offset. Among non-zero scales a 0 decodes to the axis' smallest
/// scale: the uniform grid cannot reach ln 0 without coarsening every other code of the axis.
SourceCodes scale_codes(const EncodedScene& s, const std::vector<uint64_t>& omitted, const ArchiveOptions& o) {
  const uint64_t n = s.count;
  const bool log = s.metadata.scale_encoding == ScaleEncoding::kLog;
  const uint32_t max_code = (1u << o.scale_bits) - 1;
  auto ln_of = [&](uint32_t bits) {
    const double v = half_bits_to_float(static_cast<uint16_t>(bits));
    if (log) return v <= kZeroLogScale ? -std::numeric_limits<double>::infinity() : v;
    return v > 0 ? std::log(v) : -std::numeric_limits<double>::infinity();
  };
  // The scales are binary16: with more values than bit patterns, each pattern's logarithm is taken once.
  std::vector<double> ln_table;
  if (3 * n > 65536) {
    ln_table.resize(65536);
    for (uint32_t bits = 0; bits < 65536; ++bits) ln_table[bits] = ln_of(bits);
  }
  auto ln = [&](uint16_t bits) { return ln_table.empty() ? ln_of(bits) : ln_table[bits]; };
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -std::numeric_limits<double>::infinity();
  }
  for (uint64_t i = 0, next = 0; i < n; ++i) {
    if (next < omitted.size() && omitted[next] == i) {
      ++next;
      continue;
    }
    for (uint32_t a = 0; a < 3; ++a) {
      const double v = ln(s.scales[i * 3 + a]);
      if (!std::isfinite(v)) continue;
      lo[a] = std::min(lo[a], v);
      hi[a] = std::max(hi[a], v);
    }
  }
  SourceCodes out;
  std::vector<float>& params = out.params = std::vector<float>(6);
  for (int a = 0; a < 3; ++a) {
    if (!(lo[a] <= hi[a])) {  // every kept scale of the axis is 0
      params[a] = log ? static_cast<float>(kZeroLogScale) : kZeroLinearScaleOffset;
      params[3 + a] = 0;
      continue;
    }
    // Offsets and steps are stored as float32; codes are computed against the stored values. The offset is
    // rounded down, so that the step (hi - offset) / max_code is never negative, which §3.3.2 forbids.
    float offset = static_cast<float>(lo[a]);
    if (static_cast<double>(offset) > lo[a]) offset = std::nextafter(offset, -std::numeric_limits<float>::infinity());
    params[a] = offset;
    params[3 + a] = lo[a] == hi[a] ? 0.0f : static_cast<float>((hi[a] - offset) / max_code * o.scale_step);
  }
  CodePlanes& codes = out.codes = CodePlanes(n, 3, o.scale_bits);
  for (uint64_t i = 0; i < n; ++i) {
    for (uint32_t a = 0; a < 3; ++a) {
      const double v = ln(s.scales[i * 3 + a]);
      const double step = params[3 + a];
      codes.set(a, i, !std::isfinite(v) || step == 0 ? 0 : round_code((v - params[a]) / step, max_code));
    }
  }
  return out;
}

/// The opacity code of a stored opacity (binary16 bits).
uint32_t opacity_code(uint16_t opacity, const ArchiveOptions& o) {
  const uint32_t max_code = (1u << o.opacity_bits) - 1;
  return round_code(half_bits_to_float(opacity) * static_cast<double>(max_code), o.opacity_step, max_code);
}

/// §3.3.2 transform 3 codes of every opacity of the scene.
SourceCodes opacity_codes(const EncodedScene& s, const ArchiveOptions& o) {
  SourceCodes out;
  out.codes = CodePlanes(s.count, 1, o.opacity_bits);
  for (uint64_t i = 0; i < s.count; ++i) out.codes.set(0, i, opacity_code(s.opacities[i], o));
  return out;
}

/// §3.3.2 transform 6: transform 4's codes with each (R, G, B) triple stored as (R - G, G, B - G) modulo 256, since
/// the channels of a trained colour move together; the DC triples as three planes, which zstd codes with a
/// table each; the rest as one record of 3K - 3 codes per Gaussian, since scenes whose SH come from a codebook
/// repeat whole records, which zstd finds as matches (docs/lab/AUDIT_RUNS.md#sh-colour-differences).
Status encode_sh(const EncodedScene& s, const std::vector<uint64_t>& order, const ArchiveOptions& o,
                 std::vector<uint8_t>* out) {
  const uint64_t n = order.size();
  const uint32_t values = 3 * sh_coefficient_count(s.metadata.sh_degree), rest_values = values - 3;
  CodePlanes codes(n, values, 8);
  uint8_t* rest = codes.bytes.data() + 3 * n;
  for (uint32_t c = 0; c < values; c += 3) {
    const int m = sh_multiplier(o, c);
    for (uint64_t i = 0; i < n; ++i) {
      const int8_t* q = &s.sh[order[i] * values + c];
      const auto green = static_cast<uint8_t>(sh_code(q[1], m));
      const uint8_t triple[3] = {static_cast<uint8_t>(static_cast<uint8_t>(sh_code(q[0], m)) - green), green,
                                 static_cast<uint8_t>(static_cast<uint8_t>(sh_code(q[2], m)) - green)};
      for (uint32_t k = 0; k < 3; ++k) {
        if (c == 0) {
          codes.bytes[k * n + i] = triple[k];
        } else {
          rest[i * rest_values + c - 3 + k] = triple[k];
        }
      }
    }
  }
  return finish_quantized(QuantizedTransform::kShColourDifferences, 8, values, sh_params(o), codes.bytes, o,
                          out);
}

/// One cell of the SH codebook's splitting tree: Gaussians ids[begin, end) and the exact integer sums of
/// their rest values (so every statistic, hence the tree, is the same whatever the thread count).
struct ShCell {
  uint32_t begin = 0, end = 0;
  int32_t left = -1, right = -1;  ///< children (node indices), -1 for a leaf
  double sse = 0;                 ///< weighted squared error of the cell around its mean
  uint32_t split_dim = 0;
};

/// §3.3.3 Builds the SH codebook: a variance-splitting tree over the per-Gaussian rest vectors (runtime i8
/// values, each dimension weighted by its dequantization step squared, so the error is the real SH
/// error, and each Gaussian by an integer importance). The cell of largest error is split first, on its
/// dimension of largest error, at the weighted mean; the leaves are the entries, numbered depth first so
/// that similar entries get near indices. Entries are the rounded weighted leaf means; every Gaussian
/// takes its leaf's index. Cost O(N R log K), single-threaded (it runs beside the other sections); all
/// sums are integers, so the tree does not depend on evaluation order.
struct ShCodebook {
  std::vector<int8_t> entries;   ///< [K, R]
  std::vector<uint16_t> index;   ///< [N] entry of each Gaussian (output order)
};

ShCodebook build_sh_codebook(const EncodedScene& s, const std::vector<uint64_t>& order, uint32_t target_size) {
  const uint64_t n = order.size();
  const uint32_t values = 3 * sh_coefficient_count(s.metadata.sh_degree), rest = values - 3;
  // Rest vectors in output order, contiguous (better locality than gathering through `order`).
  std::vector<int8_t> v(static_cast<size_t>(n * rest));
  for (uint64_t i = 0; i < n; ++i) std::memcpy(&v[i * rest], &s.sh[order[i] * values + 3], rest);
  std::vector<double> weight(rest);
  for (uint32_t j = 0; j < rest; ++j) {
    const double step = s.metadata.sh_quantization.scales[sh_degree_of_coefficient(1 + j / 3)][j % 3];
    weight[j] = step * step;
  }
  // Importance of each Gaussian: opacity x (scale product)^(2/3), a proxy of the screen area it covers,
  // as an integer weight 1..4096 relative to the mean (integers keep the sums exact).
  std::vector<uint32_t> wt(static_cast<size_t>(n));
  {
    const bool log = s.metadata.scale_encoding == ScaleEncoding::kLog;
    std::vector<double> imp(static_cast<size_t>(n));
    double total = 0;
    for (uint64_t i = 0; i < n; ++i) {
      const uint64_t src = order[i];
      double ln_volume = 0;
      for (int a = 0; a < 3; ++a) {
        const double scale = half_bits_to_float(s.scales[src * 3 + a]);
        ln_volume += log ? scale : std::log(std::max(scale, 1e-30));
      }
      imp[i] = half_bits_to_float(s.opacities[src]) * std::exp(2.0 / 3.0 * ln_volume);
      total += imp[i];
    }
    const double unit = total > 0 ? 64.0 * static_cast<double>(n) / total : 0;
    for (uint64_t i = 0; i < n; ++i)
      wt[i] = static_cast<uint32_t>(std::clamp(std::floor(imp[i] * unit + 0.5), 1.0, 4096.0));
  }
  std::vector<uint32_t> ids(static_cast<size_t>(n));
  for (uint64_t i = 0; i < n; ++i) ids[i] = static_cast<uint32_t>(i);
  std::vector<ShCell> cells;
  const size_t stride = 2 * size_t{rest} + 1;
  std::vector<int64_t> sums;  // [cells, 2R + 1]: weighted sum and sum of squares per dimension, total weight
  cells.reserve(2 * size_t{target_size});
  sums.reserve(2 * size_t{target_size} * stride);
  auto finish_cell = [&](size_t c) {
    const int64_t* sm = &sums[c * stride];
    const double count = static_cast<double>(sm[2 * rest]);
    double total = 0, best = -1;
    for (uint32_t j = 0; j < rest; ++j) {
      const double e = weight[j] * (static_cast<double>(sm[rest + j]) -
                                    static_cast<double>(sm[j]) * static_cast<double>(sm[j]) / count);
      total += e;
      if (e > best) best = e, cells[c].split_dim = j;
    }
    cells[c].sse = total;
  };
  auto add_cell = [&](uint32_t begin, uint32_t end) {
    cells.push_back(ShCell{begin, end});
    sums.resize(cells.size() * stride, 0);
    return cells.size() - 1;
  };
  auto accumulate = [&](size_t c) {
    int64_t* sm = &sums[c * stride];
    for (uint32_t p = cells[c].begin; p < cells[c].end; ++p) {
      const int8_t* x = &v[size_t{ids[p]} * rest];
      const int64_t w = wt[ids[p]];
      for (uint32_t j = 0; j < rest; ++j) {
        sm[j] += w * x[j];
        sm[rest + j] += w * (x[j] * x[j]);
      }
      sm[2 * rest] += w;
    }
  };
  accumulate(add_cell(0, static_cast<uint32_t>(n)));
  finish_cell(0);
  // Max-heap on (error, -node): ties go to the older node, so the order is fully determined.
  auto less = [&](uint32_t a, uint32_t b) {
    return cells[a].sse < cells[b].sse || (cells[a].sse == cells[b].sse && a > b);
  };
  std::vector<uint32_t> heap = {0};
  uint32_t leaves = 1;
  while (leaves < target_size && !heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), less);
    const uint32_t c = heap.back();
    heap.pop_back();
    if (!(cells[c].sse > 0)) break;  // every remaining cell holds one repeated vector
    const uint32_t j = cells[c].split_dim, begin = cells[c].begin, end = cells[c].end;
    const int64_t sum = sums[size_t{c} * stride + j];
    const int64_t count = sums[size_t{c} * stride + 2 * rest];
    // x <= weighted mean  <=>  x * total weight <= weighted sum: exact in integers.
    const uint32_t* mid = std::partition(ids.data() + begin, ids.data() + end, [&](uint32_t id) {
      return int64_t{v[size_t{id} * rest + j]} * count <= sum;
    });
    const uint32_t split = static_cast<uint32_t>(mid - ids.data());
    if (split == begin || split == end) continue;  // cannot happen with a positive variance; stay a leaf
    const size_t l = add_cell(begin, split), r = add_cell(split, end);
    cells[c].left = static_cast<int32_t>(l);
    cells[c].right = static_cast<int32_t>(r);
    // Sum the smaller child, the other is the parent minus it (exact).
    const size_t small = split - begin <= end - split ? l : r, large = small == l ? r : l;
    accumulate(small);
    for (size_t k = 0; k < stride; ++k)
      sums[large * stride + k] = sums[size_t{c} * stride + k] - sums[small * stride + k];
    for (size_t child : {l, r}) {
      finish_cell(child);
      heap.push_back(static_cast<uint32_t>(child));
      std::push_heap(heap.begin(), heap.end(), less);
    }
    ++leaves;
  }
  ShCodebook book;
  book.entries.reserve(size_t{leaves} * rest);
  book.index.resize(static_cast<size_t>(n));
  std::vector<uint32_t> stack = {0};
  while (!stack.empty()) {
    const uint32_t c = stack.back();
    stack.pop_back();
    if (cells[c].left >= 0) {
      stack.push_back(static_cast<uint32_t>(cells[c].right));
      stack.push_back(static_cast<uint32_t>(cells[c].left));
      continue;
    }
    const uint16_t e = static_cast<uint16_t>(book.entries.size() / rest);
    const int64_t count = sums[size_t{c} * stride + 2 * rest];
    for (uint32_t j = 0; j < rest; ++j) {
      // Round half away from zero; a mean of values in [-127, 127] stays in it.
      const int64_t sm = sums[size_t{c} * stride + j];
      const int64_t q = sm >= 0 ? (2 * sm + count) / (2 * count) : -((-2 * sm + count) / (2 * count));
      book.entries.push_back(static_cast<int8_t>(q));
    }
    for (uint32_t p = cells[c].begin; p < cells[c].end; ++p) book.index[ids[p]] = e;
  }
  return book;
}

/// §3.3.3 Distinct rest-code records in first-occurrence order: `first[e]` is the first Gaussian (output
/// order) holding entry e, `index[i]` the entry of Gaussian i. An open-addressing table of entry ids
/// (4 bytes a slot) compares records by recomputing them, so no copy of the records is kept. Returns
/// false as soon as more than `max_entries` records are distinct.
bool dedup_sh_records(const EncodedScene& s, const std::vector<uint64_t>& order, const ArchiveOptions& o,
                      uint64_t max_entries, std::vector<uint32_t>* first, std::vector<uint32_t>* index) {
  const uint64_t n = order.size();
  const uint32_t values = 3 * sh_coefficient_count(s.metadata.sh_degree), rest = values - 3;
  int mult[45];
  for (uint32_t j = 0; j < rest; ++j)
    mult[j] = sh_multiplier(o, 3 + j);
  auto codes_of = [&](uint64_t i, int8_t* record) {
    const int8_t* q = &s.sh[order[i] * values + 3];
    for (uint32_t j = 0; j < rest; ++j) record[j] = sh_code(q[j], mult[j]);
  };
  uint64_t slots = 1024;
  while (slots < 2 * max_entries + 2) slots *= 2;
  std::vector<uint32_t> table(static_cast<size_t>(slots), 0);  // entry id + 1, 0 = empty
  first->clear();
  index->resize(static_cast<size_t>(n));
  int8_t record[45], other[45];
  for (uint64_t i = 0; i < n; ++i) {
    codes_of(i, record);
    uint64_t slot = XXH64(record, rest, 0) & (slots - 1);
    for (;; slot = (slot + 1) & (slots - 1)) {
      const uint32_t id = table[slot];
      if (id == 0) {
        if (first->size() >= max_entries) return false;
        table[slot] = static_cast<uint32_t>(first->size() + 1);
        (*index)[i] = static_cast<uint32_t>(first->size());
        first->push_back(static_cast<uint32_t>(i));
        break;
      }
      codes_of((*first)[id - 1], other);
      if (std::memcmp(other, record, rest) == 0) {
        (*index)[i] = id - 1;
        break;
      }
    }
  }
  return true;
}

/// §3.3.3 The sh section with transform 5: entry codes, DC codes and index planes in one zstd frame. With
/// sh_codebook_size 0 the entries are the distinct records of transform-4 codes (the same decoded values
/// as transform 4), used only when at most kShDedupMaxShare of the Gaussians hold distinct records
/// (`*used` false otherwise: the caller writes transform 6); otherwise the lossy tree codebook.
constexpr double kShDedupMaxShare = 0.75;

Status encode_sh_codebook(const EncodedScene& s, const std::vector<uint64_t>& order, const ArchiveOptions& o,
                          std::vector<uint8_t>* out, bool* used) {
  const uint64_t n = order.size();
  const uint32_t values = 3 * sh_coefficient_count(s.metadata.sh_degree), rest = values - 3;
  std::vector<int8_t> entries;
  std::vector<uint32_t> index, first;
  if (o.sh_codebook_size == 0) {
    const uint64_t max_entries = static_cast<uint64_t>(kShDedupMaxShare * static_cast<double>(n));
    *used = dedup_sh_records(s, order, o, std::min<uint64_t>(max_entries, uint64_t{1} << 24), &first, &index);
    if (!*used) return Status();
  } else {
    *used = true;
    ShCodebook book = build_sh_codebook(s, order, static_cast<uint32_t>(std::min<uint64_t>(o.sh_codebook_size, n)));
    entries = std::move(book.entries);
    for (size_t e = 0; e < entries.size(); ++e) entries[e] = sh_code(entries[e], sh_multiplier(o, 3 + e % rest));
    index.assign(book.index.begin(), book.index.end());
  }
  const uint64_t k = first.empty() ? entries.size() / rest : first.size();
  uint32_t bits = 1;
  while ((uint64_t{1} << bits) < k) ++bits;
  const uint32_t width = (bits + 7) / 8;
  std::vector<uint8_t> frame(static_cast<size_t>(k * rest + n * (3 + width)));
  if (first.empty()) {
    std::memcpy(frame.data(), entries.data(), entries.size());
  } else {
    for (uint64_t e = 0; e < k; ++e) {
      const int8_t* q = &s.sh[order[first[e]] * values + 3];
      for (uint32_t j = 0; j < rest; ++j) {
        frame[e * rest + j] = static_cast<uint8_t>(sh_code(q[j], sh_multiplier(o, 3 + j)));
      }
    }
    first = {};
  }
  uint8_t* dc = frame.data() + k * rest;
  uint8_t* planes = dc + n * 3;
  const int m = static_cast<int>(o.sh_step_multipliers[0]);
  for (uint64_t i = 0; i < n; ++i) {
    for (uint32_t c = 0; c < 3; ++c) dc[i * 3 + c] = static_cast<uint8_t>(sh_code(s.sh[order[i] * values + c], m));
    for (uint32_t b = 0; b < width; ++b) planes[b * n + i] = static_cast<uint8_t>(index[i] >> (8 * b));
  }
  index = {};  // before the frame's compression buffer is allocated
  return finish_quantized(QuantizedTransform::kShCodebook, bits, values, sh_params(o), frame, o,
                          out, static_cast<uint32_t>(k));
}

/// 16 bytes: Draco's quantized coordinates (< 2^30) and the point index (< 2^31, checked by the caller).
struct QuantKey {
  int32_t q[3];
  uint32_t index;
  bool same_point(const QuantKey& b) const { return q[0] == b.q[0] && q[1] == b.q[1] && q[2] == b.q[2]; }
};

/// Sorts `keys` by point (q[0], then q[1], then q[2], as unsigned), equal points in their present order: a stable
/// LSD radix sort of 11-bit digits over the bits the coordinates use (bits of the position quantization: 3 to 9
/// passes instead of a comparison sort's 22 levels for 4M points).
void sort_by_point(std::vector<QuantKey>* keys) {
  constexpr int kDigitBits = 11;
  constexpr size_t kBuckets = size_t{1} << kDigitBits;
  uint32_t used = 0;
  for (const QuantKey& k : *keys) used |= uint32_t(k.q[0]) | uint32_t(k.q[1]) | uint32_t(k.q[2]);
  int width = 0;
  while (width < 32 && (used >> width) != 0) ++width;
  std::vector<QuantKey> other(keys->size());
  std::vector<size_t> start(kBuckets);
  for (int a = 2; a >= 0; --a) {
    for (int shift = 0; shift < width; shift += kDigitBits) {
      auto digit = [a, shift](const QuantKey& k) { return (uint32_t(k.q[a]) >> shift) & (kBuckets - 1); };
      std::fill(start.begin(), start.end(), 0);
      for (const QuantKey& k : *keys) ++start[digit(k)];
      size_t sum = 0;
      for (size_t& c : start) sum += std::exchange(c, sum);
      for (const QuantKey& k : *keys) other[start[digit(k)]++] = k;
      keys->swap(other);
    }
  }
}

/// §3.3.1 Draco-codes `means` ([n, 3] float32) and finds, for each decoded point i, the mean order[i] it came
/// from: the kd-tree coder emits points in its own order. Points are matched by their quantized coordinates
/// (computed with Draco's own quantizer); points with equal coordinates decode to equal means, so any
/// pairing among them is exact; equal points pair in index order, so the file does not depend on the sort.
Status encode_means(const std::vector<float>& means, ArchivePositionQuantization* pq, const ArchiveOptions& o,
                    std::vector<uint8_t>* stored, std::vector<float>* decoded_means, std::vector<uint64_t>* order) {
  const uint64_t n = means.size() / 3;
  draco::PointCloudBuilder builder;
  builder.Start(static_cast<uint32_t>(n));
  const int att = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  builder.SetAttributeValuesForAllPoints(att, means.data(), 12);
  std::unique_ptr<draco::PointCloud> pc = builder.Finalize(false);
  if (!pc) return Status(StatusCode::kOutOfMemory, "Draco point cloud construction failed");
  draco::Encoder encoder;
  encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION, static_cast<int>(pq->bits), 3,
                                           pq->origin, pq->range);
  encoder.SetSpeedOptions(o.draco_speed, o.draco_speed);
  encoder.SetEncodingMethod(draco::POINT_CLOUD_KD_TREE_ENCODING);
  draco::EncoderBuffer buffer;
  const draco::Status st = encoder.EncodePointCloudToBuffer(*pc, &buffer);
  if (!st.ok()) return invalid("Draco encoding failed: " + st.error_msg_string());
  pc.reset();
  stored->assign(reinterpret_cast<const uint8_t*>(buffer.data()),
                 reinterpret_cast<const uint8_t*>(buffer.data()) + buffer.size());

  // The stream decoded once, to Draco's quantized coordinates and the parameters it really used (its kd-tree
  // coder derives them itself): the source points are quantized exactly as it did, and the decoded means are
  // what its decoder returns, each coordinate q * (range / (2^bits - 1)) + min in float32, as Draco's
  // AttributeQuantizationTransform::InverseTransformAttribute computes it (this file is built without FMA
  // contraction; the tests compare the file's own decode with these means bit for bit).
  draco::DecoderBuffer raw_buffer;
  raw_buffer.Init(buffer.data(), buffer.size());
  draco::Decoder raw_decoder;
  raw_decoder.SetSkipAttributeTransform(draco::GeometryAttribute::POSITION);
  auto raw = raw_decoder.DecodePointCloudFromBuffer(&raw_buffer);
  if (!raw.ok())
    return invalid("internal error: Draco cannot decode its own stream: " + raw.status().error_msg_string());
  const std::unique_ptr<draco::PointCloud> qpc = std::move(raw).value();
  const draco::PointAttribute* qatt = qpc->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  draco::AttributeQuantizationTransform transform;
  if (qpc->num_points() != n || qatt == nullptr || !transform.InitFromAttribute(*qatt) ||
      transform.quantization_bits() != static_cast<int>(pq->bits)) {
    return invalid("internal error: Draco's stream lacks the position quantization");
  }
  for (int a = 0; a < 3; ++a) pq->origin[a] = transform.min_value(a);
  pq->range = transform.range();
  pq->step = static_cast<double>(pq->range) / static_cast<double>((uint64_t{1} << pq->bits) - 1);
  const int32_t max_quantized = static_cast<int32_t>((uint32_t{1} << pq->bits) - 1);
  draco::Quantizer quantizer;
  quantizer.Init(transform.range(), max_quantized);
  draco::Dequantizer dequantizer;
  if (!dequantizer.Init(transform.range(), max_quantized)) {
    return invalid("internal error: Draco's position range " + std::to_string(transform.range()) + " is unusable");
  }
  decoded_means->resize(static_cast<size_t>(n * 3));
  std::vector<QuantKey> src(n), dst(n);
  for (uint64_t i = 0; i < n; ++i) {
    src[i].index = dst[i].index = static_cast<uint32_t>(i);
    int32_t q[3] = {};
    qatt->GetMappedValue(draco::PointIndex(static_cast<uint32_t>(i)), q);
    for (int a = 0; a < 3; ++a) {
      // Draco's grid is its own (derived from the points): one too narrow for float32 (an infinite inverse step)
      // is refused rather than quantized. Draco scales in float32, which puts the farthest point up to a few
      // float32 units past the last code at 20 bits and more: that is rounding, not a grid too narrow.
      const float offset = means[i * 3 + a] - transform.min_value(a);
      const float scaled = offset * (static_cast<float>(max_quantized) / transform.range());
      if (!(std::fabs(double(scaled)) <= double(max_quantized) * (1.0 + 0x1p-20) + 1.0)) {
        return invalid("the means lie too close together on an axis for the archive's position grid (Draco's "
                       "range " + std::to_string(transform.range()) + "); the runtime profile keeps them");
      }
      src[i].q[a] = quantizer.QuantizeFloat(offset);
      dst[i].q[a] = q[a];
      const float value = dequantizer.DequantizeFloat(q[a]);
      (*decoded_means)[i * 3 + a] = value + transform.min_value(a);
    }
  }
  std::vector<std::function<Status()>> sorts;
  for (std::vector<QuantKey>* keys : {&src, &dst}) {
    sorts.push_back([keys] {
      sort_by_point(keys);
      return Status();
    });
  }
  RGS_RETURN_IF_ERROR(detail::run_jobs(sorts, o.threads, "pairing Draco's points"));
  order->assign(static_cast<size_t>(n), 0);
  for (uint64_t i = 0; i < n; ++i) {
    if (!src[i].same_point(dst[i])) {
      return invalid("internal error: Draco's decoded points do not match the quantized means (point " +
                     dec(dst[i].index) + ")");
    }
    (*order)[dst[i].index] = src[i].index;
  }
  return Status();
}

/// Source indices of the Gaussians the archive leaves out, ascending: those whose opacity code is 0 (they decode
/// to opacity 0, which no renderer draws) or whose opacity is below the floor; none when that would be every
/// Gaussian.
std::vector<uint64_t> omitted_gaussians(const EncodedScene& s, const ArchiveOptions& o) {
  std::vector<uint64_t> omitted;
  for (uint64_t i = 0; i < s.count; ++i) {
    if (opacity_code(s.opacities[i], o) == 0 || half_bits_to_float(s.opacities[i]) < o.opacity_floor) {
      omitted.push_back(i);
    }
  }
  if (omitted.size() == s.count) omitted.clear();
  return omitted;
}

/// The source index of each Gaussian that `omitted` (ascending) leaves, ascending.
std::vector<uint64_t> kept_gaussians(uint64_t count, const std::vector<uint64_t>& omitted) {
  std::vector<uint64_t> kept;
  kept.reserve(count - omitted.size());
  size_t next = 0;
  for (uint64_t i = 0; i < count; ++i) {
    if (next < omitted.size() && omitted[next] == i) {
      ++next;
      continue;
    }
    kept.push_back(i);
  }
  return kept;
}

/// The bounds of §4.1.1 for the decoded means, as the converter computes them (AABB centre, radius in
/// double with a 1e-6 relative margin, rounded up to float32).
SceneBounds bounds_of(const std::vector<float>& means) {
  SceneBounds b;
  const size_t n = means.size() / 3;
  if (n == 0) return b;
  box_of_means(means.data(), n, b.aabb_min, b.aabb_max);
  double center[3];
  set_sphere_center(&b, center);
  b.sphere_radius = sphere_radius_for(max_squared_distance(means.data(), n, center));
  return b;
}

}  // namespace

Status check_archive_options(const ArchiveOptions& o) {
  if (!(o.position_error >= 0.0 && o.position_error <= 0.5)) {
    return invalid("position error " + std::to_string(o.position_error) + " outside (0, 0.5] (or 0: by scene)");
  }
  for (auto [name, bits] : {std::pair{"rotation", o.rotation_bits}, std::pair{"scale", o.scale_bits},
                            std::pair{"opacity", o.opacity_bits}}) {
    if (bits != 0 && (bits < 4 || bits > 16)) {
      return invalid(std::string(name) + " bits " + dec(bits) + " outside 4..16 (or 0: by scene size)");
    }
  }
  for (auto [name, step] : {std::pair{"rotation", o.rotation_step}, std::pair{"scale", o.scale_step},
                            std::pair{"opacity", o.opacity_step}}) {
    if (!(step >= 1 && step <= 4096)) {
      return invalid(std::string(name) + " step " + std::to_string(step) + " outside 1..4096 (times the bits' own step)");
    }
  }
  for (size_t d = 0; d < 4; ++d) {
    if (o.sh_step_multipliers[d] > 127) {
      return invalid("SH step multiplier of degree " + dec(d) + " = " + dec(o.sh_step_multipliers[d]) +
                     " outside 1..127 (or 0: by scene)");
    }
  }
  if (!(o.opacity_floor >= 0 && o.opacity_floor < 1)) {
    return invalid("opacity floor " + std::to_string(o.opacity_floor) + " outside [0, 1)");
  }
  if (o.sh_codebook_size == 1 || o.sh_codebook_size > 65536) {
    return invalid("SH codebook size " + dec(o.sh_codebook_size) + " outside 0 (none) or 2..65536");
  }
  RGS_RETURN_IF_ERROR(detail::check_zstd_level(o.zstd_level));
  if (o.draco_speed < 0 || o.draco_speed > 10)
    return invalid("Draco speed " + std::to_string(o.draco_speed) + " outside 0..10");
  return Status();
}

ArchiveOptions resolve_archive_options(const ArchiveOptions& options, const EncodedScene& scene) {
  ArchiveOptions o = options;
  const bool dense = scene.count >= kArchiveDenseGaussians;
  if (o.rotation_bits == 0) o.rotation_bits = dense ? 7 : 10;
  if (o.scale_bits == 0) o.scale_bits = dense ? 7 : 9;
  if (o.opacity_bits == 0) o.opacity_bits = dense ? 6 : 8;
  o.xz = o.xz && (o.zstd_level >= kArchiveXzMinZstdLevel || !dense);
  // Half SPZ's steps (archive.h): finer than these, the archive spends bytes where SPZ spends none.
  if (o.position_error == 0) {
    const SceneBounds& b = scene.metadata.bounds;
    double extent = 0;
    for (int a = 0; a < 3; ++a) extent = std::max(extent, double(b.aabb_max[a]) - double(b.aabb_min[a]));
    const double spz = extent > 0 ? kSpzPositionStep / (4 * extent) : 0;
    o.position_error = std::clamp(spz, kDefaultArchivePositionError, 0.5);
  }
  for (uint32_t d = 0; d < 4; ++d) {
    if (o.sh_step_multipliers[d] != 0) continue;
    const float* s = scene.metadata.sh_quantization.scales[d];
    const double largest = std::max({s[0], s[1], s[2]});
    const double spz = largest > 0 ? std::floor(kSpzShSteps[d] / 2 / largest) : 0;
    o.sh_step_multipliers[d] = uint32_t(std::clamp(spz, double(kArchiveShMultipliers[d]), 127.0));
  }
  return o;
}

Result<ArchivePositionQuantization> choose_position_quantization(const SceneBounds& bounds, double position_error) {
  if (!(position_error > 0.0 && position_error <= 0.5)) {
    return invalid("position error " + std::to_string(position_error) + " outside (0, 0.5]");
  }
  ArchivePositionQuantization q;
  double extent = 0;
  for (int a = 0; a < 3; ++a) {
    q.origin[a] = bounds.aabb_min[a];
    extent = std::max(extent, static_cast<double>(bounds.aabb_max[a]) - bounds.aabb_min[a]);
  }
  // The grid's range is a float32 at least the extent (Draco's): an extent of float32's largest value or more has
  // none (such means are valid, and the runtime profile keeps them).
  if (!(extent < static_cast<double>(std::numeric_limits<float>::max()))) {
    return invalid("the means span " + std::to_string(extent) +
                   " units on one axis, more than the archive's float32 position grid can cover");
  }
  q.range = static_cast<float>(extent);
  if (static_cast<double>(q.range) < extent) q.range = std::nextafter(q.range, std::numeric_limits<float>::infinity());
  if (!(q.range > 0.0f)) q.range = 1.0f;  // a single position: any grid holds it exactly
  // Fewest bits whose step range / (2^bits - 1) is at most 2 * error * extent.
  const double levels = 1.0 / (2.0 * position_error);
  q.bits = 1;
  while (q.bits < 30 && static_cast<double>((uint64_t{1} << q.bits) - 1) < levels) ++q.bits;
  q.step = static_cast<double>(q.range) / static_cast<double>((uint64_t{1} << q.bits) - 1);
  return q;
}

namespace {

/// Slots of the archive's sections in `ArchiveScene::stored`: means, rotations, scales, opacities, SH.
using SectionFlags = std::array<bool, 5>;

/// The sections of `earlier` coded with the same settings, in the same order, as `out` will be: those are taken
/// as they are (same bytes, same values). Slot 0 (the means) also says that Draco's order is the same.
SectionFlags reusable_sections(const ArchiveScene* earlier, const ArchiveScene& out, const ArchiveOptions& options) {
  if (!earlier) return {};
  const ArchiveOptions& e = earlier->options;
  const bool same_order = earlier->omitted == out.omitted && earlier->position.bits == out.position.bits &&
                          e.draco_speed == options.draco_speed;
  const bool same_zstd = same_order && e.zstd_level == options.zstd_level && e.xz == options.xz;
  return {same_order, same_zstd && e.rotation_bits == options.rotation_bits && e.rotation_step == options.rotation_step,
          same_zstd && e.scale_bits == options.scale_bits && e.scale_step == options.scale_step,
          same_zstd && e.opacity_bits == options.opacity_bits && e.opacity_step == options.opacity_step,
          same_zstd && e.sh_step_multipliers == options.sh_step_multipliers &&
              e.sh_codebook_size == options.sh_codebook_size};
}

/// Step 1: the means coded by Draco, which fixes the order (`order[i]` is the source index of the archive's
/// Gaussian i), and meanwhile the codes of rotations, scales and opacities in the source's order (slots 1..3).
Status order_means_and_quantize(const EncodedScene& source, const ArchiveOptions& options, const ArchiveScene* earlier,
                                const SectionFlags& reuse, ArchiveScene* out, std::vector<uint64_t>* order,
                                std::array<SourceCodes, 4>* codes) {
  EncodedScene& d = out->decoded;
  std::vector<std::function<Status()>> jobs;
  if (reuse[0]) {
    out->position = earlier->position;  // as Draco stored it
    out->stored[0] = earlier->stored[0];
    d.means = earlier->decoded.means;
    *order = earlier->source_index;
  } else {
    jobs.push_back([&] {
      if (out->omitted.empty()) {
        return encode_means(source.means, &out->position, options, &out->stored[0], &d.means, order);
      }
      const std::vector<uint64_t> kept = kept_gaussians(source.count, out->omitted);
      std::vector<float> kept_means(kept.size() * 3);
      for (size_t j = 0; j < kept.size(); ++j) std::copy_n(&source.means[kept[j] * 3], 3, &kept_means[j * 3]);
      RGS_RETURN_IF_ERROR(encode_means(kept_means, &out->position, options, &out->stored[0], &d.means, order));
      for (uint64_t& i : *order) i = kept[i];
      return Status();
    });
  }
  auto add_codes = [&](size_t slot, auto make) {
    if (reuse[slot]) return;
    jobs.push_back([codes, slot, make] {
      (*codes)[slot] = make();
      return Status();
    });
  };
  add_codes(1, [&] { return rotation_codes(source, options); });
  add_codes(2, [&] { return scale_codes(source, out->omitted, options); });
  add_codes(3, [&] { return opacity_codes(source, options); });
  return detail::run_jobs(jobs, options.threads, "encoding the archive");
}

/// Step 2: the sections not reused, coded in Draco's order. They share the threads: each its own, and its zstd
/// frame's jobs (§7) the threads over. Each slot's codes are freed once gathered.
Status code_sections(const EncodedScene& source, const ArchiveOptions& options, const SectionFlags& reuse,
                     const std::vector<uint64_t>& order, std::array<SourceCodes, 4>* codes, ArchiveScene* out) {
  ArchiveOptions section = options;
  section.threads = detail::threads_per_job(options.threads, std::count(reuse.begin() + 1, reuse.end(), false));
  std::vector<std::function<Status()>> jobs;
  if (!reuse[4]) {
    jobs.push_back([&] {
      bool codebook = false;
      if (source.metadata.sh_degree > 0) {
        RGS_RETURN_IF_ERROR(encode_sh_codebook(source, order, section, &out->stored[4], &codebook));
      }
      return codebook ? Status() : encode_sh(source, order, section, &out->stored[4]);
    });
  }
  constexpr QuantizedTransform kTransforms[4] = {{}, QuantizedTransform::kSmallestThree,
                                                 QuantizedTransform::kLogUniform, QuantizedTransform::kUniform};
  const uint32_t bits[4] = {0, options.rotation_bits, options.scale_bits, options.opacity_bits};
  const uint32_t slot_components[4] = {0, 4, 3, 1};
  for (size_t slot = 1; slot < 4; ++slot) {
    if (reuse[slot]) continue;
    jobs.push_back([&, slot] {
      SourceCodes& slot_codes = (*codes)[slot];
      const std::vector<uint8_t> gathered = slot_codes.codes.gathered(order).bytes;
      slot_codes.codes = CodePlanes(0, 0, 8);  // freed before the coding's buffers exist
      return finish_quantized(kTransforms[slot], bits[slot], slot_components[slot], slot_codes.params, gathered,
                              section, &out->stored[slot]);
    });
  }
  return detail::run_jobs(jobs, options.threads, "encoding the archive");
}

/// Step 3: decodes what was written into `out->decoded`, bit for bit what readers get; reused sections are
/// copied from `earlier`.
Status decode_sections(const EncodedScene& source, const ArchiveOptions& options, const ArchiveScene* earlier,
                       const SectionFlags& reuse, const std::vector<uint64_t>& order, ArchiveScene* out) {
  EncodedScene& d = out->decoded;
  const uint64_t n = d.count;
  const uint32_t values = 3 * sh_coefficient_count(d.metadata.sh_degree);
  std::vector<std::function<Status()>> jobs;
  auto add_decode = [&](SectionId id, size_t slot, uint32_t components, auto EncodedScene::*member) {
    auto& array = d.*member;
    if (reuse[slot]) {
      out->stored[slot] = earlier->stored[slot];
      array = earlier->decoded.*member;
      return;
    }
    array.resize(n * components);
    jobs.push_back([&d, out, &array, id, slot, components, n] {
      Status s = detail::decode_quantized(id, d.metadata, out->stored[slot].data(), out->stored[slot].size(), n,
                                          components, reinterpret_cast<uint8_t*>(array.data()),
                                          array.size() * sizeof(array[0]));
      return s.ok() ? s : s.prepend(std::string("internal error decoding ") + section_name(id));
    });
  };
  add_decode(SectionId::kRotations, 1, 4, &EncodedScene::rotations);
  add_decode(SectionId::kScales, 2, 3, &EncodedScene::scales);
  add_decode(SectionId::kOpacities, 3, 1, &EncodedScene::opacities);
  // Transforms 4 and 6 and the exact transform 5 decode to the transform-4 value of every source value, so the
  // SH values are computed here instead of decompressing the section again (saving its code buffer,
  // the largest, at the peak); the tests check the file decodes to them. A lossy codebook is decoded.
  if (reuse[4]) {
    out->stored[4] = earlier->stored[4];
    d.sh = earlier->decoded.sh;
  } else if (options.sh_codebook_size != 0) {
    add_decode(SectionId::kSh, 4, values, &EncodedScene::sh);
  } else {
    d.sh.resize(n * values);
    jobs.push_back([&d, &source, &order, &options, values, n] {
      int mult[48];
      for (uint32_t c = 0; c < values; ++c) mult[c] = sh_multiplier(options, c);
      for (uint64_t i = 0; i < n; ++i) {
        const int8_t* q = &source.sh[order[i] * values];
        for (uint32_t c = 0; c < values; ++c)
          d.sh[i * values + c] = static_cast<int8_t>(sh_code(q[c], mult[c]) * mult[c]);
      }
      return Status();
    });
  }
  RGS_RETURN_IF_ERROR(detail::run_jobs(jobs, options.threads, "encoding the archive"));
  if constexpr (!detail::kHostLittleEndian) {
    for (auto* v : {&d.rotations, &d.scales, &d.opacities}) {
      for (uint16_t& x : *v) x = load_u16_le(reinterpret_cast<const uint8_t*>(&x));
    }
  }
  return Status();
}

}  // namespace

Result<ArchiveScene> encode_archive(const EncodedScene& source, const ArchiveOptions& options_in,
                                    const ArchiveScene* earlier) {
  RGS_RETURN_IF_ERROR(check_archive_options(options_in));
  const ArchiveOptions options = resolve_archive_options(options_in, source);
  if (!source.is_consistent()) return invalid("encoded scene arrays do not match its count and SH degree");
  if (source.count > UINT32_MAX / 2)
    return invalid("Draco holds at most 2^31 points; the scene has " + dec(source.count));
  if (earlier && earlier->source_count != source.count) return invalid("the earlier archive is of another scene");
  try {
    ArchiveScene out;
    out.options = options;
    out.source_count = source.count;
    // The Gaussians whose opacity code is 0 or whose opacity is below the floor are left out (archive.h).
    out.omitted = omitted_gaussians(source, options);
    RGS_ASSIGN_OR_RETURN(out.position, choose_position_quantization(source.metadata.bounds, options.position_error));
    EncodedScene& d = out.decoded;
    d.metadata = source.metadata;
    d.provenance = source.provenance;
    d.count = source.count - out.omitted.size();
    if (d.count == 0) return out;  // the writer stores an empty scene with codec none

    // Draco fixes the order; the codes of rotations, scales and opacities are computed in the source's order
    // meanwhile, then gathered into Draco's order and coded with SH, each section on its own thread.
    const SectionFlags reuse = reusable_sections(earlier, out, options);
    std::vector<uint64_t> order;       // Gaussian i of the archive is Gaussian order[i] of `source`
    std::array<SourceCodes, 4> codes;  // rotations, scales, opacities at slots 1..3
    RGS_RETURN_IF_ERROR(order_means_and_quantize(source, options, earlier, reuse, &out, &order, &codes));
    d.metadata.bounds = bounds_of(d.means);
    RGS_RETURN_IF_ERROR(code_sections(source, options, reuse, order, &codes, &out));
    RGS_RETURN_IF_ERROR(decode_sections(source, options, earlier, reuse, order, &out));
    out.source_index = std::move(order);
    return out;
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, "out of memory encoding " + dec(source.count) + " Gaussians");
  } catch (const std::length_error&) {
    return Status(StatusCode::kOutOfMemory, "out of memory encoding " + dec(source.count) + " Gaussians");
  }
}

}  // namespace rgs::format
