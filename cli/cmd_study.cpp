// millsim study STUDY.json --local [--db FILE] [--out DIR] [--workers N]
//                                  [--format table|json|csv] [--resume STUDY_ID]
//                                  [--executor local|slurm]
// Expands and validates the study (all errors at once, exit 2, nothing queued), records it in
// the SQLite file, runs its runs as `millsim run` children (N at a time, default one per core),
// and prints the results table with each run's error against the reference run and its run time;
// writes DIR/<study>/results.json, results.csv, error_vs_time.svg and psd.svg. --resume finishes a
// study a previous runner left (runs it had leased are taken again when their lease expires). Exit
// 0 when every run completed, 1 when some failed, 2 bad input, 4 database or disk error.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>

#include "commands.h"
#include "executors/local_runner.h"
#include "executors/slurm_executor.h"
#include "parallel/thread_team.h"
#include "queue/database_lock.h"
#include "studies/results.h"
#include "studies/study.h"

namespace millsim::cli {
namespace {

constexpr int kMaxRunsPerStudy = 10000;

struct StudyArgs {
  std::string study_path;
  bool local = false;
  std::string db = "out/millsim.db";
  std::string out = "out/studies";
  int workers = 0;
  std::string format = "table";
  std::string resume;
  std::string executor = "local";
};

bool parse_study_args(const std::vector<std::string>& args, StudyArgs& out) {
  for (std::size_t k = 0; k < args.size(); ++k) {
    const std::string& a = args[k];
    const bool has_value = k + 1 < args.size();
    if (a == "--local") {
      out.local = true;
    } else if (a == "--db" && has_value) {
      out.db = args[++k];
    } else if (a == "--out" && has_value) {
      out.out = args[++k];
    } else if (a == "--workers" && has_value) {
      out.workers = std::atoi(args[++k].c_str());
      if (out.workers < 1 || out.workers > 1024) {
        std::fprintf(stderr, "millsim study: --workers = %s: expected an integer in [1, 1024]\n",
                     args[k].c_str());
        return false;
      }
    } else if (a == "--format" && has_value) {
      out.format = args[++k];
      if (out.format != "table" && out.format != "json" && out.format != "csv") {
        std::fprintf(stderr, "millsim study: --format = %s: expected table, json or csv\n",
                     out.format.c_str());
        return false;
      }
    } else if (a == "--resume" && has_value) {
      out.resume = args[++k];
    } else if (a == "--executor" && has_value) {
      out.executor = args[++k];
      if (out.executor != "local" && out.executor != "slurm") {
        std::fprintf(stderr, "millsim study: --executor = %s: expected local or slurm\n",
                     out.executor.c_str());
        return false;
      }
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr,
                   "millsim study: unknown option \"%s\"; allowed: --local, --db FILE, --out DIR, "
                   "--workers N, --format table|json|csv, --resume STUDY_ID, "
                   "--executor local|slurm\n",
                   a.c_str());
      return false;
    } else if (out.study_path.empty()) {
      out.study_path = a;
    } else {
      std::fprintf(stderr, "millsim study: unexpected argument \"%s\"\n", a.c_str());
      return false;
    }
  }
  if (out.study_path.empty() && out.resume.empty()) {
    std::fprintf(stderr,
                 "usage: millsim study STUDY.json --local [--db FILE] [--out DIR] "
                 "[--workers N] [--format table|json|csv] [--resume STUDY_ID]\n");
    return false;
  }
  if (!out.local) {
    std::fprintf(stderr,
                 "millsim study: add --local to run the study on this machine, or send it to a "
                 "server with millsim submit STUDY.json --server URL (millsim serve starts one)\n");
    return false;
  }
  return true;
}

// On a terminal one line redrawn; off one (a log, CI) a line each time a run starts or ends.
void print_progress(const Progress& p) {
  static int last_done = -1, last_running = -1;
  const int done = p.total - p.count(RunState::Queued) - p.count(RunState::Running) -
                   p.count(RunState::Canceling);
  const bool terminal = isatty(STDERR_FILENO);
  if (!terminal && done == last_done && p.count(RunState::Running) == last_running) return;
  last_done = done, last_running = p.count(RunState::Running);
  std::fprintf(stderr, "%s[%d/%d] running %d, complete %d, failed %d%s", terminal ? "\r" : "", done,
               p.total, p.count(RunState::Running), p.count(RunState::Complete),
               p.count(RunState::ExecutorError) + p.count(RunState::SystemError),
               terminal ? "   " : "\n");
}

}  // namespace

