// Gas–particle coupling against independent expectations: drag laws in their analytic limits,
// the Schiller–Naumann terminal velocity of single salt particles settling in still air (§3.1
// of the paper: 0.1–10 mm, with and without the drag cache), and Newton's third law for the
// momentum exchanged between particles and gas.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/rng.h"
#include "gas/coupling.h"
#include "gas/drag.h"
#include "gas/gas_grid.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kAirDensity = 1.2, kAirViscosity = 1.8e-5, kSaltDensity = 2165.0;

TEST(DragLaws, StokesLimitAndDiluteAgreement) {
  const DragInput slow{1e-4, 1e-9, 1.0, kAirDensity, kAirViscosity};
  const double stokes = 3.0 * kPi * kAirViscosity * 1e-4;
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::SchillerNaumann, slow), stokes, 1e-6 * stokes);
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::Gidaspow, slow), stokes, 1e-6 * stokes);
  // Di Felice's C_d = (0.63 + 4.8/√Re)² tends to 23.04/Re: 0.96 of Stokes.
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::DiFelice, slow), 0.96 * stokes, 1e-4 * stokes);
  // At Re = 50 and ε = 1, Wen–Yu is Schiller–Naumann: ½ ρ C_d A |s| with C_d from the formula.
  const double d = 1e-3, re = 50.0, slip = re * kAirViscosity / (kAirDensity * d);
  const DragInput mid{d, slip, 1.0, kAirDensity, kAirViscosity};
  const double cd = 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687));
  const double expected = 0.5 * kAirDensity * cd * kPi * d * d / 4.0 * slip;
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::SchillerNaumann, mid), expected, 1e-12);
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::Gidaspow, mid), expected, 1e-12);
  // Past Re = 1000 the Newton regime, C_d = 0.44.
  const double fast_slip = 3000.0 * kAirViscosity / (kAirDensity * d);
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::SchillerNaumann,
                                        {d, fast_slip, 1.0, kAirDensity, kAirViscosity}),
              0.5 * kAirDensity * 0.44 * kPi * d * d / 4.0 * fast_slip, 1e-12);
}

TEST(DragLaws, SaffmanLiftPushesALaggingParticleTowardTheFasterGas) {
  // Shear flow u = (γ y, 0, 0): ω = ∇×u = (0, 0, −γ). A particle slower than the gas (slip +x)
  // is lifted toward +y with 1.615 d² √(ρ μ γ) |s| (Saffman 1965, Crowe et al.'s form).
  const double gamma = 200.0, d = 1e-4, s = 0.5;
  const Vec3 lift = saffman_lift_n(d, {s, 0, 0}, {0, 0, -gamma}, kAirDensity, kAirViscosity);
  EXPECT_NEAR(lift.y, 1.615 * d * d * std::sqrt(kAirDensity * kAirViscosity * gamma) * s, 1e-18);
  EXPECT_DOUBLE_EQ(lift.x, 0.0);
  EXPECT_DOUBLE_EQ(lift.z, 0.0);
}

TEST(DragLaws, GidaspowDenseBranchIsErgunPerUnitBedVolume) {
  // n particles per unit volume with interstitial slip U/ε exert β n (U/ε) = ε ∇p, so ∇p must
  // be Ergun's 150 (1−ε)² μ U / (ε³ d²) + 1.75 (1−ε) ρ U² / (ε³ d).
  const double d = 5e-4, eps = 0.42, U = 0.2;
  const double n = (1.0 - eps) / (kPi * d * d * d / 6.0);
  const double beta =
      drag_coefficient_kg_per_s(DragLaw::Gidaspow, {d, U / eps, eps, kAirDensity, kAirViscosity});
  const double gradient = beta * n * (U / eps) / eps;
  const double ergun =
      150.0 * (1 - eps) * (1 - eps) * kAirViscosity * U / (eps * eps * eps * d * d) +
      1.75 * (1 - eps) * kAirDensity * U * U / (eps * eps * eps * d);
  EXPECT_NEAR(gradient, ergun, 1e-9 * ergun);
}

// Koch–Hill and Beetstra written out from their papers, as the dimensionless force over
// 3π μ d U (U = ε |s|): Koch–Hill's is the total force (drag = ε of it), Beetstra's the drag.
double koch_hill_total(double eps, double re) {
  const double phi = 1 - eps;
  const double f0 =
      phi < 0.4 ? (1 + 3 * std::sqrt(phi / 2) + 135.0 / 64 * phi * std::log(phi) + 16.14 * phi) /
                      (1 + 0.681 * phi - 8.48 * phi * phi + 8.16 * std::pow(phi, 3))
                : 10 * phi / std::pow(eps, 3);
  return f0 + 0.5 * (0.0673 + 0.212 * phi + 0.0232 / std::pow(eps, 5)) * re;
}

