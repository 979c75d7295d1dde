// Pairing of two versions of one scene Gaussian by Gaussian (gaussian_pairing.h): a k-d tree over the reference
// means, the nearest neighbours of each test mean, and a stable matching of the preferences they give.
#include "rgs/converter/gaussian_pairing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "../internal_error_accumulators.h"
#include "../internal_parallel.h"

namespace rgs::converter {

namespace {

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
/// Most points a k-d tree leaf holds (scanned in full).
constexpr uint32_t kLeafPoints = 8;
/// Weight of the attributes against the position in the combined distance: where the position error exceeds the
/// spacing of the Gaussians, a position inside the writer's quantization cell says little, and the attributes tell
/// a Gaussian from a neighbour the conversion left out (docs/AUDITS.md#how-gaussians-are-paired).
constexpr double kPairingAttributeWeight = 10;
/// SH DC coefficient to colour: Y_0^0.
constexpr double kShC0 = 0.28209479177387814;

/// A reference Gaussian found near a test mean: its index and squared distance, or its combined distance.
struct Neighbour {
  double key;
  uint32_t index;
  bool operator<(const Neighbour& o) const { return key < o.key || (key == o.key && index < o.index); }
};

/// Static k-d tree over [N, 3] float means: the points permuted, split at the middle of each range along the
/// widest axis of the range's box, down to ranges of kLeafPoints. A range [lo, hi) splits at
/// mid = lo + (hi − lo) / 2 along axis_[mid] at split_[mid]: the lower half's coordinates on that axis are ≤ it,
/// the upper half's ≥ (the point that was at mid when it split, since moved by the upper half's own splits).
class MeanTree {
 public:
  /// The tree of `means`; the ranges below the top kParallelLevels levels are split on `workers` threads. The
  /// tree does not depend on the thread count.
  static Result<MeanTree> build(const std::vector<float>& means, unsigned workers) {
    MeanTree tree;
    const auto count = static_cast<uint32_t>(means.size() / 3);
    tree.points_.resize(count);
    for (uint32_t i = 0; i < count; ++i) {
      tree.points_[i] = Point{{means[size_t(i) * 3], means[size_t(i) * 3 + 1], means[size_t(i) * 3 + 2]}, i};
    }
    tree.axis_.assign(count, 0);
    tree.split_.assign(count, 0.f);
    std::vector<std::pair<uint32_t, uint32_t>> ranges;
    tree.split_top(0, count, kParallelLevels, &ranges);
    RGS_RETURN_IF_ERROR(detail::parallel_items(ranges.size(), workers, [&](unsigned, uint64_t r) {
      tree.split_range(ranges[r].first, ranges[r].second);
    }));
    return tree;
  }

  /// The `k` points nearest to `q` within squared distance `r2`, by (squared distance, index), ascending, in
  /// `out` (keys: squared distances).
  void nearest(const double q[3], double r2, uint32_t k, std::vector<Neighbour>* out) const {
    out->clear();
    if (!points_.empty() && k > 0) search(0, static_cast<uint32_t>(points_.size()), q, r2, k, out);
    std::sort_heap(out->begin(), out->end());
  }

 private:
  /// Levels split on the calling thread before the ranges below them are split in parallel.
  static constexpr uint32_t kParallelLevels = 5;

  struct Point {
    float p[3];
    uint32_t index;  ///< the reference Gaussian
  };

