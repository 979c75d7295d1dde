// Rate control's search: the ladder, rounds of one-knob steps, scans, exchanges and code steps for a PSNR target,
// and the descent and trades between knobs for a byte budget (search.h).
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
    next_steps(knobs_, at.options, &frozen, &list, &knob_of);
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
    next_steps(steps, at.options, &frozen, &list, &knob_of);
    if (list.empty()) break;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
    const std::vector<Move> moves = passing_moves(at, points, knob_of, target, &frozen);
    if (moves.empty()) break;
    path->push_back(points[moves[0].index]);
    report_progress("filling", path->back());
  }
  return Status();
}

Result<FitPoint> Search::descend(uint64_t budget) {
  m_.watch_budget(budget);
  if (!m_.best_within()) {
    RGS_ASSIGN_OR_RETURN(const FitPoint start, ladder_for_bytes(budget));
    report_step("ladder", start);
    RGS_RETURN_IF_ERROR(descend_for_bytes(budget, start));
    // The descent's measurements ran out above the budget: the smallest archive fits (ladder_for_bytes).
    if (!m_.best_within()) RGS_RETURN_IF_ERROR(m_.measure({smallest_archive()}).status());
  }
  return *m_.best_within();
}

Result<FitPoint> Search::for_bytes(uint64_t budget, bool measure_all) {
  const FitSteps steps_of_search = part(kBytesSearchSteps);
  RGS_RETURN_IF_ERROR(descend(budget).status());
  for (int round = 0; round < kMaxRounds; ++round) {
    RGS_ASSIGN_OR_RETURN(const bool kept_steps_traded, trade_for_bytes(budget, false));
    bool traded = kept_steps_traded;
    if (!traded && measure_all) {
      RGS_ASSIGN_OR_RETURN(traded, trade_for_bytes(budget, true));
    }
    report_step("trading", m_.best_within());
    if (!traded) break;
  }
  return *m_.best_within();
}

format::ArchiveOptions Search::smallest_archive() const {
  format::ArchiveOptions o = ladder(anchor_, kLadderCoarsest);
  o.opacity_floor = kMaxOpacityFloor;
  o.rotation_step = o.scale_step = o.opacity_step = kMaxCodeStep;
  return o;
}

Result<FitPoint> Search::ladder_for_bytes(uint64_t budget) {
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> coarsest,
                       m_.bytes({ladder(anchor_, kLadderCoarsest), smallest_archive()}));
  if (coarsest[1].bytes > budget) {
    return Status(StatusCode::kInvalidArgument,
                  group_digits(budget) + " bytes is below the smallest archive the search makes: " +
                      group_digits(coarsest[1].bytes) + " bytes at the coarsest settings (" +
                      describe_archive_options(coarsest[1].options, sh_degree_) + ")");
  }
  // Bisect the finest q whose archive fits the room, by bytes alone; the coarsest when none does.
  const auto room = uint64_t(double(budget) * kDescentRoom);
  double lo = kLadderFinest, hi = kLadderCoarsest;  // invariant: hi fits the room (or is the coarsest)
  FitPoint start = coarsest[0];
  while (coarsest[0].bytes <= room && hi - lo > 0.125) {
    const double mid = (lo + hi) / 2;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> p, m_.bytes({ladder(anchor_, mid)}));
    if (p[0].bytes <= room) {
      hi = mid;
      start = p[0];
    } else {
      lo = mid;
    }
  }
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> measured, m_.measure({start.options}));
  return measured[0];
}

Status Search::descend_for_bytes(uint64_t budget, FitPoint at) {
  const std::vector<Knob>& knobs = byte_knobs_;
  // Each knob's coarser step: its bytes saved per squared error added where it was last measured (+inf before it
  // is, -inf when it saves nothing), and its archive while `at` is where it was measured (fresh).
  std::vector<double> ratio(knobs.size(), kInf);
  std::vector<std::optional<FitPoint>> fresh(knobs.size());
  for (int measured = 0; at.bytes > budget && measured < kMaxDescentMeasures;) {
    const size_t best = size_t(std::max_element(ratio.begin(), ratio.end()) - ratio.begin());
    if (!(ratio[best] > -kInf)) break;  // no knob has a coarser step that saves bytes
    std::optional<size_t> best_fresh;
    for (size_t k = 0; k < knobs.size(); ++k) {
      if (fresh[k] && (!best_fresh || ratio[k] > ratio[*best_fresh])) best_fresh = k;
    }
    if (best_fresh && ratio[*best_fresh] >= kDescentTolerance * ratio[best]) {
      at = *fresh[*best_fresh];
      for (auto& f : fresh) f.reset();
      report_progress("descending", at);
      continue;
    }
    ++measured;
    const std::optional<format::ArchiveOptions> o = step(at.options, knobs[best], true);
    if (!o) {
      ratio[best] = -kInf;
      continue;
    }
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> p, m_.measure({*o}));
    const double added = std::max(mse_of(p[0].psnr_mean_db) - mse_of(at.psnr_mean_db), 1e-30);
    ratio[best] = p[0].bytes < at.bytes ? double(at.bytes - p[0].bytes) / added : -kInf;
    fresh[best] = p[0];
  }
  return Status();
}

