// The steady state a continuous run is heading for, projected from the rates it measured
// (issue 31: a mill's steady state lies 0.6–1 s of mill time away, weeks of one core).
//
// A population balance on the run's own compartments (process/mass_flows.h): tracked particles
// and dust, by PSD slot. Over a window each compartment c held ∫M_c dt; the mass that breakage
// or grinding moved from it to c', the mass that left from it and the mass fed into it give its
// first-order rates
//     k_{c→c'} = moved / ∫M_c dt,   E_c = left / ∫M_c dt,   F_c = fed / window,
// (a run takes F_c from its scene's feeds instead, their mean over the window: process/feed.h's
// declared_feed_kg_per_s), and the balance
//     dM_c/dt = F_c − (E_c + Σ_{c'} k_{c→c'}) M_c + Σ_{c'} k_{c'→c} M_{c'}.
// Two kinds of move grow with the particles instead: the dust's grinding (the particles sweep
// it) and the breakage of particles by meeting each other (or crushed against one). Their moves
// are fitted per unit of the particles' cross-section A (the sum of π r²),
// g_{c→c'} = moved / ∫M_c A dt, and act at g A(t), with A(t) = Σ_s a_s M_s(t) from each particle
// slot's measured cross-section per kilogram a_s; a particle compartment's moves are split so by
// the share of its window's breakage events that were not wall impacts. That keeps them where
// the particles and their partners meet as they did in the window, only more or less often.
//
// Breakage moves mass only to the same or finer slots and from particles to dust, never back, so
// in the order (coarsest slot first; the particles, then the dust) the balance is triangular at
// a given A. The particles' steady hold-up at A has a cross-section f(A) that falls as A grows;
// the steady A* = f(A*) is found by bisection, then the dust's hold-up follows at A*. A
// compartment that receives mass but neither breaks nor leaves (no event in the window) has no
// steady hold-up: it would grow without end, and the projection names it. A compartment that
// held nothing yet received mass (the dust table's dust, made and counted at once) passes what
// it receives straight to the product. The course from the run's end is stepped by the exact
// propagator of the balance over 4000 steps of its horizon, renewed whenever A has moved by 5 %
// since the last renewal.
//
// What it assumes: the rates per kilogram (per kilogram and m² of cross-section for the
// collisions) are those of the window: the mill's flow, the impact speeds and where particles
// and dust meet stay as they were while the hold-up grows. The counting error of the rates is
// carried by redrawing each particle compartment's breakage and outlet rates from the gamma
// distribution their counts give (Jeffreys prior, a Poisson count n over the window:
// rate ∝ Gamma(n + ½)), the dust's rates being sums over many particles and cells.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "process/mass_flows.h"

namespace millsim {

// The outflow may differ from the feed by this share of it in a steady window (as for the
// measured steady state, process/holdup_history.h).
inline constexpr double kProjectionSteadyTolerance = 0.1;

struct CompartmentRates {
  int slots = 0;
  double window_s = 0.0;
  std::vector<double> feed_kg_per_s;   // per compartment
  std::vector<double> leave_per_s;     // E_c
  std::vector<double> move_per_s;      // (2S)², row = from; the diagonal is 0
  std::vector<double> grind_per_m2_s;  // (2S)²: moves per unit of A (grinding, collisions)
  std::vector<double> area_per_kg;     // per particle slot: a_s, m²/kg
  std::vector<double> mean_held_kg;    // ∫M dt / window
  double mean_area_m2 = 0.0;           // the particles' cross-section, ∫A dt / window
  std::vector<double> events, wall_events, left_count;
  std::vector<char> pass_through;  // held nothing, received mass: all of it leaves at once
  // Per compartment, or empty: a compartment with a value >= 0 is taken to hold this much at
  // steady state, whatever it receives, and passes mass on at its rates times that hold-up; < 0:
  // its balance decides. A hold-up fill (sim/run.cpp) sets the current hold-up of a compartment
  // that would accumulate (it receives mass, neither breaks nor leaves), so that one class the
  // window saw no event of leaves the rest of the mill a steady state, and of a particle
  // compartment whose rates rest on too few counts (time.fill_min_events).
  std::vector<double> fixed_held_kg;