  /// Splits [lo, hi) once: its axis and split value recorded at the middle, which it returns.
  uint32_t split_once(uint32_t lo, uint32_t hi) {
    float box_lo[3], box_hi[3];
    for (int a = 0; a < 3; ++a) box_lo[a] = box_hi[a] = points_[lo].p[a];
    for (uint32_t i = lo + 1; i < hi; ++i) {
      for (int a = 0; a < 3; ++a) {
        box_lo[a] = std::min(box_lo[a], points_[i].p[a]);
        box_hi[a] = std::max(box_hi[a], points_[i].p[a]);
      }
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a) {
      if (double(box_hi[a]) - box_lo[a] > double(box_hi[axis]) - box_lo[axis]) axis = a;
    }
    const uint32_t mid = lo + (hi - lo) / 2;
    // (coordinate, index): the same tree whatever the standard library's nth_element does with equal keys.
    std::nth_element(points_.begin() + lo, points_.begin() + mid, points_.begin() + hi,
                     [axis](const Point& x, const Point& y) {
                       return x.p[axis] < y.p[axis] || (x.p[axis] == y.p[axis] && x.index < y.index);
                     });
    axis_[mid] = static_cast<uint8_t>(axis);
    split_[mid] = points_[mid].p[axis];
    return mid;
  }

  /// Splits [lo, hi) for `levels` levels, then adds the ranges left to `ranges`.
  void split_top(uint32_t lo, uint32_t hi, uint32_t levels, std::vector<std::pair<uint32_t, uint32_t>>* ranges) {
    if (levels == 0 || hi - lo <= kLeafPoints) {
      ranges->emplace_back(lo, hi);
      return;
    }
    const uint32_t mid = split_once(lo, hi);
    split_top(lo, mid, levels - 1, ranges);
    split_top(mid, hi, levels - 1, ranges);
  }

  /// Splits [lo, hi) down to its leaves.
  void split_range(uint32_t lo, uint32_t hi) {
    while (hi - lo > kLeafPoints) {
      const uint32_t mid = split_once(lo, hi);
      split_range(lo, mid);
      lo = mid;
    }
  }

  /// Adds the points of [lo, hi) that belong among the k nearest to the max-heap `heap`.
  void search(uint32_t lo, uint32_t hi, const double q[3], double r2, uint32_t k, std::vector<Neighbour>* heap) const {
    auto bound = [&] { return heap->size() < k ? r2 : std::min(r2, heap->front().key); };
    if (hi - lo <= kLeafPoints) {
      for (uint32_t i = lo; i < hi; ++i) {
        double d2 = 0;
        for (int a = 0; a < 3; ++a) {
          const double d = q[a] - points_[i].p[a];
          d2 += d * d;
        }
        if (d2 > r2) continue;
        const Neighbour n{d2, points_[i].index};
        if (heap->size() < k) {
          heap->push_back(n);
          std::push_heap(heap->begin(), heap->end());
        } else if (n < heap->front()) {
          std::pop_heap(heap->begin(), heap->end());
          heap->back() = n;
          std::push_heap(heap->begin(), heap->end());
        }
      }
      return;
    }
    const uint32_t mid = lo + (hi - lo) / 2;
    const int axis = axis_[mid];
    const double diff = q[axis] - split_[mid];
    // Non-strict comparisons: a point at exactly the bound may still win on its index.
    if (diff < 0) {
      search(lo, mid, q, r2, k, heap);
      if (diff * diff <= bound()) search(mid, hi, q, r2, k, heap);
    } else {
      search(mid, hi, q, r2, k, heap);
      if (diff * diff <= bound()) search(lo, mid, q, r2, k, heap);
    }
  }

