// millsim run SCENE.json [--out DIR] [--quiet] [--log-interval S] [--checkpoint-wall S] [--resume]
//   [--files-root DIR] (file sources must lead inside DIR: decided as each is opened)
//   [--spin-up-cache DIR] (a gas spin-up shared with other runs of the same gas: sim/gas_spin_up.h)
//   [--threads N] [--strict-threads] (threads of the run: default the cores its affinity mask
//   allows; more than those is refused with --strict-threads; docs/threads.md)
// Validates the scene (all errors at once, exit 2, nothing written), runs it with a progress
// line on a terminal, prints the JSON summary on stdout and writes DIR/{run.h5, run.xdmf,
// result.json}, with checkpoints in DIR/checkpoints while it runs. Default DIR: out/<scene name>.
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "checkpoint/checkpoint_file.h"
#include "commands.h"
#include "core/errors.h"
#include "io/input_file.h"
#include "io/json_text.h"
#include "parallel/thread_team.h"
#include "scene/scene_json.h"
#include "sim/run.h"
#include "sim/simulation.h"

namespace millsim::cli {
namespace {

// Exit 4 at once after a failed write (a full disk, an unwritable directory). A normal exit would
// run HDF5's cleanup, which tries again to flush the file the disk refused and crashed the process
// with SIGSEGV after the message (the service then retried the run as a crash). The partial file
// stays aside as run.h5.partial; the last good run.h5 is never replaced.
[[noreturn]] void exit_after_io_error(const char* what) {
  std::fprintf(stderr, "millsim run: %s\n", what);
  std::fflush(stdout);
  std::fflush(stderr);
  std::_Exit(kEnvironment);
}

}  // namespace
namespace {

constexpr int kMaxThreads = 4096;

struct RunArgs {
  std::string scene_path;
  std::string out_dir;
  bool quiet = false;
  double log_interval_s = 10.0;
  double checkpoint_wall_s = 600.0;
  bool resume = false;
  std::string files_root;     // where file sources may lead (a service's scenes root)
  std::string spin_up_cache;  // the gas spin-up cache shared with other runs (a study's)
  int threads = 0;            // 0: the cores the affinity mask allows
  bool strict_threads = false;
};

// --threads' value: a whole number ≥ 1 (the result is the same for any of them).
bool thread_count_value(const std::string& text, int& out) {
  char* end = nullptr;
  const long n = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || n < 1 || n > kMaxThreads) {
    std::fprintf(stderr,
                 "millsim run: --threads = %s: expected a whole number of threads in [1, %d]\n",
                 text.c_str(), kMaxThreads);
    return false;
  }
  out = int(n);
  return true;
}

// The run's thread count: --threads, or every core the affinity mask allows. More threads than
// that run (slower, same result) with a warning, or are refused with --strict-threads.
bool choose_threads(const RunArgs& a, int& threads) {
  const int cores = usable_core_count();
  threads = a.threads > 0 ? a.threads : cores;
  if (threads <= cores) return true;
  std::fprintf(stderr,
               "millsim run: --threads = %d is more than the %d core%s this process may use (its "
               "affinity mask)%s\n",
               threads, cores, cores == 1 ? "" : "s",
               a.strict_threads ? "; without --strict-threads it would run oversubscribed"
                                : "; running oversubscribed (same result, slower)");
  return !a.strict_threads;
}

// A number option's value in [lo, hi], or false after saying what is allowed.
bool seconds_value(const std::string& option, const std::string& text, double lo, double hi,
                   double& out) {
  char* end = nullptr;
  out = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(out >= lo && out <= hi)) {
    std::fprintf(stderr, "millsim run: %s = %s: expected seconds in [%g, %g]\n", option.c_str(),
                 text.c_str(), lo, hi);
    return false;
  }
  return true;
}

