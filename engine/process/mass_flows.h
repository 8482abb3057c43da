// Where a run's mass went, by size class and phase, cumulative from the start: the measurements
// the steady-state projection (process/steady_projection.h) fits its rates to.
//
//   Compartments: the tracked particles of each PSD slot and the dust of each slot. A slot is
//   the underflow (0), a PSD class (1 … B) or the overflow (B + 1) of the run's edges, S = B + 2
//   slots; tracked compartments are [0, S), dust ones [S, 2S). The dust ledger's class k is slot
//   k (dust/dust_ledger.h); the dust table's dust lies in the same slots.
//
//   Per compartment: the mass fed into it, the mass that left the run from it (outlets; the
//   ledger's outflow), the time integral of its hold-up (kg·s), the particles that left (for the
//   rates' counting error) and its particles' breakage events, all and those by a wall impact;
//   per pair of compartments the mass that breakage or the dust's grinding moved from one to
//   the other. The dust is ground by the particles that sweep it, and particles break by meeting
//   each other, at rates that grow with the particles' number: so the particles' cross-section
//   π r² is integrated too (per slot, m²·s), and each compartment's exposure to it, ∫ M_c A dt
//   with A the particles' total cross-section (kg·m²·s).
//
// The tracked hold-up changes only where the population does (breakage, outlets, feeds), so its
// integrals are exact: the caller brings them up to the time of each change (integrate_tracked)
// and reports the change (add_tracked). The ledger's are summed at each of its advances.
#pragma once

#include <cstddef>
#include <numbers>
#include <vector>

#include "checkpoint/archive.h"

namespace millsim {

struct MassFlows {
  int slots = 0;                            // S
  std::vector<double> fed_kg;               // per compartment (2S)
  std::vector<double> left_kg;              // per compartment
  std::vector<double> left_count;           // per compartment: particles that left (tracked)
  std::vector<double> held_kg_s;            // per compartment: ∫ hold-up dt
  std::vector<double> events;               // per compartment: breakage events of its particles
  std::vector<double> wall_events;          // per compartment: of those, by a wall impact
  std::vector<double> moved_kg;             // (2S)², row = from, column = to
  std::vector<double> area_m2_s;            // per slot: ∫ the particles' cross-section dt
  std::vector<double> exposure_kg_m2_s;     // per compartment: ∫ M_c A dt
  std::vector<double> tracked_now_kg;       // per slot: the tracked hold-up now
  std::vector<double> tracked_area_now_m2;  // per slot: the particles' cross-section now
  double integrated_to_s = 0.0;             // the tracked slots' integrals are complete up to here

  int compartments() const { return 2 * slots; }
  static int dust(int slot, int slots) { return slots + slot; }
  double& moved(int from, int to) {
    return moved_kg[std::size_t(from) * std::size_t(compartments()) + std::size_t(to)];
  }
  double moved(int from, int to) const {
    return moved_kg[std::size_t(from) * std::size_t(compartments()) + std::size_t(to)];
  }

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, slots, fed_kg, left_kg, left_count, held_kg_s, events, wall_events, moved_kg);
    io_all(a, area_m2_s, exposure_kg_m2_s, tracked_now_kg, tracked_area_now_m2, integrated_to_s);
  }
};

// Empty flows over the slots of `edges_m` (its classes plus under- and overflow).
MassFlows make_mass_flows(const std::vector<double>& edges_m);

// The slot of a diameter on `edges_m`: 0 below the first edge, 1 + class, or the last slot at
// or above the last edge.
int psd_slot(const std::vector<double>& edges_m, double diameter_m);

// Adds each tracked slot's hold-up and cross-section × (time_s − integrated_to_s) to their
// integrals.
void integrate_tracked(MassFlows& f, double time_s);

// The tracked hold-up of a slot changed by `kg` and its cross-section by `area_m2` (call
// integrate_tracked first).
inline void add_tracked(MassFlows& f, int slot, double kg, double area_m2) {
  f.tracked_now_kg[std::size_t(slot)] += kg;
  f.tracked_area_now_m2[std::size_t(slot)] += area_m2;
}

// A particle's cross-section, π r².
inline double cross_section_m2(double radius_m) {
  return std::numbers::pi * radius_m * radius_m;
}

// The particles' total cross-section now.
double tracked_area_m2(const MassFlows& f);

// What happened between two states of the same run: every cumulative quantity of `later` less
// `earlier`'s; the hold-up is `later`'s.
MassFlows flows_between(const MassFlows& earlier, const MassFlows& later);

}  // namespace millsim