double beetstra_drag(double eps, double re) {
  const double phi = 1 - eps;
  return 10 * phi / (eps * eps) + eps * eps * (1 + 1.5 * std::sqrt(phi)) +
         0.413 * re / (24 * eps * eps) * (1 / eps + 3 * eps * phi + 8.4 * std::pow(re, -0.343)) /
             (1 + std::pow(10.0, 3 * phi) * std::pow(re, -(1 + 4 * phi) / 2));
}

TEST(DragLaws, KochHillAndBeetstraFollowTheirPublishedForms) {
  const double d = 2e-4;
  for (double eps : {0.95, 0.8, 0.65, 0.5, 0.4})
    for (double re : {0.1, 1.0, 10.0, 100.0, 500.0}) {
      const double slip = re * kAirViscosity / (eps * kAirDensity * d);  // Re = ε ρ d |s| / μ
      const DragInput in{d, slip, eps, kAirDensity, kAirViscosity};
      const double stokes = 3 * kPi * kAirViscosity * d;
      EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::KochHill, in) / (stokes * eps * eps),
                  koch_hill_total(eps, re), 1e-9 * koch_hill_total(eps, re))
          << "eps " << eps << " Re " << re;
      EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::Beetstra, in) / (stokes * eps),
                  beetstra_drag(eps, re), 1e-9 * beetstra_drag(eps, re))
          << "eps " << eps << " Re " << re;
    }
}

// The limits that tie both laws to first principles: a single slow sphere feels Stokes drag, and
// a slowly flowed dense bed the Carman–Kozeny gradient 180 φ² μ U / (ε³ d²) (β n (U/ε) = ε ∇p, as
// for Ergun above); Beetstra adds its ε²(1 + 1.5 √φ) term to it. Koch–Hill's two branches meet at
// φ = 0.4 within 1.1 %.
TEST(DragLaws, KochHillAndBeetstraReachStokesAndCarmanKozeny) {
  const double d = 2e-4, stokes = 3 * kPi * kAirViscosity * d;
  const DragInput single{d, 1e-9, 1.0, kAirDensity, kAirViscosity};
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::KochHill, single), stokes, 1e-6 * stokes);
  EXPECT_NEAR(drag_coefficient_kg_per_s(DragLaw::Beetstra, single), stokes, 1e-6 * stokes);

  const double eps = 0.45, phi = 1 - eps, U = 1e-7;
  const double n = phi / (kPi * d * d * d / 6.0);
  const double carman_kozeny = 180 * phi * phi * kAirViscosity * U / (std::pow(eps, 3) * d * d);
  const DragInput bed{d, U / eps, eps, kAirDensity, kAirViscosity};
  const double kh = drag_coefficient_kg_per_s(DragLaw::KochHill, bed) * n * (U / eps) / eps;
  EXPECT_NEAR(kh, carman_kozeny, 1e-6 * carman_kozeny);
  const double extra = eps * eps * (1 + 1.5 * std::sqrt(phi)) / (10 * phi / (eps * eps));
  const double bs = drag_coefficient_kg_per_s(DragLaw::Beetstra, bed) * n * (U / eps) / eps;
  EXPECT_NEAR(bs, carman_kozeny * (1 + extra), 1e-6 * carman_kozeny);

  const DragInput below{d, 1e-9, 0.6 + 1e-9, kAirDensity, kAirViscosity};
  const DragInput above{d, 1e-9, 0.6 - 1e-9, kAirDensity, kAirViscosity};
  const double low = drag_coefficient_kg_per_s(DragLaw::KochHill, below);
  const double high = drag_coefficient_kg_per_s(DragLaw::KochHill, above);
  EXPECT_NEAR(low / high, 1.0, 0.011);
}

// Terminal velocity from (ρ_p − ρ_g) g V = ½ ρ_g C_d(Re) A v², solved by bisection.
double schiller_naumann_terminal(double d) {
  const double weight = (kSaltDensity - kAirDensity) * 9.81 * kPi * d * d * d / 6.0;
  double lo = 0.0, hi = 100.0;
  for (int k = 0; k < 200; ++k) {
    const double v = 0.5 * (lo + hi), re = kAirDensity * d * v / kAirViscosity;
    const double cd = re < 1000.0 ? 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687)) : 0.44;
    (0.5 * kAirDensity * cd * kPi * d * d / 4.0 * v * v < weight ? lo : hi) = v;
  }
  return 0.5 * (lo + hi);
}

