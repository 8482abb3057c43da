// Breakage functions and fragment placement: every breakage fills the parent's volume exactly,
// the fragments' mass distribution follows the model's B(r), and placement keeps the centre of
// mass.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "comminution/fragment_sizes.h"
#include "comminution/fragment_spawn.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using test::power_law_fragments;

TEST(FragmentSizes, EveryBreakageFillsTheParentVolume) {
  FragmentConfig bc = power_law_fragments(1.0, 0.05, 0.7);
  bc.model = FragmentModel::BroadbentCallcott;
  FragmentConfig equal;
  equal.model = FragmentModel::Equal;
  equal.count = 27;
  for (const FragmentConfig& c :
       {power_law_fragments(0.8, 0.05, 0.7), power_law_fragments(2.5, 0.2, 0.9), bc, equal}) {
    const FragmentSizeSampler sampler(c);
    Rng rng(3);
    for (int event = 0; event < 2000; ++event) {
      const std::vector<double> r = sampler.draw_ratios(rng);
      ASSERT_GE(r.size(), 2u);
      double volume = 0.0;
      for (double x : r) volume += x * x * x;
      ASSERT_NEAR(volume, 1.0, 1e-13);
      EXPECT_TRUE(std::is_sorted(r.rbegin(), r.rend()));
      EXPECT_LE(r.front(), std::max(c.max_ratio, std::cbrt(1.0 / c.count)) + 1e-15);
    }
  }
}

// The mass-weighted distribution of many breakages against B(r). Only the last fragment of each
// breakage (the remaining volume) departs from the model, so the gap is small, not zero.
TEST(FragmentSizes, MassDistributionFollowsTheBreakageFunction) {
  FragmentConfig bc = power_law_fragments(1.0, 0.05, 0.7);
  bc.model = FragmentModel::BroadbentCallcott;
  for (const FragmentConfig& c :
       {power_law_fragments(1.0, 0.05, 0.7), power_law_fragments(2.0, 0.05, 0.5), bc}) {
    const FragmentSizeSampler sampler(c);
    Rng rng(11);
    std::vector<std::pair<double, double>> fragments;  // ratio, volume
    double total = 0.0;
    for (int event = 0; event < 3000; ++event)
      for (double r : sampler.draw_ratios(rng))
        fragments.push_back({r, r * r * r}), total += r * r * r;
    std::sort(fragments.begin(), fragments.end());
    double below = 0.0, ks = 0.0;
    for (const auto& [r, v] : fragments) {
      below += v;
      ks = std::max(ks, std::abs(below / total - sampler.mass_cumulative(r)));
    }
    EXPECT_LT(ks, 0.05) << "model " << int(c.model) << " q " << c.exponent;
  }
}

TEST(FragmentSpawn, FragmentsStartInsideTheParentWithItsCentreOfMass) {
  Rng rng(5);
  const double parent_d = 1e-3;
  const std::vector<double> d = {5e-4, 4e-4, 3e-4, 3e-4, 2e-4, 1e-4, 1e-4, 5e-5};
  const std::vector<Vec3> offset = place_fragments(d, parent_d, 16, rng);
  ASSERT_EQ(offset.size(), d.size());
  Vec3 moment{};
  double shift_allowed = 0.0;
  for (std::size_t k = 0; k < d.size(); ++k) moment += offset[k] * (d[k] * d[k] * d[k]);
  EXPECT_LT(norm(moment), 1e-12 * parent_d * parent_d * parent_d * parent_d);
  // Before the centre-of-mass shift each fragment was inside the parent; the shift is at most
  // the parent radius, so no fragment starts farther out than that.
  for (std::size_t k = 0; k < d.size(); ++k) {
    shift_allowed = 0.5 * parent_d;
    EXPECT_LE(norm(offset[k]) + 0.5 * d[k], 0.5 * parent_d + shift_allowed);
  }
}

}  // namespace
}  // namespace millsim
