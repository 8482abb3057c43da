#include "queue/run_state.h"

namespace millsim {

std::string_view run_state_name(RunState state) {
  switch (state) {
    case RunState::Queued:
      return "QUEUED";
    case RunState::Running:
      return "RUNNING";
    case RunState::Complete:
      return "COMPLETE";
    case RunState::ExecutorError:
      return "EXECUTOR_ERROR";
    case RunState::SystemError:
      return "SYSTEM_ERROR";
    case RunState::Canceling:
      return "CANCELING";
    case RunState::Canceled:
      return "CANCELED";
  }
  return "UNKNOWN";
}

ChildOutcome classify_child_exit(int exit_code, int signal) {
  if (exit_code < 0 || signal != 0) return {RunState::SystemError, true};  // killed: OOM, node loss
  switch (exit_code) {
    case 0:
      return {RunState::Complete, false};
    case 2:
      return {RunState::ExecutorError, false};  // the engine rejected the scene
    case 3:
      return {RunState::ExecutorError, false};  // the stability guard stopped it
    case 4:
      return {RunState::SystemError, true};  // I/O or environment
    case 128 + 2:                            // SIGINT,
    case 128 + 10:                           // SIGUSR1 or
    case 128 + 15:  // SIGTERM from outside (shutdown, preemption): stopped cleanly, try again
      return {RunState::SystemError, true};
    default:
      return {RunState::SystemError, false};  // unexpected: kept with its log, not retried
  }
}

}  // namespace millsim
