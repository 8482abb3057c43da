#include "http_limits.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>

namespace millsim {
namespace {

using Clock = std::chrono::steady_clock;

// httplib's own defaults, which this server keeps: per read or write, and between requests on a
// kept-alive connection.
constexpr int kReadTimeoutMs = 5000, kWriteTimeoutMs = 5000, kKeepAliveTimeoutMs = 5000;
constexpr int kKeepAliveMaxCount = 5;

bool wait_for(socket_t sock, short events, int timeout_ms) {
  pollfd p{sock, events, 0};
  int n;
  do n = poll(&p, 1, std::max(timeout_ms, 0));
  while (n < 0 && errno == EINTR);
  return n > 0 && (p.revents & (events | POLLHUP | POLLERR)) != 0;
}

void address_of(socket_t sock, bool peer, std::string& ip, int& port) {
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  if ((peer ? getpeername(sock, reinterpret_cast<sockaddr*>(&a), &len)
            : getsockname(sock, reinterpret_cast<sockaddr*>(&a), &len)) != 0)
    return;
  char text[INET6_ADDRSTRLEN] = {};
  if (a.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
    inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
    port = ntohs(v4->sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
    inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
    port = ntohs(v6->sin6_port);
  }
  ip = text;
}

// A connection's socket as httplib's Stream, buffered like httplib's own (its line reader asks
// for one byte at a time), with the receive deadline on every read until the handler starts.
class DeadlineStream final : public httplib::Stream {
 public:
  DeadlineStream(socket_t sock, double receive_timeout_s)
      : sock_(sock),
        receive_timeout_(std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(receive_timeout_s))) {}

  void start_request() {
    deadline_ = Clock::now() + receive_timeout_;
    receiving_ = true;
  }
  void handler_started() { receiving_ = false; }
  bool timed_out() const { return timed_out_; }

  bool is_readable() const override { return wait_for(sock_, POLLIN, kReadTimeoutMs); }
  bool is_writable() const override { return wait_for(sock_, POLLOUT, kWriteTimeoutMs); }

  ssize_t read(char* out, size_t size) override {
    if (begin_ == end_) {
      if (!wait_readable()) return -1;
      ssize_t n;
      do n = recv(sock_, buffer_, sizeof buffer_, 0);
      while (n < 0 && errno == EINTR);
      if (n <= 0) return n;
      begin_ = 0, end_ = std::size_t(n);
    }
    const std::size_t n = std::min(size, end_ - begin_);
    std::memcpy(out, buffer_ + begin_, n);
    begin_ += n;
    return ssize_t(n);
  }

  ssize_t write(const char* data, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n;
    do n = send(sock_, data, size, MSG_NOSIGNAL);
    while (n < 0 && errno == EINTR);
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    address_of(sock_, true, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    address_of(sock_, false, ip, port);
  }
  socket_t socket() const override { return sock_; }

 private:
  bool wait_readable() {
    int timeout_ms = kReadTimeoutMs;
    if (receiving_) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ - Clock::now());
      if (left.count() <= 0) return timed_out_ = true, false;
      timeout_ms = int(std::min<std::int64_t>(timeout_ms, left.count()));
    }
    if (wait_for(sock_, POLLIN, timeout_ms)) return true;
    if (receiving_ && Clock::now() >= deadline_) timed_out_ = true;
    return false;
  }

  socket_t sock_;
  Clock::duration receive_timeout_;
  Clock::time_point deadline_;
  bool receiving_ = true;
  bool timed_out_ = false;
  char buffer_[4096];
  std::size_t begin_ = 0, end_ = 0;
};

thread_local DeadlineStream* current_stream = nullptr;

// Closes a connection after its last response without resetting it: a close with unread bytes
// (the body of a request refused before it was read, a slow client's dribble) makes the kernel
// send a reset, and a reset can destroy the response before the client reads it. So the sending
// side is shut first (the client sees the end of the response), and what the client still sends
// is read and dropped for up to 200 ms or 1 MiB, or until it closes too.
void linger_and_close(socket_t sock) {
  shutdown(sock, SHUT_WR);
  const auto until = Clock::now() + std::chrono::milliseconds(200);
  char sink[4096];
  std::size_t drained = 0;
  while (drained < (1u << 20)) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
    if (left <= 0 || !wait_for(sock, POLLIN, int(left))) break;
    const ssize_t n = recv(sock, sink, sizeof sink, 0);
    if (n <= 0) break;
    drained += std::size_t(n);
  }
  close(sock);
}

