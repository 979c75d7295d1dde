// The server's frame memory: one byte budget that every client's frames draw from, from the buffers a frame is
// rendered into to its encoded message being sent (view/PROTOCOL.md "Flow control and memory").
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>

#include "rgs/api/scene.h"
#include "rgs/view/protocol.h"

namespace rgs::view::detail {

class FrameBudget;

/// Bytes held from a FrameBudget, given back when destroyed. Move-only; an empty Charge holds nothing.
class Charge {
 public:
  Charge() = default;
  Charge(Charge&& other) noexcept : budget_(other.budget_), bytes_(other.bytes_) { other.bytes_ = 0; }
  Charge& operator=(Charge&& other) noexcept;
  Charge(const Charge&) = delete;
  Charge& operator=(const Charge&) = delete;
  ~Charge() { reset(); }

  uint64_t bytes() const { return bytes_; }
  /// Moves `bytes` (at most what this holds) into a new Charge.
  Charge split(uint64_t bytes);
  /// Takes over what `other` holds (from the same budget).
  void absorb(Charge&& other);
  /// Gives back everything.
  void reset();

 private:
  friend class FrameBudget;
  Charge(FrameBudget* budget, uint64_t bytes) : budget_(budget), bytes_(bytes) {}
  FrameBudget* budget_ = nullptr;
  uint64_t bytes_ = 0;
};

/// A byte budget shared by threads. acquire() waits while the bytes do not fit next to those held; nothing is
/// ever granted beyond the capacity. Thread-safe; it must outlive its Charges.
class FrameBudget {
 public:
  explicit FrameBudget(uint64_t capacity) : capacity_(capacity) {}

  /// Holds `bytes` once they fit, or returns nullopt at once when `bytes` exceeds the capacity, and an empty
  /// Charge when `interrupted` is (or becomes, followed by wake()) true first.
  std::optional<Charge> acquire(uint64_t bytes, const std::atomic<bool>& interrupted);
  /// Holds `bytes` if they fit now.
  std::optional<Charge> try_acquire(uint64_t bytes);
  /// Makes waiting acquire() calls look at their `interrupted` flag again.
  void wake();

  uint64_t capacity() const { return capacity_; }
  uint64_t held() const;
  /// The most bytes held at once since the budget was made.
  uint64_t peak() const;

 private:
  friend class Charge;
  void release(uint64_t bytes);

  const uint64_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  uint64_t held_ = 0, peak_ = 0;
};

/// Host bytes a frame of `view` may hold from its render to its send, the unit the budget is drawn in: per image
/// rendered its 8-bit RGBA buffer (4 bytes a pixel); on the CPU backend the renderer's float planes (20 bytes a
/// pixel, one image at a time); the compare heatmap (3 bytes a pixel); the encoder's working memory and, twice
/// (the images and the assembled message), its output per image, by encoding: JPEG 9.2 + 4.2 (the measured 5 of
/// libturbojpeg's buffers plus, in strips, a copy of the output before the join), lossy WebP 2 + 1.5,
/// lossless WebP 29 + 3.1 bytes a pixel (libturbojpeg and libwebp at the viewer's settings on noise images, their
/// worst case). What depends on the scene (the CPU renderer's Gaussian and pair arrays) is not counted.
uint64_t frame_memory_bytes(const ViewRequest& view, api::Device device);

/// The part of frame_memory_bytes that is free again once the frame is rendered: the CPU renderer's float planes
/// (0 on the GPU).
uint64_t render_scratch_bytes(const ViewRequest& view, api::Device device);

}  // namespace rgs::view::detail
