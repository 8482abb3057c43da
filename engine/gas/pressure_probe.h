// Pressure probes: the mean gas pressure over a boundary patch or a plane, and the pressure drop
// between two of them (GasConfig::pressure_drops), for the time series a fluidization study
// plots.
//
// A patch's pressure is the mean over its faces that open onto fluid. The pressure lives at cell
// centres; at a face it is:
//   - on an outlet, the imposed pressure, which the projection holds exactly at the face;
//   - elsewhere (an inlet, a wall), the first cell's pressure plus the half cell of the pressure
//     gradient on the first solved face behind it, p₁ + (p₁ − p₂)/2. The projection's own
//     zero-gradient condition at a fixed face would report p₁ and miss that half cell (in a bed,
//     half a cell of its drag and weight). The value is exact for a linear pressure (a
//     hydrostatic column, a uniform bed).
// A plane's pressure is the mean over the columns of fluid cells it crosses, interpolated
// linearly between the two cell centres either side of it.
#pragma once

#include "gas/gas_config.h"
#include "gas/gas_solver.h"

namespace millsim {

double plane_pressure_pa(const GasSolver& gas, const PressurePlane& plane);

// p(from) − p(to), Pa.
inline double pressure_drop_pa(const GasSolver& gas, const PressureDropConfig& drop) {
  return plane_pressure_pa(gas, drop.from) - plane_pressure_pa(gas, drop.to);
}

}  // namespace millsim
