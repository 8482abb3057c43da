#include "particles/materials.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "particles/restitution.h"

namespace millsim {

double damping_ratio(DampingModel model, double e) {
  e = std::max(e, kLowestDampedRestitution);  // below it: restitution.h
  if (model == DampingModel::Restitution) return damping_ratio_for_restitution(e);
  const double log_e = std::log(e);
  const double pi = std::numbers::pi;
  return 2.0 * (-log_e) / std::sqrt(pi * pi + log_e * log_e);
}

ParticleSprings particle_springs(const MaterialConstants& m, double r, double stiffness_scale) {
  const double E = stiffness_scale * m.youngs_modulus_pa, nu = m.poisson_ratio;
  return {2.0 * std::sqrt(2.0 * r) * E / (3.0 * (1.0 - nu * nu)),
          std::sqrt(2.0 * r) * E / (2.0 * (2.0 - nu) * (1.0 + nu))};
}

PairConstants pair_constants(DampingModel model, double restitution, double friction,
                             double rolling_friction) {
  PairConstants p;
  p.restitution = restitution;
  p.damping_ratio = damping_ratio(model, restitution);
  p.separation_scale = separation_scale(restitution);
  p.friction = friction;
  p.rolling_friction = rolling_friction;
  return p;
}

MaterialTable::MaterialTable(const SceneConfig& scene) : damping_model_(scene.contact.damping) {
  for (const MaterialConfig& c : scene.materials) {
    const double E = c.youngs_modulus_pa, nu = c.poisson_ratio, G = E / (2.0 * (1.0 + nu));
    materials_.push_back({E, nu, c.density_kg_per_m3, c.restitution, c.friction, c.rolling_friction,
                          damping_ratio(damping_model_, c.restitution), (1.0 - nu * nu) / E,
                          (2.0 - nu) / G, c.frozen});
  }
  const int n = count();
  pairs_.resize(std::size_t(n) * n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const MaterialConstants &ma = materials_[a], &mb = materials_[b];
      pairs_[a * n + b] = pair_constants(damping_model_, 0.5 * (ma.restitution + mb.restitution),
                                         0.5 * (ma.friction + mb.friction),
                                         0.5 * (ma.rolling_friction + mb.rolling_friction));
    }
}

int MaterialTable::add_wall(int wall_material, std::optional<double> restitution,
                            std::optional<double> friction) {
  const int index = wall_count();
  const MaterialConstants& w = materials_[wall_material];
  for (const MaterialConstants& m : materials_) {
    PairConstants p = pair_constants(damping_model_, restitution.value_or(m.restitution),
                                     friction.value_or(m.friction), m.rolling_friction);
    p.wall_normal_compliance = w.normal_compliance;
    p.wall_shear_compliance = w.shear_compliance;
    wall_pairs_.push_back(p);
  }
  return index;
}

}  // namespace millsim
