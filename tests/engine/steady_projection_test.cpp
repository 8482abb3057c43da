// The steady-state projection (process/steady_projection.h, issue 31) on compartments whose
// balance has a closed form.
//
// - A chain: feed F into A, A breaks at k into B, B leaves at E. Steady: M_A = F/k, M_B = F/E,
//   the product F at B's size. From empty, the outflow is
//   F [1 − (k e^{−E t} − E e^{−k t}) / (k − E)], which first reaches 90 % of the feed at the root
//   found here by bisection.
// - The same with E = 0: B receives mass and never loses it; no steady state, and B is named.
// - Dust counted when made (the table's): B holds nothing and passes what it receives, so the
//   outflow is F (1 − e^{−k t}), 90 % at ln 10 / k.
// - Two ways out of B (the outlet at E, breakage into dust at k_B): the product's share at B's
//   size is E / (E + k_B), known only as well as the counts of outlet particles and events; the
//   spread of d50 over redrawn rates narrows as the counts grow.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>

#include "process/mass_flows.h"
#include "process/steady_projection.h"

namespace millsim {
namespace {

// Edges of 3 classes: slots 0 (under), 1–3, 4 (over).
const std::vector<double> kEdges = {1e-6, 2e-6, 4e-6, 8e-6};

// Flows over a window of `window_s` in which compartment `c` held `held_kg` throughout.
void hold(MassFlows& f, int c, double held_kg, double window_s) {
  f.held_kg_s[std::size_t(c)] += held_kg * window_s;
}

// Feed F into A (particles, slot 3), A → B at k, B leaves at E: a window of one second.
MassFlows chain_flows(double feed, double k, double leave, int b, double window_s = 1.0) {
  MassFlows f = make_mass_flows(kEdges);
  const int a = 3;
  const double held_a = feed / k, held_b = leave > 0.0 ? feed / leave : 1e-7;
  f.fed_kg[std::size_t(a)] = feed * window_s;
  hold(f, a, held_a, window_s);
  f.moved(a, b) = k * held_a * window_s;
  f.events[std::size_t(a)] = 1000.0;
  hold(f, b, held_b, window_s);
  f.left_kg[std::size_t(b)] = leave * held_b * window_s;
  return f;
}

double chain_outflow_share(double k, double e, double t) {
  return 1.0 - (k * std::exp(-e * t) - e * std::exp(-k * t)) / (k - e);
}

TEST(SteadyProjection, AChainOfTwoCompartmentsReachesItsAnalyticSteadyState) {
  const double feed = 2e-6, k = 50.0, e = 5.0;
  const int b = MassFlows::dust(2, make_mass_flows(kEdges).slots);  // dust of slot 2
  // The window's flows as a run accumulates them: a later state less an earlier one.
  const MassFlows earlier = make_mass_flows(kEdges);
  MassFlows later = chain_flows(feed, k, e, b, 0.5);
  const CompartmentRates r = fit_rates(flows_between(earlier, later), 0.5);
  EXPECT_NEAR(r.out_per_s(3, 0.0), k, 1e-12 * k);
  EXPECT_NEAR(r.leave_per_s[std::size_t(b)], e, 1e-12 * e);
  const std::vector<double> empty(std::size_t(r.compartments()), 0.0);
  const SteadyProjection p = project_steady(r, empty);
  ASSERT_TRUE(p.exists);
  EXPECT_NEAR(p.held_kg[3], feed / k, 1e-12 * feed / k);
  EXPECT_NEAR(p.held_kg[std::size_t(b)], feed / e, 1e-12 * feed / e);
  EXPECT_NEAR(p.product_kg_per_s[2], feed, 1e-12 * feed);
  // 90 % of the feed: bisection on the closed form.
  double lo = 0.0, hi = 10.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chain_outflow_share(k, e, mid) < 1.0 - kProjectionSteadyTolerance ? lo : hi) = mid;
  }
  ASSERT_GT(p.horizon_s, 0.0);
  const double resolution = p.horizon_s / 4000.0;
  EXPECT_GE(p.time_to_steady_s, hi - 1e-9);
  EXPECT_LE(p.time_to_steady_s, hi + resolution + 1e-9);
  // The course follows the closed form at every kept point.
  ASSERT_GT(p.course_time_s.size(), 10u);
  for (std::size_t i = 0; i < p.course_time_s.size(); ++i)
    EXPECT_NEAR(p.course_outflow_to_feed[i], chain_outflow_share(k, e, p.course_time_s[i]), 1e-9)
        << "t = " << p.course_time_s[i];
}

