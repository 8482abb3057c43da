#include "http/http_limits.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <strings.h>
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
constexpr int kBusyReadMs = 250;  // how long a connection over the cap may take to ask

// Whether a request head is `GET <path>` (optionally with a query) carrying `authorization`
// (empty: any or none). Header names compare case-insensitively.
bool is_probe(const std::string& head, const std::string& path, const std::string& authorization) {
  const std::string start = "GET " + path;
  if (head.compare(0, start.size(), start) != 0 || head.size() <= start.size()) return false;
  const char next = head[start.size()];
  if (next != ' ' && next != '?') return false;
  if (authorization.empty()) return true;
  std::size_t line = head.find("\r\n");
  while (line != std::string::npos) {
    const std::size_t begin = line + 2;
    const std::size_t end = head.find("\r\n", begin);
    if (end == std::string::npos) break;
    const std::string text = head.substr(begin, end - begin);
    const std::size_t colon = text.find(':');
    if (colon != std::string::npos && strncasecmp(text.c_str(), "Authorization", colon) == 0 &&
        colon == std::strlen("Authorization")) {
      std::size_t value = colon + 1;
      while (value < text.size() && (text[value] == ' ' || text[value] == '\t')) ++value;
      return text.compare(value, std::string::npos, authorization) == 0;
    }
    line = end;
  }
  return false;
}

std::string concat_response(const std::string& status, const std::string& headers,
                            const std::string& body) {
  return "HTTP/1.1 " + status +
         "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
         "\r\n" + headers + "Connection: close\r\n\r\n" + body;
}

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
    started_ = Clock::now();
    deadline_ = started_ + receive_timeout_;
    receiving_ = true;
  }
  Clock::time_point request_started() const { return started_; }
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
  Clock::time_point started_, deadline_;
  bool receiving_ = true;
  bool timed_out_ = false;
  char buffer_[4096];
  std::size_t begin_ = 0, end_ = 0;
};

thread_local DeadlineStream* current_stream = nullptr;
thread_local bool close_requested = false;  // by the request being answered on this thread

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
  // A thread per admitted connection, and some more that answer those over the cap (each for
  // at most kBusyReadMs); a connection waits in the pool's queue until a thread takes it.
  const std::size_t threads = limits_.max_connections + 16;
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

void GuardedHttpServer::close_after_response() {
  close_requested = true;
}

double GuardedHttpServer::current_request_ms() {
  if (!current_stream) return 0.0;
  return std::chrono::duration<double, std::milli>(Clock::now() - current_stream->request_started())
      .count();
}

std::string GuardedHttpServer::serve_bytes(std::string_view request) {
  MemoryStream stream(request);
  for (int left = kKeepAliveMaxCount; left > 0 && !stream.at_end(); --left) {
    bool closed = false;
    close_requested = false;
    if (!process_request(stream, left == 1, closed, nullptr) || closed || close_requested) break;
  }
  return stream.written();
}

ConnectionStats GuardedHttpServer::stats() const {
  return {accepted_.load(), refused_.load(), timed_out_.load(), exceptions_.load()};
}

bool GuardedHttpServer::admit(const std::string& client) {
  std::lock_guard<std::mutex> lock(clients_mutex_);
  std::size_t& mine = open_by_client_[client];
  if (open_.load() >= limits_.max_connections || mine >= limits_.max_connections_per_client) {
    if (mine == 0) open_by_client_.erase(client);
    return false;
  }
  ++mine;
  ++open_;
  return true;
}

void GuardedHttpServer::release(const std::string& client) {
  std::lock_guard<std::mutex> lock(clients_mutex_);
  const auto it = open_by_client_.find(client);
  if (it != open_by_client_.end() && --it->second == 0) open_by_client_.erase(it);
  --open_;
}

// A connection over the cap: its request head is read for at most kBusyReadMs; the health
// probe is answered, anything else is told to come back.
void GuardedHttpServer::answer_busy(socket_t sock) {
  const auto until = Clock::now() + std::chrono::milliseconds(kBusyReadMs);
  std::string head;
  char chunk[1024];
  while (head.size() < 8192 && head.find("\r\n\r\n") == std::string::npos) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
    if (left <= 0 || !wait_for(sock, POLLIN, int(left))) break;
    const ssize_t n = recv(sock, chunk, sizeof chunk, 0);
    if (n <= 0) break;
    head.append(chunk, std::size_t(n));
  }
  std::string reply;
  if (!busy_probe_.path.empty() && is_probe(head, busy_probe_.path, busy_probe_.authorization)) {
    reply = concat_response("200 OK", "", busy_probe_.body);
  } else {
    reply = concat_response("503 Service Unavailable", "Retry-After: 1\r\n",
                            "{\"error\": {\"code\": \"busy\", \"message\": \"the server holds as "
                            "many connections as it takes (from this address or in all); try "
                            "again\"}}\n");
  }
  if (wait_for(sock, POLLOUT, 200)) send(sock, reply.data(), reply.size(), MSG_NOSIGNAL);
  linger_and_close(sock);
}

// httplib's keep-alive loop, over the DeadlineStream: up to kKeepAliveMaxCount requests, each
// waited for at most kKeepAliveTimeoutMs after the last, the last answered with "Connection:
// close". The first request's deadline counts from the accept.
bool GuardedHttpServer::process_and_close_socket(socket_t sock) {
  std::string client;
  int port = 0;
  address_of(sock, true, client, port);
  if (!admit(client)) {
    ++refused_;
    answer_busy(sock);
    return false;
  }
  ++accepted_;
  int yes = 1;
  setsockopt(sock, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
  DeadlineStream stream(sock, limits_.receive_timeout_s);
  current_stream = &stream;
  bool ok = false;
  stream.start_request();  // the first request's deadline counts from the connection
  try {
    for (int left = kKeepAliveMaxCount; left > 0 && is_running(); --left) {
      if (left < kKeepAliveMaxCount) {
        if (!wait_for(sock, POLLIN, kKeepAliveTimeoutMs)) break;
        stream.start_request();
      }
      bool closed = false;
      close_requested = false;
      ok = process_request(stream, left == 1, closed, nullptr);
      if (stream.timed_out()) ++timed_out_;
      if (!ok || closed || close_requested || stream.timed_out()) break;
    }
  } catch (...) {  // what escaped httplib and the handlers (std::bad_alloc): this connection ends
    ++exceptions_;
    ok = false;
  }
  current_stream = nullptr;
  linger_and_close(sock);
  release(client);
  return ok;
}

}  // namespace millsim
