// The dust ledger (dust/dust_ledger.h) against what a dilute phase riding the gas must do, on
// gas fields set by hand (the solver is not stepped, so the fields are exact):
//   - in uniform flow a pulse moves at the gas speed, its mass unchanged;
//   - in still gas each class settles at its terminal speed τ_k g;
//   - in a solid-body vortex u = Ω × r, a class drifts outwards at τ_k Ω² r, the equilibrium
//     slip τ_k u_t²/r (Ferry & Balachandar 2001): d⟨r²⟩/dt = 2 τ_k Ω² ⟨r²⟩ over the dust a
//     tracer class (τ = 0) does not show;
//   - a box with an inlet and an outlet drains at the outlet's face flux c U A, the inlet passes
//     no dust, and held + outflow equals what was put in to 1e-12 throughout.
#include <gtest/gtest.h>

#include <cmath>

#include "dust/dust_ledger.h"
#include "gas/gas_solver.h"

namespace millsim {
namespace {

// Mass-weighted mean of f(cell centre) over class k's dust.
template <class F>
double dust_mean(const DustLedger& dust, int k, F f) {
  const GasGrid& g = dust.grid();
  double sum = 0.0, mass = 0.0;
  for (int kz = 1; kz <= g.n[2]; ++kz)
    for (int j = 1; j <= g.n[1]; ++j)
      for (int i = 1; i <= g.n[0]; ++i) {
        const double m = dust.cell_mass_kg(k)[g.index(i, j, kz)];
        sum += m * f(g.cell_center(i, j, kz));
        mass += m;
      }
  return sum / mass;
}

GasConfig still_config(std::array<int, 3> cells) {
  GasConfig config;
  config.density_kg_per_m3 = 1.2;
  config.viscosity_pa_s = 1.8e-5;
  config.cells = cells;
  return config;
}

TEST(DustLedger, APulseInUniformFlowMovesAtTheGasSpeed) {
  const GasConfig config = still_config({40, 4, 4});
  const double L = 0.4, U = 2.0;
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {L, 0.04, 0.04}, {true, true, true}), {});
  std::fill(gas.velocity()[0].begin(), gas.velocity()[0].end(), U);
  DustLedger dust(gas.grid(), {{2e-6, 0.0}, {8e-6, 2e-4}}, {});
  for (int k = 0; k < 2; ++k) dust.deposit({0.1, 0.02, 0.02}, k, 1e-9);
  const double x0 = dust_mean(dust, 0, [](const Vec3& x) { return x.x; });
  const double dt = 1e-3;
  for (int step = 0; step < 50; ++step) dust.advance(gas, dt);  // 0.1 m of travel
  for (int k = 0; k < 2; ++k) {
    const double x = dust_mean(dust, k, [](const Vec3& c) { return c.x; });
    EXPECT_NEAR(x - x0, U * 50 * dt, 1e-3) << "class " << k << ": the gas speed, any τ";
    EXPECT_NEAR(dust.held_kg(k), 1e-9, 1e-21) << "mass conserved to 1e-12";
    EXPECT_EQ(dust.outflow_kg(k), 0.0) << "a periodic box has no outlet";
  }
}

TEST(DustLedger, InStillGasEachClassSettlesAtItsTerminalSpeed) {
  const GasConfig config = still_config({4, 4, 60});
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.04, 0.04, 0.6}, {true, true, false}),
                {});
  const Vec3 g{0, 0, -9.81};
  const std::vector<DustClass> classes = {{1e-6, 3e-6}, {10e-6, 3e-4}, {30e-6, 3e-3}};
  DustLedger dust(gas.grid(), classes, g);
  for (int k = 0; k < 3; ++k) dust.deposit({0.02, 0.02, 0.45}, k, 1e-9);
  const double z0 = dust_mean(dust, 0, [](const Vec3& x) { return x.z; });
  const double dt = 0.2, t = 2.0;  // the coarsest falls 0.059 m, well above the floor
  for (int step = 0; step < 10; ++step) dust.advance(gas, dt);
  for (int k = 0; k < 3; ++k) {
    const double z = dust_mean(dust, k, [](const Vec3& c) { return c.z; });
    const double expected = classes[std::size_t(k)].relaxation_time_s * g.z * t;
    EXPECT_NEAR(z - z0, expected, 1e-3 * std::abs(expected) + 1e-12) << "class " << k;
    EXPECT_NEAR(dust.held_kg(k), 1e-9, 1e-21);
  }
}

