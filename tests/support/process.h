// Running the real `millsim` binary from tests.
#pragma once

#include <filesystem>
#include <string>

namespace millsim::test {

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

// Runs `millsim ARGS` in `work` (a shell command line; quote paths yourself) and collects its
// exit code, stdout and stderr.
CommandResult run_millsim(const std::string& args, const std::filesystem::path& work);

void write_file(const std::filesystem::path& path, const std::string& text);

}  // namespace millsim::test
