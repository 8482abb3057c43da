// Runs one study's queued runs on this machine: up to `workers` `millsim run` children at once
// through an Executor, with leases renewed while they run, limits enforced, cancel honoured, and
// every attempt recorded in the Store (this process is its only writer). Runs left RUNNING by a
// runner that died are taken again once their lease expires.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "executors/executor.h"
#include "queue/store.h"

namespace millsim {

struct LocalRunOptions {
  int workers = 1;
  double lease_s = 30.0;
  double poll_interval_s = 0.05;
  std::function<void(const Progress&)> on_progress;  // after every state change
};

// Returns when no run of the study is queued, running or canceling.
void run_study_locally(Store& store, const std::string& study_id, Executor& executor,
                       const LocalRunOptions& options);

// The same for several studies at once (a regression suite's checks): runs are taken oldest
// study first; `on_progress` gets the sum over the studies.
void run_studies_locally(Store& store, const std::vector<std::string>& study_ids,
                         Executor& executor, const LocalRunOptions& options);

}  // namespace millsim