TEST(SteadyProjection, ACompartmentThatNeitherBreaksNorLeavesAccumulates) {
  const int b = MassFlows::dust(2, make_mass_flows(kEdges).slots);
  const CompartmentRates r = fit_rates(chain_flows(2e-6, 50.0, 0.0, b), 1.0);
  const SteadyProjection p =
      project_steady(r, std::vector<double>(std::size_t(r.compartments()), 0.0));
  EXPECT_FALSE(p.exists);
  ASSERT_EQ(p.accumulating.size(), 1u);
  EXPECT_EQ(p.accumulating[0], b);
  EXPECT_LT(p.time_to_steady_s, 0.0);
  // Held at a given hold-up instead (what a hold-up fill does with such a class): the rest of the
  // chain has its steady state, A holding F/k, and B keeps what it was given and what A sends it.
  CompartmentRates fixed = r;
  fixed.fixed_held_kg.assign(std::size_t(r.compartments()), -1.0);
  fixed.fixed_held_kg[std::size_t(b)] = 3e-9;
  const SteadyProjection q =
      project_steady(fixed, std::vector<double>(std::size_t(r.compartments()), 0.0));
  EXPECT_TRUE(q.exists);
  EXPECT_TRUE(q.accumulating.empty());
  EXPECT_EQ(q.fixed, std::vector<int>{b});
  EXPECT_NEAR(q.held_kg[3], 2e-6 / 50.0, 1e-12 * 2e-6 / 50.0);
  EXPECT_EQ(q.held_kg[std::size_t(b)], 3e-9);
  double product = 0.0;
  for (double kg_per_s : q.product_kg_per_s) product += kg_per_s;
  EXPECT_EQ(product, 0.0) << "nothing leaves: B keeps what it receives";
}

// A compartment held at a given hold-up (a hold-up fill does so with a class counted too few
// times) passes mass on at its measured rate times that hold-up: with A held at M, B receives
// k M and holds k M / E, and the product is k M, whatever the feed.
TEST(SteadyProjection, ACompartmentHeldAtAGivenHoldUpPassesMassOnAtItsRates) {
  const double feed = 2e-6, k = 50.0, e = 5.0, held_a = 7e-8;
  const int b = MassFlows::dust(2, make_mass_flows(kEdges).slots);
  CompartmentRates r = fit_rates(chain_flows(feed, k, e, b), 1.0);
  r.fixed_held_kg.assign(std::size_t(r.compartments()), -1.0);
  r.fixed_held_kg[3] = held_a;
  const SteadyProjection p =
      project_steady(r, std::vector<double>(std::size_t(r.compartments()), 0.0));
  ASSERT_TRUE(p.exists);
  EXPECT_EQ(p.fixed, std::vector<int>{3});
  EXPECT_EQ(p.held_kg[3], held_a);
  EXPECT_NEAR(p.held_kg[std::size_t(b)], k * held_a / e, 1e-12 * k * held_a / e);
  EXPECT_NEAR(p.product_kg_per_s[2], k * held_a, 1e-12 * k * held_a);
  EXPECT_NEAR(p.feed_kg_per_s, feed, 1e-12 * feed) << "the feed is still the feed";
}

