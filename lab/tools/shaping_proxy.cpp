// A shaping TCP relay for rgs-view-bench (shaping_proxy.h).
#include "shaping_proxy.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

namespace rgs::lab {

namespace {

using Clock = std::chrono::steady_clock;

// Bytes read at once: 0.65 ms of a 50 Mbit/s link.
constexpr size_t kChunkBytes = 4096;

/// A chunk on the link and when it leaves it; no bytes: the sender closed its side.
struct Chunk {
  std::vector<uint8_t> bytes;
  Clock::time_point due;
};

/// One direction: `from` is read into the link, the link is written to `to`.
struct Link {
  int from = -1, to = -1;
  double bytes_per_s = 0;
  Clock::duration delay{};
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<Chunk> queue;
  size_t queued = 0;
  Clock::time_point free_at{};
  bool stop = false;
  std::thread reader, writer;

  void read_loop() {
    for (;;) {
      std::vector<uint8_t> bytes(kChunkBytes);
      const ssize_t n = ::recv(from, bytes.data(), bytes.size(), 0);
      bytes.resize(n > 0 ? size_t(n) : 0);
      std::unique_lock<std::mutex> lock(mutex);
      changed.wait(lock, [&] { return stop || queued == 0 || queued + bytes.size() <= ShapingProxy::kQueueBytes; });
      if (stop) return;
      // The chunk enters the link now, or when the link has sent what is ahead of it.
      free_at = std::max(Clock::now(), free_at) +
                std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(double(bytes.size()) /
                                                                                          bytes_per_s));
      queued += bytes.size();
      const bool end = bytes.empty();
      queue.push_back({std::move(bytes), free_at + delay});
      changed.notify_all();
      if (end) return;
    }
  }

  void write_loop() {
    for (;;) {
      Chunk chunk;
      {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] { return stop || !queue.empty(); });
        if (stop) return;
        chunk = std::move(queue.front());
        queue.pop_front();
        if (changed.wait_until(lock, chunk.due, [&] { return stop; })) return;
      }
      if (chunk.bytes.empty()) {
        ::shutdown(to, SHUT_WR);
        return;
      }
      for (size_t at = 0; at < chunk.bytes.size();) {
        const ssize_t n = ::send(to, chunk.bytes.data() + at, chunk.bytes.size() - at, MSG_NOSIGNAL);
        if (n <= 0) return;
        at += size_t(n);
      }
      std::lock_guard<std::mutex> lock(mutex);
      queued -= chunk.bytes.size();
      changed.notify_all();
    }
  }

  void halt() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
    }
    changed.notify_all();
    if (reader.joinable()) reader.join();
    if (writer.joinable()) writer.join();
  }
};

int connect_to(const std::string& host, const std::string& port) {
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0) return -1;
  int fd = -1;
  for (addrinfo* a = found; a && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (fd >= 0 && ::connect(fd, a->ai_addr, a->ai_addrlen) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  return fd;
}

}  // namespace

struct ShapingProxy::Impl {
  int listener = -1, client = -1, server = -1;
  uint16_t port = 0;
  std::string host, server_port;
  Link up, down;  // client → server, server → client
  std::thread acceptor;

  void serve() {
    client = ::accept(listener, nullptr, nullptr);
    if (client < 0) return;
    server = connect_to(host, server_port);
    if (server < 0) {
      ::shutdown(client, SHUT_RDWR);
      return;
    }
    const int one = 1;
    for (int fd : {client, server}) ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    up.from = down.to = client;
    up.to = down.from = server;
    for (Link* link : {&up, &down}) {
      link->reader = std::thread([link] { link->read_loop(); });
      link->writer = std::thread([link] { link->write_loop(); });
    }
  }
};

Result<std::unique_ptr<ShapingProxy>> ShapingProxy::start(const std::string& host, const std::string& port,
                                                          double mbps, double rtt_ms) {
  RGS_RETURN_ERROR_IF(!(mbps > 0 && mbps <= 1e6 && rtt_ms >= 0 && rtt_ms <= 1e5), StatusCode::kInvalidArgument,
                      "shaping: the rate must be in (0, 1e6] Mbit/s and the round trip in [0, 1e5] ms");
  auto impl = std::make_unique<Impl>();
  impl->host = host;
  impl->server_port = port;
  for (Link* link : {&impl->up, &impl->down}) {
    link->bytes_per_s = mbps * 1e6 / 8;
    link->delay = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(rtt_ms / 2));
  }
  impl->listener = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  RGS_RETURN_ERROR_IF(impl->listener < 0 || ::bind(impl->listener, (sockaddr*)&address, sizeof address) != 0 ||
                          ::listen(impl->listener, 1) != 0 ||
                          ::getsockname(impl->listener, (sockaddr*)&address, &length) != 0,
                      StatusCode::kIoError, "shaping: cannot listen on 127.0.0.1");
  impl->port = ntohs(address.sin_port);
  Impl* raw = impl.get();
  impl->acceptor = std::thread([raw] { raw->serve(); });
  return std::unique_ptr<ShapingProxy>(new ShapingProxy(std::move(impl)));
}

ShapingProxy::ShapingProxy(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

ShapingProxy::~ShapingProxy() {
  ::shutdown(impl_->listener, SHUT_RDWR);
  impl_->acceptor.join();
  for (int fd : {impl_->client, impl_->server}) {
    if (fd >= 0) ::shutdown(fd, SHUT_RDWR);
  }
  impl_->up.halt();
  impl_->down.halt();
  for (int fd : {impl_->listener, impl_->client, impl_->server}) {
    if (fd >= 0) ::close(fd);
  }
}

uint16_t ShapingProxy::port() const { return impl_->port; }

}  // namespace rgs::lab
