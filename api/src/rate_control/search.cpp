// Rate control's search: the ladder, rounds of one-knob steps, scans, exchanges and code steps for a PSNR target,
// and the search over PSNR targets for a byte budget (search.h).
#include <algorithm>
#include <cmath>
#include <limits>

#include "search.h"

namespace rgs::api::detail {

void Search::report(const std::string& what, uint32_t steps) {
  if (options_.progress) options_.progress->advance(what, steps);
}

Result<std::vector<FitPoint>> Search::for_psnr(double target, const std::vector<FitPoint>& previous) {
  const FitSteps steps_of_search = part(kPsnrSearchSteps);
  std::vector<FitPoint> path;
  // Measured again (cached): a step checked at the cameras' size since reads as measure() says.
  std::vector<format::ArchiveOptions> steps;
  for (const FitPoint& p : previous) steps.push_back(p.options);
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> now, m_.measure(steps));
  for (const FitPoint& p : now) {
    if (p.psnr_mean_db >= target) path = {p};
  }
  if (path.empty()) {
    RGS_ASSIGN_OR_RETURN(FitPoint pass, ladder_for_psnr(target));
    path = {pass};
  }
  report_step("ladder", path.back());
  RGS_RETURN_IF_ERROR(refine_for_psnr(target, &path));
  report_step("refined", path.back());
  RGS_RETURN_IF_ERROR(scan_multipliers_for_psnr(target, &path));
  report_step("scanned", path.back());
  for (int exchange = 0; exchange < kMaxExchanges; ++exchange) {
    const uint64_t before = path.back().bytes;
    RGS_ASSIGN_OR_RETURN(const bool exchanged, exchange_for_psnr(target, &path));
    if (!exchanged) break;
    RGS_RETURN_IF_ERROR(refine_for_psnr(target, &path));
    if (double(path.back().bytes) > double(before) * (1 - kExchangeMinSaving)) break;
  }
  report_step("exchanged", path.back());
  RGS_RETURN_IF_ERROR(fill_for_psnr(target, &path));
  report_step("filled", path.back());
  return path;
}

Result<FitPoint> Search::ladder_for_psnr(double target) {
  // The ladder: bracket the largest q that meets the target, halving the bracket with three points a batch.
  std::vector<double> qs = {-4, -2, 0, 2, 4};
  double q_pass = std::numeric_limits<double>::quiet_NaN(), q_fail = kLadderCoarsest + 1;
  std::optional<FitPoint> pass;
  for (int round = 0; round < 6; ++round) {
    std::vector<format::ArchiveOptions> list;
    for (double q : qs) list.push_back(ladder(anchor_, q));
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
    for (size_t i = 0; i < qs.size(); ++i) {
      note_finest(points[i]);
      if (points[i].psnr_mean_db >= target) {
        if (std::isnan(q_pass) || qs[i] > q_pass) {
          q_pass = qs[i];
          pass = points[i];
        }
      } else {
        q_fail = std::min(q_fail, qs[i]);
      }
    }
    report_progress("ladder", pass);
    if (std::isnan(q_pass)) {
      if (round > 0) break;
      qs = {kLadderFinest};  // nothing met the target: the finest archive decides whether any can
      continue;
    }
    if (q_fail > kLadderCoarsest) {  // nothing measured failed: coarser steps, up to the coarsest
      if (q_pass >= kLadderCoarsest) break;
      qs = {std::min(q_pass + 1, kLadderCoarsest), std::min(q_pass + 2, kLadderCoarsest), kLadderCoarsest};
      qs.erase(std::unique(qs.begin(), qs.end()), qs.end());
      continue;
    }
    const double width = q_fail - q_pass;
    if (width <= 0.25) break;
    qs = {q_pass + width / 4, q_pass + width / 2, q_pass + 3 * width / 4};
  }
  if (!pass) {
    return Status(StatusCode::kInvalidArgument,
                  "target " + db_text(target) + " is above what the archive profile reaches on these views: " +
                      db_text(finest_->psnr_mean_db) + " at the finest settings (" +
                      describe_archive_options(finest_->options, sh_degree_) + ")");
  }
  return *pass;
}

Status Search::refine_for_psnr(double target, std::vector<FitPoint>* path) {
  const double allowed_mse = mse_of(target);
  std::vector<bool> frozen(knobs_.size(), false);
  for (int round = 0; round < kMaxRounds; ++round) {
    const FitPoint at = path->back();
    std::vector<format::ArchiveOptions> list;
    std::vector<size_t> knob_of;
    next_steps(knobs_, at.options, true, &frozen, &list, &knob_of);
    if (list.empty()) break;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
    const std::vector<Move> moves = passing_moves(at, points, knob_of, target, &frozen);
    if (moves.empty()) break;
    FitPoint next = points[moves[0].index];
    format::ArchiveOptions together = at.options;
    double predicted = mse_of(at.psnr_mean_db);
    size_t taken = 0;
    for (const Move& mv : moves) {
      if (predicted + mv.added_mse > allowed_mse) continue;
      together = *step(together, knobs_[knob_of[mv.index]], true);
      predicted += mv.added_mse;
      ++taken;
    }
    if (taken > 1) {
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> combined, m_.measure({together}));
      if (combined[0].psnr_mean_db >= target && combined[0].bytes < next.bytes) next = combined[0];
    }
    path->push_back(next);
    report_progress("refining", path->back());
  }
  return Status();
}

