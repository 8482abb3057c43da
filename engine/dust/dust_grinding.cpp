// Dust ground by sweeping particles (dust/dust_grinding.h).
#include "dust/dust_grinding.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "comminution/strength.h"
#include "parallel/thread_team.h"

namespace millsim {

double impaction_efficiency(double stokes) {
  if (!(stokes > 0.0)) return 0.0;
  const double f = stokes / (stokes + 0.25);
  return f * f;
}

double swept_selection_probability(const StrengthConfig& strength, double diameter_m,
                                   double w0_j_per_kg) {
  const double w_min = threshold_energy_j_per_kg(strength, diameter_m);
  if (!(w0_j_per_kg > w_min)) return 0.0;
  if (strength.model == StrengthModel::VogelPeukert) {
    const double a = strength.f_mat_kg_per_j_m * diameter_m;
    const double u0 = w_min / w0_j_per_kg;
    // ∫_{u0}^{1} (1 − e^{−a (W0 u − W_min)}) du; expm1 keeps it exact for small a W0.
    return (1.0 - u0) + std::expm1(-a * (w0_j_per_kg - w_min)) / (a * w0_j_per_kg);
  }
  // Any other strength: the midpoint rule over u in 64 strips.
  constexpr int kStrips = 64;
  double sum = 0.0;
  for (int s = 0; s < kStrips; ++s)
    sum += selection_probability(strength, diameter_m, w0_j_per_kg * (s + 0.5) / kStrips);
  return sum / kStrips;
}

std::vector<std::vector<double>> dust_fragment_shares(const std::vector<double>& edges_m,
                                                      const std::vector<DustClass>& classes,
                                                      const FragmentSizeSampler& fragments) {
  const std::size_t n = classes.size();
  std::vector<std::vector<double>> shares(n, std::vector<double>(n, 0.0));
  shares[0][0] = 1.0;  // below the first edge: not ground
  for (std::size_t k = 1; k < n; ++k) {
    const double x = classes[k].diameter_m;
    double below = 0.0;  // B at the lower edge of class j
    for (std::size_t j = 0; j < k; ++j) {
      const double upper = std::min(1.0, edges_m[j] / x);  // class j ends at edges[j]
      const double b = fragments.mass_cumulative(upper, x);
      shares[k][j] = std::max(0.0, b - below);
      below = std::max(below, b);
    }
    shares[k][k] = std::max(0.0, 1.0 - below);  // what stays in its own class
  }
  return shares;
}

DustGrinding::DustGrinding(const DustLedger& ledger, const std::vector<double>& edges_m,
                           const MaterialConfig& dust, int dust_material,
                           ImpactEquivalence equivalence)
    : strength_(dust.breakage->strength),
      equivalence_(equivalence),
      dust_material_(dust_material),
      shares_(dust_fragment_shares(edges_m, ledger.classes(),
                                   FragmentSizeSampler(dust.breakage->fragments))) {
  for (const DustClass& c : ledger.classes())
    threshold_j_per_kg_.push_back(threshold_energy_j_per_kg(strength_, c.diameter_m));
  for (const DustClass& c : ledger.classes())
    class_mass_kg_.push_back(dust.density_kg_per_m3 * std::numbers::pi / 6.0 * c.diameter_m *
                             c.diameter_m * c.diameter_m);
  for (std::size_t k = 0; k < shares_.size(); ++k) {
    moved_share_.push_back(k == 0 ? 0.0 : 1.0 - shares_[k][k]);
    std::vector<double> to = shares_[k];
    to[k] = 0.0;
    if (moved_share_[k] > 0.0)
      for (double& x : to) x /= moved_share_[k];
    moved_to_.push_back(std::move(to));
  }
  const std::size_t entries = ledger.classes().size() * ledger.grid().padded_size;
  rate_.assign(entries, 0.0);
  dust_velocity_.resize(entries);
  have_velocity_.assign(entries, 0);
  stats_.ground_kg.assign(ledger.classes().size(), 0.0);
}

void DustGrinding::grind(DustLedger& ledger, const ParticleStore& p, const MaterialTable& materials,
                         double dt_s) {
  if (!(dt_s > 0.0)) return;
  const GasGrid& g = ledger.grid();
  const std::size_t n_classes = ledger.classes().size(), cells = g.padded_size;
  particle_cell_.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t c = ledger.cell_of(p.position_m[i]);
    particle_cell_[i] = g.fluid[c] ? c : cells;
  }
  // Class by class on the engine's threads (class 0 is not ground): each class's rates and
  // touched entries are its own, and each rate sums its particles in slot order, so the result
  // is the same on any thread count.
  touched_by_class_.resize(n_classes);
  if (n_classes > 1)
    parallel_blocks_if(worth_threads((n_classes - 1) * p.size()), n_classes - 1,
                       [&](std::size_t b) { sweep_class(b + 1, ledger, p, materials); });
  // The entries in ascending order (class by class, each class's cells sorted).
  touched_.clear();
  for (std::vector<std::size_t>& class_touched : touched_by_class_) {
    std::sort(class_touched.begin(), class_touched.end());
    touched_.insert(touched_.end(), class_touched.begin(), class_touched.end());
    class_touched.clear();
  }
  ++stats_.passes;
  // Class by class, cell by cell: every class loses its share of what it held at the start,
  // then the fragments land.
  const double volume = g.cell_volume_m3();
  broken_.assign(touched_.size(), 0.0);
  for (std::size_t t = 0; t < touched_.size(); ++t) {
    const std::size_t kc = touched_[t], k = kc / cells, c = kc % cells;
    const double lambda = rate_[kc] / volume;
    if (lambda > 0.0)
      broken_[t] = -std::expm1(-lambda * dt_s) * ledger.cell_mass_kg(int(k))[c] * moved_share_[k];
  }
  for (std::size_t t = 0; t < touched_.size(); ++t) {
    const std::size_t kc = touched_[t], k = kc / cells;
    if (broken_[t] > 0.0) {
      ledger.move_between_classes(kc % cells, int(k), broken_[t], moved_to_[k]);
      stats_.ground_kg[k] += broken_[t];
    }
    rate_[kc] = 0.0;
    have_velocity_[kc] = 0;
  }
  touched_.clear();
}

