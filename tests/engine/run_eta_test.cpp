// The time left in the progress lines (sim/run_eta.h) against runs whose cost is known: a step
// costs a + b N wall seconds and the population N grows linearly (a fed mill), so the exact time
// left is a sum the test computes. The estimate from the recent samples lands within 2 % of it;
// the average since the start, what the progress lines printed before, is several times short.
#include "sim/run_eta.h"

#include <gtest/gtest.h>

#include <cmath>

namespace millsim {
namespace {

struct GrowingRun {
  double fixed_s_per_step;     // a
  double s_per_particle_step;  // b
  double particles_per_step;   // dN/ds, from N = 0 at step 0
  double particles(std::int64_t step) const { return particles_per_step * double(step); }
  // Wall time of steps [0, step): Σ (a + b N(s)).
  double elapsed_s(std::int64_t step) const {
    const double n = double(step);
    return fixed_s_per_step * n + s_per_particle_step * particles_per_step * n * (n - 1.0) / 2.0;
  }
};

TEST(RunEta, AGrowingPopulationIsForecastFromItsRecentCostAndTrend) {
  const GrowingRun run{2e-5, 4e-8, 0.05};  // 5 particles per 100 steps, fixed part 20 µs/step
  const std::int64_t total = 200000;
  EtaEstimator eta;
  const std::int64_t now = 40000;  // a fifth of the way, 2,000 particles
  for (std::int64_t s = now - 11 * 500; s <= now; s += 500)
    eta.add(s, run.elapsed_s(s), std::size_t(run.particles(s)));
  const double truth = run.elapsed_s(total) - run.elapsed_s(now);
  EXPECT_NEAR(eta.eta_s(total), truth, 0.02 * truth);
  const double average_since_start = run.elapsed_s(now) / double(now) * double(total - now);
  EXPECT_LT(average_since_start, 0.5 * truth) << "the old estimate was not as short as thought";
}

TEST(RunEta, AConstantPopulationIsForecastAtItsRate) {
  EtaEstimator eta;
  for (int k = 0; k <= 5; ++k) eta.add(1000 * k, 0.5 * k, 300);  // 0.5 ms per step
  EXPECT_NEAR(eta.eta_s(10000), 0.5 * 5, 1e-9);
  EXPECT_EQ(eta.eta_s(5000), 0.0);  // done
  EtaEstimator one;
  one.add(10, 1.0, 5);
  EXPECT_EQ(one.eta_s(100), 0.0) << "no rate from one sample";
}

TEST(RunEta, AnEmptyMillCostsItsFixedPartPerStep) {
  // No particle yet (the gas only): the fixed part alone, however many particles come later.
  EtaEstimator eta;
  for (int k = 0; k <= 4; ++k) eta.add(100 * k, 0.01 * k, 0);
  EXPECT_NEAR(eta.eta_s(1400), 0.1, 1e-9);
}

}  // namespace
}  // namespace millsim
