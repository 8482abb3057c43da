// A gas field for the dust ledger's tests, set by hand (the solver is not stepped): a free vortex
// draining into a circular outlet in the lid of a square box, u = (−q r̂ + Γ θ̂) / r about the
// box's axis (held at the outlet radius inside it), the sink's 2π q per unit height leaving
// through the lid's outlet faces. Γ/q = 5 is the mill's u_t/u_r at its outlet radius.
#pragma once

#include "gas/gas_solver.h"

namespace millsim::test {

struct DrainingVortex {
  int cells = 64;                     // across the box, each way
  int layers = 1;                     // cells high
  double side_m = 0.064;              // the box's side; the cells are cubes
  double outlet_radius_m = 0.006;     // the lid's outlet, about the axis
  double sink_m2_per_s = 0.06;        // q
  double circulation_m2_per_s = 0.3;  // Γ
  double centre_m() const { return 0.5 * side_m; }
  double cell_m() const { return side_m / cells; }
};

// The gas (air at 1.2 kg/m³, 1.8e-5 Pa s) with the vortex's velocities on its faces.
GasSolver draining_vortex_gas(const DrainingVortex& vortex);

}  // namespace millsim::test
