#include "particles/materials.h"

#include <cmath>

#include "particles/restitution.h"

namespace millsim {

ParticleSprings particle_springs(const MaterialConstants& m, double r, double mass) {
  const double E = m.youngs_modulus_pa, nu = m.poisson_ratio;
  ParticleSprings s;
  s.normal_stiffness = 2.0 * std::sqrt(2.0 * r) * E / (3.0 * (1.0 - nu * nu));
  s.normal_damping = m.damping_ratio * std::sqrt(s.normal_stiffness * mass);
  s.tangential_stiffness = std::sqrt(2.0 * r) * E / (2.0 * (2.0 - nu) * (1.0 + nu));
  s.tangential_damping = 0.5 * m.damping_ratio * std::sqrt(s.tangential_stiffness * mass);
  return s;
}

PairConstants combine_materials(const MaterialConstants& a, const MaterialConstants& b,
                                double restitution, double friction, double rolling_friction) {
  const double ga = a.youngs_modulus_pa / (2.0 * (1.0 + a.poisson_ratio));
  const double gb = b.youngs_modulus_pa / (2.0 * (1.0 + b.poisson_ratio));
  PairConstants p;
  p.effective_modulus_pa = 1.0 / ((1.0 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus_pa +
                                  (1.0 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus_pa);
  p.effective_shear_modulus_pa =
      1.0 / ((2.0 - a.poisson_ratio) / ga + (2.0 - b.poisson_ratio) / gb);
  p.restitution = restitution;
  p.damping_ratio = damping_ratio_for_restitution(restitution);
  p.friction = friction;
  p.rolling_friction = rolling_friction;
  return p;
}

MaterialTable::MaterialTable(const SceneConfig& scene) {
  for (const MaterialConfig& c : scene.materials)
    materials_.push_back({c.youngs_modulus_pa, c.poisson_ratio, c.density_kg_per_m3, c.restitution,
                          c.friction, c.rolling_friction,
                          damping_ratio_for_restitution(c.restitution)});
  const int n = count();
  pairs_.resize(std::size_t(n) * n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const MaterialConstants &ma = materials_[a], &mb = materials_[b];
      pairs_[a * n + b] = combine_materials(ma, mb, 0.5 * (ma.restitution + mb.restitution),
                                            0.5 * (ma.friction + mb.friction),
                                            0.5 * (ma.rolling_friction + mb.rolling_friction));
    }
}

int MaterialTable::add_wall(int wall_material, std::optional<double> restitution,
                            std::optional<double> friction) {
  const int index = wall_count();
  const MaterialConstants& w = materials_[wall_material];
  for (const MaterialConstants& m : materials_)
    wall_pairs_.push_back(combine_materials(m, w, restitution.value_or(m.restitution),
                                            friction.value_or(m.friction), m.rolling_friction));
  return index;
}

}  // namespace millsim
