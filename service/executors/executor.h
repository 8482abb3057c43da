// Executors start one run's `millsim run` child and watch it. The interface is the seam for a
// Slurm executor (sbatch/squeue/scancel) later; the local one forks the child itself:
//   - its own working directory (the run's out_dir) holding scene.json, log.txt (stdout and
//     stderr) and what `millsim run` writes there atomically (result.json, run.h5);
//   - an address-space limit (RLIMIT_AS) from the run's memory limit;
//   - a wall-time limit: SIGTERM at the limit, SIGKILL kGraceSeconds later;
//   - its own process group, so cancel reaches everything it started.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>

#include "queue/store.h"

namespace millsim {

struct ExecHandle {
  pid_t pid = -1;
  double started_at = 0.0;
  double deadline = 0.0;      // wall-time limit
  double term_sent_at = 0.0;  // 0: not yet
  bool timed_out = false;
  bool canceled = false;
  std::filesystem::path out_dir;
  std::string job_id;            // the batch system's id (Slurm), empty for local children
  double last_checked_at = 0.0;  // batch executors query the scheduler at most once a second
};

struct ChildExit {
  int exit_code = 0;  // −1 when killed by a signal
  int signal = 0;
  bool timed_out = false;
  bool canceled = false;
  double wall_time_s = 0.0;
};

class Executor {
 public:
  virtual ~Executor() = default;
  // Prepares the run's directory and starts it; throws IoError when it cannot.
  virtual ExecHandle start(const RunRecord& run, double now) = 0;
  // The child's exit once it has ended (reaped); nullopt while it runs. Enforces the limits.
  virtual std::optional<ChildExit> poll(ExecHandle& handle, double now) = 0;
  // Asks the child to stop (SIGTERM, then SIGKILL after the grace period, via poll()).
  virtual void cancel(ExecHandle& handle, double now) = 0;
};

class LocalExecutor : public Executor {
 public:
  static constexpr double kGraceSeconds = 5.0;
  // `millsim_binary`: the executable to run (normally this very program, /proc/self/exe).
  explicit LocalExecutor(std::filesystem::path millsim_binary);
  ExecHandle start(const RunRecord& run, double now) override;
  std::optional<ChildExit> poll(ExecHandle& handle, double now) override;
  void cancel(ExecHandle& handle, double now) override;

 private:
  std::filesystem::path binary_;
};

// The gas spin-up cache the runs of one study share (`millsim run --spin-up-cache`): beside
// their directories, in the study's.
std::filesystem::path spin_up_cache_dir(const RunRecord& run);

// Writes the run's scene.json into its directory (created) and removes a previous attempt's
// result.json; throws IoError.
void prepare_run_directory(const RunRecord& run);

// Seconds since the epoch (the store's timestamps).
double wall_clock_s();

// The attempt's report from its exit and its directory: result.json when complete, the log's
// last lines as the error otherwise.
FinishReport report_from_exit(const ChildExit& exit, const std::filesystem::path& out_dir);

// The last `max_lines` lines of a text file ("" when missing).
std::string tail_of_file(const std::filesystem::path& path, std::size_t max_lines);

}  // namespace millsim
