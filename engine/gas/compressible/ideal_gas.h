// IdealGas: the thermodynamics of a calorically perfect gas (constant γ and R) and the
// isentropic relations of nozzle flow from a reservoir (stagnation) state: what the compressible
// gas model (gas/compressible/compressible_solver.h) and its pressure-set inlets use. SI units,
// temperatures in kelvin. The relations are the textbook ones (e.g. Anderson, Modern
// Compressible Flow, 3rd ed., ch. 3 and 5).
#pragma once

#include <algorithm>
#include <cmath>

namespace millsim {

struct IdealGas {
  double gamma = 1.4;                       // ratio of specific heats c_p / c_v
  double gas_constant_j_per_kg_k = 287.05;  // specific gas constant R (dry air)
  double prandtl = 0.71;                    // μ c_p / k

  double heat_capacity_p_j_per_kg_k() const {
    return gamma * gas_constant_j_per_kg_k / (gamma - 1.0);
  }
  double density_kg_per_m3(double pressure_pa, double temperature_k) const {
    return pressure_pa / (gas_constant_j_per_kg_k * temperature_k);
  }
  double temperature_k(double density_kg_per_m3, double pressure_pa) const {
    return pressure_pa / (density_kg_per_m3 * gas_constant_j_per_kg_k);
  }
  double sound_speed_m_per_s(double density_kg_per_m3, double pressure_pa) const {
    return std::sqrt(gamma * pressure_pa / density_kg_per_m3);
  }
  // ρE = p / (γ − 1) + ρ|u|²/2, J/m³.
  double total_energy_j_per_m3(double density_kg_per_m3, double speed2, double pressure_pa) const {
    return pressure_pa / (gamma - 1.0) + 0.5 * density_kg_per_m3 * speed2;
  }
  // p = (γ − 1)(ρE − |ρu|²/(2ρ)).
  double pressure_pa(double density_kg_per_m3, double momentum2, double total_energy) const {
    return (gamma - 1.0) * (total_energy - 0.5 * momentum2 / density_kg_per_m3);
  }
};

// p*/p0 at a sonic throat: (2/(γ+1))^(γ/(γ−1)), 0.528 for air. A nozzle is choked while the
// pressure behind it is below p0 times this.
inline double critical_pressure_ratio(const IdealGas& g) {
  return std::pow(2.0 / (g.gamma + 1.0), g.gamma / (g.gamma - 1.0));
}

// The mass flow per throat area of a choked nozzle fed from p0, T0:
// p0 √(γ / (R T0)) (2/(γ+1))^((γ+1)/(2(γ−1))), kg/(m² s).
inline double choked_mass_flux_kg_per_m2_s(const IdealGas& g, double p0_pa, double t0_k) {
  return p0_pa * std::sqrt(g.gamma / (g.gas_constant_j_per_kg_k * t0_k)) *
         std::pow(2.0 / (g.gamma + 1.0), (g.gamma + 1.0) / (2.0 * (g.gamma - 1.0)));
}

// The static state of isentropic flow at Mach number M from the stagnation state p0, T0.
struct IsentropicState {
  double pressure_pa = 0.0;
  double temperature_k = 0.0;
  double density_kg_per_m3 = 0.0;
  double speed_m_per_s = 0.0;
};
inline IsentropicState isentropic_state(const IdealGas& g, double p0_pa, double t0_k, double mach) {
  const double ratio = 1.0 + 0.5 * (g.gamma - 1.0) * mach * mach;  // T0 / T
  IsentropicState s;
  s.temperature_k = t0_k / ratio;
  s.pressure_pa = p0_pa * std::pow(ratio, -g.gamma / (g.gamma - 1.0));
  s.density_kg_per_m3 = g.density_kg_per_m3(s.pressure_pa, s.temperature_k);
  s.speed_m_per_s = mach * std::sqrt(g.gamma * g.gas_constant_j_per_kg_k * s.temperature_k);
  return s;
}

// The Mach number of isentropic flow whose static pressure is p from p0 (p ≤ p0), capped at 1:
// M² = (2/(γ−1)) ((p0/p)^((γ−1)/γ) − 1).
inline double isentropic_mach(const IdealGas& g, double p_pa, double p0_pa) {
  const double ratio = std::clamp(p_pa / p0_pa, critical_pressure_ratio(g), 1.0);
  const double m2 = 2.0 / (g.gamma - 1.0) * (std::pow(ratio, -(g.gamma - 1.0) / g.gamma) - 1.0);
  return std::sqrt(std::max(m2, 0.0));
}

}  // namespace millsim
