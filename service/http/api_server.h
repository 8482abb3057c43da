// The HTTP API under /v1 (docs/openapi.yaml, also served at /v1/openapi.yaml), on cpp-httplib.
// It owns the Store: one server per database file (DatabaseLock: a flock on the file itself), and
// every write to the SQLite file goes through this process, serialised by one mutex; workers (local
// or on other machines) talk to it over HTTP. JSON error bodies {"error": {"code", "message",
// "details"}} with 400/401/404/409/413. Mutating endpoints need the bearer token; read endpoints
// too when the server listens beyond loopback. A background thread re-queues runs whose lease
// expired. A port in use is an error (no SO_REUSEPORT sharing); a wrong method on a known path
// is a 405 with Allow; each request is logged as one line (time, method, path, status, ms).
#pragma once

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <thread>

#include "http/connection_limits.h"
#include "http/request_log.h"
#include "queue/database_lock.h"
#include "queue/store.h"

namespace httplib {
class Server;
}

namespace millsim {

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;  // 0: any free port (bound_port() tells which)
  std::filesystem::path db = "millsim.db";
  std::filesystem::path out_root = "out/studies";  // runs' directories
  std::filesystem::path scenes_root = ".";         // scene paths in studies resolve here
  std::string token;
  std::size_t max_body_bytes = 1 << 20;
  int max_runs_per_study = 10000;
  // What one study may add to the database: the runs' scenes as stored, summed.
  std::size_t max_study_bytes = std::size_t(256) << 20;
  double lease_s = 30.0;
  int workers = 0;          // reported in /v1/info (the serve command starts them)
  bool request_log = true;  // one line per request on stderr (idle polls: http/request_log.h)
  // Slow clients: the connection cap and the receive deadline (service/http/http_limits.h).
  ConnectionLimits limits;
  // A second port that serves the worker protocol alone (claim, heartbeat, finish), so workers
  // keep a path however busy the public port is: -1 none, 0 any free port.
  int worker_port = -1;
};

class GuardedHttpServer;
struct ApiState;

class ApiServer {
 public:
  explicit ApiServer(ServerConfig config);
  ~ApiServer();
  ApiServer(const ApiServer&) = delete;
  ApiServer& operator=(const ApiServer&) = delete;

  // Binds; throws IoError when the address is taken.
  void bind();
  int bound_port() const { return port_; }
  int bound_worker_port() const;  // -1 without a worker port
  // The public server's answer to one connection's bytes, without a socket (fuzzing).
  std::string serve_bytes(std::string_view request);
  // Connections of the public server (tests, /v1/info).
  ConnectionStats connection_stats() const;
  // Serves until stop(); call from one thread.
  void serve();
  void stop();

 private:
  // Sets up `s` (limits, the body guard, the log) and registers the routes: all of them, or
  // the worker protocol alone.
  void routes(httplib::Server& s, bool worker_only);
  std::unique_ptr<ApiState> state_;  // what the handlers share (http/handlers.h)
  std::unique_ptr<GuardedHttpServer> http_;
  std::unique_ptr<GuardedHttpServer> worker_http_;  // with a worker port
  std::thread worker_thread_;
  std::atomic<bool> stopping_{false};
  std::thread reaper_;
  int port_ = 0;
  std::unique_ptr<DatabaseLock> lock_;  // held while this server owns the database
  // A worker's idle polls, on either port, share one summary in the request log.
  std::shared_ptr<IdlePollSummary> idle_polls_ = std::make_shared<IdlePollSummary>();
};

bool is_loopback_host(const std::string& host);

}  // namespace millsim
