// Velocity Verlet in kick–drift–kick form for translation and rotation of spheres, with the
// velocity-dependent forces (damping, friction) evaluated at a predicted full-step velocity:
//   kick_drift:  v½ = v + ½ a dt;  x += v½ dt;  v ← v½ + ½ a dt      (prediction of v(n+1))
//   (forces, from x(n+1) and the predicted velocity; the old forces are kept)
//   kick:        v ← v + ½ dt (a_new − a_old)   (= v½ + ½ a_new dt, velocity Verlet)
// Positions follow velocity Verlet exactly (symplectic for conservative forces). Evaluating the
// damping at v(n+½) instead lags it by half a step, an O(dt) error in the rebound and the
// maximum overlap; the prediction makes it O(dt²) (tests/physics/overlap_sweep_test.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>

#include "dem/box.h"

#include "core/vec3.h"
#include "particles/particle_store.h"

namespace millsim {

// Returns the largest drift speed |v½| of the step, which bounds every particle's displacement
// (search/neighbor_list.h). Positions are not wrapped here: the neighbour list wraps them when it
// rebuilds and keeps each pair's periodic image until then.
inline double kick_drift(ParticleStore& p, double dt) {
  const double half = 0.5 * dt;
  const std::size_t n = p.size();
  double max_speed2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 dv = p.force_n[i] * (half * p.inv_mass_per_kg[i]);
    const Vec3 v_half = p.velocity_m_per_s[i] + dv;
    max_speed2 = std::max(max_speed2, norm2(v_half));
    p.position_m[i] += v_half * dt;
    p.velocity_m_per_s[i] = v_half + dv;
    p.angular_velocity_rad_per_s[i] += p.torque_n_m[i] * (dt * p.inv_inertia_per_kg_m2[i]);
  }
  return std::sqrt(max_speed2);
}

inline void kick(ParticleStore& p, double dt) {
  const double half = 0.5 * dt;
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    p.velocity_m_per_s[i] += (p.force_n[i] - p.previous_force_n[i]) * (half * p.inv_mass_per_kg[i]);
    p.angular_velocity_rad_per_s[i] +=
        (p.torque_n_m[i] - p.previous_torque_n_m[i]) * (half * p.inv_inertia_per_kg_m2[i]);
  }
}

// kick of one step and kick_drift of the next in one pass: per particle the same operations in
// the same order, so the same numbers, with the state read once (Simulation::advance). Written
// out rather than calling per-particle helpers shared with kick() and kick_drift(): through the
// store's arrays the compiler then reloads v and ω between the halves, and the pass took 20 %
// longer. tests/engine/determinism_test.cpp holds the two paths to the same bits.
inline double kick_then_kick_drift(ParticleStore& p, double dt) {
  const double half = 0.5 * dt;
  const std::size_t n = p.size();
  double max_speed2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double half_inv_mass = half * p.inv_mass_per_kg[i];
    const Vec3 v_end =
        p.velocity_m_per_s[i] + (p.force_n[i] - p.previous_force_n[i]) * half_inv_mass;
    const Vec3 w_end =
        p.angular_velocity_rad_per_s[i] +
        (p.torque_n_m[i] - p.previous_torque_n_m[i]) * (half * p.inv_inertia_per_kg_m2[i]);
    const Vec3 dv = p.force_n[i] * half_inv_mass;
    const Vec3 v_half = v_end + dv;
    max_speed2 = std::max(max_speed2, norm2(v_half));
    p.position_m[i] += v_half * dt;
    p.velocity_m_per_s[i] = v_half + dv;
    p.angular_velocity_rad_per_s[i] = w_end + p.torque_n_m[i] * (dt * p.inv_inertia_per_kg_m2[i]);
  }
  return std::sqrt(max_speed2);
}

// Keeps the current forces as the previous ones, then clears forces and torques and adds
// gravity, m·g.
inline void clear_forces(ParticleStore& p, const Vec3& gravity) {
  std::swap(p.force_n, p.previous_force_n);
  std::swap(p.torque_n_m, p.previous_torque_n_m);
  const std::size_t n = p.size();
  p.force_n.resize(n);
  p.torque_n_m.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.force_n[i] = gravity * p.mass_kg[i];
    p.torque_n_m[i] = {};
  }
}

}  // namespace millsim
