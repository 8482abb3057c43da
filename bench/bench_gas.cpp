// Gas-solver and coupling benchmark (figures in bench/RESULTS.md).
//   bench_gas grid [steps]          time per CFD step against grid size, multigrid and
//                                   incomplete-Cholesky preconditioners side by side: a 3-D
//                                   box with a nozzle inlet and an outlet, from rest
//   bench_gas compressible [steps] [threads]
//                                   the compressible model against the incompressible one on
//                                   the same box, inlet and outlet (a 20 m/s inlet into gas at
//                                   rest): time per step, per cell-step, the stable step, and
//                                   so the cost of one simulated millisecond of each; on the
//                                   engine's `threads` (default 1; the compressible model's
//                                   passes use them, the incompressible solver's do not yet)
//   bench_gas cavity N MACH         the lid-driven cavity at Re = 100 on N × N cells (Ghia, Ghia &
//                                   Shin 1982, Table I) by both models to t = 20 L/U, the
//                                   compressible one at lid Mach number MACH: the incompressible
//                                   limit of the compressible model
//   bench_gas stokes N              Stokes' first problem (a wall set moving at t = 0, ν = 0.01,
//                                   N cells over the unit height) by the compressible model at
//                                   Mach 0.2, against u = U erfc(y / (2√(νt))) at t = 1
//   bench_gas ledger SCENE CACHE_DIR [advances] [threads]
//                                   the dust ledger's advance in a mill's gas (SCENE with a
//                                   ledger, its gas spun up or read from the spin-up cache in
//                                   CACHE_DIR), every class holding dust in every fluid cell:
//                                   ms per advance, ns per class-cell, sub-steps per class, and a
//                                   checksum of the masses (the same for any code that is bit
//                                   for bit the same)
//   bench_gas cache SOURCE_DIR      drag caching (§3.1, Fig. 5) at thresholds 0, 1, 5, 10 %:
//                                   salt particles settling in air (terminal velocity against
//                                   Schiller–Naumann) and the fluidized bed case at 1.5 u_mf
//                                   (fluid-force time, whole-run time, Δp / W, bed height)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include "dust/dust_ledger.h"
#include "gas/compressible/compressible_solver.h"
#include "gas/gas_solver.h"
#include "parallel/thread_team.h"
#include "scene/scene_json.h"
#include "sim/gas_spin_up.h"
#include "sim/simulation.h"

using namespace millsim;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The box of grid_scan: a circular 20 m/s inlet on x−, an outlet on z+.
GasConfig inlet_box(int n) {
  GasConfig config;
  config.cells = {n, n, n};
  GasBoundaryPatch inlet;
  inlet.face = 0;
  inlet.kind = GasBoundaryKind::Inlet;
  inlet.shape = PatchShape::Circle;
  inlet.center_m = {0, 0.05, 0.05};
  inlet.radius_m = 0.01;
  inlet.velocity_m_per_s = {20, 0, 0};
  GasBoundaryPatch outlet;
  outlet.face = 5;
  outlet.kind = GasBoundaryKind::Outlet;
  config.boundaries = {inlet, outlet};
  return config;
}

