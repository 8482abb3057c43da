// ParticleStore: the DEM state of every live particle, one array per field (slot = index).
// Per-particle spring and damper constants (§3.2, Eq. 2–3) are set once, in add(), from the
// MaterialTable, never per contact. Slots are not stable (removal swaps in the last particle);
// `id` is, and is the name used in every message.
#pragma once

#include <cstdint>
#include <numbers>
#include <vector>

#include "checkpoint/archive.h"
#include "core/vec3.h"
#include "particles/materials.h"

namespace millsim {

using ParticleId = std::uint64_t;

// Mass of a sphere, the one formula every module uses (so masses add up to rounding).
inline double sphere_mass_kg(double density_kg_per_m3, double diameter_m) {
  const double r = 0.5 * diameter_m;
  return density_kg_per_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

// Velocity and angular velocity of one particle, and force and torque on it: a contact reads the
// first and adds to the second for both partners, and these are its scattered accesses, so each
// pair of vectors is one 48-byte record (1.5 cache lines on average instead of 2).
struct Motion {
  Vec3 velocity_m_per_s;
  Vec3 angular_velocity_rad_per_s;
};
struct Load {
  Vec3 force_n;
  Vec3 torque_n_m;
};
static_assert(sizeof(Motion) == 2 * sizeof(Vec3) && sizeof(Load) == 2 * sizeof(Vec3));

// The DEM cell of the gas coupling's fluid table a particle read last (gas/coupling.h): its key
// and where its state was, valid while the table's generation is unchanged. Only a hint: a stale
// one costs a hash lookup, never a wrong state.
struct FluidCellRef {
  std::uint64_t key = 0;  // 0: none
  std::uint32_t state = 0;
  std::uint32_t generation = 0;
};

struct ParticleStore {
  // hot: read or written every step
  std::vector<Vec3> position_m;
  std::vector<Motion> motion;
  std::vector<Load> load;
  std::vector<Load> previous_load;  // forces and torques of the previous step (dem/integrator.h)
  std::vector<double> radius_m;
  std::vector<double> inv_mass_per_kg;
  std::vector<double> inv_inertia_per_kg_m2;
  // k_np, η_np, k_tp/δ^½, η_tp/δ^¼ (Eq. 2–3, materials.h) in one record: a contact reads all four
  // of both partners, so each costs one cache line, not four.
  std::vector<ParticleSprings> springs;
  std::vector<double> normal_compliance;  // (1−ν²)/(s·E), 1/Pa; s = reduced-stiffness scale
  std::vector<double> shear_compliance;   // (2−ν)/(s·G), 1/Pa
  std::vector<std::uint16_t> material;
  // cold
  std::vector<double> mass_kg;
  std::vector<ParticleId> id;
  // breakage only (comminution/strength.h): mass-specific energy above W_min the particle can
  // still absorb before it breaks. Empty, and not a column, unless enable_breakage_state().
  std::vector<double> remaining_capacity_j_per_kg;
  // How many breakages made the particle: 0 for fed or initial particles, a fragment's parent's
  // generation + 1 (breakage only, like the capacity).
  std::vector<std::uint8_t> generation;
  bool has_breakage_state = false;
  // gas coupling only (gas/coupling.h): the drag cache of §3.1 (Fig. 5) and the impulse the
  // particle took from the gas since the last CFD step (given back to the gas then). Empty, and
  // not columns, unless enable_fluid_state().
  std::vector<double> fluid_coefficient_kg_per_s;  // cached β: drag = β (u − v)
  std::vector<double> fluid_coefficient_slope;     // dβ/d|u − v|² there, kg s/m² (coupling.h)
  std::vector<Vec3> fluid_cached_slip_m_per_s;     // u − v when β (and the lift) were computed
  std::vector<double> fluid_cached_fraction;       // the gas volume fraction ε then
  std::vector<Vec3> fluid_cached_force_n;          // cached drag + lift (force store) or lift
  std::vector<Vec3> fluid_impulse_n_s;             // ∫ (drag + lift) dt since the last CFD step
  std::vector<FluidCellRef> fluid_cell;            // the DEM cell last read (a lookup hint)
  bool has_fluid_state = false;
  // multi-rate stepping only (sim/multi_rate.h): 1 while the particle is in free flight, with no
  // candidate in the neighbour list, and so advanced on a long step of its own. Empty, and not a
  // column, unless enable_multi_rate_state().
  std::vector<std::uint8_t> free_flight;
  // With the gas state too: the fluid force a particle that steps with the contacts keeps between
  // two evaluations (sim/multi_rate.h), all of it and the part exchanged with the gas. Two
  // columns: the step reads the first, the second only when the kept exchange is booked.
  std::vector<Vec3> fluid_held_force_n;
  std::vector<Vec3> fluid_held_exchange_n;
  bool has_multi_rate_state = false;

  // Bumped by every add and removal, so caches (the neighbour list) see a changed population.
  std::uint64_t population_version = 0;

  std::size_t size() const { return id.size(); }
  void reserve(std::size_t n);

  // Calls f(column) for every per-particle array: the one list of columns that reserve, removal
  // and reordering share (a new field is added here, or it falls out of step).
  template <class F>
  void for_each_column(F&& f) {
    f(position_m), f(motion), f(load), f(previous_load);
    f(radius_m), f(inv_mass_per_kg), f(inv_inertia_per_kg_m2);
    f(springs);
    f(normal_compliance), f(shear_compliance);
    f(material), f(mass_kg), f(id);
    if (has_breakage_state) f(remaining_capacity_j_per_kg), f(generation);
    if (has_fluid_state) {
      f(fluid_coefficient_kg_per_s), f(fluid_coefficient_slope), f(fluid_cached_slip_m_per_s);
      f(fluid_cached_fraction);
      f(fluid_cached_force_n);
      f(fluid_impulse_n_s);
      f(fluid_cell);
    }
    if (has_multi_rate_state) f(free_flight);
    if (has_multi_rate_state && has_fluid_state) f(fluid_held_force_n), f(fluid_held_exchange_n);
  }

  // Checkpoints (checkpoint/archive.h): the flags first, so the columns they add are read back.
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, has_breakage_state, has_fluid_state, has_multi_rate_state, population_version);
    for_each_column([&](auto& column) { io(a, column); });
  }