TEST(SteadyProjection, DustCountedWhenMadePassesStraightToTheProduct) {
  const double feed = 2e-6, k = 50.0;
  MassFlows f = make_mass_flows(kEdges);
  const int b = MassFlows::dust(2, f.slots);
  f.fed_kg[3] = feed;
  hold(f, 3, feed / k, 1.0);
  f.moved(3, b) = feed;  // into the table: held by nobody
  const CompartmentRates r = fit_rates(f, 1.0);
  EXPECT_TRUE(r.pass_through[std::size_t(b)]);
  const SteadyProjection p =
      project_steady(r, std::vector<double>(std::size_t(r.compartments()), 0.0));
  ASSERT_TRUE(p.exists);
  EXPECT_NEAR(p.product_kg_per_s[2], feed, 1e-12 * feed);
  EXPECT_EQ(p.held_kg[std::size_t(b)], 0.0);
  const double exact = std::log(10.0) / k;
  EXPECT_GE(p.time_to_steady_s, exact - 1e-12);
  EXPECT_LE(p.time_to_steady_s, exact + p.horizon_s / 4000.0 + 1e-12);
}

// B (particles, slot 2) fed at F leaves through the outlet at E or breaks at k_B into dust of
// slot 1 that leaves at once; its counts over the window are `count` of each.
CompartmentRates two_ways_out(double count) {
  const double feed = 1e-6, e = 20.0, k_b = 20.0;
  MassFlows f = make_mass_flows(kEdges);
  const int b = 2, dust = MassFlows::dust(1, f.slots);
  const double held = feed / (e + k_b);
  f.fed_kg[std::size_t(b)] = feed;
  hold(f, b, held, 1.0);
  f.left_kg[std::size_t(b)] = e * held;
  f.left_count[std::size_t(b)] = count;
  f.moved(b, dust) = k_b * held;
  f.events[std::size_t(b)] = count;
  return fit_rates(f, 1.0);
}

TEST(SteadyProjection, ItsSpreadNarrowsAsTheCountsGrow) {
  const CompartmentRates few = two_ways_out(4.0), many = two_ways_out(1e6);
  const std::vector<double> empty(std::size_t(few.compartments()), 0.0);
  const SteadyProjection p = project_steady(many, empty);
  ASSERT_TRUE(p.exists);
  EXPECT_NEAR(p.product_kg_per_s[2] / p.feed_kg_per_s, 0.5, 1e-12) << "E / (E + k_B)";
  const ProjectionSpread narrow = projection_spread(many, empty, kEdges, 200, 7);
  const ProjectionSpread wide = projection_spread(few, empty, kEdges, 200, 7);
  ASSERT_EQ(narrow.draws_steady, 200);
  ASSERT_EQ(wide.draws_steady, 200);
  ASSERT_EQ(narrow.d50_m.size(), 3u);
  ASSERT_EQ(wide.d50_m.size(), 3u);
  // d50 of a product half in [1, 2) µm and half in [2, 4) µm: 2 µm.
  EXPECT_NEAR(narrow.d50_m[1], 2e-6, 0.01 * 2e-6);
  EXPECT_LT(narrow.d50_m[2] / narrow.d50_m[0], 1.01);
  EXPECT_GT(wide.d50_m[2] / wide.d50_m[0], 1.3);
  EXPECT_LE(wide.d50_m[0], 2e-6);
  EXPECT_GE(wide.d50_m[2], 2e-6);
  // The steady hold-up of B, F / (E + k_B), is as uncertain as its two rates.
  const double held = 1e-6 / 40.0;
  ASSERT_EQ(narrow.held_particles_kg.size(), 3u);
  ASSERT_EQ(wide.held_particles_kg.size(), 3u);
  EXPECT_NEAR(narrow.held_particles_kg[1], held, 0.01 * held);
  EXPECT_LT(narrow.held_particles_kg[2] / narrow.held_particles_kg[0], 1.01);
  EXPECT_GT(wide.held_particles_kg[2] / wide.held_particles_kg[0], 1.5);
  EXPECT_LE(wide.held_particles_kg[0], held);
  EXPECT_GE(wide.held_particles_kg[2], held);
  EXPECT_EQ(narrow.held_dust_kg, std::vector<double>(3, 0.0)) << "the dust leaves at once";
  // The same seed draws the same rates.
  EXPECT_EQ(projection_spread(few, empty, kEdges, 200, 7).d50_m, wide.d50_m);
}

