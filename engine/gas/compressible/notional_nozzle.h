// Notional nozzle: what a convergent nozzle fed from a reservoir (p0, T0) puts into a chamber at
// pressure pa, as a jet already expanded to pa. A mill's nozzle (about 1 mm) is narrower than a
// gas cell, so its under-expanded jet, with its expansion fan, barrel shock and Mach disk, cannot
// be resolved; the grid receives instead the fully expanded jet the real one becomes a few
// throat diameters downstream (Birch, Hughes, Caldwell & Swaffield, Combust. Sci. Technol. 36
// (1984) 249; Birch, Brown, Dodson & Swaffield, ibid. 52 (1987) 161):
//   throat      isentropic from (p0, T0) to max(pa, p0 · critical ratio): sonic and choked below
//               the critical ratio, subsonic above it; ṁ = A ρ_t u_t
//   notional    at pressure pa, with the throat's mass flow and its thrust (Birch 1987, momentum
//               conserved through the expansion): u = u_t + (p_t − pa) / (ρ_t u_t), at the
//               throat's temperature (Birch 1987's assumption), so ρ = pa / (R T_t) and the
//               notional area is ṁ / (ρ u)
//   energy      the jet carries the reservoir's stagnation enthalpy c_p T0 per kilogram (the
//               nozzle is adiabatic), whatever its notional temperature
// What it leaves out: the shock structure and the entrainment within the first few diameters,
// the nozzle's discharge coefficient (taken as 1), and any effect of the chamber's flow on the
// nozzle itself.
#pragma once

#include <cmath>

#include "gas/compressible/ideal_gas.h"

namespace millsim {

struct NozzleExit {
  double mass_flow_kg_per_s = 0.0;
  bool choked = false;
  double throat_pressure_pa = 0.0, throat_speed_m_per_s = 0.0, throat_density_kg_per_m3 = 0.0;
  // The notional (fully expanded) jet.
  double speed_m_per_s = 0.0, temperature_k = 0.0, density_kg_per_m3 = 0.0;
  double area_m2 = 0.0;
  double mach = 0.0;  // the notional jet's speed over its own sound speed
  double stagnation_enthalpy_j_per_kg = 0.0;
};

inline NozzleExit notional_nozzle(const IdealGas& g, double p0_pa, double t0_k,
                                  double throat_area_m2, double ambient_pa) {
  NozzleExit e;
  e.stagnation_enthalpy_j_per_kg = g.heat_capacity_p_j_per_kg_k() * t0_k;
  if (!(ambient_pa < p0_pa) || throat_area_m2 <= 0.0) return e;  // no flow into a fuller chamber
  const double critical_pa = p0_pa * critical_pressure_ratio(g);
  e.choked = ambient_pa <= critical_pa;
  const double throat_pa = e.choked ? critical_pa : ambient_pa;
  const IsentropicState t = isentropic_state(g, p0_pa, t0_k, isentropic_mach(g, throat_pa, p0_pa));
  e.throat_pressure_pa = t.pressure_pa;
  e.throat_speed_m_per_s = t.speed_m_per_s;
  e.throat_density_kg_per_m3 = t.density_kg_per_m3;
  e.mass_flow_kg_per_s = throat_area_m2 * t.density_kg_per_m3 * t.speed_m_per_s;
  if (e.mass_flow_kg_per_s <= 0.0) return e;
  e.speed_m_per_s =
      t.speed_m_per_s + (t.pressure_pa - ambient_pa) / (t.density_kg_per_m3 * t.speed_m_per_s);
  e.temperature_k = t.temperature_k;
  e.density_kg_per_m3 = g.density_kg_per_m3(ambient_pa, t.temperature_k);
  e.area_m2 = e.mass_flow_kg_per_s / (e.density_kg_per_m3 * e.speed_m_per_s);
  e.mach = e.speed_m_per_s / g.sound_speed_m_per_s(e.density_kg_per_m3, ambient_pa);
  return e;
}

}  // namespace millsim
