// Rate control's knobs (private to rgs_api): the archive options the search moves, their ranges and the
// constants that bound the search (rate_control.h).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "../internal_pipeline.h"
#include "rgs/format/archive.h"

namespace rgs::api::detail {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// The mean squared error (peak 1) of a PSNR in dB.
double mse_of(double psnr_db);

/// SH step multipliers the search moves between: steps of about 1.2x (1.6 dB of that band's error).
inline constexpr std::array<uint32_t, 24> kMultipliers = {1,  2,  3,  4,  5,  6,  7,  8,  10, 12, 14,  16,
                                                   20, 24, 28, 32, 40, 48, 56, 64, 80, 96, 112, 127};
/// The code step knobs (ArchiveOptions::rotation_step, scale_step, opacity_step) move by quarter bits, up to 4
/// bits past the bits' own step: finer than a bit, and below the format's 4-bit minimum.
inline constexpr double kMaxCodeStep = 16;
/// The opacity floor (ArchiveOptions::opacity_floor) moves from 0 to 1/255, which leaves out only Gaussians that
/// never blend in the source (α ≤ opacity < 1/255), then by factors of √2 up to this: each step leaves out
/// Gaussians that can blend, the faintest first. Floors the opacity code 0 already covers are skipped.
inline constexpr double kMaxOpacityFloor = 32.0 / 255;
/// The fine scan of an SH multiplier tries at most this many integers above it.
inline constexpr uint32_t kFineMultipliers = 16;
/// Rounds of one-knob steps after the ladder (and of a byte budget's trades), and of code steps at the end: bounds
/// on the search's time.
inline constexpr int kMaxRounds = 10;
inline constexpr int kMaxFillRounds = 24;
inline constexpr uint32_t kMinBits = 4, kMaxBits = 16;
/// Archives encoded at the same time (Measurer::encode_batch): at most one per CPU, and as many as fit this much
/// memory when each is estimated at kBatchBytesPerGaussian bytes a Gaussian besides its SH codes (its decoded
/// arrays, stored sections, point order and the encoder's work arrays; an upper estimate, the peak RSS measured
/// with batches is in docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes).
inline constexpr uint64_t kBatchBytes = uint64_t{4} << 30;
inline constexpr uint64_t kBatchBytesPerGaussian = 100;
/// Archives kept for their Draco points (Measurer::encode_archive): as many as fit this much memory at the
/// estimate above, at least 2 and at most kMaxPointsKept.
inline constexpr uint64_t kPointsBytes = uint64_t{2} << 30;
inline constexpr uint64_t kMaxPointsKept = 8;
/// On the GPU the source's renders of both view sets stay on the device, where the candidates' renders are
/// compared with them, while they take at most this much (RGBA float32); beyond it they are kept on the host.
inline constexpr uint64_t kDeviceSourceBytes = uint64_t{4} << 30;
/// Position errors the search uses: 2^-kFinestPositionLog2 .. 2^-kCoarsestPositionLog2 of the extent.
inline constexpr int kFinestPositionLog2 = 25, kCoarsestPositionLog2 = 3;
/// The ladder's range: q = 0 is the defaults, each unit one bit (a factor 2) coarser on every knob.
inline constexpr double kLadderFinest = -8, kLadderCoarsest = 8;
/// How much above the target the final choice may be before the search is run again at an adjusted target.
inline constexpr double kMaxAboveDb = 0.5;
/// The scan of the SH multipliers and the code steps' stage spend only what the whole steps leave more than this
/// above the target.
inline constexpr double kMinSlackDb = 0.15;
/// Exchanges (Search::exchange_for_psnr): the pairs of steps measured in each, the most taken in one search, and
/// the share of the bytes an exchange must save for the search to look for another.
inline constexpr size_t kExchangePairs = 4;
inline constexpr int kMaxExchanges = 4;
inline constexpr double kExchangeMinSaving = 0.0025;
/// Searches before the choice is settled: a PSNR target's, each checked at the cameras' own size; a byte target's,
/// each on a budget that puts the last choice's file at the target.
inline constexpr int kMaxAttempts = 3;
/// A byte target's descent (Search::descend_for_bytes): it starts from the ladder's point of at most this many
/// times the budget, takes a fresh step rated at least this share of the best rating, and ends after at most
/// this many measurements.
inline constexpr double kDescentRoom = 2;
inline constexpr double kDescentTolerance = 0.8;
inline constexpr int kMaxDescentMeasures = 200;
/// A byte target: the combinations of steps of several knobs each trade measures (Search::trade_for_bytes).
inline constexpr size_t kTradeCombinations = 4;
/// A byte target: the share of the budget a file may leave unused before the search runs again on a larger one.
inline constexpr double kBytesSlack = 0.005;
/// A byte target: the archives of the highest search PSNR within the budget checked at the cameras' own size.
inline constexpr size_t kBytesFinalists = 2;
/// The search target's margin over the measured difference between the search size and the cameras' size.
inline constexpr double kCalibrationMarginDb = 0.15;

/// The knobs the search moves, one at a time: kKnobs in the rounds, kCodeSteps in a PSNR search's last
/// stage (Search::fill_for_psnr).
enum class Knob {
  kRotation, kScale, kOpacity, kSh0, kSh1, kSh2, kSh3, kPosition, kOpacityFloor, kRotationStep, kScaleStep,
  kOpacityStep
};
inline constexpr std::array<Knob, 9> kKnobs = {Knob::kRotation, Knob::kScale, Knob::kOpacity,
                                        Knob::kSh0,      Knob::kSh1,   Knob::kSh2,
                                        Knob::kSh3,      Knob::kPosition, Knob::kOpacityFloor};
inline constexpr std::array<Knob, 3> kCodeSteps = {Knob::kRotationStep, Knob::kScaleStep, Knob::kOpacityStep};

/// The ladder: every knob of `anchor` coarsened by `q` bits (q < 0: finer).
format::ArchiveOptions ladder(const format::ArchiveOptions& anchor, double q);

/// `o` with `knob` one step coarser (`coarser`) or finer; nullopt at the end of its range.
std::optional<format::ArchiveOptions> step(format::ArchiveOptions o, Knob knob, bool coarser);

/// The value of one knob of `o` (bits, a code step, a multiplier, the floor or the position error).
double knob_value(const format::ArchiveOptions& o, Knob knob);

/// The knobs' values of an archive, as a key of the archives measured.
using Key =
    std::tuple<uint32_t, double, uint32_t, double, uint32_t, double, double, std::array<uint32_t, 4>, double>;
Key key_of(const format::ArchiveOptions& o);

/// The knobs the rounds move for a scene of SH degree `sh_degree`.
std::vector<Knob> knobs_for(uint32_t sh_degree);

/// "40.31 dB".
std::string db_text(double db);

}  // namespace rgs::api::detail