Status Search::scan_multipliers_for_psnr(double target, std::vector<FitPoint>* path) {
  for (Knob knob : knobs_) {
    if (knob < Knob::kSh0 || knob > Knob::kSh3) continue;
    const FitPoint at = path->back();
    if (!(at.psnr_mean_db > target + kMinSlackDb)) break;
    const size_t degree = size_t(int(knob) - int(Knob::kSh0));
    const uint32_t m = at.options.sh_step_multipliers[degree];
    auto next = std::upper_bound(kMultipliers.begin(), kMultipliers.end(), m);
    const uint32_t end = next == kMultipliers.end() || next + 1 == kMultipliers.end() ? 128 : *(next + 1);
    std::vector<format::ArchiveOptions> list;
    for (uint32_t v = m + 1; v < end && list.size() < kFineMultipliers; ++v) {
      format::ArchiveOptions o = at.options;
      o.sh_step_multipliers[degree] = v;
      list.push_back(o);
    }
    // Bytes first: only the archives smaller than `at` are rendered.
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> sizes, m_.bytes(list));
    std::vector<format::ArchiveOptions> smaller;
    for (size_t i = 0; i < sizes.size(); ++i) {
      if (sizes[i].bytes < at.bytes) smaller.push_back(list[i]);
    }
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(smaller));
    std::optional<FitPoint> best;
    for (const FitPoint& p : points) {
      if (p.psnr_mean_db >= target && (!best || p.bytes < best->bytes)) best = p;
    }
    if (best) {
      path->push_back(*best);
      report_progress("scanning", path->back());
    }
  }
  return Status();
}

Result<bool> Search::exchange_for_psnr(double target, std::vector<FitPoint>* path) {
  const FitPoint at = path->back();
  struct Single {
    format::ArchiveOptions options;
    size_t knob;  ///< index in knobs_; knobs_.size() for every SH multiplier together
  };
  std::vector<Single> coarser, finer;
  for (size_t k = 0; k < knobs_.size(); ++k) {
    if (auto o = step(at.options, knobs_[k], true)) coarser.push_back({*o, k});
    if (auto o = step(at.options, knobs_[k], false)) finer.push_back({*o, k});
  }
  if (sh_degree_ > 0) {
    format::ArchiveOptions o = at.options;
    bool moved = false;
    for (Knob knob : knobs_) {
      if (knob < Knob::kSh0 || knob > Knob::kSh3) continue;
      if (auto next = step(o, knob, false)) o = *next, moved = true;
    }
    if (moved) finer.push_back({o, knobs_.size()});
  }
  std::vector<format::ArchiveOptions> list;
  for (const auto* singles : {&coarser, &finer}) {
    for (const Single& one : *singles) list.push_back(one.options);
  }
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
  const double mse_at = mse_of(at.psnr_mean_db), allowed_mse = mse_of(target);
  struct Pair {
    double bytes;
    format::ArchiveOptions options;
  };
  std::vector<Pair> pairs;
  for (size_t c = 0; c < coarser.size(); ++c) {
    const FitPoint& pc = points[c];
    const bool sh_knob = knobs_[coarser[c].knob] >= Knob::kSh0 && knobs_[coarser[c].knob] <= Knob::kSh3;
    for (size_t f = 0; f < finer.size(); ++f) {
      const FitPoint& pf = points[coarser.size() + f];
      const size_t fk = finer[f].knob;
      if (fk == coarser[c].knob || (fk == knobs_.size() && sh_knob)) continue;
      const double mse = mse_of(pc.psnr_mean_db) + mse_of(pf.psnr_mean_db) - mse_at;
      const double bytes = double(pc.bytes) + double(pf.bytes) - double(at.bytes);
      if (!(mse <= allowed_mse) || !(bytes < double(at.bytes))) continue;
      std::optional<format::ArchiveOptions> o = pc.options;
      if (fk == knobs_.size()) {
        o->sh_step_multipliers = pf.options.sh_step_multipliers;
      } else {
        o = step(*o, knobs_[fk], false);
      }
      if (o) pairs.push_back({bytes, *o});
    }
  }
  std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.bytes < b.bytes; });
  list.clear();
  for (const Pair& pair : pairs) {
    if (list.size() == kExchangePairs) break;
    if (std::none_of(list.begin(), list.end(), [&](const auto& o) { return key_of(o) == key_of(pair.options); })) {
      list.push_back(pair.options);
    }
  }
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> measured, m_.measure(list));
  std::optional<FitPoint> best;
  for (const FitPoint& p : measured) {
    if (p.psnr_mean_db >= target && p.bytes < at.bytes && (!best || p.bytes < best->bytes)) best = p;
  }
  if (!best) return false;
  path->push_back(*best);
  report_progress("exchanging", path->back());
  return true;
}

