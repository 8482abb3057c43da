// millsim worker [--server URL] [--token T] [--name NAME] [--until-empty]
// One worker process (service/worker.h): claims runs from the server and executes each as a
// `millsim run` child. SIGTERM/SIGINT stop it; a run it was executing goes back to the queue.
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>

#include "cli_args.h"
#include "commands.h"
#include "core/errors.h"
#include "worker.h"

namespace millsim::cli {
namespace {

std::atomic<bool> g_stop{false};
void on_stop_signal(int) {
  g_stop = true;
}

}  // namespace

int cmd_worker(const std::vector<std::string>& args) {
  WorkerConfig config;
  if (const char* t = std::getenv("MILLSIM_TOKEN")) config.token = t;
  ArgReader r("worker", args);
  while (r.next()) {
    if (r.option("--server", config.server) || r.option("--token", config.token) ||
        r.option("--name", config.name))
      continue;
    if (r.is_flag("--until-empty")) {
      config.until_empty = true;
      continue;
    }
    r.unknown("--server URL, --token T, --name NAME, --until-empty");
  }
  if (!r.ok()) return kBadInput;
  struct sigaction action = {};
  action.sa_handler = on_stop_signal;
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGINT, &action, nullptr);
  try {
    LocalExecutor executor(std::filesystem::read_symlink("/proc/self/exe"));
    run_worker(config, executor, g_stop);
    return kOk;
  } catch (const IoError& e) {
    std::fprintf(stderr, "millsim worker: %s\n", e.what());
    return kEnvironment;
  }
}

}  // namespace millsim::cli
