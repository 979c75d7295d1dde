#include "internal_kmeans.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "../internal_parallel.h"

namespace rgs::converter::detail {

namespace {

constexpr uint32_t kHistogramBins = 65536;
/// Fewest vectors worth a thread of their own in the palette's passes.
constexpr size_t kMinVectorsPerWorker = 1024;
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

/// The distinct vectors of one k-means problem, dim floats each: duplicates (every SH-0 Gaussian of a merge
/// holds the zero vector) are one weighted vector, so they neither crowd the samples and starts nor claim palette
/// entries of their own, which made training quadratic in the duplicates.
struct VectorSet {
  const float* data;
  size_t stride;
  uint32_t dim;
  std::vector<size_t> index;     ///< each distinct vector's first holder, ascending
  std::vector<double> weight;    ///< how many vectors equal it
  const float* at(size_t m) const { return data + index[m] * stride; }
};

/// `data`'s distinct vectors into `set`, and `of[i]`, vector i's distinct one: equal bytes sort next to each
/// other (by a hash, then the bytes, then the index).
void find_distinct(size_t n, VectorSet* set, std::vector<uint32_t>* of) {
  const size_t bytes = size_t{set->dim} * sizeof(float);
  auto row = [&](size_t i) { return set->data + i * set->stride; };
  std::vector<std::pair<uint64_t, uint32_t>> keys(n);
  for (size_t i = 0; i < n; ++i) {
    uint64_t h = 14695981039346656037ull;  // FNV-1a over 32-bit words
    for (uint32_t e = 0; e < set->dim; ++e) {
      uint32_t w;
      std::memcpy(&w, row(i) + e, sizeof w);
      h = (h ^ w) * 1099511628211ull;
    }
    keys[i] = {h, static_cast<uint32_t>(i)};
  }
  std::sort(keys.begin(), keys.end(), [&](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    const int c = std::memcmp(row(a.second), row(b.second), bytes);
    return c != 0 ? c < 0 : a.second < b.second;
  });
  std::vector<uint32_t> first(n);  // the first holder of each vector's value
  for (size_t s = 0; s < n; ++s) {
    const uint32_t i = keys[s].second, p = s > 0 ? keys[s - 1].second : i;
    first[i] = s > 0 && keys[s].first == keys[s - 1].first && !std::memcmp(row(i), row(p), bytes) ? first[p] : i;
  }
  of->resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (first[i] == i) {
      set->index.push_back(i);
      set->weight.push_back(0);
    }
    (*of)[i] = first[i] == i ? static_cast<uint32_t>(set->index.size() - 1) : (*of)[first[i]];
    set->weight[(*of)[i]] += 1;
  }
}

/// `k` centroids of `dim` floats stored dimension-major, so that the distances to all of them grow in lockstep:
/// that loop vectorizes, where one distance at a time waits on its own chain of additions.
struct Centroids {
  uint32_t k, dim;
  std::vector<float> t;  ///< [dim, k]
  Centroids(const float* rows, uint32_t k_, uint32_t dim_) : k(k_), dim(dim_), t(size_t{k_} * dim_) {
    for (uint32_t c = 0; c < k; ++c) {
      for (uint32_t e = 0; e < dim; ++e) t[size_t{e} * k + c] = rows[size_t{c} * dim + e];
    }
  }
  /// The nearest centroid to `v` (ties to the first); `d` is scratch.
  uint32_t nearest(const float* v, std::vector<float>* d) const {
    d->assign(k, 0.0f);
    float* dist = d->data();
    auto sq = [](float a) { return a * a; };
    uint32_t e = 0;
    for (; e + 4 <= dim; e += 4) {  // four dimensions a pass: a quarter of the loads and stores of `dist`
      const float *q = t.data() + size_t{e} * k, *r = q + k, *s = r + k, *u = s + k;
      for (uint32_t c = 0; c < k; ++c) {
        dist[c] = dist[c] + sq(v[e] - q[c]) + sq(v[e + 1] - r[c]) + sq(v[e + 2] - s[c]) + sq(v[e + 3] - u[c]);
      }
    }
    for (; e < dim; ++e) {
      const float* q = t.data() + size_t{e} * k;
      for (uint32_t c = 0; c < k; ++c) dist[c] += sq(v[e] - q[c]);
    }
    return static_cast<uint32_t>(std::min_element(dist, dist + k) - dist);
  }
};

/// Lloyd's k-means of the vectors `members` (distinct ids) into `k` centroids ([k, dim]), started from evenly
/// spaced members; it stops early once no member changes its centroid (the later ones would be the same).
std::vector<float> lloyd(const VectorSet& set, const std::vector<size_t>& members, uint32_t k, uint32_t iterations) {
  const uint32_t dim = set.dim;
  std::vector<float> centroids(size_t{k} * dim), scratch;
  for (uint32_t c = 0; c < k; ++c) {
    const float* v = set.at(members[static_cast<size_t>(uint64_t{c} * members.size() / k)]);
    std::copy(v, v + dim, centroids.data() + size_t{c} * dim);
  }
  std::vector<uint32_t> assigned(members.size(), k);
  std::vector<double> sums, counts;
  for (uint32_t it = 0; it < iterations; ++it) {
    const Centroids near(centroids.data(), k, dim);
    sums.assign(size_t{k} * dim, 0.0);
    counts.assign(k, 0.0);
    bool changed = false;
    for (size_t m = 0; m < members.size(); ++m) {
      const float* v = set.at(members[m]);
      const uint32_t c = near.nearest(v, &scratch);
      changed |= c != assigned[m];
      assigned[m] = c;
      for (uint32_t e = 0; e < dim; ++e) sums[size_t{c} * dim + e] += set.weight[members[m]] * v[e];
      counts[c] += set.weight[members[m]];
    }
    if (!changed) break;
    for (uint32_t c = 0; c < k; ++c) {
      for (uint32_t e = 0; e < dim && counts[c] > 0; ++e) {
        centroids[size_t{c} * dim + e] = static_cast<float>(sums[size_t{c} * dim + e] / counts[c]);
      }
    }
  }
  return centroids;
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
  VectorSet set{data, stride, dim, {}, {}};
  std::vector<uint32_t> of;
  find_distinct(n, &set, &of);
  const size_t m = set.index.size();
  k = static_cast<uint32_t>(std::min<size_t>(k, m));
  labels->assign(n, 0);
  palette->clear();
  if (m == 0 || k == 0) return Status();
  if (k == m) {  // room for every distinct vector: the palette is exact
    for (size_t i = 0; i < m; ++i) palette->insert(palette->end(), set.at(i), set.at(i) + dim);
    *labels = std::move(of);
    return Status();
  }
  const unsigned workers = worker_count(m, kMinVectorsPerWorker);
  const auto coarse_k = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(k))));
  std::vector<size_t> all(m);
  for (size_t i = 0; i < m; ++i) all[i] = i;
  const std::vector<float> coarse =
      lloyd(set, sample(all, size_t{coarse_k} * kSamplesPerCentroid * 4), coarse_k, iterations);
  const Centroids coarse_near(coarse.data(), coarse_k, dim);
  std::vector<uint32_t> coarse_of(m);
  RGS_RETURN_IF_ERROR(parallel_slices(m, workers, [&](unsigned, uint64_t begin, uint64_t end) {
    std::vector<float> scratch;
    for (uint64_t i = begin; i < end; ++i) coarse_of[i] = coarse_near.nearest(set.at(i), &scratch);
  }));
  std::vector<std::vector<size_t>> members(coarse_k);
  for (size_t i = 0; i < m; ++i) members[coarse_of[i]].push_back(i);
  // Fine clusters per coarse one (at least one each non-empty one), in proportion to the Gaussians it holds (the
  // palette's error counts per Gaussian) but at most its distinct vectors: clusters of the fewest distinct vectors
  // per Gaussian go first, and what they cannot use goes to the others.
  std::vector<double> held(coarse_k, 0.0);
  for (size_t i = 0; i < m; ++i) held[coarse_of[i]] += set.weight[i];
  std::vector<std::pair<double, uint32_t>> order(coarse_k);  // (distinct per Gaussian, cluster), empty ones last
  for (uint32_t c = 0; c < coarse_k; ++c) {
    const double density = static_cast<double>(members[c].size()) / held[c];
    order[c] = {held[c] > 0 ? density : std::numeric_limits<double>::infinity(), c};
  }
  std::sort(order.begin(), order.end());
  std::vector<uint32_t> first(coarse_k + 1, 0), fine_k(coarse_k, 0);
  double spare = k - coarse_k, unserved = static_cast<double>(n);
  for (const auto& [density, c] : order) {
    if (members[c].empty()) continue;
    const auto share = static_cast<size_t>(spare * held[c] / unserved);
    fine_k[c] = static_cast<uint32_t>(std::min<size_t>(members[c].size(), 1 + share));
    spare -= fine_k[c] - 1;
    unserved -= held[c];
  }
  for (uint32_t c = 0; c < coarse_k; ++c) first[c + 1] = first[c] + fine_k[c];
  palette->assign(size_t{first[coarse_k]} * dim, 0.0f);
  RGS_RETURN_IF_ERROR(parallel_items(coarse_k, workers, [&](unsigned, uint64_t c) {  // one thread a cluster
    if (fine_k[c] == 0) return;
    const std::vector<float> fine =
        lloyd(set, sample(members[c], size_t{fine_k[c]} * kSamplesPerCentroid), fine_k[c], iterations);
    std::copy(fine.begin(), fine.end(), palette->begin() + size_t{first[c]} * dim);
  }));
  std::vector<Centroids> fine_near;
  for (uint32_t c = 0; c < coarse_k; ++c) {
    fine_near.emplace_back(palette->data() + size_t{first[c]} * dim, fine_k[c], dim);
  }
  std::vector<uint32_t> label(m);
  RGS_RETURN_IF_ERROR(parallel_slices(m, workers, [&](unsigned, uint64_t begin, uint64_t end) {
    std::vector<float> scratch;
    for (uint64_t i = begin; i < end; ++i) {
      label[i] = first[coarse_of[i]] + fine_near[coarse_of[i]].nearest(set.at(i), &scratch);
    }
  }));
  for (size_t i = 0; i < n; ++i) (*labels)[i] = label[of[i]];
  return Status();
}

}  // namespace rgs::converter::detail
