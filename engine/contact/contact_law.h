// Hertz–Mindlin contact law as pure functions over plain parameters (STYLE §7.5 S5).
// Two ways to get a pair's springs, selected once per step:
//   SeriesSprings (§3.2, Eq. 2–3): per-particle constants combined in series (see below for
//     the tangential part); exact Hertz–Mindlin for equal particles.
//   EquivalentProperties (Eq. 1): E*, G*, R*, m* of the pair; Hertz (4/3)E*√R*, Mindlin 8G*√R*.
// Both use the same damping form, F_damp = η δ^{1/4} v with η = α √(k m*) of the pair
// (restitution.h), and the normal force is clipped at zero (a contact never pulls).
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

// Springs in series; two zero springs give zero, not 0/0.
inline double series(double a, double b) {
  const double sum = a + b;
  return sum > 0.0 ? a * b / sum : 0.0;
}

// The pair's dampers from its restitution: η = α √(k m*) for each spring, with m* from the
// partners' inverse masses (a frozen partner or a wall, 1/m = 0, is immovable: m* is the other's
// mass). The impact then scales to X'' = −X^{3/2} − α X^{1/4} X' (restitution.h), so every pair
// rebounds with its restitution whatever its sizes, masses and spring model. Per-particle dampers
// combined in series (the paper's §3.2) give that only for two equal free spheres: 0.71× the
// damping against a frozen equal sphere, 1.14× at 1:5 (docs/contact-model.md).
inline PairSprings damped_springs(double normal_stiffness, double tangential_stiffness,
                                  double damping_ratio, double inv_mass_sum_per_kg) {
  if (!(inv_mass_sum_per_kg > 0.0)) return {normal_stiffness, 0.0, tangential_stiffness, 0.0};
  const double alpha_sqrt_m = damping_ratio / std::sqrt(inv_mass_sum_per_kg);
  return {normal_stiffness, alpha_sqrt_m * std::sqrt(normal_stiffness), tangential_stiffness,
          alpha_sqrt_m * std::sqrt(tangential_stiffness)};
}

// Per-particle springs (§3.2). Normal: series, Eq. 2. Tangential: Eq. 3 sums the particles'
// springs in parallel, which is exact Mindlin only for equal sizes; for a fine against a coarse
// particle the sum is set by the coarse particle's √r: (1 + √(r_coarse/r_fine))/(2√2) times
// Mindlin's 8G*√(R*δ) (11.5× at 1:1000), and the explicit step cannot hold it (energy grew 700-fold
// in 300 steps in cases/stability/size_ratio_1000.json). kSeriesTangential combines 4·k_tp in
// series instead: identical to Eq. 3 for equal particles, dominated by the fine one otherwise,
// like the normal spring. The paper's parallel sum stays selectable for comparison.
template <bool kSeriesTangential>
struct PerParticleSprings {
  const ParticleSprings* springs;
  const double* inv_mass;
  explicit PerParticleSprings(const ParticleStore& p)
      : springs(p.springs.data()), inv_mass(p.inv_mass_per_kg.data()) {}
  // Starts loading particle j's constants (pair loop prefetch).
  void prefetch(std::size_t j) const {
    __builtin_prefetch(springs + j), __builtin_prefetch(inv_mass + j);
  }
  PairSprings operator()(std::size_t i, std::size_t j, const PairConstants& pair) const {
    const ParticleSprings& a = springs[i];
    const ParticleSprings& b = springs[j];
    const double kn = series(a.normal_stiffness, b.normal_stiffness);
    const double kt = kSeriesTangential
                          ? 4.0 * series(a.tangential_stiffness, b.tangential_stiffness)
                          : a.tangential_stiffness + b.tangential_stiffness;
    return damped_springs(kn, kt, pair.damping_ratio, inv_mass[i] + inv_mass[j]);
  }
};
using SeriesSprings = PerParticleSprings<true>;
using PaperSprings = PerParticleSprings<false>;  // Eq. 3 exactly: tangential in parallel

