// Breakage in the running engine: impacts select particles with the selection function's
// probability, fatigue breaks a survivor after the predicted number of impacts, spawning
// conserves mass and momentum, mass is conserved through thousands of events, and fragments
// below the dust threshold exist only in the dust table.
#include "comminution/breakage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "comminution/strength.h"
#include "sim/run.h"
#include "sim/simulation.h"
#include "support/process.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

// A salt-like material with Vogel–Peukert strength: W_min = 10 J/kg at 100 µm.
MaterialConfig breakable_material(double f_mat, double x_w_min, FragmentConfig fragments) {
  MaterialConfig m = test::table1_material(0.5, 0.3);
  m.name = "salt";
  MaterialBreakageConfig b;
  b.strength.model = StrengthModel::VogelPeukert;
  b.strength.f_mat_kg_per_j_m = f_mat;
  b.strength.x_w_min_j_m_per_kg = x_w_min;
  b.fragments = fragments;
  m.breakage = b;
  return m;
}

FragmentConfig equal_fragments(int count) {
  FragmentConfig f;
  f.model = FragmentModel::Equal;
  f.count = count;
  return f;
}

// One step; a stability-guard stop fails the test with its message.
::testing::AssertionResult step_ok(Simulation& sim) {
  if (const auto failure = sim.step())
    return ::testing::AssertionFailure() << failure->cause << ": " << failure->detail;
  return ::testing::AssertionSuccess();
}

void enable_breakage(SceneConfig& s, double dust_threshold_m) {
  s.breakage = BreakageConfig{};
  s.dust = DustConfig{};
  s.dust->threshold_diameter_m = dust_threshold_m;
}

// N isolated spheres fired head-on at the floor: each sees one wall impact at speed v.
TEST(Breakage, WallImpactsBreakTheSelectionFraction) {
  const double d = 1e-4, v = 10.0, w = 0.5 * v * v, w_min = 10.0;
  const double f_mat = std::log(2.0) / (d * (w - w_min));  // P = 1/2 exactly
  const int side = 20;
  const double pitch = 3 * d;
  SceneConfig s = test::empty_scene({0, 0, 0}, {side * pitch, side * pitch, 4 * d},
                                    breakable_material(f_mat, w_min * d, equal_fragments(8)));
  enable_breakage(s, 0.6 * d);  // the 0.5 d fragments are dust: only first impacts count
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      test::add_particle(s, {(i + 0.5) * pitch, (j + 0.5) * pitch, 0.55 * d}, {0, 0, -v}, d);
  s.time.end_s = 2e-6;  // 5 µm of travel to the floor, then the contact
  Simulation sim(s);
  while (sim.step_index() < sim.total_steps()) ASSERT_TRUE(step_ok(sim));
  const BreakageStats& b = sim.breakage()->stats();
  const double n = side * side;
  EXPECT_EQ(b.impacts, std::uint64_t(n));  // every sphere hit the floor once, above W_min
  const double p = selection_probability(s.materials[0].breakage->strength, d, w);
  EXPECT_NEAR(p, 0.5, 1e-12);
  EXPECT_NEAR(double(b.events) / n, p, 3.0 * std::sqrt(p * (1 - p) / n));
  EXPECT_EQ(b.dust_fragments, 8 * b.events);
  EXPECT_EQ(sim.particles().size(), std::size_t(n - b.events));
}

// Every sphere breaks on the floor by a power law on its published domain (min_ratio 0): what
// lands in the dust table below the threshold follows B(x/y) = (x/y)/0.9 class by class, and
// parent mass = fragments + dust. The dust is the breakage function's share below the threshold,
// spread over the table's classes by B, plus the few last fragments that fall below it.
TEST(Breakage, DustBelowTheThresholdFollowsTheBreakageFunction) {
  const double d = 1e-4, v = 10.0, w = 0.5 * v * v, w_min = 10.0;
  const double f_mat = 50.0 / (d * (w - w_min));  // P = 1 − e^−50: every sphere breaks
  const int side = 20;
  const double pitch = 3 * d;
  SceneConfig s = test::empty_scene(
      {0, 0, 0}, {side * pitch, side * pitch, 4 * d},
      breakable_material(f_mat, w_min * d, test::power_law_fragments(1.0, 0.0, 0.9)));
  const double threshold = 0.45 * d;
  enable_breakage(s, threshold);
  s.psd.edges_m.clear();
  for (double e = 2e-6; e < 1.5 * d; e *= 1.25) s.psd.edges_m.push_back(e);
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      test::add_particle(s, {(i + 0.5) * pitch, (j + 0.5) * pitch, 0.55 * d}, {0, 0, -v}, d);
  s.time.end_s = 2e-6;
  Simulation sim(s);
  while (sim.step_index() < sim.total_steps()) ASSERT_TRUE(step_ok(sim));
  const BreakageStats& b = sim.breakage()->stats();
  ASSERT_EQ(b.events, std::uint64_t(side * side));
  const PsdTally& dust = sim.breakage()->dust();
  const double parent_mass = sphere_mass_kg(s.materials[0].density_kg_per_m3, d);
  const double total = b.events * parent_mass;
  double below = dust.under_mass_kg;
  for (std::size_t k = 0; k + 1 < dust.edges_m.size() && dust.edges_m[k + 1] <= threshold; ++k) {
    below += dust.mass_kg[k];
    EXPECT_NEAR(below / total, dust.edges_m[k + 1] / d / 0.9, 0.01)
        << "x = " << dust.edges_m[k + 1];
  }
  double fragment_mass = 0.0;
  for (std::size_t i = 0; i < sim.particles().size(); ++i)
    fragment_mass += sim.particles().mass_kg[i];
  const double dust_mass = dust.under_mass_kg + dust.over_mass_kg +
                           std::accumulate(dust.mass_kg.begin(), dust.mass_kg.end(), 0.0);
  EXPECT_NEAR(fragment_mass + dust_mass, total, 1e-12 * total);
  // Half a parent's mass lies below 0.45 of its diameter: B(0.5) = 0.5.
  EXPECT_NEAR(dust_mass / total, 0.5, 0.01);
}