// One salt particle released from rest in still air, in a periodic box (a column without end).
struct Settling {
  double final_speed, largest_speed, evaluations_per_step;
  double time_to_95_percent_s;  // of the Schiller–Naumann terminal speed
};

Settling settle(double d, double cache_threshold, DragCacheStore store) {
  MaterialConfig salt = test::table1_material();
  salt.density_kg_per_m3 = kSaltDensity;
  salt.youngs_modulus_pa = 1e5;  // alone in the air: only the Rayleigh bound of the step cares
  const double box = std::max(0.01, 3.0 * d);
  SceneConfig scene = test::empty_scene({0, 0, 0}, {box, box, box}, salt, {true, true, true});
  test::add_particle(scene, {0.5 * box, 0.5 * box, 0.5 * box}, {}, d);
  scene.gravity_m_per_s2 = {0, 0, -9.81};
  const double v_t = schiller_naumann_terminal(d);
  scene.time.end_s = 8.0 * v_t / 9.81 + 0.05;  // several relaxation times
  GasConfig gas;
  gas.cells = {1, 1, 1};
  gas.two_way = false;  // still air far from the particle, as the analytic result assumes
  gas.cache_threshold = cache_threshold;
  gas.cache_store = store;
  scene.gas = gas;
  Simulation sim(scene);
  Settling out{0, 0, 0, -1};
  while (sim.step_index() < sim.total_steps()) {
    const double before = norm(sim.particles().motion[0].velocity_m_per_s);
    EXPECT_FALSE(sim.step());
    const double speed = norm(sim.particles().motion[0].velocity_m_per_s);
    out.largest_speed = std::max(out.largest_speed, speed);
    if (out.time_to_95_percent_s < 0 && speed >= 0.95 * v_t) {  // interpolated within the step
      const double dt = sim.time_step().step_s;
      out.time_to_95_percent_s = sim.time_s() - dt * (speed - 0.95 * v_t) / (speed - before);
    }
  }
  out.final_speed = norm(sim.particles().motion[0].velocity_m_per_s);
  const CouplingStats& s = sim.gas()->stats();
  out.evaluations_per_step =
      double(s.drag_evaluations) / double(s.drag_evaluations + s.drag_reuses);
  return out;
}

// The transient: time to 95 % of the terminal speed from rest, against m dv/dt = m g − β(v) v
// with Schiller–Naumann's β, integrated here by RK4 at 1e5 steps. With the cache at its default
// (5 %) the cached β follows the slip to first order (docs/gas.md); without that slope the
// particles arrived 4–5 % early (bench/RESULTS.md, "Drag caching").
double time_to_95_percent(double d) {
  const double m = kSaltDensity * kPi * d * d * d / 6.0, v_t = schiller_naumann_terminal(d);
  const double weight = (kSaltDensity - kAirDensity) / kSaltDensity * 9.81;
  const auto accel = [&](double v) {
    const double re = kAirDensity * d * v / kAirViscosity;
    const double beta = re < 1000.0 ? 3 * kPi * kAirViscosity * d * (1 + 0.15 * std::pow(re, 0.687))
                                    : 0.125 * kPi * d * d * kAirDensity * 0.44 * v;
    return weight - beta * v / m;
  };
  const double h = 20.0 * v_t / 9.81 / 1e5;
  double v = 0.0, t = 0.0;
  while (true) {
    const double k1 = accel(v), k2 = accel(v + 0.5 * h * k1), k3 = accel(v + 0.5 * h * k2),
                 k4 = accel(v + h * k3);
    const double next = v + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
    if (next >= 0.95 * v_t) return t + h * (0.95 * v_t - v) / (next - v);
    v = next, t += h;
  }
}

