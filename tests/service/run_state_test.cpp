// Child exit → run state, per DESIGN.md's exit codes and the retry policy of issue 6:
// engine errors (2 bad input, 3 unstable) are final; environment errors and kills are retried.
#include <gtest/gtest.h>

#include <csignal>

#include "queue/run_state.h"

namespace millsim {
namespace {

TEST(RunState, ExitCodesMapToStatesAndRetryPolicy) {
  EXPECT_EQ(classify_child_exit(0, 0).state, RunState::Complete);
  EXPECT_EQ(classify_child_exit(2, 0).state, RunState::ExecutorError);
  EXPECT_FALSE(classify_child_exit(3, 0).retryable);
  EXPECT_EQ(classify_child_exit(4, 0).state, RunState::SystemError);
  EXPECT_TRUE(classify_child_exit(4, 0).retryable);
  // A run stopped cleanly by a signal from outside (130 SIGINT, 143 SIGTERM) is tried again.
  EXPECT_EQ(classify_child_exit(143, 0).state, RunState::SystemError);
  EXPECT_TRUE(classify_child_exit(143, 0).retryable);
  EXPECT_TRUE(classify_child_exit(130, 0).retryable);
  EXPECT_FALSE(classify_child_exit(1, 0).retryable);
  EXPECT_TRUE(classify_child_exit(-1, SIGKILL).retryable);
  EXPECT_EQ(run_state_name(classify_child_exit(-1, SIGKILL).state), "SYSTEM_ERROR");
  EXPECT_FALSE(classify_child_exit(1, 0).retryable);
}

}  // namespace
}  // namespace millsim
