// Time-step bounds (§4, Eq. 4–5). The automatic step is safety_factor × the Rayleigh time of
// the smallest particle of each material, t_R = π r √(ρ/G) / (0.1631 ν + 0.8766), the
// customary DEM bound (it is ∝ d, while the Hertz bound of Eq. 5 is ∝ d^1.25 at a given speed).
#pragma once

namespace millsim {

double rayleigh_time_s(double radius_m, double youngs_modulus_pa, double poisson_ratio,
                       double density_kg_per_m3);

// Hertz contact duration of a head-on impact at `speed` with stiffness k = (4/3)E*√R* and
// reduced mass m*: t_c = 2.943 (m*/k)^{2/5} v^{-1/5} (from Eq. 12 and the Hertz force law).
double hertz_contact_time_s(double reduced_mass_kg, double stiffness, double speed_m_per_s);

}  // namespace millsim
