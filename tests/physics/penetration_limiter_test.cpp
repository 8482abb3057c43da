// The penetration limiter of §4, Eq. 8.
//   Unit: on a contact past the limit and still closing, the normal relative velocity becomes
//   −e times its value; between two particles momentum is conserved.
//   Whole engine, a deliberately too-soft case: a 10 µm particle (Table 1) softened with a
//   threshold of 45 µm hits a steel wall at 40 m/s. Unlimited it penetrates ≈ 28 % (Eq. 13
//   predictor); with the limiter it stops near 15 %, and its rebound lies between e·v_L (the
//   reversed speed at the firing instant; the spring still pushes outward afterwards) and the
//   speed that e·V plus all the elastic energy stored at the deepest point would give.
#include <gtest/gtest.h>

#include <cmath>

#include "contact/penetration_limit.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

TEST(PenetrationLimiter, ReversesClosingVelocityTimesRestitutionAndConservesMomentum) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {1, 1, 1}, test::table1_material(0.6));
  const MaterialTable table(scene);
  ParticleStore p;
  p.add(table, 0, 1, {0.5, 0.5, 0.5}, {3.0, 1.0, 0.0}, {}, 0.2);
  p.add(table, 0, 2, {0.6, 0.5, 0.5}, {-1.0, 0.0, 2.0}, {}, 0.1);
  NeighborList nl;
  nl.pairs.push(0, 1);
  nl.pair_history.push_back(kNoHistory);
  ContactStepStats stats;
  stats.pairs_over_limit.push_back(0);
  const Vec3 momentum_before =
      p.motion[0].velocity_m_per_s * p.mass_kg[0] + p.motion[1].velocity_m_per_s * p.mass_kg[1];
  const PeriodicBox box{{0, 0, 0}, {1, 1, 1}, {false, false, false}};
  EXPECT_EQ(apply_penetration_limiter(stats, table, box, {}, nl, p), 1u);
  // n = (x0 − x1)/|…| = −x̂; v_n = (v0 − v1)·n = −4 (closing) → +0.6·4 = 2.4.
  EXPECT_NEAR(dot(p.motion[0].velocity_m_per_s - p.motion[1].velocity_m_per_s, Vec3{-1, 0, 0}), 2.4,
              1e-12);
  const Vec3 momentum_after =
      p.motion[0].velocity_m_per_s * p.mass_kg[0] + p.motion[1].velocity_m_per_s * p.mass_kg[1];
  EXPECT_NEAR(norm(momentum_after - momentum_before), 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(p.motion[0].velocity_m_per_s.y, 1.0) << "tangential velocity untouched";
  // Already separating: nothing happens.
  EXPECT_EQ(apply_penetration_limiter(stats, table, box, {}, nl, p), 0u);
}

SceneConfig soft_impact(bool limiter) {
  MaterialConfig steel{"steel", 210e9, 0.3, 7800, 0.5, 0.0, 0.0, false, {}};
  SceneConfig s =
      test::empty_scene({-1e-3, -1e-3, 0}, {1e-3, 1e-3, 1e-3}, test::table1_material(0.5));
  s.materials.push_back(steel);
  s.domain.wall_material = 1;
  s.contact.max_impact_speed_m_per_s = 40.0;
  s.contact.reduced_stiffness = ReducedStiffnessConfig{45e-6};
  s.contact.penetration_limiter = limiter;
  s.contact.penetration_limit = limiter ? 0.15 : 0.45;  // without: let it go to the predicted depth
  s.time.end_s = 1e-4;
  test::add_particle(s, {0, 0, 0.5 * 10e-6 * 1.0001}, {0, 0, -40.0}, 10e-6);
  return s;
}

