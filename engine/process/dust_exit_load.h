// How the dust's exit rates follow the dust the mill holds, and the steady state that follows
// from it (issue 31: a fill of the dust alone projected at fixed exit rates misjudges the cut's
// classes, bench/RESULTS.md, steadyI).
//
// The dust loads the gas (two-way coupling): the more a mill holds, the slower its vortex, the
// coarser its cut, and the faster the classes near the cut leave. In steadyI a fill that took the
// ledger from 3.31 to 2.90 mg sped the vortex at 5 mm from 143 to 148 m/s, moved the cut from
// 1.03 to 0.99 µm and halved the exit rate of the 1.41 µm class. A projection that holds each
// class's exit rate E_s at its window's value projects that class's hold-up for the cut of the
// window, not for the cut of the mill the fill makes.
//
// Each dust class's rate is taken to follow the dust hold-up D as a power,
//     E_s(D) = E_s(D_1) (D / D_1)^β_s,
// with β_s from two windows (the fill's own and the one before it, when the fill between them
// moved the dust alone: sim/run.cpp) that held D_0 and D_1:
//     β_s = ln(E_s,1 / E_s,0) / ln(D_1 / D_0).
// β_s < 0 is read as counting noise and taken as 0: loading slows the vortex, so it coarsens the
// cut and no class leaves slower for more dust. Two windows whose dust differs by less than
// kMinLoadLogChange in ln D give no fit (every β_s = 0: the rates as measured).
//
// With β ≥ 0 each class's steady hold-up at a given D, M_s(D) (the balance of
// process/steady_projection.h at the rates E_s(D)), falls as D grows, so the steady
// D* = Σ_s M_s(D*) is the one root of Σ_s M_s(D) − D, found by bisection in ln D.
//
// What it assumes: the dust alone moves the cut (the particles' hold-up is held in a fill of the
// dust alone), each class's rate is a power of D between and beyond the two windows, and the two
// windows differ by their dust, not by a change of the mill's flow.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "process/steady_projection.h"

namespace millsim {

// Two windows whose dust hold-up differs by less than this in ln D fit no exponent.
inline constexpr double kMinLoadLogChange = 0.02;

// A window's dust: its mean hold-up D and each dust class's exit rate E_s (per dust slot).
struct DustExitWindow {
  double dust_kg = 0.0;
  std::vector<double> leave_per_s;
  bool empty() const { return leave_per_s.empty(); }
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, dust_kg, leave_per_s);
  }
};

// The dust of a window's rates (the dust compartments [S, 2S) of `r`).
DustExitWindow dust_exit_window(const CompartmentRates& r);

struct DustExitLoad {
  bool fitted = false;
  double earlier_dust_kg = 0.0, reference_dust_kg = 0.0;  // D_0, D_1
  std::vector<double> exponent;    // β_s per dust slot, >= 0 (all 0 when not fitted)
  std::vector<int> taken_as_zero;  // slots whose fit gave β_s < 0
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, fitted, earlier_dust_kg, reference_dust_kg, exponent, taken_as_zero);
  }
};

// β_s from an earlier window and a later one (the rates hold at the later one's D).
DustExitLoad fit_dust_exit_load(const DustExitWindow& earlier, const DustExitWindow& later);

// `r` with each dust class's exit rate taken at a dust hold-up D.
CompartmentRates rates_at_dust_kg(const CompartmentRates& r, const DustExitLoad& load,
                                  double dust_kg);

struct LoadedProjection {
  SteadyProjection projection;  // at the rates E_s(D*)
  double dust_kg = 0.0;         // D*
};

// The steady state whose dust hold-up D* is the one its own exit rates E_s(D*) give; without a
// fit, project_steady at r's rates.
LoadedProjection project_steady_at_own_load(const CompartmentRates& r, const DustExitLoad& load,
                                            const std::vector<double>& start_held_kg,
                                            int course_points);

// A fill's `dust_exit_load` record: the exponents, the two windows' dust and D*.
nlohmann::ordered_json dust_exit_load_json(const DustExitLoad& load, double projected_dust_kg);

}  // namespace millsim