void compressible_scan(int steps) {
  std::printf(
      "| cells | model | ms per step | ns per cell-step | stable step, µs | "
      "s per simulated ms |\n| --- | --- | --- | --- | --- | --- |\n");
  for (int n : {16, 32, 48, 64}) {
    const double cells = double(n) * n * n;
    {
      GasConfig config = inlet_box(n);
      GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.1, 0.1, 0.1}, {}), {0, 0, -9.81});
      for (int k = 0; k < 5; ++k) gas.advance(gas.stable_step_s());
      const double dt = gas.stable_step_s();
      const auto t0 = Clock::now();
      for (int k = 0; k < steps; ++k) gas.advance(gas.stable_step_s());
      const double s = seconds_since(t0) / steps;
      std::printf("| %d³ | incompressible | %.3f | %.1f | %.2f | %.3g |\n", n, 1e3 * s,
                  1e9 * s / cells, 1e6 * dt, s * 1e-3 / dt);
    }
    GasConfig config = inlet_box(n);
    config.model = GasModel::Compressible;
    config.boundaries[1].pressure_pa = 101325.0;  // the compressible model's p is absolute
    config.viscosity_pa_s = 1.8e-5;
    CompressibleSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.1, 0.1, 0.1}, {}),
                           {0, 0, -9.81});
    for (int k = 0; k < 5; ++k) gas.advance(gas.stable_step_s(0.4));
    const double dt = gas.stable_step_s(0.4);
    const auto t0 = Clock::now();
    for (int k = 0; k < steps; ++k)
      if (auto failure = gas.advance(gas.stable_step_s(0.4))) {
        std::printf("failed: %s\n", failure->c_str());
        return;
      }
    const double s = seconds_since(t0) / steps;
    std::printf("| %d³ | compressible | %.3f | %.1f | %.2f | %.3g |\n", n, 1e3 * s, 1e9 * s / cells,
                1e6 * dt, s * 1e-3 / dt);
  }
}

void grid_scan(int steps) {
  std::printf("| cells | preconditioner | ms per CFD step | CG iterations per step |\n");
  std::printf("| --- | --- | --- | --- |\n");
  for (int n : {16, 32, 48, 64}) {
    for (PressurePreconditioner kind :
         {PressurePreconditioner::Multigrid, PressurePreconditioner::IncompleteCholesky}) {
      GasConfig config = inlet_box(n);
      config.pressure_preconditioner = kind;
      GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.1, 0.1, 0.1}, {}), {0, 0, -9.81});
      for (int k = 0; k < 5; ++k) gas.advance(gas.stable_step_s());  // warm up
      const std::uint64_t iterations0 = gas.stats().pressure_iterations;
      const auto t0 = Clock::now();
      for (int k = 0; k < steps; ++k)
        if (auto failure = gas.advance(gas.stable_step_s())) {
          std::printf("failed: %s\n", failure->c_str());
          return;
        }
      const double ms = 1e3 * seconds_since(t0) / steps;
      std::printf("| %d³ = %d | %s | %.3f | %.1f |\n", n, n * n * n,
                  kind == PressurePreconditioner::Multigrid ? "multigrid" : "incomplete Cholesky",
                  ms, double(gas.stats().pressure_iterations - iterations0) / steps);
    }
  }
}

double terminal_velocity(double d) {
  const double rho = 1.2, mu = 1.8e-5, rho_p = 2165.0;
  const double weight = (rho_p - rho) * 9.81 * std::numbers::pi * d * d * d / 6.0;
  double lo = 0.0, hi = 100.0;
  for (int k = 0; k < 200; ++k) {
    const double v = 0.5 * (lo + hi), re = rho * d * v / mu;
    const double cd = re < 1000.0 ? 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687)) : 0.44;
    (0.5 * rho * cd * std::numbers::pi * d * d / 4.0 * v * v < weight ? lo : hi) = v;
  }
  return 0.5 * (lo + hi);
}

