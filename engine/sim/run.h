// The run loop: steps a Simulation to its end time, reports progress, writes snapshots and the
// time series to run.h5 (+ run.xdmf), and builds the JSON summary (result.json). Files appear
// under their final names only when complete (written as *.partial, then renamed). A stop request
// (SIGINT, SIGTERM, SIGUSR1 in `millsim run`) ends the run early with every file complete.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>

#include "scene/scene_config.h"
#include "sim/gas_spin_up.h"
#include "sim/simulation.h"

namespace millsim {

inline constexpr const char* kMillsimVersion = "0.1.0";

struct RunProgress {
  std::int64_t step = 0;
  std::int64_t total_steps = 0;
  double time_s = 0.0;
  std::size_t particles = 0;
  double elapsed_s = 0.0;
  double eta_s = 0.0;
  std::size_t contacts = 0;  // touching particle pairs and wall contacts
  double kinetic_j = 0.0;    // translational kinetic energy
  double time_step_s = 0.0;
  double particle_steps_per_s = 0.0;  // since the start
};

struct RunOptions {
  std::filesystem::path out_dir;  // empty: write no files
  std::function<void(const RunProgress&)> on_progress;
  double progress_interval_s = 0.2;
  // Set (to a signal number) by a signal handler: the run stops after the step under way,
  // writes its last snapshot, closes run.h5 as a valid file and its summary says "interrupted".
  const std::atomic<int>* stop_request = nullptr;
  // The scene file's text as given and its path: kept in run.h5 /meta and copied to
  // DIR/scene.json (unless that is the file itself).
  std::string scene_text;
  std::filesystem::path scene_path;
  // Checkpoints in out_dir/checkpoints (checkpoint/checkpoint_file.h, docs/checkpoints.md):
  // every scene.output.checkpoint_interval_s of simulated time, every checkpoint_wall_s of wall
  // time (0: none by wall clock), and at a stop request. The newest `checkpoints_kept` stay
  // until the run ends complete; then all are removed.
  double checkpoint_wall_s = 600.0;
  int checkpoints_kept = 2;
  // Continue from the newest valid checkpoint in out_dir/checkpoints, falling back to the one
  // before when it is damaged; with none there, the run starts from the beginning.
  bool resume = false;
  // A Simulation built with SimulationStart::AfterSpinUp spins its gas up here first
  // (sim/gas_spin_up.h): reported through on_spin_up_progress, checkpointed at a stop request,
  // shared with other runs through the cache in spin_up_cache_dir (empty: none).
  std::filesystem::path spin_up_cache_dir;
  std::function<void(const SpinUpProgress&)> on_spin_up_progress;
  // A line about an event of the run that a user watching its log wants to see when it happens
  // (a hold-up fill: what it moved, or why it did not), without a newline.
  std::function<void(const std::string&)> on_notice;
};

// A checkpoint that cannot be continued: another scene's, another build's layout, or every one
// damaged. Nothing in the run's folder has been changed when it is thrown.
struct ResumeError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct RunOutcome {
  std::optional<StepFailure> failure;
  int interrupted_by = 0;  // the signal that stopped the run, 0 when it was not interrupted
  nlohmann::ordered_json summary;
};

// Throws IoError when an output file cannot be written, ResumeError (options.resume) when the
// run's checkpoints cannot be continued.
RunOutcome run_simulation(Simulation& sim, const SceneConfig& scene, const RunOptions& options);

nlohmann::ordered_json energy_json(const EnergyReport& e);

}  // namespace millsim
