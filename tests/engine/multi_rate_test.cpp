// Multi-rate stepping (sim/multi_rate.h): particles in free flight take a long step of their own.
// Checked against the single-rate run of the same scene: a free flight that ends in a contact
// (pair and wall) rebounds as in single-rate, a run where every particle has a partner is
// single-rate bit for bit, and a particle settling in a gas reaches the same terminal speed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "gas/gas_config.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

Simulation& run_through(Simulation& sim) {
  // One call: the free particles wait as long as the rule lets them.
  EXPECT_FALSE(sim.advance(sim.total_steps() - sim.step_index()));
  return sim;
}

double relative_difference(const Vec3& a, const Vec3& b) {
  return norm(a - b) / std::max(norm(b), 1e-300);
}

// Two spheres 40 diameters apart close head-on at 2 m/s each, touch, and rebound; without
// gravity or gas their flight is force-free, and with gas it is slowed by drag.
SceneConfig head_on_pair(bool multi_rate, bool with_gas) {
  const double d = 1e-3, box = 0.1;
  SceneConfig scene = test::empty_scene({0, 0, 0}, {box, 0.01, 0.01}, test::table1_material(0.5));
  test::add_particle(scene, {0.03, 0.005, 0.005}, {2, 0, 0}, d);
  test::add_particle(scene, {0.07, 0.005, 0.005}, {-2, 0, 0}, d);
  scene.time.end_s = 0.012;  // they meet at about 9.75 ms
  scene.time.multi_rate = multi_rate;
  if (with_gas) {
    GasConfig gas;
    gas.cells = {4, 1, 1};
    gas.two_way = false;
    scene.gas = gas;
  }
  return scene;
}

TEST(MultiRate, APairMeetingAfterAFreeFlightReboundsAsInSingleRate) {
  for (const bool with_gas : {false, true}) {
    SCOPED_TRACE(with_gas ? "in still air" : "in vacuum");
    Simulation single(head_on_pair(false, with_gas)), multi(head_on_pair(true, with_gas));
    run_through(single);
    run_through(multi);
    const MultiRate* m = multi.multi_rate();
    ASSERT_NE(m, nullptr);
    ASSERT_EQ(single.multi_rate(), nullptr);
    // Most of the flight was taken at the long step, and the contact at the contact step.
    EXPECT_GT(m->stats.waiting_particle_steps, 0.8 * 2.0 * double(multi.total_steps()));
    EXPECT_GT(multi.particle_steps(), 0.0);
    for (std::size_t i = 0; i < 2; ++i) {
      const Vec3 v_single = single.particles().motion[i].velocity_m_per_s;
      const Vec3 v_multi = multi.particles().motion[i].velocity_m_per_s;
      // They rebounded: each moves away from the middle.
      EXPECT_LT(v_single.x * (i == 0 ? 1.0 : -1.0), 0.0);
      EXPECT_LT(relative_difference(v_multi, v_single), 1e-6)
          << "particle " << i << ": " << v_multi.x << " against " << v_single.x << " m/s";
      EXPECT_LT(norm(multi.particles().position_m[i] - single.particles().position_m[i]), 1e-9);
    }
  }
}

// A sphere dropped 20 mm in vacuum falls freely, then bounces on the floor: the wall contact
// comes after a long free flight under gravity.
SceneConfig drop_on_floor(bool multi_rate) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {0.01, 0.01, 0.03}, test::table1_material(0.5),
                                        {true, true, false});
  test::add_particle(scene, {0.005, 0.005, 0.0205}, {}, 1e-3);
  scene.gravity_m_per_s2 = {0, 0, -9.81};
  scene.time.end_s = 0.066;  // falls 20 mm in 63.9 ms, bounces at 0.31 m/s
  scene.time.multi_rate = multi_rate;
  return scene;
}

TEST(MultiRate, AWallContactAfterAFreeFallReboundsAsInSingleRate) {
  Simulation single(drop_on_floor(false)), multi(drop_on_floor(true));
  run_through(single);
  run_through(multi);
  const Vec3 v_single = single.particles().motion[0].velocity_m_per_s;
  const Vec3 v_multi = multi.particles().motion[0].velocity_m_per_s;
  ASSERT_GT(v_single.z, 0.0) << "the sphere must have bounced";
  EXPECT_LT(relative_difference(v_multi, v_single), 1e-6)
      << v_multi.z << " against " << v_single.z << " m/s";
  EXPECT_GT(multi.multi_rate()->stats.waiting_particle_steps, 0.8 * double(multi.total_steps()));
}

