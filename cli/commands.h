// The `millsim` verbs. Each takes its arguments (after the verb) and returns the process exit
// code: 0 ok, 2 bad input, 3 stopped by the stability guard, 4 environment error, 1 unexpected.
#pragma once

#include <string>
#include <vector>

namespace millsim::cli {

enum ExitCode { kOk = 0, kUnexpected = 1, kBadInput = 2, kUnstable = 3, kEnvironment = 4 };

int cmd_run(const std::vector<std::string>& args);
int cmd_study(const std::vector<std::string>& args);
int cmd_serve(const std::vector<std::string>& args);
int cmd_worker(const std::vector<std::string>& args);
int cmd_submit(const std::vector<std::string>& args);
int cmd_status(const std::vector<std::string>& args);
int cmd_results(const std::vector<std::string>& args);
int cmd_psd(const std::vector<std::string>& args);
int cmd_cancel(const std::vector<std::string>& args);
int cmd_regress(const std::vector<std::string>& args);

}  // namespace millsim::cli
