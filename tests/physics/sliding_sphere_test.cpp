// A sphere launched sliding on a floor with no spin: friction μ m g decelerates it and spins it
// up until it rolls without slipping. Rigid-body mechanics gives the rolling speed
// v = (5/7) v₀, reached at t = 2 v₀ / (7 μ g), independent of μ, mass and radius.
// Checks the tangential spring, Coulomb limit, torque arm and rotational integration together.
#include <gtest/gtest.h>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

class SlidingSphere : public testing::TestWithParam<double> {};  // friction coefficient

TEST_P(SlidingSphere, EndsRollingAtFiveSeventhsOfLaunchSpeed) {
  const double mu = GetParam(), v0 = 0.1, g = 9.81, d = 1e-3, r = 0.5 * d;
  SceneConfig s =
      test::empty_scene({-0.05, -0.05, 0}, {0.05, 0.05, 0.01}, test::table1_material(0.5, mu));
  s.gravity_m_per_s2 = {0, 0, -g};
  // Start resting at the static overlap m g = k δ^{3/2}, so no bounce disturbs the slide.
  const double k = 4.0 / 3.0 * (1e9 / (2.0 * (1.0 - 0.09))) * std::sqrt(r);
  const double mass = 2000.0 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
  const double static_overlap = std::pow(mass * g / k, 2.0 / 3.0);
  test::add_particle(s, {0, 0, r - static_overlap}, {v0, 0, 0}, d);
  const double t_roll = 2.0 * v0 / (7.0 * mu * g);
  s.time.end_s = 2.0 * t_roll;
  Simulation sim(s);
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step().has_value());
  const ParticleStore& p = sim.particles();
  EXPECT_NEAR(p.motion[0].velocity_m_per_s.x, 5.0 / 7.0 * v0, 0.01 * v0);
  // Rolling without slip: ω_y r = v_x (right-handed, rolling along +x means ω along +y).
  EXPECT_NEAR(p.motion[0].angular_velocity_rad_per_s.y * r, p.motion[0].velocity_m_per_s.x,
              0.01 * v0);
  // Distance slid: x = v₀ t_r − ½ μ g t_r² during sliding, then 5/7 v₀ (t − t_r).
  const double x_expected = v0 * t_roll - 0.5 * mu * g * t_roll * t_roll + 5.0 / 7.0 * v0 * t_roll;
  EXPECT_NEAR(p.position_m[0].x, x_expected, 0.02 * x_expected);
}

INSTANTIATE_TEST_SUITE_P(Frictions, SlidingSphere, testing::Values(0.1, 0.3, 0.6));

}  // namespace
}  // namespace millsim