// A sphere that breaks as it hits the floor at v: its fragments leave the impact as the sphere
// would have, rebounding at about e·v (one step of the contact has already slowed it, 20 steps
// per contact time here), and none of them meets the floor again. Without completing the impact
// the fragments carried on into the floor at −v and broke again, generation after generation.
TEST(Breakage, FragmentsOfAWallImpactLeaveWithTheRebound) {
  const double d = 1e-4, v = 10.0;
  SceneConfig s = test::empty_scene({0, 0, 0}, {1e-3, 1e-3, 1e-3},
                                    breakable_material(1e6, 1e-6, equal_fragments(8)));
  enable_breakage(s, 0.1 * d);  // the 0.5 d fragments are particles
  test::add_particle(s, {5e-4, 5e-4, 0.55 * d}, {0, 0, -v}, d);
  s.time.end_s = 1e-4;
  Simulation sim(s);
  while (sim.breakage()->stats().events == 0 && sim.step_index() < 100000)
    ASSERT_TRUE(step_ok(sim));
  ASSERT_EQ(sim.breakage()->stats().events, 1u);
  EXPECT_EQ(sim.breakage()->stats().completed_impacts, 1u);
  const ParticleStore& p = sim.particles();
  double mass = 0.0, momentum_z = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    mass += p.mass_kg[i], momentum_z += p.mass_kg[i] * p.motion[i].velocity_m_per_s.z;
  const double e = s.materials[0].restitution;
  EXPECT_NEAR(momentum_z / mass, e * v, 0.1 * e * v);
  for (int k = 0; k < 20000; ++k) ASSERT_TRUE(step_ok(sim));
  EXPECT_EQ(sim.breakage()->stats().events, 1u) << "a fragment broke again on the floor";
}

// One sphere bouncing between two walls (e = 1, no gravity): with fatigue it breaks at the
// predicted impact; without, never.
TEST(Breakage, FatigueBreaksASurvivorAfterRepeatedImpacts) {
  for (bool fatigue : {true, false}) {
    const double d = 1e-4, w_min = 10.0;
    MaterialConfig m = breakable_material(100.0, w_min * d, equal_fragments(8));
    m.restitution = 1.0;
    m.friction = 0.0;
    m.breakage->fatigue = fatigue;
    SceneConfig s = test::empty_scene({0, 0, 0}, {4 * d, 4 * d, 2.2 * d}, m);
    enable_breakage(s, 1e-5);
    test::add_particle(s, {2 * d, 2 * d, 1.1 * d}, {0, 0, 0}, d);
    s.contact.max_impact_speed_m_per_s = 12.0;
    s.time.end_s = 2e-4;
    Simulation sim(s);
    // Set the speed so the excess energy is capacity / 3.4: survives 3 impacts, breaks on the 4th.
    const double capacity = sim.particles().remaining_capacity_j_per_kg[0];
    const double w = w_min + capacity / 3.4;
    ASSERT_LT(std::sqrt(2 * w), 12.0) << "capacity " << capacity;
    sim.particles().motion[0].velocity_m_per_s = {0, 0, std::sqrt(2 * w)};
    sim.refresh_forces();
    while (sim.step_index() < sim.total_steps() && sim.breakage()->stats().events == 0)
      ASSERT_TRUE(step_ok(sim));
    const BreakageStats& b = sim.breakage()->stats();
    if (fatigue) {
      EXPECT_EQ(b.events, 1u);
      EXPECT_EQ(b.impacts, 4u);
      EXPECT_EQ(b.fatigue_impacts, 3u);
    } else {
      EXPECT_EQ(b.events, 0u);
      EXPECT_GE(b.impacts, 6u);  // it kept bouncing past the impact that broke it with fatigue
    }
  }
}

