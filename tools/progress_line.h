// A progress line on the terminal for the tools' long operations: a conversion's stages
// (api::ConvertOptions::progress) drawn in place on stderr, with the estimated time left.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "rgs/api/convert.h"

namespace rgs::tools {

/// `seconds` in words for a progress line: "<1 s", "7 s", "2 min 05 s", "1 h 02 min".
std::string duration_text(double seconds);

/// One progress line's text: "<stage> <percent>%", the percent rounded down (so 100% only when done; a
/// fraction outside [0, 1] is clamped), then ", about <duration_text> left" when `seconds_left` is given.
std::string progress_text(std::string_view stage, double fraction, std::optional<double> seconds_left);

/// The time left when `fraction` of the work was done after `reported_s` seconds and `elapsed_s` seconds
/// have passed: reported_s * (1 - fraction) / fraction - (elapsed_s - reported_s). None before any work is
/// done or once that estimate has run out.
std::optional<double> seconds_left(double fraction, double reported_s, double elapsed_s);

/// Whether stderr is a terminal (isatty): the only place a line redrawn with carriage returns makes sense.
bool stderr_is_terminal();

/// Draws a conversion's progress as "\r<tool>: <progress_text>" on `out`, each drawing overwriting the last
/// (padded with spaces over a longer previous line), when enabled: rgs-convert enables it unless -q and only
/// when stderr is a terminal. Nothing is drawn during the first `delay_s` seconds, so quick runs show
/// nothing. With `redraw`, a thread of its own redraws the line 4 times a second so that the time left
/// counts down between updates. Stage "done" (fraction 1), clear() and the destructor blank the line and
/// return to its start. Thread safety: update() and clear() may be called from any one thread.
class ProgressLine {
 public:
  ProgressLine(std::FILE* out, std::string tool, bool enabled, double delay_s = 1.0, bool redraw = true);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  /// Takes `progress` as of now and draws it.
  void update(const api::ConvertProgress& progress);
  /// Takes `progress` as of `elapsed_s` seconds after construction and draws it (for tests: no clock).
  void update(const api::ConvertProgress& progress, double elapsed_s);
  /// Blanks the line if one was drawn; nothing is drawn after it.
  void clear();

 private:
  double elapsed() const;
  void draw(double elapsed_s);  ///< with mutex_ held
  void redraw_loop();

  std::FILE* out_;
  std::string tool_;
  bool enabled_;
  double delay_s_;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopped_ = false;
  std::string stage_;
  double fraction_ = 0, reported_s_ = 0;
  bool have_progress_ = false;
  size_t drawn_ = 0;  ///< characters of the line now shown (0: none)
  std::thread redrawer_;
};

}  // namespace rgs::tools
