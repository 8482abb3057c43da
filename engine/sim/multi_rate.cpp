#include "sim/multi_rate.h"

#include <algorithm>
#include <cmath>

#include "dem/integrator.h"

namespace millsim {

namespace {

void list_slots(const ParticleStore& p, MultiRate& m) {
  m.stepping.clear();
  m.waiting.clear();
  for (std::uint32_t i = 0; i < std::uint32_t(p.size()); ++i)
    (p.free_flight[i] ? m.waiting : m.stepping).push_back(i);
  m.lists_version = p.population_version;
  m.speeds_valid = false;
}

}  // namespace

void mark_free_flight(ParticleStore& p, const NeighborList& neighbors, MultiRate& m) {
  std::fill(p.free_flight.begin(), p.free_flight.end(), std::uint8_t(1));
  for (std::size_t k = 0; k < neighbors.pairs.size(); ++k)
    p.free_flight[neighbors.pairs.first[k]] = p.free_flight[neighbors.pairs.second[k]] = 0;
  for (const std::uint32_t i : neighbors.wall_particle) p.free_flight[i] = 0;
  list_slots(p, m);
  m.marked_rebuilds = neighbors.stats().rebuilds;
}

void relist_if_moved(const ParticleStore& p, MultiRate& m) {
  if (m.lists_version != p.population_version) list_slots(p, m);
}

std::int64_t max_wait_steps(double dt, double relaxation_s) {
  const double steps = std::floor(kMaxWaitPerRelaxationTime * relaxation_s / dt);
  return std::clamp<std::int64_t>(std::int64_t(std::min(steps, 1e9)), 1, kMaxFreeFlightSteps);
}

void bound_waiting_speeds(const ParticleStore& p, double dt, MultiRate& m) {
  const double credit_s = 0.5 * double(m.max_wait_steps) * dt;
  m.waiting_block_speed2.assign((p.size() + kSpeedBlockSlots - 1) / kSpeedBlockSlots, 0.0);
  m.waiting_max_speed2 =
      for_listed_speeds(m.waiting, m.waiting_block_speed2, [&](std::uint32_t i, Vec3&) {
        const double speed = norm(p.motion[i].velocity_m_per_s) +
                             credit_s * norm(p.load[i].force_n) * p.inv_mass_per_kg[i];
        return speed * speed;
      });
  m.speeds_valid = true;
}

Vec3 kick_drift_keeping_fluid(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                              const Vec3& gravity, std::vector<double>& block_max_speed2,
                              double& max_speed2) {
  const double* mass = p.mass_kg.data();
  const HeldFluidForce* held = p.fluid_held.data();
  Vec3* impulse = p.fluid_impulse_n_s.data();
  // The impulse booked for the gas, summed per piece of the list and then in piece order: the
  // same sum on any thread count.
  static thread_local std::vector<Vec3> calling_thread_piece_sums;
  std::vector<Vec3>& booked_per_piece = calling_thread_piece_sums;
  max_speed2 = kick_drift_listed(
      p, slots, dt, block_max_speed2,
      [&](std::uint32_t i, Vec3& booked_here) {
        const Vec3 step_impulse = held[i].exchange_n * dt;
        impulse[i] += step_impulse;
        booked_here += step_impulse;
        return Load{gravity * mass[i] + held[i].force_n, {}};
      },
      &booked_per_piece);
  Vec3 booked;
  for (const Vec3& b : booked_per_piece) booked += b;
  return booked;
}

}  // namespace millsim
