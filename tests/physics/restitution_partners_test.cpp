// Restitution that does not depend on the partner (issue 34, item 1). Once each damper is
// α √(k m*) of the pair, with m* from the partners' inverse masses, an impact scales to one
// dimensionless equation whose rebound depends on α alone (docs/contact-model.md), whatever the
// sizes, the spring model, or whether the partner is free, frozen or a wall. Expectation: the
// measured coefficient of restitution equals the pair's e within 0.5 %, for free spheres of size
// ratio 1–100, a sphere on a frozen sphere of ratio 1–100, and a sphere on a wall. Before the
// fix the per-particle dampers in series gave 0.463 for e = 0.5 on a frozen sphere of 5× the
// radius, and 2.6 % low for unequal free spheres at e = 0.2.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kE = 1e9, kNu = 0.3, kRho = 2000.0;
constexpr double kSmallDiameter = 20e-6, kSpeed = 1.0;

double sphere_mass(double d) {
  return kRho * std::numbers::pi / 6.0 * d * d * d;
}

// Hertz contact time for stiffness k and effective mass m* at impact speed v (Eq. 12).
double hertz_contact_time(double m_eff, double k, double v) {
  const double overlap = std::pow(5.0 * m_eff * v * v / (4.0 * k), 0.4);
  return 2.0 * std::tgamma(0.4) * std::tgamma(0.5) / (2.5 * std::tgamma(0.9)) * overlap / v;
}

// Steps the scene until particle 1 has touched `partner_overlap` > 0 and left it; returns the
// normal rebound speed over the impact speed. `normal_speed` is the separating speed.
template <class Overlap, class Speed>
double measured_restitution(Simulation& sim, Overlap overlap, Speed normal_speed) {
  bool touched = false;
  for (int step = 0; step < 200'000; ++step) {
    if (const auto failure = sim.step()) {
      ADD_FAILURE() << failure->detail;
      return 0.0;
    }
    const double now = overlap(sim);
    if (now > 0.0) touched = true;
    if (touched && now <= 0.0) return normal_speed(sim) / kSpeed;
  }
  ADD_FAILURE() << "the contact never ended";
  return 0.0;
}

// A small sphere (slot 1) strikes a sphere `ratio` times its diameter (slot 0) head on.
double sphere_on_sphere(double e, double ratio, bool big_frozen, ContactModel model) {
  const double d_small = kSmallDiameter, d_big = ratio * kSmallDiameter;
  const double extent = 2.0 * d_big;
  MaterialConfig free_material = test::table1_material(e);
  SceneConfig s =
      test::empty_scene({-extent, -extent, -extent}, {extent, extent, extent}, free_material);
  MaterialConfig frozen = free_material;
  frozen.name = "frozen";
  frozen.frozen = true;
  s.materials.push_back(frozen);
  s.contact.model = model;
  const double gap = 0.05 * d_small;
  test::add_particle(s, {0, 0, 0}, {}, d_big, big_frozen ? 1 : 0);
  test::add_particle(s, {-(0.5 * (d_big + d_small) + gap), 0, 0}, {kSpeed, 0, 0}, d_small, 0);
  // The step: 1/200 of the pair's Hertz contact time (series springs, Eq. 2).
  const double k_np_small = 2.0 * std::sqrt(d_small) * kE / (3.0 * (1.0 - kNu * kNu));
  const double k_np_big = 2.0 * std::sqrt(d_big) * kE / (3.0 * (1.0 - kNu * kNu));
  const double k = k_np_small * k_np_big / (k_np_small + k_np_big);
  const double inv_m = 1.0 / sphere_mass(d_small) + (big_frozen ? 0.0 : 1.0 / sphere_mass(d_big));
  s.time.step_s = hertz_contact_time(1.0 / inv_m, k, kSpeed) / 200.0;
  Simulation sim(s);
  return measured_restitution(
      sim,
      [](const Simulation& x) {
        const ParticleStore& p = x.particles();
        return p.radius_m[0] + p.radius_m[1] - norm(p.position_m[0] - p.position_m[1]);
      },
      [](const Simulation& x) {
        const ParticleStore& p = x.particles();
        return p.motion[0].velocity_m_per_s.x - p.motion[1].velocity_m_per_s.x;
      });
}

TEST(RestitutionPartners, FreeSpheresOfAnySizeRatioReboundWithTheirRestitution) {
  for (ContactModel model : {ContactModel::SeriesSprings, ContactModel::PaperSprings,
                             ContactModel::EquivalentProperties})
    for (double e : {0.2, 0.5, 0.9})
      for (double ratio : {1.0, 2.0, 5.0, 10.0, 100.0})
        EXPECT_NEAR(sphere_on_sphere(e, ratio, false, model), e, 0.005 * e)
            << "model " << int(model) << ", e " << e << ", size ratio " << ratio;
}

TEST(RestitutionPartners, ASphereOnAFrozenSphereReboundsWithItsRestitution) {
  for (double e : {0.2, 0.5, 0.9})
    for (double ratio : {1.0, 5.0, 100.0})
      EXPECT_NEAR(sphere_on_sphere(e, ratio, true, ContactModel::SeriesSprings), e, 0.005 * e)
          << "e " << e << ", size ratio " << ratio;
}

TEST(RestitutionPartners, ASphereOnAWallReboundsWithItsRestitution) {
  for (double e : {0.2, 0.5, 0.9}) {
    const double d = kSmallDiameter;
    SceneConfig s =
        test::empty_scene({-1e-3, -1e-3, 0}, {1e-3, 1e-3, 1e-3}, test::table1_material(e));
    test::add_particle(s, {0, 0, 0.55 * d}, {0, 0, -kSpeed}, d);
    // Against a wall of the same material: E* = E/(2(1−ν²)), R* = r, m* = m.
    const double k = 4.0 / 3.0 * kE / (2.0 * (1.0 - kNu * kNu)) * std::sqrt(0.5 * d);
    s.time.step_s = hertz_contact_time(sphere_mass(d), k, kSpeed) / 200.0;
    Simulation sim(s);
    const double got = measured_restitution(
        sim,
        [](const Simulation& x) {
          return x.particles().radius_m[0] - x.particles().position_m[0].z;
        },
        [](const Simulation& x) { return x.particles().motion[0].velocity_m_per_s.z; });
    EXPECT_NEAR(got, e, 0.005 * e) << "e " << e;
  }
}

}  // namespace
}  // namespace millsim