void settling(double threshold, DragCacheStore store) {
  for (double d : {1e-4, 1e-3, 1e-2}) {
    SceneConfig scene;
    const double box = std::max(0.01, 3.0 * d);
    scene.domain.min_m = {0, 0, 0};
    scene.domain.max_m = {box, box, box};
    scene.domain.periodic = {true, true, true};
    MaterialConfig salt;
    salt.name = "salt";
    salt.youngs_modulus_pa = 1e5;
    salt.poisson_ratio = 0.25;
    salt.density_kg_per_m3 = 2165.0;
    scene.materials = {salt};
    SourceConfig source;
    source.particles.push_back({{box / 2, box / 2, box / 2}, {}, {}, d});
    scene.sources = {source};
    scene.gravity_m_per_s2 = {0, 0, -9.81};
    const double v_t = terminal_velocity(d);
    scene.time.end_s = 8.0 * v_t / 9.81 + 0.05;
    GasConfig gas;
    gas.two_way = false;
    gas.cache_threshold = threshold;
    gas.cache_store = store;
    scene.gas = gas;
    Simulation sim(scene);
    double peak = 0.0;
    while (sim.step_index() < sim.total_steps()) {
      sim.step();
      peak = std::max(peak, norm(sim.particles().motion[0].velocity_m_per_s));
    }
    const double v = norm(sim.particles().motion[0].velocity_m_per_s);
    const CouplingStats& s = sim.gas()->stats();
    std::printf("| %g %% | %s | %g mm | %.3f %% | %.3f %% | %.4f |\n", 100 * threshold,
                store == DragCacheStore::Force ? "force" : "coefficient", 1e3 * d,
                100 * (v / v_t - 1), 100 * (peak / v_t - 1),
                double(s.drag_evaluations) / double(s.drag_evaluations + s.drag_reuses));
  }
}

void fluidized(const std::string& source_dir, double threshold) {
  SceneConfig scene = load_scene(source_dir + "/cases/fluidized_bed.json");
  scene.gas->boundaries.at(0).velocity_m_per_s.z = 0.28;  // ≈ 1.5 u_mf
  scene.gas->cache_threshold = threshold;
  scene.time.end_s = 0.3;
  Simulation sim(scene);
  const auto t0 = Clock::now();
  double top_sum = 0.0;
  int samples = 0;
  while (sim.step_index() < sim.total_steps()) {
    sim.step();
    if (sim.time_s() > 0.15 && sim.step_index() % 500 == 0) {
      std::vector<double> z;
      for (std::size_t i = 0; i < sim.particles().size(); ++i)
        z.push_back(sim.particles().position_m[i].z);
      std::nth_element(z.begin(), z.begin() + std::ptrdiff_t(0.9 * z.size()), z.end());
      top_sum += z[std::size_t(0.9 * z.size())];
      ++samples;
    }
  }
  const double wall = seconds_since(t0);
  const CouplingStats& s = sim.gas()->stats();
  const double fluid = sim.profile().seconds[std::size_t(Phase::Fluid)];
  std::printf("| %g %% | %.2f | %.2f | %.4f | %.4f |\n", 100 * threshold, wall, fluid,
              double(s.drag_evaluations) / double(s.drag_evaluations + s.drag_reuses),
              1e3 * top_sum / samples);
}

// The lid-driven cavity of unit size, lid speed 1, ν = 0.01, N × N cells, periodic in z.
GasConfig cavity_config(int n) {
  GasConfig config;
  config.density_kg_per_m3 = 1.0;
  config.viscosity_pa_s = 0.01;
  config.cells = {n, n, 1};
  GasBoundaryPatch lid;
  lid.face = 3;  // y+
  lid.kind = GasBoundaryKind::Wall;
  lid.velocity_m_per_s = {1.0, 0.0, 0.0};
  config.boundaries.push_back(lid);
  return config;
}

// The compressible model's gas at density 1 with sound speed 1 / mach (the lid's speed is 1).
GasConfig at_mach(GasConfig config, double mach) {
  config.model = GasModel::Compressible;
  const double c = 1.0 / mach, gamma = config.compressible.gas.gamma;
  config.compressible.initial_pressure_pa = c * c / gamma;
  config.compressible.initial_temperature_k =
      config.compressible.initial_pressure_pa / config.compressible.gas.gas_constant_j_per_kg_k;
  return config;
}

