// Hertz–Mindlin contact law as pure functions over plain parameters (STYLE §7.5 S5).
// Two ways to get a pair's springs, selected once per step:
//   SeriesSprings (§3.2, Eq. 2–3): per-particle constants, normal in series, tangential in
//     parallel; exact Hertz–Mindlin for equal particles.
//   EquivalentProperties (Eq. 1): E*, G*, R*, m* of the pair; Hertz (4/3)E*√R*, Mindlin 8G*√R*.
// Both use the same damping form, F_damp = η δ^{1/4} v (restitution.h), and the normal force is
// clipped at zero (a contact never pulls).
#pragma once

#include <cmath>

#include "particles/materials.h"

namespace millsim {

// Coefficients of one contact; forces are
//   F_n = max(0, kn·δ^{3/2} − ηn·δ^{1/4}·v_n),  F_t = −kt·δ^{1/2}·ξ − ηt·δ^{1/4}·v_t.
struct PairSprings {
  double normal_stiffness;      // kn, N/m^1.5
  double normal_damping;        // ηn, N s/m^1.25
  double tangential_stiffness;  // kt, N/m^1.5
  double tangential_damping;    // ηt, N s/m^1.25
};

// Springs (or dampers) in series; two zero dampers (e = 1) give zero, not 0/0.
inline double series(double a, double b) {
  const double sum = a + b;
  return sum > 0.0 ? a * b / sum : 0.0;
}

struct SeriesSprings {
  const double* kn;
  const double* etan;
  const double* kt;
  const double* etat;
  PairSprings operator()(std::size_t i, std::size_t j, double, double, double, double,
                         const PairConstants&) const {
    return {series(kn[i], kn[j]), series(etan[i], etan[j]), kt[i] + kt[j], etat[i] + etat[j]};
  }
};

struct EquivalentProperties {
  PairSprings operator()(std::size_t, std::size_t, double ri, double rj, double mi, double mj,
                         const PairConstants& pair) const {
    const double r_eff = ri * rj / (ri + rj), m_eff = mi * mj / (mi + mj);
    const double kn = 4.0 / 3.0 * pair.effective_modulus_pa * std::sqrt(r_eff);
    const double kt = 8.0 * pair.effective_shear_modulus_pa * std::sqrt(r_eff);
    return {kn, pair.damping_ratio * std::sqrt(kn * m_eff), kt,
            pair.damping_ratio * std::sqrt(kt * m_eff)};
  }
};

// Particle against an infinite-mass, flat wall: exact Hertz with R* = r, m* = m (Eq. 5).
inline PairSprings wall_springs(double r, double m, const PairConstants& pair) {
  const double kn = 4.0 / 3.0 * pair.effective_modulus_pa * std::sqrt(r);
  const double kt = 8.0 * pair.effective_shear_modulus_pa * std::sqrt(r);
  return {kn, pair.damping_ratio * std::sqrt(kn * m), kt, pair.damping_ratio * std::sqrt(kt * m)};
}

inline double hertz_normal_force_n(const PairSprings& s, double overlap_m, double sqrt_overlap,
                                   double normal_velocity_m_per_s) {
  const double f = overlap_m * sqrt_overlap * s.normal_stiffness -
                   std::sqrt(sqrt_overlap) * s.normal_damping * normal_velocity_m_per_s;
  return f > 0.0 ? f : 0.0;
}

}  // namespace millsim
