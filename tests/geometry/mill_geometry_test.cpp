// The mill's geometry (geometry/surface.h, geometry/mill.h) against independent expectations:
//   - every surface's gap and normal against a brute-force nearest point on a dense sampling of
//     the surface;
//   - a sphere fired at the chamber's mantle against Hertz's maximum overlap (Eq. 12) and
//     contact time, and restitution; a sphere circling inside the mantle against the static
//     Hertz overlap under the centripetal load m v² / (R − r);
//   - the gas grid's voxels against the DEM walls (one geometry), the nozzles' inflow against the
//     set flow, and the gas leaving through the outlet against what the nozzles blow in;
//   - the outlet tube's inside is the DEM outlet; bad geometry is an input error naming the key.
#include <gtest/gtest.h>

#include <fstream>

#include <cmath>
#include <numbers>
#include <random>

#include "gas/gas_grid.h"
#include "gas/gas_solver.h"
#include "geometry/mill.h"
#include "process/classification.h"
#include "process/outlet.h"
#include "scene/mill_json.h"
#include "scene/scene_json.h"
#include "sim/simulation.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using test::add_particle;
using test::table1_material;

// Brute force: the nearest of many points spread over the surface (within a bounding cylinder).
double nearest_sampled_distance(const Surface& s, const Vec3& x, Vec3& direction) {
  double best = 1e300;
  const int na = 720, nb = 400;
  auto consider = [&](const Vec3& q) {
    const double d = norm(x - q);
    if (d < best) best = d, direction = (x - q) * (1.0 / std::max(d, 1e-300));
  };
  const Vec3 e1{1, 0, 0}, e2{0, 1, 0};  // the tests use axis +z
  for (int a = 0; a < na; ++a) {
    const double phi = 2.0 * std::numbers::pi * a / na;
    const Vec3 u = e1 * std::cos(phi) + e2 * std::sin(phi);
    for (int b = 0; b <= nb; ++b) {
      const double t = double(b) / nb;
      if (s.kind == SurfaceKind::Tube)
        consider(s.point_m + u * s.radius_m +
                 s.normal * (s.axial_min_m + t * (s.axial_max_m - s.axial_min_m)));
      else  // disc
        consider(s.point_m + u * (s.inner_radius_m + t * (s.radius_m - s.inner_radius_m)) +
                 s.normal * s.axial_min_m);
    }
  }
  return best;
}

TEST(Surface, TubeAndDiscGapsAreTheDistanceToTheNearestPoint) {
  Surface tube;
  tube.kind = SurfaceKind::Tube;
  tube.point_m = {0.01, -0.02, 0.0};
  tube.normal = {0, 0, 1};
  tube.radius_m = 0.004;
  tube.axial_min_m = 0.002;
  tube.axial_max_m = 0.006;
  Surface disc = tube;
  disc.kind = SurfaceKind::Disc;
  disc.radius_m = 0.01;
  disc.inner_radius_m = 0.003;
  disc.axial_min_m = 0.004;
  disc.facing = 1.0;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-0.012, 0.012), uz(-0.002, 0.01);
  for (const Surface& s : {tube, disc})
    for (int k = 0; k < 300; ++k) {
      const Vec3 x = s.point_m + Vec3{u(rng), u(rng), uz(rng)};
      Vec3 n, expected_direction;  // the direction is checked through the foot point
      const double gap = surface_gap(s, x, n);
      const double expected = nearest_sampled_distance(s, x, expected_direction);
      // A disc over its face is one-sided: the gap carries the side.
      const double d = x.z - s.point_m.z - s.axial_min_m;
      const double rho = std::hypot(x.x - s.point_m.x, x.y - s.point_m.y);
      const bool over_face =
          s.kind == SurfaceKind::Disc && rho >= s.inner_radius_m && rho <= s.radius_m;
      EXPECT_NEAR(over_face ? std::abs(gap) : gap, expected, 2e-5) << "point " << k;
      if (over_face) {
        EXPECT_EQ(gap < 0.0, d < 0.0);
      }
      // The foot of the normal, x − gap n, lies on the surface (within the sampling spacing).
      Vec3 unused;
      EXPECT_LT(nearest_sampled_distance(s, x - n * gap, unused), 5e-5) << "point " << k;
      EXPECT_NEAR(norm(n), 1.0, 1e-12);
    }
}

