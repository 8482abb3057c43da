// The gas spin-up as a phase of a run (scene.gas.spin_up_s: the gas solved alone before time 0,
// so the particles start in the developed flow): progress reports while it runs, stop requests
// answered with a checkpoint of the gas state that --resume continues, and a cache shared by runs
// whose gas inputs are identical (the runs of a study that vary anything but the gas), keyed by
// a hash of those inputs, the build's state layout and its commit. However the gas got its
// spin-up (here in one go, resumed from its checkpoint, or read from the cache) the state handed
// on is the same, bit for bit (docs/checkpoints.md).
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "sim/simulation.h"

namespace millsim {

struct SpinUpProgress {
  double done_s = 0.0;   // gas time spun up so far
  double total_s = 0.0;  // scene.gas.spin_up_s
  std::uint64_t steps = 0;
  double elapsed_s = 0.0;  // wall time of this phase
  double eta_s = 0.0;      // at the rate of this attempt's steps
  bool waiting = false;    // for another run that spins the same gas up (the cache's lock)
  bool last = false;       // the phase ends with this report
};

struct SpinUpOptions {
  std::filesystem::path checkpoint_dir;  // the run's checkpoint folder; empty: no checkpoint
  std::filesystem::path cache_dir;       // the shared cache; empty: none
  std::string scene_text;                // the scene's JSON: its hash, and the cache key's inputs
  bool resume = false;  // continue from checkpoint_dir's spin-up checkpoint, when there is one
  const std::atomic<int>* stop_request = nullptr;  // a signal number, set by a handler
  std::function<void(const SpinUpProgress&)> on_progress;
  double progress_interval_s = 0.2;
};

struct SpinUpReport {
  // "computed" (spun up here from the start), "resumed" (continued from its checkpoint), "cache"
  // (read from the shared cache), "none" (spin_up_s is 0).
  std::string source = "computed";
  double wall_s = 0.0;
  double done_s = 0.0;               // gas time spun up when the phase ended
  double resumed_from_s = 0.0;       // "resumed": where its checkpoint stood
  double earlier_wall_s = 0.0;       // "resumed": the wall time of the attempts before
  double waited_s = 0.0;             // for another run's spin-up of the same gas
  std::filesystem::path cache_file;  // the cache entry read or written; empty without a cache
  bool cache_written = false;
  std::string note;        // a checkpoint or cache entry that could not be used, and why
  int interrupted_by = 0;  // the stop request's signal; the gas state is then in the checkpoint
};

// Spins up the gas of `sim`, built with SimulationStart::AfterSpinUp, and finishes its start
// (unless interrupted). Throws InputErrorList when the gas fails, ResumeError (sim/run.h) for
// a spin-up checkpoint of another scene or build, IoError when a file cannot be written.
SpinUpReport run_gas_spin_up(Simulation& sim, const SpinUpOptions& options);

// The cache key of `sim`'s spin-up: a hash of the scene's sections the gas is built from (gas,
// mill, domain, gravity), the DEM-cell size of the fluid table, the gas grid as built, this
// build's state layout and its commit.
std::uint64_t gas_spin_up_key(Simulation& sim, const std::string& scene_text);

// The cache's file for a key.
std::filesystem::path spin_up_cache_file(const std::filesystem::path& cache_dir, std::uint64_t key);

}  // namespace millsim
