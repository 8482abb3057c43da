// Filling a continuous mill's hold-up to a target by PSD slot (issue 31): where copies of the
// particles it holds go, so that a run can start from the steady hold-up it projects
// (process/steady_projection.h) instead of filling for the 0.5–1 s of mill time the projection
// says it would take.
//
// A particle slot short of its target gets copies of particles of the same slot, each turned
// about the mill's (vertical) axis by a random angle: its position, velocity and spin turned
// together, so it lies at the same radius and height and moves with the vortex as its source
// does (the chamber is axisymmetric but for its nozzles). A copy is placed only where it
// overlaps no particle (those held and the copies placed before it) and no wall; a source and
// angle that fail are drawn again. Copies are added while the next one brings the slot's mass
// closer to its target, so each slot ends within half a particle's mass of it, unless its
// sources run out of room (kMaxDrawsPerCopy failed draws in a row) or it holds no particle to
// copy: both are reported. Slots are filled coarsest first, as a packing is. The caller
// (Simulation::fill_holdup) adds the copies and books their mass; the dust is scaled in place
// (DustLedger::scale_class).
//
// A slot above its target (with time.fill_removes) loses particles drawn at random from it,
// each removed while that brings the slot's mass closer to its target: the ones it keeps are a
// fair sample of where and how fast it held them. Repeated fills under-relaxed towards each
// new projection (relaxed_target_kg) iterate the hold-up towards the one the mill's own rates
// reproduce.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/rng.h"
#include "core/vec3.h"
#include "particles/particle_store.h"

namespace millsim {

// Failed draws (source and angle) in a row after which a slot is left short of its target.
inline constexpr int kMaxDrawsPerCopy = 200;

struct ParticleCopy {
  std::uint32_t source = 0;  // the slot of the particle copied
  Vec3 position_m, velocity_m_per_s, angular_velocity_rad_per_s;
};

struct CopyPlan {
  std::vector<ParticleCopy> copies;  // in the order placed
  std::vector<double> added_kg;      // per PSD slot
  std::uint64_t rejected_draws = 0;  // draws that overlapped a particle or a wall
  std::vector<int> without_source;   // slots short of their target that hold no particle
  std::vector<int> out_of_room;      // slots left short after kMaxDrawsPerCopy failed draws
};

// `v` turned by `angle_rad` about the z axis.
inline Vec3 turned_about_z(const Vec3& v, double angle_rad) {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  return {c * v.x - s * v.y, s * v.x + c * v.y, v.z};
}

// The copies that bring each PSD slot of `edges_m` (psd_slot: under- and overflow included)
// from what `particles` hold towards `deficit_kg` more (per slot; 0 or less: none), turned about
// the vertical axis through `axis_point_m`. `clear_of_walls(x, r)`: whether a sphere of radius r
// at x lies in the free space (inside the chamber, off every wall, outside every outlet).
CopyPlan plan_copies(const ParticleStore& particles, const std::vector<double>& edges_m,
                     const std::vector<double>& deficit_kg, const Vec3& axis_point_m,
                     const std::function<bool(const Vec3&, double)>& clear_of_walls, Rng& rng);

// The particles (slots of the store, highest first) whose removal brings each PSD slot of
// `edges_m` towards `excess_kg` less (per slot; 0 or less: none), drawn at random from the slot;
// `removed_kg` per PSD slot.
struct RemovalPlan {
  std::vector<std::uint32_t> particles;
  std::vector<double> removed_kg;
};
RemovalPlan plan_removals(const ParticleStore& particles, const std::vector<double>& edges_m,
                          const std::vector<double>& excess_kg, Rng& rng);

// Each compartment's hold-up moved the share `omega` in (0, 1] of the way from `held_kg` to
// `projected_kg`: geometrically, held^(1−ω) projected^ω, where both are positive (a class
// projected at 50 times what it holds moves 7 times at ω = ½, one projected at a fiftieth to a
// seventh), else arithmetically; ω = 1 gives the projection.
std::vector<double> relaxed_target_kg(const std::vector<double>& held_kg,
                                      const std::vector<double>& projected_kg, double omega);

}  // namespace millsim