TEST(PenetrationLimiter, TooSoftImpactIsStoppedNearTheLimitAndRebounds) {
  const double d = 10e-6, v = 40.0, e = 0.5;
  double unlimited_max = 0.0;
  {
    Simulation sim(soft_impact(false));
    const ParticleStore& p = sim.particles();
    while (p.motion[0].velocity_m_per_s.z < 0.0 || unlimited_max == 0.0) {
      ASSERT_FALSE(sim.step().has_value());
      unlimited_max = std::max(unlimited_max, p.radius_m[0] - p.position_m[0].z);
    }
    EXPECT_NEAR(unlimited_max / d, sim.reduced_stiffness()->predicted_penetration_ratio, 0.01);
    EXPECT_GT(unlimited_max / d, 0.25) << "the case must be too soft for a 15 % limit";
  }
  Simulation sim(soft_impact(true));
  const ParticleStore& p = sim.particles();
  const double step_travel = v * sim.time_step().step_s / d;
  double max_ratio = 0.0, speed_after_firing = 0.0;
  while (!(p.position_m[0].z > p.radius_m[0] && p.motion[0].velocity_m_per_s.z > 0.0)) {
    const std::uint64_t before = sim.penetration_limiter_events();
    ASSERT_FALSE(sim.step().has_value());
    max_ratio = std::max(max_ratio, (p.radius_m[0] - p.position_m[0].z) / d);
    if (sim.penetration_limiter_events() > before)
      speed_after_firing = p.motion[0].velocity_m_per_s.z;
  }
  EXPECT_EQ(sim.penetration_limiter_events(), 1u);
  EXPECT_LT(max_ratio, 0.15 + step_travel);
  EXPECT_GT(speed_after_firing, 0.0) << "reversed at the firing step";
  // Upper bound: e·V plus the elastic energy stored at the deepest point, all returned.
  const double r = 0.5 * d, mass = 2000.0 * 4.0 / 3.0 * M_PI * r * r * r;
  const double scale = std::pow(d / 45e-6, 2.5);
  const double e_star = 1.0 / ((1 - 0.09) / (scale * 1e9) + (1 - 0.09) / 210e9);
  const double k = 4.0 / 3.0 * e_star * std::sqrt(r), delta = max_ratio * d;
  const double elastic = 0.4 * k * std::pow(delta, 2.5);
  const double rebound = p.motion[0].velocity_m_per_s.z;
  EXPECT_GE(rebound, speed_after_firing);
  EXPECT_LE(rebound, std::sqrt(e * e * v * v + 2.0 * elastic / mass));
  std::printf("too-soft impact: limiter fired at %.1f %% overlap; rebound %.2f m/s = %.3f e V\n",
              100.0 * max_ratio, rebound, rebound / (e * v));
}

TEST(PenetrationLimiter, TheAutomaticStepKeepsAHeadOnPairAtTheDeclaredSpeedBelowTheGuard) {
  // The classification case's fines: 1 µm, E = 1 MPa, so soft that Hertz alone would let a pair
  // closing at 120 m/s overlap several diameters; only the limiter holds them. It acts once per
  // step, so the deepest overlap is the limit plus one step's travel, and the automatic step
  // keeps that travel within the limit (dt = limit · d / V): the pair stays below twice the limit,
  // where the guard would stop the run. The contact-time bound alone gives a step of about
  // 4e-9 s here, a travel of 49 % of the diameter per step.
  MaterialConfig fine = test::table1_material(0.5);
  fine.youngs_modulus_pa = 1e6;
  SceneConfig s = test::empty_scene({-1e-5, -1e-5, -1e-5}, {1e-5, 1e-5, 1e-5}, fine);
  const double d = 1e-6, v = 120.0, limit = 0.15;
  s.contact.max_impact_speed_m_per_s = v;
  s.contact.penetration_limit = limit;
  s.time.end_s = 1e-6;
  test::add_particle(s, {-0.5 * d * 1.0001, 0, 0}, {0.5 * v, 0, 0}, d);
  test::add_particle(s, {0.5 * d * 1.0001, 0, 0}, {-0.5 * v, 0, 0}, d);
  Simulation sim(s);
  const TimeStepInfo& ts = sim.time_step();
  EXPECT_GT(ts.bounds.contact_s / s.time.steps_per_contact, 3.0 * ts.travel_bound_s)
      << "the travel bound is the one that binds here";
  EXPECT_NEAR(ts.step_s, limit * d / v, 1e-12 * limit * d / v);
  const ParticleStore& p = sim.particles();
  double deepest = 0.0;
  while (!(p.position_m[1].x - p.position_m[0].x > d && sim.step_index() > 0)) {
    ASSERT_FALSE(sim.step().has_value())
        << "the guard stopped the run at step " << sim.step_index();
    deepest = std::max(deepest, (d - (p.position_m[1].x - p.position_m[0].x)) / d);
  }
  EXPECT_GT(sim.penetration_limiter_events(), 0u);
  EXPECT_GT(deepest, limit) << "the limiter, not the spring, stopped the pair";
  EXPECT_LE(deepest, limit + v * ts.step_s / d + 1e-12);
  EXPECT_LT(deepest, 2.0 * limit);
}

}  // namespace
}  // namespace millsim
