// Same scene, same seed → the same run, bit for bit: every automatic choice (skin steering,
// sub-cell division, reordering) depends on counted quantities only, never on timing
// (docs/contact-search.md). Studies compare runs with each other, so this must hold.
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "gas/gas_config.h"
#include "sim/simulation.h"
#include "support/run_compare.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

SceneConfig wide_gas() {
  // 5000 particles: above the reordering threshold.
  return test::periodic_random_gas(
      1.2e-3, 5000, {SizeDistributionKind::PowerLaw, 0.0, 5e-6, 100e-6, 0.0, 1.0, -2.5}, 3.0,
      test::table1_material(0.5, 0.3), 99);
}

TEST(Determinism, SameSceneAndSeedGiveBitIdenticalRuns) {
  // 800 steps: with skin by speed the lists outlive 400 (two builds), and the steering must act.
  Simulation a(wide_gas()), b(wide_gas());
  for (int step = 0; step < 800; ++step) {
    ASSERT_FALSE(a.step().has_value());
    ASSERT_FALSE(b.step().has_value());
  }
  EXPECT_GT(a.neighbors().stats().rebuilds, 2u) << "the skin steering must have had a say";
  const ParticleStore &pa = a.particles(), &pb = b.particles();
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(pa.id, pb.id);
  EXPECT_EQ(0, std::memcmp(pa.position_m.data(), pb.position_m.data(), pa.size() * sizeof(Vec3)));
  EXPECT_EQ(0, std::memcmp(pa.motion.data(), pb.motion.data(), pa.size() * sizeof(Motion)));
  EXPECT_EQ(a.neighbors().skin_m(), b.neighbors().skin_m());
}

TEST(Determinism, AdvanceIsStepByStepBitForBit) {
  // Simulation::advance carries each step's closing kick into the next step's kick-drift; the
  // reference is the plain step-by-step trajectory.
  Simulation fused(wide_gas()), plain(wide_gas());
  ASSERT_FALSE(fused.advance(150).has_value());
  ASSERT_FALSE(fused.advance(250).has_value());
  for (int step = 0; step < 400; ++step) ASSERT_FALSE(plain.step().has_value());
  EXPECT_EQ(fused.step_index(), plain.step_index());
  EXPECT_EQ(fused.contact_steps(), plain.contact_steps());
  EXPECT_GT(fused.profile().seconds[std::size_t(Phase::Kick)], 0.0);
  EXPECT_GT(fused.carried_kicks(), 0u) << "kicks must have been carried";
  const ParticleStore &pa = fused.particles(), &pb = plain.particles();
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(pa.id, pb.id);
  EXPECT_EQ(0, std::memcmp(pa.position_m.data(), pb.position_m.data(), pa.size() * sizeof(Vec3)));
  EXPECT_EQ(0, std::memcmp(pa.motion.data(), pb.motion.data(), pa.size() * sizeof(Motion)));
  EXPECT_EQ(0, std::memcmp(pa.load.data(), pb.load.data(), pa.size() * sizeof(Load)));
  EXPECT_EQ(fused.energy().total_j(), plain.energy().total_j());
}

TEST(Determinism, MultiRateCarriedKicksAreBitForBit) {
  // Under multi-rate stepping advance() carries the stepping particles' closing kick into their
  // next kick-drift until something reads them (breakage, outlets and feeds, the gas, the health
  // check, a change of the sets). The reference closes every step's kick in that step: breakage
  // (attrition target), kept fluid forces (fluidized bed), and a mill with its feed, outlet,
  // breakage and compressible gas.
  struct Case {
    const char* file;
    double end_s;
  };
  // Under the sanitizers (5-15x slower) half the bed's window.
#if defined(MILLSIM_SANITIZED)
  constexpr double kBedEnd = 0.005;
#else
  constexpr double kBedEnd = 0.01;
#endif
  for (const Case& c : {Case{"attrition_target.json", 6e-4}, Case{"fluidized_bed.json", kBedEnd},
                        Case{"spiral_jet_mill_4barg.json", 5e-5}}) {
    SCOPED_TRACE(c.file);
    SceneConfig scene = test::shipped_case(c.file, test::bit_for_bit_window_s(c.file, c.end_s));
    scene.time.multi_rate = true;
    if (scene.gas && scene.gas->model == GasModel::Compressible) scene.gas->spin_up_s = 0.0;
    Simulation carried(scene), plain(scene);
    plain.carry_closing_kicks(false);
    ASSERT_FALSE(carried.advance(carried.total_steps()).has_value());
    ASSERT_FALSE(plain.advance(plain.total_steps()).has_value());
    test::expect_identical(carried, plain);
    EXPECT_GT(carried.carried_kicks(), std::uint64_t(carried.total_steps() / 4))
        << "the stepping particles' kicks must have been carried";
    EXPECT_EQ(plain.carried_kicks(), 0u);
    EXPECT_GT(carried.multi_rate()->stats.waiting_particle_steps, 0.0)
        << "the case must have particles in free flight";
    if (std::string(c.file) == "attrition_target.json") {
      EXPECT_GT(carried.breakage()->stats().events, 0u) << "the case must break something";
    }
  }
}

}  // namespace
}  // namespace millsim
