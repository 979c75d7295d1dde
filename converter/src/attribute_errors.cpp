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
#include <string>
#include <vector>

#include "internal_error_accumulators.h"
#include "internal_parallel.h"

namespace rgs::converter {

namespace {

using detail::Accumulators;
using detail::GaussianView;
constexpr uint64_t kChunkGaussians = detail::kErrorChunkGaussians;

/// Adds Gaussians [test_first, test_first + count) of `test` compared with Gaussians [first, first + count)
/// of `ref`.
void accumulate(const format::GaussianCloud& ref, uint64_t first, const format::GaussianCloud& test,
                uint64_t test_first, uint64_t count, Accumulators* acc) {
  const uint32_t k_count = ref.sh_coefficients();
  for (uint64_t jj = 0; jj < count; ++jj) {
    const uint64_t i = first + jj;
    const uint64_t j = test_first + jj;
    const GaussianView r{&ref.means[i * 3], &ref.rotations[i * 4], &ref.scales[i * 3], ref.opacities[i],
                         &ref.sh[i * k_count * 3]};
    const GaussianView t{&test.means[j * 3], &test.rotations[j * 4], &test.scales[j * 3], test.opacities[j],
                         &test.sh[j * k_count * 3]};
    detail::accumulate_gaussian(r, t, k_count, acc);
  }
}

/// Runs `chunk_fn(first, count, &acc)` for every chunk of kChunkGaussians Gaussians of [0, n), chunks spread
/// over the available cores, and merges the per-chunk accumulators in chunk order. `chunk_fn` returns a
/// Status; the first error in chunk order is returned.
template <typename ChunkFn>
Result<AttributeErrors> accumulate_chunks(uint64_t n, ChunkFn&& chunk_fn) {
  const uint64_t chunks = (n + kChunkGaussians - 1) / kChunkGaussians;
  std::vector<Accumulators> partial(chunks);
  std::vector<Status> status(chunks);
  RGS_RETURN_IF_ERROR(
      detail::parallel_slices(chunks, detail::worker_count(chunks, 1), [&](unsigned, uint64_t begin, uint64_t end) {
        for (uint64_t c = begin; c < end; ++c) {
          const uint64_t first = c * kChunkGaussians;
          status[c] = chunk_fn(first, std::min(kChunkGaussians, n - first), &partial[c]);
        }
      }));
  Accumulators total;
  for (uint64_t c = 0; c < chunks; ++c) {
    RGS_RETURN_IF_ERROR(status[c]);
    total.merge(partial[c]);
  }
  return total.result();
}

/// kInvalidArgument "cannot compare N Gaussians at SH degree D with <what>M at SH degree E<tail>": the clouds'
/// sizes or degrees disagree.
Status cannot_compare(const format::GaussianCloud& reference, const std::string& what, uint64_t n, uint32_t degree,
                      const std::string& tail = "") {
  return Status(StatusCode::kInvalidArgument, "cannot compare " + std::to_string(reference.size()) +
                                                  " Gaussians at SH degree " + std::to_string(reference.sh_degree) +
                                                  " with " + what + std::to_string(n) + " at SH degree " +
                                                  std::to_string(degree) + tail);
}

}  // namespace

Result<AttributeErrors> measure_attribute_errors(const format::GaussianCloud& reference,
                                                 const format::GaussianCloud& test) {
  RGS_RETURN_IF_ERROR(detail::check_consistent(reference, "reference cloud"));
  RGS_RETURN_IF_ERROR(detail::check_consistent(test, "test cloud"));
  if (reference.size() != test.size() || reference.sh_degree != test.sh_degree) {
    return cannot_compare(reference, "", test.size(), test.sh_degree);
  }
  return catch_bad_alloc([&] {
    return accumulate_chunks(test.size(), [&](uint64_t first, uint64_t count, Accumulators* acc) {
      accumulate(reference, first, test, first, count, acc);
      return Status();
    });
  }, [] { return "out of memory measuring attribute errors"; });
}

Result<AttributeErrors> measure_paired_attribute_errors(const format::GaussianCloud& reference,
                                                        const format::GaussianCloud& test,
                                                        const std::vector<uint64_t>& reference_of_test) {
  RGS_RETURN_IF_ERROR(detail::check_consistent(reference, "reference cloud"));
  RGS_RETURN_IF_ERROR(detail::check_consistent(test, "test cloud"));
  if (reference.sh_degree != test.sh_degree || reference_of_test.size() != test.size()) {
    return cannot_compare(reference, "", test.size(), test.sh_degree,
                          " paired by " + std::to_string(reference_of_test.size()) + " indices");
  }
  constexpr uint64_t kUnpaired = std::numeric_limits<uint64_t>::max();
  return catch_bad_alloc([&]() -> Result<AttributeErrors> {
    std::vector<uint64_t> test_of_reference(reference.size(), kUnpaired);
    for (uint64_t j = 0; j < test.size(); ++j) {
      const uint64_t i = reference_of_test[j];
      const bool beyond = i >= reference.size();
      RGS_RETURN_ERROR_IF(beyond || test_of_reference[i] != kUnpaired, StatusCode::kInvalidArgument,
                          "test Gaussian " + std::to_string(j) + " is paired with reference Gaussian " +
                              std::to_string(i) + ", which is " +
                              (beyond ? "out of range (" + std::to_string(reference.size()) + ")"
                                      : "paired with test Gaussian " + std::to_string(test_of_reference[i])));
      test_of_reference[i] = j;
    }
    return accumulate_chunks(reference.size(), [&](uint64_t first, uint64_t count, Accumulators* acc) {
      for (uint64_t i = first; i < first + count; ++i) {
        if (test_of_reference[i] != kUnpaired) accumulate(reference, i, test, test_of_reference[i], 1, acc);
      }
      return Status();
    });
  }, [] { return "out of memory measuring paired attribute errors"; });
}

Result<AttributeErrors> measure_quantization_errors(const format::GaussianCloud& reference,
                                                    const format::EncodedScene& encoded) {
  RGS_RETURN_IF_ERROR(detail::check_consistent(reference, "reference cloud"));
  if (reference.size() != encoded.count || reference.sh_degree != encoded.metadata.sh_degree) {
    return cannot_compare(reference, "an encoded scene of ", encoded.count, encoded.metadata.sh_degree);
  }
  return catch_bad_alloc([&] {
    return accumulate_chunks(encoded.count, [&](uint64_t first, uint64_t count, Accumulators* acc) {
      return catch_bad_alloc([&]() -> Status {
        format::GaussianCloud chunk;  // one chunk per call: a worker holds at most one at a time
        RGS_RETURN_IF_ERROR(format::dequantize_range(encoded, first, count, &chunk));
        accumulate(reference, first, chunk, 0, count, acc);
        return Status();
      }, [] { return "out of memory dequantizing a chunk for error measurement"; });
    });
  }, [] { return "out of memory measuring quantization errors"; });
}

}  // namespace rgs::converter