TEST(Surface, CylinderInsideIsSignedRadialDistance) {
  Surface s;
  s.kind = SurfaceKind::CylinderInside;
  s.point_m = {1, 2, 3};
  s.normal = {0, 0, 1};
  s.radius_m = 0.5;
  Vec3 n;
  EXPECT_NEAR(surface_gap(s, {1.3, 2.4, 7}, n), 0.0, 1e-15);  // on the wall (0.3, 0.4 → 0.5)
  EXPECT_NEAR(n.x, -0.6, 1e-15);
  EXPECT_NEAR(n.y, -0.8, 1e-15);
  EXPECT_NEAR(surface_gap(s, {1.0, 2.1, 0}, n), 0.4, 1e-15);
  EXPECT_NEAR(surface_gap(s, {1.0, 2.7, 0}, n), -0.2, 1e-15);  // behind the wall
}

// The wall pass skips an apart candidate when surface_certainly_beyond says the gap exceeds the
// particle's radius (contact/contact_forces.cpp): that must never happen where the exact gap
// would give an overlap, r − gap > 0, however close to contact the point lies, and it must
// happen for points clearly apart (else it saves nothing). Points are drawn at gaps within
// 1e-7 relative of r on either side, and well apart, on a tilted plane, a tilted cylinder's
// inside and a disc facing either way (over its face and past its edges).
TEST(Surface, CertainlyBeyondNeverCallsApartWhatTheGapTouches) {
  const Vec3 axis = Vec3{0.3, -0.2, 0.9} * (1.0 / norm(Vec3{0.3, -0.2, 0.9}));
  Surface plane = plane_surface({0.01, 0.02, -0.03}, axis);
  Surface cylinder;
  cylinder.kind = SurfaceKind::CylinderInside;
  cylinder.point_m = {0.013, -0.007, 0.002};
  cylinder.normal = axis;
  cylinder.radius_m = 0.02;
  Surface disc = cylinder;
  disc.kind = SurfaceKind::Disc;
  disc.radius_m = 0.01, disc.inner_radius_m = 0.003, disc.axial_min_m = 0.004;
  Surface back = disc;
  back.facing = -1.0;
  const Vec3 across = Vec3{1, 0, 0} - axis * axis.x;
  const Vec3 e1 = across * (1.0 / norm(across)), e2 = cross(axis, e1);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> unit(0.0, 1.0), near(-1e-7, 1e-7);
  const double r = 25e-6;
  int said_beyond = 0, clearly_apart = 0;
  for (const Surface* s : {&plane, &cylinder, &disc, &back})
    for (int k = 0; k < 20000; ++k) {
      // The gap to aim at: at contact within 1e-7 relative, or clearly apart (2 to 10 radii).
      const bool close = k % 4 != 0;
      const double target = close ? r * (1.0 + near(rng)) : r * (2.0 + 8.0 * unit(rng));
      const double phi = 2.0 * std::numbers::pi * unit(rng);
      const Vec3 around = e1 * std::cos(phi) + e2 * std::sin(phi);
      Vec3 x;
      if (s->kind == SurfaceKind::Plane) {
        x = s->point_m + around * (0.05 * unit(rng)) + s->normal * target;
      } else if (s->kind == SurfaceKind::CylinderInside) {
        x = s->point_m + around * (s->radius_m - target) + s->normal * (0.1 * (unit(rng) - 0.5));
      } else {  // a disc: its plane at `target` on the facing side, anywhere across it
        x = s->point_m + around * (0.012 * unit(rng)) +
            s->normal * (s->axial_min_m + s->facing * target);
      }
      const bool beyond = surface_certainly_beyond(*s, x, r);
      const double overlap = r - surface_gap(*s, x);
      ASSERT_FALSE(beyond && overlap > 0.0)
          << "kind " << int(s->kind) << " point " << k << " overlap " << overlap;
      said_beyond += beyond;
      if (!close) {
        ++clearly_apart;
        EXPECT_TRUE(beyond) << "kind " << int(s->kind) << " point " << k;
      }
    }
  EXPECT_GT(said_beyond, clearly_apart) << "some of the close points are told apart too";
  Surface tube = cylinder;
  tube.kind = SurfaceKind::Tube;
  EXPECT_FALSE(surface_certainly_beyond(tube, cylinder.point_m, r)) << "a tube is always measured";
}