Status Search::fill_for_psnr(double target, std::vector<FitPoint>* path) {
  const std::vector<Knob> steps(kCodeSteps.begin(), kCodeSteps.end());
  std::vector<bool> frozen(steps.size(), false);
  for (int round = 0; round < kMaxFillRounds; ++round) {
    const FitPoint at = path->back();
    if (!(at.psnr_mean_db > target + kMinSlackDb)) break;
    std::vector<format::ArchiveOptions> list;
    std::vector<size_t> knob_of;
    next_steps(steps, at.options, true, &frozen, &list, &knob_of);
    if (list.empty()) break;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
    const std::vector<Move> moves = passing_moves(at, points, knob_of, target, &frozen);
    if (moves.empty()) break;
    path->push_back(points[moves[0].index]);
    report_progress("filling", path->back());
  }
  return Status();
}

Result<FitPoint> Search::for_bytes(uint64_t budget) {
  const FitSteps steps_of_search = part(kBytesSearchSteps);
  m_.watch_budget(budget);
  // The ladder by bytes alone (no renders): bisect the finest q whose file fits.
  double lo = kLadderFinest, hi = kLadderCoarsest;  // invariant: hi fits (checked), lo does not (or untested)
  // The smallest archive the searches make: the ladder's coarsest with the coarsest opacity floor and code steps
  // (knobs the ladder leaves alone, which the PSNR searches move).
  format::ArchiveOptions smallest_options = ladder(anchor_, hi);
  smallest_options.opacity_floor = kMaxOpacityFloor;
  smallest_options.rotation_step = smallest_options.scale_step = smallest_options.opacity_step = kMaxCodeStep;
  RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> coarsest, m_.bytes({ladder(anchor_, hi), smallest_options}));
  if (coarsest[1].bytes > budget) {
    return Status(StatusCode::kInvalidArgument,
                  group_digits(budget) + " bytes is below the smallest archive the search makes: " +
                      group_digits(coarsest[1].bytes) + " bytes at the coarsest settings (" +
                      describe_archive_options(coarsest[1].options, sh_degree_) + ")");
  }
  FitPoint fit = coarsest[0].bytes <= budget ? coarsest[0] : coarsest[1];
  RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> finest, m_.bytes({ladder(anchor_, lo)}));
  if (finest[0].bytes <= budget) {
    fit = finest[0];
    hi = lo;
  }
  while (coarsest[0].bytes <= budget && hi - lo > 0.125) {
    const double mid = (lo + hi) / 2;
    RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> p, m_.bytes({ladder(anchor_, mid)}));
    if (p[0].bytes <= budget) {
      hi = mid;
      fit = p[0];
    } else {
      lo = mid;
    }
  }
  RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> start, m_.measure({fit.options}));
  report_step("ladder", start[0]);
  // The search over targets, in log2 of the bytes, from every PSNR search run so far (probes_, kept across
  // budgets): `below` is the highest target whose search ended within the budget, `above` the lowest above it
  // whose search ended over it or failed (bytes +inf). Between the two, the next target is interpolated where
  // the bytes would meet the budget (kept off either end by a tenth of the bracket); above every search that
  // fits, extrapolated along the slope of the two highest (kDbPerDoubling until there are two), by at least a
  // step that doubles from 1 dB (on a flat stretch of the curve, a few per cent of bytes are several dB).
  const double log_budget = std::log2(double(budget));
  std::optional<Probe> below, above, below_before;
  for (const Probe& p : probes_) {
    if (p.bytes <= double(budget)) {
      if (!below || p.target > below->target) below_before = below, below = p;
    }
  }
  for (const Probe& p : probes_) {
    if (p.bytes > double(budget) && (!below || p.target > below->target) && (!above || p.target < above->target)) {
      above = p;
    }
  }
  if (!below) below = Probe{start[0].psnr_mean_db, double(start[0].bytes), start[0].psnr_mean_db};
  std::vector<FitPoint> previous;
  double min_step = 1;
  for (int search = 0; search < kMaxBytesSearches; ++search) {
    double target = 0;
    if (above) {
      const double width = above->target - below->target;
      if (width < kBytesTargetResolutionDb) break;
      target = below->target + width / 2;
      if (std::isfinite(above->bytes) && above->bytes > below->bytes) {
        target = below->target + width * (log_budget - std::log2(below->bytes)) /
                                     (std::log2(above->bytes) - std::log2(below->bytes));
      }
      target = std::clamp(target, below->target + width / 10, above->target - width / 10);
    } else {
      double slope = kDbPerDoubling;
      if (below_before && below->bytes > below_before->bytes && below->psnr > below_before->psnr) {
        slope = (below->psnr - below_before->psnr) / std::log2(below->bytes / below_before->bytes);
      }
      target = std::max(below->psnr, below->target) +
               std::max(slope * (log_budget - std::log2(below->bytes)), min_step);
      min_step *= 2;
    }
    Result<std::vector<FitPoint>> searched = for_psnr(target, previous);
    Probe probe{target, std::numeric_limits<double>::infinity(), kNaN};  // failed: above what the finest reaches
    if (!searched.ok()) {
      if (searched.status().code() != StatusCode::kInvalidArgument) return std::move(searched).status();
    } else {
      previous = std::move(searched).value();
      probe.bytes = double(previous.back().bytes);
      probe.psnr = previous.back().psnr_mean_db;
    }
    probes_.push_back(probe);
    if (probe.bytes <= double(budget)) {
      below_before = below;
      below = probe;
    } else {
      above = probe;
    }
    report_progress("searching", m_.best_within());
  }
  RGS_RETURN_IF_ERROR(fill_for_bytes(budget));
  report_step("filled", m_.best_within());
  return *m_.best_within();
}

