// millsim: the command-line front end. A table of verbs; each verb lives in cmd_<verb>.cpp.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "commands.h"
#include "sim/run.h"

namespace {

struct Verb {
  const char* name;
  int (*run)(const std::vector<std::string>&);
  const char* summary;
};

constexpr Verb kVerbs[] = {
    {"run", millsim::cli::cmd_run, "run one scene: millsim run SCENE.json [--out DIR] [--quiet]"},
    {"study", millsim::cli::cmd_study,
     "run a parameter study on this machine: millsim study STUDY.json --local [--db FILE] "
     "[--out DIR] [--workers N] [--format table|json|csv] [--resume STUDY_ID]"},
    {"serve", millsim::cli::cmd_serve,
     "the batch service: millsim serve [--host H] [--port P] [--db FILE] [--token T] "
     "[--workers N] [--out DIR] [--scenes DIR] [--lease S]"},
    {"worker", millsim::cli::cmd_worker,
     "one worker: millsim worker [--server URL] [--token T] [--name NAME] [--until-empty]"},
    {"regress", millsim::cli::cmd_regress,
     "run a regression suite against its baseline: millsim regress SUITE.json [--local | "
     "--server URL] [--junit FILE] [--format table|json] [--update-baseline]; past runs: "
     "millsim regress --history CHECK[/QUANTITY]"},
    {"submit", millsim::cli::cmd_submit, "submit a study: millsim submit STUDY.json [--wait]"},
    {"status", millsim::cli::cmd_status,
     "studies, or one study's progress: millsim status [STUDY] [--watch]"},
    {"results", millsim::cli::cmd_results,
     "a study's results table: millsim results STUDY [--format table|json|csv]"},
    {"psd", millsim::cli::cmd_psd, "a run's outlet PSD as JSON: millsim psd RUN"},
    {"cancel", millsim::cli::cmd_cancel, "cancel a study: millsim cancel STUDY"},
};

void usage(std::FILE* to) {
  std::fprintf(to, "millsim %s: CFD-DEM for wide particle size distributions\n\nusage:\n",
               millsim::kMillsimVersion);
  for (const Verb& v : kVerbs) std::fprintf(to, "  %-8s %s\n", v.name, v.summary);
  std::fprintf(to, "  %-8s %s\n", "version", "print the version");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    usage(stderr);
    return millsim::cli::kBadInput;
  }
  const std::string verb = argv[1];
  if (verb == "-h" || verb == "--help" || verb == "help") {
    usage(stdout);
    return 0;
  }
  if (verb == "version" || verb == "--version") {
    std::printf("millsim %s\n", millsim::kMillsimVersion);
    return 0;
  }
  const std::vector<std::string> args(argv + 2, argv + argc);
  for (const Verb& v : kVerbs) {
    if (verb != v.name) continue;
    try {
      return v.run(args);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "millsim %s: unexpected error: %s\n", v.name, e.what());
      return millsim::cli::kUnexpected;
    }
  }
  std::fprintf(stderr, "millsim: unknown command \"%s\"\n", verb.c_str());
  usage(stderr);
  return millsim::cli::kBadInput;
}
