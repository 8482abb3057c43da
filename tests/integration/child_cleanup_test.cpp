// A process a test starts dies with the test process, even when the test process is killed
// (issue 32: a crashing test left its `millsim serve` running; 15 reruns left 15 servers).
// test::die_with_parent() is what every forked child in the suite calls before its exec.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "support/process.h"

namespace millsim {
namespace {

// Whether `pid` still runs (a zombie or a missing process does not).
bool running(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const std::size_t close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] != 'Z';
}

TEST(ChildCleanup, AChildOfAKilledTestProcessDiesWithIt) {
  int pipe_fd[2];
  ASSERT_EQ(pipe(pipe_fd), 0);
  const pid_t test_process = fork();  // stands for a test binary that crashes
  ASSERT_GE(test_process, 0);
  if (test_process == 0) {
    close(pipe_fd[0]);
    const pid_t child = fork();  // stands for the `millsim serve` it started
    if (child == 0) {
      test::die_with_parent();
      execl("/bin/sleep", "sleep", "120", static_cast<char*>(nullptr));
      _exit(98);
    }
    if (write(pipe_fd[1], &child, sizeof child) != sizeof child) _exit(97);
    pause();
    _exit(0);
  }
  close(pipe_fd[1]);
  pid_t child = -1;
  ASSERT_EQ(read(pipe_fd[0], &child, sizeof child), ssize_t(sizeof child));
  close(pipe_fd[0]);
  // The child has exec'd (its command line is sleep's) before the parent is killed.
  for (int k = 0; k < 3000; ++k) {
    std::ifstream cmdline("/proc/" + std::to_string(child) + "/cmdline");
    std::string argv0;
    std::getline(cmdline, argv0, '\0');
    if (argv0 == "sleep") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(running(child));
  kill(test_process, SIGKILL);
  waitpid(test_process, nullptr, 0);
  bool gone = false;
  for (int k = 0; k < 3000 && !gone; ++k) {  // at most 30 s on a busy machine
    gone = !running(child);
    if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!gone) kill(child, SIGKILL);
  EXPECT_TRUE(gone) << "the child outlived the process that started it";
}

}  // namespace
}  // namespace millsim
