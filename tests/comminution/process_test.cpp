// Feeds, outlets and the comminution sections of the scene file: the feed delivers its mass
// rate, particles leaving by an outlet are binned, mass balances to rounding, and bad breakage
// input is named by path.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/json_reader.h"
#include "scene/scene_json.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

// Particles fed at the top of a column fall through an outlet plane at its bottom.
TEST(FeedAndOutlet, FeedRateIsDeliveredAndOutletMassBalances) {
  SceneConfig s = test::empty_scene({0, 0, -2e-3}, {4e-3, 4e-3, 10e-3}, test::table1_material());
  s.domain.periodic = {true, true, false};
  s.gravity_m_per_s2 = {0, 0, -9.81};
  FeedConfig f;
  f.name = "top";
  f.region_min_m = {0, 0, 8e-3};
  f.region_max_m = {4e-3, 4e-3, 9e-3};
  f.sizes.kind = SizeDistributionKind::Uniform;
  f.sizes.min_m = 2e-4;
  f.sizes.max_m = 3e-4;
  f.velocity_m_per_s = {0, 0, -2.0};
  f.mass_rate_kg_per_s = 1e-4;
  f.end_s = 4e-3;
  s.feeds.push_back(f);
  OutletConfig o;
  o.name = "bottom";
  o.point_m = {0, 0, 0};
  o.normal = {0, 0, 1};
  s.outlets.push_back(o);
  s.psd.edges_m = {1e-4, 2e-4, 2.5e-4, 3e-4, 4e-4};
  s.time.end_s = 8e-3;
  Simulation sim(s);
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step());

  const MassBalance m = sim.mass_balance();
  // The feed ran 4 ms at 0.1 g/s: 0.4 mg, short of it by at most one particle's mass.
  const double largest = 2000.0 * std::numbers::pi / 6.0 * std::pow(3e-4, 3);
  EXPECT_LE(m.fed_kg, 4e-7 * (1 + 1e-12));
  EXPECT_GT(m.fed_kg, 4e-7 - largest);
  EXPECT_LT(std::abs(m.relative_error()), 1e-13);
  // 2 m/s plus gravity covers the 8–9 mm drop in under 4 ms: the early particles have left.
  EXPECT_GT(m.outlet_kg, 0.25 * m.fed_kg);
  const PsdSummary psd = summarize(sim.outlet_tally());
  EXPECT_EQ(psd.under_mass_kg + psd.over_mass_kg, 0.0);  // every fed size is inside the classes
  EXPECT_NEAR(psd.total_mass_kg, m.outlet_kg, 1e-20);
  EXPECT_EQ(psd.mass_kg[0], 0.0);  // nothing below 200 µm was fed
  EXPECT_EQ(psd.mass_kg[3], 0.0);  // nor above 300 µm
  // Nothing remaining is below the outlet plane.
  for (const Vec3& x : sim.particles().position_m) EXPECT_GE(x[2], -1e-4);
}

// Feeding costs no rebuilds of its own: the fed particles enter on the step before the list
// would rebuild anyway, and that rebuild takes theirs. Every particle moves at one speed v, so
// each list lives L = ⌈(skin/2) / (v dt)⌉ steps (the motion bound and the exact displacement
// agree); a particle is due every 30 steps, far more often than L.
TEST(FeedAndOutlet, FeedsWaitForTheListsOwnRebuild) {
  SceneConfig s =
      test::empty_scene({0, 0, 0}, {4e-3, 4e-3, 4e-3}, test::table1_material(), {true, true, true});
  const double speed = 0.2, dt = 5e-7, skin = 2e-5;  // dt under the Rayleigh time, 7.7e-7 s
  s.time.step_s = dt;
  s.time.end_s = 3000 * dt;
  s.search.skin_m = skin;
  FeedConfig f;
  f.name = "cloud";
  f.region_min_m = {0, 0, 0};
  f.region_max_m = {4e-3, 4e-3, 4e-3};
  f.sizes.kind = SizeDistributionKind::Uniform;
  f.sizes.min_m = f.sizes.max_m = 2e-4;
  f.velocity_m_per_s = {speed, 0, 0};
  const double particle_kg =
      s.materials[0].density_kg_per_m3 * std::numbers::pi / 6.0 * std::pow(2e-4, 3);
  f.mass_rate_kg_per_s = particle_kg / (30 * dt);
  s.feeds.push_back(f);
  Simulation sim(s);
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step());

  const std::int64_t list_steps = std::int64_t(std::ceil(0.5 * skin / (speed * dt)));
  ASSERT_NEAR(double(list_steps), 100.0, 1.0);  // (100 up to rounding)
  const double steps = double(sim.total_steps());
  // Applied every 64 steps (the rule before), the feed would rebuild 47 times.
  EXPECT_LE(double(sim.neighbors().stats().rebuilds), steps / double(list_steps - 2) + 2.0);
  // Fed mass waits at most one list: what was due until then has entered.
  const double due_kg = f.mass_rate_kg_per_s * (steps - double(list_steps)) * dt;
  EXPECT_GE(sim.mass_balance().fed_kg, due_kg - particle_kg);
  EXPECT_LE(sim.mass_balance().fed_kg, f.mass_rate_kg_per_s * steps * dt * (1 + 1e-12));
}