// A small spiral-jet-mill geometry for the tests: chamber R = 10 mm, 4 mm high.
MillConfig test_mill() {
  MillConfig m = test::small_mill_chamber();
  for (int k = 0; k < 4; ++k) {
    NozzleConfig n;
    n.name = "n";
    n.name += std::to_string(k);
    n.azimuth_rad = k * std::numbers::pi / 2.0;
    n.height_m = 0.002;
    n.diameter_m = 0.0008;
    n.angle_to_tangent_rad = 40.0 * std::numbers::pi / 180.0;
    n.speed_m_per_s = 20.0;
    m.nozzles.push_back(n);
  }
  return m;
}

SceneConfig mill_scene(const MaterialConfig& material) {
  SceneConfig s = test::empty_scene({0, 0, 0}, {0.02, 0.02, 0.004}, material);
  s.mill = test_mill();
  InputErrors errors;
  finish_mill_scene(s, errors);
  EXPECT_TRUE(errors.empty());
  return s;
}

constexpr double kPi = std::numbers::pi;
constexpr double kDiameter = 100e-6, kRadius = 0.5 * kDiameter;

double eq12_max_overlap(double m, double k, double v) {
  return std::pow(5.0 * m * v * v / (4.0 * k), 0.4);
}

TEST(MillWalls, SphereFiredAtTheMantleMatchesHertzAndRestitution) {
  // Expectation: a sphere against a flat wall of the same material, E* = E/(2(1−ν²)), R* = r:
  // the mantle's curvature changes Hertz's equivalent radius by r/(2R) = 0.25 %, within 1 %.
  for (double e : {1.0, 0.5}) {
    const MaterialConfig material = table1_material(e);
    SceneConfig s = mill_scene(material);
    const double v = 2.0, phi = 0.7;
    const Vec3 radial{std::cos(phi), std::sin(phi), 0.0};
    const Vec3 start = s.mill->axis_point_m + radial * (0.01 - 1.2 * kRadius) + Vec3{0, 0, 0.001};
    add_particle(s, start, radial * v, kDiameter);
    const double m = material.density_kg_per_m3 * std::numbers::pi / 6.0 * std::pow(kDiameter, 3);
    const double k = 4.0 / 3.0 * (1e9 / (2.0 * (1.0 - 0.09))) * std::sqrt(kRadius);
    const double expected = eq12_max_overlap(m, k, v);
    s.time.step_s = 2e-9;
    Simulation sim(s);
    double max_overlap = 0.0;
    for (int step = 0; step < 20000; ++step) {
      ASSERT_FALSE(sim.step().has_value());
      const Vec3 d = sim.particles().position_m[0] - s.mill->axis_point_m;
      max_overlap = std::max(max_overlap, std::hypot(d.x, d.y) + kRadius - 0.01);
    }
    const Vec3 w = sim.particles().motion[0].velocity_m_per_s;
    EXPECT_NEAR(dot(w, radial), -e * v, 0.02 * e * v) << "rebound at e = " << e;
    EXPECT_NEAR(norm(w - radial * dot(w, radial)), 0.0, 1e-9 * v) << "a normal impact stays normal";
    if (e == 1.0) {
      EXPECT_NEAR(max_overlap, expected, 0.01 * expected);
    }
  }
}

TEST(MillWalls, SphereCirclingInsideTheMantleCarriesTheCentripetalLoad) {
  // Frictionless, no gravity: the mantle pushes with m v² / (R − r + δ) ≈ m v²/(R − r), so the
  // static Hertz overlap is δ = (F / k)^{2/3}, k = (4/3) E* √r. Damped so the radial
  // oscillation of the start dies out.
  const MaterialConfig material = table1_material(0.3, 0.0);
  SceneConfig s = mill_scene(material);
  const double v = 5.0;
  const double m = material.density_kg_per_m3 * std::numbers::pi / 6.0 * std::pow(kDiameter, 3);
  const double k = 4.0 / 3.0 * (1e9 / (2.0 * (1.0 - 0.09))) * std::sqrt(kRadius);
  const double force = m * v * v / (0.01 - kRadius);
  const double expected = std::pow(force / k, 2.0 / 3.0);
  add_particle(s, s.mill->axis_point_m + Vec3{0.01 - kRadius + expected, 0, 0.001}, {0, v, 0},
               kDiameter);
  s.time.step_s = 5e-9;
  Simulation sim(s);
  for (int step = 0; step < 200000; ++step) ASSERT_FALSE(sim.step().has_value());
  const Vec3 d = sim.particles().position_m[0] - s.mill->axis_point_m;
  const double overlap = std::hypot(d.x, d.y) + kRadius - 0.01;
  EXPECT_NEAR(overlap, expected, 0.03 * expected);
  EXPECT_NEAR(norm(sim.particles().motion[0].velocity_m_per_s), v, 0.01 * v);
  EXPECT_GT(std::abs(std::atan2(d.y, d.x)), 0.5) << "it went round";
}

