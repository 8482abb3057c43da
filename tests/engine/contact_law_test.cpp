// The series/parallel per-particle springs of §3.2 against the equivalent-property model
// (Eq. 1): for two particles of equal properties they must coincide exactly (the paper's note
// under Fig. 6), and both must be textbook Hertz–Mindlin: k_n = (4/3)E*√R*, k_t = 8G*√R*.
#include <gtest/gtest.h>

#include <cmath>

#include "contact/contact_law.h"
#include "support/scenes.h"

namespace millsim {
namespace {

ParticleStore two_particles(const MaterialTable& table, double d1, double d2) {
  ParticleStore p;
  p.add(table, 0, 1, {}, {}, {}, d1);
  p.add(table, 0, 2, {1, 0, 0}, {}, {}, d2);
  return p;
}

TEST(ContactLaw, SeriesEqualsEquivalentAndHertzForEqualParticles) {
  for (double e : {0.4, 0.7, 1.0})
    for (double d : {1e-6, 30e-6, 1e-3}) {
      SceneConfig scene = test::empty_scene({0, 0, 0}, {1, 1, 1}, test::table1_material(e));
      const MaterialTable table(scene);
      const ParticleStore p = two_particles(table, d, d);
      const PairConstants& pc = table.pair(0, 0);
      const PairSprings series = SeriesSprings(p)(0, 1, pc);
      const PairSprings paper = PaperSprings(p)(0, 1, pc);  // Eq. 3: tangential in parallel
      EXPECT_NEAR(paper.tangential_stiffness, series.tangential_stiffness,
                  1e-12 * series.tangential_stiffness);
      EXPECT_NEAR(paper.tangential_damping, series.tangential_damping,
                  1e-12 * series.tangential_damping + 1e-300);
      const PairSprings equivalent = EquivalentProperties(p)(0, 1, pc);
      const double E = 1e9, nu = 0.3, G = E / (2 * (1 + nu)), r = 0.5 * d;
      const double hertz_kn = 4.0 / 3.0 * (E / (2 * (1 - nu * nu))) * std::sqrt(0.5 * r);
      const double mindlin_kt = 8.0 * (G / (2 * (2 - nu))) * std::sqrt(0.5 * r);
      EXPECT_NEAR(series.normal_stiffness, hertz_kn, 1e-12 * hertz_kn);
      EXPECT_NEAR(equivalent.normal_stiffness, hertz_kn, 1e-12 * hertz_kn);
      EXPECT_NEAR(series.tangential_stiffness, mindlin_kt, 1e-12 * mindlin_kt);
      EXPECT_NEAR(equivalent.tangential_stiffness, mindlin_kt, 1e-12 * mindlin_kt);
      EXPECT_NEAR(series.normal_damping, equivalent.normal_damping,
                  1e-12 * equivalent.normal_damping + 1e-300);
      EXPECT_NEAR(series.tangential_damping, equivalent.tangential_damping,
                  1e-12 * equivalent.tangential_damping + 1e-300);
    }
}

TEST(ContactLaw, SeriesAndEquivalentDifferForUnequalSizes) {
  // Expectation: series k = (1/k₁ + 1/k₂)⁻¹ with k_i ∝ √r_i is not (4/3)E*√R*; at a size ratio
  // of 10/30 they must differ (the spread that Fig. 7 shows).
  SceneConfig scene = test::empty_scene({0, 0, 0}, {1, 1, 1}, test::table1_material(0.5));
  const MaterialTable table(scene);
  const ParticleStore p = two_particles(table, 30e-6, 10e-6);
  const PairSprings series = SeriesSprings(p)(0, 1, table.pair(0, 0));
  const PairSprings equivalent = EquivalentProperties(p)(0, 1, table.pair(0, 0));
  EXPECT_GT(std::abs(series.normal_stiffness / equivalent.normal_stiffness - 1.0), 0.01);
}

TEST(ContactLaw, SeriesTangentialFollowsTheFinePartnerLikeMindlin) {
  // Expectation: Mindlin k_t = 8G*√(R*δ) with R* → r_fine as the partner grows; the series
  // tangential spring must stay within the same factor of it as the series normal spring is of
  // Hertz (√2 at 1:1000), while Eq. 3's parallel sum is (1 + √1000)/(2√2) = 11.5× Mindlin.
  SceneConfig scene = test::empty_scene({0, 0, 0}, {1, 1, 1}, test::table1_material(0.5));
  const MaterialTable table(scene);
  const ParticleStore p = two_particles(table, 1e-6, 1e-3);
  const PairSprings series = SeriesSprings(p)(0, 1, table.pair(0, 0));
  const PairSprings paper = PaperSprings(p)(0, 1, table.pair(0, 0));
  const PairSprings mindlin = EquivalentProperties(p)(0, 1, table.pair(0, 0));
  EXPECT_NEAR(series.tangential_stiffness / mindlin.tangential_stiffness,
              series.normal_stiffness / mindlin.normal_stiffness, 0.01);
  EXPECT_NEAR(paper.tangential_stiffness / mindlin.tangential_stiffness,
              (1.0 + std::sqrt(1000.0)) / (2.0 * std::sqrt(2.0)), 0.01);
}

}  // namespace
}  // namespace millsim
