// Drag and lift on one particle from the mean fluid state of its DEM cell (§3.1). Every law
// returns the particle's drag coefficient β in kg/s, so the drag is F = β (u − v) with u the
// interstitial gas velocity; β stays finite as the slip goes to zero (the Stokes limit).
//   Schiller & Naumann (1933): single sphere, C_d = 24/Re (1 + 0.15 Re^0.687), 0.44 past
//     Re = 1000; no crowding correction.
//   Di Felice (1994): C_d = (0.63 + 4.8/√Re)², F = ⅛ C_d ρ π d² ε^(2−χ) |s| s,
//     χ = 3.7 − 0.65 exp(−(1.5 − log10 Re)²/2), Re = ε ρ d |s| / μ.
//   Gidaspow (1994): Ergun (1952) below ε = 0.8, Wen & Yu (1966) above;
//     per particle β = V_p β_vol / (1 − ε).
//   Koch & Hill (2001; Hill, Koch & Ladd 2001), CFDEM's default: total force on a particle over
//     3π μ d U (U = ε |s| the superficial slip) F = F0(φ) + ½ F3(φ) Re, Re = ε ρ d |s| / μ,
//     φ = 1 − ε, F0 = (1 + 3√(φ/2) + (135/64) φ ln φ + 16.14 φ) / (1 + 0.681 φ − 8.48 φ² +
//     8.16 φ³) below φ = 0.4 and 10 φ / ε³ above, F3 = 0.0673 + 0.212 φ + 0.0232 / ε⁵.
//     The drag is ε times the total force (the rest is the pressure gradient's): β = 3π μ d ε² F.
//   Beetstra, van der Hoef & Kuipers (2007): drag over 3π μ d U, F = 10 φ/ε² + ε² (1 + 1.5 √φ)
//     + 0.413 Re / (24 ε²) (1/ε + 3 ε φ + 8.4 Re^−0.343) / (1 + 10^(3φ) Re^−(1+4φ)/2);
//     β = 3π μ d ε F.
//   In a packed bed at Re → 0 both give the Carman–Kozeny pressure drop (Beetstra plus its
//   ε² (1 + 1.5 √φ) term); for ε = 1 and Re → 0 both are Stokes drag.
// Saffman (1965) lift, in the form of Crowe et al.: F = 1.615 d² √(ρ μ / |ω|) (s × ω).
#pragma once

#include <cmath>

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

// Cunningham's slip correction for a sphere of diameter d in a gas of mean free path λ: the drag
// of the continuum laws is divided by C = 1 + Kn (A1 + A2 exp(−A3 / Kn)), Kn = 2λ/d, with Davies'
// constants A1 = 1.257, A2 = 0.400, A3 = 1.10 (Proc. Phys. Soc. 57 (1945) 259), fitted to
// Millikan's oil drops over the whole Knudsen range. 1 µm in air at 1 bar: C = 1.17; 10 µm: 1.017.
double cunningham_correction(double diameter_m, double mean_free_path_m);

// The mean free path of a gas from its viscosity, pressure and density (the kinetic-theory
// relation of the hard-sphere gas, λ = (μ / p) √(π p / (2 ρ)) = μ √(π / (2 p ρ))): 66 nm for air
// at 20 °C and 1 atm (the value Cunningham corrections for air are quoted with is 66–68 nm).
inline double mean_free_path_m(double viscosity_pa_s, double pressure_pa,
                               double density_kg_per_m3) {
  return viscosity_pa_s * std::sqrt(1.5707963267948966 / (pressure_pa * density_kg_per_m3));
}

// Standard single-sphere drag coefficient of Schiller & Naumann (used by Wen & Yu too).
double schiller_naumann_cd(double reynolds);

Vec3 saffman_lift_n(double diameter_m, const Vec3& slip_m_per_s, const Vec3& vorticity_per_s,
                    double density_kg_per_m3, double viscosity_pa_s);

}  // namespace millsim