  std::vector<Point> points_;  ///< the means in tree order, with their reference index
  std::vector<uint8_t> axis_;  ///< split axis of the range whose middle is this position
  std::vector<float> split_;   ///< its split coordinate
};

/// Combined distance of gaussian_pairing.h between reference Gaussian r and test Gaussian t, `d2` their squared
/// distance and `inv_tol2` 1 / τ² (0 when τ = 0: every candidate then lies at distance 0).
double combined_distance(const format::GaussianCloud& ref, uint32_t r, const format::GaussianCloud& test, uint32_t t,
                         double d2, double inv_tol2) {
  const float* qr = &ref.rotations[size_t(r) * 4];
  const float* qt = &test.rotations[size_t(t) * 4];
  double dot = 0, nr = 0, nt = 0;
  for (int a = 0; a < 4; ++a) {
    dot += double(qr[a]) * qt[a];
    nr += double(qr[a]) * qr[a];
    nt += double(qt[a]) * qt[a];
  }
  const double cos2 = (nr > 0 && nt > 0) ? dot * dot / (nr * nt) : (nr == nt ? 1.0 : 0.0);
  const float* sr = &ref.scales[size_t(r) * 3];
  const float* st = &test.scales[size_t(t) * 3];
  const double largest = std::max({double(sr[0]), double(sr[1]), double(sr[2]), double(st[0]), double(st[1]),
                                   double(st[2])});
  double scale = 0;
  if (largest > 0) {
    for (int a = 0; a < 3; ++a) {
      const double e = (double(sr[a]) - st[a]) / largest;
      scale += e * e / 3;
    }
  }
  const double opacity = double(ref.opacities[r]) - test.opacities[t];
  const size_t kr = ref.sh_coefficients() * 3, kt = test.sh_coefficients() * 3;
  double colour = 0;
  for (int c = 0; c < 3; ++c) {
    const double e = kShC0 * (double(ref.sh[r * kr + c]) - test.sh[t * kt + c]);
    colour += e * e / 3;
  }
  return d2 * inv_tol2 + kPairingAttributeWeight * (std::max(0.0, 1.0 - cos2) + scale + opacity * opacity + colour);
}

/// Squared distance between reference mean r and `q`, in the tree's arithmetic.
double squared_distance(const format::GaussianCloud& ref, uint32_t r, const double q[3]) {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = q[a] - ref.means[size_t(r) * 3 + a];
    d2 += d * d;
  }
  return d2;
}

/// What the content pairing searches with.
struct ContentSearch {
  const format::GaussianCloud& ref;
  const format::GaussianCloud& test;
  const MeanTree& tree;
  /// [M] the reference Gaussian nearest to each test mean (nearest_references), within any τ of the search.
  const std::vector<uint32_t>& nearest;
  double tolerance = 0;

  /// The reference Gaussians test Gaussian t may pair with, most preferred first (keys: combined distances).
  void preferences(uint32_t t, std::vector<Neighbour>* scratch, std::vector<Neighbour>* out) const {
    const double q[3] = {test.means[size_t(t) * 3], test.means[size_t(t) * 3 + 1], test.means[size_t(t) * 3 + 2]};
    tree.nearest(q, tolerance * tolerance, kPairingNeighbours, scratch);
    const double inv_tol2 = tolerance > 0 ? 1.0 / (tolerance * tolerance) : 0.0;
    out->clear();
    for (const Neighbour& n : *scratch) {
      out->push_back({combined_distance(ref, n.index, test, t, n.key, inv_tol2), n.index});
    }
    std::sort(out->begin(), out->end());
  }