// A fill's rates pooled over windows (time.fill_particle_rate_windows). Particles A (slot 3, beads
// of m each) fed at F break by wall impact at a first-order rate k into dust B, which leaves at a
// rate that changes from window to window (the gas changes as the mill fills). A is held at its
// steady F/k and counts Poisson(k F/k w / m) events a window. The pooled rates take A's from
// every window (Σ moved / Σ ∫M dt, exactly) and B's from the last one. Over many runs, A's
// projection F/k̂ centres on F/k. Its relative spread is 1/√n at n events, so pooling 8 windows
// narrows it by √8 against the last window alone.
MassFlows wall_impact_window(double feed, double k, double bead_kg, double leave_b, double window_s,
                             std::mt19937_64& random) {
  MassFlows f = make_mass_flows(kEdges);
  const int a = 3, b = MassFlows::dust(2, f.slots);
  const double held_a = feed / k;
  const double events =
      double(std::poisson_distribution<long>(k * held_a * window_s / bead_kg)(random));
  f.fed_kg[std::size_t(a)] = feed * window_s;
  hold(f, a, held_a, window_s);
  f.events[std::size_t(a)] = f.wall_events[std::size_t(a)] = events;
  f.moved(a, b) = events * bead_kg;
  hold(f, b, feed / leave_b, window_s);
  f.left_kg[std::size_t(b)] = feed * window_s;
  return f;
}

// What a run accumulates: the flows of `earlier` and `window` summed.
MassFlows summed(const MassFlows& earlier, const MassFlows& window) {
  MassFlows sum = window;
  const auto add = [](std::vector<double>& to, const std::vector<double>& from) {
    for (std::size_t i = 0; i < to.size(); ++i) to[i] += from[i];
  };
  add(sum.fed_kg, earlier.fed_kg), add(sum.left_kg, earlier.left_kg);
  add(sum.held_kg_s, earlier.held_kg_s), add(sum.events, earlier.events);
  add(sum.wall_events, earlier.wall_events), add(sum.moved_kg, earlier.moved_kg);
  return sum;
}

