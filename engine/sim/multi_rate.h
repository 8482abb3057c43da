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
// With /time/wall_riders, a particle whose list holds wall candidates but no candidate pair
// ("rides the walls") steps at a step of its own as well: its only contacts until the next
// rebuild are walls, whose force depends on nothing but its own state, so its contact step is
// the one its own size and stiffness set, not the smallest particle's. It is put on level L, a
// step of 2^L dt, the largest with 2^L dt at most the step the run's own rule gives for it (its
// Rayleigh time, its Hertz contact time with a wall at its own impact speed bound, its
// penetration travel: dem/time_step.h) and 2^L ≤ max_wait_steps. Each level is caught up every 2^L
// steps, and with the particles in free flight, in one velocity-Verlet step of its own length, its
// wall contacts computed at that step (their springs' history at that step too). Its motion bound
// is the free-flight one, which holds for any single Verlet step up to max_wait_steps long. Its
// wall impacts and crushes go to the breakage by particle id (their slots may move before the next
// population pass), and every rider is caught up before a breakage moves slots (their wall
// candidates are listed by slot). Level 0 steps with the contacts.
//
// The particles that step keep their fluid force too (in gas scenes): it is evaluated at most
// every max_wait_steps steps and on the step after a CFD step (which changed the gas), and in
// between the step applies the kept force, so the drag and the DEM-cell lookup follow the
// particle's time scale, not the contact's. The kept force enters the step's kick-drift. The
// impulse it exchanges with the gas is the same every step while it is kept, so the steps only
// count themselves (MultiRate::held_exchange_steps) and the count is booked into each particle's
// impulse at once, k dt times the kept exchange (book_held_exchange), before anything reads the
// impulses, replaces the kept forces or changes the stepping set or its slots: with the stepping
// particles' deferred kick (Simulation::finish_stepping_kick), before a step that may rebuild the
// list, and before the step that evaluates the force again.
#pragma once

#include <cstdint>
#include <vector>

#include "checkpoint/archive.h"
#include "dem/time_step.h"
#include "particles/materials.h"
#include "particles/particle_store.h"
#include "search/neighbor_list.h"

namespace millsim {

// The longest wait, in DEM steps, and the share of the smallest particle's drag relaxation time τ
// a long step may take. In the mill 64 steps are 0.2 µs against τ = 0.67 ms for its smallest
// particle; a rebuild (about every 80 steps there) catches every particle up anyway.
inline constexpr std::int64_t kMaxFreeFlightSteps = 64;
inline constexpr double kMaxWaitPerRelaxationTime = 0.05;

// The deepest wall-rider level: a step of 2^6 = kMaxFreeFlightSteps steps.
inline constexpr int kMaxRiderLevel = 6;

// ParticleStore::free_flight holds, per particle since the last rebuild: kSteps (takes the contact
// step), kInFreeFlight, or kRidesWalls + L for a wall rider on level L ≥ 1.
inline constexpr std::uint8_t kSteps = 0, kInFreeFlight = 1, kRidesWalls = 1;

// What a wall rider's level is chosen from (a run with /time/wall_riders).
struct RiderRule {
  WallStiffness wall;
  double impact_speed_m_per_s = 0.0;
  double safety_factor = 0.0;      // of the Rayleigh time
  double steps_per_contact = 0.0;  // per Hertz contact time
  double penetration_limit = 0.0;  // travel per step, in diameters, at the impact speed
  double run_bound_s = 0.0;  // the same bound over the run's smallest particles, or dt if larger
  int max_level = 0;         // log2(max_wait_steps), at most kMaxRiderLevel
};

// The step wall rider i allows: min(safety t_R, t_c / steps per contact, limit · d / V), the
// run's own rule (dem/time_step.h) for its size and stiffness, with t_c its Hertz contact time
// against the stiffest, most concave wall at V, its own impact speed bound: twice its speed, at
// least 1 m/s and at most the run's impact speed.
double own_step_bound_s(const ParticleStore& p, std::size_t i, const MaterialTable& materials,
                        const RiderRule& rule);
// Its level: the largest L ≤ rule.max_level with 2^L ≤ own_step_bound_s / rule.run_bound_s.
int rider_level(const ParticleStore& p, std::size_t i, const MaterialTable& materials,
                const RiderRule& rule);

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
  double rider_steps = 0.0;             // wall riders' own steps (particle catch-ups)
  double rider_waited_steps = 0.0;      // DEM steps the wall riders did not take
  std::uint64_t rider_catch_ups = 0;    // level catch-ups
};

// A wall rider's impact (onset of a wall contact) or crush (past the penetration limit), kept by
// id until the breakage takes it.
struct RiderEvent {
  std::uint64_t id = 0;
  std::uint32_t wall = 0;
  bool crushed = false;
  double speed_m_per_s = 0.0;
  double tangential_speed_m_per_s = 0.0;
  std::int64_t step = 0;  // when it was recorded
};

