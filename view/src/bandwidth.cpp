// The bandwidth budget's control law (internal_bandwidth.h; view/PROTOCOL.md "Bandwidth budget").
#include <algorithm>
#include <cmath>

#include "internal_bandwidth.h"

namespace rgs::view::detail {

namespace {

// Weight of the newest measurement in the moving averages.
constexpr double kRecent = 0.25;

double average(double old, double now) { return old > 0 ? old + kRecent * (now - old) : now; }

}  // namespace

double effective_mbps(double server_mbps, double view_mbps) {
  if (server_mbps > 0 && view_mbps > 0) return std::min(server_mbps, view_mbps);
  return std::max(server_mbps, view_mbps);
}

ViewRequest apply_rate(const ViewRequest& view, const RateChoice& choice) {
  ViewRequest out = view;
  out.quality = choice.quality;
  if (choice.scale == 1.0) return out;
  InriaCamera& c = out.camera;
  const uint32_t w = std::max(1u, uint32_t(std::lround(c.width * choice.scale)));
  const uint32_t h = std::max(1u, uint32_t(std::lround(c.height * choice.scale)));
  c.fx *= double(w) / c.width;
  c.fy *= double(h) / c.height;
  c.width = w;
  c.height = h;
  return out;
}

double RateControl::jpeg_size_factor(int quality) {
  const double q = std::clamp(quality, 1, 100);
  const double s = std::max(q < 50 ? 5000.0 / q : 200.0 - 2.0 * q, 2.5);
  return (q >= 90 ? 1.4 : 1.0) / std::sqrt(s);
}

RateChoice RateControl::choose(double mbps, const ViewRequest& view, bool still) {
  RateChoice choice{view.quality, 1.0, false};
  const double budget_bps = mbps * 1e6 / 8;
  last_scale_ = 1;
  if (still || budget_bps <= 0 || view.encoding == Encoding::kLossless) return choice;
  choice.limited = true;
  if (bytes_per_unit_ <= 0) return choice;  // nothing known yet
  const double hold_s = 1 / kHoldFps;
  const double share_s = std::max(hold_s - fixed_s_, kMinShare * hold_s);
  const double target = budget_bps * (interval_s_ > 0 ? std::min(interval_s_, share_s) : share_s);
  const double pixels = double(view.camera.width) * view.camera.height;
  const auto fits = [&](int q, double scale) {
    const double allowed = scale > last_scale_ ? target * kRaiseMargin : target;
    return bytes_per_unit_ * pixels * scale * scale * jpeg_size_factor(q) <= allowed;
  };
  const int lowest = std::min(view.quality, kMinQuality);
  for (const double scale : {1.0, 0.75, 0.5}) {
    const int floor = scale == 0.5 ? lowest : std::min(view.quality, kKneeQuality);
    int q = view.quality;
    while (q > floor && !fits(q, scale)) --q;
    choice = {q, scale, true};
    if (fits(q, scale)) break;
  }
  last_scale_ = choice.scale;
  return choice;
}

void RateControl::record(uint64_t bytes, uint64_t pixels, int quality, bool lossy, double paced_mbps,
                         double now_s) {
  if (lossy && pixels > 0) {
    bytes_per_unit_ = average(bytes_per_unit_, double(bytes) / (double(pixels) * jpeg_size_factor(quality)));
  }
  const double interval = now_s - last_sent_s_;
  if (last_sent_s_ >= 0 && interval > 0 && interval <= kPauseS) {
    interval_s_ = average(interval_s_, interval);
    if (budget_bps_ > 0) fixed_s_ = average(fixed_s_, std::max(interval - last_bytes_ / budget_bps_, 1e-6));
  }
  budget_bps_ = paced_mbps * 1e6 / 8;
  paced_until_s_ = budget_bps_ > 0 ? now_s + double(bytes) / budget_bps_ : now_s;
  last_sent_s_ = now_s;
  last_bytes_ = double(bytes);
}

}  // namespace rgs::view::detail
