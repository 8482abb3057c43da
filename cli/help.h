// The `millsim` help text, one table for everything that shows it: the verb list of `millsim
// --help`, each verb's `--help` and `millsim help VERB` (usage, every option with its default,
// an example), the usage printed when an argument is missing, and the man page
// (`millsim help --man`, roff). The exit-code table lives here too.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace millsim::cli {

struct OptionHelp {
  const char* flag;      // "--out DIR"
  const char* fallback;  // the default, "" for none
  const char* meaning;
};

struct VerbHelp {
  const char* name;
  const char* summary;  // one line for the verb list
  const char* usage;    // "millsim run SCENE.json [--out DIR] [--quiet]"
  const char* description;
  std::vector<OptionHelp> options;
  const char* example;
};

const std::vector<VerbHelp>& verb_help();
const VerbHelp* find_verb_help(const std::string& name);

// The verb list with a line each, and the exit codes.
void print_overview(std::FILE* to);
// A verb's whole help: usage, description, options with defaults, example, exit codes.
void print_verb_help(const VerbHelp& verb, std::FILE* to);
// "usage: …" and a pointer to --help (for a missing or wrong argument).
void print_verb_usage(const char* verb, std::FILE* to);
// The man page millsim(1), in roff.
std::string man_page();

}  // namespace millsim::cli
