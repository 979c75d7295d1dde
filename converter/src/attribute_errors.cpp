// Per-attribute error metrics between a source cloud and its decoded version (audit, tests, CLI).
//
// Both entry points accumulate per fixed chunk of kChunkGaussians (chunks in parallel, each sequential in
// Gaussian order with double sums) and merge the chunks in order, so results depend on neither the thread
// count nor the entry point: measure_quantization_errors() equals measure_attribute_errors() on the
// dequantized scene bit for bit.
#include "rgs/converter/attribute_errors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <string>
#include <vector>

#include "internal_parallel.h"

namespace rgs::converter {

namespace {

constexpr uint64_t kChunkGaussians = 65536;
constexpr double kRadToDeg = 57.29577951308232;

/// Running max and sum of squares of one measure.
struct Accumulator {
  double max = 0;
  double sum_sq = 0;
  uint64_t samples = 0;

  void add(double e) {
    // NaN propagates into max (a NaN error must not look like a perfect match).
    if (!(e <= max)) max = e;
    sum_sq += e * e;
    ++samples;
  }
  void merge(const Accumulator& other) {
    if (!(other.max <= max)) max = other.max;
    sum_sq += other.sum_sq;
    samples += other.samples;
  }
  ErrorStats stats() const {
    ErrorStats s;
    s.max = max;
    s.samples = samples;
    s.rms = samples ? std::sqrt(sum_sq / static_cast<double>(samples)) : 0.0;
    return s;
  }
};

struct Accumulators {
  Accumulator position, rotation, scale, opacity;
  Accumulator sh[4];
  Accumulator sh_channel[4][3];

  void merge(const Accumulators& o) {
    position.merge(o.position);
    rotation.merge(o.rotation);
    scale.merge(o.scale);
    opacity.merge(o.opacity);
    for (int d = 0; d < 4; ++d) {
      sh[d].merge(o.sh[d]);
      for (int c = 0; c < 3; ++c) sh_channel[d][c].merge(o.sh_channel[d][c]);
    }
  }

  AttributeErrors result() const {
    AttributeErrors r;
    r.position = position.stats();
    r.rotation_deg = rotation.stats();
    r.scale_relative = scale.stats();
    r.opacity = opacity.stats();
    for (int d = 0; d < 4; ++d) {
      r.sh[d] = sh[d].stats();
      for (int c = 0; c < 3; ++c) r.sh_channel[d][c] = sh_channel[d][c].stats();
    }
    return r;
  }
};

/// Rotation angle in degrees between the orientations of two quaternions (normalized here).
double rotation_angle_deg(const float* q1f, const float* q2f) {
  double q1[4], q2[4];
  double n1 = 0, n2 = 0, dot = 0;
  for (int a = 0; a < 4; ++a) {
    q1[a] = q1f[a];
    q2[a] = q2f[a];
    n1 += q1[a] * q1[a];
    n2 += q2[a] * q2[a];
  }
  // A zero quaternion has no orientation: equal to another zero one, maximally far from anything else.
  if (n1 == 0 || n2 == 0) return n1 == n2 ? 0.0 : 180.0;
  n1 = 1.0 / std::sqrt(n1);
  n2 = 1.0 / std::sqrt(n2);
  for (int a = 0; a < 4; ++a) {
    q1[a] *= n1;
    q2[a] *= n2;
    dot += q1[a] * q2[a];
  }
  const double sign = dot < 0 ? -1.0 : 1.0;  // q and −q are the same rotation
  double diff = 0, sum = 0;
  for (int a = 0; a < 4; ++a) {
    const double b = sign * q2[a];
    diff += (q1[a] - b) * (q1[a] - b);
    sum += (q1[a] + b) * (q1[a] + b);
  }
  return 4.0 * std::atan2(std::sqrt(diff), std::sqrt(sum)) * kRadToDeg;
}

/// Adds Gaussians [test_first, test_first + count) of `test` compared with Gaussians [first, first + count)
/// of `ref`.
void accumulate(const format::GaussianCloud& ref, uint64_t first, const format::GaussianCloud& test,
                uint64_t test_first, uint64_t count, Accumulators* acc) {
  const uint32_t k_count = ref.sh_coefficients();
  for (uint64_t jj = 0; jj < count; ++jj) {
    const uint64_t i = first + jj;
    const uint64_t j = test_first + jj;
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = static_cast<double>(test.means[j * 3 + a]) - ref.means[i * 3 + a];
      d2 += d * d;
    }
    acc->position.add(std::sqrt(d2));
    acc->rotation.add(rotation_angle_deg(&ref.rotations[i * 4], &test.rotations[j * 4]));
    for (int a = 0; a < 3; ++a) {
      const double s = ref.scales[i * 3 + a];
      const double t = test.scales[j * 3 + a];
      acc->scale.add(t == s ? 0.0 : std::fabs(t - s) / s);
    }
    acc->opacity.add(std::fabs(static_cast<double>(test.opacities[j]) - ref.opacities[i]));
    for (uint32_t k = 0; k < k_count; ++k) {
      const uint32_t d = format::sh_degree_of_coefficient(k);
      for (uint32_t c = 0; c < 3; ++c) {
        const double e = std::fabs(static_cast<double>(test.sh[(j * k_count + k) * 3 + c]) -
                                   ref.sh[(i * k_count + k) * 3 + c]);
        acc->sh[d].add(e);
        acc->sh_channel[d][c].add(e);
      }
    }
  }
}

Status check_reference(const format::GaussianCloud& reference) {
  if (!reference.is_consistent()) {
    return Status(StatusCode::kInvalidArgument, "reference cloud arrays are inconsistent with " +
                                                    std::to_string(reference.size()) + " Gaussians at SH degree " +
                                                    std::to_string(reference.sh_degree));
  }
  return Status();
}

/// Runs `chunk_fn(first, count, &acc)` for every chunk of kChunkGaussians Gaussians of [0, n), chunks spread
/// over the available cores, and merges the per-chunk accumulators in chunk order. `chunk_fn` returns a
/// Status; the first error in chunk order is returned.
template <typename ChunkFn>
Result<AttributeErrors> accumulate_chunks(uint64_t n, ChunkFn&& chunk_fn) {
  const uint64_t chunks = (n + kChunkGaussians - 1) / kChunkGaussians;
  std::vector<Accumulators> partial(chunks);
  std::vector<Status> status(chunks);
  detail::parallel_slices(chunks, detail::worker_count(chunks, 1), [&](unsigned, uint64_t begin, uint64_t end) {
    for (uint64_t c = begin; c < end; ++c) {
      const uint64_t first = c * kChunkGaussians;
      status[c] = chunk_fn(first, std::min(kChunkGaussians, n - first), &partial[c]);
    }
  });
  Accumulators total;
  for (uint64_t c = 0; c < chunks; ++c) {
    RGS_RETURN_IF_ERROR(status[c]);
    total.merge(partial[c]);
  }
  return total.result();
}

}  // namespace

