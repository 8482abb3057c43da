// Breakage functions: the sizes of the fragments of one broken particle, as ratios r = x / y of
// fragment to parent diameter, always filling exactly the parent's volume (Σ r³ = 1 to rounding).
// The model gives the mass-cumulative distribution B(r) on [r_min, r_max]; fragments are drawn
// from the matching number distribution (density ∝ B'(r) / r³) one at a time until the next one
// would not fit, and the remaining volume becomes the last fragment. The first fragment always
// fits (r_max³ < 1), so a breakage gives at least two fragments.
#pragma once

#include <vector>

#include "core/rng.h"
#include "scene/scene_config.h"

namespace millsim {

class FragmentSizeSampler {
 public:
  FragmentSizeSampler() = default;
  explicit FragmentSizeSampler(const FragmentConfig& config);

  // Fragment diameter ratios of one breakage, largest first.
  std::vector<double> draw_ratios(Rng& rng) const;

  // B(r): the model's mass fraction of fragments smaller than r (before the last fragment).
  double mass_cumulative(double ratio) const;

 private:
  double draw_one(Rng& rng) const;

  FragmentConfig config_;
  std::vector<double> log_ratio_;   // grid in ln r
  std::vector<double> number_cdf_;  // number CDF at the grid points
};

}  // namespace millsim