// Hertz–Mindlin springs from effective properties: (4/3)E*√R* and 8G*√R*.
inline PairSprings hertz_mindlin_springs(double effective_modulus_pa, double effective_shear_pa,
                                         double r_eff, double inv_mass_sum_per_kg,
                                         double damping_ratio) {
  const double sqrt_r = std::sqrt(r_eff);
  return damped_springs(4.0 / 3.0 * effective_modulus_pa * sqrt_r,
                        8.0 * effective_shear_pa * sqrt_r, damping_ratio, inv_mass_sum_per_kg);
}

struct EquivalentProperties {
  const double* r;
  const double* inv_mass;
  const double* cn;
  const double* cs;
  explicit EquivalentProperties(const ParticleStore& p)
      : r(p.radius_m.data()),
        inv_mass(p.inv_mass_per_kg.data()),
        cn(p.normal_compliance.data()),
        cs(p.shear_compliance.data()) {}
  void prefetch(std::size_t j) const {
    __builtin_prefetch(r + j), __builtin_prefetch(inv_mass + j);
    __builtin_prefetch(cn + j), __builtin_prefetch(cs + j);
  }
  PairSprings operator()(std::size_t i, std::size_t j, const PairConstants& pair) const {
    return hertz_mindlin_springs(1.0 / (cn[i] + cn[j]), 1.0 / (cs[i] + cs[j]),
                                 r[i] * r[j] / (r[i] + r[j]), inv_mass[i] + inv_mass[j],
                                 pair.damping_ratio);
  }
};

// Particle against an infinitely massive wall (m* = m): Hertz with R* = r on a flat wall (Eq. 5),
// or the elliptic contact's equivalent radius on a curved one (contact/curved_contact.h).
inline PairSprings wall_springs(const ParticleStore& p, std::size_t i, const PairConstants& wall,
                                double contact_radius_m) {
  return hertz_mindlin_springs(1.0 / (p.normal_compliance[i] + wall.wall_normal_compliance),
                               1.0 / (p.shear_compliance[i] + wall.wall_shear_compliance),
                               contact_radius_m, p.inv_mass_per_kg[i], wall.damping_ratio);
}

inline double hertz_normal_force_n(const PairSprings& s, double overlap_m, double sqrt_overlap,
                                   double normal_velocity_m_per_s) {
  const double f = overlap_m * sqrt_overlap * s.normal_stiffness -
                   std::sqrt(sqrt_overlap) * s.normal_damping * normal_velocity_m_per_s;
  return f > 0.0 ? f : 0.0;
}

// Tangential spring with history and Coulomb's limit; returns the tangential force on the first
// body. `n` points from the second body to the first; v_t is the tangential slip velocity; the
// stored displacement `history` is rotated into the current tangent plane and advanced by v_t dt.
[[gnu::always_inline]] inline Vec3 tangential_force_n(const PairSprings& s, double sqrt_overlap,
                                                      double normal_force, double friction,
                                                      const Vec3& n, const Vec3& v_t, double dt,
                                                      Vec3& history) {
  // Keep the stored displacement in the current tangent plane, with its length (rotation).
  const double len2 = norm2(history);
  if (len2 > 0.0) {
    history -= n * dot(history, n);
    const double new_len2 = norm2(history);
    if (new_len2 > 0.0) history *= std::sqrt(len2 / new_len2);
  }
  history += v_t * dt;
  const double kt = s.tangential_stiffness * sqrt_overlap;
  const double etat = s.tangential_damping * std::sqrt(sqrt_overlap);
  const double ft_max = friction * normal_force;
  const Vec3 spring = -(history * kt);
  const double spring2 = norm2(spring);
  if (spring2 > ft_max * ft_max) {
    // Gross sliding: the spring alone has reached μ F_n. It is held there (the slip it stores
    // stays what μ F_n stretches it to, opposite the slip) and the force is μ F_n, with no
    // damping: a sliding contact dissipates through friction alone (LIGGGHTS's history model).
    // Folding the damper into the stored spring instead, as LAMMPS's rescaling does, leaves the
    // spring pointing along the slip early in a contact, where damping exceeds μ F_n, and the
    // sliding force then falls short of μ F_n (a gross-sliding impact's tangential impulse came
    // out at 0.78–0.88 μ J_n; tests/physics/oblique_impact_test.cpp).
    const double scale = ft_max / std::sqrt(spring2);
    history *= scale;
    return spring * scale;
  }
  // Sticking: spring and damper, with the total never beyond Coulomb's limit (early in a contact
  // the damper can exceed it before the spring has built up); the spring is left as it is.
  Vec3 ft = spring - v_t * etat;
  const double ft2 = norm2(ft);
  if (ft2 > ft_max * ft_max) ft *= ft_max / std::sqrt(ft2);
  return ft;
}

