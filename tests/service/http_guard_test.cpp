// The HTTP guard of `millsim serve` (issue 33), on an ApiServer in this process: every method
// that carries a body meets the same checks before its body is read (token, one Content-Length,
// no Transfer-Encoding, no Content-Encoding but identity; names and values in any case), as a
// table of methods x encodings x token; one client (source address) cannot take every
// connection, and the health probe is answered while the cap is reached.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "http/api_server.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr const char* kToken = "guard-token";

ServerConfig config_in(const std::filesystem::path& dir) {
  ServerConfig config;
  config.db = dir / "q.db";
  config.out_root = dir / "runs";
  config.scenes_root = dir;
  config.token = kToken;
  config.request_log = false;
  config.port = 0;
  return config;
}

int status_of(const std::string& reply) {
  if (reply.rfind("HTTP/1.1 ", 0) != 0) return -1;
  return std::stoi(reply.substr(9, 3));
}

struct Encoding {
  const char* name;
  std::string headers;  // after the token, before the body
  int expected;         // with the token; 0: what the endpoint itself answers
};

TEST(HttpGuard, EveryMethodThatCarriesABodyMeetsTheSameChecksBeforeItIsRead) {
  test::TempDir dir;
  ApiServer server(config_in(dir.path()));
  const std::string body = "{\"name\": \"x\"}";
  const std::string length = "Content-Length: " + std::to_string(body.size()) + "\r\n";
  const std::vector<Encoding> encodings = {
      {"plain", length, 0},
      {"gzip", length + "Content-Encoding: gzip\r\n", 415},
      {"GZIP", length + "content-encoding: GZIP\r\n", 415},
      {"br", length + "Content-Encoding: br\r\n", 415},
      {"identity", length + "Content-Encoding: Identity\r\n", 0},
      {"chunked", "Transfer-Encoding: chunked\r\n", 411},
      {"Chunked", "Transfer-Encoding: Chunked\r\n", 411},
      {"TE unknown", length + "TRANSFER-ENCODING: rot13\r\n", 411},
      {"two lengths", length + "Content-Length: 3\r\n", 400},
      {"same length twice", length + length, 400},
      {"length not a number", "Content-Length: 12x\r\n", 400},
  };
  // The endpoint's own answers to a plain body with the token.
  const std::vector<std::pair<std::string, int>> methods = {
      {"POST", 400}, {"PUT", 405}, {"PATCH", 405}, {"DELETE", 405}};
  for (const auto& [method, plain_status] : methods)
    for (const Encoding& e : encodings)
      for (const bool token : {false, true}) {
        std::string request = method + " /v1/studies HTTP/1.1\r\nHost: x\r\n";
        if (token) request += std::string("Authorization: Bearer ") + kToken + "\r\n";
        request += e.headers + "\r\n";
        request += e.name == std::string("chunked") || e.name == std::string("Chunked")
                       ? concat(std::hex, body.size(), "\r\n", body, "\r\n0\r\n\r\n")
                       : body;
        // A second request behind it: a refused request's connection ends after the refusal.
        const std::string reply =
            server.serve_bytes(request + "GET /v1/info HTTP/1.1\r\nHost: x\r\n\r\n");
        const int expected = !token ? 401 : e.expected ? e.expected : plain_status;
        EXPECT_EQ(status_of(reply), expected)
            << method << " with " << e.name << (token ? " and" : " without") << " the token:\n"
            << reply.substr(0, 400);
        if (expected != plain_status) {
          EXPECT_EQ(reply.find("millsim_version"), std::string::npos)
              << method << " with " << e.name << ": a request after a refused one was served";
        }
      }
  // A GET that announces a body is answered and its connection closed: the unread body never
  // becomes the next request.
  const std::string get = server.serve_bytes(
      "GET /v1/health HTTP/1.1\r\nHost: x\r\nContent-Length: 40\r\n\r\n"
      "GET /v1/info HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(status_of(get), 401) << get;  // a body needs the token, whatever the method
  const std::string get_with_token = server.serve_bytes(
      std::string("GET /v1/health HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer ") + kToken +
      "\r\nContent-Length: 34\r\n\r\nGET /v1/info HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(status_of(get_with_token), 200) << get_with_token;
  EXPECT_EQ(get_with_token.find("millsim_version"), std::string::npos)
      << "the body of a GET was served as a second request:\n"
      << get_with_token;
}

// A served ApiServer on a loopback port, stopped and joined at the end.
class ServedApi {
 public:
  explicit ServedApi(ServerConfig config) : server_(std::move(config)) {
    server_.bind();
    thread_ = std::thread([this] { server_.serve(); });
  }
  ~ServedApi() {
    server_.stop();
    thread_.join();
  }
  int port() const { return server_.bound_port(); }
  ApiServer& server() { return server_; }

 private:
  ApiServer server_;
  std::thread thread_;
};

using test::connect_loopback;

// Sends a whole request and reads the reply until the server closes (at most 30 s).
std::string ask(int port, const std::string& request) {
  const int fd = connect_loopback(port);
  if (fd < 0) return "";
  timeval timeout{30, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string reply;
  char buffer[4096];
  ssize_t n;
  while ((n = recv(fd, buffer, sizeof buffer, 0)) > 0) reply.append(buffer, std::size_t(n));
  close(fd);
  return reply;
}

TEST(HttpGuard, OneClientCannotTakeEveryConnectionAndHealthIsAnsweredAtTheCap) {
  struct IgnoreSigpipe {
    void (*previous)(int) = signal(SIGPIPE, SIG_IGN);
    ~IgnoreSigpipe() { signal(SIGPIPE, previous); }
  } ignore_sigpipe;
  test::TempDir dir;
  ServerConfig config = config_in(dir.path());
  config.limits.max_connections = 8;
  config.limits.max_connections_per_client = 3;
  config.limits.receive_timeout_s = 60;  // the held connections stay for the whole test
  ServedApi api(config);
  const std::string health = "GET /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  const std::string info = "GET /v1/info HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  // This test's client (127.0.0.1) holds three slow connections: its whole share.
  std::vector<int> held;
  for (int k = 0; k < 3; ++k) {
    held.push_back(connect_loopback(api.port()));
    ASSERT_GE(held.back(), 0);
    send(held.back(), "GET /v1/info HTTP/1.1\r\n", 23, MSG_NOSIGNAL);  // and never finishes
  }
  // Wait until the server has taken all three.
  for (int k = 0; k < 3000 && api.server().connection_stats().accepted < 3; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(api.server().connection_stats().accepted, 3u);
  // A fourth from the same address is over its share: told to come back, with Retry-After...
  const std::string busy = ask(api.port(), info);
  EXPECT_EQ(status_of(busy), 503) << busy;
  EXPECT_NE(busy.find("Retry-After: 1"), std::string::npos) << busy;
  EXPECT_NE(busy.find("\"busy\""), std::string::npos) << busy;
  // ...but a health probe is answered.
  const std::string ok = ask(api.port(), health);
  EXPECT_EQ(status_of(ok), 200) << ok;
  EXPECT_NE(ok.find("\"ok\""), std::string::npos) << ok;
  EXPECT_EQ(api.server().connection_stats().refused, 2u);
  // Released slots are the client's again.
  for (int fd : held) close(fd);
  held.clear();
  std::string again;
  for (int k = 0; k < 3000 && status_of(again) != 200; ++k) {
    again = ask(api.port(), info);
    if (status_of(again) != 200) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(status_of(again), 200) << again;
}

TEST(HttpGuard, OffLoopbackTheBusyHealthProbeNeedsTheToken) {
  // The probe's reply is the same either way; its head is matched case-insensitively by name.
  test::TempDir dir;
  ServerConfig config = config_in(dir.path());
  config.host = "0.0.0.0";  // reads need the token
  config.limits.max_connections = 4;
  config.limits.max_connections_per_client = 1;
  config.limits.receive_timeout_s = 60;
  ServedApi api(config);
  const int hold = connect_loopback(api.port());
  ASSERT_GE(hold, 0);
  send(hold, "GET ", 4, MSG_NOSIGNAL);
  for (int k = 0; k < 3000 && api.server().connection_stats().accepted < 1; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(api.server().connection_stats().accepted, 1u);
  const std::string without = ask(api.port(), "GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(status_of(without), 503) << without;
  const std::string with = ask(api.port(), std::string("GET /v1/health HTTP/1.1\r\nHost: x\r\n"
                                                       "authorization:  Bearer ") +
                                               kToken + "\r\n\r\n");
  EXPECT_EQ(status_of(with), 200) << with;
  close(hold);
}

}  // namespace
}  // namespace millsim
