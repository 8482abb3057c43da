#include "help.h"

#include "sim/run.h"

namespace millsim::cli {
namespace {

constexpr const char* kExitCodes[][2] = {
    {"0", "ok"},
    {"1",
     "the work failed (a failed run in a study that was waited for, a regression drift) or "
     "something unexpected"},
    {"2", "usage or bad input (every problem is listed; nothing is run or stored)"},
    {"3", "a run stopped by the stability guard"},
    {"4", "an I/O error (disk, database) or an unreachable server"},
};

const OptionHelp kServer = {"--server URL", "http://127.0.0.1:8080",
                            "the millsim serve to talk to"};
const OptionHelp kToken = {"--token-file FILE", "$MILLSIM_TOKEN",
                           "read the bearer token from the file's first line (never on the "
                           "command line: ps shows argv)"};

// `text` broken into lines of at most `width` characters, each after `indent` spaces (the first
// line too, unless `first_indent` is false).
std::string wrapped(const std::string& text, std::size_t indent, std::size_t width,
                    bool first_indent = true) {
  std::string out = first_indent ? std::string(indent, ' ') : "", word;
  std::size_t column = indent;
  auto flush = [&] {
    if (word.empty()) return;
    if (column > indent && column + 1 + word.size() > width) {
      out.append("\n").append(indent, ' ');
      column = indent;
    } else if (column > indent) {
      out += ' ';
      ++column;
    }
    out += word;
    column += word.size();
    word.clear();
  };
  for (const char c : text) {
    if (c == ' ') {
      flush();
    } else if (c == '\n') {
      flush();
      out.append("\n").append(indent, ' ');
      column = indent;
    } else {
      word += c;
    }
  }
  flush();
  return out;
}

std::string roff_escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '\\')
      out += "\\e";
    else if (c == '-')
      out += "\\-";
    else
      out += c;
  }
  // A line starting with . or ' would be a roff request.
  if (!out.empty() && (out[0] == '.' || out[0] == '\'')) out = "\\&" + out;
  return out;
}

}  // namespace

