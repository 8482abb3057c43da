// Inlet schedules and pressure drops (issue 17, items 4 and 8). A schedule's value follows its
// table (linear between rows, a repeated time is a step); the gas carries exactly the scheduled
// mass flow out of the outlet at every step (continuity); a scheduled nozzle blows the flow and
// momentum of its speed at that time; a column of gas at rest has the hydrostatic drop ρ g L
// between its end faces; and a fixed random bed, with its inlet ramped, has at every recorded
// time the pressure gradient Koch & Hill (2001) give for its voidage and the inlet's speed then.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>

#include <nlohmann/json.hpp>

#include "gas/gas_solver.h"
#include "gas/pressure_probe.h"
#include "scene/scene_json.h"
#include "sim/run.h"
#include "sim/simulation.h"
#include "support/drag_reference.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kPi = std::numbers::pi, kG = 9.81;

TEST(Schedule, RowsInterpolateLinearlyRepeatedTimesStepAndTheEndsHold) {
  const Schedule s{{0.0, 0.1, 0.1, 0.3}, {1.0, 2.0, 4.0, 0.0}};
  EXPECT_EQ(s.at(-1.0), 1.0);
  EXPECT_DOUBLE_EQ(s.at(0.05), 1.5);  // half-way up the first ramp
  EXPECT_EQ(s.at(0.1), 4.0);          // at a step the later row holds
  EXPECT_DOUBLE_EQ(s.at(0.2), 2.0);   // half-way down from 4 to 0
  EXPECT_EQ(s.at(0.3), 0.0);
  EXPECT_EQ(s.at(7.0), 0.0);
  EXPECT_EQ(Schedule({{0.5}, {3.0}}).at(0.0), 3.0);  // one row: constant
}

// A 2 × 2 × 10 column, periodic across, an inlet patch at the bottom and an outlet on top.
GasConfig column(InflowSchedule schedule) {
  GasConfig g;
  g.cells = {2, 2, 10};
  g.pressure_tolerance = 1e-12;
  GasBoundaryPatch inlet;
  inlet.name = "distributor";
  inlet.face = 4;
  inlet.kind = GasBoundaryKind::Inlet;
  inlet.schedule = std::move(schedule);
  GasBoundaryPatch top;
  top.name = "top";
  top.face = 5;
  top.kind = GasBoundaryKind::Outlet;
  g.boundaries = {inlet, top};
  return g;
}

TEST(InflowSchedule, TheOutletCarriesTheScheduledMassFlowAtEveryStep) {
  // Mass flow 0 until 10 ms, a step to 2e-5 kg/s, a ramp to 6e-5 kg/s at 30 ms, then held.
  InflowSchedule schedule{{{0.0, 0.01, 0.01, 0.03}, {0.0, 0.0, 2e-5, 6e-5}}, true};
  const GasConfig config = column(schedule);
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.01, 0.01, 0.05}, {true, true, false}),
                {0, 0, -kG});
  const GasGrid& g = gas.grid();
  const double area = 0.01 * 0.01;
  int steps = 0;
  while (gas.time_s() < 0.04) {
    ASSERT_FALSE(gas.advance(5e-4).has_value());
    ++steps;
    const double set_kg_per_s = schedule.table.at(gas.time_s());
    double out_kg_per_s = 0.0;
    for (std::size_t f = 0; f < g.padded_size; ++f)
      if (g.face[2][f] == FaceKind::Outflow)
        out_kg_per_s += config.density_kg_per_m3 * gas.velocity()[2][f] * g.face_area_m2(2);
    EXPECT_NEAR(out_kg_per_s, set_kg_per_s, 1e-9 * 6e-5) << "t = " << gas.time_s();
    // The inlet's faces hold the speed of that mass flow over the patch's area.
    EXPECT_NEAR(gas.inlet_velocity_m_per_s(0).z, set_kg_per_s / (config.density_kg_per_m3 * area),
                1e-12);
  }
  EXPECT_EQ(steps, 80);
}

