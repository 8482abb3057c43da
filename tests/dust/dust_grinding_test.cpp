// Dust ground by sweeping particles (dust/dust_grinding.h), against independent expectations:
//   - the impaction efficiency's fit at its ends and knee;
//   - the swept breakage probability against a brute-force average of the strength model's own
//     selection probability over the impact parameters of the swept disc (Vogel–Peukert closed
//     form; Weibull by quadrature);
//   - the fragment shares against the Gates–Gaudin–Schuhmann B integrated between class edges;
//   - a particle crossing uniform dust in still gas: the class decays at the analytic rate
//     λ = π (R + r)² s η P̄ / V_cell, the fragments land in the finer classes by the shares, the
//     cell's dust mass is conserved to 1e-12, and a slow particle grinds nothing;
//   - the scene keys refused where they cannot work, each naming /dust/grinding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>

#include "comminution/strength.h"
#include "dust/dust_grinding.h"
#include "gas/gas_solver.h"
#include "particles/materials.h"
#include "scene/scene_json.h"
#include "support/scenes.h"

namespace millsim {
namespace {

MaterialConfig salt() {
  MaterialConfig m;
  m.name = "salt";
  m.youngs_modulus_pa = 1e9;
  m.poisson_ratio = 0.25;
  m.density_kg_per_m3 = 2160;
  m.restitution = 0.5;
  m.friction = 0.5;
  MaterialBreakageConfig b;
  b.strength.model = StrengthModel::VogelPeukert;
  b.strength.f_mat_kg_per_j_m = 60.0;
  b.strength.x_w_min_j_m_per_kg = 0.003;
  b.fragments.model = FragmentModel::PowerLaw;
  b.fragments.exponent = 1.0;
  b.fragments.min_ratio = 0.05;
  b.fragments.max_ratio = 0.7;
  m.breakage = b;
  return m;
}

// The average over the swept disc (impact parameter b, area element 2πb db) of the selection
// probability at the normal component's energy W0 (1 − b²/R²): 20 000 rings.
double disc_average(const StrengthConfig& s, double d, double w0) {
  const int rings = 20000;
  double sum = 0.0;
  for (int i = 0; i < rings; ++i) {
    const double b = (i + 0.5) / rings;  // in units of R
    sum += 2.0 * b / rings * selection_probability(s, d, w0 * (1.0 - b * b));
  }
  return sum;
}

TEST(DustGrinding, ImpactionEfficiencyVanishesAtRestReachesOneAndIsAQuarterAtItsKnee) {
  EXPECT_EQ(impaction_efficiency(0.0), 0.0);
  EXPECT_EQ(impaction_efficiency(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(impaction_efficiency(0.25), 0.25);
  EXPECT_NEAR(impaction_efficiency(1e6), 1.0, 1e-6);
  double last = 0.0;
  for (double st = 1e-3; st < 1e3; st *= 1.5) {
    EXPECT_GT(impaction_efficiency(st), last);
    last = impaction_efficiency(st);
  }
}

TEST(DustGrinding, TheSweptProbabilityIsTheStrengthsAverageOverTheSweptDisc) {
  const StrengthConfig vp = salt().breakage->strength;
  for (double d : {1e-6, 4e-6, 9e-6})
    for (double w0 : {10.0, 400.0, 1e3, 5e3, 5e4, 1e6}) {
      const double expected = disc_average(vp, d, w0);
      EXPECT_NEAR(swept_selection_probability(vp, d, w0), expected, 2e-6)
          << "d " << d << " W0 " << w0;
    }
  // Below W_min = 0.003 / d nothing breaks, at any impact parameter.
  EXPECT_EQ(swept_selection_probability(vp, 9e-6, 0.99 * 0.003 / 9e-6), 0.0);
  StrengthConfig weibull;
  weibull.model = StrengthModel::Weibull;
  weibull.median_energy_j_per_kg = 800.0;
  weibull.reference_diameter_m = 1e-5;
  weibull.size_exponent = 0.5;
  weibull.weibull_modulus = 3.0;
  for (double w0 : {100.0, 1e3, 1e4})
    EXPECT_NEAR(swept_selection_probability(weibull, 5e-6, w0), disc_average(weibull, 5e-6, w0),
                2e-4)
        << w0;
}

// Classes from edges 1, 2, 4, 8, 16 µm and a 10 µm threshold: 0 (< 1 µm), [1, 2), [2, 4), [4, 8),
// [8, 10].
std::vector<double> test_edges() {
  return {1e-6, 2e-6, 4e-6, 8e-6, 16e-6};
}

TEST(DustGrinding, FragmentSharesFollowTheBreakageFunctionBetweenTheClassEdges) {
  const MaterialConfig m = salt();
  const std::vector<DustClass> classes = dust_classes(test_edges(), 1e-5, 2160, 1.8e-5, 0.0);
  ASSERT_EQ(classes.size(), 5u);
  const auto shares =
      dust_fragment_shares(test_edges(), classes, FragmentSizeSampler(m.breakage->fragments));
  // Gates–Gaudin–Schuhmann with q = 1 normalised on [0.05, 0.7].
  const auto B = [](double r) { return std::clamp((r - 0.05) / (0.7 - 0.05), 0.0, 1.0); };
  const std::vector<double> edges = test_edges();
  for (std::size_t k = 1; k < classes.size(); ++k) {
    const double x = classes[k].diameter_m;
    double sum = 0.0, lower = 0.0;
    for (std::size_t j = 0; j <= k; ++j) {
      const double upper = j < k ? B(edges[j] / x) : 1.0;
      EXPECT_NEAR(shares[k][j], upper - lower, 1e-12) << "class " << k << " into " << j;
      lower = upper;
      sum += shares[k][j];
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  EXPECT_EQ(shares[0][0], 1.0) << "the finest class is not ground";
}

struct Cell {
  GasConfig config;
  std::unique_ptr<GasSolver> gas;
  std::unique_ptr<DustLedger> ledger;
};

// A periodic box of 4³ cells of 1 mm, still gas, no gravity, 1 µg of the 8.9 µm class in every
// cell.
Cell dusty_box() {
  Cell c;
  c.config.density_kg_per_m3 = 1.2;
  c.config.viscosity_pa_s = 1.8e-5;
  c.config.cells = {4, 4, 4};
  c.gas = std::make_unique<GasSolver>(
      c.config, build_gas_grid(c.config, {0, 0, 0}, {4e-3, 4e-3, 4e-3}, {true, true, true}),
      Vec3{});
  c.ledger = std::make_unique<DustLedger>(
      c.gas->grid(), dust_classes(test_edges(), 1e-5, 2160, 1.8e-5, 0.0), Vec3{});
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i)
        c.ledger->deposit({(i + 0.5) * 1e-3, (j + 0.5) * 1e-3, (k + 0.5) * 1e-3}, 4, 1e-9);
  c.ledger->advance(*c.gas, 1e-9);  // takes the gas's velocity (still)
  return c;
}

TEST(DustGrinding, AParticleCrossingUniformDustGrindsItAtTheAnalyticRate) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {1, 1, 1}, salt());
  const MaterialTable table(scene);
  for (double speed : {60.0, 200.0}) {
    Cell box = dusty_box();
    DustLedger& ledger = *box.ledger;
    const Vec3 x{1.5e-3, 1.5e-3, 1.5e-3};
    ParticleStore p;
    const double D = 2e-4;
    p.add(table, 0, 1, x, {speed, 0, 0}, {}, D);
    const std::size_t c = ledger.cell_of(x);
    DustGrinding grinding(ledger, test_edges(), salt(), 0, ImpactEquivalence::Energy);
    // The rate from its parts, computed here: η from τ s / R, P̄ from the disc average, the
    // energy equivalence's speed v m_p / (m_d + m_p).
    const DustClass& k4 = ledger.classes()[4];
    const double r = 0.5 * k4.diameter_m, R = 0.5 * D;
    const double tau = 2160 * k4.diameter_m * k4.diameter_m / (18 * 1.8e-5);
    ASSERT_NEAR(k4.relaxation_time_s, tau, 1e-12 * tau);
    const double m_d = 2160 * std::numbers::pi / 6 * std::pow(k4.diameter_m, 3);
    const double v = speed * p.mass_kg[0] / (m_d + p.mass_kg[0]);
    const double P = disc_average(salt().breakage->strength, k4.diameter_m, 0.5 * v * v);
    const double eta = std::pow((tau * speed / R) / (tau * speed / R + 0.25), 2);
    const double lambda = std::numbers::pi * (R + r) * (R + r) * speed * eta * P / 1e-9;
    const double stays = grinding.shares()[4][4];
    const double dt = 2e-5;
    const int passes = 10;
    // One pass: the finer classes, empty before it, receive their shares of what broke.
    grinding.grind(ledger, p, table, dt);
    const double first = 1e-9 - ledger.cell_mass_kg(4)[c];
    EXPECT_NEAR(first, 1e-9 * (1.0 - std::exp(-lambda * dt)) * (1.0 - stays), 1e-6 * first);
    for (int j = 0; j < 4; ++j)
      EXPECT_NEAR(ledger.cell_mass_kg(j)[c],
                  first * grinding.shares()[4][std::size_t(j)] / (1.0 - stays), 1e-12 * 1e-9)
          << "class " << j;
    // More passes: the class decays geometrically (the fragments are ground further in turn).
    for (int n = 1; n < passes; ++n) grinding.grind(ledger, p, table, dt);
    const double expected =
        1e-9 * std::pow(1.0 - (1.0 - std::exp(-lambda * dt)) * (1.0 - stays), passes);
    std::printf("s = %g m/s: P = %.4f, eta = %.4f, lambda = %.4g 1/s, left %.4g of 1e-9 kg\n",
                speed, P, eta, lambda, ledger.cell_mass_kg(4)[c]);
    EXPECT_GT(P, 0.0);
    EXPECT_NEAR(ledger.cell_mass_kg(4)[c], expected, 1e-6 * 1e-9);
    EXPECT_LT(ledger.cell_mass_kg(4)[c], 0.99e-9) << "it ground something";
    // The cell's dust is conserved.
    double cell_total = 0.0;
    for (int k = 0; k < ledger.class_count(); ++k) cell_total += ledger.cell_mass_kg(k)[c];
    EXPECT_NEAR(cell_total, 1e-9, 1e-12 * 1e-9);
    double ground = 0.0;
    for (double kg : grinding.stats().ground_kg) ground += kg;
    EXPECT_GE(ground, 1e-9 - ledger.cell_mass_kg(4)[c]);
    EXPECT_NEAR(ledger.held_kg(), 64e-9, 1e-12 * 64e-9) << "the box's dust is conserved";
    // The other cells, without a particle, kept their dust.
    EXPECT_EQ(ledger.cell_mass_kg(4)[ledger.cell_of({3.5e-3, 3.5e-3, 3.5e-3})], 1e-9);
    EXPECT_NEAR(grinding.stats().ground_kg[4], 1e-9 - ledger.cell_mass_kg(4)[c], 1e-12 * 1e-9);
  }
  // At 5 m/s, W0 = 12.5 J/kg lies below W_min = 0.003 / 8.9 µm = 337 J/kg: nothing breaks.
  Cell box = dusty_box();
  ParticleStore slow;
  slow.add(table, 0, 1, {1.5e-3, 1.5e-3, 1.5e-3}, {5, 0, 0}, {}, 2e-4);
  DustGrinding grinding(*box.ledger, test_edges(), salt(), 0, ImpactEquivalence::Energy);
  grinding.grind(*box.ledger, slow, table, 1e-3);
  EXPECT_EQ(box.ledger->cell_mass_kg(4)[box.ledger->cell_of({1.5e-3, 1.5e-3, 1.5e-3})], 1e-9);
}

TEST(DustGrinding, TheSceneKeyIsRefusedWhereItCannotWork) {
  std::ifstream in(std::string(MILLSIM_SOURCE_DIR) + "/cases/attrition_target.json");
  nlohmann::json doc = nlohmann::json::parse(in);
  doc["dust"]["grinding"] = "sweep";  // with the dust table
  InputErrors errors;
  parse_scene(doc, ".", errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "/dust/grinding");
  EXPECT_NE(errors[0].allowed.find("ledger"), std::string::npos);
  doc["dust"]["grinding"] = "mill";
  errors.clear();
  parse_scene(doc, ".", errors);
  ASSERT_FALSE(errors.empty());
  EXPECT_EQ(errors[0].path, "/dust/grinding");
  EXPECT_EQ(errors[0].value, "\"mill\"");
}

}  // namespace
}  // namespace millsim