bool parse_run_args(const std::vector<std::string>& args, RunArgs& out) {
  for (std::size_t k = 0; k < args.size(); ++k) {
    const std::string& a = args[k];
    const bool takes_value = a == "--out" || a == "--log-interval" || a == "--checkpoint-wall" ||
                             a == "--files-root" || a == "--spin-up-cache" || a == "--threads";
    if (takes_value && k + 1 >= args.size()) {
      std::fprintf(stderr, "millsim run: %s needs a value\n", a.c_str());
      return false;
    }
    if (a == "--files-root") {
      out.files_root = args[++k];
    } else if (a == "--spin-up-cache") {
      out.spin_up_cache = args[++k];
    } else if (a == "--out" && k + 1 < args.size()) {
      out.out_dir = args[++k];
    } else if (a.rfind("--out=", 0) == 0) {
      out.out_dir = a.substr(6);
    } else if (a == "--quiet" || a == "-q") {
      out.quiet = true;
    } else if (a == "--log-interval" && k + 1 < args.size()) {
      if (!seconds_value(a, args[++k], 0.01, 1e6, out.log_interval_s)) return false;
    } else if (a == "--checkpoint-wall" && k + 1 < args.size()) {
      if (!seconds_value(a, args[++k], 0.0, 1e7, out.checkpoint_wall_s)) return false;
    } else if (a == "--resume") {
      out.resume = true;
    } else if (a == "--threads") {
      if (!thread_count_value(args[++k], out.threads)) return false;
    } else if (a == "--strict-threads") {
      out.strict_threads = true;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr,
                   "millsim run: unknown option \"%s\"; allowed: --out DIR, --quiet, "
                   "--log-interval S, --checkpoint-wall S, --resume, --files-root DIR, "
                   "--spin-up-cache DIR, --threads N, --strict-threads\n",
                   a.c_str());
      return false;
    } else if (out.scene_path.empty()) {
      out.scene_path = a;
    } else {
      std::fprintf(stderr, "millsim run: unexpected argument \"%s\"; one scene file is allowed\n",
                   a.c_str());
      return false;
    }
  }
  if (out.scene_path.empty()) {
    std::fprintf(stderr, "usage: millsim run SCENE.json [--out DIR] [--quiet]\n");
    return false;
  }
  return true;
}

std::atomic<int> g_stop_signal{0};

void on_stop_signal(int signal) {
  g_stop_signal.store(signal, std::memory_order_relaxed);
}

// LAMMPS-style thermo lines for batch logs (stderr is not a terminal): a header, then one line
// every interval of wall time and one at the end, on stderr and in DIR/log.txt (once when
// stderr already is that file, as under the service's executors).
class ThermoLog {
 public:
  ThermoLog(const std::filesystem::path& dir, double interval_s) : interval_s_(interval_s) {
    std::filesystem::create_directories(dir);
    file_ = std::fopen((dir / "log.txt").c_str(), "a");
    struct stat a {
    }, b{};
    to_stderr_ = !(file_ && fstat(fileno(file_), &a) == 0 && fstat(STDERR_FILENO, &b) == 0 &&
                   a.st_dev == b.st_dev && a.st_ino == b.st_ino);
  }
  ~ThermoLog() {
    if (file_) std::fclose(file_);
  }
  ThermoLog(const ThermoLog&) = delete;
  ThermoLog& operator=(const ThermoLog&) = delete;

  void report(const RunProgress& p) {
    const bool last = p.step == p.total_steps;
    if (!header_written_) {
      write("%10s %12s %10s %9s %12s %10s %10s %9s\n", "Step", "Time_s", "Particles", "Contacts",
            "KinEng_J", "Dt_s", "PSteps/s", "ETA_s");
      header_written_ = true;
    } else if (!last && p.elapsed_s - last_s_ < interval_s_) {
      return;
    }
    last_s_ = p.elapsed_s;
    write("%10lld %12.6g %10zu %9zu %12.5g %10.4g %10.4g %9.0f\n", static_cast<long long>(p.step),
          p.time_s, p.particles, p.contacts, p.kinetic_j, p.time_step_s, p.particle_steps_per_s,
          p.eta_s);
  }

