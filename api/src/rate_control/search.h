// Rate control's search (private to rgs_api): from the ladder's point, rounds of one-knob steps for a PSNR
// target at the search size (for_psnr), and a greedy descent with trades between knobs for a byte budget
// (for_bytes).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rate_control.h"
#include "knobs.h"
#include "measurer.h"

namespace rgs::api::detail {

/// Progress steps (FitProgress) of one PSNR search (Search::for_psnr): its ladder (or the earlier path it starts
/// from), refining, scanning, exchanging and filling.
inline constexpr uint32_t kPsnrSearchSteps = 5;
/// Progress steps of a byte search at one budget (Search::for_bytes): its ladder and at most kMaxRounds rounds of
/// trades.
inline constexpr uint32_t kBytesSearchSteps = 1 + kMaxRounds;

class Search {
 public:
  Search(Measurer& m, const FitOptions& options, uint32_t sh_degree, format::ArchiveOptions anchor)
      : m_(m),
        options_(options),
        knobs_(knobs_for(sh_degree)),
        anchor_(std::move(anchor)),
        sh_degree_(sh_degree) {
    byte_knobs_ = knobs_;
    byte_knobs_.insert(byte_knobs_.end(), kCodeSteps.begin(), kCodeSteps.end());
  }

  /// Reports `what` to FitOptions::progress, with `steps` more steps done.
  void report(const std::string& what, uint32_t steps = 0);
  /// A part of the search of at most `most` progress steps (FitSteps on FitOptions::progress).
  FitSteps part(uint32_t most) { return FitSteps(options_.progress, most); }
  FitProgress* progress() const { return options_.progress; }

  /// A PSNR target at the search size: the path of accepted archives, finest first, each meeting `target`. It
  /// starts from the last step of `previous` (an earlier search's path) that meets `target`, else from the
  /// ladder.
  Result<std::vector<FitPoint>> for_psnr(double target, const std::vector<FitPoint>& previous = {});

  /// A PSNR target's ladder: the coarsest point of the ladder that meets `target`, bracketed to a quarter bit.
  Result<FitPoint> ladder_for_psnr(double target);

  /// A PSNR target's refinement from path->back(): each round moves every knob one step coarser on its own; the
  /// steps that still meet `target` are taken together, best bytes saved per unit of squared error first,
  /// while the sum of their error increments (errors of different knobs add, roughly) stays within what the
  /// target allows; the combination is measured and kept when it meets the target, else the best single step.
  Status refine_for_psnr(double target, std::vector<FitPoint>* path);

  /// A PSNR target's scan of each SH step multiplier's integers, while path->back() is more than
  /// kMinSlackDb above `target`: the integers between the multiplier and the second ladder value above it
  /// (at most kFineMultipliers). Where the source's colours already lie on a grid of their own (a scene that was
  /// 8-bit before it was a PLY), the error of a step depends on how it lines up with that grid, not only on its
  /// size, so a multiplier between two ladder values can be both smaller and closer to the target than either.
  /// The smallest archive that meets `target` is kept when it is smaller than path->back().
  Status scan_multipliers_for_psnr(double target, std::vector<FitPoint>* path);

  /// A PSNR target's exchange between knobs, after the rounds, where no knob can go one step coarser on its own: the
  /// knobs differ in bytes per squared error, so one step coarser with another step finer can meet `target` in
  /// fewer bytes (a greedy path through the knobs ends off the rate-distortion curve otherwise). Every knob one step
  /// coarser and one step finer, and every SH multiplier one step finer together, are measured at path->back() (the
  /// coarser steps are the last round's, measured before); squared errors and bytes of two steps roughly add, so
  /// the kExchangePairs pairs of a coarser and a finer step of two knobs predicted smallest among those predicted to
  /// meet `target` are measured together. The smallest that meets it, if smaller than path->back(), is taken
  /// (returns true).
  Result<bool> exchange_for_psnr(double target, std::vector<FitPoint>* path);

  /// A PSNR target's last stage, while path->back() is more than kMinSlackDb above `target`: the code steps of
  /// rotations, scales and opacities, a quarter bit coarser at a time (finer than the bits, and below their
  /// 4-bit minimum), the step with the most bytes saved per squared error added that still meets `target` each
  /// round. It only spends what the knobs of whole steps leave above the target, so it never ends larger.
  Status fill_for_psnr(double target, std::vector<FitPoint>* path);

  /// A byte budget at the search size: the archive of the highest mean PSNR within `budget` among every archive
  /// the search measured (Measurer::watch_budget). From the best one within it measured before, else from the
  /// descent (descend), rounds of trades (trade_for_bytes) while a trade reads higher, at most kMaxRounds; a round
  /// trades first on the steps as last measured, then (with `measure_all`) on every step measured again there.
  Result<FitPoint> for_bytes(uint64_t budget, bool measure_all);

