// A run's hold-up and what left it over time, and whether it ended in a steady state.
//
//   One row per output interval: the mass fed, the tracked particles' mass (in total and by PSD
//   class), what left through outlets, the dust made (the paper's §5: product at once), the dust
//   the ledger carried out and still holds, and breakage events by the broken particle's
//   generation, all cumulative except the hold-up.
//
//   Steady state over a window [t_a, t_b] (the product window, or the run's last third): the
//   mass that left, outlet particles plus the dust carried out (or, with the dust table, made),
//   against the mass fed in the window, and how much each phase of the hold-up (the tracked
//   particles, the ledger's dust) changed. A mill is steady when the outflow agrees with the feed
//   within 10 % (issue 31) and neither phase changed by more than 10 % of the feed: an outflow at
//   the feed rate alone says only that the total hold-up holds, and a mill whose dust drains as
//   fast as its particles pile up has it (bench/RESULTS.md, "The dust's weight on the gas, and
//   the filled mills' grinding rate"). The same ratio with the dust counted when made is reported
//   too: with the ledger it is what the dust table would have said.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "checkpoint/archive.h"

namespace millsim {

struct HoldupRow {
  double time_s = 0.0;
  // Cumulative, with the particles there at the start and what a hold-up fill added (the fill
  // lies before the steady window, scene/scene_json.cpp).
  double fed_kg = 0.0;
  double particles_kg = 0.0;  // the tracked hold-up now
  double outlet_kg = 0.0;     // cumulative: particles that left through outlets
  double dust_made_kg = 0.0;  // cumulative: the breakage's dust, and the ledger dust a fill added
  double dust_out_kg = 0.0;   // cumulative: the ledger's dust out of the gas outlets (table: 0)
  double dust_held_kg = 0.0;  // the ledger's dust in the gas now (table: 0)
  // Cumulative, by the broken particle's generation.
  std::vector<std::uint64_t> events_by_generation;
  // By PSD class (underflow, the classes, overflow): the tracked hold-up now, and the dust made
  // so far.
  std::vector<double> holdup_by_class_kg, dust_made_by_class_kg;
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, time_s, fed_kg, particles_kg, outlet_kg, dust_made_kg, dust_out_kg, dust_held_kg,
           events_by_generation, holdup_by_class_kg, dust_made_by_class_kg);
  }
};

// The outflow may differ from the feed, and each phase's hold-up may change, by this share of
// the feed in a steady window.
inline constexpr double kSteadyOutflowTolerance = 0.1;

struct SteadyWindow {
  double start_s = 0.0, end_s = 0.0;  // the rows that bound it
  double fed_kg = 0.0;                // fed in the window
  double outlet_kg = 0.0, dust_made_kg = 0.0, dust_out_kg = 0.0;
  double outflow_kg = 0.0;           // outlet + dust out (ledger) or dust made (table)
  double particles_change_kg = 0.0;  // tracked hold-up at the end − at the start
  double dust_held_change_kg = 0.0;  // the ledger's
  double outflow_to_feed = 0.0;      // outflow / fed
  double made_to_feed = 0.0;         // (outlet + dust made) / fed: the dust table's view
  bool outflow_steady = false;       // |outflow / fed − 1| ≤ kSteadyOutflowTolerance
  bool holdup_steady = false;        // |each phase's change| ≤ kSteadyOutflowTolerance · fed
  bool steady = false;               // both
};

// The window from the first row at or after `start_s` to the last row at or before `end_s`; none
// when fewer than two rows lie in it or nothing was fed there. `ledger`: the dust leaves only
// when carried out, not when made. `step_s`: the run's step; rows sit on the step grid, so a row
// within a step of either end counts as on it (a run's last row lies up to a step past its end).
std::optional<SteadyWindow> steady_window(const std::vector<HoldupRow>& rows, double start_s,
                                          double end_s, bool ledger, double step_s = 0.0);

// result.json's `holdup_history`: one array per quantity, a row per time.
nlohmann::ordered_json holdup_history_json(const std::vector<HoldupRow>& rows);
nlohmann::ordered_json steady_window_json(const SteadyWindow& w);

}  // namespace millsim
