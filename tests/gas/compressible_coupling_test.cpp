// The compressible gas model in a coupled run, against independent expectations: the notional
// nozzle against isentropic theory written out here and Birch et al.'s momentum balance; Newton's
// third law for the momentum exchanged with the particles in a periodic box; a fine particle's
// drag relaxation against Stokes' law with Cunningham's slip correction from the kinetic-theory
// mean free path; a coarse particle's drag at high slip Mach against Loth's correction; and the
// scene keys of the model refused with the key named.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "gas/compressible/notional_nozzle.h"
#include "gas/coupling.h"
#include "gas/mach_drag.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(NotionalNozzle, AChokedNozzleDeliversTheSonicThroatsFlowAndThrust) {
  const IdealGas air;
  const double gamma = air.gamma, r = air.gas_constant_j_per_kg_k;
  const double p0 = 5e5, t0 = 293.15, pa = 1e5, area = kPi * 0.5e-3 * 0.5e-3;
  // The sonic throat, from T*/T0 = 2/(γ+1) and p*/p0 = (T*/T0)^(γ/(γ−1)).
  const double t_star = 2.0 * t0 / (gamma + 1.0);
  const double p_star = p0 * std::pow(t_star / t0, gamma / (gamma - 1.0));
  const double u_star = std::sqrt(gamma * r * t_star), rho_star = p_star / (r * t_star);
  const NozzleExit e = notional_nozzle(air, p0, t0, area, pa);
  ASSERT_TRUE(e.choked);
  EXPECT_NEAR(e.mass_flow_kg_per_s, area * rho_star * u_star, 1e-12 * e.mass_flow_kg_per_s);
  EXPECT_NEAR(e.throat_pressure_pa, p_star, 1e-9 * p_star);
  // Birch et al. (1987): the notional jet at pa carries the throat's mass flow and its thrust
  // A (ρ* u*² + p* − pa), at the throat's temperature.
  const double thrust = area * (rho_star * u_star * u_star + p_star - pa);
  EXPECT_NEAR(e.mass_flow_kg_per_s * e.speed_m_per_s, thrust, 1e-12 * thrust);
  EXPECT_NEAR(e.density_kg_per_m3 * e.speed_m_per_s * e.area_m2, e.mass_flow_kg_per_s,
              1e-12 * e.mass_flow_kg_per_s);
  EXPECT_NEAR(e.density_kg_per_m3, pa / (r * t_star), 1e-12);
  EXPECT_NEAR(e.stagnation_enthalpy_j_per_kg, gamma * r / (gamma - 1.0) * t0, 1e-9);
  // Five bar into one: a supersonic notional jet, wider than the throat (Birch 1987's Fig. for
  // air: about 1.4 diameters at this ratio).
  EXPECT_GT(e.mach, 1.2);
  EXPECT_GT(e.area_m2, 1.5 * area);
  // Below the critical ratio the flow does not depend on the chamber's pressure.
  EXPECT_DOUBLE_EQ(notional_nozzle(air, p0, t0, area, 0.5 * pa).mass_flow_kg_per_s,
                   e.mass_flow_kg_per_s);
}

TEST(NotionalNozzle, AboveTheCriticalRatioTheJetLeavesAtTheIsentropicSpeed) {
  const IdealGas air;
  const double p0 = 1.5e5, t0 = 300.0, pa = 1.1e5, area = 1e-6;
  const double cp = air.heat_capacity_p_j_per_kg_k(), k = (air.gamma - 1.0) / air.gamma;
  // Energy: u² / 2 = c_p T0 (1 − (pa/p0)^((γ−1)/γ)); isentropic density at pa.
  const double u = std::sqrt(2.0 * cp * t0 * (1.0 - std::pow(pa / p0, k)));
  const double t = t0 * std::pow(pa / p0, k), rho = pa / (air.gas_constant_j_per_kg_k * t);
  const NozzleExit e = notional_nozzle(air, p0, t0, area, pa);
  EXPECT_FALSE(e.choked);
  EXPECT_NEAR(e.speed_m_per_s, u, 1e-9 * u);
  EXPECT_NEAR(e.mass_flow_kg_per_s, rho * u * area, 1e-9 * rho * u * area);
  EXPECT_NEAR(e.area_m2, area, 1e-9 * area);  // expanded already: no notional widening
  EXPECT_EQ(notional_nozzle(air, p0, t0, area, p0).mass_flow_kg_per_s, 0.0);
  EXPECT_EQ(notional_nozzle(air, p0, t0, area, 2.0 * p0).mass_flow_kg_per_s, 0.0);
}

