// The server's memory reserve (service/memory_reserve.h): in a process whose address space is
// capped, allocating until memory runs out taps the reserve instead of throwing (the allocation
// that failed succeeds, and so does the next, from the block released), the tap is seen, and
// after the memory is freed the reserve is armed again.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <memory>
#include <new>
#include <vector>

#include "memory_reserve.h"
#include "support/process.h"

namespace millsim {
namespace {

// The checks, in a child with 512 MB of address space; its exit code says which one failed.
int tap_and_rearm() {
  const struct rlimit limit = {rlim_t(512) << 20, rlim_t(512) << 20};
  if (setrlimit(RLIMIT_AS, &limit) != 0) return 10;
  arm_memory_reserve(std::size_t(64) << 20);
  if (memory_reserve_tapped()) return 11;
  std::vector<std::unique_ptr<char[]>> chunks;
  try {
    while (!memory_reserve_tapped() && chunks.size() < 1000)
      chunks.emplace_back(new char[std::size_t(8) << 20]);
  } catch (const std::bad_alloc&) {
    return 12;  // thrown although the reserve was there to release
  }
  if (!memory_reserve_tapped()) return 13;
  try {
    chunks.emplace_back(new char[std::size_t(8) << 20]);  // from the released block
  } catch (const std::bad_alloc&) {
    return 14;
  }
  chunks.clear();
  rearm_memory_reserve();
  return memory_reserve_tapped() ? 15 : 0;
}

TEST(MemoryReserve, RunningOutTapsTheReserveInsteadOfThrowingAndItRearms) {
#if defined(MILLSIM_SANITIZED)
  GTEST_SKIP() << "ASan reserves terabytes of address space: no RLIMIT_AS under it";
#endif
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    test::die_with_parent();
    _exit(tap_and_rearm());
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the child died of signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "check " << WEXITSTATUS(status) << " failed";
}

}  // namespace
}  // namespace millsim
