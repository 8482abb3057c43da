// Fragment spawning (after Brosh, Kalman & Levy 2011): where the fragments of a broken particle
// start and how they move.
//   Placement: largest first, each centre drawn uniformly in the ball of radius R − r_k, so each
//   fragment lies inside the parent; of `attempts` draws the one overlapping the already placed
//   fragments least is kept. Then all move together so their centre of mass is the parent's
//   (fragments cannot pack into the parent's volume, so overlaps between siblings remain).
//   Motion: the parent's rigid-body field, v_k = v + ω × (x_k − x_c), ω_k = ω. With the centre of
//   mass kept this conserves momentum exactly.
//   Sibling overlaps: siblings that overlap at birth remember that overlap; only overlap beyond
//   it pushes back, and the memory follows the overlap down as they separate (the neighbour list
//   marks them, search/neighbor_list.h, kPairGhost). The birth overlap thus stores no energy and
//   cannot explode, yet siblings do not pass through each other (nor squeeze a third particle).
//   Contacts a fragment has at birth with other particles or walls are not new impacts (no
//   breakage cascade within one impact).
#pragma once

#include <vector>

#include "core/rng.h"
#include "core/vec3.h"

namespace millsim {

// Offsets of the fragment centres from the parent's centre; `diameters_m` largest first. The
// mass-weighted mean offset is zero (equal densities: weights d³).
std::vector<Vec3> place_fragments(const std::vector<double>& diameters_m, double parent_diameter_m,
                                  int attempts, Rng& rng);

}  // namespace millsim
