// Drag and lift on one particle from the mean fluid state of its DEM cell (§3.1). Every law
// returns the particle's drag coefficient β in kg/s, so the drag is F = β (u − v) with u the
// interstitial gas velocity; β stays finite as the slip goes to zero (the Stokes limit).
//   Schiller & Naumann (1933): single sphere, C_d = 24/Re (1 + 0.15 Re^0.687), 0.44 past
//     Re = 1000; no crowding correction.
//   Di Felice (1994): C_d = (0.63 + 4.8/√Re)², F = ⅛ C_d ρ π d² ε^(2−χ) |s| s,
//     χ = 3.7 − 0.65 exp(−(1.5 − log10 Re)²/2), Re = ε ρ d |s| / μ.
//   Gidaspow (1994): Ergun (1952) below ε = 0.8, Wen & Yu (1966) above;
//     per particle β = V_p β_vol / (1 − ε).
// Saffman (1965) lift, in the form of Crowe et al.: F = 1.615 d² √(ρ μ / |ω|) (s × ω).
#pragma once

#include "core/vec3.h"
#include "gas/gas_config.h"

namespace millsim {

struct DragInput {
  double diameter_m = 0.0;
  double slip_speed_m_per_s = 0.0;  // |u − v|
  double volume_fraction = 1.0;     // ε of the gas
  double density_kg_per_m3 = 1.2;
  double viscosity_pa_s = 1.8e-5;
};

double drag_coefficient_kg_per_s(DragLaw law, const DragInput& in);

// Particle Reynolds number ρ d |u − v| / μ (without ε).
inline double particle_reynolds(const DragInput& in) {
  return in.density_kg_per_m3 * in.diameter_m * in.slip_speed_m_per_s / in.viscosity_pa_s;
}

// Standard single-sphere drag coefficient of Schiller & Naumann (used by Wen & Yu too).
double schiller_naumann_cd(double reynolds);

Vec3 saffman_lift_n(double diameter_m, const Vec3& slip_m_per_s, const Vec3& vorticity_per_s,
                    double density_kg_per_m3, double viscosity_pa_s);

}  // namespace millsim