TEST(PressureDrop, AColumnAtRestHasTheHydrostaticDropBetweenItsEndFaces) {
  // Gas at rest under gravity, open on top at p = 0: p(z) = ρ g (L − z). Between the bottom
  // face and the top face the drop is ρ g L; the first cell centre alone would miss ρ g h/2.
  const GasConfig config = column(InflowSchedule{{{0.0}, {0.0}}, false});
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {0.01, 0.01, 0.05}, {true, true, false}),
                {0, 0, -kG});
  for (int k = 0; k < 20; ++k) ASSERT_FALSE(gas.advance(1e-3).has_value());
  const double rho_g = config.density_kg_per_m3 * kG;
  const PressurePlane bottom{0, 2, 0.0}, top{1, 2, 0.0};
  EXPECT_NEAR(pressure_drop_pa(gas, {"column", bottom, top}), rho_g * 0.05, 1e-9 * rho_g * 0.05);
  EXPECT_NEAR(plane_pressure_pa(gas, top), 0.0, 1e-15);
  // Planes between cell centres, one of them on a cell face.
  const PressurePlane low{-1, 2, 0.0061}, high{-1, 2, 0.035};
  EXPECT_NEAR(pressure_drop_pa(gas, {"inside", low, high}), rho_g * (0.035 - 0.0061),
              1e-9 * rho_g * 0.05);
  const GasGrid& g = gas.grid();
  EXPECT_NEAR(gas.pressure()[g.index(1, 1, 1)], rho_g * (0.05 - 0.0025), 1e-9 * rho_g * 0.05)
      << "the first cell centre sits half a cell (2.5 mm) above the bottom face";
}

TEST(InflowSchedule, BadSchedulesAndDropsAreInputErrorsNamingTheField) {
  nlohmann::json doc = nlohmann::json::parse(R"({
    "materials": [{"name": "m", "youngs_modulus_pa": 1e7, "poisson_ratio": 0.3,
                   "density_kg_per_m3": 2500}],
    "domain": {"min_m": [0, 0, 0], "max_m": [0.01, 0.01, 0.01]},
    "time": {"end_s": 0.01},
    "gas": {"cells": [4, 4, 4],
            "boundaries": [
              {"name": "in", "face": "z-", "type": "inlet", "velocity_m_per_s": [0, 0, 1],
               "schedule": {"time_s": [0, 0.2, 0.1], "speed_m_per_s": [1, 2]}},
              {"name": "in2", "face": "x-", "type": "inlet",
               "schedule": {"time_s": [0], "speed_m_per_s": [1], "mass_flow_kg_per_s": [1]}},
              {"name": "out", "face": "z+", "type": "outlet",
               "schedule": {"time_s": [0], "speed_m_per_s": [-1]}}],
            "pressure_drops": [
              {"name": "a b", "from": "nowhere", "to": {"axis": "z", "at_m": 0.0}},
              {"from": "in"}]}
  })");
  const InputErrors errors = test::scene_errors(doc);
  std::string all;
  for (const InputError& e : errors) all += e.path + " | " + e.value + " | " + e.allowed + "\n";
  for (const char* expected :
       {"/gas/boundaries/0/velocity_m_per_s |  | give velocity_m_per_s or a schedule",
        "/gas/boundaries/0/schedule/time_s/2 | 0.1 | expected times in non-decreasing order",
        "/gas/boundaries/1/schedule |  | expected one of speed_m_per_s and mass_flow_kg_per_s",
        "/gas/boundaries/2/schedule | outlet | only an inlet has a schedule",
        "/gas/boundaries/2/schedule/speed_m_per_s/0 | -1 |",
        "/gas/pressure_drops/0/name | a b | expected 1 to 64 letters",
        "/gas/pressure_drops/0/from | \"nowhere\" | expected the name of a /gas/boundaries patch "
        "(in, in2, out)",
        "/gas/pressure_drops/0/to/at_m | 0.0 | expected a number in [0.00125, 0.00875]",
        "/gas/pressure_drops/1 |  | a pressure drop needs"})
    EXPECT_NE(all.find(expected), std::string::npos) << expected << "\nin:\n" << all;
  // Equal lengths are needed once the times are in order.
  doc["gas"]["boundaries"][0]["schedule"]["time_s"] = {0, 0.1, 0.2};
  std::string second;
  for (const InputError& e : test::scene_errors(doc))
    second += e.path + " | " + e.value + " | " + e.allowed + "\n";
  EXPECT_NE(second.find("/gas/boundaries/0/schedule | 3 times, 2 values | expected as many"),
            std::string::npos)
      << second;
}