Status Search::fill_for_bytes(uint64_t budget) {
  std::vector<bool> frozen(knobs_.size(), false);
  for (int round = 0; round < kMaxRounds; ++round) {
    const FitPoint at = *m_.best_within();
    std::vector<format::ArchiveOptions> list;
    std::vector<size_t> knob_of;
    next_steps(knobs_, at.options, false, &frozen, &list, &knob_of);
    if (list.empty()) break;
    // Bytes first: only the steps that fit are rendered.
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> sizes, m_.bytes(list));
    std::vector<format::ArchiveOptions> fitting;
    std::vector<size_t> fitting_knob;
    for (size_t i = 0; i < sizes.size(); ++i) {
      if (sizes[i].bytes <= budget) {
        fitting.push_back(list[i]);
        fitting_knob.push_back(knob_of[i]);
      } else {
        frozen[knob_of[i]] = true;
      }
    }
    if (fitting.empty()) break;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(fitting));
    for (size_t i = 0; i < points.size(); ++i) {
      if (!(points[i].psnr_mean_db > at.psnr_mean_db)) frozen[fitting_knob[i]] = true;  // no better for its bytes
    }
    if (!(m_.best_within()->psnr_mean_db > at.psnr_mean_db)) break;
    report_progress("refining", m_.best_within());
  }
  return Status();
}

void Search::next_steps(const std::vector<Knob>& knobs, const format::ArchiveOptions& at, bool coarser,
                        std::vector<bool>* frozen, std::vector<format::ArchiveOptions>* list,
                        std::vector<size_t>* knob_of) {
  for (size_t k = 0; k < knobs.size(); ++k) {
    if ((*frozen)[k]) continue;
    if (auto o = step(at, knobs[k], coarser)) {
      list->push_back(*o);
      knob_of->push_back(k);
    } else {
      (*frozen)[k] = true;
    }
  }
}

std::vector<Search::Move> Search::passing_moves(const FitPoint& at, const std::vector<FitPoint>& points,
                                                const std::vector<size_t>& knob_of, double target,
                                                std::vector<bool>* frozen) {
  std::vector<Move> moves;
  for (size_t i = 0; i < points.size(); ++i) {
    const FitPoint& p = points[i];
    if (!(p.psnr_mean_db >= target) || p.bytes >= at.bytes) {
      (*frozen)[knob_of[i]] = true;
      continue;
    }
    const double added = std::max(mse_of(p.psnr_mean_db) - mse_of(at.psnr_mean_db), 0.0);
    moves.push_back({i, added, double(at.bytes - p.bytes) / std::max(added, 1e-30)});
  }
  std::stable_sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) { return a.ratio > b.ratio; });
  return moves;
}

void Search::note_finest(const FitPoint& p) {
  if (!finest_ || p.bytes > finest_->bytes) finest_ = p;
}

void Search::report_progress(const char* stage, const std::optional<FitPoint>& best, uint32_t steps) {
  std::string line = std::string(stage) + ": " + std::to_string(m_.encodings()) + " archives encoded, " +
                     std::to_string(m_.renders()) + " rendered";
  if (best) line += "; at " + db_text(best->psnr_mean_db) + ", " + group_digits(best->bytes) + " bytes";
  report(line, steps);
}

}  // namespace rgs::api::detail
