// A living population: particles are removed and added mid-run (outlet, breakage, feed). The
// neighbour list must notice, and the contact set it yields must stay exactly the all-pairs
// contact set; the automatic skin and sub-cell division must be re-derived from the population
// as it is now, not as it started.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "search/hashed_grid.h"
#include "search/pair_search.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using Pairs = std::vector<std::pair<ParticleId, ParticleId>>;

// Touching pairs (by id) as the engine's neighbour list sees them.
// Every geometrically touching candidate lies in the bands the force loop looked at this step,
// and that pass flagged it (docs/contact-search.md: candidates sorted by gap band).
int touching_pairs_outside_the_force_pass(const Simulation& sim) {
  const ParticleStore& p = sim.particles();
  const NeighborList& nl = sim.neighbors();
  int missed = 0;
  for (std::size_t k = 0; k < nl.pairs.size(); ++k) {
    const std::uint32_t i = nl.pairs.first[k], j = nl.pairs.second[k];
    const Vec3 d = p.position_m[i] - p.position_m[j] - nl.pair_shift(k);
    const double reach = p.radius_m[i] + p.radius_m[j];
    if (norm2(d) >= reach * reach) continue;
    if (!nl.pair_active(k) || nl.pair_touching[k] == kPairApart) ++missed;
  }
  return missed;
}

Pairs engine_contacts(const Simulation& sim) {
  const ParticleStore& p = sim.particles();
  const NeighborList& nl = sim.neighbors();
  Pairs out;
  for (std::size_t k = 0; k < nl.pairs.size(); ++k) {
    const std::uint32_t i = nl.pairs.first[k], j = nl.pairs.second[k];
    const Vec3 d = p.position_m[i] - p.position_m[j] - nl.pair_shift(k);
    const double reach = p.radius_m[i] + p.radius_m[j];
    if (norm2(d) < reach * reach)
      out.emplace_back(std::min(p.id[i], p.id[j]), std::max(p.id[i], p.id[j]));
  }
  std::sort(out.begin(), out.end());
  return out;
}

Pairs reference_contacts(const Simulation& sim) {
  const ParticleStore& p = sim.particles();
  PairList all;
  find_pairs_all_pairs(p.position_m, p.radius_m, sim.box(), 0.0, all);
  Pairs out;
  for (std::size_t k = 0; k < all.size(); ++k) {
    const ParticleId a = p.id[all.first[k]], b = p.id[all.second[k]];
    out.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(out.begin(), out.end());
  return out;
}

SceneConfig gas() {
  return test::periodic_random_gas(2e-3, 800, {SizeDistributionKind::Fixed, 100e-6}, 2.0,
                                   test::table1_material(0.5, 0.3), 11);
}

// Adds `count` particles of diameter d at random free positions (no overlap), ids after `next_id`.
void add_free_particles(Simulation& sim, int count, double d, ParticleId& next_id,
                        std::mt19937_64& rng) {
  ParticleStore& p = sim.particles();
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const PeriodicBox& box = sim.box();
  for (int added = 0; added < count;) {
    const Vec3 x{u(rng) * box.length(0), u(rng) * box.length(1), u(rng) * box.length(2)};
    bool free = true;
    for (std::size_t i = 0; i < p.size() && free; ++i)
      free = norm(box.minimum_image(p.position_m[i] - x)) > p.radius_m[i] + 0.5 * d;
    if (!free) continue;
    p.add(sim.materials(), 0, next_id++, x, {u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5}, {}, d);
    ++added;
  }
}

TEST(LivingPopulation, ContactSetStaysExactThroughRemovalsAndAdditions) {
  Simulation sim(gas());
  std::mt19937_64 rng(5);
  ParticleId next_id = 100000;
  EXPECT_EQ(sim.neighbors().stats().last_search.subcells_per_axis, 1) << "equal sizes: no sub-grid";
  for (int round = 0; round < 4; ++round) {
    for (int step = 0; step < 40; ++step) {
      sim.step();
      ASSERT_EQ(engine_contacts(sim), reference_contacts(sim))
          << "round " << round << " step " << step;
      ASSERT_EQ(touching_pairs_outside_the_force_pass(sim), 0)
          << "round " << round << " step " << step;
    }
    ParticleStore& p = sim.particles();
    for (std::size_t i = 0; i < p.size(); i += 7) p.remove_swap(i);  // an outlet takes some
    add_free_particles(sim, 600, 8e-6, next_id, rng);                // breakage brings fines
  }
  sim.step();  // the population changed: this step rebuilds
  const ParticleStore& p = sim.particles();
  const auto [r_min, r_max] = std::minmax_element(p.radius_m.begin(), p.radius_m.end());
  EXPECT_DOUBLE_EQ(sim.neighbors().skin_m(), 0.5 * std::sqrt(*r_min * *r_max))
      << "skin = ¼ √(d_min d_max) of the current population";
  const double volume = std::pow(sim.box().length(0), 3);
  const GridDivision expected = choose_grid_division(p.radius_m, sim.neighbors().skin_m(), volume);
  EXPECT_EQ(sim.neighbors().stats().last_search.subcells_per_axis, expected.subcells_per_axis);
  EXPECT_EQ(sim.neighbors().stats().last_search.levels, expected.levels);
}

// One fast particle in a long slab of slow ones: the gap bands must open only in the slot blocks
// around it (neighbor_list.h), and every touching pair must still be looked at. With one bound
// for all, the fast particle would open every band everywhere before each rebuild.
TEST(LivingPopulation, GapBandsOpenOnlyAroundAFastParticle) {
  const double d = 60e-6;
  SceneConfig scene = test::empty_scene({0, 0, 0}, {24e-3, 1e-3, 1e-3},
                                        test::table1_material(0.5, 0.3), {true, true, true});
  SourceConfig slow;
  slow.kind = SourceKind::Random;
  slow.count = 6 * 4096;  // six slot blocks, laid out along the slab by the spatial reorder
  slow.region_min_m = {0, 0, 0};
  slow.region_max_m = {24e-3, 1e-3, 1e-3};
  slow.sizes = {SizeDistributionKind::Fixed, d};
  slow.velocity_spread_m_per_s = 0.01;
  scene.sources.push_back(slow);
  test::add_particle(scene, {12.01e-3, 0.51e-3, 0.49e-3}, {10.0, 0.3, 0.2}, d);
  scene.seed = 3;
  Simulation sim(scene);
  const std::uint64_t rebuilds_at_start = sim.neighbors().stats().rebuilds;
  double most_looked_at = 0.0;  // largest share of candidates the force loop looked at
  for (int step = 0; step < 200; ++step) {
    sim.step();
    const NeighborList& nl = sim.neighbors();
    std::size_t looked_at = 0;
    for (const NeighborList::PairRange& range : nl.active_ranges())
      looked_at += range.end - range.begin;
    most_looked_at = std::max(most_looked_at, double(looked_at) / double(nl.pairs.size()));
    ASSERT_EQ(touching_pairs_outside_the_force_pass(sim), 0) << "step " << step;
    if (step % 100 == 99) {
      ASSERT_EQ(engine_contacts(sim), reference_contacts(sim)) << step;
    }
  }
  EXPECT_GE(sim.neighbors().stats().rebuilds - rebuilds_at_start, 2u)
      << "the fast particle must have forced rebuilds";
  // One bound for all opens every band everywhere before each rebuild (a share of 1).
  EXPECT_LT(most_looked_at, 0.75) << "bands opened far from the fast particle";
}

}  // namespace
}  // namespace millsim
