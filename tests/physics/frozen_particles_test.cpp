// Frozen particles (a material with "frozen": true): a fixed bed or a target. They never move,
// under gravity or when struck, while their contacts act on their partners: a sphere dropped on a
// frozen one bounces off it with the pair's restitution: the damper is α √(k m*) with the frozen
// partner's inverse mass 0, m* = m (tests/physics/restitution_partners_test.cpp for more ratios).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

TEST(FrozenParticles, StayPutWhileAStruckSphereReboundsAsFromAWall) {
  MaterialConfig mobile = test::table1_material(0.5, 0.0);
  MaterialConfig fixed = mobile;
  fixed.name = "fixed";
  fixed.frozen = true;
  SceneConfig s = test::empty_scene({-1e-3, -1e-3, -1e-3}, {1e-3, 1e-3, 1e-3}, mobile);
  s.materials.push_back(fixed);
  s.gravity_m_per_s2 = {0, 0, -9.81};
  const double d = 1e-4, v = 1.0;
  test::add_particle(s, {0, 0, 0}, {0.3, 0, 0}, d, 1);       // frozen; its velocity is ignored
  test::add_particle(s, {0, 0, 1.2 * d}, {0, 0, -v}, d, 0);  // falls onto it
  s.time.step_s = 1e-9;
  s.time.end_s = 1e-4;
  Simulation sim(s);
  const Vec3 x0 = sim.particles().position_m[0];
  EXPECT_EQ(norm(sim.particles().motion[0].velocity_m_per_s), 0.0);
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step().has_value());
  const ParticleStore& p = sim.particles();
  EXPECT_EQ(p.position_m[0].x, x0.x);
  EXPECT_EQ(p.position_m[0].y, x0.y);
  EXPECT_EQ(p.position_m[0].z, x0.z) << "gravity and the impact left the frozen sphere in place";
  EXPECT_EQ(norm(p.motion[0].velocity_m_per_s), 0.0);
  // e = 0.5, within 0.5 % (gravity takes 1e-3 m/s of it over the 0.1 ms run).
  EXPECT_NEAR(p.motion[1].velocity_m_per_s.z, 0.5 * v, 0.0025 * v);
  EXPECT_GT(p.position_m[1].z, x0.z + d) << "it bounced off";
}

TEST(FrozenParticles, AFrozenMaterialCannotBreak) {
  nlohmann::json doc = {
      {"domain", {{"min_m", {0, 0, 0}}, {"max_m", {1e-3, 1e-3, 1e-3}}}},
      {"materials",
       {{{"name", "m"},
         {"youngs_modulus_pa", 1e9},
         {"poisson_ratio", 0.3},
         {"density_kg_per_m3", 2000},
         {"frozen", true},
         {"breakage",
          {{"strength",
            {{"model", "vogel_peukert"}, {"f_mat_kg_per_j_m", 1}, {"x_w_min_j_m_per_kg", 1}}}}}}}},
      {"sources",
       {{{"type", "list"},
         {"material", "m"},
         {"particles", {{{"position_m", {5e-4, 5e-4, 5e-4}}, {"diameter_m", 1e-4}}}}}}},
      {"dust", {{"threshold_diameter_m", 1e-5}}},
      {"time", {{"end_s", 1e-5}}}};
  bool reported = false;
  for (const InputError& e : test::scene_errors(doc))
    reported = reported || e.path == "/materials/0/frozen";
  EXPECT_TRUE(reported);
}

}  // namespace
}  // namespace millsim
