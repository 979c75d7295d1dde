// The server's TCP connections outside a client slot (HTTP requests, upgrades being refused): a total bound and a
// bound per remote address, where a new connection over either bound takes the place of the one that has waited
// longest for its request header, so idle connections cannot lock clients out (view/PROTOCOL.md "Transport and
// security").
#pragma once

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace rgs::view::detail {

/// The connections outside a client slot, by id, with their remote address and whether they wait for a request
/// header. Thread-safe.
class ConnectionTable {
 public:
  /// Closes a connection from outside (posts the close to its strand); called without the table's lock held.
  using Close = std::function<void()>;

  /// At most `total` connections, at most `per_peer` from one address (1 ≤ per_peer ≤ total).
  ConnectionTable(uint32_t total, uint32_t per_peer);

  /// Admits a new connection from `peer` (its address as text), waiting for its first request header. Over a
  /// bound, the connection of that peer (when the peer is at its bound), or else of any peer, that has waited
  /// longest for a request header leaves the table and its Close comes back in `*evicted`, to be called.
  /// @return the connection's id (never 0), or 0 when every connection over the bound is busy (answering a
  /// request or closing a WebSocket): the new one is refused.
  uint64_t admit(const std::string& peer, Close close, Close* evicted);
  /// Whether connection `id` is waiting for a request header (it may then be evicted) or busy.
  void set_waiting(uint64_t id, bool waiting);
  /// Connection `id` is closed, or holds a client slot now (bounded by ServerOptions::max_clients instead).
  /// Ids no longer in the table (evicted) are ignored.
  void remove(uint64_t id);

  size_t size() const;
  size_t count(const std::string& peer) const;

 private:
  struct Entry {
    uint64_t id = 0;
    std::string peer;
    bool waiting = true;
    uint64_t waiting_since = 0;  ///< value of clock_ when it started waiting: the smallest has waited longest
    Close close;
  };
  /// The waiting entry with the smallest waiting_since, of `peer` (or of anyone when null); end() if none.
  std::vector<Entry>::iterator longest_waiting(const std::string* peer);
  size_t count_locked(const std::string& peer) const;

  const uint32_t total_, per_peer_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;
  uint64_t next_id_ = 1, clock_ = 0;
};

/// A connection's place in a ConnectionTable, given back when destroyed (or released earlier). Move-only.
class ConnectionTicket {
 public:
  ConnectionTicket() = default;
  ConnectionTicket(ConnectionTable* table, uint64_t id) : table_(table), id_(id) {}
  ConnectionTicket(ConnectionTicket&& other) noexcept : table_(other.table_), id_(other.id_) { other.table_ = nullptr; }
  ConnectionTicket& operator=(ConnectionTicket&& other) noexcept;
  ConnectionTicket(const ConnectionTicket&) = delete;
  ConnectionTicket& operator=(const ConnectionTicket&) = delete;
  ~ConnectionTicket() { release(); }

  void set_waiting(bool waiting) const {
    if (table_ != nullptr) table_->set_waiting(id_, waiting);
  }
  void release();

 private:
  ConnectionTable* table_ = nullptr;
  uint64_t id_ = 0;
};

}  // namespace rgs::view::detail
