#include "particles/particle_store.h"

#include <numbers>

namespace millsim {

void ParticleStore::reserve(std::size_t n) {
  position_m.reserve(n), velocity_m_per_s.reserve(n), force_n.reserve(n);
  angular_velocity_rad_per_s.reserve(n), torque_n_m.reserve(n);
  previous_force_n.reserve(n), previous_torque_n_m.reserve(n);
  radius_m.reserve(n), inv_mass_per_kg.reserve(n), inv_inertia_per_kg_m2.reserve(n);
  normal_stiffness.reserve(n), normal_damping.reserve(n);
  tangential_stiffness.reserve(n), tangential_damping.reserve(n);
  normal_compliance.reserve(n), shear_compliance.reserve(n);
  material.reserve(n), mass_kg.reserve(n), id.reserve(n);
}

std::size_t ParticleStore::add(const MaterialTable& materials, int material_index,
                               ParticleId particle_id, const Vec3& position, const Vec3& velocity,
                               const Vec3& angular_velocity, double diameter_m,
                               double stiffness_scale) {
  const MaterialConstants& m = materials.material(material_index);
  const double r = 0.5 * diameter_m;
  const double mass = m.density_kg_per_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
  const ParticleSprings springs = particle_springs(m, r, mass, stiffness_scale);

  position_m.push_back(position);
  velocity_m_per_s.push_back(velocity);
  force_n.push_back({});
  angular_velocity_rad_per_s.push_back(angular_velocity);
  torque_n_m.push_back({});
  previous_force_n.push_back({});
  previous_torque_n_m.push_back({});
  radius_m.push_back(r);
  inv_mass_per_kg.push_back(1.0 / mass);
  inv_inertia_per_kg_m2.push_back(1.0 / (0.4 * mass * r * r));
  normal_stiffness.push_back(springs.normal_stiffness);
  normal_damping.push_back(springs.normal_damping);
  tangential_stiffness.push_back(springs.tangential_stiffness);
  tangential_damping.push_back(springs.tangential_damping);
  normal_compliance.push_back(m.normal_compliance / stiffness_scale);
  shear_compliance.push_back(m.shear_compliance / stiffness_scale);
  material.push_back(std::uint16_t(material_index));
  mass_kg.push_back(mass);
  id.push_back(particle_id);
  ++population_version;
  return id.size() - 1;
}

void ParticleStore::remove_swap(std::size_t slot) {
  const std::size_t last = size() - 1;
  auto move_last = [slot, last](auto& column) {
    column[slot] = column[last];
    column.pop_back();
  };
  move_last(position_m), move_last(velocity_m_per_s), move_last(force_n);
  move_last(angular_velocity_rad_per_s), move_last(torque_n_m);
  move_last(previous_force_n), move_last(previous_torque_n_m);
  move_last(radius_m), move_last(inv_mass_per_kg), move_last(inv_inertia_per_kg_m2);
  move_last(normal_stiffness), move_last(normal_damping);
  move_last(tangential_stiffness), move_last(tangential_damping);
  move_last(normal_compliance), move_last(shear_compliance);
  move_last(material), move_last(mass_kg), move_last(id);
  ++population_version;
}

void ParticleStore::permute(const std::vector<std::uint32_t>& order) {
  auto apply = [&order](auto& column) {
    std::remove_reference_t<decltype(column)> sorted(column.size());
    for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = column[order[k]];
    column.swap(sorted);
  };
  apply(position_m), apply(velocity_m_per_s), apply(force_n);
  apply(angular_velocity_rad_per_s), apply(torque_n_m);
  apply(previous_force_n), apply(previous_torque_n_m);
  apply(radius_m), apply(inv_mass_per_kg), apply(inv_inertia_per_kg_m2);
  apply(normal_stiffness), apply(normal_damping);
  apply(tangential_stiffness), apply(tangential_damping);
  apply(normal_compliance), apply(shear_compliance);
  apply(material), apply(mass_kg), apply(id);
  ++population_version;
}

}  // namespace millsim