GasConfig compressible_gas(std::array<int, 3> cells) {
  GasConfig gas;
  gas.model = GasModel::Compressible;
  gas.cells = cells;
  gas.density_kg_per_m3 = gas.compressible.gas.density_kg_per_m3(
      gas.compressible.initial_pressure_pa, gas.compressible.initial_temperature_k);
  gas.slip_correction = true;
  return gas;
}

TEST(CompressibleCoupling, MomentumExchangedWithTheParticlesBalancesToRounding) {
  // Particles drifting through gas at rest in a periodic box: the gas's momentum changes by
  // exactly what it received, which is exactly what the particles lost to drag.
  const MaterialConfig glass = test::table1_material(0.9, 0.3);
  SizeDistribution sizes;
  sizes.kind = SizeDistributionKind::Uniform;
  sizes.min_m = 2e-4;
  sizes.max_m = 5e-4;
  SceneConfig scene = test::periodic_random_gas(0.006, 400, sizes, 2.0, glass, 7);
  scene.sources[0].velocity_m_per_s = {3.0, -1.0, 0.5};
  scene.time.end_s = 3e-4;
  GasConfig gas = compressible_gas({6, 6, 6});
  gas.pressure_gradient_force = false;
  scene.gas = gas;
  Simulation sim(scene);
  const auto particle_momentum = [&] {
    Vec3 p = test::total_momentum(sim.particles());
    for (std::size_t i = 0; i < sim.particles().size(); ++i)
      p += sim.particles().load[i].force_n * (0.5 * sim.time_step().step_s);
    return p;
  };
  ASSERT_NE(sim.gas()->compressible(), nullptr);
  const Vec3 gas_before = sim.gas()->compressible()->total_momentum_n_s();
  const Vec3 particles_before = particle_momentum();
  double scale = 0.0;
  for (std::size_t i = 0; i < sim.particles().size(); ++i)
    scale += sim.particles().mass_kg[i] * norm(sim.particles().motion[i].velocity_m_per_s);
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step());
  const CouplingStats& s = sim.gas()->stats();
  const CompressibleSolver& c = *sim.gas()->compressible();
  ASSERT_GT(s.cfd_steps, 3u);
  ASSERT_GT(norm(s.particle_impulse_n_s), 1e-4 * scale);
  EXPECT_LT(norm(s.deposited_impulse_n_s - c.received_impulse_n_s()), 1e-12 * scale);
  EXPECT_LT(norm(c.total_momentum_n_s() - gas_before - c.received_impulse_n_s()), 1e-12 * scale);
  Vec3 pending;
  for (const Vec3& j : sim.particles().fluid_impulse_n_s) pending += j;
  EXPECT_LT(norm(s.particle_impulse_n_s + s.deposited_impulse_n_s - pending), 1e-12 * scale);
  EXPECT_LT(norm(particle_momentum() - particles_before - s.particle_impulse_n_s), 1e-12 * scale);
  // The gas was pushed along the drift.
  EXPECT_GT(c.total_momentum_n_s().x - gas_before.x, 0.0);
}

// Still air at 1 atm and 20 °C, as the coupling sees it: density, sound speed, mean free path.
struct StillAir {
  double density_kg_per_m3, sound_speed_m_per_s, mean_free_path_m;
};
StillAir still_air(double viscosity_pa_s) {
  const IdealGas air;
  const double rho = 101325.0 / (air.gas_constant_j_per_kg_k * 293.15);
  return {rho, std::sqrt(air.gamma * 101325.0 / rho),
          viscosity_pa_s * std::sqrt(kPi / (2.0 * 101325.0 * rho))};
}

// A particle of diameter d launched at v0 through still air, no gravity, for time t; the drag
// evaluated every step.
struct Launch {
  double speed_m_per_s;
  CouplingStats stats;
};
Launch launch(double d, double v0, double t_s, bool slip_correction, bool mach_correction) {
  MaterialConfig salt = test::table1_material();
  salt.density_kg_per_m3 = 2165.0;
  salt.youngs_modulus_pa = 1e5;
  const double box = 1e-3;
  SceneConfig scene = test::empty_scene({0, 0, 0}, {box, box, box}, salt, {true, true, true});
  test::add_particle(scene, {0.5 * box, 0.5 * box, 0.5 * box}, {v0, 0, 0}, d);
  scene.gravity_m_per_s2 = {0, 0, 0};
  scene.time.end_s = t_s;
  GasConfig gas = compressible_gas({1, 1, 1});
  gas.two_way = false;
  gas.cache_threshold = 0.0;
  gas.slip_correction = slip_correction;
  gas.mach_correction = mach_correction;
  scene.gas = gas;
  Simulation sim(scene);
  while (sim.step_index() < sim.total_steps()) EXPECT_FALSE(sim.step());
  return {norm(sim.particles().motion[0].velocity_m_per_s), sim.gas()->stats()};
}

