// The table of connections outside a client slot: bounds in total and per remote address, eviction of the
// connection that has waited longest for its request header.
#include <algorithm>

#include "internal_connections.h"

namespace rgs::view::detail {

ConnectionTable::ConnectionTable(uint32_t total, uint32_t per_peer) : total_(total), per_peer_(per_peer) {}

std::vector<ConnectionTable::Entry>::iterator ConnectionTable::longest_waiting(const std::string* peer) {
  auto best = entries_.end();
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (!it->waiting || (peer != nullptr && it->peer != *peer)) continue;
    if (best == entries_.end() || it->waiting_since < best->waiting_since) best = it;
  }
  return best;
}

uint64_t ConnectionTable::admit(const std::string& peer, Close close, Close* evicted) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool peer_full = count_locked(peer) >= per_peer_;
  if (peer_full || entries_.size() >= total_) {
    const auto victim = longest_waiting(peer_full ? &peer : nullptr);
    if (victim == entries_.end()) return 0;
    *evicted = std::move(victim->close);
    entries_.erase(victim);
  }
  Entry entry;
  entry.id = next_id_++;
  entry.peer = peer;
  entry.waiting_since = ++clock_;
  entry.close = std::move(close);
  entries_.push_back(std::move(entry));
  return entries_.back().id;
}

void ConnectionTable::set_waiting(uint64_t id, bool waiting) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& entry : entries_) {
    if (entry.id != id) continue;
    if (waiting && !entry.waiting) entry.waiting_since = ++clock_;
    entry.waiting = waiting;
    return;
  }
}

void ConnectionTable::remove(uint64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.erase(std::remove_if(entries_.begin(), entries_.end(), [id](const Entry& e) { return e.id == id; }),
                 entries_.end());
}

size_t ConnectionTable::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

size_t ConnectionTable::count(const std::string& peer) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_locked(peer);
}

size_t ConnectionTable::count_locked(const std::string& peer) const {
  return size_t(std::count_if(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.peer == peer; }));
}

ConnectionTicket& ConnectionTicket::operator=(ConnectionTicket&& other) noexcept {
  if (this != &other) {
    release();
    table_ = other.table_;
    id_ = other.id_;
    other.table_ = nullptr;
  }
  return *this;
}

void ConnectionTicket::release() {
  if (table_ != nullptr) table_->remove(id_);
  table_ = nullptr;
}

}  // namespace rgs::view::detail