  // Adds the breakage column (infinite capacity until the breakage module draws one).
  void enable_breakage_state() {
    has_breakage_state = true;
    remaining_capacity_j_per_kg.assign(size(), 1e300);
    generation.assign(size(), 0);
  }

  // Adds the gas-coupling columns; every particle starts with no cached drag.
  void enable_fluid_state() {
    has_fluid_state = true;
    fluid_coefficient_kg_per_s.assign(size(), -1.0);  // < 0: nothing cached
    fluid_coefficient_slope.assign(size(), 0.0);
    fluid_cached_slip_m_per_s.assign(size(), {});
    fluid_cached_fraction.assign(size(), 1.0);
    fluid_cached_force_n.assign(size(), {});
    fluid_impulse_n_s.assign(size(), {});
    fluid_cell.assign(size(), {});
  }

  // Adds the multi-rate columns (after enable_fluid_state(), if any); every particle starts
  // stepping with the rest.
  void enable_multi_rate_state() {
    has_multi_rate_state = true;
    free_flight.assign(size(), 0);
    if (has_fluid_state)
      fluid_held_force_n.assign(size(), {}), fluid_held_exchange_n.assign(size(), {});
  }

  // Appends a particle and computes its contact constants; `stiffness_scale` multiplies its
  // Young's modulus (reduced stiffness, §4 Eq. 6–7). Returns its slot.
  std::size_t add(const MaterialTable& materials, int material_index, ParticleId particle_id,
                  const Vec3& position, const Vec3& velocity, const Vec3& angular_velocity,
                  double diameter_m, double stiffness_scale = 1.0);

  // Removes the particle in `slot` by moving the last one into it.
  void remove_swap(std::size_t slot);

  // Reorders every column: new slot k holds the particle that was in slot order[k]. Used to keep
  // particles that are close in space close in memory. `scratch` is a work buffer (its contents
  // are overwritten), so that repeated reorders do not allocate; it never grows past one Vec3 per
  // particle, as wider records are moved in slices of at most that size.
  void permute(const std::vector<std::uint32_t>& order, std::vector<Vec3>& scratch);
};

}  // namespace millsim
