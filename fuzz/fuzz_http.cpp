// Fuzzes the HTTP request handling of `millsim serve`: any bytes, as what one connection sends,
// go through httplib's parsing and the server's routing, checks and handlers (the same
// ApiServer, on a SQLite file of its own, without a socket: GuardedHttpServer::serve_bytes). A
// crash, a sanitizer report or an exception out of the server is a finding; every answer must be
// an HTTP response. Each input is answered twice at once, on this thread and on a second one, so
// the handlers' shared state (the store, its lock, the results cache) meets concurrent requests.
// Seeds: fuzz/http_seeds/ (requests of every endpoint, with the token "fuzz-token"; the header
// variants the guard refuses: any method, case, repeated Content-Length, unknown encodings).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <thread>

#include "http/api_server.h"

namespace {

// The server, on a fresh SQLite file every 20 000 inputs: studies the fuzzer manages to queue
// pile up in the database and would slow every later query.
millsim::ApiServer& server() {
  static std::unique_ptr<millsim::ApiServer> s;
  static long inputs = 0;
  static const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("millsim-fuzz-http-" + std::to_string(getpid()));
  if (inputs++ % 20000 == 0) {
    s.reset();
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "scenes");
    millsim::ServerConfig config;
    config.db = dir / "fuzz.db";
    config.out_root = dir / "runs";
    config.scenes_root = dir / "scenes";
    config.token = "fuzz-token";
    config.request_log = false;
    config.max_runs_per_study = 50;
    s = std::make_unique<millsim::ApiServer>(config);
  }
  return *s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  millsim::ApiServer& s = server();
  std::string other;
  std::thread concurrent([&] { other = s.serve_bytes(input); });
  const std::string reply = s.serve_bytes(input);
  concurrent.join();
  for (const std::string& r : {reply, other})
    if (!r.empty() && r.rfind("HTTP/1.1 ", 0) != 0) std::abort();
  return 0;
}