TEST(MultiRate, WhereEveryParticleHasAPartnerTheRunIsSingleRateBitForBit) {
  // 4000 spheres of 0.5 mm in a periodic 10 mm cube (solids fraction 0.26) with a 1 mm skin:
  // about 56 centres lie within reach of each, so none is ever in free flight.
  SizeDistribution sizes;
  sizes.kind = SizeDistributionKind::Fixed;
  sizes.diameter_m = 5e-4;
  auto scene = [&](bool multi_rate) {
    SceneConfig s =
        test::periodic_random_gas(0.01, 4000, sizes, 0.5, test::table1_material(0.7, 0.3), 11);
    s.search.skin_m = 1e-3;
    s.time.end_s = 2e-4;
    s.time.multi_rate = multi_rate;
    return s;
  };
  Simulation single(scene(false)), multi(scene(true));
  run_through(single);
  run_through(multi);
  ASSERT_GT(single.contact_steps(), 0u);
  EXPECT_EQ(multi.multi_rate()->stats.waiting_particle_steps, 0.0);
  EXPECT_EQ(multi.multi_rate()->stats.long_steps, 0.0);
  const ParticleStore &a = single.particles(), &b = multi.particles();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.position_m.data(), b.position_m.data(), a.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.motion.data(), b.motion.data(), a.size() * sizeof(Motion)), 0);
  EXPECT_EQ(std::memcmp(a.load.data(), b.load.data(), a.size() * sizeof(Load)), 0);
  EXPECT_EQ(single.neighbors().stats().rebuilds, multi.neighbors().stats().rebuilds);
  EXPECT_EQ(single.contact_steps(), multi.contact_steps());
}

// One 50 µm salt particle released from rest in still air (a periodic column): 8 relaxation
// times later its speed against the single-rate run's and Stokes's terminal speed with
// Schiller–Naumann's correction (Re ≈ 0.5 here).
TEST(MultiRate, ASettlingParticleReachesTheSingleRateTerminalSpeed) {
  const double d = 5e-5, rho_p = 2160.0, mu = 1.8e-5, rho_g = 1.2, g = 9.81;
  auto settle = [&](bool multi_rate) {
    MaterialConfig salt = test::table1_material();
    salt.density_kg_per_m3 = rho_p;
    SceneConfig scene = test::empty_scene({0, 0, 0}, {0.01, 0.01, 0.01}, salt, {true, true, true});
    test::add_particle(scene, {0.005, 0.005, 0.005}, {}, d);
    scene.gravity_m_per_s2 = {0, 0, -g};
    scene.time.end_s = 8.0 * rho_p * d * d / (18.0 * mu);
    scene.time.multi_rate = multi_rate;
    GasConfig gas;
    gas.cells = {1, 1, 1};
    gas.two_way = false;
    gas.density_kg_per_m3 = rho_g;
    gas.viscosity_pa_s = mu;
    scene.gas = gas;
    auto sim = std::make_unique<Simulation>(scene);
    run_through(*sim);
    return sim;
  };
  const auto single = settle(false), multi = settle(true);
  const double v_single = -single->particles().motion[0].velocity_m_per_s.z;
  const double v_multi = -multi->particles().motion[0].velocity_m_per_s.z;
  // Terminal speed: (ρp − ρg) g V = 3π μ d v (1 + 0.15 Re^0.687), by fixed-point iteration.
  double v_t = (rho_p - rho_g) * g * d * d / (18.0 * mu);
  for (int k = 0; k < 100; ++k)
    v_t = (rho_p - rho_g) * g * d * d / (18.0 * mu) /
          (1.0 + 0.15 * std::pow(rho_g * d * v_t / mu, 0.687));
  std::printf("terminal speed %.6f m/s: single-rate %.6f, multi-rate %.6f (%+.4f %%)\n", v_t,
              v_single, v_multi, 100.0 * (v_multi / v_single - 1.0));
  EXPECT_NEAR(v_multi, v_single, 0.005 * v_single);
  EXPECT_NEAR(v_multi, v_t, 0.01 * v_t);
  // Nothing to touch: every step but the catch-ups was waited.
  const MultiRate& m = *multi->multi_rate();
  EXPECT_GT(m.stats.waiting_particle_steps, 0.95 * double(multi->total_steps()));
}

}  // namespace
}  // namespace millsim