TEST(MillWalls, OutletTubeInsideIsTheOutletAndItsShellIsAWall) {
  const MillConfig mill = test_mill();
  const OutletConfig outlet = mill_outlet(mill);
  const Vec3 axis = mill.axis_point_m;
  EXPECT_TRUE(inside_mill(mill, axis + Vec3{0.004, 0, 0.002}, 1e-4));
  EXPECT_FALSE(inside_mill(mill, axis + Vec3{0.00259, 0, 0.003}, 1e-4)) << "touches the tube";
  EXPECT_FALSE(inside_mill(mill, axis + Vec3{0.00995, 0, 0.002}, 1e-4)) << "touches the mantle";
  EXPECT_TRUE(outlet_contains(outlet, axis + Vec3{0.001, 0.001, 0.003}));
  EXPECT_FALSE(outlet_contains(outlet, axis + Vec3{0.001, 0.001, 0.0024}))
      << "below the mouth (at 2.5 mm)";
  EXPECT_FALSE(outlet_contains(outlet, axis + Vec3{0.003, 0, 0.003})) << "outside the tube";
}

TEST(MillWalls, ParticlesRisingIntoTheOutletTubeAreTalliedWithTheirMass) {
  // No gas; "gravity" pointing up carries a layer of spheres under the tube's mouth into it.
  // Each that enters leaves the run and is binned into the outlet PSD: particles + outlet =
  // initial, to rounding, and the tally counts exactly those that went.
  SceneConfig s = mill_scene(table1_material(0.5, 0.3));
  s.gravity_m_per_s2 = {0, 0, 50.0};
  int placed = 0;
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j) {
      const Vec3 x = s.mill->axis_point_m + Vec3{i * 0.0005, j * 0.0005, 0.0015};
      if (std::hypot(i * 0.0005, j * 0.0005) > 0.002) continue;  // under the mouth only
      add_particle(s, x, {0, 0, 0}, kDiameter);
      ++placed;
    }
  s.time.step_s = 1e-7;
  s.time.end_s = 0.02;
  Simulation sim(s);
  const double initial = sim.mass_balance().initial_kg;
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.advance(1000).has_value());
  const MassBalance m = sim.mass_balance();
  EXPECT_EQ(sim.particles().size(), 0u) << "all rose into the tube";
  EXPECT_EQ(sim.outlet_tally().total_count(), double(placed));
  ASSERT_EQ(sim.outlet_mass_by_outlet_kg().size(), 1u);
  EXPECT_NEAR(sim.outlet_mass_by_outlet_kg()[0], initial, 1e-15 * initial);
  EXPECT_LE(std::abs(m.relative_error()), 1e-14);
}

// The inflow the fixed faces hold (face velocities u), summed from the grid itself: fixed faces
// between solid and fluid cells, signed into the fluid.
double fixed_face_inflow_m3_per_s(const GasGrid& g, const std::array<std::vector<double>, 3>& u) {
  double flow = 0.0;
  for (int a = 0; a < 3; ++a)
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      const double v = u[std::size_t(a)][f];
      if (g.face[std::size_t(a)][f] != FaceKind::Fixed || v == 0.0) continue;
      const bool into_high = g.fluid[f + g.stride[std::size_t(a)]] && !g.fluid[f];
      flow += v * (into_high ? 1.0 : -1.0) * g.face_area_m2(a);
    }
  return flow;
}

// The momentum a nozzle blows in, as the grid holds it: what its fixed faces carry (ρ A u |u|
// along each face's axis) plus the jet body force over its control volumes.
Vec3 nozzle_momentum_n(const GasGrid& g, const std::array<std::vector<double>, 3>& u,
                       double density_kg_per_m3) {
  Vec3 momentum;
  for (int a = 0; a < 3; ++a)
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      const double v = u[std::size_t(a)][f];
      if (g.face[std::size_t(a)][f] == FaceKind::Fixed && v != 0.0)
        momentum[a] += density_kg_per_m3 * g.face_area_m2(a) * v * std::abs(v);
      momentum[a] += g.jet_force_n_per_m3[std::size_t(a)][f] * g.cell_volume_m3();
    }
  return momentum;
}

