// Pressure probes: the mean gas pressure over a boundary patch or a plane, and the pressure drop
// between two of them (GasConfig::pressure_drops), for the time series a fluidization study
// plots.
//
// A patch's pressure is the mean over its faces that open onto fluid. The pressure lives at cell
// centres; at a face it is:
//   - on an outlet, the imposed pressure, which the projection holds exactly at the face;
//   - elsewhere (an inlet, a wall), the first cell's pressure plus the weight of the gas in the
//     half cell between them, p₁ + ρ g·(x_face − x₁). The drag of the particles in that half
//     cell is already in p₁: the face behind it is held, so their impulse goes to the first
//     solved face (gas/coupling.h), whose balance sets p₁ − p₂. Extrapolating the gradient
//     instead, p₁ + (p₁ − p₂)/2, counted that half cell's drag twice (4 % of a 14-cell bed).
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
