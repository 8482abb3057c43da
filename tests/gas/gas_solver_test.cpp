// The gas solver alone against analytic and published flows: plane Poiseuille flow (exact
// parabola), the lid-driven cavity at Re = 100 (Ghia, Ghia & Shin 1982, Tables I and II),
// hydrostatic pressure, and continuity with a changing volume fraction.
#include <gtest/gtest.h>

#include <cmath>

#include "gas/gas_solver.h"
#include "support/sanitizers.h"

namespace millsim {
namespace {

// Advances until the largest velocity change per unit time falls below `rate_tol`.
double run_to_steady(GasSolver& gas, double rate_tol, double max_time_s) {
  double rate = 1e300;
  while (gas.time_s() < max_time_s && rate > rate_tol) {
    const std::array<std::vector<double>, 3> before = gas.velocity();
    const double dt = gas.stable_step_s();
    const auto failure = gas.advance(dt);
    EXPECT_FALSE(failure) << *failure;
    if (failure) break;
    rate = 0.0;
    for (int a = 0; a < 3; ++a)
      for (std::size_t f = 0; f < before[a].size(); ++f)
        rate = std::max(rate, std::abs(gas.velocity()[a][f] - before[a][f]) / dt);
  }
  return rate;
}

TEST(GasSolver, PlanePoiseuilleMatchesTheParabola) {
  // Channel between walls at y = 0 and y = H, periodic in x and z, driven by an imposed mean
  // pressure gradient −ρG: u(y) = G y (H − y) / (2ν), centreline G H² / (8ν).
  GasConfig config;
  config.density_kg_per_m3 = 1.0;
  config.viscosity_pa_s = 0.1;
  config.cells = {4, 16, 1};
  const double H = 1.0, G = 0.8, nu = 0.1;
  config.mean_pressure_gradient_pa_per_m = {-G * config.density_kg_per_m3, 0, 0};
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.25, H, 0.0625}, {true, false, true}),
                {});
  const double rate = run_to_steady(gas, 1e-9, 200.0);
  ASSERT_LT(rate, 1e-9);
  const double centre = G * H * H / (8.0 * nu);
  EXPECT_NEAR(gas.velocity_at({0.1, 0.5 * H, 0.03}).x, centre, 0.01 * centre);
  for (double y = 0.05; y < H; y += 0.1) {
    const double exact = G * y * (H - y) / (2.0 * nu);
    EXPECT_NEAR(gas.velocity_at({0.1, y, 0.03}).x, exact, 0.01 * centre) << "y = " << y;
  }
  EXPECT_NEAR(gas.velocity_at({0.1, 0.3, 0.03}).y, 0.0, 1e-10);
}

TEST(GasSolver, SmagorinskyEddyViscosityInCouetteFlow) {
  // Plane Couette flow (lid at y = H moving at U, periodic x and z): the steady profile is
  // U y / H whatever the viscosity, and the shear rate U / H is uniform, so the eddy viscosity
  // must be (C_s Δ)² U / H in every cell (|S| = √(2 S_ij S_ij) = U / H for simple shear).
  GasConfig config;
  config.density_kg_per_m3 = 1.0;
  config.viscosity_pa_s = 0.1;
  config.cells = {4, 16, 1};
  config.smagorinsky_constant = 0.17;
  config.pressure_tolerance = 1e-12;
  GasBoundaryPatch lid;
  lid.face = 3;
  lid.velocity_m_per_s = {1.0, 0.0, 0.0};
  config.boundaries.push_back(lid);
  const double H = 1.0, U = 1.0, h = 1.0 / 16;
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {4 * h, H, h}, {true, false, true}), {});
  ASSERT_LT(run_to_steady(gas, 1e-10, 400.0), 1e-10);
  for (double y = 0.03; y < H; y += 0.1)
    EXPECT_NEAR(gas.velocity_at({0.1, y, 0.5 * h}).x, U * y / H, 1e-6) << "y = " << y;
  const double expected = std::pow(0.17 * h, 2) * U / H;  // Δ = √(h_x h_y) = h
  const GasGrid& g = gas.grid();
  for (int j = 1; j <= g.n[1]; ++j)
    EXPECT_NEAR(gas.eddy_viscosity()[g.index(2, j, 1)], expected, 1e-6 * expected) << "j = " << j;
}