TEST(MillGas, VoxelsAgreeWithTheDemWallsAndNozzlesCarryTheSetFlow) {
  SceneConfig s = mill_scene(table1_material());
  GasConfig gas;
  gas.cells = {40, 40, 8};
  InputErrors errors;
  s.gas = gas;
  s.outlets.clear();
  finish_mill_scene(s, errors);
  ASSERT_TRUE(errors.empty());
  const GasGrid g = build_gas_grid(*s.gas, s.domain.min_m, s.domain.max_m, {false, false, false});
  const double h = g.h_m.x;  // 0.5 mm
  const std::vector<NamedSurface> walls = mill_surfaces(*s.mill);
  std::size_t checked = 0;
  for (int k = 1; k <= g.n[2]; ++k)
    for (int j = 1; j <= g.n[1]; ++j)
      for (int i = 1; i <= g.n[0]; ++i) {
        const Vec3 x = g.cell_center(i, j, k);
        double nearest = 1e300;
        for (const NamedSurface& w : walls)
          nearest = std::min(nearest, std::abs(surface_gap(w.surface, x)));
        if (nearest < h) continue;  // the staircase may go either way within a cell of a wall
        const Vec3 d = x - s.mill->axis_point_m;
        const bool in_chamber = std::hypot(d.x, d.y) < s.mill->radius_m;
        EXPECT_EQ(bool(g.fluid[g.index(i, j, k)]), in_chamber)
            << "cell " << i << " " << j << " " << k;
        ++checked;
      }
  EXPECT_GT(checked, 4000u);
  double set_flow = 0.0;
  for (std::size_t n = 0; n < s.gas->jets.size(); ++n) {
    EXPECT_GT(g.jet_faces[n], 0u);
    set_flow += s.gas->jets[n].volume_flow_m3_per_s();
  }
  EXPECT_NEAR(fixed_face_inflow_m3_per_s(g, g.fixed_value), set_flow, 1e-12 * set_flow);
  // Momentum, one nozzle at a time (the four together cancel): what its faces carry in
  // (ρ A u |u| along each face's axis) plus the body force over its control volumes is exactly
  // what it blows in, ρ Q speed · direction.
  for (std::size_t n = 0; n < s.gas->jets.size(); ++n) {
    GasConfig one = *s.gas;
    one.jets = {s.gas->jets[n]};
    const GasGrid gj = build_gas_grid(one, s.domain.min_m, s.domain.max_m, {false, false, false});
    const GasJetConfig& jet = one.jets[0];
    const Vec3 set_momentum =
        jet.direction * (one.density_kg_per_m3 * jet.volume_flow_m3_per_s() * jet.speed_m_per_s);
    const Vec3 grid_momentum = nozzle_momentum_n(gj, gj.fixed_value, one.density_kg_per_m3);
    EXPECT_LT(norm(grid_momentum - set_momentum), 1e-12 * norm(set_momentum)) << "nozzle " << n;
  }
  EXPECT_NEAR(set_flow, 4 * std::numbers::pi * 0.0004 * 0.0004 * 20.0, 1e-15);
}

TEST(MillGas, WhatTheNozzlesBlowInLeavesThroughTheOutletAndTheGasTurns) {
  // Continuity on the real solve: after some steps the outlet's outflow equals the nozzles' set
  // flows (to the pressure tolerance), and the jets, all turning counter-clockwise, spin the gas
  // that way at every radius.
  SceneConfig s = mill_scene(table1_material());
  GasConfig gas;
  gas.cells = {20, 20, 4};
  gas.advection = AdvectionScheme::Tvd;
  gas.pressure_tolerance = 1e-10;
  s.gas = gas;
  s.outlets.clear();
  InputErrors errors;
  finish_mill_scene(s, errors);
  ASSERT_TRUE(errors.empty());
  GasSolver solver(*s.gas,
                   build_gas_grid(*s.gas, s.domain.min_m, s.domain.max_m, {false, false, false}),
                   {0, 0, 0});
  for (int step = 0; step < 400; ++step)
    ASSERT_FALSE(solver.advance(solver.stable_step_s()).has_value());
  const GasGrid& g = solver.grid();
  double outflow = 0.0, set_flow = 0.0;
  for (std::size_t f = 0; f < g.padded_size; ++f)
    if (g.face[2][f] == FaceKind::Outflow) outflow += solver.velocity()[2][f] * g.face_area_m2(2);
  for (const GasJetConfig& jet : s.gas->jets) set_flow += jet.volume_flow_m3_per_s();
  EXPECT_NEAR(outflow, set_flow, 1e-6 * set_flow);
  for (double r : {0.004, 0.006, 0.008}) {
    const VortexSample v = sample_vortex(solver, *s.mill, r, 0.0, 0.0025);
    EXPECT_GT(v.tangential_m_per_s, 0.0) << "r = " << r;
    EXPECT_LT(v.radial_m_per_s, 0.0) << "r = " << r << ": the gas drains inwards to the outlet";
  }
}

