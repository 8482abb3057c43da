// Dust ground by the tracked particles that sweep through it (issue 31, `dust.grinding:
// "sweep"`). Without it, ledger dust between a mill's cut and the dust threshold can neither
// leave (the vortex holds it) nor break, so a mill whose cut lies below the threshold never
// reaches a steady state; in a real jet mill such fines are ground by the collisions that grind
// everything else.
//
// Each tracked particle i sweeps the dust of its gas cell. Dust of class k moves with the gas
// plus its slip (dust/dust_ledger.h), so it meets particle i at s = |u_i − u_dust,k|, and in a
// time dt the particle meets the dust in the volume π (R_i + r_k)² s η dt, η the inertial
// impaction efficiency on a sphere in potential flow, the usual fit η = (St / (St + 1/4))² with
// St = 2 τ_k s / D_i (Langmuir & Blodgett's trajectories; at the speeds that can break dust St is
// large and η ≈ 1). A dust grain hitting at impact parameter b has the normal speed
// s √(1 − b²/(R_i + r_k)²); mapped to a wall impact by the scene's equivalence (comminution/
// strength.h) its specific energy is W₀ u with u = 1 − b²/(R_i + r_k)² uniform over the swept
// disc, W₀ = ½ v_eq(s)². The share that breaks is the material's selection probability
// averaged over u (fatigue left out: each grain is counted at its first impact, a lower bound):
//     Vogel–Peukert: P̄ = (1 − u₀) − (1 − e^{−a (W₀ − W_min)}) / (a W₀),  a = f_mat x_k,
//                    u₀ = W_min / W₀ (0 when W₀ ≤ W_min).
// Per cell and class the rate λ = Σ_i π (R_i + r_k)² s η P̄ / V_cell; over dt the class loses the
// share 1 − e^{−λ dt} of what it held at the start, spread over the finer classes by the
// material's breakage function B (the share that falls in its own class stays there; what falls
// below the first edge joins class 0, which is not ground). Mass moves only between classes of
// one cell: the ledger's total is unchanged to rounding. The particles are not slowed by it (the
// dust is one-way coupled).
#pragma once

#include <cstdint>
#include <vector>

#include "checkpoint/archive.h"
#include "comminution/fragment_sizes.h"
#include "dust/dust_ledger.h"
#include "particles/materials.h"
#include "particles/particle_store.h"
#include "scene/scene_config.h"

namespace millsim {

// η(St) = (St / (St + 1/4))², 0 at St ≤ 0.
double impaction_efficiency(double stokes);

// P̄ above: the breakage probability of a grain of `diameter_m` averaged over the impact
// parameters of a sweep whose head-on impact has specific energy `w0_j_per_kg`.
double swept_selection_probability(const StrengthConfig& strength, double diameter_m,
                                   double w0_j_per_kg);

// share[k][j]: the part of class k's broken mass that lands in class j ≤ k (B between the class
// edges over the class's diameter; class 0 takes what lies below the first edge). Rows sum to 1.
std::vector<std::vector<double>> dust_fragment_shares(const std::vector<double>& edges_m,
                                                      const std::vector<DustClass>& classes,
                                                      const FragmentSizeSampler& fragments);

struct DustGrindingStats {
  std::uint64_t passes = 0;
  std::vector<double> ground_kg;  // per class: mass broken out of it so far
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, passes, ground_kg);
  }
};

class DustGrinding {
 public:
  // `dust` is the ledger's material (the one breakable material), `dust_material` its index in
  // the run's material table.
  DustGrinding(const DustLedger& ledger, const std::vector<double>& edges_m,
               const MaterialConfig& dust, int dust_material, ImpactEquivalence equivalence);

  // Grinds the ledger's dust over dt_s with the particles as they are now; call after the
  // ledger's advance (its gas velocities and slips are those of the same gas). `materials`
  // gives the partners' compliances (force equivalence).
  void grind(DustLedger& ledger, const ParticleStore& particles, const MaterialTable& materials,
             double dt_s);

  const DustGrindingStats& stats() const { return stats_; }
  const std::vector<std::vector<double>>& shares() const { return shares_; }
  // Where mass ground out of class k lands: a share per class (0 for k itself), summing to 1.
  const std::vector<double>& moved_to(int k) const { return moved_to_[std::size_t(k)]; }
  template <class A>
  void checkpoint_io(A& a) {
    io(a, stats_);
  }

 private:
  StrengthConfig strength_;
  ImpactEquivalence equivalence_;
  int dust_material_ = 0;
  std::vector<double> class_mass_kg_;       // a grain's mass per class
  std::vector<double> threshold_j_per_kg_;  // per class: W_min at its diameter
  std::vector<std::vector<double>> shares_;
  // Per class: the share of its broken mass that leaves it (1 − shares[k][k]), and how that
  // part spreads over the finer classes (Σ = 1).
  std::vector<double> moved_share_;
  std::vector<std::vector<double>> moved_to_;
  // Per class × padded cell, this pass: the rate λ V_cell, the dust's velocity (computed when
  // first needed) and whether it was; `touched` lists the entries set, so a pass clears only
  // those, and `broken` holds their mass to move.
  std::vector<double> rate_;
  std::vector<Vec3> dust_velocity_;
  std::vector<std::uint8_t> have_velocity_;
  std::vector<std::size_t> touched_;
  std::vector<std::vector<std::size_t>> touched_by_class_;  // a class's own, while it is swept
  std::vector<double> broken_;
  std::vector<std::size_t> particle_cell_;  // per particle, this pass: its fluid cell (or none)
  void sweep_class(std::size_t k, const DustLedger& ledger, const ParticleStore& particles,
                   const MaterialTable& materials);
  DustGrindingStats stats_;
};

}  // namespace millsim
