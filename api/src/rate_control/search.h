// Rate control's search (private to rgs_api): from the ladder's point, rounds of one-knob steps for a PSNR
// target at the search size (for_psnr), and the search over PSNR targets for a byte budget (for_bytes).
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
/// Progress steps of a byte search at one budget (Search::for_bytes): its ladder, at most kMaxBytesSearches PSNR
/// searches, and filling.
inline constexpr uint32_t kBytesSearchSteps = 1 + kMaxBytesSearches * kPsnrSearchSteps + 1;

class Search {
 public:
  Search(Measurer& m, const FitOptions& options, uint32_t sh_degree, format::ArchiveOptions anchor)
      : m_(m),
        options_(options),
        knobs_(knobs_for(sh_degree)),
        anchor_(std::move(anchor)),
        sh_degree_(sh_degree) {}

  /// A search of its own (no history) on the same measurer, options and anchor.
  Search fresh() const { return Search(m_, options_, sh_degree_, anchor_); }

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
  /// the search measured (Measurer::watch_budget). The searches are PSNR searches (for_psnr), over the same
  /// knobs and with the same rounds, scans, exchanges and code steps, so that no PSNR search finds a file of at
  /// most these bytes that reads higher on these views: from the ladder's point that fits the budget, a search
  /// over PSNR targets (secant steps in log bytes, bracketed) for the highest target whose search ends within it
  /// (at most kMaxBytesSearches searches, to kBytesTargetResolutionDb; the searches of earlier budgets count). Then the finer steps of one knob at a time that still fit spend
  /// what the budget leaves, the step with the most dB gained per byte added each round.
  Result<FitPoint> for_bytes(uint64_t budget);

  const std::optional<FitPoint>& finest() const { return finest_; }
  uint32_t sh_degree() const { return sh_degree_; }

 private:
  /// A byte budget's last stage, from the best archive within `budget` measured so far: each round, of the finer
  /// steps of one knob that still fit, the one with the most dB gained per byte added (at most kMaxRounds).
  Status fill_for_bytes(uint64_t budget);

  /// One step of every knob of `knobs` not yet frozen, coarser or finer, into `list` with its index in `knobs`
  /// in `knob_of`; a knob that has no such step left is frozen.
  static void next_steps(const std::vector<Knob>& knobs, const format::ArchiveOptions& at, bool coarser,
                         std::vector<bool>* frozen, std::vector<format::ArchiveOptions>* list,
                         std::vector<size_t>* knob_of);

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

  /// A PSNR search of the bytes search: its target, and its choice's bytes (+inf when the target is above the
  /// finest archive) and PSNR.
  struct Probe {
    double target, bytes, psnr;
  };

  Measurer& m_;
  const FitOptions& options_;
  std::vector<Probe> probes_;  ///< every PSNR search for_bytes ran, whatever its budget
  std::vector<Knob> knobs_;
  format::ArchiveOptions anchor_;
  uint32_t sh_degree_;
  std::optional<FitPoint> finest_;
};

}  // namespace rgs::api::detail