TEST(GasSolver, LidDrivenCavityAtRe100MatchesGhia) {
  MILLSIM_RELEASE_ONLY(
      "GasSolver.PlanePoiseuilleMatchesTheParabola, ...InCouetteFlow (a moving "
      "wall) and ...TaylorGreenVortex (the advection schemes)");
  GasConfig config;
  config.density_kg_per_m3 = 1.0;
  config.viscosity_pa_s = 0.01;  // Re = U L / ν = 100
  config.cells = {64, 64, 1};
  config.courant = 0.9;
  GasBoundaryPatch lid;
  lid.face = 3;  // y+
  lid.kind = GasBoundaryKind::Wall;
  lid.velocity_m_per_s = {1.0, 0.0, 0.0};
  config.boundaries.push_back(lid);
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {1, 1, 1.0 / 64}, {false, false, true}),
                {});
  const double rate = run_to_steady(gas, 1e-5, 60.0);
  EXPECT_LT(rate, 1e-5);
  // Ghia, Ghia & Shin (1982), Table I: u along the vertical centreline, Re = 100.
  const double y_ghia[] = {0.0547, 0.0625, 0.0703, 0.1016, 0.1719, 0.2813, 0.4531, 0.5,
                           0.6172, 0.7344, 0.8516, 0.9531, 0.9609, 0.9688, 0.9766};
  const double u_ghia[] = {-0.03717, -0.04192, -0.04775, -0.06434, -0.10150,
                           -0.15662, -0.21090, -0.20581, -0.13641, 0.00332,
                           0.23151,  0.68717,  0.73722,  0.78871,  0.84123};
  double worst_u = 0.0;
  for (int k = 0; k < 15; ++k)
    worst_u = std::max(worst_u, std::abs(gas.velocity_at({0.5, y_ghia[k], 0.005}).x - u_ghia[k]));
  // Table II: v along the horizontal centreline.
  const double x_ghia[] = {0.0625, 0.0703, 0.0781, 0.0938, 0.1563, 0.2266, 0.2344, 0.5,
                           0.8047, 0.8594, 0.9063, 0.9453, 0.9531, 0.9609, 0.9688};
  const double v_ghia[] = {0.09233,  0.10091,  0.10890,  0.12317,  0.16077,
                           0.17507,  0.17527,  0.05454,  -0.24533, -0.22445,
                           -0.16914, -0.10313, -0.08864, -0.07391, -0.05906};
  double worst_v = 0.0;
  for (int k = 0; k < 15; ++k)
    worst_v = std::max(worst_v, std::abs(gas.velocity_at({x_ghia[k], 0.5, 0.005}).y - v_ghia[k]));
  EXPECT_LT(worst_u, 0.02) << "largest |u − u_Ghia| / U";
  EXPECT_LT(worst_v, 0.02) << "largest |v − v_Ghia| / U";
  RecordProperty("worst_u", std::to_string(worst_u));
  RecordProperty("worst_v", std::to_string(worst_v));
  std::printf("cavity Re=100 64x64: max |u-u_Ghia| = %.4f, max |v-v_Ghia| = %.4f\n", worst_u,
              worst_v);
}

TEST(GasSolver, StillGasUnderGravityIsHydrostatic) {
  GasConfig config;
  config.cells = {3, 3, 8};
  config.pressure_tolerance = 1e-12;
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.03, 0.03, 0.08}, {}), {0, 0, -9.81});
  for (int k = 0; k < 20; ++k) ASSERT_FALSE(gas.advance(1e-3));
  const double rho = config.density_kg_per_m3;
  EXPECT_NEAR(gas.pressure_gradient_at({0.015, 0.015, 0.04}).z, -rho * 9.81, 1e-9);
  EXPECT_NEAR(gas.pressure_gradient_at({0.015, 0.015, 0.001}).z, -rho * 9.81, 1e-9);
  EXPECT_LT(norm(gas.velocity_at({0.01, 0.02, 0.05})), 1e-12);
}