// A mill with an inlet patch of its own (issue 34, item 6): its gas leaves through the vortex
// finder, which the mill adds as the gas's outlet, so the scene is accepted, and the outlet
// carries what the nozzles and the inlet blow in. Gas blown in with no way out is still refused.
TEST(MillGas, AnInletPatchIsAcceptedAndLeavesThroughTheVortexFinder) {
  MILLSIM_RELEASE_ONLY("MillGas.WhatTheNozzlesBlowInLeavesThroughTheOutletAndTheGasTurns");
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/spiral_jet_mill.json");
  nlohmann::json doc = nlohmann::json::parse(in);
  doc["gas"]["boundaries"] = {{{"name", "floor_air"},
                               {"face", "z-"},
                               {"type", "inlet"},
                               {"velocity_m_per_s", {0.0, 0.0, 0.5}}}};
  const InputErrors errors = test::scene_errors(doc);
  ASSERT_TRUE(errors.empty()) << errors[0].path << ": " << errors[0].allowed;
  InputErrors none;
  SceneConfig s = parse_scene(doc, MILLSIM_SOURCE_DIR "/cases", none);
  s.gas->pressure_tolerance = 1e-10;
  GasSolver solver(*s.gas,
                   build_gas_grid(*s.gas, s.domain.min_m, s.domain.max_m, {false, false, false}),
                   {0, 0, 0});
  const GasGrid& g = solver.grid();
  ASSERT_GT(g.patch_faces[0], 0u) << "the inlet covers the chamber's floor";
  for (int step = 0; step < 200; ++step)
    ASSERT_FALSE(solver.advance(solver.stable_step_s()).has_value());
  double outflow = 0.0, set_flow = 0.5 * g.patch_area_m2[0];
  for (std::size_t f = 0; f < g.padded_size; ++f)
    if (g.face[2][f] == FaceKind::Outflow) outflow += solver.velocity()[2][f] * g.face_area_m2(2);
  for (const GasJetConfig& jet : s.gas->jets) set_flow += jet.volume_flow_m3_per_s();
  EXPECT_NEAR(outflow, set_flow, 1e-6 * set_flow);

  // The fluidized bed with its outlet taken away: an inlet and nowhere to go.
  std::ifstream bed_in(MILLSIM_SOURCE_DIR "/cases/fluidized_bed.json");
  nlohmann::json bed = nlohmann::json::parse(bed_in);
  bed["gas"]["boundaries"].erase(1);
  std::string all;
  for (const InputError& e : test::scene_errors(bed)) all += e.path + ": " + e.allowed + "\n";
  EXPECT_NE(all.find("no boundary is an outlet"), std::string::npos) << all;
}

