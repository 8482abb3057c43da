#include "executors/executor.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/errors.h"
#include "core/json_reader.h"

namespace millsim {

double wall_clock_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

LocalExecutor::LocalExecutor(std::filesystem::path millsim_binary)
    : binary_(std::move(millsim_binary)) {}

std::filesystem::path spin_up_cache_dir(const RunRecord& run) {
  return std::filesystem::absolute(run.out_dir).lexically_normal().parent_path() / "spin-up-cache";
}

void prepare_run_directory(const RunRecord& run) {
  const std::filesystem::path dir = run.out_dir;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw IoError("cannot create " + dir.string() + ": " + ec.message());
  std::filesystem::remove(dir / "result.json", ec);  // a previous attempt's
  std::ofstream scene(dir / "scene.json", std::ios::trunc);
  scene << nlohmann::json::parse(run.scene).dump(1) << "\n";
  if (!scene) throw IoError("cannot write " + (dir / "scene.json").string());
}

ExecHandle LocalExecutor::start(const RunRecord& run, double now) {
  ExecHandle h;
  h.out_dir = run.out_dir;
  prepare_run_directory(run);
  const std::string log = (h.out_dir / "log.txt").string();
  const std::string binary = binary_.string();
  const std::string dir = h.out_dir.string();
  // The engine's arguments and environment, made before fork (the child only execs). It needs
  // no service token: MILLSIM_TOKEN is not passed on. --files-root: the run's file sources are
  // checked as they are opened, not only when the study was posted.
  std::vector<std::string> arg_text = {"millsim", "run",     "scene.json", "--out",
                                       ".",       "--quiet", "--resume"};
  if (!run.files_root.empty()) {
    arg_text.push_back("--files-root");
    arg_text.push_back(run.files_root);
  }
  arg_text.push_back("--spin-up-cache");
  arg_text.push_back(spin_up_cache_dir(run).string());
  arg_text.push_back("--threads");
  arg_text.push_back(std::to_string(std::max(1, run.threads)));
  std::vector<char*> argv;
  for (std::string& a : arg_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<char*> envp;
  for (char** e = environ; *e; ++e)
    if (std::strncmp(*e, "MILLSIM_TOKEN=", 14) != 0) envp.push_back(*e);
  envp.push_back(nullptr);
  [[maybe_unused]] const rlim_t memory = rlim_t(run.memory_limit_mb * 1024.0 * 1024.0);

  const pid_t pid = fork();
  if (pid < 0) throw IoError("fork failed");
  if (pid == 0) {  // child: only async-signal-safe calls until exec
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // dies with its worker (no orphan writing the directory)
    if (chdir(dir.c_str()) != 0) _exit(4);
    // log.txt is the run's log: its stderr (thermo lines, messages). Its stdout carries only the
    // JSON summary, result.json's copy, which would otherwise be the tail of a finished run's log.
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    const int null_fd = open("/dev/null", O_WRONLY);
    if (fd < 0 || null_fd < 0) _exit(4);
    dup2(null_fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    close(fd);
    close(null_fd);
#ifndef MILLSIM_SANITIZED  // ASan reserves terabytes of address space for its shadow
    const struct rlimit limit = {memory, memory};
    setrlimit(RLIMIT_AS, &limit);
#endif
    // --resume: a later attempt continues from the checkpoints an earlier one left.
    execve(binary.c_str(), argv.data(), envp.data());
    _exit(4);  // exec failed: an environment error
  }
  setpgid(pid, pid);  // also from the parent, so the group exists before any kill
  h.pid = pid;
  h.started_at = now;
  h.deadline = now + run.wall_limit_s;
  return h;
}

std::optional<ChildExit> LocalExecutor::poll(ExecHandle& h, double now) {
  int status = 0;
  const pid_t done = waitpid(h.pid, &status, WNOHANG);
  if (done == h.pid) {
    // The child is gone; stop anything it left in its group.
    kill(-h.pid, SIGKILL);
    ChildExit e;
    e.timed_out = h.timed_out;
    e.canceled = h.canceled;
    e.wall_time_s = now - h.started_at;
    if (WIFEXITED(status)) {
      e.exit_code = WEXITSTATUS(status);
    } else {
      e.exit_code = -1;
      e.signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    }
    return e;
  }
  if (h.term_sent_at == 0.0 && now >= h.deadline) {
    h.timed_out = true;
    h.term_sent_at = now;
    kill(-h.pid, SIGTERM);
  } else if (h.term_sent_at > 0.0 && now - h.term_sent_at > kGraceSeconds) {
    kill(-h.pid, SIGKILL);
  }
  return std::nullopt;
}

void LocalExecutor::cancel(ExecHandle& h, double now) {
  if (h.term_sent_at > 0.0) return;
  h.canceled = true;
  h.term_sent_at = now;
  kill(-h.pid, SIGTERM);
}

std::string tail_of_file(const std::filesystem::path& path, std::size_t max_lines) {
  std::ifstream in(path);
  if (!in) return "";
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    lines.push_back(line);
    if (lines.size() > max_lines) lines.erase(lines.begin());
  }
  std::string out;
  for (const std::string& l : lines) out.append(l).append("\n");
  return valid_utf8(out);  // a log may hold any bytes; what is served is JSON text
}

FinishReport report_from_exit(const ChildExit& e, const std::filesystem::path& out_dir) {
  FinishReport r;
  r.exit_code = e.exit_code >= 0 ? std::optional<int>(e.exit_code) : std::nullopt;
  r.wall_time_s = e.wall_time_s;
  if (e.canceled) {
    r.state = RunState::Canceled;
    r.error = "canceled";
    return r;
  }
  if (e.timed_out) {
    r.state = RunState::ExecutorError;  // the limit is the study's: trying again would not help
    r.error = concat("stopped at the wall-time limit after ", e.wall_time_s, " s");
    return r;
  }
  const ChildOutcome outcome = classify_child_exit(e.exit_code, e.signal);
  r.state = outcome.state;
  r.retryable = outcome.retryable;
  std::ifstream result(out_dir / "result.json");
  if (result) {
    std::stringstream text;
    text << result.rdbuf();
    r.result = text.str();
  }
  if (r.state != RunState::Complete) {
    r.error = e.signal ? concat("killed by signal ", e.signal, " (memory limit, OOM or kill)\n")
                       : concat("exit status ", e.exit_code, "\n");
    r.error += tail_of_file(out_dir / "log.txt", 20);
  }
  return r;
}

}  // namespace millsim