TEST(Settling, TheCachedDragKeepsTheTransientWithinOnePercent) {
  for (double d : {1e-3, 3e-3, 1e-2}) {
    const double expected = time_to_95_percent(d);
    const Settling exact = settle(d, 0.0, DragCacheStore::Coefficient);
    const Settling cached = settle(d, 0.05, DragCacheStore::Coefficient);
    std::printf("d = %g m: t95 %.6f s; no cache %.6f (%+.3f %%); cache 5 %% %.6f (%+.3f %%)\n", d,
                expected, exact.time_to_95_percent_s,
                100 * (exact.time_to_95_percent_s / expected - 1), cached.time_to_95_percent_s,
                100 * (cached.time_to_95_percent_s / expected - 1));
    EXPECT_NEAR(exact.time_to_95_percent_s, expected, 0.002 * expected) << "d = " << d;
    EXPECT_NEAR(cached.time_to_95_percent_s, expected, 0.01 * expected) << "d = " << d;
  }
}

TEST(Settling, SaltParticlesReachTheSchillerNaumannTerminalVelocity) {
  for (double d : {1e-4, 1e-3, 1e-2}) {
    const double v_t = schiller_naumann_terminal(d);
    const Settling exact = settle(d, 0.0, DragCacheStore::Coefficient);
    EXPECT_NEAR(exact.final_speed, v_t, 0.01 * v_t) << "d = " << d;
    EXPECT_DOUBLE_EQ(exact.evaluations_per_step, 1.0);
    const Settling cached = settle(d, 0.05, DragCacheStore::Coefficient);
    EXPECT_NEAR(cached.final_speed, v_t, 0.03 * v_t) << "d = " << d << ", cache 5 %";
    EXPECT_LT(cached.largest_speed, 1.03 * v_t);
    EXPECT_LT(cached.evaluations_per_step, 0.2);
    const Settling force = settle(d, 0.05, DragCacheStore::Force);
    std::printf(
        "d = %g m: v_t = %.5f m/s; no cache %.5f (%.3f %%); cached coefficient %.5f (%.3f %%, "
        "%.4f evaluations/step); cached force %.5f (%.3f %%, peak %.3f %%, %.4f "
        "evaluations/step)\n",
        d, v_t, exact.final_speed, 100 * (exact.final_speed / v_t - 1), cached.final_speed,
        100 * (cached.final_speed / v_t - 1), cached.evaluations_per_step, force.final_speed,
        100 * (force.final_speed / v_t - 1), 100 * (force.largest_speed / v_t - 1),
        force.evaluations_per_step);
  }
}

// Particles moving through gas at rest in a periodic box, no gravity, no pressure-gradient force:
// what the particles gain from drag the gas loses, to rounding, and the particles' momentum (with
// the force in flight) changes by exactly the drag impulse. `steps` runs advance() over that many
// steps at a time (under multi-rate stepping the stepping particles' kept exchange is then booked
// in counts of steps, sim/multi_rate.h).
void expect_momentum_exchange_balances(bool multi_rate, std::int64_t steps) {
  const MaterialConfig glass = test::table1_material(0.9, 0.3);
  SizeDistribution sizes;
  sizes.kind = SizeDistributionKind::Uniform;
  sizes.min_m = 2e-4;
  sizes.max_m = 5e-4;
  SceneConfig scene = test::periodic_random_gas(0.006, 400, sizes, 2.0, glass, 7);
  scene.sources[0].velocity_m_per_s = {3.0, -1.0, 0.5};  // a drift the gas has to take up
  scene.time.end_s = 4e-4;
  GasConfig gas;
  gas.cells = {6, 6, 6};
  gas.pressure_gradient_force = false;
  gas.pressure_tolerance = 1e-10;
  gas.step_s = 2e-5;  // several CFD steps in the run
  scene.gas = gas;
  scene.time.multi_rate = multi_rate;
  Simulation sim(scene);
  const auto momentum = [&] {
    Vec3 p = test::total_momentum(sim.particles());
    for (std::size_t i = 0; i < sim.particles().size(); ++i)
      p += sim.particles().load[i].force_n * (0.5 * sim.time_step().step_s);
    return p;
  };
  const Vec3 before = momentum();
  double scale = 0.0;
  for (std::size_t i = 0; i < sim.particles().size(); ++i)
    scale += sim.particles().mass_kg[i] * norm(sim.particles().motion[i].velocity_m_per_s);
  while (sim.step_index() < sim.total_steps())
    ASSERT_FALSE(sim.advance(std::min(steps, sim.total_steps() - sim.step_index())));
  if (multi_rate) {  // both kinds of particle, and kept forces applied
    ASSERT_NE(sim.multi_rate(), nullptr);
    ASSERT_GT(sim.multi_rate()->stats.waiting_particle_steps, 0.0);
    ASSERT_GT(sim.multi_rate()->stats.held_fluid_steps, 0.0);
  }
  const CouplingStats& s = sim.gas()->stats();
  ASSERT_GT(s.cfd_steps, 3u);
  ASSERT_GT(norm(s.particle_impulse_n_s), 1e-4 * scale);  // drag did real work
  // Gas side: everything handed over by the last CFD step was received.
  const Vec3 gas_received = sim.gas()->gas().received_impulse_n_s();
  EXPECT_LT(norm(s.deposited_impulse_n_s - gas_received), 1e-12 * scale);
  // What the particles took since the last CFD step is still pending with them.
  Vec3 pending;
  for (const Vec3& j : sim.particles().fluid_impulse_n_s) pending += j;
  EXPECT_LT(norm(s.particle_impulse_n_s + s.deposited_impulse_n_s - pending), 1e-12 * scale);
  // Particle side: momentum change = drag impulse (contacts cancel in pairs). Under multi-rate
  // stepping a particle in free flight last took a long step h of its own, so the force in flight
  // is ½ h F, which momentum() counts as ½ dt F: the balance then holds to within the largest
  // such difference, Σ ½ (max_wait_steps − 1) dt |F|.
  double in_flight_slack = 0.0;
  if (multi_rate)
    for (const Load& l : sim.particles().load)
      in_flight_slack += 0.5 * double(sim.multi_rate()->max_wait_steps - 1) *
                         sim.time_step().step_s * norm(l.force_n);
  EXPECT_LT(norm(momentum() - before - s.particle_impulse_n_s), 1e-12 * scale + in_flight_slack);
}