// One breakage by hand: fragments + dust carry the parent's mass, momentum and centre of mass.
TEST(Breakage, SpawningConservesMassMomentumAndCentreOfMass) {
  const FragmentConfig f = test::power_law_fragments(0.7, 0.02, 0.6);
  SceneConfig s =
      test::empty_scene({0, 0, 0}, {1e-2, 1e-2, 1e-2}, breakable_material(1e3, 1e-3, f));
  const double parent_d = 1e-3;
  enable_breakage(s, 0.08 * parent_d);
  MaterialTable materials(s);
  std::vector<Wall> walls = build_walls(s, materials);
  ParticleStore p;
  p.enable_breakage_state();
  const Vec3 x{5e-3, 5e-3, 5e-3}, v{3.0, -2.0, 7.0}, w{1e3, -4e3, 2e3};
  p.add(materials, 0, 1, x, v, w, parent_d);
  p.remaining_capacity_j_per_kg[0] = 0.0;  // any impact above W_min breaks it
  const double parent_mass = p.mass_kg[0];
  Breakage breakage(s, materials, std::nullopt, 42, {1e-6, 1e-2});
  ParticleId next_id = 2;
  std::vector<Newborn> newborn;
  const auto ignore = [](const ParticleStore&, std::size_t) {};
  const std::uint64_t events = breakage.process({{0, 0, true, 20.0}}, {}, 1e-8, 0.25, walls,
                                                PeriodicBox{s.domain.min_m, s.domain.max_m, {}}, p,
                                                next_id, newborn, ignore, ignore);
  ASSERT_EQ(events, 1u);
  ASSERT_GT(p.size(), 1u);
  EXPECT_EQ(newborn.size(), p.size());
  EXPECT_GT(breakage.stats().dust_fragments, 0u);
  double mass = breakage.dust().total_mass_kg();
  Vec3 momentum = breakage.dust_momentum_kg_m_per_s(), moment = x * mass;
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_GE(2 * p.radius_m[i], 0.08 * parent_d);
    mass += p.mass_kg[i];
    momentum += p.motion[i].velocity_m_per_s * p.mass_kg[i];
    moment += p.position_m[i] * p.mass_kg[i];
    EXPECT_EQ(norm(p.motion[i].angular_velocity_rad_per_s - w), 0.0);
  }
  EXPECT_NEAR(mass / parent_mass, 1.0, 1e-14);
  EXPECT_LT(norm(momentum - v * parent_mass), 1e-14 * norm(v) * parent_mass);
  EXPECT_LT(norm(moment * (1.0 / parent_mass) - x), 1e-14 * norm(x));

  // The event log (run.h5 /breakage_events): this one event as it happened. A wall impact of
  // 20 m/s on a particle against a rigid-enough wall: the strength model compared the energy of
  // the equivalent speed, at most the approach's v²/2 = 200 J/kg.
  ASSERT_EQ(breakage.event_log().size(), 1u);
  const BreakageEvent& e = breakage.event_log()[0];
  EXPECT_EQ(e.time_s, 0.25);
  EXPECT_EQ(e.parent_id, 1u);
  EXPECT_EQ(e.parent_diameter_m, parent_d);
  EXPECT_EQ(norm(e.position_m - x), 0.0);
  EXPECT_EQ(e.generation, 0);
  EXPECT_EQ(e.crushed, 0);
  EXPECT_GT(e.specific_energy_j_per_kg, 0.0);
  EXPECT_LE(e.specific_energy_j_per_kg, 0.5 * 20.0 * 20.0 * (1.0 + 1e-12));
  EXPECT_EQ(e.fragments, p.size());
  EXPECT_DOUBLE_EQ(e.dust_mass_kg, breakage.dust().total_mass_kg());
}

// A periodic gas of weak particles shatters through thousands of events: mass (particles + dust)
// and momentum (particles + dust) stay what they were; no particle is below the dust threshold.
// min_ratio 0.1: the threshold (0.15–0.2 of a fed parent) lies above it, and the breakage
// function's share below the threshold goes to the dust table spread by B. min_ratio 0.25: the
// threshold lies below it for fed parents (B has no mass there; a last fragment may be dust) and
// above it for their fragments.
class BreakageConservation : public ::testing::TestWithParam<double> {};

