// Conservation laws on a granular gas in a periodic box:
//   e = 1, μ = 0: total energy (kinetic + rotational + elastic) is conserved (velocity Verlet,
//   bounded error), within 0.1 % over 10 000 steps (issue 2);
//   any e and μ: linear momentum is conserved to rounding (Newton's third law in every contact).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

SceneConfig granular_gas(double restitution, double friction, std::int64_t count,
                         double solids_fraction) {
  const double d = 100e-6;
  const double L = std::cbrt(double(count) * std::numbers::pi / 6.0 * d * d * d / solids_fraction);
  return test::periodic_random_gas(L, count, {SizeDistributionKind::Uniform, 0.0, 0.8 * d, 1.2 * d},
                                   2.0, test::table1_material(restitution, friction), 42);
}

TEST(Conservation, ElasticFrictionlessGasConservesEnergy) {
  // Expectation: energy conservation (no damping, no friction, no gravity).
  Simulation sim(granular_gas(1.0, 0.0, 400, 0.25));
  const double e0 = sim.energy().total_j();
  double worst = 0.0;
  std::uint64_t contact_steps = 0;
  for (int step = 1; step <= 10'000; ++step) {
    const auto failure = sim.step();
    ASSERT_FALSE(failure.has_value()) << failure->detail;
    contact_steps += sim.contact_stats().touching_pairs;
    if (step % 50 == 0) worst = std::max(worst, std::abs(sim.energy().total_j() - e0) / e0);
  }
  EXPECT_GT(contact_steps, 20'000u) << "too few collisions for the test to mean anything";
  EXPECT_LT(worst, 1e-3) << "relative energy drift";  // 0.1 %, issue 2
}

TEST(Conservation, DampedFrictionalGasConservesMomentum) {
  // Expectation: Newton's third law; the sum of m v stays at its initial value to rounding.
  Simulation sim(granular_gas(0.5, 0.3, 400, 0.3));
  const Vec3 p0 = test::total_momentum(sim.particles());
  double scale = 0.0;  // Σ m|v|, the size of the terms that round
  for (std::size_t i = 0; i < sim.particles().size(); ++i)
    scale += sim.particles().mass_kg[i] * norm(sim.particles().motion[i].velocity_m_per_s);
  const double e0 = sim.energy().kinetic_j;
  for (int step = 0; step < 3000; ++step) ASSERT_FALSE(sim.step().has_value());
  EXPECT_LT(sim.energy().kinetic_j, 0.9 * e0) << "collisions must have dissipated energy";
  EXPECT_LT(norm(test::total_momentum(sim.particles()) - p0), 1e-12 * scale);
}

}  // namespace
}  // namespace millsim
