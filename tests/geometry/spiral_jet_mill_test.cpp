// The shipped spiral jet mill (cases/spiral_jet_mill.json), shortened so it runs in seconds: it
// must grind by successive breakage (a fragment of a fragment breaks: generation ≥ 2), keep
// every particle inside its chamber, and conserve mass to rounding through feed, breakage, dust
// and the outlet tally: particles + outlet + dust = fed, to 1e-12.
#include <gtest/gtest.h>

#include <cmath>

#include "gas/gas_grid.h"
#include "gas/gas_solver.h"
#include "process/classification.h"
#include "scene/scene_json.h"
#include "sim/simulation.h"

namespace millsim {
namespace {

TEST(SpiralJetMill, GrindsBySuccessiveBreakageAndConservesMass) {
  SceneConfig scene =
      load_scene(std::filesystem::path(MILLSIM_SOURCE_DIR) / "cases/spiral_jet_mill.json");
  // Shortened: a coarser dust threshold (fewer, larger fragments), half the spin-up, 1.5 ms.
  scene.dust->threshold_diameter_m = 8e-5;
  scene.gas->spin_up_s = 0.006;
  scene.time.end_s = 0.0015;
  Simulation sim(scene);
  while (sim.step_index() < sim.total_steps()) {
    const std::int64_t steps = std::min<std::int64_t>(20000, sim.total_steps() - sim.step_index());
    const auto failure = sim.advance(steps);
    ASSERT_FALSE(failure.has_value()) << failure->detail;
    const ParticleStore& p = sim.particles();
    // Inside the mantle and between the plates, up to half a radius of overlap (the tube's
    // inside is the outlet, emptied at the next population update).
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Vec3 d = p.position_m[i] - scene.mill->axis_point_m;
      const double slack = 0.5 * p.radius_m[i];
      ASSERT_LE(std::hypot(d.x, d.y), scene.mill->radius_m + slack)
          << "particle " << p.id[i] << " went through the mantle by step " << sim.step_index();
      ASSERT_GE(d.z, -slack) << "particle " << p.id[i] << " went through the floor";
      ASSERT_LE(d.z, scene.mill->height_m + slack)
          << "particle " << p.id[i] << " went through the top";
    }
  }
  const BreakageStats& b = sim.breakage()->stats();
  ASSERT_GE(b.events_by_generation.size(), 3u) << "no fragment of a fragment broke";
  EXPECT_GT(b.events_by_generation[2], 0u);
  EXPECT_GE(b.max_generation, 3);
  const MassBalance m = sim.mass_balance();
  EXPECT_GT(m.fed_kg, 0.0);
  EXPECT_GT(m.dust_kg, 0.0);
  EXPECT_LE(std::abs(m.relative_error()), 1e-12);
  EXPECT_EQ(sim.outlet_mass_by_outlet_kg().size(), 1u) << "the vortex finder is the only outlet";
}

TEST(SpiralJetMill, ItsGasSpinUpEndsOnTheDevelopedVortex) {
  // The case's spin-up is there so the particles start in the developed flow (docs/gas.md). The
  // vortex has settled when 12 ms more of the same solve no longer change it: the mean
  // tangential gas speed at the outlet radius (between floor and tube mouth, where the
  // force-balance cut size is taken) and over the whole height out to the mantle, within 5 %.
  // A 12 ms spin-up fails here: the vortex then still overshoots, 43 % faster at the outlet.
  // About 30 s of gas solving: skipped under the sanitizers, where the same solver code runs in
  // the shorter gas tests.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_UNDEFINED__)
  GTEST_SKIP() << "a physics check of the shipped case; too slow under the sanitizers";
#endif
  const SceneConfig scene =
      load_scene(std::filesystem::path(MILLSIM_SOURCE_DIR) / "cases/spiral_jet_mill.json");
  ASSERT_TRUE(scene.gas && scene.mill);
  const MillConfig& mill = *scene.mill;
  GasSolver gas(
      *scene.gas,
      build_gas_grid(*scene.gas, scene.domain.min_m, scene.domain.max_m, scene.domain.periodic),
      scene.gravity_m_per_s2);
  const auto solve_for = [&](double duration_s) {
    for (double done_s = 0.0; done_s < duration_s;) {
      const double dt = std::min(gas.stable_step_s(), duration_s - done_s);
      ASSERT_FALSE(gas.advance(dt).has_value());
      done_s += dt;
    }
  };
  const std::vector<double> radii = {mill.outlet.radius_m, 0.5 * mill.radius_m,
                                     0.75 * mill.radius_m};
  const auto vortex = [&] {
    std::vector<double> u_t = {
        sample_vortex(gas, mill, mill.outlet.radius_m, 0.0, mill.height_m - mill.outlet.depth_m)
            .tangential_m_per_s};
    for (double r : radii)
      u_t.push_back(sample_vortex(gas, mill, r, 0.0, mill.height_m).tangential_m_per_s);
    return u_t;
  };
  solve_for(scene.gas->spin_up_s);
  const std::vector<double> developed = vortex();
  solve_for(0.012);
  const std::vector<double> later = vortex();
  for (std::size_t k = 0; k < developed.size(); ++k) {
    EXPECT_GT(developed[k], 1.0) << "sample " << k << ": the jets spin the gas";
    EXPECT_NEAR(later[k], developed[k], 0.05 * developed[k]) << "sample " << k;
  }
}

}  // namespace
}  // namespace millsim
