// GuardedHttpServer: an httplib::Server that slow clients cannot starve.
//   - Each connection gets a thread of its own from a pool larger than the connection cap, so no
//     connection waits in a queue behind others, and one over the cap is closed at once.
//   - Each request must arrive whole (head and body) within the receive deadline, counted from
//     its first byte's wait until its handler starts (mark_handler_started()); a slowloris that
//     dribbles a byte at a time, which httplib's per-read timeout never ends, is cut there. A slow
//     download of a large response is not: the deadline stops when the handler starts.
// It serves each connection itself (httplib's keep-alive loop over a Stream of its own that
// knows the deadline), with httplib's request parsing and routing unchanged. Workers keep a path
// of their own on a second server (ApiServer, --worker-port) that public traffic cannot fill.
#pragma once

#include <httplib.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace millsim {

struct ConnectionLimits {
  std::size_t max_connections = 64;  // open at once; more are closed on accept
  double receive_timeout_s = 10.0;   // for a request's head and body
};

struct ConnectionStats {
  std::uint64_t accepted = 0;
  std::uint64_t refused = 0;    // over the cap
  std::uint64_t timed_out = 0;  // cut by the receive deadline
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

  // Answers one connection's bytes as the server would (routing, handlers, keep-alive up to the
  // usual count) without a socket: the fuzz harness of the HTTP handling, and tests.
  std::string serve_bytes(std::string_view request);

  ConnectionStats stats() const;
  std::size_t open_connections() const { return open_.load(); }
  const ConnectionLimits& limits() const { return limits_; }

 private:
  bool process_and_close_socket(socket_t sock) override;

  ConnectionLimits limits_;
  std::atomic<std::size_t> open_{0};
  std::atomic<std::uint64_t> accepted_{0}, refused_{0}, timed_out_{0};
};

}  // namespace millsim