  // An event of the run (a hold-up fill), as it happens.
  void note(const std::string& text) { write("%s\n", text.c_str()); }

  // The gas spin-up before the first step: a line at its start, every interval and at its end.
  void report_spin_up(const SpinUpProgress& p) {
    if (spin_up_lines_ > 0 && !p.last && p.elapsed_s - last_spin_up_s_ < interval_s_) return;
    ++spin_up_lines_;
    last_spin_up_s_ = p.elapsed_s;
    if (p.waiting) {
      write("spin-up: waiting for another run spinning up the same gas (%.0f s)\n", p.elapsed_s);
      return;
    }
    write("spin-up: gas %.4g of %.4g s (%.0f %%), %llu gas steps, elapsed %.1f s, ETA %.0f s%s\n",
          p.done_s, p.total_s, 100.0 * p.done_s / p.total_s,
          static_cast<unsigned long long>(p.steps), p.elapsed_s, p.eta_s, p.last ? ", done" : "");
  }

 private:
  template <class... Args>
  void write(const char* format, Args... args) {
    if (to_stderr_) std::fprintf(stderr, format, args...);
    if (file_) {
      std::fprintf(file_, format, args...);
      std::fflush(file_);
    }
  }
  double interval_s_;
  double last_s_ = 0.0;
  double last_spin_up_s_ = 0.0;
  int spin_up_lines_ = 0;
  bool header_written_ = false;
  bool to_stderr_ = true;
  std::FILE* file_ = nullptr;
};

