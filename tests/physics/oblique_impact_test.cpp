// Oblique impacts of a sphere on a wall in gross sliding (Maw, Barber & Fawcett 1976; the rigid-
// body limit of the standard oblique-impact benchmarks): when the contact point slides for the
// whole impact, Coulomb friction acts at μ F_n throughout, so the tangential impulse is exactly
// μ times the normal one, J_t = μ J_n with J_n = m (1 + e) v_n, whatever the contact law's
// stiffness and damping. A sphere slides throughout when tan θ_in ≥ (7/2) μ (1 + e) (its
// contact point would otherwise stop slipping: the rolling condition v_t = ω r is reached after
// a tangential impulse of (2/7) m v_t). Checked over restitutions 0.1–1 and incidence angles
// across the sliding regime.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

struct SlidingImpact {
  double tangential_over_mu_normal = 0.0;  // J_t / (μ J_n)
  double normal_restitution = 0.0;
};

SlidingImpact oblique_wall_impact(double e, double mu, double tan_incidence) {
  const double d = 1e-4, v_n = 2.0, v_t = tan_incidence * v_n;
  SceneConfig s =
      test::empty_scene({-1e-2, -1e-3, 0}, {1e-2, 1e-3, 2e-3}, test::table1_material(e, mu));
  test::add_particle(s, {0, 0, 0.55 * d}, {v_t, 0, -v_n}, d);
  s.time.step_s = 2e-9;  // about 60 steps per contact
  Simulation sim(s);
  double m = sim.particles().mass_kg[0];
  bool touched = false;
  for (int step = 0; step < 200000; ++step) {
    EXPECT_FALSE(sim.step().has_value());
    const bool touching = sim.particles().position_m[0].z < 0.5 * d;
    touched = touched || touching;
    if (touched && !touching) break;
  }
  const Vec3 v = sim.particles().motion[0].velocity_m_per_s;
  const double j_n = m * (v.z + v_n), j_t = m * (v_t - v.x);
  return {j_t / (mu * j_n), v.z / v_n};
}

class GrossSliding : public testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(GrossSliding, TangentialImpulseIsMuTimesTheNormalImpulse) {
  const auto [e, excess] = GetParam();
  const double mu = 0.2;
  const double tan_incidence = excess * 3.5 * mu * (1.0 + e);  // `excess` times the threshold
  const SlidingImpact got = oblique_wall_impact(e, mu, tan_incidence);
  EXPECT_NEAR(got.tangential_over_mu_normal, 1.0, 0.01)
      << "e = " << e << ", tan θ = " << tan_incidence;
  EXPECT_NEAR(got.normal_restitution, e, 0.03 * e + 0.005);
}

INSTANTIATE_TEST_SUITE_P(RestitutionsAndAngles, GrossSliding,
                         testing::Combine(testing::Values(0.1, 0.5, 0.9, 1.0),
                                          testing::Values(1.5, 3.0, 10.0)));

}  // namespace
}  // namespace millsim