void cavity(int n, double mach) {
  const double end_s = 20.0;
  const Vec3 hi{1.0, 1.0, 1.0 / n};
  GasConfig config = cavity_config(n);
  config.courant = 0.9;
  GasSolver incompressible(config, build_gas_grid(config, {}, hi, {false, false, true}), {});
  const GasConfig c_config = at_mach(cavity_config(n), mach);
  CompressibleSolver compressible(c_config, build_gas_grid(c_config, {}, hi, {false, false, true}),
                                  {});
  auto t0 = Clock::now();
  while (incompressible.time_s() < end_s)
    if (auto f = incompressible.advance(incompressible.stable_step_s()))
      return (void)std::puts(f->c_str());
  const double incompressible_s = seconds_since(t0);
  t0 = Clock::now();
  while (compressible.time_s() < end_s)
    if (auto f = compressible.advance(compressible.stable_step_s(0.5)))
      return (void)std::puts(f->c_str());
  const double compressible_s = seconds_since(t0);
  const double y[] = {0.0547, 0.0625, 0.0703, 0.1016, 0.1719, 0.2813, 0.4531, 0.5,
                      0.6172, 0.7344, 0.8516, 0.9531, 0.9609, 0.9688, 0.9766};
  const double u_ghia[] = {-0.03717, -0.04192, -0.04775, -0.06434, -0.10150,
                           -0.15662, -0.21090, -0.20581, -0.13641, 0.00332,
                           0.23151,  0.68717,  0.73722,  0.78871,  0.84123};
  double worst_i = 0.0, worst_c = 0.0, worst_d = 0.0;
  for (int k = 0; k < 15; ++k) {
    const Vec3 x{0.5, y[k], 0.5 / n};
    const double ui = incompressible.velocity_at(x).x, uc = compressible.velocity_at(x).x;
    worst_i = std::max(worst_i, std::abs(ui - u_ghia[k]));
    worst_c = std::max(worst_c, std::abs(uc - u_ghia[k]));
    worst_d = std::max(worst_d, std::abs(uc - ui));
  }
  std::printf("| %d² | %g | %.4f | %.4f | %.4f | %.1f | %.1f |\n", n, mach, worst_i, worst_c,
              worst_d, incompressible_s, compressible_s);
}

void stokes_first_problem(int n) {
  const double nu = 0.01, end_s = 1.0;
  GasConfig config = at_mach(cavity_config(n), 0.2);
  config.cells = {2, n, 1};
  CompressibleSolver gas(
      config, build_gas_grid(config, {}, {2.0 / n, 1.0, 1.0 / n}, {true, false, true}), {});
  while (gas.time_s() < end_s)
    if (auto f = gas.advance(std::min(gas.stable_step_s(0.5), end_s - gas.time_s())))
      return (void)std::puts(f->c_str());
  double worst = 0.0, at = 0.0;
  for (int j = n; j > 3 * n / 4; --j) {
    const double distance = 1.0 - (j - 0.5) / n;
    const double exact = std::erfc(distance / (2.0 * std::sqrt(nu * end_s)));
    const double error = gas.velocity_m_per_s(gas.grid().index(1, j, 1)).x - exact;
    if (std::abs(error) > std::abs(worst)) worst = error, at = distance;
  }
  std::printf("| %d | %+.5f | %.4f |\n", n, worst, at);
}

