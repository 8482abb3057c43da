// The neighbour list carries each contact's state across rebuilds by stable particle id. A
// rebuild may list a pair the other way round (particles moved to other cells, or memory was
// reordered); the tangential spring is a vector from one partner to the other and must turn
// with the pair, while a ghost pair's overlap memory is a length and must not. Checked by the
// independent expectation that nothing physical changed: with the particles at rest, the forces
// on each particle after a rebuild that flips the pair equal those before it. A list without a
// skin is searched again every step (the conventional method) and finds the same contacts.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "contact/contact_forces.h"
#include "search/neighbor_list.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kDiameter = 100e-6;

struct TwoSpheres {
  SceneConfig scene =
      test::empty_scene({0, 0, 0}, {1e-3, 1e-3, 1e-3}, test::table1_material(0.5, 0.5));
  MaterialTable table{scene};
  PeriodicBox box{{0, 0, 0}, {1e-3, 1e-3, 1e-3}, {false, false, false}};
  ParticleStore p;
  NeighborList nl{settings()};

  static NeighborSettings settings() {
    NeighborSettings s;
    s.skin_m = 0.1 * kDiameter;
    return s;
  }

  TwoSpheres() {
    const double overlap = 1e-3 * kDiameter;
    p.add(table, 0, 1, {4e-4, 5e-4, 5e-4}, {}, {}, kDiameter);
    p.add(table, 0, 2, {4e-4 + kDiameter - overlap, 5e-4, 5e-4}, {}, {}, kDiameter);
    nl.update(p, box, {}, true);
  }

  // Force on each particle by id (1, 2) from one force pass at rest (no time passes).
  std::array<Vec3, 2> forces_by_id() {
    for (Load& l : p.load) l = {};
    ContactStepStats stats;
    compute_pair_forces(ContactModel::SeriesSprings, table, box, 0.0, 1.0, p, nl, stats);
    std::array<Vec3, 2> by_id;
    for (std::size_t i = 0; i < p.size(); ++i) by_id[p.id[i] - 1] = p.load[i].force_n;
    return by_id;
  }

  // Swaps the two slots and rebuilds: the only candidate is then listed the other way round.
  void swap_slots_and_rebuild() {
    std::vector<Vec3> scratch;
    p.permute({1, 0}, scratch);
    nl.update(p, box, {}, true);
  }
};

TEST(NeighborList, TangentialSpringTurnsWithThePairAcrossARebuild) {
  TwoSpheres s;
  ASSERT_EQ(s.nl.pairs.size(), 1u);
  // A loaded tangential spring (along y, in the tangent plane of the x-normal contact).
  s.nl.pair_touching[0] = kPairTouching;
  s.nl.pair_history[0] = s.nl.history_pool.take({0.0, 2e-3 * kDiameter, 0.0});
  const std::array<Vec3, 2> before = s.forces_by_id();
  ASSERT_GT(std::abs(before[0].y), 1e-6 * norm(before[0])) << "the spring must carry load";
  const ParticleId first_before = s.p.id[s.nl.pairs.first[0]];

  s.swap_slots_and_rebuild();
  ASSERT_EQ(s.nl.pairs.size(), 1u);
  ASSERT_NE(s.p.id[s.nl.pairs.first[0]], first_before) << "the rebuild must flip the pair";
  const std::array<Vec3, 2> after = s.forces_by_id();
  for (int id = 0; id < 2; ++id)
    EXPECT_NEAR(norm(after[id] - before[id]), 0.0, 1e-12 * norm(before[id])) << "particle " << id;
}

TEST(NeighborList, GhostOverlapMemoryKeepsItsSignAcrossAFlippingRebuild) {
  TwoSpheres s;
  ASSERT_EQ(s.nl.pairs.size(), 1u);
  // Born overlapping: 60 % of the overlap is remembered, so only the other 40 % pushes back.
  const double overlap = 1e-3 * kDiameter;
  s.nl.pair_touching[0] = kPairGhost;
  s.nl.pair_history[0] = s.nl.history_pool.take({0.6 * overlap, 0.0, 0.0});
  const std::array<Vec3, 2> before = s.forces_by_id();
  ASSERT_GT(norm(before[0]), 0.0);
  const ParticleId first_before = s.p.id[s.nl.pairs.first[0]];

  s.swap_slots_and_rebuild();
  ASSERT_NE(s.p.id[s.nl.pairs.first[0]], first_before) << "the rebuild must flip the pair";
  const std::array<Vec3, 2> after = s.forces_by_id();
  for (int id = 0; id < 2; ++id)
    EXPECT_NEAR(norm(after[id] - before[id]), 0.0, 1e-12 * norm(before[id])) << "particle " << id;
}

TEST(NeighborList, WithoutASkinItSearchesEveryStepAndFindsTheSameContacts) {
  // A dense, polydisperse periodic gas, 300 steps with the steered skin and with none. Both
  // contact sets are exact, so every step's touching pairs agree; the trajectories agree to
  // the rounding of sums taken in another candidate order.
  auto scene = [](std::optional<double> skin) {
    SceneConfig s = test::periodic_random_gas(
        6e-4, 1500, {SizeDistributionKind::PowerLaw, 0.0, 10e-6, 60e-6, 0.0, 1.0, -2.5}, 3.0,
        test::table1_material(0.5, 0.3), 7);
    s.search.skin_m = skin;
    return s;
  };
  Simulation steered(scene(std::nullopt)), every_step(scene(0.0));
  std::uint64_t touching_steps = 0;
  for (int step = 0; step < 300; ++step) {
    ASSERT_FALSE(steered.step().has_value());
    ASSERT_FALSE(every_step.step().has_value());
    ASSERT_EQ(every_step.contact_stats().touching_pairs, steered.contact_stats().touching_pairs)
        << "step " << step;
    touching_steps += steered.contact_stats().touching_pairs > 0 ? 1 : 0;
  }
  EXPECT_EQ(touching_steps, 300u);
  EXPECT_GE(every_step.neighbors().stats().rebuilds, 300u);
  EXPECT_LT(steered.neighbors().stats().rebuilds, 100u);
  const double ka = steered.energy().kinetic_j, kb = every_step.energy().kinetic_j;
  EXPECT_NEAR(kb, ka, 1e-9 * ka);
}

}  // namespace
}  // namespace millsim