Result<bool> Search::trade_for_bytes(uint64_t budget, bool measure_all) {
  const FitPoint at = *m_.best_within();
  const double mse_at = mse_of(at.psnr_mean_db);
  const std::vector<Knob>& knobs = byte_knobs_;
  // The steps of a knob that moved since they were measured (all, with measure_all) are measured here, both ways;
  // the others' are kept from where they were measured (steps of different knobs roughly add).
  std::vector<format::ArchiveOptions> list;
  for (size_t k = 0; k < knobs.size(); ++k) {
    const double value = knob_value(at.options, knobs[k]);
    const auto of_knob = [&](const TradeStep& t) { return t.knob == k; };
    const bool kept = !measure_all && std::any_of(trade_steps_.begin(), trade_steps_.end(), [&](const TradeStep& t) {
      return of_knob(t) && t.from == value;
    });
    if (kept) continue;
    trade_steps_.erase(std::remove_if(trade_steps_.begin(), trade_steps_.end(), of_knob), trade_steps_.end());
    for (bool coarser : {true, false}) {
      if (auto o = step(at.options, knobs[k], coarser)) {
        list.push_back(*o);
        trade_steps_.push_back({k, coarser, value, 0, 0});
      }
    }
  }
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
  const size_t first = trade_steps_.size() - points.size();  // the steps measured here, last
  for (size_t i = 0; i < points.size(); ++i) {
    trade_steps_[first + i].added_mse = mse_of(points[i].psnr_mean_db) - mse_at;
    trade_steps_[first + i].added_bytes = double(points[i].bytes) - double(at.bytes);
  }
  // Of the combinations of at most one step a knob, the kTradeCombinations predicted lowest in error among those
  // predicted within the budget (steps measured alone here are measured already).
  std::vector<std::vector<const TradeStep*>> by_knob(knobs.size());
  for (const TradeStep& t : trade_steps_) {
    if (step(at.options, knobs[t.knob], t.coarser)) by_knob[t.knob].push_back(&t);
  }
  struct Combination {
    double mse, bytes;
    std::vector<const TradeStep*> steps;
  };
  std::vector<Combination> best;
  Combination now{mse_at, double(at.bytes), {}};
  const size_t fewest = first == 0 ? 2 : 1;
  const auto enumerate = [&](const auto& self, size_t k) -> void {
    if (k == knobs.size()) {
      if (now.steps.size() < fewest || now.bytes > double(budget) || !(now.mse < mse_at)) return;
      best.push_back(now);
      std::stable_sort(best.begin(), best.end(), [](const auto& a, const auto& b) { return a.mse < b.mse; });
      if (best.size() > kTradeCombinations) best.pop_back();
      return;
    }
    self(self, k + 1);
    for (const TradeStep* t : by_knob[k]) {
      now.mse += t->added_mse, now.bytes += t->added_bytes;
      now.steps.push_back(t);
      self(self, k + 1);
      now.mse -= t->added_mse, now.bytes -= t->added_bytes;
      now.steps.pop_back();
    }
  };
  enumerate(enumerate, 0);
  list.clear();
  for (const Combination& c : best) {
    format::ArchiveOptions o = at.options;
    for (const TradeStep* t : c.steps) o = *step(o, knobs[t->knob], t->coarser);
    list.push_back(o);
  }
  // Bytes first: only the combinations that fit are rendered.
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> sizes, m_.bytes(list));
  std::vector<format::ArchiveOptions> fitting;
  for (const FitPoint& p : sizes) {
    if (p.bytes <= budget) fitting.push_back(p.options);
  }
  RGS_RETURN_IF_ERROR(m_.measure(fitting).status());
  return m_.best_within()->psnr_mean_db > at.psnr_mean_db;
}

void Search::next_steps(const std::vector<Knob>& knobs, const format::ArchiveOptions& at, std::vector<bool>* frozen,
                        std::vector<format::ArchiveOptions>* list, std::vector<size_t>* knob_of) {
  for (size_t k = 0; k < knobs.size(); ++k) {
    if ((*frozen)[k]) continue;
    if (auto o = step(at, knobs[k], true)) {
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