// Volume of a sphere (centre zc, radius r) between heights z0 and z1.
double slab_volume(double zc, double r, double z0, double z1) {
  const double a = std::max(z0 - zc, -r), b = std::min(z1 - zc, r);
  if (b <= a) return 0.0;
  const auto F = [r](double t) { return kPi * (r * r * t - t * t * t / 3.0); };
  return F(b) - F(a);
}

using test::koch_hill_gradient;

// A fixed bed of 1200 frozen 0.5 mm beads at random in the lower `top_m` of a 4 × 4 × 40 mm
// column on 2 mm gas cells, its inlet ramped (below).
void check_a_ramped_fixed_bed(double top_m) {
  // 1200 frozen 0.5 mm beads at random in the lower 28 mm of a 4 × 4 × 40 mm column. The inlet
  // starts from rest, reaches 0.05 m/s at 10 ms, holds it to 20 ms, ramps to 0.15 m/s by 40 ms
  // and holds. The run writes the drop between two planes inside the bed and from the inlet face
  // to the outlet face to result.json; at every gas solve they match the gas's momentum balance
  // with Koch–Hill's drag at the inlet's speed then:
  //   −dp/dz = KH(φ, U) + ρ g + (ρ/ε) dU/dt  in the bed,   ρ g + ρ dU/dt  above it.
  // (The ramp's inertia is 6 % of the slab's drop, so leaving it out would fail.)
  nlohmann::json doc = nlohmann::json::parse(R"({
    "seed": 5,
    "domain": {"min_m": [0, 0, 0], "max_m": [0.004, 0.004, 0.04], "periodic": [true, true, false],
               "wall_material": "glass"},
    "materials": [{"name": "glass", "youngs_modulus_pa": 1e6, "poisson_ratio": 0.3,
                   "density_kg_per_m3": 2500, "restitution": 0.5, "friction": 0.3,
                   "frozen": true}],
    "sources": [{"type": "random", "material": "glass", "count": 1200,
                 "region": {"min_m": [0, 0, 0], "max_m": [0.004, 0.004, 0.028]},
                 "sizes": {"distribution": "fixed", "diameter_m": 0.0005}}],
    "gravity_m_per_s2": [0, 0, -9.81],
    "gas": {"cells": [2, 2, 20], "drag": "koch_hill", "step_s": 0.002,
            "boundaries": [
              {"name": "distributor", "face": "z-", "type": "inlet",
               "schedule": {"time_s": [0, 0.01, 0.02, 0.04],
                            "speed_m_per_s": [0, 0.05, 0.05, 0.15]}},
              {"name": "top", "face": "z+", "type": "outlet", "pressure_pa": 0}],
            "pressure_drops": [
              {"name": "inside", "from": {"axis": "z", "at_m": 0.005},
               "to": {"axis": "z", "at_m": 0.021}},
              {"name": "column", "from": "distributor", "to": "top"}]},
    "time": {"end_s": 0.06},
    "output": {"timeseries_interval_s": 0.002, "h5": false}
  })");
  doc["sources"][0]["region"]["max_m"][2] = top_m;
  InputErrors errors;
  const SceneConfig scene = parse_scene(doc, ".", errors);
  ASSERT_TRUE(errors.empty()) << errors.front().path << ": " << errors.front().allowed;
  Simulation sim(scene);
  test::TempDir dir;
  RunOptions options;
  options.out_dir = dir.path();
  ASSERT_FALSE(run_simulation(sim, scene, options).failure);
  std::ifstream in(dir.path() / "result.json");
  const nlohmann::json result = nlohmann::json::parse(in);
  ASSERT_EQ(result["pressure_drops"].size(), 2u);
  EXPECT_EQ(result["pressure_drops"][1]["from"], "distributor");
  const double cfd_step_s = result["gas"]["dem_steps_per_cfd_step"]["last"].get<double>() *
                            result["time_step_s"].get<double>();

  // The bed's solid fraction in the slab between the planes, over its whole height, and in each
  // 0.5 mm layer up to 28 mm (the face-to-face drop is the drag law integrated over the layers,
  // finer than the gas cells: a random bed's layers differ, the law is convex in φ, and a bed's
  // top inside a cell is sharp here).
  const ParticleStore& p = sim.particles();
  constexpr double kLayer = 0.0005;
  double inside = 0.0, whole = 0.0;
  std::vector<double> layer_solid(56, 0.0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    inside += slab_volume(p.position_m[i].z, p.radius_m[i], 0.005, 0.021);
    whole += slab_volume(p.position_m[i].z, p.radius_m[i], 0.0, top_m);
    for (std::size_t k = 0; k < layer_solid.size(); ++k)
      layer_solid[k] +=
          slab_volume(p.position_m[i].z, p.radius_m[i], kLayer * double(k), kLayer * double(k + 1));
  }
  const double area = 0.004 * 0.004, d = 0.0005, rho = 1.2, mu = 1.8e-5;
  const double phi_inside = inside / (area * 0.016), phi_whole = whole / (area * top_m);
  const Schedule speed{{0, 0.01, 0.02, 0.04}, {0, 0.05, 0.05, 0.15}};
  const nlohmann::json& slab = result["pressure_drops"][0];
  const nlohmann::json& column = result["pressure_drops"][1];
  ASSERT_GE(slab["time_s"].size(), 31u);  // every 2 ms, and the last step
  int checked = 0;
  double worst_slab = 0.0, worst_column = 0.0;
  for (std::size_t k = 0; k < slab["time_s"].size(); ++k) {
    const double t = slab["gas_time_s"][k];
    EXPECT_NEAR(t, slab["time_s"][k].get<double>(), cfd_step_s);
    if (t < 2 * cfd_step_s) continue;  // the start from rest
    const double U = speed.at(t), rate = (U - speed.at(t - cfd_step_s)) / cfd_step_s;
    const double expected_slab =
        (koch_hill_gradient(phi_inside, U, d, rho, mu) + rho * kG + rho / (1 - phi_inside) * rate) *
        0.016;
    EXPECT_NEAR(slab["drop_pa"][k].get<double>(), expected_slab, 0.03 * expected_slab)
        << "t = " << t << ", U = " << U;
    double expected_column = rho * rate * 0.012 + rho * kG * 0.04;
    for (const double solid : layer_solid) {
      const double phi = solid / (area * kLayer);
      expected_column +=
          ((phi > 0.0 ? koch_hill_gradient(phi, U, d, rho, mu) : 0.0) + rho / (1 - phi) * rate) *
          kLayer;
    }
    // Face to face, the bed's ends included (each particle's volume goes to the cells it
    // overlaps, and it reads its DEM cell's ε and the superficial flow over it).
    EXPECT_NEAR(column["drop_pa"][k].get<double>(), expected_column, 0.03 * expected_column)
        << "t = " << t << ", U = " << U;
    worst_slab =
        std::max(worst_slab, std::abs(slab["drop_pa"][k].get<double>() / expected_slab - 1));
    worst_column =
        std::max(worst_column, std::abs(column["drop_pa"][k].get<double>() / expected_column - 1));
    ++checked;
  }
  EXPECT_GE(checked, 25);
  EXPECT_NEAR(slab["time_s"].back().get<double>(), 0.06, result["time_step_s"].get<double>());
  std::printf(
      "fixed bed to %.0f mm, solid fraction %.3f (slab) %.3f (bed), CFD step %.2g s: drop at 0.05 "
      "m/s %.3f Pa (slab), %.3f Pa (column); at 0.15 m/s %.3f, %.3f Pa; largest deviation from "
      "the momentum balance %.2f %% (slab), %.2f %% (column)\n",
      1e3 * top_m, phi_inside, phi_whole, cfd_step_s, slab["drop_pa"][8].get<double>(),
      column["drop_pa"][8].get<double>(), slab["drop_pa"].back().get<double>(),
      column["drop_pa"].back().get<double>(), 100 * worst_slab, 100 * worst_column);
}

TEST(PressureDrop, AFixedBedFollowsKochHillWhileItsInletRamps) {
  check_a_ramped_fixed_bed(0.028);  // the bed's top on a cell face
}

TEST(PressureDrop, AFixedBedWhoseTopIsInsideACellFollowsKochHillWhileItsInletRamps) {
  check_a_ramped_fixed_bed(0.027);  // the top cell half full
}

}  // namespace
}  // namespace millsim
