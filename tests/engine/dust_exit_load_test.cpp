// The dust's exit rates that follow its hold-up (process/dust_exit_load.h, issue 31).
//
// - The fit recovers the exponents of rates that are powers of the hold-up, E_s ∝ D^β_s, from
//   two windows; a rate that fell as the dust grew is taken as 0 and named; two windows whose
//   dust barely differs fit nothing.
// - One dust class fed F at a rate E_1 (D / D_1)^β holds, at steady state, the D* that solves
//   F = E_1 (D*/D_1)^β D*: D* = D_1 (F / (E_1 D_1))^{1/(1+β)}.
// - Two classes with unlike exponents: D* against a scan of Σ_s F_s / E_s(D) − D over a fine
//   grid in ln D (the closed form of each class's hold-up at a given D), and each class's
//   outflow at D* equals what it receives.
#include <gtest/gtest.h>

#include <cmath>

#include "process/dust_exit_load.h"
#include "process/mass_flows.h"

namespace millsim {
namespace {

const std::vector<double> kEdges = {1e-6, 2e-6, 4e-6, 8e-6};  // slots 0 (under), 1–3, 4 (over)

DustExitWindow window_of(double dust_kg, std::vector<double> leave_per_s) {
  DustExitWindow w;
  w.dust_kg = dust_kg;
  w.leave_per_s = std::move(leave_per_s);
  return w;
}

TEST(DustExitLoad, TheFitRecoversPowersOfTheHoldUp) {
  const double d0 = 2.0e-6, d1 = 2.6e-6, ratio = d1 / d0;
  const std::vector<double> beta = {0.0, 1.5, 6.0};
  const std::vector<double> e0 = {40.0, 3.0, 0.5, 2.0, 0.0};
  std::vector<double> e1 = {40.0, 3.0 * std::pow(ratio, 1.5), 0.5 * std::pow(ratio, 6.0),
                            2.0 * std::pow(ratio, -2.0), 1.0};
  const DustExitLoad load = fit_dust_exit_load(window_of(d0, e0), window_of(d1, e1));
  ASSERT_TRUE(load.fitted);
  EXPECT_EQ(load.earlier_dust_kg, d0);
  EXPECT_EQ(load.reference_dust_kg, d1);
  ASSERT_EQ(load.exponent.size(), 5u);
  for (std::size_t s = 0; s < 3; ++s) EXPECT_NEAR(load.exponent[s], beta[s], 1e-12) << s;
  // Slot 3's rate fell as the dust grew: taken as 0 and named. Slot 4 left in one window only.
  EXPECT_EQ(load.exponent[3], 0.0);
  EXPECT_EQ(load.taken_as_zero, std::vector<int>{3});
  EXPECT_EQ(load.exponent[4], 0.0);
  // The rates at D_1 are the window's; at D_0 they are the earlier window's.
  CompartmentRates r;
  r.slots = 5;
  r.leave_per_s.assign(10, 0.0);
  std::copy(e1.begin(), e1.end(), r.leave_per_s.begin() + 5);
  EXPECT_EQ(rates_at_dust_kg(r, load, d1).leave_per_s, r.leave_per_s);
  const CompartmentRates back = rates_at_dust_kg(r, load, d0);
  for (std::size_t s = 0; s < 3; ++s)
    EXPECT_NEAR(back.leave_per_s[5 + s], e0[s], 1e-12 * e0[s]) << s;
}

TEST(DustExitLoad, TwoWindowsOfAlmostTheSameDustFitNothing) {
  const DustExitLoad load =
      fit_dust_exit_load(window_of(2.0e-6, {1.0, 2.0}), window_of(2.0e-6 * 1.01, {1.0, 4.0}));
  EXPECT_FALSE(load.fitted);
  EXPECT_EQ(load.exponent, (std::vector<double>{0.0, 0.0}));
  const DustExitLoad none =
      fit_dust_exit_load(window_of(0.0, {1.0, 2.0}), window_of(1e-6, {1.0, 4.0}));
  EXPECT_FALSE(none.fitted);
}

// Particles of slot 3 fed F, broken at k into the dust of the slots in `split` (shares of F),
// each dust class held at `held` and leaving at `leave`: one second's flows, fitted.
CompartmentRates breaking_into_dust(double feed, double k, const std::vector<int>& slots,
                                    const std::vector<double>& split,
                                    const std::vector<double>& held,
                                    const std::vector<double>& leave) {
  MassFlows f = make_mass_flows(kEdges);
  const int a = 3;
  f.fed_kg[std::size_t(a)] = feed;
  f.held_kg_s[std::size_t(a)] = feed / k;
  f.events[std::size_t(a)] = 1000.0;
  f.wall_events[std::size_t(a)] = 1000.0;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    const int b = MassFlows::dust(slots[i], f.slots);
    f.moved(a, b) = split[i] * feed;
    f.held_kg_s[std::size_t(b)] = held[i];
    f.left_kg[std::size_t(b)] = leave[i] * held[i];
  }
  return fit_rates(f, 1.0);
}

TEST(DustExitLoad, OneClassHoldsTheDustItsOwnRateGives) {
  const double feed = 2e-6, k = 50.0, e1 = 4.0, d1 = 1e-7, beta = 3.0;
  const CompartmentRates r = breaking_into_dust(feed, k, {2}, {1.0}, {d1}, {e1});
  const DustExitWindow window = dust_exit_window(r);
  EXPECT_NEAR(window.dust_kg, d1, 1e-15 * d1);
  const double d0 = 0.8 * d1;
  const DustExitLoad load =
      fit_dust_exit_load(window_of(d0, {0.0, 0.0, e1 * std::pow(d0 / d1, beta), 0.0, 0.0}), window);
  ASSERT_TRUE(load.fitted);
  ASSERT_NEAR(load.exponent[2], beta, 1e-12);
  const std::vector<double> empty(std::size_t(r.compartments()), 0.0);
  const LoadedProjection p = project_steady_at_own_load(r, load, empty, 2);
  ASSERT_TRUE(p.projection.exists);
  const double expected = d1 * std::pow(feed / (e1 * d1), 1.0 / (1.0 + beta));
  EXPECT_NEAR(p.dust_kg, expected, 1e-9 * expected);
  const int b = MassFlows::dust(2, r.slots);
  EXPECT_NEAR(p.projection.held_kg[std::size_t(b)], expected, 1e-9 * expected);
  EXPECT_NEAR(p.projection.product_kg_per_s[2], feed, 1e-9 * feed) << "what is fed leaves";
  EXPECT_GT(p.projection.time_to_steady_s, 0.0) << "the course is kept";
  // At fixed rates the class would hold F / E_1, 5 times D_1: following the load it holds less.
  const SteadyProjection fixed = project_steady(r, empty, 2);
  EXPECT_NEAR(fixed.held_kg[std::size_t(b)], feed / e1, 1e-12 * feed / e1);
  EXPECT_LT(p.dust_kg, feed / e1);
  EXPECT_GT(p.dust_kg, d1);
}

TEST(DustExitLoad, TwoClassesOfUnlikeExponentsMeetAtOneHoldUp) {
  const double feed = 3e-6, k = 50.0, d1 = 2e-7;
  const std::vector<double> split = {0.7, 0.3}, held = {1.5e-7, 0.5e-7}, leave = {20.0, 1.0};
  const std::vector<double> beta = {0.5, 8.0};
  const CompartmentRates r = breaking_into_dust(feed, k, {1, 2}, split, held, leave);
  const DustExitWindow window = dust_exit_window(r);
  ASSERT_NEAR(window.dust_kg, d1, 1e-15);
  const double d0 = 1.1 * d1;
  const DustExitLoad load =
      fit_dust_exit_load(window_of(d0, {0.0, leave[0] * std::pow(d0 / d1, beta[0]),
                                        leave[1] * std::pow(d0 / d1, beta[1]), 0.0, 0.0}),
                         window);
  ASSERT_TRUE(load.fitted);
  // The reference: Σ_s F_s / (E_s (D/D_1)^β_s) − D changes sign once; scanned over a fine grid.
  const auto excess = [&](double d) {
    double sum = 0.0;
    for (std::size_t i = 0; i < 2; ++i)
      sum += split[i] * feed / (leave[i] * std::pow(d / d1, beta[i]));
    return sum - d;
  };
  double scanned = 0.0;
  const int points = 200000;
  for (int i = 0; i < points; ++i) {
    const double d = d1 * std::exp(-3.0 + 6.0 * i / points);
    const double next = d1 * std::exp(-3.0 + 6.0 * (i + 1) / points);
    if (excess(d) > 0.0 && excess(next) <= 0.0) scanned = std::sqrt(d * next);
  }
  ASSERT_GT(scanned, 0.0);
  const std::vector<double> empty(std::size_t(r.compartments()), 0.0);
  const LoadedProjection p = project_steady_at_own_load(r, load, empty, 2);
  ASSERT_TRUE(p.projection.exists);
  EXPECT_NEAR(p.dust_kg, scanned, 6.0 / points * scanned);
  // The projection holds what it says, and each class's outflow at D* is what it receives.
  double held_dust = 0.0;
  for (int s = 0; s < r.slots; ++s) held_dust += p.projection.held_kg[std::size_t(r.slots + s)];
  EXPECT_NEAR(held_dust, p.dust_kg, 1e-9 * p.dust_kg);
  for (std::size_t i = 0; i < 2; ++i) {
    const int slot = int(i) + 1;
    EXPECT_NEAR(p.projection.product_kg_per_s[std::size_t(slot)], split[i] * feed,
                1e-9 * split[i] * feed)
        << slot;
  }
}

}  // namespace
}  // namespace millsim
