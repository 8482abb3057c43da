// GuardedHttpServer: an httplib::Server that slow clients cannot starve.
//   - Each connection gets a thread of its own from a pool larger than the connection cap, so no
//     connection waits in a queue behind others, and one over the cap is closed at once.
//   - Each request must arrive whole (head and body) within the receive deadline, counted from
//     its first byte's wait until its handler starts (mark_handler_started()); a slowloris that
//     dribbles a byte at a time, which httplib's per-read timeout never ends, is cut there. A slow
//     download of a large response is not: the deadline stops when the handler starts.
//   - One client (source address) holds at most max_connections_per_client of them, so a client
//     that keeps slow connections open cannot take every slot.
//   - A connection over either cap is not served: within a short deadline its request head is
//     read, a health probe is answered (200) and anything else gets 503 with Retry-After.
//   - Nothing a request does (an exception, memory running out) leaves the connection's thread:
//     the connection is closed and counted.
// It serves each connection itself (httplib's keep-alive loop over a Stream of its own that
// knows the deadline), with httplib's request parsing and routing unchanged. Workers keep a path
// of their own on a second server (ApiServer, --worker-port) that public traffic cannot fill.
#pragma once

#include <httplib.h>

#include "http/connection_limits.h"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace millsim {

// What a connection over the cap may still ask: GET `path` (a health probe), answered 200 with
// `body`, when it carries `authorization` as its Authorization header (empty: none needed).
struct BusyHealthProbe {
  std::string path;
  std::string authorization;
  std::string body;
};

class GuardedHttpServer : public httplib::Server {
 public:
  explicit GuardedHttpServer(ConnectionLimits limits);

  // After binding: a listen backlog of the connection cap instead of httplib's 5, so a burst of
  // connections is accepted (and admitted or closed) at once, not left to the client's SYN
  // retries a second or more later.
  void widen_backlog();

  // Call when a route handler starts: the request has arrived whole.
  static void mark_handler_started();

  // Milliseconds since the request being answered on this thread began to arrive (its first
  // byte waited for), for the request log; 0 off a connection (serve_bytes).
  static double current_request_ms();

  // Call from a handler (or the pre-routing handler): this connection ends after the response,
  // whatever its request asked (an unread body must not become the next request).
  static void close_after_response();

  // Answers this probe on connections over the cap (set before listening).
  void answer_health_when_busy(BusyHealthProbe probe) { busy_probe_ = std::move(probe); }

  // Answers one connection's bytes as the server would (routing, handlers, keep-alive up to the
  // usual count) without a socket: the fuzz harness of the HTTP handling, and tests.
  std::string serve_bytes(std::string_view request);

  ConnectionStats stats() const;
  std::size_t open_connections() const { return open_.load(); }
  const ConnectionLimits& limits() const { return limits_; }

 private:
  bool process_and_close_socket(socket_t sock) override;
  // Takes a slot for `client`; false when the total or the client's share is full.
  bool admit(const std::string& client);
  void release(const std::string& client);
  void answer_busy(socket_t sock);

  ConnectionLimits limits_;
  BusyHealthProbe busy_probe_;
  std::mutex clients_mutex_;
  std::map<std::string, std::size_t> open_by_client_;  // guarded by clients_mutex_
  std::atomic<std::size_t> open_{0};
  std::atomic<std::uint64_t> accepted_{0}, refused_{0}, timed_out_{0}, exceptions_{0};
};

}  // namespace millsim
