// 200 random particle–wall impacts over the ranges of Table 2 (d 1–10 000 µm, E 1e7–1e11 Pa,
// ρ 500–5000 kg/m³, ν 0.34, e 0.4–1, wall E 1e9–1e11 Pa, ν_w 0.3, V 1–100 m/s, dt = 1/10 of
// the largest step the engine accepts). Expectations:
//   with the damping Eq. 13 was fitted for (α = 2γ, DESIGN.md errata): the simulated maximum
//   overlap is within 0.5 % of Eq. 13 (the paper reports < 0.3 %);
//   with the engine's default (restitution-calibrated) damping: within 0.5 % of the engine's
//   predictor, which is the dimensionless solution for that damping.
// Impacts whose predicted overlap exceeds a quarter of the diameter are redrawn: Hertz theory
// assumes small strains, and the engine's guard stops such runs.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "contact/penetration_limit.h"
#include "sim/simulation.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

struct Impact {
  double d, E, rho, e, E_wall, v;
};

double log_uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo * std::pow(hi / lo, std::uniform_real_distribution<double>(0, 1)(rng));
}

SceneConfig impact_scene(const Impact& c, DampingModel damping) {
  MaterialConfig particle{"particle", c.E, 0.34, c.rho, c.e, 0.0, 0.0, false, {}};
  MaterialConfig wall{"wall", c.E_wall, 0.3, 7800, 1.0, 0.0, 0.0, false, {}};
  const double L = 4.0 * c.d;
  SceneConfig s = test::empty_scene({-L, -L, 0}, {L, L, L}, particle);
  s.materials.push_back(wall);
  s.domain.wall_material = 1;
  s.contact.damping = damping;
  s.contact.max_impact_speed_m_per_s = c.v;
  s.contact.penetration_limiter = false;
  s.contact.penetration_limit = 0.45;
  s.time.end_s = 1e-4;              // stepped by hand below; only bounds the planned step count
  s.time.safety_factor = 0.1;       // automatic step = min(t_R, t_c/8) / 10:
  s.time.steps_per_contact = 80.0;  // a tenth of the largest accepted step
  test::add_particle(s, {0, 0, 0.5 * c.d * 1.0001}, {0, 0, -c.v}, c.d);
  return s;
}

// Simulated maximum overlap against the predictor; returns the relative error.
double relative_error(const Impact& c, DampingModel damping) {
  Simulation sim(impact_scene(c, damping));
  const ParticleStore& p = sim.particles();
  double max_overlap = 0.0;
  while (p.motion[0].velocity_m_per_s.z < 0.0 || max_overlap == 0.0) {
    if (const auto failure = sim.step()) {
      ADD_FAILURE() << failure->detail;
      return 1.0;
    }
    max_overlap = std::max(max_overlap, p.radius_m[0] - p.position_m[0].z);
    if (sim.step_index() > 10'000'000) return 1.0;
  }
  const double r = 0.5 * c.d, mass = c.rho * 4.0 / 3.0 * M_PI * r * r * r;
  const double e_star = 1.0 / ((1 - 0.34 * 0.34) / c.E + (1 - 0.3 * 0.3) / c.E_wall);
  const double k = 4.0 / 3.0 * e_star * std::sqrt(r);  // Eq. 5 with R* = r
  const double expected = predicted_max_overlap_m(damping, mass, k, c.v, c.e);
  return std::abs(max_overlap - expected) / expected;
}

TEST(OverlapSweep, TwoHundredImpactsMatchTheMaxOverlapPredictors) {
  MILLSIM_RELEASE_ONLY("tests/physics/impact_test.cpp");
  std::mt19937_64 rng(2013);
  std::vector<Impact> impacts;
  while (impacts.size() < 200) {
    Impact c{log_uniform(rng, 1e-6, 1e-2), log_uniform(rng, 1e7, 1e11),
             log_uniform(rng, 500, 5000),  std::uniform_real_distribution<double>(0.4, 1.0)(rng),
             log_uniform(rng, 1e9, 1e11),  log_uniform(rng, 1.0, 100.0)};
    const double r = 0.5 * c.d, mass = c.rho * 4.0 / 3.0 * M_PI * r * r * r;
    const double e_star = 1.0 / ((1 - 0.34 * 0.34) / c.E + (1 - 0.3 * 0.3) / c.E_wall);
    if (hertz_max_overlap_m(mass, 4.0 / 3.0 * e_star * std::sqrt(r), c.v) > 0.25 * c.d) continue;
    impacts.push_back(c);
  }
  for (DampingModel damping : {DampingModel::Paper, DampingModel::Restitution}) {
    double worst = 0.0, sum = 0.0;
    for (const Impact& c : impacts) {
      const double err = relative_error(c, damping);
      if (std::getenv("MILLSIM_SWEEP_VERBOSE"))
        std::printf("d=%.3g E=%.3g rho=%.0f e=%.3f Ew=%.3g v=%.3g err=%.4f%%\n", c.d, c.E, c.rho,
                    c.e, c.E_wall, c.v, 100 * err);
      worst = std::max(worst, err);
      sum += err;
    }
    const char* name = damping == DampingModel::Paper ? "eq13_alpha_2gamma" : "engine_predictor";
    std::printf("overlap sweep (%s): 200 impacts, max error %.4f %%, mean error %.4f %%\n", name,
                100.0 * worst, 100.0 * sum / 200.0);
    RecordProperty(std::string(name) + "_max_error", std::to_string(worst));
    RecordProperty(std::string(name) + "_mean_error", std::to_string(sum / 200.0));
    EXPECT_LT(worst, 0.005) << name;  // 0.5 %, issue 4
  }
}

}  // namespace
}  // namespace millsim
