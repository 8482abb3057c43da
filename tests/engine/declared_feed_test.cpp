// The feed a scene declares, by PSD slot (process/feed.h, particles/particle_sources.h): the
// share of a size distribution's mass below a size, against its closed form where there is one
// and against the mass of many draws of sample_diameter otherwise; and a feeder's inserted
// particles over a long span against the declared rate in each slot.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dem/box.h"
#include "particles/particle_sources.h"
#include "particles/particle_store.h"
#include "process/feed.h"
#include "process/mass_flows.h"

namespace millsim {
namespace {

SizeDistribution uniform_sizes(double min_m, double max_m) {
  SizeDistribution s;
  s.kind = SizeDistributionKind::Uniform;
  s.min_m = min_m, s.max_m = max_m;
  return s;
}

TEST(DeclaredFeed, TheMassShareOfAUniformRangeIsTheFourthPowersShare) {
  const SizeDistribution s = uniform_sizes(1e-4, 2e-4);
  // ∫ x³ dx from 1 to 1.5 over from 1 to 2: (1.5⁴ − 1) / (2⁴ − 1).
  EXPECT_NEAR(mass_share_below(s, 1.5e-4), (std::pow(1.5, 4) - 1.0) / 15.0, 1e-12);
  EXPECT_EQ(mass_share_below(s, 0.9e-4), 0.0);
  EXPECT_EQ(mass_share_below(s, 1e-4), 0.0);
  EXPECT_EQ(mass_share_below(s, 2e-4), 1.0);
  EXPECT_EQ(mass_share_below(s, 3e-4), 1.0);
  SizeDistribution fixed;
  fixed.kind = SizeDistributionKind::Fixed, fixed.diameter_m = 5e-5;
  EXPECT_EQ(mass_share_below(fixed, 5e-5), 0.0) << "a size on an edge lies in the slot above";
  EXPECT_EQ(mass_share_below(fixed, 5.0001e-5), 1.0);
  EXPECT_EQ(mass_share_below(uniform_sizes(7e-5, 7e-5), 7.1e-5), 1.0) << "a range of no width";
}

// Against 400 000 draws: each edge's estimated share within five of its standard errors (the
// mass-weighted share's, from the draws themselves). That error is an estimate only where both
// sides of the edge drew many particles: edges with fewer than 200 draws on a side are left
// out, and at least three are checked.
void expect_draws_carry_the_shares(const SizeDistribution& s, const std::vector<double>& edges) {
  Rng rng(2026);
  const std::size_t draws = 400000;
  std::vector<double> weights(draws, 0.0), diameters(draws, 0.0);
  double total = 0.0;
  for (std::size_t i = 0; i < draws; ++i) {
    const double d = sample_diameter(s, rng);
    diameters[i] = d, weights[i] = d * d * d;
    total += d * d * d;
  }
  int checked = 0;
  for (double edge : edges) {
    double below = 0.0;
    std::size_t drawn_below = 0;
    for (std::size_t i = 0; i < draws; ++i)
      if (diameters[i] < edge) below += weights[i], ++drawn_below;
    if (std::min(drawn_below, draws - drawn_below) < 200) continue;
    ++checked;
    const double share = below / total;
    double variance = 0.0;  // of the ratio estimator: Σ w² (1{d < e} − share)² / (Σ w)²
    for (std::size_t i = 0; i < draws; ++i) {
      const double deviation = weights[i] * ((diameters[i] < edge ? 1.0 : 0.0) - share);
      variance += deviation * deviation;
    }
    const double standard_error = std::sqrt(variance) / total;
    EXPECT_NEAR(mass_share_below(s, edge), share, 5.0 * standard_error + 1e-12)
        << "kind " << int(s.kind) << ", edge " << edge;
  }
  EXPECT_GE(checked, 3) << "kind " << int(s.kind);
}

TEST(DeclaredFeed, TheMassShareBelowEachSizeIsWhatTheDrawsCarry) {
  const std::vector<double> edges = {2e-6, 3.5e-6, 5e-6, 7e-6, 1e-5, 2e-5, 4e-5, 8e-5, 1.6e-4};
  expect_draws_carry_the_shares(uniform_sizes(1e-5, 1.5e-4), edges);
  for (const double exponent : {-2.5, -4.0, -6.0}) {  // −4: the third moment's logarithm
    SizeDistribution power;
    power.kind = SizeDistributionKind::PowerLaw;
    power.min_m = 3e-6, power.max_m = 1.5e-4, power.exponent = exponent;
    expect_draws_carry_the_shares(power, edges);
  }
  SizeDistribution log_normal;
  log_normal.kind = SizeDistributionKind::LogNormal;
  log_normal.median_m = 1e-5, log_normal.geometric_std = 1.8;
  log_normal.min_m = 0.0, log_normal.max_m = 10.0;  // the scene's defaults: untruncated
  expect_draws_carry_the_shares(log_normal, edges);
  log_normal.min_m = 4e-6, log_normal.max_m = 3e-5;  // truncated at both ends
  expect_draws_carry_the_shares(log_normal, edges);
}

TEST(DeclaredFeed, AFeedersInsertedMassBySlotIsItsDeclaredRate) {
  FeedConfig feed;
  feed.mass_rate_kg_per_s = 5e-6;  // the steady mill's 5 mg/s of 100-300 um
  feed.sizes = uniform_sizes(1e-4, 3e-4);
  feed.region_min_m = {0.0, 0.0, 0.0}, feed.region_max_m = {1.0, 1.0, 1.0};
  feed.start_s = 0.5, feed.end_s = 30.5;
  const std::vector<double> edges = {1e-5, 1e-4, 1.2e-4, 1.6e-4, 2e-4, 2.5e-4, 2.9e-4, 4e-4};
  const double density = 2165.0, from_s = 0.0, to_s = 40.0;

  const std::vector<double> declared = declared_feed_kg_per_s({feed}, edges, from_s, to_s);
  ASSERT_EQ(declared.size(), edges.size() + 1);
  double sum = 0.0;
  for (double r : declared) sum += r;
  // On for 30 s of the 40.
  EXPECT_NEAR(sum, feed.mass_rate_kg_per_s * 30.0 / 40.0, 1e-15);
  EXPECT_EQ(declared[0] + declared[1], 0.0) << "no feed below 100 um";
  EXPECT_EQ(declared.back(), 0.0) << "nor above 400 um";

  // The feeder run over the span with nothing in its way (each particle is placed and not kept).
  Feeder feeder(feed, density, 7);
  const ParticleStore empty;
  PeriodicBox box;
  box.min_m = {0.0, 0.0, 0.0}, box.max_m = {1.0, 1.0, 1.0};
  std::vector<double> inserted(declared.size(), 0.0), count(declared.size(), 0.0);
  const int steps = 40000;
  for (int i = 1; i <= steps; ++i)
    for (const ParticleSpec& p : feeder.take_due(to_s * i / steps, empty, box)) {
      const std::size_t slot = std::size_t(psd_slot(edges, p.diameter_m));
      inserted[slot] += sphere_mass_kg(density, p.diameter_m);
      count[slot] += 1.0;
    }
  for (std::size_t slot = 0; slot < declared.size(); ++slot) {
    const double expected_kg = declared[slot] * (to_s - from_s);
    if (expected_kg == 0.0) {
      EXPECT_EQ(inserted[slot], 0.0) << "slot " << slot;
      continue;
    }
    // The particles in a slot are a Poisson count of about similar masses: a relative error of
    // about 1/√n. Five of those.
    ASSERT_GT(count[slot], 100.0) << "slot " << slot;
    EXPECT_NEAR(inserted[slot] / expected_kg, 1.0, 5.0 / std::sqrt(count[slot])) << "slot " << slot;
  }
}

}  // namespace
}  // namespace millsim
