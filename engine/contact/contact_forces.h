// Contact forces for one step: loops over the neighbour list's candidates, skips those not
// touching (and forgets their tangential history), and adds Hertz–Mindlin normal, tangential
// (Coulomb-limited spring with history) and optional rolling-resistance forces and torques to
// both partners. No virtual call and no model branch per contact: the law is a template.
#pragma once

#include <cstdint>
#include <vector>

#include "contact/walls.h"
#include "dem/box.h"
#include "particles/particle_store.h"
#include "scene/scene_config.h"
#include "search/neighbor_list.h"

namespace millsim {

struct ContactStepStats {
  std::uint64_t touching_pairs = 0;
  std::uint64_t touching_walls = 0;
  double max_overlap_ratio = 0.0;          // δ / d of the smaller partner
  std::uint64_t max_overlap_particle = 0;  // id
};

void compute_pair_forces(ContactModel model, const MaterialTable& materials, const PeriodicBox& box,
                         double dt_s, ParticleStore& particles, NeighborList& neighbors,
                         ContactStepStats& stats);

void compute_wall_forces(const MaterialTable& materials, const std::vector<PlaneWall>& walls,
                         double dt_s, ParticleStore& particles, NeighborList& neighbors,
                         ContactStepStats& stats);

// Elastic energy stored in the touching contacts: Σ (2/5) kn δ^{5/2} + ½ kt δ^{1/2} |ξ|².
double contact_elastic_energy_j(ContactModel model, const MaterialTable& materials,
                                const PeriodicBox& box, const std::vector<PlaneWall>& walls,
                                const ParticleStore& particles, const NeighborList& neighbors);

}  // namespace millsim
