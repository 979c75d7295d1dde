// A TCP relay on 127.0.0.1 that shapes the connection through it like a link of a given rate and round trip, for
// rgs-view-bench --shape-mbps/--shape-rtt-ms (docs/VIEWER.md "Bandwidth budget").
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "rgs/format/status.h"

namespace rgs::lab {

/// Relays the first connection made to port() to `host`:`port`. Each direction is a link of `mbps` Mbit/s with a
/// one-way delay of rtt_ms / 2: a chunk read at t leaves the link at max(t, when the link is free) + bytes / rate
/// + delay (serialization and propagation overlap, as on a wire; no burst), and at most kQueueBytes wait in each
/// direction (more stays in the sender's socket, whose writes then block, as behind a real bottleneck). One
/// reader and one writer thread per direction. Destroying it closes both connections and joins its threads.
class ShapingProxy {
 public:
  static constexpr size_t kQueueBytes = 1 << 20;

  /// Listens on 127.0.0.1 (any free port); `mbps` > 0, `rtt_ms` ≥ 0.
  /// @return kIoError (socket, bind or listen failed), kInvalidArgument (rate or delay out of range).
  static Result<std::unique_ptr<ShapingProxy>> start(const std::string& host, const std::string& port, double mbps,
                                                     double rtt_ms);
  ~ShapingProxy();
  uint16_t port() const;

  struct Impl;

 private:
  explicit ShapingProxy(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rgs::lab