  int compartments() const { return 2 * slots; }
  double move(int from, int to) const {
    return move_per_s[std::size_t(from) * std::size_t(compartments()) + std::size_t(to)];
  }
  double grind(int from, int to) const {
    return grind_per_m2_s[std::size_t(from) * std::size_t(compartments()) + std::size_t(to)];
  }
  // k_{c→c'} + g_{c→c'} A: the rate of moves at a cross-section A.
  double move_at(int from, int to, double area_m2) const {
    return move(from, to) + grind(from, to) * area_m2;
  }
  // E_c + Σ_{c'} k_{c→c'} (A): the rate at which compartment c loses mass.
  double out_per_s(int c, double area_m2) const;
  // A of a hold-up (per compartment): Σ_s a_s M_s.
  double area_m2(const std::vector<double>& held_kg) const;
  bool grinds() const;  // any move grows with A
};

// The rates over a window's flows (flows_between) of length window_s > 0.
CompartmentRates fit_rates(const MassFlows& window, double window_s);

// `r` with its particle compartments' rates (rows [0, S): outflow, moves, their counts) taken
// from `pooled`, fitted over a longer span of the same run that contains r's window, wherever
// the span held them; the dust's rates, the feed and the hold-ups stay r's. The first-order
// estimate over the longer span, Σ moved / Σ ∫M dt, counts every event since the span began
// (time.fill_particle_rate_windows).
void take_particle_rates(CompartmentRates& r, const CompartmentRates& pooled);

struct SteadyProjection {
  bool exists = false;            // every compartment that receives mass also loses it
  std::vector<int> accumulating;  // those that do not
  std::vector<int> fixed;         // those held at CompartmentRates::fixed_held_kg instead
  double feed_kg_per_s = 0.0;
  std::vector<double> held_kg;           // per compartment, at steady state
  double area_m2 = 0.0;                  // the particles' cross-section at steady state
  std::vector<double> product_kg_per_s;  // per slot: what leaves, at steady state
  // From the run's final hold-up: the first time after which the outflow stays within
  // kProjectionSteadyTolerance of the feed (−1 when it does not within the horizon), and the
  // projected course (times, total hold-up, outflow / feed), for a picture.
  double time_to_steady_s = -1.0;
  double horizon_s = 0.0;
  std::vector<double> course_time_s, course_held_kg, course_outflow_to_feed;
};

// Solves the balance for its steady state and, from `start_held_kg` (per compartment), its
// course. `course_points`: how many points of the course to keep; 0: the steady state alone (no
// course, no time to steady).
SteadyProjection project_steady(const CompartmentRates& r, const std::vector<double>& start_held_kg,
                                int course_points = 48);

// A steady state's hold-up of the particles' compartments [0, slots) and of the dust's.
std::pair<double, double> held_by_phase_kg(const SteadyProjection& p, int slots);

// Draws of the counting error a run reports.
inline constexpr int kProjectionDraws = 200;

struct ProjectionSpread {
  int draws = 0;
  int draws_steady = 0;  // draws in which a steady state exists
  // 5 %, 50 % and 95 % over the draws with a steady state.
  std::vector<double> d10_m, d50_m, d90_m, time_to_steady_s;
  std::vector<double> held_particles_kg, held_dust_kg, cross_section_m2;  // the steady state's
};

// The counting error (above): `draws` redrawn rate sets from a fixed seed, each projected.
ProjectionSpread projection_spread(const CompartmentRates& r,
                                   const std::vector<double>& start_held_kg,
                                   const std::vector<double>& edges_m, int draws,
                                   std::uint64_t seed);

// result.json's `steady_projection`: the rates by compartment, the steady hold-up, the product
// and its d10/d50/d90, the time to steady and the spread.
nlohmann::ordered_json steady_projection_json(const CompartmentRates& r, const SteadyProjection& p,
                                              const ProjectionSpread& spread,
                                              const std::vector<double>& edges_m);

}  // namespace millsim