const std::vector<VerbHelp>& verb_help() {
  static const std::vector<VerbHelp> verbs = {
      {"run",
       "run one scene",
       "millsim run SCENE.json [--out DIR] [--quiet] [--log-interval S] [--checkpoint-wall S] "
       "[--resume] [--files-root DIR] [--spin-up-cache DIR] [--threads N] [--strict-threads]",
       "Validates the scene (every error at once, exit 2, nothing written), spins its gas up "
       "(gas.spin_up_s, with progress lines), runs it with a progress line on a terminal, prints "
       "the JSON summary on stdout and writes DIR/run.h5, run.xdmf and result.json. While it "
       "runs it keeps its two newest checkpoints in DIR/checkpoints, removed when it ends "
       "complete. SIGINT, SIGTERM and SIGUSR1 stop it after the step under way with a checkpoint "
       "and every file complete (result.json status \"interrupted\", exit 128 + the signal), "
       "during the gas spin-up too (DIR/checkpoints/spin-up.ckpt); --resume continues it bit for "
       "bit.",
       {{"--out DIR", "out/<scene name>", "where the run's files go"},
        {"--quiet", "off", "no start line and no progress line on a terminal"},
        {"--log-interval S", "10",
         "seconds of wall time between thermo lines (step, time, particles, contacts, kinetic "
         "energy, time step, particle-steps/s, ETA) on stderr and in DIR/log.txt when stderr is "
         "not a terminal"},
        {"--checkpoint-wall S", "600",
         "seconds of wall time between checkpoints (0: none by wall clock; the scene's "
         "output.checkpoint_interval_s adds checkpoints by simulated time)"},
        {"--resume", "off",
         "continue from the newest valid checkpoint in DIR/checkpoints (the one before when it is "
         "damaged; from the start when there is none); exit 2 for another scene's or build's"},
        {"--files-root DIR", "none",
         "every file source must be a regular file inside DIR, checked as it is opened (after "
         "symlinks); a service's workers pass the server's scenes root"},
        {"--spin-up-cache DIR", "none",
         "share the gas spin-up with other runs of the same gas inputs (gas, mill, domain, "
         "gravity): read it from DIR when one left it there, else spin up and leave it; a run "
         "waits while another spins up the same gas. Bit for bit the same run; a study's runs "
         "share one in <study>/spin-up-cache"},
        {"--threads N", "the affinity mask's cores",
         "threads of this run (N >= 1). The physics in result.json and run.h5 is the same bit for "
         "bit on any number of threads, and a checkpoint resumes on any number (docs/threads.md)"},
        {"--strict-threads", "off",
         "refuse (exit 2) a --threads above the cores the affinity mask allows, instead of "
         "running oversubscribed"}},
       "millsim run cases/spiral_jet_mill.json --out out/mill"},
      {"study",
       "run a parameter study on this machine",
       "millsim study STUDY.json --local [--db FILE] [--out DIR] [--workers N] [--format "
       "table|json|csv] [--resume STUDY_ID] [--executor local|slurm]",
       "Expands and validates the study, records it in the SQLite file, runs its runs as `millsim "
       "run` children and prints the results table: each run's error against the reference run "
       "and its run time. Writes DIR/<study>/results.json, results.csv, error_vs_time.svg (with a "
       "reference run) and psd.svg (every run's outlet PSD, when the runs have one). With "
       "--executor slurm, the study file's \"slurm\" key sets its batch jobs' options: "
       "partition, account, qos and sbatch_args (docs/studies.md, \"On Slurm\").",
       {{"--local", "required", "run here (the server's queue is `millsim submit`)"},
        {"--db FILE", "out/millsim.db", "the SQLite file of studies and runs"},
        {"--out DIR", "out/studies", "run directories and results"},
        {"--workers N", "one per core",
         "runs at once; workers x the study's limits.threads_per_run must fit the cores"},
        {"--format F", "table", "table, json or csv"},
        {"--resume STUDY_ID", "", "finish a study a previous runner left"},
        {"--executor E", "local", "local children, or slurm batch jobs"}},
       "millsim study cases/spiral_jet_mill_quick_scan.study.json --local"},
      {"regress",
       "run a regression suite against its baseline",
       "millsim regress SUITE.json [--local | --server URL] [--db FILE] [--out DIR] [--workers "
       "N] [--junit FILE] [--format table|json] [--update-baseline]\n"
       "       millsim regress --history CHECK[/QUANTITY] [--suite NAME] [--db FILE | --server "
       "URL]",
       "Runs each check of the suite as a study (here or on a server), compares the chosen "
       "quantities with the baseline, prints the drift table and records the run in the "
       "history. A scene check with `repeats` runs that many seeds and compares their mean "
       "(a tolerance in `sigmas`: standard errors of the difference from the baseline's mean). "
       "Exit 1 on any drift or failed run. docs/regression.md.",
       {{"--local", "on", "run the checks on this machine"},
        kServer,
        kToken,
        {"--db FILE", "out/millsim.db", "the SQLite file (queue and history) with --local"},
        {"--out DIR", "out/regress", "run directories with --local"},
        {"--workers N", "one per core", "runs at once with --local"},
        {"--executor E", "local", "local children, or slurm batch jobs"},
        {"--junit FILE", "", "also write JUnit XML"},
        {"--format F", "table", "table or json"},
        {"--update-baseline", "off",
         "write the baseline from this run (refused if a check failed)"},
        {"--history CHECK[/QUANTITY]", "", "show a check's quantities across past runs"},
        {"--suite NAME", "all", "with --history: only this suite's runs"}},
       "millsim regress cases/regression/physics.json --workers 1 --junit out/junit.xml"},
      {"serve",
       "the batch service: HTTP API, queue and workers",
       "millsim serve [--host H] [--port P] [--db FILE] [--workers N] [--out DIR] [--scenes DIR] "
       "[--lease S] [--max-body BYTES] [--max-runs N] [--max-study-bytes BYTES] [--worker-port P] "
       "[--max-connections N] [--max-connections-per-client N] [--receive-timeout S] "
       "[--token-file FILE]",
       "Serves the HTTP API (docs/openapi.yaml), owns the SQLite file and starts the workers. The "
       "token comes from MILLSIM_TOKEN or --token-file, never from the command line (ps shows "
       "it); without one a token is generated and printed.",
       {{"--host H", "127.0.0.1", "address to listen on (beyond loopback, reads need the token)"},
        {"--port P", "8080", "0 picks a free port"},
        {"--db FILE", "millsim.db", "the SQLite file"},
        {"--workers N", "one per core",
         "worker processes to start (0: none); at most the cores of the affinity mask, and a "
         "study whose workers x limits.threads_per_run exceed them is refused (docs/threads.md)"},
        {"--out DIR", "out/studies", "run directories"},
        {"--scenes DIR", ".", "scene paths in submitted studies resolve here"},
        {"--lease S", "30", "seconds a worker's claim lasts without a heartbeat"},
        {"--max-body BYTES", "1048576", "largest request body"},
        {"--max-runs N", "10000", "largest study"},
        {"--max-study-bytes BYTES", "268435456",
         "most a study may store: its runs' scenes summed (HTTP 413 beyond)"},
        {"--worker-port P", "0 (a free port)",
         "a second port serving only the worker protocol; the started workers use it, so slow "
         "public clients cannot make them miss their heartbeats"},
        {"--max-connections N", "64",
         "open connections per port; one over it gets 503 busy (a health probe still 200)"},
        {"--max-connections-per-client N", "half of --max-connections",
         "open connections one source address may hold, so one client cannot take every slot"},
        {"--receive-timeout S", "10",
         "seconds a request's head and body may take to arrive (slow clients are cut)"},
        kToken},
       "MILLSIM_TOKEN=secret millsim serve --port 8080 --workers 2"},
      {"worker",
       "one worker: claims runs from a server and runs them",
       "millsim worker [--server URL] [--name NAME] [--until-empty] [--executor local|slurm] "
       "[--slots N] [--partition P] [--account A] [--qos Q] [--sbatch-args ARGS]",
       "Claims runs from the server and executes each as a `millsim run` child or a Slurm batch "
       "job. SIGTERM or SIGINT stop it; its runs go back to the queue.",
       {kServer,
        kToken,
        {"--name NAME", "host-pid", "the worker's name in the run log"},
        {"--until-empty", "off", "exit when nothing is queued"},
        {"--executor E", "local", "local children, or slurm batch jobs"},
        {"--slots N", "1", "runs (or batch jobs) at once"},
        {"--partition P", "", "Slurm partition of every job (a study's own `slurm` wins)"},
        {"--account A", "", "Slurm account of every job"},
        {"--qos Q", "", "Slurm QOS of every job"},
        {"--sbatch-args ARGS", "", "extra sbatch arguments, e.g. \"--constraint=avx2\""}},
       "millsim worker --server http://login:8080 --executor slurm --slots 64"},
      {"submit",
       "submit a study to the server",
       "millsim submit STUDY.json [--wait] [--format table|json|csv] [--idempotency-key K] "
       "[--server URL]",
       "Sends the study (its scene inline) to the server's queue and prints the study id; with "
       "--wait, follows it to the end and prints the results table (exit 1 if a run failed).",
       {kServer,
        kToken,
        {"--wait", "off", "wait for the study and print its results"},
        {"--format F", "table", "table, json or csv (with --wait)"},
        {"--idempotency-key K", "", "submitting again with the same key returns the same study"}},
       "millsim submit cases/dust_threshold_scan.study.json --wait"},
      {"status",
       "the server's studies, or one study's progress",
       "millsim status [STUDY] [--watch] [--format table|json|csv] [--server URL]",
       "Without a study: the newest 100 studies with their progress, newest first. With one: "
       "its progress by state and its runs.",
       {kServer,
        kToken,
        {"--watch", "off", "follow the study until it finishes"},
        {"--format F", "table", "table, json or csv"}},
       "millsim status s000001"},
      {"results",
       "a study's results table",
       "millsim results STUDY [--format table|json|csv] [--server URL]",
       "Each run's parameters, state, run time, outlet d10/d50/d90 and error against the "
       "reference run.",
       {kServer, kToken, {"--format F", "table", "table, json or csv"}},
       "millsim results s000001 --format csv"},
      {"psd",
       "a run's outlet PSD",
       "millsim psd RUN [--server URL]",
       "The run's full outlet PSD (outlet particles and the dust table) as JSON.",
       {kServer, kToken},
       "millsim psd s000001-r3"},
      {"cancel",
       "cancel a study",
       "millsim cancel STUDY [--server URL]",
       "Queued runs are canceled at once, running ones are stopped by their workers. A study "
       "that has finished cannot be canceled (exit 2).",
       {kServer, kToken},
       "millsim cancel s000001"},
  };
  return verbs;
}

