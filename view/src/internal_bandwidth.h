// A client's bandwidth budget (rgs-view --max-mbps, the view's "max_mbps"): the JPEG/WebP quality and, while the
// camera moves, the resolution scale of its next frame (view/PROTOCOL.md "Bandwidth budget").
#pragma once

#include <algorithm>
#include <cstdint>

#include "rgs/view/protocol.h"

namespace rgs::view::detail {

/// What a frame is encoded and rendered with.
struct RateChoice {
  int quality = 85;    ///< 1..100, at most the view's
  double scale = 1.0;  ///< 1, 0.75 or 0.5 of the view's width and height
  bool limited = false;  ///< chosen under the budget (a moving view): the frame is paced
};

/// The budget in Mbit/s a client's view gets: the smaller of the server's and the view's, a 0 being none.
double effective_mbps(double server_mbps, double view_mbps);

/// `view` rendered with `choice`: width and height scaled (rounded, at least 1), fx and fy with them, quality set.
ViewRequest apply_rate(const ViewRequest& view, const RateChoice& choice);

/// The control law of one client's frames (view/PROTOCOL.md "Bandwidth budget", where its steps are stated);
/// deterministic, not thread-safe (the pipeline calls it under its lock). A frame of b bytes takes b/B seconds of a
/// budget B; I is the interval between frames handed over, c = I − b/B the rest of the client's loop; a moving
/// frame may take τ = min(I, max(1/kHoldFps − c, kMinShare/kHoldFps)) seconds; its size is predicted as
/// k · pixels · scale² · jpeg_size_factor(q) with k learnt from the frames sent; frames are paced (wait_s) when
/// even the smallest choice is over.
class RateControl {
 public:
  static constexpr double kHoldFps = 30;        ///< the frame rate a moving view is given room for
  static constexpr double kMinShare = 0.25;      ///< the least share of 1/kHoldFps a frame may take on the link
  static constexpr double kPauseS = 1.0;         ///< a longer interval between frames is a pause, not a rate
  static constexpr int kKneeQuality = 60;        ///< the lowest quality before the frame is made smaller
  static constexpr int kMinQuality = 30;         ///< the lowest quality at half size
  static constexpr double kRaiseMargin = 0.8;    ///< a larger scale is taken back only within 0.8 of the target

  /// The next frame's quality and scale for `view` under a budget of `mbps` (0: none); a `still` view, a lossless
  /// one or one without a budget keeps its size and quality.
  RateChoice choose(double mbps, const ViewRequest& view, bool still);
  /// A frame of `bytes` handed over at `now_s` (seconds, any steady origin), encoded from `pixels` rendered
  /// pixels at `quality` (`lossy`: JPEG or WebP; a lossless frame counts for the timing only) under a budget of
  /// `paced_mbps` (0: none, or a still frame).
  void record(uint64_t bytes, uint64_t pixels, int quality, bool lossy, double paced_mbps, double now_s);
  /// How long the next frame must wait at `now_s` before it is handed over (0 or more seconds).
  double wait_s(double now_s) const { return std::max(0.0, paced_until_s_ - now_s); }

  /// Relative size of a JPEG at `quality`: libjpeg's quantizer scale S (5000/q below 50, 200 − 2q from 50) to the
  /// power −1/2 (S at least 2.5), × 1.4 from 90 (4:4:4 chroma). 1/√30 at 85.
  static double jpeg_size_factor(int quality);

 private:
  double bytes_per_unit_ = 0;  ///< k; 0 before the first lossy frame
  double interval_s_ = 0, fixed_s_ = 0;  ///< I and c; 0 before the first interval
  double last_sent_s_ = -1, last_bytes_ = 0;
  double budget_bps_ = 0;  ///< B of the last frame recorded, bytes/s
  double last_scale_ = 1;  ///< of the last choice
  double paced_until_s_ = 0;
};

}  // namespace rgs::view::detail
