#include "internal_kmeans.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "internal_parallel.h"

namespace rgs::converter::detail {

namespace {

constexpr uint32_t kHistogramBins = 65536;
/// Vectors per parallel block: blocks, not threads, fix how sums are grouped (determinism).
constexpr size_t kBlockVectors = 16384;
/// Training samples per centroid at each level of the palette tree.
constexpr size_t kSamplesPerCentroid = 16;

}  // namespace

std::vector<float> kmeans_codebook(const float* values, size_t n, uint32_t k, uint32_t iterations) {
  std::vector<float> codebook(k, 0.0f);
  if (n == 0 || k == 0) return codebook;
  float lo = values[0], hi = values[0];
  for (size_t i = 1; i < n; ++i) {
    lo = std::min(lo, values[i]);
    hi = std::max(hi, values[i]);
  }
  if (!(hi > lo)) {
    std::fill(codebook.begin(), codebook.end(), lo);
    return codebook;
  }
  std::vector<double> count(kHistogramBins, 0.0), sum(kHistogramBins, 0.0);
  const double bin_scale = (kHistogramBins - 1) / (static_cast<double>(hi) - lo);
  for (size_t i = 0; i < n; ++i) {
    const auto b = static_cast<uint32_t>((static_cast<double>(values[i]) - lo) * bin_scale);
    count[b] += 1;
    sum[b] += values[i];
  }
  std::vector<double> bins, weight;  // the occupied bins' means and counts, ascending
  for (uint32_t b = 0; b < kHistogramBins; ++b) {
    if (count[b] > 0) {
      bins.push_back(sum[b] / count[b]);
      weight.push_back(count[b]);
    }
  }
  // Half the starts at quantiles (where the values are dense), half spread evenly over the range, so that sparse
  // tails (the few huge background Gaussians of a capture) keep codes of their own: Lloyd's iterations alone
  // never move a centre far into a tail that quantile starts left empty.
  std::vector<double> centre(k);
  const uint32_t quantile_starts = k - k / 2;
  double seen = 0;
  size_t at = 0;
  for (uint32_t j = 0; j < quantile_starts; ++j) {
    const double target = (j + 0.5) * static_cast<double>(n) / quantile_starts;
    while (at + 1 < bins.size() && seen + weight[at] < target) seen += weight[at++];
    centre[j] = bins[at];
  }
  for (uint32_t j = quantile_starts; j < k; ++j) {
    const double unit = k / 2 > 1 ? static_cast<double>(j - quantile_starts) / (k / 2 - 1) : 0.5;
    centre[j] = lo + unit * (static_cast<double>(hi) - lo);
  }
  std::sort(centre.begin(), centre.end());
  std::vector<double> csum(k), ccount(k);
  for (uint32_t it = 0; it < iterations; ++it) {
    std::fill(csum.begin(), csum.end(), 0.0);
    std::fill(ccount.begin(), ccount.end(), 0.0);
    uint32_t j = 0;
    for (size_t b = 0; b < bins.size(); ++b) {  // centres ascending: the nearest moves right only
      while (j + 1 < k && std::fabs(centre[j + 1] - bins[b]) < std::fabs(centre[j] - bins[b])) ++j;
      csum[j] += bins[b] * weight[b];
      ccount[j] += weight[b];
    }
    for (uint32_t c = 0; c < k; ++c) {
      if (ccount[c] > 0) centre[c] = csum[c] / ccount[c];
    }
    std::sort(centre.begin(), centre.end());
  }
  for (uint32_t c = 0; c < k; ++c) codebook[c] = static_cast<float>(centre[c]);
  std::sort(codebook.begin(), codebook.end());
  return codebook;
}

uint8_t nearest_code(const std::vector<float>& codebook, float v) {
  const auto it = std::lower_bound(codebook.begin(), codebook.end(), v);
  if (it == codebook.begin()) return 0;
  if (it == codebook.end()) return static_cast<uint8_t>(codebook.size() - 1);
  const size_t hi = static_cast<size_t>(it - codebook.begin());
  return static_cast<uint8_t>(v - codebook[hi - 1] <= *it - v ? hi - 1 : hi);
}

namespace {

/// Vectors of one k-means problem: indices into the data, dim floats each.
struct VectorSet {
  const float* data;
  size_t stride;
  uint32_t dim;
  const float* at(size_t i) const { return data + i * stride; }
};

uint32_t nearest_centroid(const float* v, const float* centroids, uint32_t k, uint32_t dim) {
  uint32_t best = 0;
  float best_d = std::numeric_limits<float>::infinity();
  for (uint32_t c = 0; c < k; ++c) {
    const float* q = centroids + size_t{c} * dim;
    float d = 0;
    for (uint32_t e = 0; e < dim; ++e) {
      const float t = v[e] - q[e];
      d += t * t;
    }
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

/// Lloyd's k-means of the vectors `members` (indices) into `k` centroids, started from evenly spaced members.
/// Sums are kept per block of members and added in block order, so the result does not depend on threads.
Status lloyd(const VectorSet& set, const std::vector<size_t>& members, uint32_t k, uint32_t iterations,
             unsigned workers, std::vector<float>* centroids) {
  const uint32_t dim = set.dim;
  centroids->assign(size_t{k} * dim, 0.0f);
  for (uint32_t c = 0; c < k; ++c) {
    const float* v = set.at(members[static_cast<size_t>(uint64_t{c} * members.size() / k)]);
    std::copy(v, v + dim, centroids->data() + size_t{c} * dim);
  }
  const size_t blocks = (members.size() + kBlockVectors - 1) / kBlockVectors;
  std::vector<std::vector<double>> sums(blocks);
  std::vector<std::vector<uint32_t>> counts(blocks);
  for (uint32_t it = 0; it < iterations; ++it) {
    RGS_RETURN_IF_ERROR(parallel_items(blocks, workers, [&](unsigned, uint64_t b) {
      sums[b].assign(size_t{k} * dim, 0.0);
      counts[b].assign(k, 0);
      const size_t end = std::min(members.size(), (b + 1) * kBlockVectors);
      for (size_t m = b * kBlockVectors; m < end; ++m) {
        const float* v = set.at(members[m]);
        const uint32_t c = nearest_centroid(v, centroids->data(), k, dim);
        for (uint32_t e = 0; e < dim; ++e) sums[b][size_t{c} * dim + e] += v[e];
        ++counts[b][c];
      }
    }));
    for (uint32_t c = 0; c < k; ++c) {
      double total = 0;
      for (size_t b = 0; b < blocks; ++b) total += counts[b][c];
      if (total == 0) continue;
      for (uint32_t e = 0; e < dim; ++e) {
        double s = 0;
        for (size_t b = 0; b < blocks; ++b) s += sums[b][size_t{c} * dim + e];
        (*centroids)[size_t{c} * dim + e] = static_cast<float>(s / total);
      }
    }
  }
  return Status();
}

/// Evenly spaced picks of at most `limit` of `members`.
std::vector<size_t> sample(const std::vector<size_t>& members, size_t limit) {
  if (members.size() <= limit) return members;
  std::vector<size_t> out(limit);
  for (size_t i = 0; i < limit; ++i) out[i] = members[static_cast<size_t>(uint64_t{i} * members.size() / limit)];
  return out;
}

}  // namespace

Status kmeans_palette(const float* data, size_t n, size_t stride, uint32_t dim, uint32_t k, uint32_t iterations,
                      std::vector<float>* palette, std::vector<uint32_t>* labels) {
  const VectorSet set{data, stride, dim};
  k = static_cast<uint32_t>(std::min<size_t>(k, n));
  labels->assign(n, 0);
  palette->clear();
  if (n == 0 || k == 0) return Status();
  const unsigned workers = worker_count(n, kBlockVectors);
  const auto coarse_k = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(k))));
  std::vector<size_t> all(n);
  for (size_t i = 0; i < n; ++i) all[i] = i;
  std::vector<float> coarse;
  RGS_RETURN_IF_ERROR(lloyd(set, sample(all, size_t{coarse_k} * kSamplesPerCentroid * 4), coarse_k, iterations,
                            workers, &coarse));
  std::vector<uint32_t> coarse_of(n);
  RGS_RETURN_IF_ERROR(parallel_slices(n, workers, [&](unsigned, uint64_t begin, uint64_t end) {
    for (uint64_t i = begin; i < end; ++i) coarse_of[i] = nearest_centroid(set.at(i), coarse.data(), coarse_k, dim);
  }));
  std::vector<std::vector<size_t>> members(coarse_k);
  for (size_t i = 0; i < n; ++i) members[coarse_of[i]].push_back(i);
  // Fine clusters per coarse one, in proportion to its members (at least one each non-empty one).
  std::vector<uint32_t> first(coarse_k + 1, 0), fine_k(coarse_k, 0);
  for (uint32_t c = 0; c < coarse_k; ++c) {
    if (members[c].empty()) continue;
    const double share = static_cast<double>(k - coarse_k) * static_cast<double>(members[c].size()) / static_cast<double>(n);
    fine_k[c] = static_cast<uint32_t>(std::min<size_t>(members[c].size(), 1 + static_cast<size_t>(share)));
  }
  for (uint32_t c = 0; c < coarse_k; ++c) first[c + 1] = first[c] + fine_k[c];
  palette->assign(size_t{first[coarse_k]} * dim, 0.0f);
  for (uint32_t c = 0; c < coarse_k; ++c) {
    if (fine_k[c] == 0) continue;
    std::vector<float> fine;
    RGS_RETURN_IF_ERROR(lloyd(set, sample(members[c], size_t{fine_k[c]} * kSamplesPerCentroid), fine_k[c],
                              iterations, workers, &fine));
    std::copy(fine.begin(), fine.end(), palette->begin() + size_t{first[c]} * dim);
  }
  return parallel_slices(n, workers, [&](unsigned, uint64_t begin, uint64_t end) {
    for (uint64_t i = begin; i < end; ++i) {
      const uint32_t c = coarse_of[i];
      (*labels)[i] = first[c] + nearest_centroid(set.at(i), palette->data() + size_t{first[c]} * dim, fine_k[c], dim);
    }
  });
}

}  // namespace rgs::converter::detail
