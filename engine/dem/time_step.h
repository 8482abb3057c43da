// Time-step bounds (§4, Eq. 4–5). Two limits, both from the smallest, stiffest contacts:
//   the Rayleigh time t_R = π r √(ρ/G) / (0.1631 ν + 0.8766) (the customary DEM bound, ∝ d);
//   the Hertz contact time at the expected impact speed V, t_c = 2.943 (m*/k)^{2/5} V^{-1/5}
//   (from Eq. 12 and the Hertz force law; ∝ d at fixed V), against the stiffest wall and
//   against an equal particle. A step must resolve each contact in several steps.
// A third limit, the penetration limiter's (§4, Eq. 8), which acts once per step: a contact
// closing at V must not travel more than `penetration_limit` of the smaller partner's diameter
// in one step, or it can pass from below the limit to beyond twice it (where the run's guard
// stops) before the limiter sees it. It binds only for contacts so soft that their Hertz
// overlap at V would exceed about a diameter (dt ≤ limit·d/V against t_c/20 ≈ 0.147 δ_max/V).
// Reduced stiffness enters through each particle's compliance (scale s lowers E and G by s).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "contact/walls.h"
#include "dem/box.h"
#include "particles/materials.h"
#include "particles/particle_store.h"

namespace millsim {

double rayleigh_time_s(double radius_m, double youngs_modulus_pa, double poisson_ratio,
                       double density_kg_per_m3);

// Hertz contact duration of a head-on impact at `speed` with stiffness k and reduced mass m*.
double hertz_contact_time_s(double reduced_mass_kg, double stiffness, double speed_m_per_s);

// The fewest steps a contact may take: a fixed step above t_c / this is rejected. Fewer steps
// lose accuracy fast: the damping term δ^{1/4} has an infinite slope at contact onset, so the
// error of the maximum overlap falls only as dt^{1.25} (0.73 % at 40 steps per contact for
// e = 0.41, 0.31 % at 80).
inline constexpr double kMinStepsPerContact = 8.0;

struct TimeStepBounds {
  double rayleigh_s = 1e300;  // smallest Rayleigh time
  std::uint64_t rayleigh_particle = 0;
  double contact_s = 1e300;  // shortest Hertz contact time at the impact speed
  std::uint64_t contact_particle = 0;
  bool contact_with_wall = false;
  double smallest_diameter_m = 1e300;  // the travel bound's d
};

// The stiffest wall's normal compliance (−1: no wall) and the most concave wall's curvature
// (≤ 0), which together bound every wall contact's stiffness.
struct WallStiffness {
  double compliance = -1.0;
  double most_concave_per_m = 0.0;
};
WallStiffness stiffest_wall_stiffness(const MaterialTable& materials,
                                      const std::vector<Wall>& walls);

// One particle's own time scales: its Rayleigh time and its Hertz contact times at `speed`
// against an equal particle and against the stiffest, most concave wall (1e300 without walls).
struct ParticleStepTimes {
  double rayleigh_s = 1e300;
  double pair_contact_s = 1e300;
  double wall_contact_s = 1e300;
};
ParticleStepTimes particle_step_times(const ParticleStore& p, std::size_t i,
                                      const MaterialTable& materials, const WallStiffness& wall,
                                      double speed, bool at_real_stiffness = false);

// Bounds over all particles. Each particle's reduced-stiffness scale is read from its compliance
// (s = c_material / c_particle); `at_real_stiffness` ignores it, for the time-step gain.
TimeStepBounds time_step_bounds(const ParticleStore& p, const MaterialTable& materials,
                                const std::vector<Wall>& walls, double impact_speed_m_per_s,
                                bool at_real_stiffness = false);

// The automatic step's contact bounds for one size: min(safety × t_R, t_c / steps per contact,
// the penetration travel bound).
inline double contact_step_bound_s(double rayleigh_s, double contact_s, double travel_s,
                                   double safety_factor, double steps_per_contact) {
  const double step = std::min(safety_factor * rayleigh_s, contact_s / steps_per_contact);
  return std::min(step, travel_s);
}

// The penetration limiter's bound: limit · d_min / V (above).
inline double penetration_travel_bound_s(const TimeStepBounds& b, double penetration_limit,
                                         double impact_speed_m_per_s) {
  return penetration_limit * b.smallest_diameter_m / impact_speed_m_per_s;
}

// Twice the fastest initial speed (a head-on pair) plus the free-fall speed over the domain's
// extent along gravity; at least 1 m/s.
double default_max_impact_speed_m_per_s(double fastest_speed_m_per_s, const Vec3& gravity,
                                        const PeriodicBox& box);

}  // namespace millsim