TEST(GasSolver, InletFlowLeavesThroughTheOutletAndContinuityHolds) {
  GasConfig config;
  config.cells = {6, 6, 12};
  config.pressure_tolerance = 1e-12;
  GasBoundaryPatch inlet;
  inlet.face = 4;  // z-
  inlet.kind = GasBoundaryKind::Inlet;
  inlet.shape = PatchShape::Circle;
  inlet.center_m = {0.03, 0.03, 0};
  inlet.radius_m = 0.015;
  inlet.velocity_m_per_s = {0, 0, 2.0};
  GasBoundaryPatch outlet;
  outlet.face = 5;
  outlet.kind = GasBoundaryKind::Outlet;
  config.boundaries = {inlet, outlet};
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.06, 0.06, 0.12}, {}), {});
  // A volume fraction that changes in time: continuity must include ∂ε/∂t.
  for (int step = 0; step < 50; ++step) {
    for (std::size_t c = 0; c < gas.volume_fraction().size(); ++c)
      gas.volume_fraction()[c] = 0.8 + 0.1 * std::sin(0.1 * step + 0.01 * double(c));
    gas.volume_fraction_changed();
    ASSERT_FALSE(gas.advance(1e-3));
    ASSERT_LT(gas.max_continuity_error_m3_per_s(), 1e-8 * 2.0 * 0.06 * 0.06);
  }
  // Outflow = inflow once ε stops changing.
  for (int step = 0; step < 50; ++step) ASSERT_FALSE(gas.advance(1e-3));
  const GasGrid& g = gas.grid();
  double in = 0.0, out = 0.0;
  for (int j = 1; j <= g.n[1]; ++j)
    for (int i = 1; i <= g.n[0]; ++i) {
      in += gas.velocity()[2][g.index(i, j, 0)] * g.face_area_m2(2);
      const std::size_t top = g.index(i, j, g.n[2]);
      out += gas.velocity()[2][top] * gas.volume_fraction()[top] * g.face_area_m2(2);
    }
  EXPECT_GT(in, 0.0);
  EXPECT_NEAR(out, in, 1e-8 * in);
}

}  // namespace
}  // namespace millsim

namespace millsim {
namespace {

// Kinetic energy per unit density of a 2-D Taylor–Green vortex after `t_end`, solved with
// `scheme` on n × n cells of a periodic unit square: u = U sin(kx) cos(ky),
// v = −U cos(kx) sin(ky), k = 2π. Exact: E(t) = E(0) exp(−4 ν k² t).
double taylor_green_energy_ratio(AdvectionScheme scheme, int n, double nu, double t_end) {
  GasConfig config;
  config.density_kg_per_m3 = 1.0;
  config.viscosity_pa_s = nu;
  config.cells = {n, n, 1};
  config.advection = scheme;
  config.pressure_tolerance = 1e-10;
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {1, 1, 1.0 / n}, {true, true, true}), {});
  const GasGrid& g = gas.grid();
  const double k = 2.0 * std::acos(-1.0), h = 1.0 / n;
  auto energy = [&]() {
    double e = 0.0;
    for (int j = 1; j <= n; ++j)
      for (int i = 1; i <= n; ++i) {
        const std::size_t c = g.index(i, j, 1);
        e += 0.5 * (std::pow(gas.velocity()[0][c], 2) + std::pow(gas.velocity()[1][c], 2));
      }
    return e;
  };
  for (int j = 0; j <= n + 1; ++j)
    for (int i = 0; i <= n + 1; ++i)
      for (int kk = 0; kk <= 2; ++kk) {
        const std::size_t c = g.index(i, j, kk);
        // Face of component a on the + side of cell (i, j): at x = i h (a = 0), y = j h (a = 1).
        gas.velocity()[0][c] = std::sin(k * i * h) * std::cos(k * (j - 0.5) * h);
        gas.velocity()[1][c] = -std::cos(k * (i - 0.5) * h) * std::sin(k * j * h);
      }
  const double e0 = energy();
  while (gas.time_s() < t_end - 1e-12) {
    const auto failure = gas.advance(std::min(gas.stable_step_s(), t_end - gas.time_s()));
    EXPECT_FALSE(failure) << *failure;
    if (failure) break;
  }
  return energy() / e0;
}

TEST(GasSolver, TvdAdvectionDissipatesFarLessThanUpwindInATaylorGreenVortex) {
  // Cell Péclet number U h / ν = 25: the hybrid scheme is upwind everywhere, and its numerical
  // viscosity (about U h / 2 = 12 ν) swamps the physical one. The second-order TVD scheme must
  // come within a quarter of the exact decay's energy loss where upwind is off by several times.
  const int n = 32;
  const double nu = 1.0 / (25.0 * n), t_end = 0.25;
  const double exact = std::exp(-4.0 * nu * std::pow(2.0 * std::acos(-1.0), 2) * t_end);
  const double upwind = taylor_green_energy_ratio(AdvectionScheme::Hybrid, n, nu, t_end);
  const double tvd = taylor_green_energy_ratio(AdvectionScheme::Tvd, n, nu, t_end);
  const double exact_loss = 1.0 - exact;
  EXPECT_GT(1.0 - upwind, 3.0 * exact_loss) << "upwind should be far too dissipative here";
  EXPECT_NEAR(1.0 - tvd, exact_loss, 0.25 * exact_loss) << "tvd " << tvd << ", exact " << exact;
  EXPECT_LE(tvd, 1.0) << "TVD must not create energy";
}

}  // namespace
}  // namespace millsim
