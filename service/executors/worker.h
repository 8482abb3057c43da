// A worker process: claims runs from the server over HTTP (up to `slots` at once), executes each
// through an Executor
// (the local one: a `millsim run` child in the run's directory, with its limits), renews the
// lease while the child runs, stops the child when the server refuses a heartbeat (canceled or
// lost), and reports the attempt with its fencing token. It never touches the database, so a
// worker on another machine (Slurm) behaves exactly like a local one, given a shared
// filesystem for the runs' directories.
#pragma once

#include <atomic>
#include <string>

#include "executors/executor.h"

namespace millsim {

struct WorkerConfig {
  std::string server = "http://127.0.0.1:8080";
  std::string token;
  std::string name;          // default: host-pid
  double idle_poll_s = 0.5;  // between claims when the queue is empty
  bool until_empty = false;  // exit when no run is queued
  int slots = 1;             // runs executed at once (many with a batch executor)
};

// Runs until `stop` is set (or the queue is empty with until_empty). Returns the number of runs
// it executed. Throws IoError when the server cannot be reached at start.
int run_worker(const WorkerConfig& config, Executor& executor, const std::atomic<bool>& stop);

}  // namespace millsim
