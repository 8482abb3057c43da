// The `millsim` verbs. Each takes its arguments (after the verb) and returns the process exit
// code: 0 ok, 2 bad input, 3 stopped by the stability guard, 4 environment error, 1 unexpected.
#pragma once

#include <string>
#include <vector>

namespace millsim::cli {

enum ExitCode { kOk = 0, kUnexpected = 1, kBadInput = 2, kUnstable = 3, kEnvironment = 4 };

int cmd_run(const std::vector<std::string>& args);
int cmd_study(const std::vector<std::string>& args);

}  // namespace millsim::cli
