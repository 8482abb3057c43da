// Run states of the batch service (in the spirit of GA4GH WES) and how a finished
// `millsim run` child maps onto them. The queue, workers and HTTP API build on this (issue 6).
#pragma once

#include <string_view>

namespace millsim {

enum class RunState { Queued, Running, Complete, ExecutorError, SystemError, Canceling, Canceled };

std::string_view run_state_name(RunState state);

struct ChildOutcome {
  RunState state;
  bool retryable;  // a system error is tried again (bounded); an engine error is not
};

// exit_code: the child's exit status, or -1 when it was killed by `signal`.
ChildOutcome classify_child_exit(int exit_code, int signal);

}  // namespace millsim
