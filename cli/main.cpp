// millsim: the command-line front end. A table of verbs; each verb lives in cmd_<verb>.cpp.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "commands.h"
#include "help.h"
#include "sim/run.h"

namespace {

struct Verb {
  const char* name;
  int (*run)(const std::vector<std::string>&);
};

constexpr Verb kVerbs[] = {
    {"run", millsim::cli::cmd_run},         {"study", millsim::cli::cmd_study},
    {"regress", millsim::cli::cmd_regress}, {"serve", millsim::cli::cmd_serve},
    {"worker", millsim::cli::cmd_worker},   {"submit", millsim::cli::cmd_submit},
    {"status", millsim::cli::cmd_status},   {"results", millsim::cli::cmd_results},
    {"psd", millsim::cli::cmd_psd},         {"cancel", millsim::cli::cmd_cancel},
};

// millsim help [VERB | --man]
int help(const std::vector<std::string>& args) {
  if (args.empty()) {
    millsim::cli::print_overview(stdout);
    return 0;
  }
  if (args[0] == "--man") {
    std::fputs(millsim::cli::man_page().c_str(), stdout);
    return 0;
  }
  if (args[0] == "--help" || args[0] == "-h") {  // help on help: the overview, which lists it
    millsim::cli::print_overview(stdout);
    return 0;
  }
  if (const millsim::cli::VerbHelp* v = millsim::cli::find_verb_help(args[0])) {
    millsim::cli::print_verb_help(*v, stdout);
    return 0;
  }
  std::fprintf(stderr, "millsim help: no verb \"%s\"\n", args[0].c_str());
  millsim::cli::print_overview(stderr);
  return millsim::cli::kBadInput;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    millsim::cli::print_overview(stderr);
    return millsim::cli::kBadInput;
  }
  const std::string verb = argv[1];
  if (verb == "-h" || verb == "--help") {
    millsim::cli::print_overview(stdout);
    return 0;
  }
  if (verb == "version" || verb == "--version") {
    std::printf("millsim %s\n", millsim::kMillsimVersion);
    return 0;
  }
  const std::vector<std::string> args(argv + 2, argv + argc);
  if (verb == "help") return help(args);
  for (const Verb& v : kVerbs) {
    if (verb != v.name) continue;
    for (const std::string& a : args)
      if (a == "--help" || a == "-h") {
        millsim::cli::print_verb_help(*millsim::cli::find_verb_help(v.name), stdout);
        return 0;
      }
    try {
      return v.run(args);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "millsim %s: unexpected error: %s\n", v.name, e.what());
      return millsim::cli::kUnexpected;
    }
  }
  std::fprintf(stderr, "millsim: unknown command \"%s\"\n\n", verb.c_str());
  millsim::cli::print_overview(stderr);
  return millsim::cli::kBadInput;
}