TEST(SteadyProjection, ParticleRatesPooledOverWindowsCountEveryEventAndKeepTheDustsOwn) {
  const double feed = 2e-6, k = 40.0, bead_kg = 1e-9, window_s = 0.004;
  const int a = 3, windows = 8;
  const int b = MassFlows::dust(2, make_mass_flows(kEdges).slots);
  const double steady_a = feed / k;  // 5e-8 kg: 50 beads; 8 events a window
  std::mt19937_64 random(11);
  std::vector<double> single, pooled;
  for (int run = 0; run < 2000; ++run) {
    MassFlows start = make_mass_flows(kEdges), before_last = start, now = start;
    double total_events = 0.0;
    for (int w = 0; w < windows; ++w) {
      const MassFlows window =
          wall_impact_window(feed, k, bead_kg, 10.0 * (w + 1), window_s, random);
      total_events += window.events[std::size_t(a)];
      before_last = now;
      now = summed(now, window);
    }
    CompartmentRates r = fit_rates(flows_between(before_last, now), window_s);
    const CompartmentRates over_all = fit_rates(flows_between(start, now), windows * window_s);
    const double last_leave = r.leave_per_s[std::size_t(b)];
    const std::vector<double> empty(std::size_t(r.compartments()), 0.0);
    const SteadyProjection alone = project_steady(r, empty, 2);
    take_particle_rates(r, over_all);
    ASSERT_EQ(r.events[std::size_t(a)], total_events);
    ASSERT_NEAR(r.out_per_s(a, 0.0), total_events * bead_kg / (windows * window_s * steady_a),
                1e-12 * k);
    ASSERT_EQ(r.leave_per_s[std::size_t(b)], last_leave) << "the dust's rates are the window's";
    ASSERT_NEAR(last_leave, 10.0 * windows, 1e-9 * last_leave);
    if (total_events == 0.0 || !alone.exists) continue;
    const SteadyProjection p = project_steady(r, empty, 2);
    ASSERT_TRUE(p.exists);
    EXPECT_NEAR(p.held_kg[std::size_t(b)], feed / (10.0 * windows), 1e-9 * feed / 80.0);
    single.push_back(std::log(alone.held_kg[std::size_t(a)] / steady_a));
    pooled.push_back(std::log(p.held_kg[std::size_t(a)] / steady_a));
  }
  const auto mean_and_spread = [](const std::vector<double>& v) {
    double sum = 0.0, squares = 0.0;
    for (double x : v) sum += x, squares += x * x;
    const double mean = sum / double(v.size());
    return std::pair{mean, std::sqrt(squares / double(v.size()) - mean * mean)};
  };
  const auto [single_mean, single_spread] = mean_and_spread(single);
  const auto [pooled_mean, pooled_spread] = mean_and_spread(pooled);
  ASSERT_GT(single.size(), 1900u);  // a window counts none with probability e^-8
  // ln(F/k̂) = −ln(n / 64) for n ~ Poisson(64): mean about 1/(2·64), spread 1/8.
  EXPECT_NEAR(pooled_mean, 1.0 / 128.0, 0.01);
  EXPECT_NEAR(pooled_spread, 0.125, 0.015);
  // One window's: Poisson(8), spread of ln about 1/√8 (0.37; the log's skew lifts it).
  EXPECT_GT(single_spread / pooled_spread, 2.5);
  EXPECT_GT(single_mean, pooled_mean) << "few counts bias ln(F/k̂) upwards";
}

// A feed size no particle of which arrived in the last window: A (slot 3) is fed in the span
// before it and held there, breaking at k into dust B that leaves at E; in the last window A
// holds nothing and receives nothing. With the scene's feed F into A the window alone has no
// rates for A (it would accumulate); pooled, A takes the span's and the steady state is F/k.
// A class the span never held (slot 2's particles) takes nothing.
TEST(SteadyProjection, AClassTheSpanHeldButTheWindowDidNotTakesTheSpansRates) {
  const double feed = 2e-6, k = 40.0, e = 10.0, window_s = 0.004;
  const int a = 3, unheld = 2, b = MassFlows::dust(2, make_mass_flows(kEdges).slots);
  MassFlows before = make_mass_flows(kEdges);
  before.fed_kg[std::size_t(a)] = feed * window_s;
  hold(before, a, feed / k, window_s);
  before.moved(a, b) = feed * window_s;
  before.events[std::size_t(a)] = before.wall_events[std::size_t(a)] = 12.0;
  MassFlows last = make_mass_flows(kEdges);  // A empty, B draining
  hold(last, b, feed / e, window_s);
  last.left_kg[std::size_t(b)] = feed * window_s;
  const MassFlows start = make_mass_flows(kEdges), now = summed(summed(start, before), last);

  CompartmentRates r = fit_rates(last, window_s);
  r.feed_kg_per_s[std::size_t(a)] = feed;  // the scene's, not the window's none
  const std::vector<double> empty(std::size_t(r.compartments()), 0.0);
  EXPECT_FALSE(project_steady(r, empty, 2).exists) << "A receives and neither breaks nor leaves";
  take_particle_rates(r, fit_rates(flows_between(start, now), 2.0 * window_s));
  // Over the span A held F/k for half of it and moved F w: k̂ = F w / (F/k w) = k.
  EXPECT_NEAR(r.out_per_s(a, 0.0), k, 1e-12 * k);
  EXPECT_EQ(r.events[std::size_t(a)], 12.0);
  EXPECT_EQ(r.out_per_s(unheld, 0.0), 0.0);
  EXPECT_EQ(r.pass_through[std::size_t(unheld)], 0);
  const SteadyProjection p = project_steady(r, empty, 2);
  ASSERT_TRUE(p.exists);
  EXPECT_NEAR(p.held_kg[std::size_t(a)], feed / k, 1e-12 * feed / k);
  EXPECT_NEAR(p.held_kg[std::size_t(b)], feed / e, 1e-9 * feed / e);
}