  /// A byte budget's descent, when no archive within `budget` was measured before: from the ladder's point of
  /// kDescentRoom times the budget (ladder_for_bytes), the knobs' coarser steps one at a time, the one with the
  /// most bytes saved per squared error added first (descend_for_bytes), until the archive fits. Returns the best
  /// archive within the budget measured.
  Result<FitPoint> descend(uint64_t budget);

  const std::optional<FitPoint>& finest() const { return finest_; }
  uint32_t sh_degree() const { return sh_degree_; }
  const format::ArchiveOptions& anchor() const { return anchor_; }

 private:
  /// The smallest archive the search makes: the ladder's coarsest with the coarsest opacity floor and code steps
  /// (knobs the ladder leaves alone, which the descent and the trades move).
  format::ArchiveOptions smallest_archive() const;

  /// A byte budget's start: the finest ladder point whose archive fits kDescentRoom times `budget`, bisected by
  /// bytes alone to an eighth of a bit (the ladder's coarsest when none does), then rendered. kInvalidArgument
  /// when even the smallest archive does not fit the budget.
  Result<FitPoint> ladder_for_bytes(uint64_t budget);

  /// A byte budget's descent from `at`: a lazy greedy path along the rate-distortion curve. Each knob's coarser
  /// step is rated by its bytes saved per squared error added where it was last measured; the best fresh step
  /// (measured at `at`) is taken while it rates at least kDescentTolerance of the best rating, else the best step
  /// is measured again at `at`. Errors of different knobs roughly add, so a step measured before still rates
  /// nearly as it did. Ends when the archive fits `budget`, or after kMaxDescentMeasures measurements.
  Status descend_for_bytes(uint64_t budget, FitPoint at);

  /// A byte budget's trade, from the best archive within `budget` measured so far: every knob (byte_knobs_) one
  /// step coarser and one step finer, measured there when the knob moved since it was last measured (every knob
  /// with `measure_all`), kept otherwise. Bytes and squared errors of steps of different knobs roughly add, so of
  /// the combinations of at most one step a knob, the kTradeCombinations predicted lowest in error among those
  /// predicted within the budget are measured (bytes first, those that fit rendered): steps coarser pay for steps
  /// finer where they cost less error per byte, so the budget goes where it buys the most. Returns whether the
  /// best archive within the budget now reads higher.
  Result<bool> trade_for_bytes(uint64_t budget, bool measure_all);

  /// A trade's step: a knob (its index in byte_knobs_) one step coarser or finer, the knob's value it steps from
  /// (knob_value), and the squared error and bytes it added where it was measured.
  struct TradeStep {
    size_t knob;
    bool coarser;
    double from, added_mse, added_bytes;
  };

  /// One step coarser of every knob of `knobs` not yet frozen, into `list` with its index in `knobs` in `knob_of`;
  /// a knob that has no such step left is frozen.
  static void next_steps(const std::vector<Knob>& knobs, const format::ArchiveOptions& at, std::vector<bool>* frozen,
                         std::vector<format::ArchiveOptions>* list, std::vector<size_t>* knob_of);

  /// A coarser step measured at `points[index]`: the squared error it adds and its bytes saved per unit of it.
  struct Move {
    size_t index;
    double added_mse, ratio;
  };
  /// The coarser steps `points` (of the knobs `knob_of`, from `at`) that still meet `target` in fewer bytes, by
  /// bytes saved per squared error added, best first (a step that adds none first; ties in knob order); the knob
  /// of every other step is frozen: coarser still, with the others coarser too, will not meet the target.
  static std::vector<Move> passing_moves(const FitPoint& at, const std::vector<FitPoint>& points,
                                         const std::vector<size_t>& knob_of, double target, std::vector<bool>* frozen);

  void note_finest(const FitPoint& p);

  /// Reports where the search is (`stage`, the archives measured, the best one so far) with `steps` more
  /// progress steps done.
  void report_progress(const char* stage, const std::optional<FitPoint>& best, uint32_t steps = 0);
  /// A stage of a search done: one progress step.
  void report_step(const char* stage, const std::optional<FitPoint>& best) { report_progress(stage, best, 1); }

  Measurer& m_;
  const FitOptions& options_;
  std::vector<Knob> knobs_;
  std::vector<Knob> byte_knobs_;        ///< the knobs a byte budget moves: knobs_, then the code steps
  std::vector<TradeStep> trade_steps_;  ///< the trades' steps, as last measured
  format::ArchiveOptions anchor_;
  uint32_t sh_degree_;
  std::optional<FitPoint> finest_;
};

}  // namespace rgs::api::detail
