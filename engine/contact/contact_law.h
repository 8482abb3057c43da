// Hertz–Mindlin contact law as pure functions over plain parameters (STYLE §7.5 S5).
// Two ways to get a pair's springs, selected once per step:
//   SeriesSprings (§3.2, Eq. 2–3): per-particle constants combined in series (see below for
//     the tangential part); exact Hertz–Mindlin for equal particles.
//   EquivalentProperties (Eq. 1): E*, G*, R*, m* of the pair; Hertz (4/3)E*√R*, Mindlin 8G*√R*.
// Both use the same damping form, F_damp = η δ^{1/4} v (restitution.h), and the normal force is
// clipped at zero (a contact never pulls).
#pragma once

#include <cmath>

#include "particles/materials.h"
#include "particles/particle_store.h"

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

// Per-particle springs (§3.2). Normal: series, Eq. 2. Tangential: Eq. 3 sums the particles'
// springs in parallel, which is exact Mindlin only for equal sizes; for a fine against a coarse
// particle the sum is set by the coarse particle's √r: (1 + √(r_coarse/r_fine))/(2√2) times
// Mindlin's 8G*√(R*δ) (11.5× at 1:1000), and the explicit step cannot hold it (energy grew 700-fold
// in 300 steps in cases/stability/size_ratio_1000.json). kSeriesTangential combines 4·k_tp and
// 4·η_tp in series instead: identical to Eq. 3 for equal particles, dominated by the fine one
// otherwise, like the normal spring. The paper's parallel sum stays selectable for comparison.
template <bool kSeriesTangential>
struct PerParticleSprings {
  const ParticleSprings* springs;
  explicit PerParticleSprings(const ParticleStore& p) : springs(p.springs.data()) {}
  // Starts loading particle j's constants (pair loop prefetch).
  void prefetch(std::size_t j) const { __builtin_prefetch(springs + j); }
  PairSprings operator()(std::size_t i, std::size_t j, const PairConstants&) const {
    const ParticleSprings& a = springs[i];
    const ParticleSprings& b = springs[j];
    const double kn = series(a.normal_stiffness, b.normal_stiffness);
    const double etan = series(a.normal_damping, b.normal_damping);
    if constexpr (kSeriesTangential)
      return {kn, etan, 4.0 * series(a.tangential_stiffness, b.tangential_stiffness),
              4.0 * series(a.tangential_damping, b.tangential_damping)};
    else
      return {kn, etan, a.tangential_stiffness + b.tangential_stiffness,
              a.tangential_damping + b.tangential_damping};
  }
};
using SeriesSprings = PerParticleSprings<true>;
using PaperSprings = PerParticleSprings<false>;  // Eq. 3 exactly: tangential in parallel

// Hertz–Mindlin springs from effective properties.
inline PairSprings hertz_mindlin_springs(double effective_modulus_pa, double effective_shear_pa,
                                         double r_eff, double m_eff, double damping_ratio) {
  const double sqrt_r = std::sqrt(r_eff);
  const double kn = 4.0 / 3.0 * effective_modulus_pa * sqrt_r;
  const double kt = 8.0 * effective_shear_pa * sqrt_r;
  return {kn, damping_ratio * std::sqrt(kn * m_eff), kt, damping_ratio * std::sqrt(kt * m_eff)};
}

struct EquivalentProperties {
  const double* r;
  const double* m;
  const double* cn;
  const double* cs;
  explicit EquivalentProperties(const ParticleStore& p)
      : r(p.radius_m.data()),
        m(p.mass_kg.data()),
        cn(p.normal_compliance.data()),
        cs(p.shear_compliance.data()) {}
  void prefetch(std::size_t j) const {
    __builtin_prefetch(r + j), __builtin_prefetch(m + j);
    __builtin_prefetch(cn + j), __builtin_prefetch(cs + j);
  }
  PairSprings operator()(std::size_t i, std::size_t j, const PairConstants& pair) const {
    return hertz_mindlin_springs(1.0 / (cn[i] + cn[j]), 1.0 / (cs[i] + cs[j]),
                                 r[i] * r[j] / (r[i] + r[j]), m[i] * m[j] / (m[i] + m[j]),
                                 pair.damping_ratio);
  }
};

// Particle against an infinite-mass, flat wall: exact Hertz with R* = r, m* = m (Eq. 5).
inline PairSprings wall_springs(const ParticleStore& p, std::size_t i, const PairConstants& wall) {
  return hertz_mindlin_springs(1.0 / (p.normal_compliance[i] + wall.wall_normal_compliance),
                               1.0 / (p.shear_compliance[i] + wall.wall_shear_compliance),
                               p.radius_m[i], p.mass_kg[i], wall.damping_ratio);
}

inline double hertz_normal_force_n(const PairSprings& s, double overlap_m, double sqrt_overlap,
                                   double normal_velocity_m_per_s) {
  const double f = overlap_m * sqrt_overlap * s.normal_stiffness -
                   std::sqrt(sqrt_overlap) * s.normal_damping * normal_velocity_m_per_s;
  return f > 0.0 ? f : 0.0;
}

// A contact of restitution below 0.05 ends keeping `scale` = e / 0.05 of its normal separation
// speed vn > 0 (particles/restitution.h): the force that, applied over one step dt to partners
// of inverse masses summing to inv_mass_sum, removes the rest (along n, equal and opposite).
inline double separation_force_n(double scale, double vn_m_per_s, double inv_mass_sum_per_kg,
                                 double dt_s) {
  return (1.0 - scale) * vn_m_per_s / (inv_mass_sum_per_kg * dt_s);
}

}  // namespace millsim