TEST_P(BreakageConservation, MassAndMomentumConservedThroughThousandsOfEvents) {
  const FragmentConfig f = test::power_law_fragments(1.0, GetParam(), 0.7);
  MaterialConfig m = breakable_material(2e4, 2e-4, f);  // W_min = 1 J/kg at 200 µm
  SizeDistribution sizes;
  sizes.kind = SizeDistributionKind::Uniform;
  sizes.min_m = 300e-6;
  sizes.max_m = 400e-6;
  SceneConfig s = test::periodic_random_gas(3e-3, 150, sizes, 15.0, m, 9);
  const double threshold = 60e-6;
  enable_breakage(s, threshold);
  s.psd.edges_m = {1e-6, threshold, 1e-3};
  s.time.end_s = 1.0;
  Simulation sim(s);
  const Vec3 p0 = test::total_momentum(sim.particles());
  const double mass0 = sim.mass_balance().particles_kg;
  while (sim.breakage()->stats().events < 2000 && sim.step_index() < 400000)
    ASSERT_TRUE(step_ok(sim)) << sim.step_index();
  const BreakageStats& b = sim.breakage()->stats();
  EXPECT_GE(b.events, 2000u);
  EXPECT_GT(b.dust_fragments, 1000u);
  const MassBalance balance = sim.mass_balance();
  EXPECT_LT(std::abs(balance.relative_error()), 1e-12);
  EXPECT_NEAR(balance.particles_kg + balance.dust_kg, mass0, 1e-12 * mass0);
  // Velocity Verlet conserves Σ m v + ½ dt Σ F (the force in flight: each stored force still
  // owes half a kick); Σ F is zero except right after a breakage, where this test stops.
  Vec3 in_flight{};
  for (const Load& l : sim.particles().load)
    in_flight += l.force_n * (0.5 * sim.time_step().step_s);
  const Vec3 p1 =
      test::total_momentum(sim.particles()) + in_flight + sim.removed_momentum_kg_m_per_s();
  double scale = 0.0;  // Σ m |v|: the momentum in play
  for (std::size_t i = 0; i < sim.particles().size(); ++i)
    scale += sim.particles().mass_kg[i] * norm(sim.particles().motion[i].velocity_m_per_s);
  EXPECT_LT(norm(p1 - p0), 1e-12 * scale);
  // Fragments below the threshold exist only in the dust table.
  for (double r : sim.particles().radius_m) EXPECT_GE(2 * r, threshold);
  const PsdTally& dust = sim.breakage()->dust();
  EXPECT_EQ(dust.count[1], 0.0);  // [threshold, 1 mm): no dust there
  EXPECT_EQ(dust.over_count, 0.0);
  EXPECT_GT(dust.count[0] + dust.under_count, 1000.0);
}

INSTANTIATE_TEST_SUITE_P(Breakage, BreakageConservation, ::testing::Values(0.1, 0.25));

// The same closed periodic gas, read from outside: result.json's momentum section holds what the
// particles, the force in flight and the dust carry, and the balance against the start closes to
// 1e-12 of the momentum in play, dust included (issue 34, item 4).
TEST(Breakage, MomentumThroughBreakageBalancesInResultJson) {
  MILLSIM_RELEASE_ONLY(
      "BreakageConservation (the same balance in memory) and every run's "
      "result.json");
  MaterialConfig m = breakable_material(2e4, 2e-4, test::power_law_fragments(1.0, 0.1, 0.7));
  SizeDistribution sizes;
  sizes.kind = SizeDistributionKind::Uniform;
  sizes.min_m = 300e-6;
  sizes.max_m = 400e-6;
  SceneConfig s = test::periodic_random_gas(3e-3, 150, sizes, 15.0, m, 9);
  enable_breakage(s, 60e-6);
  s.psd.edges_m = {1e-6, 60e-6, 1e-3};
  s.time.end_s = 30000 * Simulation(s).time_step().step_s;
  Simulation sim(s);
  test::TempDir dir;
  RunOptions options;
  options.out_dir = dir.path();
  ASSERT_FALSE(run_simulation(sim, s, options).failure);
  const nlohmann::json result = nlohmann::json::parse(test::read_file(dir.path() / "result.json"));
  ASSERT_GT(result["breakage"]["events"].get<int>(), 50);
  const nlohmann::json& p = result["momentum_kg_m_per_s"];
  const double scale = p["scale"];
  auto vec = [&](const char* key) {
    return Vec3{p[key][0].get<double>(), p[key][1].get<double>(), p[key][2].get<double>()};
  };
  EXPECT_GT(norm(vec("dust")), 1e-6 * scale) << "the dust carries momentum away";
  EXPECT_EQ(norm(vec("fed")), 0.0);
  EXPECT_EQ(norm(vec("outlet")), 0.0);
  const Vec3 change =
      vec("particles") + vec("in_flight") + vec("outlet") + vec("dust") - vec("initial");
  EXPECT_LT(norm(change), 1e-12 * scale) << p;
  EXPECT_LT(norm(vec("external_impulse")), 1e-12 * scale) << p;
}

}  // namespace
}  // namespace millsim