// The fine particle's decay rate −1/τ as measured, launched at 1 mm/s (Re = 7e-5: Stokes flow).
double fine_particle_speed_ratio(double d, double t_s, bool slip_correction) {
  const double v0 = 1e-3;
  const Launch run = launch(d, v0, t_s, slip_correction, true);
  // The run's record of the drag's range: the first evaluation's slip Mach number v0 / c and the
  // Knudsen number 2λ/d of still air at 1 atm, 20 °C.
  const StillAir air = still_air(1.8e-5);
  const double mach = v0 / air.sound_speed_m_per_s;
  EXPECT_NEAR(run.stats.max_slip_mach, mach, 1e-9 * mach);
  EXPECT_NEAR(run.stats.max_knudsen, 2.0 * air.mean_free_path_m / d,
              1e-9 * air.mean_free_path_m / d);
  EXPECT_EQ(run.stats.drag_evaluations_past_mach_0_3, 0u);
  // At Mach 3e-6 Loth's correction leaves the Stokes drag as it is.
  EXPECT_NEAR(run.stats.max_mach_drag_factor, 1.0, 1e-12);
  return std::log(run.speed_m_per_s / v0) / t_s;
}

TEST(CompressibleCoupling, AFineParticleRelaxesAtTheSlipCorrectedStokesRate) {
  // m dv/dt = −3π μ d v / C: v = v0 exp(−t/τ), τ = m C / (3π μ d), with Cunningham's C from
  // Kn = 2λ/d and the hard-sphere mean free path λ = μ √(π / (2 p ρ)) of air at 1 atm, 20 °C.
  const IdealGas air;
  const double mu = 1.8e-5, p = 101325.0, rho = p / (air.gas_constant_j_per_kg_k * 293.15);
  const double lambda = mu * std::sqrt(kPi / (2.0 * p * rho));
  EXPECT_NEAR(lambda, 6.5e-8, 0.2e-8);  // air's tabulated 66–68 nm at μ = 1.8e-5
  for (double d : {1e-6, 3e-6}) {
    const double kn = 2.0 * lambda / d;
    const double c = 1.0 + kn * (1.257 + 0.400 * std::exp(-1.10 / kn));
    const double m = 2165.0 * kPi / 6.0 * d * d * d, stokes_tau = m / (3.0 * kPi * mu * d);
    const double t = 2.0 * stokes_tau * c;
    const double with = fine_particle_speed_ratio(d, t, true);
    const double without = fine_particle_speed_ratio(d, t, false);
    std::printf(
        "d = %g m: Kn %.4f, C %.4f; decay rate %.6g /s (expected %.6g), without the "
        "correction %.6g (expected %.6g)\n",
        d, kn, c, -with, 1.0 / (stokes_tau * c), -without, 1.0 / stokes_tau);
    EXPECT_NEAR(-with * stokes_tau * c, 1.0, 0.005) << "d = " << d;
    EXPECT_NEAR(-without * stokes_tau, 1.0, 0.005) << "d = " << d;
  }
}

TEST(CompressibleCoupling, ACoarseParticleCrossingAtHighSlipMachTakesLothsDrag) {
  // A 200 µm particle at 300 m/s through still air: slip Mach 0.87, Re 4 000 (Schiller–Naumann's
  // Newton regime). Over 0.5 µs its speed falls by about 0.02 %, so the drag stays at its initial
  // value to 5e-4: the speed lost with Loth's correction over the speed lost without it is
  // Loth's C_D(Re, M) / C_D(Re, 0) at the launch, with Re, M and λ/d from the still air here.
  const double d = 200e-6, v0 = 300.0, t = 0.5e-6, mu = 1.8e-5;
  const StillAir air = still_air(mu);
  const double re = air.density_kg_per_m3 * v0 * d / mu, mach = v0 / air.sound_speed_m_per_s;
  const double expected = loth_mach_factor(re, mach, air.mean_free_path_m / d, IdealGas{}.gamma);
  ASSERT_GT(expected, 1.5);  // the transonic drag rise (tests/gas/mach_drag_test.cpp)
  const Launch with = launch(d, v0, t, true, true), without = launch(d, v0, t, true, false);
  const double lost_with = v0 - with.speed_m_per_s, lost_without = v0 - without.speed_m_per_s;
  ASSERT_GT(lost_without, 1e-5 * v0);
  std::printf(
      "slip Mach %.3f, Re %.0f: speed lost %.6g m/s with Loth's correction, %.6g without "
      "(ratio %.5f, factor at launch %.5f)\n",
      mach, re, lost_with, lost_without, lost_with / lost_without, expected);
  EXPECT_NEAR(lost_with / lost_without, expected, 5e-4 * expected);
  EXPECT_NEAR(with.stats.max_mach_drag_factor, expected, 1e-9 * expected);
  EXPECT_EQ(without.stats.max_mach_drag_factor, 1.0);
  EXPECT_GT(with.stats.drag_evaluations_past_mach_0_3, 0u);
}

