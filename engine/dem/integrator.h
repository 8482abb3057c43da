// Velocity Verlet in kick–drift–kick form for translation and rotation of spheres:
//   kick_drift: v += ½ a dt, ω += ½ α dt, x += v dt   (a, α from the previous step's forces)
//   (forces)
//   kick:       v += ½ a dt, ω += ½ α dt
// Symplectic and second order for conservative forces; velocity-dependent forces see v(n+½).
#pragma once

#include "core/vec3.h"
#include "particles/particle_store.h"

namespace millsim {

inline void kick_drift(ParticleStore& p, double dt) {
  const double half = 0.5 * dt;
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    p.velocity_m_per_s[i] += p.force_n[i] * (half * p.inv_mass_per_kg[i]);
    p.angular_velocity_rad_per_s[i] += p.torque_n_m[i] * (half * p.inv_inertia_per_kg_m2[i]);
    p.position_m[i] += p.velocity_m_per_s[i] * dt;
  }
}

inline void kick(ParticleStore& p, double dt) {
  const double half = 0.5 * dt;
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    p.velocity_m_per_s[i] += p.force_n[i] * (half * p.inv_mass_per_kg[i]);
    p.angular_velocity_rad_per_s[i] += p.torque_n_m[i] * (half * p.inv_inertia_per_kg_m2[i]);
  }
}

// Clears forces and torques and adds gravity, m·g.
inline void clear_forces(ParticleStore& p, const Vec3& gravity) {
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    p.force_n[i] = gravity * p.mass_kg[i];
    p.torque_n_m[i] = {};
  }
}

}  // namespace millsim
