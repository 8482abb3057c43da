#include "dem/time_step.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "contact/curved_contact.h"

namespace millsim {

double rayleigh_time_s(double r, double E, double nu, double rho) {
  const double shear_modulus = E / (2.0 * (1.0 + nu));
  return std::numbers::pi * r * std::sqrt(rho / shear_modulus) / (0.1631 * nu + 0.8766);
}

double hertz_contact_time_s(double m_eff, double k, double v) {
  // t_c = 2 (δ_max / v) ∫₀¹ dx / √(1 − x^{5/2}), δ_max = (5 m* v² / (4 k))^{2/5} (Eq. 12);
  // the integral is Γ(2/5) Γ(1/2) / (5/2 Γ(9/10)) = 1.4716.
  const double integral = std::tgamma(0.4) * std::tgamma(0.5) / (2.5 * std::tgamma(0.9));
  const double max_overlap = std::pow(5.0 * m_eff * v * v / (4.0 * k), 0.4);
  return 2.0 * integral * max_overlap / v;
}

WallStiffness stiffest_wall_stiffness(const MaterialTable& materials,
                                      const std::vector<Wall>& walls) {
  WallStiffness w;
  const int stiffest = stiffest_wall(materials, walls);
  if (stiffest >= 0)
    w.compliance =
        materials.wall_pair(walls[std::size_t(stiffest)].pair_table, 0).wall_normal_compliance;
  // A concave wall holds a sphere in a stiffer elliptic contact (contact/curved_contact.h): the
  // most concave one, at the stiffest wall's compliance, bounds them all.
  for (const Wall& wall : walls)
    if (wall.surface.kind == SurfaceKind::CylinderInside || wall.surface.kind == SurfaceKind::Tube)
      w.most_concave_per_m = std::min(w.most_concave_per_m, -1.0 / wall.surface.radius_m);
  return w;
}

ParticleStepTimes particle_step_times(const ParticleStore& p, std::size_t i,
                                      const MaterialTable& materials, const WallStiffness& wall,
                                      double speed, bool at_real_stiffness) {
  const MaterialConstants& m = materials.material(p.material[i]);
  const double r = p.radius_m[i];
  ParticleStepTimes t;
  const double s = at_real_stiffness ? 1.0 : m.normal_compliance / p.normal_compliance[i];
  t.rayleigh_s = rayleigh_time_s(r, s * m.youngs_modulus_pa, m.poisson_ratio, m.density_kg_per_m3);
  const double compliance = at_real_stiffness ? m.normal_compliance : p.normal_compliance[i];
  // Against an equal particle: E* = 1/(2c), R* = r/2, m* = m/2.
  const double k_pair = 4.0 / 3.0 / (2.0 * compliance) * std::sqrt(0.5 * r);
  t.pair_contact_s = hertz_contact_time_s(0.5 * p.mass_kg[i], k_pair, speed);
  if (wall.compliance >= 0.0) {
    const double k_wall = 4.0 / 3.0 / (compliance + wall.compliance) *
                          std::sqrt(equivalent_contact_radius_m(r, wall.most_concave_per_m));
    t.wall_contact_s = hertz_contact_time_s(p.mass_kg[i], k_wall, speed);
  }
  return t;
}

TimeStepBounds time_step_bounds(const ParticleStore& p, const MaterialTable& materials,
                                const std::vector<Wall>& walls, double speed,
                                bool at_real_stiffness) {
  TimeStepBounds b;
  const WallStiffness wall = stiffest_wall_stiffness(materials, walls);
  for (std::size_t i = 0; i < p.size(); ++i) {
    b.smallest_diameter_m = std::min(b.smallest_diameter_m, 2.0 * p.radius_m[i]);
    const ParticleStepTimes t =
        particle_step_times(p, i, materials, wall, speed, at_real_stiffness);
    if (t.rayleigh_s < b.rayleigh_s) b.rayleigh_s = t.rayleigh_s, b.rayleigh_particle = p.id[i];
    if (t.pair_contact_s < b.contact_s)
      b.contact_s = t.pair_contact_s, b.contact_particle = p.id[i], b.contact_with_wall = false;
    if (t.wall_contact_s < b.contact_s)
      b.contact_s = t.wall_contact_s, b.contact_particle = p.id[i], b.contact_with_wall = true;
  }
  return b;
}

double default_max_impact_speed_m_per_s(double fastest, const Vec3& gravity,
                                        const PeriodicBox& box) {
  const double g = norm(gravity);
  double fall = 0.0;
  if (g > 0.0) {
    double extent = 0.0;  // the box's extent along gravity
    for (int a = 0; a < 3; ++a) extent += std::abs(gravity[a] / g) * box.length(a);
    fall = std::sqrt(2.0 * g * extent);
  }
  return std::max(1.0, 2.0 * fastest + fall);
}

}  // namespace millsim