int cmd_study(const std::vector<std::string>& args) {
  StudyArgs a;
  if (!parse_study_args(args, a)) return kBadInput;
  std::optional<Study> study;
  if (a.resume.empty()) {
    try {
      study = load_study(a.study_path, kMaxRunsPerStudy);
    } catch (const InputErrorList& e) {
      std::fprintf(stderr, "%s", format_input_errors(a.study_path, e.errors()).c_str());
      return kBadInput;
    }
  }
  const int workers = a.workers > 0 ? a.workers : usable_core_count();
  if (study)
    if (const std::optional<InputError> p =
            thread_budget_problem(study->limits.threads_per_run, workers, usable_core_count())) {
      std::fprintf(stderr, "%s", format_input_errors(a.study_path, {*p}).c_str());
      return kBadInput;
    }
  try {
    std::filesystem::create_directories(std::filesystem::path(a.db).parent_path().empty()
                                            ? "."
                                            : std::filesystem::path(a.db).parent_path());
    const DatabaseLock lock(a.db);  // not a database a server holds
    Store store(a.db);
    const std::filesystem::path out_root = std::filesystem::absolute(a.out);
    std::string study_id = a.resume;
    if (study) {
      study_id = store.submit(*study, std::nullopt, out_root, wall_clock_s()).study_id;
      std::fprintf(stderr, "millsim study: %s, %zu runs, recorded as %s in %s\n",
                   study->name.c_str(), study->runs.size(), study_id.c_str(), a.db.c_str());
    } else if (!store.study(study_id)) {
      std::fprintf(stderr, "millsim study: no study \"%s\" in %s\n", study_id.c_str(),
                   a.db.c_str());
      return kBadInput;
    }
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
    const std::unique_ptr<Executor> executor = make_executor(a.executor, self);
    LocalRunOptions options;
    options.workers = workers;
    options.on_progress = print_progress;
    run_study_locally(store, study_id, *executor, options);
    if (isatty(STDERR_FILENO)) std::fprintf(stderr, "\n");

    const nlohmann::ordered_json table = results_table(store, study_id);
    const std::filesystem::path dir = out_root / study_id;
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "results.json") << table.dump(2) << "\n";
    std::ofstream(dir / "results.csv") << results_csv(table);
    if (table["reference_run"].is_string())
      std::ofstream(dir / "error_vs_time.svg") << error_vs_time_svg(table);
    if (const std::string psd = psd_svg(store, study_id); !psd.empty())
      std::ofstream(dir / "psd.svg") << psd;
    if (a.format == "json")
      std::cout << table.dump(2) << std::endl;
    else if (a.format == "csv")
      std::cout << results_csv(table);
    else
      // Named as the user gave the output folder (relative stays relative).
      std::cout << results_text(table) << "results: "
                << (std::filesystem::path(a.out) / study_id / "results.json").string() << "\n";
    const Progress p = store.progress(study_id);
    return p.count(RunState::Complete) == p.total ? kOk : kUnexpected;
  } catch (const DbError& e) {
    std::fprintf(stderr, "millsim study: %s\n", e.what());
    return kEnvironment;
  } catch (const IoError& e) {
    std::fprintf(stderr, "millsim study: %s\n", e.what());
    return kEnvironment;
  }
}

}  // namespace millsim::cli