  /// The first of preferences(t), or index kNone when there is none: the same choice, searched only where a
  /// reference Gaussian could beat the nearest one (its squared distance / τ² at most the nearest's combined
  /// distance; the nearest ones within τ, as preferences() takes them, begin with those).
  Neighbour first_preference(uint32_t t, std::vector<Neighbour>* scratch) const {
    const double q[3] = {test.means[size_t(t) * 3], test.means[size_t(t) * 3 + 1], test.means[size_t(t) * 3 + 2]};
    const double tol2 = tolerance * tolerance;
    const double inv_tol2 = tolerance > 0 ? 1.0 / tol2 : 0.0;
    const uint32_t r = nearest[t];
    const double nearest_cost = combined_distance(ref, r, test, t, squared_distance(ref, r, q), inv_tol2);
    // A little wider than the bound, so that rounding cannot leave out a reference Gaussian it admits.
    tree.nearest(q, std::min(tol2, nearest_cost * tol2 * (1 + 1e-9)), kPairingNeighbours, scratch);
    Neighbour best{nearest_cost, r};
    for (const Neighbour& n : *scratch) {
      const Neighbour c{combined_distance(ref, n.index, test, t, n.key, inv_tol2), n.index};
      if (c < best) best = c;
    }
    return best;
  }
};

/// The reference Gaussian nearest to each test mean within `max_distance` (kNone: none), the largest distance to
/// one, and how many test means have none.
struct NearestReferences {
  std::vector<uint32_t> index;
  double largest = 0;
  uint64_t far = 0;
};

Result<NearestReferences> nearest_references(const format::GaussianCloud& test, const MeanTree& tree,
                                             double max_distance, unsigned workers) {
  const uint64_t m = test.size();
  NearestReferences out;
  out.index.assign(m, kNone);
  std::vector<double> largest(workers, 0.0);
  std::vector<uint64_t> far(workers, 0);
  RGS_RETURN_IF_ERROR(detail::parallel_slices(m, workers, [&](unsigned w, uint64_t begin, uint64_t end) {
    std::vector<Neighbour> found;
    for (uint64_t t = begin; t < end; ++t) {
      const double q[3] = {test.means[t * 3], test.means[t * 3 + 1], test.means[t * 3 + 2]};
      tree.nearest(q, max_distance * max_distance, 1, &found);
      if (found.empty()) {
        ++far[w];
      } else {
        out.index[t] = found[0].index;
        largest[w] = std::max(largest[w], std::sqrt(found[0].key));
      }
    }
  }));
  for (unsigned w = 0; w < workers; ++w) {
    out.largest = std::max(out.largest, largest[w]);
    out.far += far[w];
  }
  return out;
}

/// The stable matching of gaussian_pairing.h at `search.tolerance`: reference_of_test[t] (kNone: unpaired).
Result<std::vector<uint32_t>> stable_matching(const ContentSearch& search, unsigned workers) {
  const uint32_t m = static_cast<uint32_t>(search.test.size());
  const uint32_t n = static_cast<uint32_t>(search.ref.size());
  // Every test Gaussian's first choice, in parallel; later choices are searched again when needed (rare).
  std::vector<Neighbour> first(m, Neighbour{0, kNone});
  RGS_RETURN_IF_ERROR(detail::parallel_slices(m, workers, [&](unsigned, uint64_t begin, uint64_t end) {
    std::vector<Neighbour> scratch;
    for (uint64_t t = begin; t < end; ++t) first[t] = search.first_preference(static_cast<uint32_t>(t), &scratch);
  }));
  std::vector<uint32_t> holder(n, kNone);  // the test Gaussian holding each reference Gaussian
  std::vector<double> held_at(n, 0.0);     // its combined distance
  std::vector<uint32_t> rank(m, 0);        // the next preference each test Gaussian proposes to
  std::vector<Neighbour> scratch, prefs;
  std::vector<uint32_t> proposing;
  for (uint32_t start = 0; start < m; ++start) {
    proposing.push_back(start);
    while (!proposing.empty()) {
      const uint32_t t = proposing.back();
      proposing.pop_back();
      bool searched = false;  // prefs holds t's preferences
      while (true) {
        Neighbour choice{0, kNone};
        if (rank[t] == 0) {
          choice = first[t];
        } else {
          if (!searched) search.preferences(t, &scratch, &prefs);
          searched = true;
          if (rank[t] < prefs.size()) choice = prefs[rank[t]];
        }
        if (choice.index == kNone) break;  // no reference Gaussian left within τ
        const uint32_t r = choice.index;
        const uint32_t held = holder[r];
        if (held == kNone || choice.key < held_at[r] || (choice.key == held_at[r] && t < held)) {
          holder[r] = t;
          held_at[r] = choice.key;
          if (held != kNone) {
            ++rank[held];
            proposing.push_back(held);
          }
          break;
        }
        ++rank[t];
      }
    }
  }
  std::vector<uint32_t> reference_of_test(m, kNone);
  for (uint32_t r = 0; r < n; ++r) {
    if (holder[r] != kNone) reference_of_test[holder[r]] = r;
  }
  return reference_of_test;
}

/// kInvalidArgument unless `cloud` is consistent, has fewer than kNone Gaussians and finite means (the tree's
/// ordering needs them).
Status check_cloud(const format::GaussianCloud& cloud, const char* what) {
  RGS_RETURN_IF_ERROR(detail::check_consistent(cloud, what));
  RGS_RETURN_ERROR_IF(cloud.size() >= kNone, StatusCode::kInvalidArgument,
                      std::string(what) + " has " + std::to_string(cloud.size()) +
                          " Gaussians; pairing handles at most 4294967294");
  for (size_t v = 0; v < cloud.means.size(); ++v) {
    RGS_RETURN_ERROR_IF(!std::isfinite(cloud.means[v]), StatusCode::kInvalidArgument,
                        std::string(what) + ": Gaussian " + std::to_string(v / 3) + " has a non-finite mean");
  }
  return Status();
}

/// True when both clouds hold the same number of Gaussians with equal means index by index.
bool same_means_in_order(const format::GaussianCloud& reference, const format::GaussianCloud& test) {
  if (reference.size() != test.size()) return false;
  for (size_t v = 0; v < reference.means.size(); ++v) {
    if (!(reference.means[v] == test.means[v])) return false;
  }
  return true;
}

}  // namespace