TEST(Coupling, MomentumExchangeBalancesToRounding) {
  expect_momentum_exchange_balances(false, 1);
}

TEST(Coupling, MomentumExchangeBalancesToRoundingUnderMultiRateStepping) {
  expect_momentum_exchange_balances(true, 1);
  expect_momentum_exchange_balances(true, 50);  // kicks carried, exchange booked in counts
}

TEST(Coupling, APerParticleCellHintNeverReturnsAnotherCellsOrAnOldStepsState) {
  // The fluid table's per-particle hint (the DEM cell read last) only skips the hash lookup. A
  // DEM cell no larger than a gas cell holds the gas state at its centre; particles random-walk
  // across cells while the gas field is replaced and the table cleared every few steps (a CFD
  // step): every read must be the state at the centre of the cell the particle is in now, from
  // the current field. A hint kept across a clear, or kept after leaving its cell, fails.
  const PeriodicBox box{{0.0, 0.0, 0.0}, {0.004, 0.004, 0.004}, {true, true, true}};
  GasConfig config;
  config.cells = {8, 8, 8};
  GasSolver gas(config, build_gas_grid(config, box.min_m, box.max_m, box.periodic), {});
  const double cell_m = 0.00025;  // half a gas cell: one averaging point, the centre
  DemCellFluidTable table(cell_m, box.min_m);
  Rng rng(11);
  const auto new_field = [&] {
    for (auto& component : gas.velocity())
      for (double& u : component) u = 20.0 * uniform01(rng) - 10.0;
    gas.fill_velocity_ghosts(gas.velocity());
  };
  std::vector<Vec3> x(300);
  for (Vec3& xi : x) xi = {0.004 * uniform01(rng), 0.004 * uniform01(rng), 0.004 * uniform01(rng)};
  std::vector<FluidCellRef> hint(x.size());
  std::size_t moved_cells = 0, kept_cells = 0;
  for (int step = 0; step < 60; ++step) {
    if (step % 4 == 0) {
      new_field();
      table.clear();
    }
    for (std::size_t i = 0; i < x.size(); ++i) {
      const Vec3 before = x[i];
      for (int a = 0; a < 3; ++a)  // steps of up to 0.2 cell, wrapped into the box
        x[i][a] = std::fmod(x[i][a] + 0.2 * cell_m * (2.0 * uniform01(rng) - 1.0) + 0.004, 0.004);
      const Vec3 centre = {(std::floor(x[i].x / cell_m) + 0.5) * cell_m,
                           (std::floor(x[i].y / cell_m) + 0.5) * cell_m,
                           (std::floor(x[i].z / cell_m) + 0.5) * cell_m};
      const bool same_cell = std::floor(before.x / cell_m) == std::floor(x[i].x / cell_m) &&
                             std::floor(before.y / cell_m) == std::floor(x[i].y / cell_m) &&
                             std::floor(before.z / cell_m) == std::floor(x[i].z / cell_m);
      ++(same_cell ? kept_cells : moved_cells);
      const Vec3 expected = gas.velocity_at(centre);
      const Vec3 read = table.at(x[i], gas, false, hint[i]).velocity_m_per_s;
      ASSERT_LT(norm(read - expected), 1e-12 * norm(expected)) << "step " << step << " i " << i;
    }
  }
  // Both paths ran many times: the hint kept (same cell) and the hint left behind.
  EXPECT_GT(kept_cells, 5000u);
  EXPECT_GT(moved_cells, 1000u);
}