// Particles A (slot 3, cross-section a per kg) fed at F break at k into dust of slot 2, which
// the particles grind into dust of slot 1 at g A per second, A = a M_A; dust of slot 1 leaves at
// E. The window saw A at a tenth of its steady hold-up F/k, so its grinding ran at a tenth of
// the steady rate: the steady dust of slot 2 is F / (g a F/k), not F over the window's rate.
TEST(SteadyProjection, DustGroundByTheParticlesIsGroundAsTheyAreAtSteadyState) {
  const double feed = 1e-6, k = 100.0, a = 2.0e3, g = 5.0e3, e = 40.0;
  MassFlows f = make_mass_flows(kEdges);
  const int particles = 3, coarse = MassFlows::dust(2, f.slots), fine = MassFlows::dust(1, f.slots);
  const double held_a = 0.1 * feed / k, held_coarse = 2e-8, held_fine = 3e-8;
  f.fed_kg[std::size_t(particles)] = feed;
  hold(f, particles, held_a, 1.0);
  f.area_m2_s[std::size_t(particles)] = a * held_a;
  f.moved(particles, coarse) = k * held_a;
  f.events[std::size_t(particles)] = 1000.0;
  hold(f, coarse, held_coarse, 1.0);
  f.exposure_kg_m2_s[std::size_t(coarse)] = held_coarse * a * held_a;
  f.moved(coarse, fine) = g * a * held_a * held_coarse;
  hold(f, fine, held_fine, 1.0);
  f.exposure_kg_m2_s[std::size_t(fine)] = held_fine * a * held_a;
  f.left_kg[std::size_t(fine)] = e * held_fine;
  const CompartmentRates r = fit_rates(f, 1.0);
  EXPECT_NEAR(r.grind(coarse, fine), g, 1e-12 * g);
  EXPECT_EQ(r.move(coarse, fine), 0.0);
  EXPECT_NEAR(r.area_per_kg[std::size_t(particles)], a, 1e-12 * a);
  const SteadyProjection p =
      project_steady(r, std::vector<double>(std::size_t(r.compartments()), 0.0));
  ASSERT_TRUE(p.exists);
  const double steady_a = feed / k;
  EXPECT_NEAR(p.area_m2, a * steady_a, 1e-12 * a * steady_a);
  EXPECT_NEAR(p.held_kg[std::size_t(coarse)], feed / (g * a * steady_a), 1e-9 * held_coarse);
  EXPECT_NEAR(p.held_kg[std::size_t(fine)], feed / e, 1e-12 * feed / e);
  EXPECT_NEAR(p.product_kg_per_s[1], feed, 1e-12 * feed);
  // The course ends steady (the outflow within the tolerance long before the horizon).
  ASSERT_FALSE(p.course_outflow_to_feed.empty());
  EXPECT_NEAR(p.course_outflow_to_feed.back(), 1.0, 1e-6);
  EXPECT_GT(p.time_to_steady_s, 0.0);
  EXPECT_LT(p.time_to_steady_s, 0.5 * p.horizon_s);
}