// A square box of n² cells of side L (walls) turning as a solid body at Ω about its centre:
// faces of x at (i·h, (j−½)h) hold u_x = −Ω (y − c), faces of y u_y = Ω (x − c); walls hold 0.
constexpr int kVortexCells = 48;
constexpr double kVortexSide = 0.096, kOmega = 100.0;
GasSolver solid_body_vortex() {
  const int n = kVortexCells;
  const double L = kVortexSide, c0 = 0.5 * L, h = L / n;
  const GasConfig config = still_config({n, n, 1});
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {L, L, h}, {false, false, true}), {});
  const GasGrid& grid = gas.grid();
  for (int j = 1; j <= n; ++j)
    for (int i = 1; i < n; ++i) {
      gas.velocity()[0][grid.index(i, j, 1)] = -kOmega * ((j - 0.5) * h - c0);
      gas.velocity()[1][grid.index(j, i, 1)] = kOmega * ((j - 0.5) * h - c0);
    }
  return gas;
}

TEST(DustLedger, ASolidBodyVortexDrivesEachClassOutwardsAtTheEquilibriumSlip) {
  const int n = kVortexCells;
  const double omega = kOmega, c0 = 0.5 * kVortexSide;
  const GasSolver gas = solid_body_vortex();
  const GasGrid& grid = gas.grid();
  const std::vector<DustClass> classes = {{1e-6, 0.0}, {5e-6, 2e-4}, {10e-6, 8e-4}};
  DustLedger dust(gas.grid(), classes, {});
  // A Gaussian blob of width 8 mm about the axis, the same for every class.
  for (int j = 1; j <= n; ++j)
    for (int i = 1; i <= n; ++i) {
      const Vec3 x = grid.cell_center(i, j, 1);
      const double r2 = (x.x - c0) * (x.x - c0) + (x.y - c0) * (x.y - c0);
      for (int k = 0; k < 3; ++k) dust.deposit(x, k, 1e-12 * std::exp(-r2 / (2 * 0.008 * 0.008)));
    }
  const auto r2_of = [&](int k) {
    return dust_mean(
        dust, k, [&](const Vec3& x) { return (x.x - c0) * (x.x - c0) + (x.y - c0) * (x.y - c0); });
  };
  double before[3], total[3];
  for (int k = 0; k < 3; ++k) before[k] = r2_of(k), total[k] = dust.held_kg(k);
  const double dt = 2e-4;
  dust.advance(gas, dt);
  const double tracer_change = r2_of(0) - before[0];  // the scheme's own spreading
  for (int k = 1; k < 3; ++k) {
    const double drift = r2_of(k) - before[k] - tracer_change;
    // The locally implicit slip: (I + τ Ω J) w = τ Ω² r, radial part τ Ω² r / (1 + τ² Ω²).
    const double tau = classes[std::size_t(k)].relaxation_time_s;
    const double expected =
        2.0 * tau * omega * omega * before[k] * dt / (1.0 + tau * tau * omega * omega);
    EXPECT_NEAR(drift, expected, 0.05 * expected) << "class " << k;
    EXPECT_NEAR(dust.held_kg(k), total[k], 1e-12 * total[k]) << "walls pass nothing";
  }
}