Result<GaussianPairing> pair_gaussians(const format::GaussianCloud& reference, const format::GaussianCloud& test,
                                       const PairingOptions& options) {
  RGS_RETURN_IF_ERROR(check_cloud(reference, "reference cloud"));
  RGS_RETURN_IF_ERROR(check_cloud(test, "test cloud"));
  RGS_RETURN_ERROR_IF(!(options.max_position_distance >= 0) || !std::isfinite(options.max_position_distance),
                      StatusCode::kInvalidArgument,
                      "pairing: the largest position distance must be finite and >= 0, not " +
                          std::to_string(options.max_position_distance));
  return catch_bad_alloc([&]() -> Result<GaussianPairing> {
    GaussianPairing pairing;
    if (same_means_in_order(reference, test)) {
      pairing.reference_of_test.resize(test.size());
      for (uint64_t i = 0; i < test.size(); ++i) pairing.reference_of_test[i] = i;
      return pairing;
    }
    pairing.method = PairingMethod::kContent;
    const unsigned workers =
        options.threads != 0 ? options.threads : detail::worker_count(test.size(), 4096);
    RGS_ASSIGN_OR_RETURN(const MeanTree tree, MeanTree::build(reference.means, workers));
    RGS_ASSIGN_OR_RETURN(const NearestReferences nearest,
                         nearest_references(test, tree, options.max_position_distance, workers));
    pairing.far_test = nearest.far;
    pairing.position_tolerance = options.max_position_distance;
    if (pairing.far_test > 0) {
      pairing.unpaired_test = pairing.far_test;
      return pairing;
    }
    ContentSearch search{reference, test, tree, nearest.index,
                         std::min(options.max_position_distance, 2 * nearest.largest)};
    std::vector<uint32_t> matched;
    while (true) {
      RGS_ASSIGN_OR_RETURN(matched, stable_matching(search, workers));
      pairing.unpaired_test = uint64_t(std::count(matched.begin(), matched.end(), kNone));
      if (pairing.unpaired_test == 0 || search.tolerance >= options.max_position_distance) break;
      search.tolerance = options.max_position_distance;
    }
    pairing.position_tolerance = search.tolerance;
    if (pairing.unpaired_test > 0) return pairing;
    pairing.reference_of_test.assign(matched.begin(), matched.end());
    pairing.unpaired_reference = reference.size() - test.size();  // every test Gaussian has a distinct partner
    return pairing;
  }, [&] { return "out of memory pairing " + std::to_string(test.size()) + " Gaussians with " +
                  std::to_string(reference.size()); });
}

}  // namespace rgs::converter
