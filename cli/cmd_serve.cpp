// millsim serve [--host H] [--port P] [--db FILE] [--token-file FILE] [--workers N] [--out DIR]
// [--worker-port P] [--max-connections N] [--receive-timeout S] (and the limits in --help)
//               [--scenes DIR] [--lease S] [--max-body BYTES] [--max-runs N]
//               [--max-study-bytes BYTES]
// The batch service: the HTTP API (service/http/api_server.h) on H:P (default 127.0.0.1:8080), the
// SQLite file (default ./millsim.db), and N worker processes (`millsim worker`, default one per
// core; a worker that dies is started again). The token comes from MILLSIM_TOKEN or --token-file
// (never from argv, where ps shows it); without one a token is generated and printed.
// Stops cleanly on SIGINT/SIGTERM (workers first: their runs go back to the queue).
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <thread>
#include <vector>

#include "cli_args.h"
#include "commands.h"
#include "core/errors.h"
#include "http/api_server.h"
#include "memory_reserve.h"
#include "parallel/thread_team.h"

namespace millsim::cli {
namespace {

std::string random_token() {
  std::ifstream urandom("/dev/urandom", std::ios::binary);
  unsigned char bytes[16] = {};
  urandom.read(reinterpret_cast<char*>(bytes), sizeof bytes);
  std::string hex;
  for (unsigned char b : bytes) {
    static const char* digits = "0123456789abcdef";
    hex += digits[b >> 4];
    hex += digits[b & 15];
  }
  return hex;
}

pid_t start_worker(const std::string& self, const std::string& url, const std::string& token,
                   int index) {
  const pid_t pid = fork();
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGTERM);  // a worker stops when its server dies
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    const std::string name = "local-" + std::to_string(index);
    setenv("MILLSIM_TOKEN", token.c_str(), 1);  // in the environment, not in argv (ps)
    execl(self.c_str(), "millsim", "worker", "--server", url.c_str(), "--name", name.c_str(),
          static_cast<char*>(nullptr));
    _exit(4);
  }
  return pid;
}

}  // namespace

int cmd_serve(const std::vector<std::string>& args) {
  // 64 MiB set aside: a request that runs the server out of memory fails alone, whichever
  // thread's allocation fails first (service/memory_reserve.h).
  arm_memory_reserve(std::size_t(64) << 20);
  ServerConfig config;
  config.workers = usable_core_count();
  config.worker_port = 0;  // the started workers' own path (service/http/http_limits.h)
  // The token from the environment keeps it out of `ps` (systemd: EnvironmentFile=).
  if (const char* t = std::getenv("MILLSIM_TOKEN")) config.token = t;
  ArgReader r("serve", args);
  int per_client = 0;
  while (r.next()) {
    if (r.option("--host", config.host)) continue;
    if (r.token_option(config.token)) continue;
    std::string db, out, scenes;
    if (r.option("--db", db)) {
      config.db = db;
      continue;
    }
    if (r.option("--out", out)) {
      config.out_root = out;
      continue;
    }
    if (r.option("--scenes", scenes)) {
      config.scenes_root = scenes;
      continue;
    }
    if (r.int_option("--port", config.port, 0, 65535) ||
        r.int_option("--workers", config.workers, 0, 1024) ||
        r.int_option("--max-runs", config.max_runs_per_study, 1, 1000000) ||
        r.double_option("--lease", config.lease_s, 0.5, 3600))
      continue;
    int max_body = 0;
    if (r.int_option("--max-body", max_body, 1024, 1 << 30)) {
      config.max_body_bytes = std::size_t(max_body);
      continue;
    }
    double max_study = 0;
    if (r.double_option("--max-study-bytes", max_study, 1024, 1e13)) {
      config.max_study_bytes = std::size_t(max_study);
      continue;
    }
    int max_connections = 0;
    if (r.int_option("--max-connections", max_connections, 4, 4096)) {
      config.limits.max_connections = std::size_t(max_connections);
      continue;
    }
    if (r.int_option("--max-connections-per-client", per_client, 1, 4096)) continue;
    if (r.int_option("--worker-port", config.worker_port, 0, 65535) ||
        r.double_option("--receive-timeout", config.limits.receive_timeout_s, 0.1, 3600))
      continue;
    r.unknown(
        "--host H, --port P, --db FILE, --token-file FILE, --workers N, --out DIR, --scenes DIR, "
        "--lease S, --max-body BYTES, --max-runs N, --max-study-bytes BYTES, --worker-port P, "
        "--max-connections N, --max-connections-per-client N, --receive-timeout S");
  }
  // Each local worker runs one run of at least one thread: never more of them than cores.
  if (config.workers > usable_core_count()) {
    std::fprintf(stderr,
                 "millsim serve: --workers = %d: expected at most %d, the cores this process may "
                 "use (its affinity mask); each worker runs one run of at least one thread\n",
                 config.workers, usable_core_count());
    return kBadInput;
  }
  // One client (source address) may hold half the connections unless told otherwise.
  config.limits.max_connections_per_client =
      per_client > 0 ? std::size_t(per_client)
                     : std::max<std::size_t>(1, config.limits.max_connections / 2);
  if (config.limits.max_connections_per_client > config.limits.max_connections)
    r.error("--max-connections-per-client = " + std::to_string(per_client) +
            ": expected at most --max-connections (" +
            std::to_string(config.limits.max_connections) + ")");
  if (!r.ok()) return kBadInput;
  const bool token_generated = config.token.empty();
  if (token_generated) config.token = random_token();

  // SIGINT/SIGTERM are taken by sigwait below, in this thread only.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  try {
    std::unique_ptr<ApiServer> server = std::make_unique<ApiServer>(config);
    server->bind();
    const std::string url = "http://" + config.host + ":" + std::to_string(server->bound_port());
    const std::string worker_url =
        "http://" + config.host + ":" + std::to_string(server->bound_worker_port());
    // A token the operator gave is theirs already; only a generated one is printed.
    std::printf(
        "millsim serve: listening on %s (database %s, %d workers; worker protocol also on "
        "port %d)\ntoken: %s\n",
        url.c_str(), config.db.c_str(), config.workers, server->bound_worker_port(),
        token_generated ? config.token.c_str() : "(given)");
    std::fflush(stdout);
    std::thread http([&] { server->serve(); });

    const std::string self = std::filesystem::read_symlink("/proc/self/exe");
    std::vector<pid_t> workers;
    for (int k = 0; k < config.workers; ++k)
      workers.push_back(start_worker(self, worker_url, config.token, k));
    const timespec tick = {0, 200'000'000};
    while (sigtimedwait(&stop_signals, nullptr, &tick) < 0) {
      for (std::size_t k = 0; k < workers.size(); ++k) {
        int status = 0;
        if (waitpid(workers[k], &status, WNOHANG) == workers[k])
          workers[k] = start_worker(self, worker_url, config.token, int(k));  // keep N workers
      }
    }
    std::fprintf(stderr, "millsim serve: stopping\n");
    for (pid_t w : workers) kill(w, SIGTERM);
    for (pid_t w : workers) waitpid(w, nullptr, 0);
    server->stop();
    http.join();
    return kOk;
  } catch (const DbError& e) {
    std::fprintf(stderr, "millsim serve: %s\n", e.what());
    return kEnvironment;
  } catch (const IoError& e) {
    std::fprintf(stderr, "millsim serve: %s\n", e.what());
    return kEnvironment;
  }
}

}  // namespace millsim::cli
