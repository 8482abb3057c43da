// Wall riders (sim/multi_rate.h, /time/wall_riders): a particle whose only candidates are walls
// steps at the step its own size allows, in powers of two of the run's step. Checked against
// Hertz's static overlap of a sphere resting on a floor, against the single-rate run of the
// same scenes (a sphere resting and one bouncing), and bit for bit against multi-rate stepping
// without riders where no particle may take a longer step than the run's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kBig = 1e-3, kSmall = 1e-4;  // diameters (m)

// A 10 mm periodic floor cell (walls at z = 0 and 10 mm) under gravity: a 1 mm sphere at height
// `z_m` moving down at `speed`, and a 0.1 mm sphere resting on the floor 5 mm away, which sets
// the run's step (about ten times shorter than the large one's own).
SceneConfig floor_pair(double z_m, double speed_m_per_s, double end_s, bool riders) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {0.01, 0.01, 0.01}, test::table1_material(0.5),
                                        {true, true, false});
  test::add_particle(scene, {0.0025, 0.005, z_m}, {0, 0, -speed_m_per_s}, kBig);
  test::add_particle(scene, {0.0075, 0.005, 0.5 * kSmall}, {}, kSmall);
  scene.gravity_m_per_s2 = {0, 0, -9.81};
  scene.time.end_s = end_s;
  scene.time.multi_rate = true;
  scene.time.wall_riders = riders;
  return scene;
}

std::size_t slot_of_diameter(const ParticleStore& p, double d) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (std::abs(2.0 * p.radius_m[i] - d) < 1e-12) return i;
  ADD_FAILURE() << "no particle of diameter " << d;
  return 0;
}

Simulation& run_through(Simulation& sim) {
  EXPECT_FALSE(sim.advance(sim.total_steps() - sim.step_index()));
  return sim;
}

// Hertz: m g = (4/3) E* √R δ^{3/2}, E* = E / (2 (1 − ν²)) for a sphere on a wall of its material.
double hertz_static_overlap_m(double d) {
  const MaterialConfig m = test::table1_material(0.5);
  const double mass = m.density_kg_per_m3 * M_PI * d * d * d / 6.0;
  const double e_star = m.youngs_modulus_pa / (2.0 * (1.0 - m.poisson_ratio * m.poisson_ratio));
  const double k = 4.0 / 3.0 * e_star * std::sqrt(0.5 * d);
  return std::pow(mass * 9.81 / k, 2.0 / 3.0);
}

TEST(WallRiders, ASphereRestingOnTheFloorStepsOnItsOwnLevelAndSettlesAtHertzsOverlap) {
  // Placed touching the floor at rest: it sinks in, rings and settles (e = 0.5 damps the ringing
  // e^-18-fold in 2 ms).
  Simulation single(floor_pair(0.5 * kBig, 0.0, 2e-3, false));
  Simulation riders(floor_pair(0.5 * kBig, 0.0, 2e-3, true));
  run_through(single);
  run_through(riders);
  const ParticleStore& p = riders.particles();
  const std::size_t big = slot_of_diameter(p, kBig), small = slot_of_diameter(p, kSmall);
  // Its own bound is about ten times the run's (both scale with the diameter): level 3, a step
  // of 8 dt; the small one sets the run's step and steps with it.
  EXPECT_EQ(p.free_flight[big], kRidesWalls + 3);
  EXPECT_EQ(p.free_flight[small], kSteps);
  const MultiRate* m = riders.multi_rate();
  ASSERT_NE(m, nullptr);
  const double steps = double(riders.total_steps());
  EXPECT_NEAR(m->stats.rider_steps, steps / 8.0, 0.02 * steps / 8.0);
  EXPECT_NEAR(m->stats.rider_waited_steps, steps * 7.0 / 8.0, 0.02 * steps);
  const double expected = hertz_static_overlap_m(kBig);
  const double overlap = 0.5 * kBig - p.position_m[big].z;
  EXPECT_NEAR(overlap, expected, 1e-3 * expected) << "Hertz's static overlap " << expected << " m";
  const ParticleStore& s = single.particles();
  const double single_overlap = 0.5 * kBig - s.position_m[slot_of_diameter(s, kBig)].z;
  EXPECT_NEAR(overlap, single_overlap, 1e-6 * expected);
  EXPECT_LT(std::abs(p.motion[big].velocity_m_per_s.z), 1e-9);
  std::printf(
      "static overlap: Hertz %.6e m, own step %.6e m, single step %.6e m; %.0f own "
      "steps of %.0f\n",
      expected, overlap, single_overlap, m->stats.rider_steps, steps);
}

TEST(WallRiders, ABounceOnItsOwnStepReboundsAsTheSingleStepOne) {
  // Dropped at 0.3 m/s from 0.2 mm above the floor: it rides the floor on its own step through
  // the contact (its own 20 steps per contact) and leaves at half its speed (e = 0.5).
  auto rebound = [](bool riders) {
    Simulation sim(floor_pair(0.5 * kBig + 2e-4, 0.3, 2.5e-3, riders));
    run_through(sim);
    const ParticleStore& p = sim.particles();
    const std::size_t big = slot_of_diameter(p, kBig);
    const Vec3 v = p.motion[big].velocity_m_per_s;
    return std::make_pair(v.z, sim.multi_rate()->stats.rider_steps);
  };
  const auto [v_single, single_rider_steps] = rebound(false);
  const auto [v_riders, rider_steps] = rebound(true);
  EXPECT_EQ(single_rider_steps, 0.0);
  EXPECT_GT(rider_steps, 0.0);
  ASSERT_GT(v_single, 0.0) << "the sphere must have bounced";
  EXPECT_NEAR(v_riders, v_single, 0.01 * v_single) << v_riders << " against " << v_single << " m/s";
  std::printf(
      "speed 0.3 ms later: single step %.6f m/s, own step %.6f m/s (%+.3f %%), %.0f own "
      "steps\n",
      v_single, v_riders, 100.0 * (v_riders / v_single - 1.0), rider_steps);
}

TEST(WallRiders, WhereNoParticleMayTakeALongerStepTheRunIsUnchangedBitForBit) {
  // Equal spheres: every wall rider's own bound is the run's, so all of them step on level 0.
  auto scene = [](bool riders) {
    SceneConfig s = test::empty_scene({0, 0, 0}, {0.01, 0.01, 0.01}, test::table1_material(0.5),
                                      {true, true, false});
    for (int k = 0; k < 5; ++k)
      test::add_particle(s, {0.001 + 0.0018 * k, 0.005, 0.5 * kBig + 1e-4 * k}, {0, 0, -0.1 * k},
                         kBig);
    test::add_particle(s, {0.005, 0.005, 0.006}, {0.2, 0, 0}, kBig);  // in free flight
    s.gravity_m_per_s2 = {0, 0, -9.81};
    s.time.end_s = 2e-3;
    s.time.multi_rate = true;
    s.time.wall_riders = riders;
    return s;
  };
  Simulation plain(scene(false)), riders(scene(true));
  run_through(plain);
  run_through(riders);
  ASSERT_GT(plain.multi_rate()->stats.waiting_particle_steps, 0.0);
  EXPECT_EQ(riders.multi_rate()->stats.rider_steps, 0.0);
  const ParticleStore &a = plain.particles(), &b = riders.particles();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.position_m.data(), b.position_m.data(), a.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.motion.data(), b.motion.data(), a.size() * sizeof(Motion)), 0);
  EXPECT_EQ(plain.neighbors().stats().rebuilds, riders.neighbors().stats().rebuilds);
}

}  // namespace
}  // namespace millsim