const VerbHelp* find_verb_help(const std::string& name) {
  for (const VerbHelp& v : verb_help())
    if (name == v.name) return &v;
  return nullptr;
}

void print_exit_codes(std::FILE* to) {
  std::fprintf(to, "\nexit codes:\n");
  for (const auto& code : kExitCodes)
    std::fprintf(to, "  %s  %s\n", code[0], wrapped(code[1], 5, 96, false).c_str());
}

void print_overview(std::FILE* to) {
  std::fprintf(to, "millsim %s: CFD-DEM for wide particle size distributions\n\n", kMillsimVersion);
  std::fprintf(to, "usage: millsim VERB [OPTIONS]   (millsim VERB --help, millsim help VERB)\n\n");
  for (const VerbHelp& v : verb_help()) std::fprintf(to, "  %-8s %s\n", v.name, v.summary);
  std::fprintf(to, "  %-8s %s\n", "help", "this text, or a verb's: millsim help VERB");
  std::fprintf(to, "  %-8s %s\n", "version", "print the version");
  print_exit_codes(to);
}

void print_verb_help(const VerbHelp& v, std::FILE* to) {
  std::fprintf(to, "usage: %s\n\n%s\n\noptions:\n", v.usage, wrapped(v.description, 0, 96).c_str());
  for (const OptionHelp& o : v.options) {
    std::string meaning = o.meaning;
    if (*o.fallback) meaning += std::string(" (default: ") + o.fallback + ")";
    std::fprintf(to, "  %-28s %s\n", o.flag, wrapped(meaning, 31, 96, false).c_str());
  }
  std::fprintf(to, "  %-28s %s\n", "--help", "this text");
  std::fprintf(to, "\nexample:\n  %s\n", v.example);
  print_exit_codes(to);
}

