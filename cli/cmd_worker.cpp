// millsim worker [--server URL] [--token-file FILE] [--name NAME] [--until-empty]
//                [--executor local|slurm] [--slots N] [--sbatch-args "..."]
// One worker process (service/executors/worker.h): claims runs from the server and executes each as
// a `millsim run` child (local) or a Slurm batch job (slurm; --slots jobs at once). SIGTERM/SIGINT
// stop it; the runs it was executing go back to the queue.
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>

#include "cli_args.h"
#include "commands.h"
#include "core/errors.h"
#include "executors/slurm_executor.h"
#include "executors/worker.h"

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
  std::string executor_name = "local", sbatch_args, partition, account, qos;
  ArgReader r("worker", args);
  while (r.next()) {
    if (r.option("--server", config.server) || r.token_option(config.token) ||
        r.option("--name", config.name) || r.option("--executor", executor_name) ||
        r.option("--sbatch-args", sbatch_args) || r.option("--partition", partition) ||
        r.option("--account", account) || r.option("--qos", qos) ||
        r.int_option("--slots", config.slots, 1, 100000))
      continue;
    if (r.is_flag("--until-empty")) {
      config.until_empty = true;
      continue;
    }
    r.unknown(
        "--server URL, --token-file FILE, --name NAME, --until-empty, --executor local|slurm, "
        "--slots N, --sbatch-args ARGS, --partition P, --account A, --qos Q");
  }
  if (!r.ok()) return kBadInput;
  // The worker's own Slurm options (a study's `slurm` key comes after them and wins).
  nlohmann::json given = nlohmann::json::object();
  if (!partition.empty()) given["partition"] = partition;
  if (!account.empty()) given["account"] = account;
  if (!qos.empty()) given["qos"] = qos;
  SlurmOptions own;
  InputErrors errors;
  parse_slurm(given, own, errors);
  for (const InputError& e : errors) {
    std::fprintf(stderr, "millsim worker: --%s = %s: %s\n",
                 e.path.substr(e.path.rfind('/') + 1).c_str(), e.value.c_str(), e.allowed.c_str());
    return kBadInput;
  }
  sbatch_args += study_options(own);
  if (executor_name != "local" && executor_name != "slurm") {
    std::fprintf(stderr, "millsim worker: --executor = %s: expected local or slurm\n",
                 executor_name.c_str());
    return kBadInput;
  }
  struct sigaction action = {};
  action.sa_handler = on_stop_signal;
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGINT, &action, nullptr);
  try {
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
    if (executor_name == "slurm") {
      if (!SlurmExecutor::available())
        throw IoError("--executor slurm: sinfo does not answer (no Slurm cluster configured)");
      SlurmExecutor executor(self, sbatch_args);
      run_worker(config, executor, g_stop);
    } else {
      LocalExecutor executor(self);
      run_worker(config, executor, g_stop);
    }
    return kOk;
  } catch (const IoError& e) {
    std::fprintf(stderr, "millsim worker: %s\n", e.what());
    return kEnvironment;
  }
}

}  // namespace millsim::cli
