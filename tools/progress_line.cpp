#include "progress_line.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace rgs::tools {

std::string duration_text(double seconds) {
  if (!(seconds >= 1.0)) return "<1 s";  // NaN too
  const long total = static_cast<long>(std::round(std::min(seconds, 359999.0)));
  char text[32];
  if (total < 60) {
    std::snprintf(text, sizeof(text), "%ld s", total);
  } else if (total < 3600) {
    std::snprintf(text, sizeof(text), "%ld min %02ld s", total / 60, total % 60);
  } else {
    std::snprintf(text, sizeof(text), "%ld h %02ld min", total / 3600, (total % 3600) / 60);
  }
  return text;
}

std::string progress_text(std::string_view stage, double fraction, std::optional<double> left) {
  fraction = std::isnan(fraction) ? 0.0 : std::clamp(fraction, 0.0, 1.0);
  std::string text(stage);
  text += " " + std::to_string(static_cast<int>(std::floor(fraction * 100.0))) + "%";
  if (left) text += ", about " + duration_text(*left) + " left";
  return text;
}

std::optional<double> seconds_left(double fraction, double reported_s, double elapsed_s) {
  if (!(fraction > 0.0) || fraction > 1.0) return std::nullopt;
  const double left = reported_s * (1.0 - fraction) / fraction - (elapsed_s - reported_s);
  if (!(left >= 0.0)) return std::nullopt;
  return left;
}

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

ProgressLine::ProgressLine(std::FILE* out, std::string tool, bool enabled, double delay_s, bool redraw)
    : out_(out), tool_(std::move(tool)), enabled_(enabled), delay_s_(delay_s),
      start_(std::chrono::steady_clock::now()) {
  if (enabled_ && redraw) redrawer_ = std::thread([this] { redraw_loop(); });
}

ProgressLine::~ProgressLine() {
  clear();
  if (redrawer_.joinable()) redrawer_.join();
}

double ProgressLine::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressLine::update(const api::ConvertProgress& progress) { update(progress, elapsed()); }

void ProgressLine::update(const api::ConvertProgress& progress, double elapsed_s) {
  if (!enabled_) return;
  if (progress.fraction >= 1.0) {
    clear();
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  stage_ = progress.stage;
  fraction_ = progress.fraction;
  reported_s_ = elapsed_s;
  have_progress_ = true;
  draw(elapsed_s);
}

void ProgressLine::draw(double elapsed_s) {
  if (stopped_ || !have_progress_ || elapsed_s < delay_s_) return;
  const std::string line =
      tool_ + ": " + progress_text(stage_, fraction_, seconds_left(fraction_, reported_s_, elapsed_s));
  const size_t pad = drawn_ > line.size() ? drawn_ - line.size() : 0;
  std::fprintf(out_, "\r%s%*s", line.c_str(), static_cast<int>(pad), "");
  std::fflush(out_);
  drawn_ = line.size();
}

void ProgressLine::clear() {
  if (!enabled_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) return;
    stopped_ = true;
    if (drawn_ > 0) {
      std::fprintf(out_, "\r%*s\r", static_cast<int>(drawn_), "");
      std::fflush(out_);
      drawn_ = 0;
    }
  }
  wake_.notify_all();
}

void ProgressLine::redraw_loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopped_) {
    wake_.wait_for(lock, std::chrono::milliseconds(250));
    draw(elapsed());
  }
}

}  // namespace rgs::tools