void print_progress(const RunProgress& p) {
  const double percent = 100.0 * double(p.step) / double(std::max<std::int64_t>(1, p.total_steps));
  std::fprintf(
      stderr,
      "\r[%5.1f%%] step %lld/%lld  t = %.4g s  particles %zu  elapsed %.1f s  ETA %.1f s   ",
      percent, static_cast<long long>(p.step), static_cast<long long>(p.total_steps), p.time_s,
      p.particles, p.elapsed_s, p.eta_s);
  if (p.step == p.total_steps) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

void print_spin_up_progress(const SpinUpProgress& p) {
  if (p.waiting)
    std::fprintf(stderr, "\r[spin-up] waiting for another run spinning up the same gas, %.0f s   ",
                 p.elapsed_s);
  else
    std::fprintf(stderr, "\r[spin-up %5.1f%%] gas %.4g of %.4g s  elapsed %.1f s  ETA %.1f s   ",
                 100.0 * p.done_s / p.total_s, p.done_s, p.total_s, p.elapsed_s, p.eta_s);
  if (p.last) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

}  // namespace

int cmd_run(const std::vector<std::string>& args) {
  RunArgs run_args;
  if (!parse_run_args(args, run_args)) return kBadInput;
  int threads = 1;
  if (!choose_threads(run_args, threads)) return kBadInput;
  set_thread_count(threads);
  try {
    SceneConfig scene = load_scene(run_args.scene_path);
    scene.files_root = run_args.files_root;
    RunOptions options;
    options.out_dir = run_args.out_dir.empty() ? std::filesystem::path("out") / scene.name
                                               : std::filesystem::path(run_args.out_dir);
    // With checkpoints to resume from, the start state is replaced: no gas spin-up for it.
    // Otherwise the run loop spins the gas up (reported, stoppable, shared through the cache).
    Simulation sim(scene,
                   run_args.resume && !list_checkpoints(options.out_dir / "checkpoints").empty()
                       ? SimulationStart::ForRestore
                       : SimulationStart::AfterSpinUp);
    options.spin_up_cache_dir = run_args.spin_up_cache;
    options.scene_text = read_input_file(run_args.scene_path, {});
    options.scene_path = run_args.scene_path;
    options.checkpoint_wall_s = run_args.checkpoint_wall_s;
    options.resume = run_args.resume;
    std::unique_ptr<ThermoLog> thermo;
    if (isatty(STDERR_FILENO)) {
      if (!run_args.quiet) options.on_progress = print_progress;
      if (!run_args.quiet) options.on_spin_up_progress = print_spin_up_progress;
      if (!run_args.quiet)
        options.on_notice = [](const std::string& text) {
          std::fprintf(stderr, "\n%s\n", text.c_str());  // below the progress line
        };
    } else {
      thermo = std::make_unique<ThermoLog>(options.out_dir, run_args.log_interval_s);
      options.on_progress = [&thermo](const RunProgress& p) { thermo->report(p); };
      options.on_spin_up_progress = [&thermo](const SpinUpProgress& p) {
        thermo->report_spin_up(p);
      };
      options.on_notice = [&thermo](const std::string& text) { thermo->note(text); };
    }
    // SIGINT (Ctrl-C), SIGTERM (a batch system's stop, a wall-time limit) and SIGUSR1 end the
    // run after the step under way, with run.h5 and result.json complete.
    struct sigaction action = {};
    action.sa_handler = on_stop_signal;
    for (const int sig : {SIGINT, SIGTERM, SIGUSR1}) sigaction(sig, &action, nullptr);
    options.stop_request = &g_stop_signal;
    if (!run_args.quiet)
      std::fprintf(stderr, "millsim run: %s, %zu particles, dt = %.4g s (%s), %lld steps -> %s\n",
                   scene.name.c_str(), sim.particles().size(), sim.time_step().step_s,
                   sim.time_step().automatic ? "auto" : "fixed",
                   static_cast<long long>(sim.total_steps()), options.out_dir.c_str());
    const RunOutcome outcome = run_simulation(sim, scene, options);
    std::cout << readable_json(outcome.summary) << std::endl;
    if (outcome.failure) {
      std::fprintf(stderr, "\nrun stopped at step %lld (t = %.4g s): %s\n",
                   static_cast<long long>(outcome.failure->step), outcome.failure->time_s,
                   outcome.failure->detail.c_str());
      return kUnstable;
    }
    if (outcome.interrupted_by != 0 && outcome.summary["interrupted"].contains("phase")) {
      std::fprintf(stderr,
                   "\nmillsim run: interrupted by %s during the gas spin-up (%.4g of %.4g s); "
                   "result.json says so%s\n",
                   outcome.summary["interrupted"]["signal"].get<std::string>().c_str(),
                   outcome.summary["spin_up"]["done_s"].get<double>(),
                   outcome.summary["spin_up"]["gas_time_s"].get<double>(),
                   outcome.summary.contains("checkpoints")
                       ? " and checkpoints/spin-up.ckpt holds the gas: --resume continues it"
                       : "");
      return 128 + outcome.interrupted_by;
    }
    if (outcome.interrupted_by != 0) {
      std::fprintf(stderr,
                   "\nmillsim run: interrupted by %s at step %lld of %lld; run.h5 and "
                   "result.json are complete up to there\n",
                   outcome.summary["interrupted"]["signal"].get<std::string>().c_str(),
                   static_cast<long long>(sim.step_index()),
                   static_cast<long long>(sim.total_steps()));
      return 128 + outcome.interrupted_by;  // the shell's convention: 130 for SIGINT, 143 SIGTERM
    }
    return kOk;
  } catch (const InputErrorList& e) {
    std::fprintf(stderr, "%s\n", format_input_errors(run_args.scene_path, e.errors()).c_str());
    return kBadInput;
  } catch (const ResumeError& e) {
    std::fprintf(stderr, "millsim run: --resume: %s\n", e.what());
    return kBadInput;
  } catch (const IoError& e) {
    exit_after_io_error(e.what());
  } catch (const std::filesystem::filesystem_error& e) {
    exit_after_io_error(e.what());
  }
}

}  // namespace millsim::cli
