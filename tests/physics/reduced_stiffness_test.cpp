// Reduced stiffness (§4, Eq. 6–7) at the salt example of Fig. 9: a salt particle (NaCl:
// E = 40 GPa, ν = 0.25, ρ = 2165 kg/m³; e = 0.5) hitting a steel wall (E = 210 GPa, ν = 0.3)
// at 40 m/s, penetration limit 15 % of the diameter, damping α = 2γ so that Eq. 13 applies.
// Expectations, computed here by hand from Eq. 13 and the Hertz contact time:
//   the automatic threshold d_th makes the smallest particle's predicted δ_max/d exactly 0.15,
//   and it is the largest such threshold;
//   the time-step gain is the ratio of the automatic steps min(0.2 t_R, t_c/20) of the smallest
//   particle with and without the reduction;
//   simulating that impact at a tenth of the largest accepted step penetrates 15 % (± 0.5 %).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kSaltE = 40e9, kSaltNu = 0.25, kSaltRho = 2165, kE = 0.5;
constexpr double kSteelE = 210e9, kSteelNu = 0.3, kSpeed = 40.0, kDmin = 8e-6;

SceneConfig salt_scene(double safety_factor, double steps_per_contact) {
  MaterialConfig salt{"salt", kSaltE, kSaltNu, kSaltRho, kE, 0.0, 0.0, false, {}};
  MaterialConfig steel{"steel", kSteelE, kSteelNu, 7800, kE, 0.0, 0.0, false, {}};
  SceneConfig s = test::empty_scene({-1e-3, -1e-3, 0}, {1e-3, 1e-3, 1e-3}, salt);
  s.materials.push_back(steel);
  s.domain.wall_material = 1;
  s.contact.damping = DampingModel::Paper;
  s.contact.max_impact_speed_m_per_s = kSpeed;
  s.contact.penetration_limiter = false;
  s.contact.reduced_stiffness = ReducedStiffnessConfig{};  // automatic threshold
  s.time.safety_factor = safety_factor;
  s.time.steps_per_contact = steps_per_contact;
  s.time.end_s = 1e-4;
  test::add_particle(s, {0, 0, 0.5 * kDmin * 1.0001}, {0, 0, -kSpeed}, kDmin);
  test::add_particle(s, {5e-4, 5e-4, 5e-4}, {}, 100e-6);  // a coarse particle far away
  return s;
}

struct ByHand {
  double scale, mass, k;
};
// Hertz against the steel wall (Eq. 5) for the smallest particle with E scaled by `scale`.
ByHand wall_contact(double scale) {
  const double r = 0.5 * kDmin;
  const double e_star =
      1.0 / ((1 - kSaltNu * kSaltNu) / (scale * kSaltE) + (1 - kSteelNu * kSteelNu) / kSteelE);
  return {scale, kSaltRho * 4.0 / 3.0 * M_PI * r * r * r, 4.0 / 3.0 * e_star * std::sqrt(r)};
}
double eq13_ratio(const ByHand& c) {
  const double gamma = -std::log(kE) / std::sqrt(M_PI * M_PI + std::log(kE) * std::log(kE));
  return (0.73 + 0.27 * (kE - gamma)) *
         std::pow(5.0 * c.mass * kSpeed * kSpeed / (4.0 * c.k), 0.4) / kDmin;
}
double automatic_step(const ByHand& c) {
  const double r = 0.5 * kDmin, G = c.scale * kSaltE / (2 * (1 + kSaltNu));
  const double rayleigh = M_PI * r * std::sqrt(kSaltRho / G) / (0.1631 * kSaltNu + 0.8766);
  const double contact = 2.0 * (std::tgamma(0.4) * std::tgamma(0.5) / (2.5 * std::tgamma(0.9))) *
                         std::pow(5.0 * c.mass * kSpeed * kSpeed / (4.0 * c.k), 0.4) / kSpeed;
  return std::min(0.2 * rayleigh, contact / 20.0);
}

TEST(ReducedStiffness, SaltAutomaticThresholdAndGainMatchEq13ByHand) {
  Simulation sim(salt_scene(0.2, 20.0));
  ASSERT_TRUE(sim.reduced_stiffness().has_value());
  const ReducedStiffnessInfo& info = *sim.reduced_stiffness();
  const double d_th = info.threshold_diameter_m;
  std::printf("salt at 40 m/s, d_min = %.1f um: automatic threshold %.2f um, time-step gain %.3f\n",
              kDmin * 1e6, d_th * 1e6, info.time_step_gain);
  EXPECT_TRUE(info.automatic);
  const double scale = std::pow(kDmin / d_th, 2.5);  // Eq. 7
  EXPECT_NEAR(eq13_ratio(wall_contact(scale)), 0.15, 1e-6);
  EXPECT_GT(eq13_ratio(wall_contact(std::pow(kDmin / (1.01 * d_th), 2.5))), 0.15)
      << "not the largest";
  EXPECT_NEAR(info.time_step_gain,
              automatic_step(wall_contact(scale)) / automatic_step(wall_contact(1.0)),
              1e-9 * info.time_step_gain);
  EXPECT_NEAR(sim.time_step().step_s, automatic_step(wall_contact(scale)),
              1e-9 * sim.time_step().step_s);
  EXPECT_EQ(info.reduced_particles, 1u) << "only the fine particle is softened";
}

TEST(ReducedStiffness, SimulatedPenetrationOfTheSmallestParticleIsTheLimit) {
  Simulation sim(salt_scene(0.1, 80.0));  // a tenth of the largest accepted step
  const ParticleStore& p = sim.particles();
  double max_overlap = 0.0;
  while (p.motion[0].velocity_m_per_s.z < 0.0 || max_overlap == 0.0) {
    ASSERT_FALSE(sim.step().has_value());
    max_overlap = std::max(max_overlap, p.radius_m[0] - p.position_m[0].z);
  }
  EXPECT_NEAR(max_overlap / kDmin, 0.15, 0.005 * 0.15);  // 0.5 %, the predictor's accuracy
}

}  // namespace
}  // namespace millsim