// The wall riders of one level.
struct RiderLevel {
  std::vector<std::uint32_t> slots;                  // ascending
  std::vector<NeighborList::PairRange> wall_ranges;  // their wall candidates
  std::int64_t since_step = 0;                       // the step they are complete at
  std::vector<double> block_speed2;                  // their speed bounds, as the waiting ones'
  double max_speed2 = 0.0;
  std::uint64_t touching_walls = 0;  // their wall contacts at their last own step
  // When their fluid force was last evaluated (they keep it in between, as the stepping ones
  // do); −1: at their next step.
  std::int64_t fluid_refreshed_step = -1;

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, slots, wall_ranges, since_step, block_speed2, max_speed2, touching_walls,
           fluid_refreshed_step);
  }
};

struct MultiRate {
  std::vector<std::uint32_t> stepping, waiting;       // slots, ascending
  std::uint64_t lists_version = ~std::uint64_t(0);    // the population_version they belong to
  std::uint64_t marked_rebuilds = ~std::uint64_t(0);  // neighbour rebuilds when flags were set
  std::int64_t waiting_since_step = 0;  // the step the waiting particles are complete at
  std::int64_t max_wait_steps = kMaxFreeFlightSteps;
  std::int64_t fluid_refreshed_step = 0;  // when the stepping particles' fluid force was evaluated
  bool fluid_refresh_due = true;          // a CFD step changed the gas since
  // Steps the stepping particles applied their kept fluid force since its exchange was last booked
  // into their impulses (book_held_exchange).
  std::int64_t held_exchange_steps = 0;
  std::int64_t gas_changed_step = -1;  // the step of the last CFD step
  // Per slot block (dem/integrator.h): the waiting particles' speed bound, squared.
  std::vector<double> waiting_block_speed2;
  double waiting_max_speed2 = 0.0;
  bool speeds_valid = false;
  std::vector<double> block_speed2;  // work array of the step's kick-drift
  MultiRateStats stats;
  // Wall riders (/time/wall_riders): levels 1..kMaxRiderLevel at riders[L - 1], the stepping
  // particles' wall candidates, and the riders' events not yet given to the breakage.
  bool riders_on = false;
  std::vector<RiderLevel> riders;
  std::vector<NeighborList::PairRange> stepping_wall_ranges;
  bool rider_ranges_valid = false;  // the wall ranges match the slots (since the last rebuild)
  std::vector<RiderEvent> rider_events;
  // The free-flight particles' own speed bounds (waiting_block_speed2 is theirs and the riders').
  std::vector<double> free_block_speed2;
  double free_max_speed2 = 0.0;

  bool any_riders() const {
    for (const RiderLevel& level : riders)
      if (!level.slots.empty()) return true;
    return false;
  }

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, stepping, waiting, lists_version, marked_rebuilds, waiting_since_step, max_wait_steps,
           fluid_refreshed_step, fluid_refresh_due);
    io_all(a, waiting_block_speed2, waiting_max_speed2, speeds_valid, stats);
    io_all(a, riders_on, riders, stepping_wall_ranges, rider_ranges_valid, rider_events,
           free_block_speed2, free_max_speed2, gas_changed_step, held_exchange_steps);
  }
};

// After a rebuild, with every particle complete: flags each particle in free flight (no
// candidate pair, no wall candidate) and, with a rider rule, each wall rider's level; lists the
// sets.
void mark_free_flight(ParticleStore& p, const NeighborList& neighbors, MultiRate& m,
                      const RiderRule* riders = nullptr, const MaterialTable* materials = nullptr);
// Re-lists the sets from the flags when slots moved (a breakage or an outlet removed some).
void relist_if_moved(const ParticleStore& p, const NeighborList& neighbors, MultiRate& m);
// The waiting particles' (free flight and riders) speed bounds per slot block, from their
// current state, as the neighbour list counts speeds (dem/motion_frame.h, SpeedReport).
void bound_waiting_speeds(const ParticleStore& p, double dt, const SpeedReport& report,
                          MultiRate& m);
// The same for one rider level only (after its catch-up), the others' bounds kept.
void bound_rider_speeds(const ParticleStore& p, double dt, int level, const SpeedReport& report,
                        MultiRate& m);

// kick_drift_listed (dem/integrator.h) for particles that keep their fluid force: each one's
// next force starts from gravity plus the kept force. Returns the largest |v½|² as `report`
// counts it. With `kick_first`, the last step's closing kick comes first in the same pass
// (kick_drift_listed's kKickFirst). The kept exchange's impulse is the caller's to book
// (book_held_exchange). `shares`: as kick_drift_listed's.
double kick_drift_keeping_fluid(ParticleStore& p, const std::vector<std::uint32_t>& slots,
                                double dt, const Vec3& gravity,
                                std::vector<double>& block_max_speed2, const SpeedReport& report,
                                bool kick_first = false, const SlotShares* shares = nullptr);

// Adds the kept exchange over `held_s` to each listed particle's impulse for the gas; returns
// the sum, added per piece of the list and then in piece order (the same on any thread count).
Vec3 book_held_exchange(ParticleStore& p, const std::vector<std::uint32_t>& slots, double held_s);

}  // namespace millsim
