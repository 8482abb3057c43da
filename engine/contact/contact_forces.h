// Contact forces for one step: loops over the neighbour list's candidates, skips those not
// touching (and forgets their tangential history), and adds Hertz–Mindlin normal, tangential
// (Coulomb-limited spring with history) and optional rolling-resistance forces and torques to
// both partners. No virtual call and no model branch per contact: the law is a template.
// Contacts past the penetration limit are listed for the limiter (contact/penetration_limit.h).
#pragma once

#include <cstdint>
#include <vector>

#include "contact/walls.h"
#include "dem/box.h"
#include "particles/particle_store.h"
#include "scene/scene_config.h"
#include "search/neighbor_list.h"

namespace millsim {

// The onset of a contact (first force pass in which it touches), approaching at normal speed
// `speed_m_per_s` > 0, with the tangential relative speed of the contact points then: the input
// of the breakage module (comminution/breakage.h) and of the impact spectrum
// (process/impact_spectrum.h).
struct Impact {
  std::uint32_t particle;  // slot
  std::uint32_t partner;   // slot of the other particle, or the wall index
  bool with_wall;
  double speed_m_per_s;
  double tangential_speed_m_per_s = 0.0;
};

struct ContactStepStats {
  std::uint64_t touching_pairs = 0;
  std::uint64_t touching_walls = 0;
  double max_overlap_ratio = 0.0;          // δ / d of the smaller partner
  std::uint64_t max_overlap_particle = 0;  // id of the smaller partner
  std::uint64_t max_overlap_partner = 0;   // id of the other particle; 0 for a wall
  int max_overlap_wall = -1;               // wall index when the partner is a wall
  // Contacts past the penetration limit (indices into the neighbour list), for Eq. 8.
  std::vector<std::uint32_t> pairs_over_limit;
  std::vector<std::uint32_t> walls_over_limit;
  // Contact onsets of this pass, recorded only when record_impacts is set (breakage scenes, the
  // impact spectrum).
  bool record_impacts = false;
  std::vector<Impact> impacts;

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, touching_pairs, touching_walls, max_overlap_ratio, max_overlap_particle,
           max_overlap_partner, max_overlap_wall, pairs_over_limit, walls_over_limit,
           record_impacts, impacts);
  }

  void reset() {
    impacts.clear();
    max_overlap_ratio = 0.0;
    max_overlap_particle = max_overlap_partner = 0;
    max_overlap_wall = -1;
    pairs_over_limit.clear();
    walls_over_limit.clear();
  }
};

// `penetration_limit`: overlap / smaller diameter past which a contact is listed for Eq. 8.
void compute_pair_forces(ContactModel model, const MaterialTable& materials, const PeriodicBox& box,
                         double dt_s, double penetration_limit, ParticleStore& particles,
                         NeighborList& neighbors, ContactStepStats& stats);

// The wall candidates of `ranges` only, when given (multi-rate's wall riders step on their own).
void compute_wall_forces(const MaterialTable& materials, const std::vector<Wall>& walls,
                         double dt_s, double penetration_limit, ParticleStore& particles,
                         NeighborList& neighbors, ContactStepStats& stats,
                         const std::vector<NeighborList::PairRange>* ranges = nullptr);

// Elastic energy stored in the touching contacts: Σ (2/5) kn δ^{5/2} + ½ kt δ^{1/2} |ξ|².
double contact_elastic_energy_j(ContactModel model, const MaterialTable& materials,
                                const PeriodicBox& box, const std::vector<Wall>& walls,
                                const ParticleStore& particles, const NeighborList& neighbors);

}  // namespace millsim