json breakable_scene() {
  return json::parse(R"({
    "domain": {"min_m": [0,0,0], "max_m": [1e-3,1e-3,1e-3]},
    "materials": [{"name": "salt", "youngs_modulus_pa": 1e9, "poisson_ratio": 0.25,
                   "density_kg_per_m3": 2160,
                   "breakage": {"strength": {"model": "vogel_peukert", "f_mat_kg_per_j_m": 8,
                                             "x_w_min_j_m_per_kg": 0.03},
                                "fragments": {"model": "power_law", "exponent": 1.0}}}],
    "sources": [{"type": "list", "material": "salt",
                 "particles": [{"position_m": [5e-4,5e-4,5e-4], "diameter_m": 1e-4}]}],
    "dust": {"threshold_diameter_m": 1e-5},
    "time": {"end_s": 1e-5}
  })");
}

InputErrors errors_of(const json& doc) {
  return test::scene_errors(doc);
}

bool has_error(const InputErrors& errors, const std::string& path, const std::string& text) {
  for (const InputError& e : errors)
    if (e.path == path && e.allowed.find(text) != std::string::npos) return true;
  return false;
}

TEST(ComminutionScene, ValidSceneParsesEveryField) {
  InputErrors errors;
  const SceneConfig s = parse_scene(breakable_scene(), ".", errors);
  ASSERT_TRUE(errors.empty()) << errors.front().path << " " << errors.front().allowed;
  ASSERT_TRUE(s.materials[0].breakage.has_value());
  EXPECT_EQ(s.materials[0].breakage->strength.f_mat_kg_per_j_m, 8.0);
  EXPECT_TRUE(s.breakage.has_value());  // defaults filled in
  EXPECT_EQ(s.dust->threshold_diameter_m, 1e-5);
}

TEST(ComminutionScene, BadInputIsNamed) {
  json doc = breakable_scene();
  doc.erase("dust");
  EXPECT_TRUE(has_error(errors_of(doc), "/dust/threshold_diameter_m", "dust threshold"));

  doc = breakable_scene();
  doc["materials"][0]["breakage"]["fragments"]["max_ratio"] = 0.01;
  EXPECT_TRUE(has_error(errors_of(doc), "/materials/0/breakage/fragments/max_ratio",
                        "expected > min_ratio"));

  doc = breakable_scene();
  doc["materials"][0]["breakage"]["strength"]["model"] = "tavares";
  EXPECT_TRUE(has_error(errors_of(doc), "/materials/0/breakage/strength/model", "vogel_peukert"));

  doc = breakable_scene();
  doc["materials"][0].erase("breakage");
  doc["breakage"] = {{"equivalence", "force"}};
  EXPECT_TRUE(has_error(errors_of(doc), "/breakage", "no material is breakable"));

  doc = breakable_scene();
  doc["psd"] = {{"edges_m", {1e-5, 1e-6}}};
  EXPECT_TRUE(has_error(errors_of(doc), "/psd/edges_m/1", "ascending"));

  doc = breakable_scene();
  doc["outlets"] = {{{"type", "plane"}, {"point_m", {0, 0, 0}}, {"normal", {0, 0, 0}}}};
  EXPECT_TRUE(has_error(errors_of(doc), "/outlets/0/normal", "non-zero"));

  doc = breakable_scene();
  doc["feeds"] = {{{"material", "salt"},
                   {"mass_rate_kg_per_s", -1},
                   {"region", {{"min_m", {0, 0, 0}}, {"max_m", {1e-3, 1e-3, 2e-3}}}},
                   {"sizes", {{"distribution", "fixed"}, {"diameter_m", 1e-4}}}}};
  const InputErrors feed_errors = errors_of(doc);
  EXPECT_TRUE(has_error(feed_errors, "/feeds/0/mass_rate_kg_per_s", "> 0"));
  EXPECT_TRUE(has_error(feed_errors, "/feeds/0/region", "inside the domain"));
}

}  // namespace
}  // namespace millsim
