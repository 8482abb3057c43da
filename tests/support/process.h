// Running the real `millsim` binary from tests.
#pragma once

#include <sys/types.h>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace millsim::test {

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
  std::pair<int, std::string> status_and_output() const { return {exit_code, out}; }
};

// Runs `millsim ARGS` in `work` (a shell command line; quote paths yourself) and collects its
// exit code, stdout and stderr.
CommandResult run_millsim(const std::string& args, const std::filesystem::path& work);

// Processes whose parent is `parent` (from /proc/*/stat).
std::vector<pid_t> children_of(pid_t parent);

// Call in a child just forked by a test: it gets SIGTERM when the test process dies (even by a
// crash), so no server or run outlives the suite. Kept across exec.
void die_with_parent();

// A TCP connection to 127.0.0.1:port (its descriptor), or -1.
int connect_loopback(int port);

void write_file(const std::filesystem::path& path, const std::string& text);
std::string read_file(const std::filesystem::path& path);  // "" when missing

// Runs a shell command line; its exit status (-1 when it did not exit) and its stdout and
// stderr together.
CommandResult run_shell(const std::string& command);

}  // namespace millsim::test