// The dust ledger in the mill's spun-up gas (the gas held still: the ledger's own cost).
void ledger(const std::string& scene_path, const std::string& cache_dir, int advances) {
  const SceneConfig scene = load_scene(scene_path);
  std::ifstream in(scene_path);
  std::stringstream text;
  text << in.rdbuf();
  Simulation sim(scene, SimulationStart::AfterSpinUp);
  SpinUpOptions options;
  options.cache_dir = cache_dir;
  options.scene_text = text.str();
  const SpinUpReport spin = run_gas_spin_up(sim, options);
  if (!sim.dust_ledger()) {
    std::fprintf(stderr, "%s has no dust ledger\n", scene_path.c_str());
    std::exit(2);
  }
  const GasView gas = sim.gas()->view();
  const GasGrid& grid = gas.grid();
  DustLedger dust(grid, sim.dust_ledger()->classes(), scene.gravity_m_per_s2);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t fluid_cells = 0;
  for (int k = 1; k <= grid.n[2]; ++k)
    for (int j = 1; j <= grid.n[1]; ++j)
      for (int i = 1; i <= grid.n[0]; ++i) {
        if (!grid.fluid[grid.index(i, j, k)]) continue;
        ++fluid_cells;
        for (int c = 0; c < dust.class_count(); ++c)
          dust.deposit(grid.cell_center(i, j, k), c, 1e-12 * unit(rng));
      }
  const double dt = sim.gas()->compressible() ? 4.6e-7 : 1e-6;  // the 4 barg mill's gas step
  dust.advance(gas, dt);
  const auto t0 = Clock::now();
  for (int a = 0; a < advances; ++a) dust.advance(gas, dt);
  const double s = seconds_since(t0) / advances;
  double checksum = 0.0;
  for (int c = 0; c < dust.class_count(); ++c)
    for (std::size_t i = 0; i < grid.padded_size; ++i)
      checksum += dust.cell_mass_kg(c)[i] * double(i % 97 + c + 1);
  std::printf("| %s | %d | %zu | %d | %.3f | %.1f | %.2f | %.17g |\n", spin.source.c_str(),
              thread_count(), fluid_cells, dust.class_count(), 1e3 * s,
              1e9 * s / (double(fluid_cells) * dust.class_count()),
              double(dust.stats().substeps) / double(dust.stats().advances) / dust.class_count(),
              checksum);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "grid") {
    grid_scan(argc > 2 ? std::atoi(argv[2]) : 20);
  } else if (mode == "compressible") {
    set_thread_count(argc > 3 ? std::max(1, std::atoi(argv[3])) : 1);
    compressible_scan(argc > 2 ? std::atoi(argv[2]) : 20);
  } else if (mode == "cavity" && argc > 3) {
    std::printf(
        "| cells | lid Mach | worst |u − Ghia|, incompressible | compressible | |compressible − "
        "incompressible| | incompressible s | compressible s |\n| --- | --- | --- | --- | --- "
        "| --- | --- |\n");
    cavity(std::atoi(argv[2]), std::atof(argv[3]));
  } else if (mode == "stokes" && argc > 2) {
    std::printf("| cells | largest u − erfc near the wall | at distance |\n| --- | --- | --- |\n");
    stokes_first_problem(std::atoi(argv[2]));
  } else if (mode == "ledger" && argc > 3) {
    set_thread_count(argc > 5 ? std::max(1, std::atoi(argv[5])) : 1);
    std::printf(
        "| gas | threads | fluid cells | classes | ms per advance | ns per class-cell | "
        "sub-steps per class | checksum |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    ledger(argv[2], argv[3], argc > 4 ? std::atoi(argv[4]) : 200);
  } else if (mode == "cache" && argc > 2) {
    std::printf(
        "| threshold | cache stores | d | final v / v_t − 1 | peak v / v_t − 1 | "
        "evaluations per particle-step |\n| --- | --- | --- | --- | --- | --- |\n");
    for (double t : {0.0, 0.01, 0.05, 0.10}) settling(t, DragCacheStore::Coefficient);
    for (double t : {0.05, 0.10}) settling(t, DragCacheStore::Force);
    std::printf(
        "\n| threshold | wall s | fluid-force s | evaluations per particle-step | "
        "mean 90th-percentile height, mm |\n| --- | --- | --- | --- | --- |\n");
    for (double t : {0.0, 0.01, 0.05, 0.10}) fluidized(argv[2], t);
  } else {
    std::fprintf(stderr,
                 "usage: bench_gas grid [steps] | bench_gas compressible [steps] [threads] | "
                 "bench_gas cavity N MACH | bench_gas stokes N | bench_gas cache SOURCE_DIR | "
                 "bench_gas ledger SCENE CACHE_DIR [advances] [threads]\n");
    return 2;
  }
  return 0;
}
