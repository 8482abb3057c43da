// Multi-rate stepping: which particles take the contact step and which a long step of their own,
// and the bookkeeping of the second kind. The rule lives here; the step that applies it is
// Simulation::step_multi_rate (sim/simulation.cpp), the kernels are the listed passes of
// dem/integrator.h and GasCoupling::add_fluid_forces.
//
// A particle is in free flight from one neighbour-list rebuild to the next when the list holds
// no candidate pair and no wall candidate for it. The list's rule (search/neighbor_list.h) then
// guarantees it touches nothing before the next rebuild, so its only forces are gravity and the
// gas's, whose time scales (drag relaxation, the CFD step) are far longer than a contact's. It
// waits while the others step, and is brought up to the current step ("caught up") in one
// velocity-Verlet step of length h = (steps waited) × dt whenever something reads it:
//   - before the neighbour list measures motion or rebuilds (the step then becomes a full one),
//   - before outlets and feeds are applied and before a population change's rebuild,
//   - before a CFD step (the gas takes every particle's volume and impulse),
//   - at the end of Simulation::advance() (output, checkpoints and tests see a complete state),
//   - and at least every max_wait_steps steps (kMaxFreeFlightSteps, fewer where a twentieth of
//     the smallest particle's drag relaxation time is shorter: the long step's drag is explicit).
// While it waits, the list's motion bound counts it at a speed it cannot exceed over the wait,
// |v| + ½ max_wait_steps dt |F|/m with v and F its state when it was last caught up: the lumped
// step's displacement after k steps, |v + ½ a k dt| k dt, stays under that speed × k dt.
// So the rebuild comes no later than it would have, and nothing it would have found is missed.
// A run where no particle is in free flight takes the single-rate path unchanged.
//
// The particles that step keep their fluid force too (in gas scenes): it is evaluated at most
// every max_wait_steps steps and on the step after a CFD step (which changed the gas), and in
// between the step applies the kept force, so the drag and the DEM-cell lookup follow the
// particle's time scale, not the contact's. The kept force enters the step's kick-drift, which
// also books its impulse for the gas.
#pragma once

#include <cstdint>
#include <vector>

#include "checkpoint/archive.h"
#include "particles/particle_store.h"
#include "search/neighbor_list.h"

namespace millsim {

// The longest wait, in DEM steps, and the share of the smallest particle's drag relaxation time τ
// a long step may take. In the mill 64 steps are 0.2 µs against τ = 0.67 ms for its smallest
// particle; a rebuild (about every 80 steps there) catches every particle up anyway.
inline constexpr std::int64_t kMaxFreeFlightSteps = 64;
inline constexpr double kMaxWaitPerRelaxationTime = 0.05;

// The longest wait for a step `dt` and the smallest particle's relaxation time (1e300 without
// gas): at least one step, at most kMaxFreeFlightSteps.
std::int64_t max_wait_steps(double dt, double relaxation_s);

struct MultiRateStats {
  double held_fluid_steps = 0.0;        // particle-steps that applied a kept fluid force
  std::uint64_t fluid_refreshes = 0;    // steps that evaluated the stepping particles' fluid force
  double waiting_particle_steps = 0.0;  // DEM steps not taken by particles in free flight
  double long_steps = 0.0;              // particle catch-ups (each one long step)
  std::uint64_t catch_ups = 0;          // times the waiting particles were brought up to date
  std::uint64_t full_steps = 0;         // steps turned into full ones by the motion bound
};

struct MultiRate {
  std::vector<std::uint32_t> stepping, waiting;       // slots, ascending
  std::uint64_t lists_version = ~std::uint64_t(0);    // the population_version they belong to
  std::uint64_t marked_rebuilds = ~std::uint64_t(0);  // neighbour rebuilds when flags were set
  std::int64_t waiting_since_step = 0;  // the step the waiting particles are complete at
  std::int64_t max_wait_steps = kMaxFreeFlightSteps;
  std::int64_t fluid_refreshed_step = 0;  // when the stepping particles' fluid force was evaluated
  bool fluid_refresh_due = true;          // a CFD step changed the gas since
  // Per slot block (dem/integrator.h): the waiting particles' speed bound, squared.
  std::vector<double> waiting_block_speed2;
  double waiting_max_speed2 = 0.0;
  bool speeds_valid = false;
  std::vector<double> block_speed2;  // work array of the step's kick-drift
  MultiRateStats stats;

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, stepping, waiting, lists_version, marked_rebuilds, waiting_since_step, max_wait_steps,
           fluid_refreshed_step, fluid_refresh_due);
    io_all(a, waiting_block_speed2, waiting_max_speed2, speeds_valid, stats);
  }
};

// After a rebuild, with every particle complete: flags each particle in free flight (no
// candidate pair, no wall candidate) and lists the two sets.
void mark_free_flight(ParticleStore& p, const NeighborList& neighbors, MultiRate& m);
// Re-lists the two sets from the flags when slots moved (a breakage or an outlet removed some).
void relist_if_moved(const ParticleStore& p, MultiRate& m);
// The waiting particles' speed bounds per slot block, from their current state.
void bound_waiting_speeds(const ParticleStore& p, double dt, MultiRate& m);

// kick_drift_listed (dem/integrator.h) for particles that keep their fluid force: each one's
// next force starts from gravity plus the kept force, and the kept exchange's impulse over the
// step is booked for the gas (returned summed). Returns the largest |v½|² in `max_speed2`.
Vec3 kick_drift_keeping_fluid(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                              const Vec3& gravity, std::vector<double>& block_max_speed2,
                              double& max_speed2);

}  // namespace millsim
