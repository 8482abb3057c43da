// The stiff and extreme scenes of cases/stability/: each either runs stably (no guard trips,
// energy does not grow, momentum or restitution as physics demands) or is stopped with its
// documented message. Expectations are written in each scene's description.
#include <gtest/gtest.h>

#include <cmath>

#include "scene/scene_json.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

SceneConfig load_case(const std::string& name) {
  return load_scene(std::string(MILLSIM_SOURCE_DIR) + "/cases/stability/" + name + ".json");
}

// Runs to the end; fails the test on a guard stop. Returns the initial energy.
EnergyReport run_to_end(Simulation& sim) {
  const EnergyReport start = sim.energy();
  while (sim.step_index() < sim.total_steps()) {
    const auto failure = sim.step();
    if (failure) {
      ADD_FAILURE() << failure->detail;
      break;
    }
  }
  return start;
}

TEST(StabilityCases, StiffFinesAtHundredMetresPerSecondRunStably) {
  Simulation sim(load_case("fines_100mps"));
  const EnergyReport start = run_to_end(sim);
  EXPECT_LT(sim.energy().total_j(), start.total_j()) << "e = 0.5 collisions must dissipate";
  EXPECT_GT(sim.energy().kinetic_j, 0.0);
  EXPECT_EQ(sim.penetration_limiter_events(), 0u) << "the automatic step resolves every contact";
}

TEST(StabilityCases, SizeRatioThousandRunsStablyAndFinesRebound) {
  Simulation sim(load_case("size_ratio_1000"));
  const Vec3 p0 = test::total_momentum(sim.particles());
  run_to_end(sim);
  const ParticleStore& p = sim.particles();
  std::size_t rebounded = 0;
  for (std::size_t i = 1; i < p.size(); ++i) rebounded += p.motion[i].velocity_m_per_s.x > 0.0;
  EXPECT_GT(rebounded, p.size() / 2) << "most fines must have bounced off the coarse particle";
  // No wall was touched, so momentum is conserved (to rounding of the fines' momenta).
  EXPECT_LT(norm(test::total_momentum(p) - p0), 1e-9 * norm(p0));
}

TEST(StabilityCases, PaperParallelTangentialSpringsAtSizeRatioThousandDoNotProduceGarbage) {
  // Eq. 3's parallel tangential sum is 11.5× too stiff for a 1 µm fine on a 1 mm particle. The
  // fines slide on the coarse particle, and a sliding spring is held at μ F_n with no damping
  // (contact_forces.cpp), so the stiffness no longer feeds an instability here; before that law
  // the guard had to stop this run on energy growth. Either way no garbage may come out: the run
  // is stopped by the guard, or it ends with no energy gained, momentum conserved and the fines
  // rebounding, as with the series springs.
  SceneConfig scene = load_case("size_ratio_1000");
  scene.contact.model = ContactModel::PaperSprings;
  Simulation sim(scene);
  const Vec3 p0 = test::total_momentum(sim.particles());
  const EnergyReport start = sim.energy();
  std::optional<StepFailure> failure;
  while (!failure && sim.step_index() < sim.total_steps()) failure = sim.step();
  if (failure) {
    EXPECT_EQ(failure->cause, "energy_growth");
    return;
  }
  const ParticleStore& p = sim.particles();
  EXPECT_LT(sim.energy().total_j(), start.total_j());
  std::size_t rebounded = 0;
  for (std::size_t i = 1; i < p.size(); ++i) rebounded += p.motion[i].velocity_m_per_s.x > 0.0;
  EXPECT_GT(rebounded, p.size() / 2);
  EXPECT_LT(norm(test::total_momentum(p) - p0), 1e-9 * norm(p0));
}

TEST(StabilityCases, ParticleIntoWallAtThreeHundredMetresPerSecondRebounds) {
  Simulation sim(load_case("wall_300mps"));
  run_to_end(sim);
  EXPECT_NEAR(sim.particles().motion[0].velocity_m_per_s.z / 300.0, 0.5,
              0.02 * 0.5);  // e within 2 %
}

std::string build_error(const std::string& name) {
  try {
    Simulation sim(load_case(name));
  } catch (const InputErrorList& e) {
    return format_input_errors(name, e.errors());
  }
  return "";
}

TEST(StabilityCases, OverlappingStartIsRejectedNamingThePairAndTheLimit) {
  const std::string message = build_error("overlapping_start");
  EXPECT_NE(message.find("overlaps particle"), std::string::npos) << message;
  EXPECT_NE(message.find("at the start; at most 15 % is allowed (/contact/penetration_limit)"),
            std::string::npos)
      << message;
}

TEST(StabilityCases, PlainlyTooLargeStepIsRejectedBeforeTheRun) {
  const std::string message = build_error("step_too_large");
  EXPECT_NE(message.find("/time/step_s = 4e-07: expected at most the Rayleigh time"),
            std::string::npos)
      << message;
}

}  // namespace
}  // namespace millsim
