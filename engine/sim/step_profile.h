// StepProfile: wall seconds spent in each phase of the step, for the run summary
// ("every run reports where its time went").
#pragma once

#include <array>
#include <chrono>
#include <string_view>

namespace millsim {

enum class Phase {
  KickDrift,
  Neighbors,
  Forces,
  Kick,
  Breakage,
  Population,  // outlets, feeds and the rebuild after any population change
  Fluid,       // drag, lift and pressure-gradient forces from the DEM-cell fluid table
  Gas,         // one CFD step: particle → gas deposit and the gas solve
  Health,
  Output,
  FreeFlight,  // multi-rate stepping: particles in free flight brought up to date
               // (sim/multi_rate.h)
  WallRiders,  // multi-rate stepping: wall riders' own steps, their wall contacts included
  Count
};

inline constexpr std::array<std::string_view, std::size_t(Phase::Count)> kPhaseNames = {
    "kick_drift", "neighbors", "forces", "kick",   "breakage",    "population",
    "fluid",      "gas",       "health", "output", "free_flight", "wall_riders"};

struct StepProfile {
  std::array<double, std::size_t(Phase::Count)> seconds{};

  template <class Fn>
  void time(Phase phase, Fn&& fn) {
    const auto start = std::chrono::steady_clock::now();
    fn();
    seconds[std::size_t(phase)] +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  double total() const {
    double t = 0.0;
    for (double s : seconds) t += s;
    return t;
  }
};

}  // namespace millsim
