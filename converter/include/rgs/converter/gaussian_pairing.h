// Pairing of two versions of one scene Gaussian by Gaussian, when one of them is stored in another order or
// lacks some Gaussians (an archive .rgs, a level-of-detail file, a reordering writer), for per-attribute errors.
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// How pair_gaussians() paired the Gaussians.
enum class PairingMethod : uint8_t {
  /// Index by index: both clouds have the same size and every test mean equals the reference mean of its index.
  kIndex = 0,
  /// By content: each test Gaussian with a reference Gaussian near its mean (GaussianPairing documents the rule).
  kContent = 1,
};

/// Options of pair_gaussians().
struct PairingOptions {
  /// Largest distance between the means of a pair, world units, finite and ≥ 0. A test Gaussian with no
  /// reference mean this close is not paired.
  double max_position_distance = 0;
  /// Worker threads (0 = every CPU this process may run on). The result does not depend on it.
  uint32_t threads = 0;
};

/// A one-to-one pairing of the Gaussians of a test cloud with some of a reference cloud's.
///
/// By content (PairingMethod::kContent), with d_j the distance from test mean j to the nearest reference mean:
/// - the tolerance τ is min(max_position_distance, 2 · max_j d_j): it follows the conversion's own largest
///   position error, so that a Gaussian is not paired with a neighbour far beyond it;
/// - test Gaussian j may pair with the kPairingNeighbours reference Gaussians nearest to its mean (ties by index)
///   that lie within τ, and prefers the smallest combined distance
///   (d/τ)² + 10 · [(1 − (q·q')²) + Σ_axes ((s − s') / largest axis)² / 3 + (α − α')² + Σ_c (C0 · ΔDC_c)² / 3]
///   (d between the means; unit quaternions; linear scales, the largest axis of either; activated opacities; the
///   SH DC terms as colour, C0 = 0.2820948): positions decide between Gaussians far apart within τ, the other
///   attributes between near ones (docs/AUDITS.md#how-gaussians-are-paired);
/// - the pairing is the stable matching of these preferences (Gale–Shapley, test Gaussians proposing, a reference
///   Gaussian keeping the proposer of the smallest combined distance): no test Gaussian and reference Gaussian
///   prefer each other to their partners. It depends on neither cloud's order, except between proposals of
///   exactly equal distance (decided by test index), and it is the conversion's own pairing wherever each
///   Gaussian's version is the one nearest to it in this distance;
/// - when that leaves some test Gaussian without a partner at τ < max_position_distance, it is made again at
///   τ = max_position_distance.
/// Where the position error exceeds the spacing of the Gaussians and the conversion left some out (an archive
/// fitted to a low PSNR), a few Gaussians may pair with a left-out neighbour instead of their own, and figures
/// measured over the pairing can differ from the conversion's own in their maxima (docs/AUDITS.md says by how
/// much on the measured scenes).
struct GaussianPairing {
  /// Index by index, or by content.
  PairingMethod method = PairingMethod::kIndex;
  /// [test size] the reference Gaussian each test Gaussian is paired with, all distinct; empty when
  /// unpaired_test > 0 (no pairing is given then).
  std::vector<uint64_t> reference_of_test;
  /// Test Gaussians left without a partner: far_test of them, or else test Gaussians that lost every reference
  /// Gaussian within τ to test Gaussians preferred by it (more test Gaussians than reference ones, for one).
  uint64_t unpaired_test = 0;
  /// Test Gaussians with no reference mean within max_position_distance (the pairing then stops there).
  uint64_t far_test = 0;
  /// Reference Gaussians no test Gaussian is paired with (those a conversion left out), when paired.
  uint64_t unpaired_reference = 0;
  /// τ, world units: every pair's means lie at most this far apart (0 for kIndex; max_position_distance when
  /// far_test > 0).
  double position_tolerance = 0;

  /// True when every test Gaussian has a partner.
  bool complete() const { return unpaired_test == 0; }
};

/// Reference Gaussians a test Gaussian may pair with: its nearest ones within the tolerance.
inline constexpr uint32_t kPairingNeighbours = 64;

/// Pairs each Gaussian of `test` with a distinct Gaussian of `reference` that it is a version of: index by
/// index when both hold the same Gaussians in the same order (equal sizes and every mean equal to the mean of
/// the same index), else by content as GaussianPairing says. A test cloud with more Gaussians than the
/// reference, or with Gaussians far from every reference mean, comes back with unpaired_test > 0 and no pairs.
/// Cost: O(N + M) for an index pairing (N reference, M test Gaussians). By content: a k-d tree over the reference
/// means, O(N log N) to build; per test Gaussian a nearest-neighbour search, then a search of at most
/// kPairingNeighbours within the radius where one could be preferred to the nearest (O(log N) each on spread
/// points), spread over `threads`; then a sequential matching, O(M) plus one search of kPairingNeighbours for
/// each proposal after a test Gaussian's first (a test Gaussian displaced from its first choice; at most
/// kPairingNeighbours proposals each). Memory besides the clouds and the result: 33 bytes per reference and
/// 28 per test Gaussian.
/// Deterministic: the same clouds and options give the same pairing whatever the thread count.
/// Errors: kInvalidArgument (inconsistent clouds, a non-finite mean, a negative or non-finite
/// max_position_distance, more than 2^32 − 2 Gaussians in either cloud), kOutOfMemory.
Result<GaussianPairing> pair_gaussians(const format::GaussianCloud& reference, const format::GaussianCloud& test,
                                       const PairingOptions& options);

}  // namespace rgs::converter