TEST(DustLedger, TheSlipOfHeavyDustStaysBoundedByTheGasSpeed) {
  // Expectation: in solid-body rotation (I + τ Ω J) w = τ Ω² r gives, in complex form,
  // w = τ Ω² r (1 − i τ Ω) / (1 + τ² Ω²): radially τ Ω² r / (1 + τ² Ω²), and against the
  // rotation τ² Ω³ r / (1 + τ² Ω²). At τ Ω = 10 the plain slip τ Ω² r would be 10× the gas speed
  // Ω r; this one is 0.995 Ω r, a particle that hardly turns. Checked in every cell two or more
  // cells from the walls (the wall cells' velocities are half their faces').
  const GasSolver gas = solid_body_vortex();
  const GasGrid& grid = gas.grid();
  const double tau = 10.0 / kOmega, c0 = 0.5 * kVortexSide, k = tau * kOmega;
  DustLedger dust(grid, {{50e-6, tau}}, {});
  dust.advance(gas, 1e-5);
  for (int j = 3; j <= kVortexCells - 2; ++j)
    for (int i = 3; i <= kVortexCells - 2; ++i) {
      const Vec3 x = grid.cell_center(i, j, 1);
      const Vec3 r{x.x - c0, x.y - c0, 0.0};
      const double radius = norm(r);
      if (radius == 0.0) continue;
      const Vec3 radial = r * (1.0 / radius), along{-radial.y, radial.x, 0.0};
      const Vec3 w = dust.slip_m_per_s(grid.index(i, j, 1), tau);
      const double speed = kOmega * radius;
      EXPECT_NEAR(dot(w, radial), speed * k / (1.0 + k * k), 1e-9 * speed) << i << ", " << j;
      EXPECT_NEAR(dot(w, along), -speed * k * k / (1.0 + k * k), 1e-9 * speed) << i << ", " << j;
    }
}

TEST(DustLedger, ABoxDrainsAtTheOutletsFaceFlux) {
  GasConfig config = still_config({20, 2, 2});
  const double L = 0.2, U = 1.0, A = 0.02 * 0.02;
  GasBoundaryPatch inlet, outlet;
  inlet.name = "in", inlet.face = 0, inlet.kind = GasBoundaryKind::Inlet;
  inlet.velocity_m_per_s = {U, 0, 0};
  outlet.name = "out", outlet.face = 1, outlet.kind = GasBoundaryKind::Outlet;
  config.boundaries = {inlet, outlet};
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {L, 0.02, 0.02}, {false, true, true}),
                {});
  const GasGrid& grid = gas.grid();
  for (std::size_t f = 0; f < grid.padded_size; ++f)
    if (grid.face[0][f] != FaceKind::None && grid.face[0][f] != FaceKind::Solid)
      gas.velocity()[0][f] = U;
  DustLedger dust(grid, {{3e-6, 0.0}}, {});
  double fed = 0.0;
  for (int k = 1; k <= 2; ++k)
    for (int j = 1; j <= 2; ++j)
      for (int i = 1; i <= 20; ++i) dust.deposit(grid.cell_center(i, j, k), 0, 1e-10), fed += 1e-10;
  // One small step: what leaves is the last cells' concentration times U A dt.
  const double dt = 1e-3;
  const double last_cells = 4 * 1e-10, concentration = last_cells / (A * 0.01);
  dust.advance(gas, dt);
  EXPECT_NEAR(dust.outflow_kg(), concentration * U * A * dt, 1e-9 * concentration * U * A * dt);
  // Then the box flushes; the inlet brings no dust in.
  for (int step = 0; step < 1000; ++step) {
    dust.advance(gas, dt);
    ASSERT_NEAR(dust.held_kg() + dust.outflow_kg(), fed, 1e-12 * fed) << "step " << step;
  }
  EXPECT_LT(dust.held_kg(), 1e-6 * fed) << "five flushes of the box";
}

TEST(DustLedger, ADepositInASolidCellGoesToTheNearestFluidCell) {
  GasConfig config = still_config({8, 8, 8});
  GasSolidConfig block;
  block.shape = GasSolidShape::Box;
  block.min_m = {0, 0, 0};
  block.max_m = {0.5, 1, 1};
  config.solids.push_back(block);
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {1, 1, 1}, {false, false, false}), {});
  DustLedger dust(gas.grid(), {{1e-6, 0.0}}, {});
  dust.deposit({0.4, 0.3, 0.3}, 0, 2e-9);
  const GasGrid& g = gas.grid();
  EXPECT_EQ(dust.cell_mass_kg(0)[g.index(5, 3, 3)], 2e-9) << "the first fluid cell along x";
  EXPECT_EQ(dust.stats().displaced_deposits, 1u);
}

}  // namespace
}  // namespace millsim
