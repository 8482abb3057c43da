#include "executors/slurm_executor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/errors.h"
#include "core/json_reader.h"

namespace millsim {
namespace {

// Runs a shell command; returns its stdout and sets `status` to its exit status.
// The command's stdout (and its stderr too with `with_errors`) and its exit status.
std::string capture(const std::string& command, int& status, bool with_errors = false) {
  std::string out;
  FILE* pipe = popen((command + (with_errors ? " 2>&1" : " 2>/dev/null")).c_str(), "r");
  if (!pipe) {
    status = -1;
    return out;
  }
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  status = pclose(pipe);
  return out;
}

std::string shell_quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace

SlurmExecutor::SlurmExecutor(std::filesystem::path binary, std::string extra)
    : binary_(std::move(binary)), extra_args_(std::move(extra)) {}

std::string study_options(const SlurmOptions& o) {
  std::string out;
  if (!o.partition.empty()) out += " --partition=" + shell_quoted(o.partition);
  if (!o.account.empty()) out += " --account=" + shell_quoted(o.account);
  if (!o.qos.empty()) out += " --qos=" + shell_quoted(o.qos);
  for (const std::string& a : o.sbatch_args) out.append(" ").append(shell_quoted(a));
  return out;
}

namespace {

// The batch script: `millsim run --resume` in the background, so the shell can pass on the
// SIGUSR1 Slurm sends before the time limit (--signal=B:USR1@lead). The run then writes a
// checkpoint and exits 138, and the job requeues itself: it starts again under the same job id
// and resumes from that checkpoint. Any other exit is the job's.
std::string requeue_script(const std::filesystem::path& binary, const RunRecord& run) {
  const std::string root =
      run.files_root.empty() ? "" : " --files-root " + shell_quoted(run.files_root);
  const std::string cache = " --spin-up-cache " + shell_quoted(spin_up_cache_dir(run).string()) +
                            " --threads " + std::to_string(std::max(1, run.threads));
  // The summary on stdout is result.json's copy: kept out of log.txt (the job's output), as
  // under the local executor, so the log ends with the run's thermo lines.
  return shell_quoted(binary.string()) + " run scene.json --out . --quiet --resume" + root + cache +
         " >/dev/null & pid=$!; stopped=0; "
         "trap 'stopped=1; kill -USR1 $pid 2>/dev/null' USR1; "
         "wait $pid; rc=$?; while kill -0 $pid 2>/dev/null; do wait $pid; rc=$?; done; "
         "if [ $stopped = 1 ] && [ $rc = 138 ] && [ -n \"$SLURM_JOB_ID\" ]; then "
         "echo \"millsim: checkpointed before the time limit; requeueing job $SLURM_JOB_ID\"; "
         "scontrol requeue \"$SLURM_JOB_ID\" && exit 0; fi; exit $rc";
}

}  // namespace

bool SlurmExecutor::available() {
  int status = 0;
  capture("sinfo -h -o %P", status);
  return status == 0;
}

ExecHandle SlurmExecutor::start(const RunRecord& run, double now) {
  ExecHandle h;
  h.out_dir = run.out_dir;
  prepare_run_directory(run);
  const long minutes = std::max(1L, long(std::ceil(run.wall_limit_s / 60.0)));
  const long memory_mb = std::max(16L, long(run.memory_limit_mb));
  // The job has no use for the service token (sbatch exports the environment): it is unset.
  std::string job = "unset MILLSIM_TOKEN; " + requeue_script(binary_, run);
#ifndef MILLSIM_SANITIZED  // ASan reserves terabytes of address space for its shadow
  job = "ulimit -v " + std::to_string(memory_mb * 1024) + "; " + job;
#endif
  // SIGUSR1 this long before the job's time limit: the run checkpoints and the job requeues.
  const long lead_s = std::clamp(minutes * 60 / 4, 10L, 300L);
  const std::string command =
      "sbatch --parsable --job-name=" + shell_quoted("millsim-" + run.id) +
      " --chdir=" + shell_quoted(h.out_dir.string()) +
      " --output=log.txt --open-mode=append --ntasks=1 --cpus-per-task=" +
      std::to_string(std::max(1, run.threads)) + " --time=" + std::to_string(minutes) +
      " --mem=" + std::to_string(memory_mb) + " --requeue --signal=B:USR1@" +
      std::to_string(lead_s) + " " + extra_args_ + study_options(run.slurm) +
      " --wrap=" + shell_quoted(job);
  int status = 0;
  // With stderr, so a refusal carries sbatch's own words; the job id is the last line.
  const std::string out = trim(capture(command, status, true));
  const std::string last =
      out.substr(out.find_last_of('\n') == std::string::npos ? 0 : out.find_last_of('\n') + 1);
  const std::string id = last.substr(0, last.find(';'));  // "jobid[;cluster]"
  if (status != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    throw IoError("sbatch failed (status " + std::to_string(status) + "): " + valid_utf8(out));
  h.job_id = id;
  h.started_at = now;
  h.deadline = now + run.wall_limit_s;
  return h;
}

std::optional<ChildExit> SlurmExecutor::poll(ExecHandle& h, double now) {
  if (now - h.last_checked_at < 1.0) return std::nullopt;
  // A job that requeues itself gets a fresh time limit each time: the study's wall-time limit
  // holds over all of them.
  if (!h.canceled && !h.timed_out && now >= h.deadline + 60.0) {
    h.timed_out = true;
    int status = 0;
    capture("scancel " + h.job_id, status);
  }
  h.last_checked_at = now;
  int status = 0;
  const std::string state = trim(capture("squeue -h -t all -j " + h.job_id + " -o %T", status));
  if (status == 0 && (state == "PENDING" || state == "RUNNING" || state == "CONFIGURING" ||
                      state == "COMPLETING" || state == "REQUEUED" || state == "SUSPENDED" ||
                      state == "RESIZING" || state == "SIGNALING" || state == "STAGE_OUT"))
    return std::nullopt;
  ChildExit e;
  e.wall_time_s = now - h.started_at;
  e.canceled = h.canceled;
  // ExitCode=code:signal of the batch script.
  const std::string info = capture("scontrol show job " + h.job_id, status);
  int code = -1, signal = 0;
  const std::size_t at = info.find("ExitCode=");
  if (at != std::string::npos) std::sscanf(info.c_str() + at, "ExitCode=%d:%d", &code, &signal);
  if (state == "COMPLETED" || state == "FAILED") {
    e.exit_code = signal ? -1 : code;
    e.signal = signal;
  } else if (state == "TIMEOUT" || state == "DEADLINE") {
    e.timed_out = true;
    e.exit_code = -1;
    e.signal = 15;
  } else if (state == "CANCELLED" && h.timed_out) {
    e.timed_out = true;
    e.exit_code = -1;
    e.signal = 15;
  } else if (state == "CANCELLED" && h.canceled) {
    e.exit_code = -1;
    e.signal = 15;
  } else {  // OUT_OF_MEMORY, NODE_FAIL, PREEMPTED, BOOT_FAIL, CANCELLED by others, or gone
    e.exit_code = -1;
    e.signal = 9;
  }
  return e;
}

void SlurmExecutor::cancel(ExecHandle& h, double) {
  if (h.canceled) return;
  h.canceled = true;
  int status = 0;
  capture("scancel " + h.job_id, status);
}

std::unique_ptr<Executor> make_executor(const std::string& name,
                                        const std::filesystem::path& binary) {
  if (name != "slurm") return std::make_unique<LocalExecutor>(binary);
  if (!SlurmExecutor::available())
    throw IoError("--executor slurm: sinfo does not answer (no Slurm cluster configured)");
  return std::make_unique<SlurmExecutor>(binary);
}

}  // namespace millsim
