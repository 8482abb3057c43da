// MaterialTable: per-material constants and the per-pair tables derived from them, built once
// per run. Owns the mixing rules for unlike materials (documented in docs/contact-model.md):
// friction, rolling friction and restitution of a pair are the means of the two materials';
// particle–wall values default to the particle's material unless the wall overrides them.
// Elastic constants always combine exactly (E*, G* of Hertz–Mindlin).
#pragma once

#include <vector>

#include "scene/scene_config.h"

namespace millsim {

struct MaterialConstants {
  double youngs_modulus_pa;
  double poisson_ratio;
  double density_kg_per_m3;
  double restitution;
  double friction;
  double rolling_friction;
  double damping_ratio;      // α(e): F_damp = α √(m* k) δ^{1/4} v (restitution.h)
  double normal_compliance;  // (1−ν²)/E, 1/Pa: E* = 1/(c₁ + c₂)
  double shear_compliance;   // (2−ν)/G, 1/Pa: G* = 1/(c₁ + c₂)
  bool frozen;               // particles of it never move (ParticleStore::add)
};

double damping_ratio(DampingModel model, double restitution);

// Per-particle springs of §3.2 (Eq. 2–3, square roots as in DESIGN.md errata). A particle with
// reduced stiffness (§4, Eq. 6–7) has E replaced by stiffness_scale × E. The dampers are the
// pair's, formed per contact from its springs and masses (contact/contact_law.h).
struct alignas(16) ParticleSprings {  // aligned: one record never straddles two cache lines
  double normal_stiffness;            // k_np = 2√(2r)·E / (3(1−ν²))
  double tangential_stiffness;        // k_tp/δ^½ = √(2r)·E / (2(2−ν)(1+ν))
};
ParticleSprings particle_springs(const MaterialConstants& m, double radius_m,
                                 double stiffness_scale = 1.0);

// What a contact between two materials (or a material and a wall) needs beyond the particles.
// Elastic constants come from the partners' compliances (per particle, since reduced stiffness
// makes them size dependent); a wall's own compliances are stored here.
struct PairConstants {
  double damping_ratio;  // α of the pair's restitution
  double restitution;
  // Below e = 0.05, the share of the normal separation speed a contact keeps when it ends
  // (particles/restitution.h); 1 otherwise.
  double separation_scale = 1.0;
  double friction;
  double rolling_friction;
  double wall_normal_compliance = 0.0;  // walls only: (1−ν²)/E of the wall
  double wall_shear_compliance = 0.0;   // walls only: (2−ν)/G of the wall
};

class MaterialTable {
 public:
  MaterialTable() = default;
  explicit MaterialTable(const SceneConfig& scene);
  DampingModel damping_model() const { return damping_model_; }

  int count() const { return int(materials_.size()); }
  const MaterialConstants& material(int m) const { return materials_[m]; }
  const PairConstants& pair(int a, int b) const { return pairs_[a * count() + b]; }
  // Particle of material m against wall w (w indexes the run's wall list).
  const PairConstants& wall_pair(int wall, int m) const { return wall_pairs_[wall * count() + m]; }
  int wall_count() const { return count() ? int(wall_pairs_.size()) / count() : 0; }

  // Adds a wall made of `wall_material`, with optional e/μ overrides; returns its index.
  int add_wall(int wall_material, std::optional<double> restitution,
               std::optional<double> friction);

 private:
  DampingModel damping_model_ = DampingModel::Restitution;
  std::vector<MaterialConstants> materials_;
  std::vector<PairConstants> pairs_;       // count × count
  std::vector<PairConstants> wall_pairs_;  // walls × count
};

PairConstants pair_constants(DampingModel model, double restitution, double friction,
                             double rolling_friction);

}  // namespace millsim
