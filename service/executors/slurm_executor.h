// The Slurm executor: each run is one batch job (`sbatch --wrap`), so the cluster schedules it
// and enforces its limits: --time from the run's wall-time limit (whole minutes, at least 1),
// --mem from its memory limit (and `ulimit -v` inside the job), --chdir the run's directory
// (on a filesystem the worker and the nodes share), --output log.txt. The job's state is read
// with squeue (terminal states stay visible for MinJobAge) and its exit code with scontrol;
// cancel is scancel. A job that vanished, failed with its node or was preempted is a system
// error (retried); TIMEOUT is the run's own limit.
#pragma once

#include <memory>
#include <string>

#include "executors/executor.h"

namespace millsim {

// The sbatch options of a study's `slurm` key, each shell-quoted, with a leading space each
// ("" when there are none). They come after the worker's own, so they win.
std::string study_options(const SlurmOptions& options);

class SlurmExecutor : public Executor {
 public:
  // `extra_sbatch_args`: appended to every sbatch call (e.g. "--partition=debug").
  SlurmExecutor(std::filesystem::path millsim_binary, std::string extra_sbatch_args = "");
  ExecHandle start(const RunRecord& run, double now) override;
  std::optional<ChildExit> poll(ExecHandle& handle, double now) override;
  void cancel(ExecHandle& handle, double now) override;

  // True when sbatch and squeue answer (a cluster is configured).
  static bool available();

 private:
  std::filesystem::path binary_;
  std::string extra_args_;
};

// The executor a study runner asked for by name: "slurm" (throws IoError when no cluster answers)
// or "local"; `binary` is the millsim to start (normally /proc/self/exe).
std::unique_ptr<Executor> make_executor(const std::string& name,
                                        const std::filesystem::path& binary);

}  // namespace millsim
