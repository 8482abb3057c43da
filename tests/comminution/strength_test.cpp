// Comminution functions (comminution/strength.h): the drawn strengths follow the selection
// function, fatigue needs the predicted number of impacts, and the impact equivalences match
// the centre-of-mass and Hertz peak-force expectations computed here independently.
#include "comminution/strength.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"

namespace millsim {
namespace {

StrengthConfig vogel_peukert(double f_mat, double x_w_min) {
  StrengthConfig s;
  s.model = StrengthModel::VogelPeukert;
  s.f_mat_kg_per_j_m = f_mat;
  s.x_w_min_j_m_per_kg = x_w_min;
  return s;
}

StrengthConfig weibull(double median, double d_ref, double phi, double m) {
  StrengthConfig s;
  s.model = StrengthModel::Weibull;
  s.median_energy_j_per_kg = median;
  s.reference_diameter_m = d_ref;
  s.size_exponent = phi;
  s.weibull_modulus = m;
  return s;
}

// Fraction of N drawn capacities at or below `excess` against the selection probability.
void expect_draws_follow_selection(const StrengthConfig& s, double d) {
  Rng rng(7);
  const int n = 20000;
  for (double w_factor : {1.2, 2.0, 5.0}) {
    const double w = s.model == StrengthModel::VogelPeukert
                         ? w_factor * threshold_energy_j_per_kg(s, d)
                         : w_factor * 0.5 * s.median_energy_j_per_kg;
    const double excess = w - threshold_energy_j_per_kg(s, d);
    int broken = 0;
    for (int k = 0; k < n; ++k)
      broken += capacity_from_uniform_j_per_kg(s, d, 1.0 - uniform01(rng)) <= excess;
    const double p = selection_probability(s, d, w);
    const double sigma = std::sqrt(p * (1 - p) / n);
    EXPECT_NEAR(double(broken) / n, p, 4 * sigma + 1e-12) << "W = " << w;
  }
}

TEST(Strength, VogelPeukertSelectionHasThePublishedForm) {
  const StrengthConfig s = vogel_peukert(200.0, 2e-3);
  const double d = 1e-4, w_min = 2e-3 / d;
  EXPECT_DOUBLE_EQ(threshold_energy_j_per_kg(s, d), 20.0);
  EXPECT_EQ(selection_probability(s, d, 0.9 * w_min), 0.0);
  const double w = 80.0;
  EXPECT_NEAR(selection_probability(s, d, w), 1 - std::exp(-200.0 * d * (w - w_min)), 1e-15);
  // Larger particles are weaker: lower threshold, steeper selection.
  EXPECT_GT(selection_probability(s, 2 * d, w), selection_probability(s, d, w));
  // Vogel–Peukert's k impacts: 1 − exp(−f x k (W − W_min)) with fatigue factor 1.
  EXPECT_NEAR(selection_probability(s, d, w, 5, 1.0), 1 - std::exp(-200.0 * d * 5 * (w - w_min)),
              1e-15);
  expect_draws_follow_selection(s, d);
}

TEST(Strength, WeibullMedianBreaksHalfAndScalesWithSize) {
  const StrengthConfig s = weibull(100.0, 1e-4, 0.5, 3.0);
  EXPECT_NEAR(selection_probability(s, 1e-4, 100.0), 0.5, 1e-14);
  // W50(4 x_ref) = 100 · 4^(−0.5) = 50.
  EXPECT_NEAR(selection_probability(s, 4e-4, 50.0), 0.5, 1e-14);
  expect_draws_follow_selection(s, 1e-4);
}

TEST(Strength, FatigueBreaksAfterThePredictedNumberOfImpacts) {
  MaterialBreakageConfig b;
  b.strength = vogel_peukert(200.0, 2e-3);
  const double d = 1e-4, w_min = 20.0;
  for (double ratio : {1.5, 3.2, 7.9}) {
    const double capacity = 40.0;
    const double excess = capacity / ratio;  // survives the first impact
    double remaining = capacity;
    int impacts = 0;
    bool broken = false;
    while (!broken && impacts < 100)
      broken = apply_impact(b, d, w_min + excess, remaining), ++impacts;
    EXPECT_TRUE(broken);
    EXPECT_EQ(impacts, int(std::ceil(ratio))) << "capacity / excess = " << ratio;
  }
  b.fatigue = false;
  double remaining = 40.0;
  for (int k = 0; k < 1000; ++k) EXPECT_FALSE(apply_impact(b, d, w_min + 39.0, remaining));
  // Impacts below W_min never damage.
  b.fatigue = true;
  remaining = 40.0;
  for (int k = 0; k < 1000; ++k) EXPECT_FALSE(apply_impact(b, d, 0.99 * w_min, remaining));
  EXPECT_EQ(remaining, 40.0);
}

// Peak Hertz force of a head-on elastic impact: F = (4/3) E* √R* δ^{3/2}, δ from Eq. 12.
double peak_force(double e_star, double r_star, double m_star, double v) {
  const double k = 4.0 / 3.0 * e_star * std::sqrt(r_star);
  const double overlap = std::pow(5.0 * m_star * v * v / (4.0 * k), 0.4);
  return k * std::pow(overlap, 1.5);
}

TEST(Strength, EquivalentSpeeds) {
  const double v = 10.0;
  // Equal spheres: each hits the symmetry plane, a rigid wall, at v/2; both equivalences agree.
  EXPECT_NEAR(equivalent_speed_pair(ImpactEquivalence::Energy, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, v),
              5.0, 1e-14);
  EXPECT_NEAR(equivalent_speed_pair(ImpactEquivalence::Force, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, v), 5.0,
              1e-13);
  EXPECT_EQ(equivalent_speed_wall(ImpactEquivalence::Energy, 1e-10, 1e-11, v), v);

  // Unlike pair: the force-equivalent rigid-wall impact gives the pair's peak force.
  const double m_i = 2e-9, r_i = 50e-6, c_i = 1.0 / 40e9;   // fine, stiff
  const double m_j = 3e-7, r_j = 300e-6, c_j = 1.0 / 10e9;  // coarse, soft
  const double u = equivalent_speed_pair(ImpactEquivalence::Force, m_i, r_i, c_i, m_j, r_j, c_j, v);
  const double pair_force =
      peak_force(1.0 / (c_i + c_j), r_i * r_j / (r_i + r_j), m_i * m_j / (m_i + m_j), v);
  EXPECT_NEAR(peak_force(1.0 / c_i, r_i, m_i, u) / pair_force, 1.0, 1e-12);
  // Against an elastic wall likewise.
  const double c_wall = 1.0 / 200e9;
  const double u_wall = equivalent_speed_wall(ImpactEquivalence::Force, c_i, c_wall, v);
  EXPECT_NEAR(
      peak_force(1.0 / c_i, r_i, m_i, u_wall) / peak_force(1.0 / (c_i + c_wall), r_i, m_i, v), 1.0,
      1e-12);
  // Energy: a fine particle hitting a much heavier one sees nearly the full speed.
  EXPECT_NEAR(equivalent_speed_pair(ImpactEquivalence::Energy, m_i, r_i, c_i, m_j, r_j, c_j, v),
              v * m_j / (m_i + m_j), 1e-14);
}

}  // namespace
}  // namespace millsim