TEST(Coupling, SceneErrorsNameTheGasField) {
  nlohmann::json doc = {
      {"materials",
       {{{"name", "m"},
         {"youngs_modulus_pa", 1e7},
         {"poisson_ratio", 0.3},
         {"density_kg_per_m3", 2500}}}},
      {"domain",
       {{"min_m", {0, 0, 0}}, {"max_m", {0.01, 0.01, 0.01}}, {"periodic", {true, false, false}}}},
      {"time", {{"end_s", 0.01}}},
      {"gas",
       {{"cells", {4, 4, 4}},
        {"boundaries", {{{"face", "x-"}, {"type", "inlet"}, {"velocity_m_per_s", {1, 0, 0}}}}},
        {"drag", "stokes"}}}};
  const InputErrors errors = test::scene_errors(doc);
  std::string all;
  for (const InputError& e : errors) all += e.path + " | " + e.value + " | " + e.allowed + "\n";
  EXPECT_NE(all.find("/gas/boundaries/0/face | x- | this axis is periodic"), std::string::npos)
      << all;
  EXPECT_NE(all.find("/gas/boundaries | "), std::string::npos) << all;  // inlet, no outlet
  EXPECT_NE(all.find("/gas/drag | \"stokes\""), std::string::npos) << all;
}

TEST(Coupling, AnInletThatCoversNoFaceIsRefused) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {0.01, 0.01, 0.01}, test::table1_material());
  test::add_particle(scene, {0.005, 0.005, 0.005}, {}, 5e-4);
  scene.time.end_s = 1e-3;
  GasConfig gas;
  gas.cells = {4, 4, 4};  // 2.5 mm cells: face centres at 1.25, 3.75, ... mm
  GasBoundaryPatch nozzle;
  nozzle.name = "nozzle";
  nozzle.face = 0;
  nozzle.kind = GasBoundaryKind::Inlet;
  nozzle.shape = PatchShape::Circle;
  nozzle.center_m = {0, 0.005, 0.005};
  nozzle.radius_m = 0.001;  // covers no face centre (the nearest are 1.77 mm away)
  nozzle.velocity_m_per_s = {10, 0, 0};
  GasBoundaryPatch exhaust;
  exhaust.face = 1;
  exhaust.kind = GasBoundaryKind::Outlet;
  gas.boundaries = {nozzle, exhaust};
  scene.gas = gas;
  try {
    Simulation sim(scene);
    FAIL() << "expected an input error";
  } catch (const InputErrorList& e) {
    EXPECT_EQ(e.errors().at(0).path, "/gas/boundaries/0");
    EXPECT_NE(e.errors().at(0).allowed.find("covers no boundary face"), std::string::npos);
  }
  scene.gas->boundaries[0].radius_m = 0.002;  // now it covers the four nearest faces
  Simulation sim(scene);
  EXPECT_EQ(sim.gas()->gas().grid().patch_faces[0], 4u);
  EXPECT_NEAR(sim.gas()->gas().grid().patch_area_m2[0], 4 * 0.0025 * 0.0025, 1e-15);
}

TEST(Coupling, GasCellsMustBeLargerThanTheLargestParticle) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {0.01, 0.01, 0.01}, test::table1_material());
  test::add_particle(scene, {0.005, 0.005, 0.005}, {}, 2e-3);
  scene.time.end_s = 1e-3;
  GasConfig gas;
  gas.cells = {10, 4, 4};
  scene.gas = gas;
  try {
    Simulation sim(scene);
    FAIL() << "expected an input error";
  } catch (const InputErrorList& e) {
    EXPECT_EQ(e.errors().at(0).path, "/gas/cells/0");
    EXPECT_NE(e.errors().at(0).allowed.find("at most 5 cells"), std::string::npos)
        << e.errors().at(0).allowed;
  }
}

}  // namespace
}  // namespace millsim
