// PSD tally, summary and distance on synthetic sets whose statistics are known exactly.
#include "process/psd.h"

#include <gtest/gtest.h>

#include <cmath>

namespace millsim {
namespace {

std::vector<double> decade_edges() {
  return {1e-6, 1e-5, 1e-4, 1e-3, 1e-2};
}

TEST(Psd, TallyAndSummaryOfAKnownSet) {
  PsdTally t(decade_edges());
  t.add(5e-6, 1.0);       // bin 0
  t.add(2e-5, 2.0, 3.0);  // bin 1: three particles, 2 kg
  t.add(1e-4, 3.0);       // exactly on an edge: the upper bin (2)
  t.add(5e-7, 0.5);       // underflow
  t.add(2e-2, 0.25);      // overflow
  EXPECT_DOUBLE_EQ(t.total_count(), 7.0);
  EXPECT_DOUBLE_EQ(t.total_mass_kg(), 6.75);
  const PsdSummary s = summarize(t);
  EXPECT_EQ(s.mass_kg, (std::vector<double>{1.0, 2.0, 3.0, 0.0}));
  EXPECT_EQ(s.count, (std::vector<double>{1.0, 3.0, 1.0, 0.0}));
  EXPECT_DOUBLE_EQ(s.cumulative_mass.front(), 0.5 / 6.75);
  EXPECT_DOUBLE_EQ(s.cumulative_mass[2], 3.5 / 6.75);
  EXPECT_NEAR(s.cumulative_mass.back(), 6.5 / 6.75, 1e-15);
  EXPECT_DOUBLE_EQ(s.number_fraction[1], 3.0 / 7.0);
  EXPECT_DOUBLE_EQ(s.mass_density_per_m[0], (1.0 / 6.75) / 9e-6);
  // d50: cumulative 0.5 lies in bin 1 at (0.5 − 1.5/6.75) / (2/6.75) of the way in ln x.
  const double t50 = (0.5 - 1.5 / 6.75) / (2.0 / 6.75);
  EXPECT_NEAR(s.d50_m, 1e-5 * std::pow(10.0, t50), 1e-18);
  // d10 in the underflow's class reads as... cumulative 0.1 > 0.074 (underflow): bin 0.
  const double t10 = (0.1 - 0.5 / 6.75) / (1.0 / 6.75);
  EXPECT_NEAR(s.d10_m, 1e-6 * std::pow(10.0, t10), 1e-19);
}

TEST(Psd, EqualMassPerDecadePutsD50OnTheMiddleEdge) {
  PsdTally t(decade_edges());
  for (double d : {3e-6, 3e-5, 3e-4, 3e-3}) t.add(d, 1.0);
  const PsdSummary s = summarize(t);
  EXPECT_NEAR(s.d50_m, 1e-4, 1e-18);
  EXPECT_NEAR(s.d10_m, 1e-6 * std::pow(10.0, 0.4), 1e-19);
  EXPECT_NEAR(s.d90_m, 1e-3 * std::pow(10.0, 0.6), 1e-16);
}

// An empty product (nothing left the mill yet) has no size: its d10/d50/d90 are null in JSON,
// not 0 m, while a product of one particle has all three.
TEST(Psd, AnEmptyDistributionHasNoSizes) {
  const nlohmann::ordered_json empty = psd_json(summarize(PsdTally(decade_edges())));
  for (const char* d : {"d10_m", "d50_m", "d90_m"}) EXPECT_TRUE(empty[d].is_null()) << d;
  EXPECT_EQ(empty["total_mass_kg"], 0.0);
  PsdTally one(decade_edges());
  one.add(5e-6, 1.0);
  const nlohmann::ordered_json some = psd_json(summarize(one));
  for (const char* d : {"d10_m", "d50_m", "d90_m"}) {
    ASSERT_TRUE(some[d].is_number()) << d;
    EXPECT_GE(some[d].get<double>(), 1e-6);
    EXPECT_LE(some[d].get<double>(), 1e-5);
  }
}

TEST(Psd, DistanceBetweenDistributions) {
  PsdTally a(decade_edges()), b(decade_edges());
  a.add(3e-5, 1.0);  // all mass in bin 1
  b.add(3e-4, 1.0);  // all mass in bin 2
  const PsdDistance same = compare_psd(summarize(a), summarize(a));
  EXPECT_EQ(same.ks, 0.0);
  EXPECT_EQ(same.l1, 0.0);
  EXPECT_EQ(same.d50_relative_error, 0.0);
  const PsdDistance d = compare_psd(summarize(a), summarize(b));
  EXPECT_DOUBLE_EQ(d.ks, 1.0);
  // The cumulatives differ by 1 at the edge 1e-4 only, 0 at its neighbours: trapezoids give
  // half a decade on each side, one decade of the four.
  EXPECT_NEAR(d.l1, 0.25, 1e-15);
  EXPECT_NEAR(d.d50_relative_error,
              (std::sqrt(10.0) * 1e-5 - std::sqrt(10.0) * 1e-4) / (std::sqrt(10.0) * 1e-4), 1e-12);
  PsdTally other({1e-6, 1e-3});
  EXPECT_THROW(compare_psd(summarize(a), summarize(other)), std::invalid_argument);
}

}  // namespace
}  // namespace millsim