void print_verb_usage(const char* verb, std::FILE* to) {
  if (const VerbHelp* v = find_verb_help(verb))
    std::fprintf(to, "usage: %s\n(millsim %s --help for every option)\n", v->usage, verb);
}

std::string man_page() {
  std::string out = ".TH MILLSIM 1 \"\" \"millsim " + std::string(kMillsimVersion) +
                    "\" \"User Commands\"\n.SH NAME\nmillsim \\- CFD\\-DEM for wide particle size "
                    "distributions, and its batch service\n.SH SYNOPSIS\n";
  for (const VerbHelp& v : verb_help()) out += ".B\n" + roff_escaped(v.usage) + "\n.br\n";
  out += ".SH DESCRIPTION\nOne verb per task; each takes \\fB\\-\\-help\\fR.\n";
  for (const VerbHelp& v : verb_help()) {
    out += ".SS " + std::string(v.name) + "\n" + roff_escaped(v.description) + "\n";
    for (const OptionHelp& o : v.options) {
      out += ".TP\n.B " + roff_escaped(o.flag) + "\n" + roff_escaped(o.meaning);
      if (*o.fallback) out += " (default: " + roff_escaped(o.fallback) + ")";
      out += "\n";
    }
    out += ".PP\nExample:\n.nf\n" + roff_escaped(v.example) + "\n.fi\n";
  }
  out += ".SH EXIT STATUS\n";
  for (const auto& code : kExitCodes)
    out += ".TP\n.B " + std::string(code[0]) + "\n" + roff_escaped(code[1]) + "\n";
  out +=
      ".SH ENVIRONMENT\n.TP\n.B MILLSIM_TOKEN\nthe service's bearer token (serve, worker and "
      "the client verbs)\n.SH SEE ALSO\nThe documentation in the docs/ folder of the source: "
      "scene\\-format.md, studies.md, regression.md, openapi.yaml.\n";
  return out;
}

}  // namespace millsim::cli