Result<AttributeErrors> measure_attribute_errors(const format::GaussianCloud& reference,
                                                 const format::GaussianCloud& test) {
  RGS_RETURN_IF_ERROR(check_reference(reference));
  if (!test.is_consistent()) {
    return Status(StatusCode::kInvalidArgument, "test cloud arrays are inconsistent with " +
                                                    std::to_string(test.size()) + " Gaussians at SH degree " +
                                                    std::to_string(test.sh_degree));
  }
  if (reference.size() != test.size() || reference.sh_degree != test.sh_degree) {
    return Status(StatusCode::kInvalidArgument,
                  "cannot compare " + std::to_string(reference.size()) + " Gaussians at SH degree " +
                      std::to_string(reference.sh_degree) + " with " + std::to_string(test.size()) +
                      " at SH degree " + std::to_string(test.sh_degree));
  }
  try {
    return accumulate_chunks(test.size(), [&](uint64_t first, uint64_t count, Accumulators* acc) {
      accumulate(reference, first, test, first, count, acc);
      return Status();
    });
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, "out of memory measuring attribute errors");
  }
}

Result<AttributeErrors> measure_quantization_errors(const format::GaussianCloud& reference,
                                                    const format::EncodedScene& encoded) {
  RGS_RETURN_IF_ERROR(check_reference(reference));
  if (reference.size() != encoded.count || reference.sh_degree != encoded.metadata.sh_degree) {
    return Status(StatusCode::kInvalidArgument,
                  "cannot compare " + std::to_string(reference.size()) + " Gaussians at SH degree " +
                      std::to_string(reference.sh_degree) + " with an encoded scene of " +
                      std::to_string(encoded.count) + " at SH degree " + std::to_string(encoded.metadata.sh_degree));
  }
  try {
    return accumulate_chunks(encoded.count, [&](uint64_t first, uint64_t count, Accumulators* acc) {
      try {
        format::GaussianCloud chunk;  // one chunk per call: a worker holds at most one at a time
        RGS_RETURN_IF_ERROR(format::dequantize_range(encoded, first, count, &chunk));
        accumulate(reference, first, chunk, 0, count, acc);
        return Status();
      } catch (const std::bad_alloc&) {
        return Status(StatusCode::kOutOfMemory, "out of memory dequantizing a chunk for error measurement");
      }
    });
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, "out of memory measuring quantization errors");
  }
}

}  // namespace rgs::converter