TEST(MillGas, AScheduledNozzleBlowsTheFlowAndMomentumOfItsSpeedThen) {
  // A start-up: every nozzle ramps from 0 to 20 m/s over 1 ms. At each step the faces carry
  // π r² · speed(t), and the outlet lets it out; one nozzle's faces with its body force carry
  // the momentum ρ Q(t) speed(t) along the jet (the balance of a fixed speed, at every speed).
  SceneConfig s = test::empty_scene({0, 0, 0}, {0.02, 0.02, 0.004}, table1_material());
  s.mill = test_mill();
  const Schedule ramp{{0.0, 1e-3}, {0.0, 20.0}};
  for (NozzleConfig& n : s.mill->nozzles) n.schedule = InflowSchedule{ramp, false};
  GasConfig gas;
  gas.cells = {20, 20, 4};
  gas.pressure_tolerance = 1e-10;
  s.gas = gas;
  s.outlets.clear();
  InputErrors errors;
  finish_mill_scene(s, errors);
  ASSERT_TRUE(errors.empty());
  const double rho = s.gas->density_kg_per_m3, full_flow = 4 * kPi * 0.0004 * 0.0004 * 20.0;
  GasSolver solver(*s.gas,
                   build_gas_grid(*s.gas, s.domain.min_m, s.domain.max_m, {false, false, false}),
                   {0, 0, 0});
  const GasGrid& g = solver.grid();
  int checked = 0;
  while (solver.time_s() < 1.5e-3) {
    ASSERT_FALSE(solver.advance(std::min(solver.stable_step_s(), 1e-4)).has_value());
    const double speed = ramp.at(solver.time_s());
    double outflow = 0.0, set_flow = 0.0;
    for (std::size_t k = 0; k < s.gas->jets.size(); ++k) {
      const GasJetConfig& jet = s.gas->jets[k];
      set_flow += kPi * jet.radius_m * jet.radius_m * speed;
      EXPECT_NEAR(solver.jet_speed_m_per_s(k), speed, 1e-12);
    }
    for (std::size_t f = 0; f < g.padded_size; ++f)
      if (g.face[2][f] == FaceKind::Outflow) outflow += solver.velocity()[2][f] * g.face_area_m2(2);
    const double face_flow = fixed_face_inflow_m3_per_s(g, solver.velocity());
    EXPECT_NEAR(face_flow, set_flow, 1e-12 * full_flow) << "t = " << solver.time_s();
    EXPECT_NEAR(outflow, set_flow, 1e-6 * full_flow) << "t = " << solver.time_s();
    ++checked;
  }
  EXPECT_GE(checked, 15);

  GasConfig one = *s.gas;
  one.jets = {s.gas->jets[0]};
  GasSolver single(one, build_gas_grid(one, s.domain.min_m, s.domain.max_m, {false, false, false}),
                   {0, 0, 0});
  const GasGrid& gj = single.grid();
  const GasJetConfig& jet = one.jets[0];
  for (double t : {0.0, 2.5e-4, 7.5e-4, 2e-3, 1e-4}) {  // down again at the end
    single.apply_inflow_schedules(t);
    const double speed = ramp.at(t), flow = kPi * jet.radius_m * jet.radius_m * speed;
    const Vec3 set_momentum = jet.direction * (rho * flow * speed);
    const Vec3 grid_momentum = nozzle_momentum_n(gj, single.velocity(), rho);
    EXPECT_LT(norm(grid_momentum - set_momentum), 1e-12 * rho * flow * 20.0 + 1e-30) << "t = " << t;
    EXPECT_NEAR(gj.jet_flow_m3_per_s[0], flow, 1e-15);
  }
}

TEST(Classification, CutSizesFromTheForceBalanceAndFromAGradeCurve) {
  // x_c = √(18 μ |u_r| r / (Δρ u_t²)): 18 · 1.8e-5 · 2 · 0.005 / (2000 · 100) = 1.62e-11.
  VortexSample v;
  v.radius_m = 0.005, v.tangential_m_per_s = 10.0, v.radial_m_per_s = -2.0;
  EXPECT_NEAR(force_balance_cut_size_m(1.8e-5, 2001.2, 1.2, v), std::sqrt(1.62e-11), 1e-18);
  // A grade curve 1, 0.8, 0.2, 0 over classes [0.7, 1.4, 2.8, 5.6, 11.2] µm: the share falls
  // through 1/2 half-way (in log size) between the centres √(1.4 · 2.8) and √(2.8 · 5.6) µm,
  // that is at 2.8 µm.
  PsdTally out({0.7e-6, 1.4e-6, 2.8e-6, 5.6e-6, 11.2e-6}), kept(out.edges_m);
  const double centres[4] = {1e-6, 2e-6, 4e-6, 8e-6}, share[4] = {1.0, 0.8, 0.2, 0.0};
  for (int k = 0; k < 4; ++k) {
    out.add(centres[k], share[k]);
    kept.add(centres[k], 1.0 - share[k]);
  }
  const GradeEfficiency g = grade_efficiency(out, kept);
  ASSERT_TRUE(g.cut_size_m.has_value());
  EXPECT_NEAR(*g.cut_size_m, 2.8e-6, 1e-9 * 2.8e-6);
  // A fifth of those shares (most fines still in transit): no size reaches 1/2, and the reduced
  // curve T / T_max falls through 1/2 at the same 2.8 µm.
  PsdTally out5(out.edges_m), kept5(out.edges_m);
  for (int k = 0; k < 4; ++k) {
    out5.add(centres[k], 0.2 * share[k]);
    kept5.add(centres[k], 1.0 - 0.2 * share[k]);
  }
  const GradeEfficiency g5 = grade_efficiency(out5, kept5);
  EXPECT_FALSE(g5.cut_size_m.has_value());
  EXPECT_NEAR(g5.max_share, 0.2, 1e-12);
  ASSERT_TRUE(g5.reduced_cut_size_m.has_value());
  EXPECT_NEAR(*g5.reduced_cut_size_m, 2.8e-6, 1e-9 * 2.8e-6);
}

