// Breakage functions: the sizes of the fragments of one broken particle, as ratios r = x / y of
// fragment to parent diameter, always filling exactly the parent's volume.
//
// Each model gives the mass-cumulative distribution B(r) of its fragments: power law
// (Gates–Gaudin–Schuhmann), Broadbent–Callcott, Austin–Luckie, Vogel–Peukert (whose B also
// depends on the parent's size), or n equal fragments. B is used on [min_ratio, max_ratio] and
// normalised there; min_ratio = 0 is the published domain.
//
// One breakage, given the smallest tracked ratio ("floor", the dust threshold over the parent's
// diameter, never below min_ratio):
//   * the share B(floor) of the volume below the floor is not drawn as fragments at all: it is
//     returned as one number, for the dust table to bin by B;
//   * the rest is filled with fragments drawn from the number distribution (density ∝ B'(r) / r³)
//     restricted to [floor, max_ratio]. A draw that does not fit in the volume still free is not
//     discarded or shrunk but kept in the material's pool and placed first in a later breakage.
//     Every draw is thus used once, and over many breakages the mass-weighted sizes follow B
//     (dropping or shrinking the draws that do not fit is what biases simple samplers towards
//     fines). Filling stops when no tracked fragment fits or after 16 draws in a row did not
//     fit; the volume still free becomes one last fragment, or, if that would lie below the
//     floor, joins the share below the floor, and later breakages give that much less to
//     theirs (the pool's credit): over many breakages that share is B(floor) exactly.
// The pool is the only state and is checkpointed with the breakage module.
#pragma once

#include <vector>

#include "core/rng.h"
#include "scene/scene_config.h"

namespace millsim {

// Draws kept for later breakages, as volumes in parent volumes of the breakage that drew them.
struct FragmentPool {
  std::vector<double> volumes;
  // Volume that went below the floor beyond B(floor) (the last free volume of a breakage): taken
  // back from the share below the floor of later breakages.
  double below_floor_credit = 0.0;
  template <class A>
  void checkpoint_io(A& a) {
    io(a, volumes);
    io(a, below_floor_credit);
  }
};

struct FragmentDraw {
  // Fragments, largest first; only the last may lie below the floor, and then only below
  // min_ratio too (where B has no mass to spread it by).
  std::vector<double> ratios;
  double below_floor_volume = 0.0;  // share of the parent's volume below the floor, spread as B
};

class FragmentSizeSampler {
 public:
  FragmentSizeSampler() = default;
  explicit FragmentSizeSampler(const FragmentConfig& config);

  // One breakage of a parent of `parent_diameter_m` whose fragments below `floor_ratio` are not
  // tracked. Σ ratios³ + below_floor_volume = 1 to rounding.
  FragmentDraw draw(double parent_diameter_m, double floor_ratio, FragmentPool& pool,
                    Rng& rng) const;

  // B(r): the model's mass fraction of fragments smaller than r, for a parent of that diameter.
  double mass_cumulative(double ratio, double parent_diameter_m) const;
  // The drawn part's B (without Vogel–Peukert's unbroken share), normalised: how the volume below
  // the floor is spread over sizes.
  double drawn_cumulative(double ratio) const;
  double min_ratio() const { return config_.min_ratio; }

 private:
  double draw_one(double floor_cdf, Rng& rng) const;
  double number_cdf_at(double ratio) const;
  // Vogel–Peukert: the share of the parent's mass that breaks into the power-law fragments.
  double broken_share(double parent_diameter_m) const;

  FragmentConfig config_;
  std::vector<double> log_ratio_;   // grid in ln r
  std::vector<double> number_cdf_;  // number CDF at the grid points
};

}  // namespace millsim