nlohmann::json compressible_mill_scene() {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/spiral_jet_mill.json");
  nlohmann::json doc = nlohmann::json::parse(in);
  doc["gas"] = {{"model", "compressible"}, {"cells", {32, 32, 5}}};
  nlohmann::json& nozzle = doc["mill"]["nozzles"][0];
  nozzle.erase("speed_m_per_s");
  nozzle["supply_pressure_pa"] = 501325.0;
  return doc;
}

std::string error_text(const nlohmann::json& doc) {
  std::string all;
  for (const InputError& e : test::scene_errors(doc))
    all += e.path + " | " + e.value + " | " + e.allowed + "\n";
  return all;
}

TEST(CompressibleCoupling, AMillSetByItsGrindingPressureIsAValidScene) {
  EXPECT_EQ(error_text(compressible_mill_scene()), "");
}

TEST(CompressibleCoupling, SceneErrorsNameTheKey) {
  {  // a pressure-set nozzle with the incompressible gas
    nlohmann::json doc = compressible_mill_scene();
    doc["gas"].erase("model");
    const std::string all = error_text(doc);
    EXPECT_NE(all.find("/mill/nozzles/0/supply_pressure_pa | 501325 | a nozzle set by its supply "
                       "pressure needs /gas/model \"compressible\""),
              std::string::npos)
        << all;
  }
  {  // ... and with no gas at all
    nlohmann::json doc = compressible_mill_scene();
    doc.erase("gas");
    EXPECT_NE(error_text(doc).find("/mill/nozzles/0/supply_pressure_pa | 501325 | a nozzle set by "
                                   "its supply pressure needs a /gas section"),
              std::string::npos)
        << error_text(doc);
  }
  {  // a supply below the chamber's pressure, a negative pressure, keys of the other model
    nlohmann::json doc = compressible_mill_scene();
    doc["mill"]["nozzles"][0]["supply_pressure_pa"] = 9e4;
    doc["gas"]["compressible"] = {{"initial_pressure_pa", -5.0}};
    doc["gas"]["density_kg_per_m3"] = 1.2;
    doc["gas"]["advection"] = "tvd";
    const std::string all = error_text(doc);
    EXPECT_NE(all.find("/gas/compressible/initial_pressure_pa | -5"), std::string::npos) << all;
    EXPECT_NE(all.find("/gas/density_kg_per_m3 |  | the compressible model does not read it"),
              std::string::npos)
        << all;
    EXPECT_NE(all.find("/gas/advection |  | the compressible model does not read it"),
              std::string::npos)
        << all;
  }
  {
    nlohmann::json doc = compressible_mill_scene();
    doc["mill"]["nozzles"][0]["supply_pressure_pa"] = 9e4;
    const std::string all = error_text(doc);
    EXPECT_NE(all.find("/mill/nozzles/0/supply_pressure_pa | 90000 | expected a supply pressure "
                       "above the chamber's (101325 Pa"),
              std::string::npos)
        << all;
  }
  {  // the compressible model's drag corrections on the incompressible gas
    nlohmann::json doc = compressible_mill_scene();
    doc["gas"] = {{"cells", {32, 32, 5}}, {"mach_correction", "loth"}};
    doc["mill"]["nozzles"][0].erase("supply_pressure_pa");
    doc["mill"]["nozzles"][0]["speed_m_per_s"] = 120;
    const std::string all = error_text(doc);
    EXPECT_NE(all.find("/gas/mach_correction | loth | Loth's Mach correction needs the gas's "
                       "sound speed: only with /gas/model \"compressible\""),
              std::string::npos)
        << all;
    doc["gas"] = {{"model", "compressible"}, {"cells", {32, 32, 5}}, {"mach_correction", "parmar"}};
    EXPECT_NE(error_text(doc).find("/gas/mach_correction | \"parmar\" | expected one of loth none"),
              std::string::npos)
        << error_text(doc);
  }
  {  // the compressible section on an incompressible gas
    nlohmann::json doc = compressible_mill_scene();
    doc["gas"] = {{"cells", {32, 32, 5}}, {"compressible", {{"gamma", 1.4}}}};
    doc["mill"]["nozzles"][0].erase("supply_pressure_pa");
    doc["mill"]["nozzles"][0]["speed_m_per_s"] = 120;
    const std::string all = error_text(doc);
    EXPECT_NE(all.find("/gas/compressible |  | only the compressible model reads this section"),
              std::string::npos)
        << all;
  }
}

}  // namespace
}  // namespace millsim
