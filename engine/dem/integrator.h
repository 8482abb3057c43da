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
#include <cstdint>
#include <utility>
#include <vector>

#include "dem/box.h"

#include "core/vec3.h"
#include "particles/particle_store.h"

namespace millsim {

// Both kick-drift passes also write the next force pass's starting forces (gravity m·g, no
// torque) into previous_load, which begin_force_pass() then swaps in: the pass is already at
// each particle, so clearing costs no pass over memory of its own.

// Slots per block for the speed report of the kick-drift passes.
inline constexpr std::size_t kSpeedBlockSlots = 4096;

// Runs `kick_particle(i)`, which kicks and drifts particle i and returns |v½|², over every slot
// in blocks of kSpeedBlockSlots; stores each block's largest drift speed and returns the largest
// of all.
template <class KickParticle>
double kick_in_blocks(std::size_t n, std::vector<double>& block_max_speed_m_per_s,
                      KickParticle&& kick_particle) {
  block_max_speed_m_per_s.resize((n + kSpeedBlockSlots - 1) / kSpeedBlockSlots);
  double max_speed2 = 0.0;
  for (std::size_t block = 0, begin = 0; begin < n; ++block, begin += kSpeedBlockSlots) {
    const std::size_t end = std::min(n, begin + kSpeedBlockSlots);
    double block_speed2 = 0.0;
    for (std::size_t i = begin; i < end; ++i)
      block_speed2 = std::max(block_speed2, kick_particle(i));
    block_max_speed_m_per_s[block] = std::sqrt(block_speed2);
    max_speed2 = std::max(max_speed2, block_speed2);
  }
  return std::sqrt(max_speed2);
}

// Returns the largest drift speed |v½| of the step, which bounds every particle's displacement,
// and the largest of each block of kSpeedBlockSlots slots in `block_max_speed_m_per_s`, which
// bounds that block's (search/neighbor_list.h). Positions are not wrapped here: the neighbour list
// wraps them when it rebuilds and keeps each pair's periodic image until then.
inline double kick_drift(ParticleStore& p, double dt, const Vec3& gravity,
                         std::vector<double>& block_max_speed_m_per_s) {
  const double half = 0.5 * dt;
  Vec3* x = p.position_m.data();
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  Load* previous_load = p.previous_load.data();
  return kick_in_blocks(p.size(), block_max_speed_m_per_s, [&](std::size_t i) {
    const Motion m = motion[i];
    const Load l = load[i];
    previous_load[i] = {gravity * p.mass_kg[i], {}};
    const Vec3 dv = l.force_n * (half * p.inv_mass_per_kg[i]);
    const Vec3 v_half = m.velocity_m_per_s + dv;
    x[i] += v_half * dt;
    motion[i] = {v_half + dv,
                 m.angular_velocity_rad_per_s + l.torque_n_m * (dt * p.inv_inertia_per_kg_m2[i])};
    return norm2(v_half);
  });
}

inline void kick(ParticleStore& p, double dt) {
  const double half = 0.5 * dt;
  const std::size_t n = p.size();
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  const Load* previous_load = p.previous_load.data();
  for (std::size_t i = 0; i < n; ++i) {
    const Load l = load[i], l_old = previous_load[i];
    motion[i].velocity_m_per_s += (l.force_n - l_old.force_n) * (half * p.inv_mass_per_kg[i]);
    motion[i].angular_velocity_rad_per_s +=
        (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
  }
}

// kick of one step and kick_drift of the next in one pass: per particle the same operations in
// the same order, so the same numbers, with the state read once (Simulation::advance). Written
// out rather than calling per-particle helpers shared with kick() and kick_drift(): through the
// store's arrays the compiler then reloads v and ω between the halves, and the pass took 20 %
// longer. tests/engine/determinism_test.cpp holds the two paths to the same bits.
inline double kick_then_kick_drift(ParticleStore& p, double dt, const Vec3& gravity,
                                   std::vector<double>& block_max_speed_m_per_s) {
  const double half = 0.5 * dt;
  Vec3* x = p.position_m.data();
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  Load* previous_load = p.previous_load.data();
  return kick_in_blocks(p.size(), block_max_speed_m_per_s, [&](std::size_t i) {
    const Motion m = motion[i];
    const Load l = load[i], l_old = previous_load[i];
    previous_load[i] = {gravity * p.mass_kg[i], {}};
    const double half_inv_mass = half * p.inv_mass_per_kg[i];
    const Vec3 v_end = m.velocity_m_per_s + (l.force_n - l_old.force_n) * half_inv_mass;
    const Vec3 w_end = m.angular_velocity_rad_per_s +
                       (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
    const Vec3 dv = l.force_n * half_inv_mass;
    const Vec3 v_half = v_end + dv;
    x[i] += v_half * dt;
    motion[i] = {v_half + dv, w_end + l.torque_n_m * (dt * p.inv_inertia_per_kg_m2[i])};
    return norm2(v_half);
  });
}

// Multi-rate stepping (sim/multi_rate.h) advances a list of slots at a time, each list with its
// own step. Per particle these are the operations of kick_drift() and kick() in the same order,
// so a list that holds every slot gives the same numbers as the single-rate passes. The force
// bookkeeping differs: a listed kick-drift copies the particle's forces to previous_load and
// starts its next forces from gravity itself (no swap of whole arrays), so the particles left
// out keep their forces untouched while they wait.

// Kick-drift of the listed slots by `dt`; returns the largest |v½|² and raises
// block_max_speed2[slot / kSpeedBlockSlots] to each particle's |v½|². Each particle's next force
// pass starts from next_load(i) (gravity, plus what the caller keeps applied).
template <class NextLoad>
double kick_drift_listed(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                         std::vector<double>& block_max_speed2, NextLoad&& next_load) {
  const double half = 0.5 * dt;
  Vec3* x = p.position_m.data();
  Motion* motion = p.motion.data();
  Load* load = p.load.data();
  Load* previous_load = p.previous_load.data();
  double max_speed2 = 0.0;
  for (const std::uint32_t i : slots) {
    const Motion m = motion[i];
    const Load l = load[i];
    previous_load[i] = l;
    load[i] = next_load(i);
    const Vec3 dv = l.force_n * (half * p.inv_mass_per_kg[i]);
    const Vec3 v_half = m.velocity_m_per_s + dv;
    x[i] += v_half * dt;
    motion[i] = {v_half + dv,
                 m.angular_velocity_rad_per_s + l.torque_n_m * (dt * p.inv_inertia_per_kg_m2[i])};
    const double speed2 = norm2(v_half);
    double& block = block_max_speed2[i / kSpeedBlockSlots];
    block = std::max(block, speed2);
    max_speed2 = std::max(max_speed2, speed2);
  }
  return max_speed2;
}

// The same, each next force pass starting from gravity, m·g.
inline double kick_drift_listed(ParticleStore& p, const std::vector<std::uint32_t>& slots,
                                double dt, const Vec3& gravity,
                                std::vector<double>& block_max_speed2) {
  const double* mass = p.mass_kg.data();
  return kick_drift_listed(p, slots, dt, block_max_speed2, [&](std::uint32_t i) {
    return Load{gravity * mass[i], {}};
  });
}

// The closing kick of the listed slots by `dt`.
inline void kick_listed(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt) {
  const double half = 0.5 * dt;
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  const Load* previous_load = p.previous_load.data();
  for (const std::uint32_t i : slots) {
    const Load l = load[i], l_old = previous_load[i];
    motion[i].velocity_m_per_s += (l.force_n - l_old.force_n) * (half * p.inv_mass_per_kg[i]);
    motion[i].angular_velocity_rad_per_s +=
        (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
  }
}

// After a kick-drift pass: keeps the current forces as the previous ones, and starts from the
// forces that pass prepared (gravity only).
inline void begin_force_pass(ParticleStore& p) {
  std::swap(p.load, p.previous_load);
}

// Without a kick-drift pass before it (the first force pass, a refresh): keeps the current forces
// as the previous ones, then clears forces and torques and adds gravity, m·g.
inline void clear_forces(ParticleStore& p, const Vec3& gravity) {
  std::swap(p.load, p.previous_load);
  const std::size_t n = p.size();
  p.load.resize(n);
  for (std::size_t i = 0; i < n; ++i) p.load[i] = {gravity * p.mass_kg[i], {}};
}

}  // namespace millsim
