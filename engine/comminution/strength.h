// Comminution functions of one breakable material (docs/comminution.md cites each source):
//   strength   — each particle draws, at creation, the mass-specific energy it can absorb above
//                the threshold W_min(x) before it breaks (its capacity), size dependent;
//   selection  — the probability that a fresh particle breaks in one impact of energy W; it is
//                the distribution of the drawn capacities, so the two are one model;
//   fatigue    — an impact too weak to break the particle lowers its remaining capacity by
//                factor × (W − W_min) (damage accumulation; with factor 1 the Vogel–Peukert
//                selection 1 − exp(−f_mat x k (W − W_min)) for k equal impacts follows exactly);
//   equivalence — how a particle–particle impact maps onto the wall impact the functions were
//                measured with.
// Pure functions of plain data; the breakage module (comminution/breakage.h) applies them.
#pragma once

#include "scene/scene_config.h"

namespace millsim {

// W_min(x): mass-specific impact energy (J/kg) below which an impact does nothing.
// Vogel–Peukert: (x W_min) / x. Weibull: 0.
double threshold_energy_j_per_kg(const StrengthConfig& s, double diameter_m);

// Capacity for a uniform draw u in (0, 1]: the inverse of the selection function's CDF.
double capacity_from_uniform_j_per_kg(const StrengthConfig& s, double diameter_m, double u);

// The probability that a particle of this size breaks at or before the k-th of k equal impacts
// of specific energy W, with fatigue `factor` (0 = no fatigue; then k does not matter).
double selection_probability(const StrengthConfig& s, double diameter_m, double w_j_per_kg,
                             int impacts = 1, double fatigue_factor = 0.0);

// One impact on a particle: breaks when its excess energy W − W_min reaches the remaining
// capacity; otherwise fatigue lowers the capacity. Returns true when the particle breaks.
bool apply_impact(const MaterialBreakageConfig& b, double diameter_m, double w_j_per_kg,
                  double& remaining_capacity_j_per_kg);

// Equivalent wall-impact speed of particle i (mass, radius, normal compliance (1−ν²)/E at real
// stiffness) in a particle–particle impact at normal relative speed v.
//   energy: v m_j / (m_i + m_j), i's speed in the centre-of-mass frame (for equal spheres,
//           each hits the symmetry plane at v/2);
//   force:  the rigid-wall speed with the same peak Hertz force,
//           u² = v² (m*/m_i) (c_i/(c_i + c_j))^{2/3} (R*/R_i)^{1/3}. For equal spheres both
//           give v/2 (the symmetry plane is a rigid wall); they differ for unlike partners.
double equivalent_speed_pair(ImpactEquivalence model, double mass_i_kg, double radius_i_m,
                             double compliance_i, double mass_j_kg, double radius_j_m,
                             double compliance_j, double speed_m_per_s);

// The same for a particle–wall impact: energy u = v; force u² = v² (c_i/(c_i + c_wall))^{2/3}.
double equivalent_speed_wall(ImpactEquivalence model, double compliance_i, double compliance_wall,
                             double speed_m_per_s);

}  // namespace millsim
