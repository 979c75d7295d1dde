// The frame memory budget: a byte count shared by every client's pipeline, and the estimate of a frame's bytes.
#include <algorithm>
#include <cmath>

#include "internal_frame_budget.h"

namespace rgs::view::detail {

namespace {

// Bytes a pixel (see frame_memory_bytes).
constexpr double kRgbaBytesPerPixel = 4;
constexpr double kCpuPlanesBytesPerPixel = 20;  // runtime::render_cpu: rgb, alpha and depth as float
constexpr double kHeatmapBytesPerPixel = 3;

struct EncoderBytes {
  double working, output;
};

EncoderBytes encoder_bytes(Encoding encoding) {
  switch (encoding) {
    case Encoding::kJpeg: return {9.2, 4.2};  // tjCompress2's output buffers, the strips' copies; 4:4:4 at q 100
    case Encoding::kWebp: return {2, 1.5};      // the YUV picture and the encoder's rows
    case Encoding::kLossless: return {29, 3.1};  // ARGB picture, hash chains and backward references
  }
  return {29, 4.2};
}

}  // namespace

Charge& Charge::operator=(Charge&& other) noexcept {
  if (this != &other) {
    reset();
    budget_ = other.budget_;
    bytes_ = other.bytes_;
    other.bytes_ = 0;
  }
  return *this;
}

Charge Charge::split(uint64_t bytes) {
  bytes = std::min(bytes, bytes_);
  bytes_ -= bytes;
  return Charge(budget_, bytes);
}

void Charge::absorb(Charge&& other) {
  if (other.bytes_ == 0) return;
  if (budget_ == nullptr) budget_ = other.budget_;
  bytes_ += other.bytes_;
  other.bytes_ = 0;
}

void Charge::reset() {
  if (bytes_ > 0) budget_->release(bytes_);
  bytes_ = 0;
}

std::optional<Charge> FrameBudget::acquire(uint64_t bytes, const std::atomic<bool>& interrupted) {
  if (bytes > capacity_) return std::nullopt;
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return interrupted.load() || held_ + bytes <= capacity_; });
  if (interrupted.load()) return Charge();
  held_ += bytes;
  peak_ = std::max(peak_, held_);
  return Charge(this, bytes);
}

std::optional<Charge> FrameBudget::try_acquire(uint64_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (held_ + bytes > capacity_) return std::nullopt;
  held_ += bytes;
  peak_ = std::max(peak_, held_);
  return Charge(this, bytes);
}

void FrameBudget::wake() {
  { std::lock_guard<std::mutex> lock(mutex_); }  // a waiter between its check and its wait sees the flag
  changed_.notify_all();
}

void FrameBudget::release(uint64_t bytes) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    held_ -= bytes;
  }
  changed_.notify_all();
}

uint64_t FrameBudget::held() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return held_;
}

uint64_t FrameBudget::peak() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return peak_;
}

uint64_t frame_memory_bytes(const ViewRequest& view, api::Device device) {
  const double pixels = double(view.camera.width) * double(view.camera.height);
  const int rendered = view.compare == CompareMode::kOff ? 1 : 2;
  const int encoded = view.compare == CompareMode::kSplit ? 2 : 1;
  const EncoderBytes encoder = encoder_bytes(view.encoding);
  double per_pixel = rendered * kRgbaBytesPerPixel + encoder.working + 2 * encoded * encoder.output;
  if (view.compare == CompareMode::kDiff) per_pixel += kHeatmapBytesPerPixel;
  return uint64_t(std::ceil(pixels * per_pixel)) + render_scratch_bytes(view, device);
}

uint64_t render_scratch_bytes(const ViewRequest& view, api::Device device) {
  if (device != api::Device::kCpu) return 0;
  return uint64_t(std::ceil(double(view.camera.width) * double(view.camera.height) * kCpuPlanesBytesPerPixel));
}

}  // namespace rgs::view::detail