// Class k's rate λ V_cell in each cell a particle sweeps: Σ_i π (R_i + r_k)² s η P̄ over the
// particles in the cell, in slot order.
void DustGrinding::sweep_class(std::size_t k, const DustLedger& ledger, const ParticleStore& p,
                               const MaterialTable& materials) {
  const GasGrid& g = ledger.grid();
  const DustClass& dust_class = ledger.classes()[k];
  const std::vector<double>& held = ledger.cell_mass_kg(int(k));
  const std::size_t cells = g.padded_size;
  const double c_dust = materials.material(dust_material_).normal_compliance;
  const double r_k = 0.5 * dust_class.diameter_m;
  const double threshold_j_per_kg = threshold_j_per_kg_[k];
  std::vector<std::size_t>& touched = touched_by_class_[k];
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t c = particle_cell_[i];
    if (c == cells || !(held[c] > 0.0)) continue;
    const std::size_t kc = k * cells + c;
    if (!have_velocity_[kc]) {
      dust_velocity_[kc] =
          ledger.gas_velocity_m_per_s(c) + ledger.slip_m_per_s(c, dust_class.relaxation_time_s);
      have_velocity_[kc] = 1;
      touched.push_back(kc);
    }
    // The equivalent speed is never above the relative one (equivalent_speed_pair shares it out
    // between the partners), so a pair below the class's threshold at its relative speed breaks
    // nothing: skipped before any root is taken.
    const double s2 = norm2(p.motion[i].velocity_m_per_s - dust_velocity_[kc]);
    if (!(0.5 * s2 > threshold_j_per_kg)) continue;
    const double r_i = p.radius_m[i];
    const double s = std::sqrt(s2);
    const double v_eq =
        equivalent_speed_pair(equivalence_, class_mass_kg_[k], r_k, c_dust, p.mass_kg[i], r_i,
                              materials.material(p.material[i]).normal_compliance, s);
    const double breaks =
        swept_selection_probability(strength_, dust_class.diameter_m, 0.5 * v_eq * v_eq);
    if (breaks <= 0.0) continue;
    const double eta = impaction_efficiency(dust_class.relaxation_time_s * s / r_i);
    const double reach = r_i + r_k;
    rate_[kc] += std::numbers::pi * reach * reach * s * eta * breaks;
  }
}

}  // namespace millsim