// Particles A (slot 3) fed at F break only by meeting each other: at g A M_A with A = a M_A,
// into dust of slot 2 that leaves at once. Steady: F = g a M_A², M_A = √(F / (g a)). Had a
// wall broken one of every four, the rest at g A: F = (k_w + g a M) M, a quadratic's root.
TEST(SteadyProjection, ParticlesThatBreakByMeetingEachOtherSettleWhereTheirCollisionsTakeTheFeed) {
  const double feed = 1e-6, a = 2.0e3, g = 4.0e6, held_window = 1e-9;
  for (double wall_share : {0.0, 0.25}) {
    MassFlows f = make_mass_flows(kEdges);
    const int particles = 3, dust = MassFlows::dust(2, f.slots);
    // The window: A held at 1e-9 kg, broken at (k_w + g a M) with k_w chosen so that a quarter
    // of the events were by a wall when wall_share is 0.25.
    const double collision_rate = g * a * held_window;
    const double wall_rate = collision_rate * wall_share / (1.0 - wall_share);
    f.fed_kg[std::size_t(particles)] = feed;
    hold(f, particles, held_window, 1.0);
    f.area_m2_s[std::size_t(particles)] = a * held_window;
    f.exposure_kg_m2_s[std::size_t(particles)] = held_window * a * held_window;
    f.moved(particles, dust) = (wall_rate + collision_rate) * held_window;
    f.events[std::size_t(particles)] = 400.0;
    f.wall_events[std::size_t(particles)] = 400.0 * wall_share;
    const CompartmentRates r = fit_rates(f, 1.0);
    EXPECT_NEAR(r.grind(particles, dust), g, 1e-9 * g);
    EXPECT_NEAR(r.move(particles, dust), wall_rate, 1e-9 * (wall_rate + 1.0));
    const SteadyProjection p =
        project_steady(r, std::vector<double>(std::size_t(r.compartments()), 0.0));
    ASSERT_TRUE(p.exists) << wall_share;
    // (g a) M² + k_w M − F = 0.
    const double ga = g * a;
    const double held =
        (-wall_rate + std::sqrt(wall_rate * wall_rate + 4.0 * ga * feed)) / (2.0 * ga);
    EXPECT_NEAR(p.held_kg[std::size_t(particles)], held, 1e-9 * held) << wall_share;
    EXPECT_NEAR(p.area_m2, a * held, 1e-9 * a * held);
    EXPECT_NEAR(p.product_kg_per_s[2], feed, 1e-12 * feed);
    ASSERT_FALSE(p.course_outflow_to_feed.empty());
    EXPECT_NEAR(p.course_outflow_to_feed.back(), 1.0, 1e-3) << "steady by the horizon";
  }
}

TEST(MassFlows, SlotsCoverEveryDiameterOnce) {
  EXPECT_EQ(psd_slot(kEdges, 0.5e-6), 0);
  EXPECT_EQ(psd_slot(kEdges, 1e-6), 1);
  EXPECT_EQ(psd_slot(kEdges, 3.9e-6), 2);
  EXPECT_EQ(psd_slot(kEdges, 4e-6), 3);
  EXPECT_EQ(psd_slot(kEdges, 8e-6), 4);
  EXPECT_EQ(make_mass_flows(kEdges).slots, 5);
  MassFlows f = make_mass_flows(kEdges);
  add_tracked(f, 2, 3.0, 5.0);
  integrate_tracked(f, 0.5);
  add_tracked(f, 2, -1.0, -2.0);
  integrate_tracked(f, 2.0);
  EXPECT_DOUBLE_EQ(f.held_kg_s[2], 3.0 * 0.5 + 2.0 * 1.5);
  EXPECT_DOUBLE_EQ(f.area_m2_s[2], 5.0 * 0.5 + 3.0 * 1.5);
  EXPECT_DOUBLE_EQ(f.exposure_kg_m2_s[2], 3.0 * 5.0 * 0.5 + 2.0 * 3.0 * 1.5);
}

}  // namespace
}  // namespace millsim