TEST(Classification, TheVortexExponentOfAPowerLawVortexIsItsPower) {
  // u_t = C r^−n sampled at nine radii: the fit returns n for a free-type vortex, −1 for solid-
  // body rotation, and nothing from one point.
  for (double n : {0.6, 1.0, -1.0}) {
    std::vector<VortexSample> samples;
    for (int k = 0; k <= 8; ++k) {
      VortexSample v;
      v.radius_m = 0.005 + 0.0015 * k;
      v.tangential_m_per_s = 40.0 * std::pow(v.radius_m / 0.005, -n);
      samples.push_back(v);
    }
    const VortexExponent e = vortex_exponent(samples, 0, samples.size() - 1);
    EXPECT_NEAR(e.n, n, 1e-12);
    EXPECT_EQ(e.points, 9u);
    EXPECT_DOUBLE_EQ(e.from_radius_m, 0.005);
    EXPECT_DOUBLE_EQ(e.to_radius_m, 0.017);
    EXPECT_EQ(vortex_exponent(samples, 8, 8).points, 1u);
    EXPECT_EQ(vortex_exponent(samples, 8, 8).n, 0.0);
  }
  // A sample with no tangential flow is left out, not taken as log 0.
  std::vector<VortexSample> samples(3);
  for (int k = 0; k < 3; ++k) samples[k].radius_m = 0.01 * (k + 1);
  samples[0].tangential_m_per_s = 0.0;
  samples[1].tangential_m_per_s = 10.0;
  samples[2].tangential_m_per_s = 10.0 * std::pow(1.5, -0.5);
  EXPECT_NEAR(vortex_exponent(samples, 0, 2).n, 0.5, 1e-12);
  EXPECT_EQ(vortex_exponent(samples, 0, 2).points, 2u);
}

TEST(MillScene, InconsistentGeometryIsAnInputErrorNamingTheKey) {
  nlohmann::json doc = {
      {"domain", {{"min_m", {0, 0, 0}}, {"max_m", {0.02, 0.02, 0.004}}}},
      {"materials",
       {{{"name", "m"},
         {"youngs_modulus_pa", 1e9},
         {"poisson_ratio", 0.3},
         {"density_kg_per_m3", 2000}}}},
      {"time", {{"end_s", 1e-3}}},
      {"mill",
       {{"radius_m", 0.011},
        {"outlet", {{"radius_m", 0.012}, {"depth_m", 0.005}}},
        {"nozzles",
         {{{"count", 2}, {"height_m", 0.0039}, {"diameter_m", 0.001}, {"speed_m_per_s", 50}}}}}},
      {"feeds",
       {{{"material", "m"},
         {"mass_rate_kg_per_s", 1e-3},
         {"region", {{"min_m", {0.0, 0.0, 0.001}}, {"max_m", {0.002, 0.002, 0.002}}}},
         {"sizes", {{"distribution", "fixed"}, {"diameter_m", 1e-4}}}}}}};
  std::string all;
  for (const InputError& e : test::scene_errors(doc)) all += e.path + ": " + e.allowed + "\n";
  for (const char* key : {"/mill/radius_m", "/mill/outlet/radius_m", "/mill/outlet/depth_m",
                          "/mill/nozzles/0/height_m", "/feeds/0/region"})
    EXPECT_NE(all.find(key), std::string::npos) << key << " not reported in:\n" << all;
}

}  // namespace
}  // namespace millsim