// What one contact exerts, for particle pairs and walls alike. The first body gets
// n·F_n + F_t and the torque −(n × F_t)(r − δ/2) − rolling; the second (a particle) the
// opposite force and −(n × F_t)(r₂ − δ/2) + rolling.
struct ContactResponse {
  double normal_force_n = 0.0;
  Vec3 tangential_force_n;
  Vec3 rolling_torque_n_m;  // on the first body, to be subtracted
};

// The contact law at overlap δ > 0 with unit normal n (from the second body to the first), the
// contact point's relative velocity v_rel, the relative spin w_rel and the rolling radius (R* for
// a pair, r on a wall). `history` is null for a contact born overlapping (no tangential spring,
// neighbor_list.h). Always inlined: the pair loop's two ways of applying a contact
// (contact_forces.cpp) and the wall loop each call it, and g++ then took it out of line (a call
// per contact, 5 % of the shipped mill's time).
[[gnu::always_inline]] inline ContactResponse contact_response(
    const PairSprings& s, const PairConstants& pc, double overlap, const Vec3& n, const Vec3& v_rel,
    const Vec3& w_rel, double rolling_radius_m, double dt, Vec3* history) {
  ContactResponse out;
  const double sqrt_overlap = std::sqrt(overlap);
  const double vn = dot(v_rel, n);
  out.normal_force_n = hertz_normal_force_n(s, overlap, sqrt_overlap, vn);
  if (history)
    out.tangential_force_n = tangential_force_n(s, sqrt_overlap, out.normal_force_n, pc.friction, n,
                                                v_rel - n * vn, dt, *history);
  if (pc.rolling_friction > 0.0) {
    // Constant directional torque (Zhou et al. 1999): μ_r R F_n ω_rel/|ω_rel|.
    const double w_len = norm(w_rel);
    if (w_len > 0.0)
      out.rolling_torque_n_m =
          w_rel * (pc.rolling_friction * rolling_radius_m * out.normal_force_n / w_len);
  }
  return out;
}

// Elastic energy of one contact: (2/5) kn δ^{5/2} + ½ kt δ^{1/2} |ξ|² (no ξ when born overlapping).
inline double contact_elastic_energy_j(const PairSprings& s, double overlap, const Vec3* history) {
  const double sqrt_overlap = std::sqrt(overlap);
  double energy = 0.4 * s.normal_stiffness * overlap * overlap * sqrt_overlap;
  if (history) energy += 0.5 * s.tangential_stiffness * sqrt_overlap * norm2(*history);
  return energy;
}

// A contact of restitution below 0.05 ends keeping `scale` = e / 0.05 of its normal separation
// speed vn > 0 (particles/restitution.h): the force that, applied over one step dt to partners
// of inverse masses summing to inv_mass_sum, removes the rest (along n, equal and opposite).
inline double separation_force_n(double scale, double vn_m_per_s, double inv_mass_sum_per_kg,
                                 double dt_s) {
  return (1.0 - scale) * vn_m_per_s / (inv_mass_sum_per_kg * dt_s);
}

}  // namespace millsim