// A connection held in memory: reads the given bytes, collects what is written.
class MemoryStream final : public httplib::Stream {
 public:
  explicit MemoryStream(std::string_view in) : in_(in) {}
  const std::string& written() const { return out_; }
  bool at_end() const { return in_.empty(); }

  bool is_readable() const override { return !in_.empty(); }
  bool is_writable() const override { return true; }
  ssize_t read(char* out, size_t size) override {
    const std::size_t n = std::min(size, in_.size());
    std::memcpy(out, in_.data(), n);
    in_.remove_prefix(n);
    return ssize_t(n);
  }
  ssize_t write(const char* data, size_t size) override {
    out_.append(data, size);
    return ssize_t(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1", port = 40000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1", port = 8080;
  }
  socket_t socket() const override { return INVALID_SOCKET; }

 private:
  std::string_view in_;
  std::string out_;
};

}  // namespace

GuardedHttpServer::GuardedHttpServer(ConnectionLimits limits) : limits_(limits) {
  // A thread per admitted connection, and a few more that close those over the cap at once
  // (a connection waits in the pool's queue until a thread takes it).
  const std::size_t threads = limits_.max_connections + 4;
  new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
}

void GuardedHttpServer::widen_backlog() {
  const socket_t sock = svr_sock_;
  if (sock != INVALID_SOCKET)
    ::listen(sock, int(std::max<std::size_t>(limits_.max_connections, 128)));
}

void GuardedHttpServer::mark_handler_started() {
  if (current_stream) current_stream->handler_started();
}

std::string GuardedHttpServer::serve_bytes(std::string_view request) {
  MemoryStream stream(request);
  for (int left = kKeepAliveMaxCount; left > 0 && !stream.at_end(); --left) {
    bool closed = false;
    if (!process_request(stream, left == 1, closed, nullptr) || closed) break;
  }
  return stream.written();
}

ConnectionStats GuardedHttpServer::stats() const {
  return {accepted_.load(), refused_.load(), timed_out_.load()};
}

// httplib's keep-alive loop, over the DeadlineStream: up to kKeepAliveMaxCount requests, each
// waited for at most kKeepAliveTimeoutMs after the last, the last answered with "Connection:
// close". The first request's deadline counts from the accept.
bool GuardedHttpServer::process_and_close_socket(socket_t sock) {
  const auto close_socket = [sock] {
    shutdown(sock, SHUT_RDWR);
    close(sock);
  };
  if (open_.fetch_add(1) >= limits_.max_connections) {
    open_.fetch_sub(1);
    ++refused_;
    close_socket();
    return false;
  }
  ++accepted_;
  int yes = 1;
  setsockopt(sock, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
  DeadlineStream stream(sock, limits_.receive_timeout_s);
  current_stream = &stream;
  bool ok = false;
  stream.start_request();  // the first request's deadline counts from the connection
  for (int left = kKeepAliveMaxCount; left > 0 && is_running(); --left) {
    if (left < kKeepAliveMaxCount) {
      if (!wait_for(sock, POLLIN, kKeepAliveTimeoutMs)) break;
      stream.start_request();
    }
    bool closed = false;
    ok = process_request(stream, left == 1, closed, nullptr);
    if (stream.timed_out()) ++timed_out_;
    if (!ok || closed || stream.timed_out()) break;
  }
  current_stream = nullptr;
  linger_and_close(sock);
  open_.fetch_sub(1);
  return ok;
}

}  // namespace millsim
