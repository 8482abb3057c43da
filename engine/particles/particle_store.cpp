#include "particles/particle_store.h"

#include <algorithm>
#include <cstring>
#include <type_traits>

namespace millsim {
namespace {

// Permutes an array of kSize-byte elements in slices of at most one Vec3, starting at byte
// kOffset of each element: the slice of every element is gathered into `gathered` (room for one
// Vec3 per element), then written back in place.
template <std::size_t kSize, std::size_t kOffset = 0>
void permute_slices(unsigned char* bytes, const std::vector<std::uint32_t>& order,
                    unsigned char* gathered) {
  constexpr std::size_t kWidth = std::min(sizeof(Vec3), kSize - kOffset);
  const std::size_t n = order.size();
  for (std::size_t k = 0; k < n; ++k)
    std::memcpy(gathered + k * kWidth, bytes + order[k] * kSize + kOffset, kWidth);
  if constexpr (kWidth == kSize) {
    if (n) std::memcpy(bytes, gathered, n * kSize);
  } else {
    for (std::size_t k = 0; k < n; ++k)
      std::memcpy(bytes + k * kSize + kOffset, gathered + k * kWidth, kWidth);
  }
  if constexpr (kOffset + kWidth < kSize)
    permute_slices<kSize, kOffset + kWidth>(bytes, order, gathered);
}

}  // namespace

void ParticleStore::reserve(std::size_t n) {
  for_each_column([n](auto& column) { column.reserve(n); });
}

std::size_t ParticleStore::add(const MaterialTable& materials, int material_index,
                               ParticleId particle_id, const Vec3& position, const Vec3& velocity,
                               const Vec3& angular_velocity, double diameter_m,
                               double stiffness_scale) {
  const MaterialConstants& m = materials.material(material_index);
  const double r = 0.5 * diameter_m;
  const double mass = sphere_mass_kg(m.density_kg_per_m3, diameter_m);

  position_m.push_back(position);
  // A frozen particle has no inverse mass or inertia: forces, gravity and impulses leave it where
  // it is, at rest, while its contacts and drag act on its partners and the gas.
  motion.push_back(m.frozen ? Motion{} : Motion{velocity, angular_velocity});
  load.push_back({});
  previous_load.push_back({});
  radius_m.push_back(r);
  inv_mass_per_kg.push_back(m.frozen ? 0.0 : 1.0 / mass);
  inv_inertia_per_kg_m2.push_back(m.frozen ? 0.0 : 1.0 / (0.4 * mass * r * r));
  springs.push_back(particle_springs(m, r, stiffness_scale));
  normal_compliance.push_back(m.normal_compliance / stiffness_scale);
  shear_compliance.push_back(m.shear_compliance / stiffness_scale);
  material.push_back(std::uint16_t(material_index));
  mass_kg.push_back(mass);
  id.push_back(particle_id);
  if (has_breakage_state) remaining_capacity_j_per_kg.push_back(1e300), generation.push_back(0);
  if (has_fluid_state) {
    fluid_coefficient_kg_per_s.push_back(-1.0);
    fluid_coefficient_slope.push_back(0.0);
    fluid_cached_slip_m_per_s.push_back({});
    fluid_cached_fraction.push_back(1.0);
    fluid_cached_force_n.push_back({});
    fluid_impulse_n_s.push_back({});
    fluid_cell.push_back({});
  }
  if (has_multi_rate_state) free_flight.push_back(0);  // complete now: it steps until a rebuild
  if (has_multi_rate_state && has_fluid_state)
    fluid_held_force_n.push_back({}), fluid_held_exchange_n.push_back({});
  ++population_version;
  return id.size() - 1;
}

void ParticleStore::remove_swap(std::size_t slot) {
  const std::size_t last = size() - 1;
  for_each_column([slot, last](auto& column) {
    column[slot] = column[last];
    column.pop_back();
  });
  ++population_version;
}

void ParticleStore::permute(const std::vector<std::uint32_t>& order, std::vector<Vec3>& scratch) {
  for_each_column([&order, &scratch](auto& column) {
    using T = typename std::remove_reference_t<decltype(column)>::value_type;
    static_assert(std::is_trivially_copyable_v<T>);
    scratch.resize(std::max(scratch.size(), order.size()));
    permute_slices<sizeof(T)>(reinterpret_cast<unsigned char*>(column.data()), order,
                              reinterpret_cast<unsigned char*>(scratch.data()));
  });
  ++population_version;
}

}  // namespace millsim
